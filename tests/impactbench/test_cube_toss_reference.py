"""The cube tosses replayed in impactbench's reference box model
(impactbench.cube_tosses.reference_model): the replay's shape, the packaged fit, convergence of
the integration, the fit's reproducibility and its file."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from impactbench.reference import box_contact as bc

from impactbench.cube_tosses import data, protocol
from impactbench.cube_tosses import reference_model as rm
from impactbench.cube_tosses.selection import RESULT_KEYS
from impactbench.cube_tosses.tune import ids_hash


@pytest.fixture(scope="module")
def df():
    return data.load()


@pytest.fixture(scope="module")
def test_ids(df):
    return data.split(data.toss_ids(df), "test")


def test_replay_of_test_tosses_has_the_engines_shape(df, test_ids) -> None:
    out = rm.replay_reference(test_ids[:4], df=df)
    assert tuple(out) == RESULT_KEYS
    assert out["status"] == "ok" and out["engine"] == "reference" and out["mode"] == "fitted"
    assert out["tosses"] == 4 and out["failed"] == [] and out["split"] == "ids"
    assert [r["toss"] for r in out["per_toss"]] == test_ids[:4]
    pos = np.array([r["position_error"] for r in out["per_toss"]])
    rot = np.array([r["rotation_error_deg"] for r in out["per_toss"]])
    # measured: position 0.26, 0.26, 0.19, 0.25 widths; rotation 11°, 6°, 71°, 61°
    assert np.all(np.isfinite(pos)) and np.all((pos > 0.06) & (pos < 0.8))
    assert np.all(np.isfinite(rot)) and np.all((rot > 2.0) & (rot < 180.0))
    assert out["position_error_median"] == pytest.approx(np.median(pos))
    assert out["engine_setup"]["integrator"]["method"] == bc.METHOD
    assert out["engine_setup"]["params"] == rm.load_fitted().describe()


def test_simulate_returns_the_reference_shapes(df, test_ids) -> None:
    start = protocol.prepare(data.toss(df, test_ids[0]))
    p, q = rm.simulate(start)
    assert p.shape == start.p_ref.shape and q.shape == start.q_ref.shape
    assert np.allclose(p[0], start.p) and np.allclose(q[0], start.q)
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    with pytest.raises(ValueError, match=r"^protocol.half_width_m = 0.0524: must equal "
                                         r"box.half_width_m = 0.05$"):
        rm.simulate(start, box=bc.Box(half_width_m=0.05), protocol=protocol.Protocol())


def test_packaged_fit_beats_its_initial_guess(df) -> None:
    """The packaged parameters load and, on a fixed subset of the training tosses (the first
    eight the fit used), score better than the fit's start."""
    fitted = rm.load_fitted()
    assert isinstance(fitted, bc.BoxContactParams) and fitted.law == "hunt-crossley"
    ids = rm.fit_ids(df)[:8]
    good = rm.replay_reference(ids, fitted, df=df)
    start = rm.replay_reference(ids, rm.start_params(), df=df)
    # measured: mean 0.148 (fitted) against 0.286 (start) widths; every toss better
    assert good["position_error_mean"] < 0.75 * start["position_error_mean"]
    assert good["position_error_mean"] < 0.2
    better = [a["position_error"] < b["position_error"]
              for a, b in zip(good["per_toss"], start["per_toss"], strict=True)]
    assert sum(better) >= 7


def test_trajectory_is_converged_in_the_tolerances(df, test_ids) -> None:
    """Halving rtol and atol changes each toss's errors far less than the model-vs-data
    error (the integration is not part of the error)."""
    fitted = rm.load_fitted()
    for toss in data.tosses(df, test_ids[:3]):
        start = protocol.prepare(toss)
        a = protocol.toss_errors(start, *rm.simulate(start, fitted))
        b = protocol.toss_errors(start, *rm.simulate(start, fitted, rtol=bc.RTOL / 2,
                                                      atol=bc.ATOL / 2))
        # measured: ≤ 1.2e-6 widths and ≤ 4.3e-4° against errors ≥ 0.18 widths and ≥ 6°
        assert abs(a["position_error"] - b["position_error"]) < 4e-6
        assert abs(a["rotation_error_deg"] - b["rotation_error_deg"]) < 1.5e-3
        assert a["position_error"] > 1e4 * abs(a["position_error"] - b["position_error"])


def test_packaged_file_records_its_provenance(df) -> None:
    doc = tomllib.loads(rm.FITTED_PATH.read_text())
    prov = doc["provenance"]
    assert prov["optimizer"] == "CMA" and prov["seed"] == 0 and prov["budget"] >= 100
    assert prov["train_ids_hash"] == ids_hash(rm.fit_ids(df, "train", prov["stride"]))
    assert prov["fit_tosses"] == len(rm.fit_ids(df, "train", prov["stride"]))
    assert prov["integrator"]["rtol"] == bc.RTOL and prov["integrator"]["method"] == bc.METHOD
    assert prov["scipy_version"] and math.isfinite(prov["loss"])
    assert prov["loss"] < prov["loss_start"]
    assert prov["command"].startswith("python -m impactbench.cube_tosses.reference_model --fit "
                                      f"--budget {prov['budget']} --seed 0 --stride "
                                      f"{prov['stride']}")
    knobs = rm.knobs_of(rm.load_fitted())
    assert knobs == pytest.approx(doc["knobs"], rel=1e-12)
    assert doc["scored"]["fitted"]["test"]["tosses"] == 89


def test_tiny_fit_is_reproducible_and_written(df, tmp_path) -> None:
    ids = rm.fit_ids(df)[:2]
    kw = {"tosses": ids, "stride": 1, "seed": 3, "score": False, "df": df}
    a = rm.fit(3, **kw)
    b = rm.fit(3, **kw)
    assert a.knobs == b.knobs and a.objective == b.objective and a.evaluations == 3
    assert a.objective <= a.objective_start
    path = rm.write_fitted(a, tmp_path / "ref.toml")
    assert rm.load_fitted(path) == a.params
    assert "--budget 3 --seed 3 --stride 1" in tomllib.loads(path.read_text())[
        "provenance"]["command"]


def test_fit_and_load_refuse_bad_inputs(df, test_ids, tmp_path) -> None:
    with pytest.raises(ValueError, match=rf"^tosses: toss {test_ids[0]} is in the test split"):
        rm.fit(2, tosses=[test_ids[0]], df=df)
    with pytest.raises(ValueError, match=r"^budget = 1: must be an integer >= 2$"):
        rm.fit(1, df=df)
    with pytest.raises(ValueError, match=r"^workers = 0: must be an integer >= 1$"):
        rm.replay_reference(test_ids[:1], workers=0, df=df)
    with pytest.raises(ValueError, match="no fitted reference-model file"):
        rm.load_fitted(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text('[parameters]\nlaw = "hunt-crossley"\nstiffnes = 1.0\n')
    with pytest.raises(ValueError, match=r"\[parameters\] 'stiffnes' is not one of"):
        rm.load_fitted(bad)
    bad.write_text('[parameters]\nlaw = "hunt-crossley"\nfriction = -1.0\n')
    with pytest.raises(ValueError, match=r"^friction = -1.0: must be >= 0 and finite$"):
        rm.load_fitted(bad)
