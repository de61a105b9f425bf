"""Packaged advice files (:mod:`impactbench.advice_files`): one per engine and customary step,
each a complete answer (model, params in the engine's own keys, snippet, per-speed claims,
provenance), round-tripping through :func:`write` and :func:`as_advice`; and the advisor's
text for an engine with nothing plausible at the step."""

from __future__ import annotations

import math

import pytest
from impactbench.engines.advice_models import ENGINES, advice_steps_s

from impactbench.advice_files import (
    ADVICE_DIR,
    advice_path,
    as_advice,
    load,
    packaged,
    packaged_advice,
    step_label,
    write,
)
from impactbench.advise import Advice
from impactbench.commands.advise import text


def test_step_labels() -> None:
    assert step_label(1 / 240) == "1_240s"
    assert step_label(2e-3) == "2ms"
    assert step_label(1e-2) == "10ms"
    assert step_label(1 / 1200) == "1_1200s"
    assert step_label(1e-5) == "1e-05s"


@pytest.mark.parametrize("engine", ENGINES)
def test_every_customary_step_has_its_advice(engine: str) -> None:
    for dt in advice_steps_s(engine):
        data = packaged(engine, dt)
        assert data is not None, advice_path(engine, dt)
        assert data["engine"] == engine and math.isclose(data["timestep_s"], dt)
        assert data["provenance"]["phases"] == [k / 8 for k in range(8)]
        assert data["provenance"]["stop"] == "searched"  # not cut by the time cap
        assert len(data["per_speed"]) == 6
        for row in data["per_speed"]:
            if data["plausible"]:  # the claim: ok at every phase, no energy created
                assert row["status"] == "ok"
                assert row["restitution_max"] <= 1.0
                assert row["restitution_min"] <= row["restitution"] <= row["restitution_max"]


def test_write_and_read_back(tmp_path) -> None:
    a = Advice("pymunk", 1 / 60, "elasticity", {"elasticity": 0.8}, "ball_shape.elasticity = 0.8",
               True, 0.128, [{"velocity_m_s": 1.0, "reference_restitution": 0.94,
                              "restitution": 0.8, "restitution_min": 0.8,
                              "restitution_max": 0.8, "worst_error": 0.147,
                              "phases_measured": 8, "step_overlap_ratio": 0.1,
                              "sinking_ratio": math.nan, "status": "ok"}],
               phases=(0.0, 0.5), engine_version="7.3.1", target="hunt-crossley",
               searched_on="pymunk", note="rigid")
    path = write(a, tmp_path / "x.toml")
    back = as_advice(load(path))
    assert back.params == a.params and back.snippet == a.snippet and back.note == "rigid"
    assert back.phases == a.phases and back.plausible
    assert math.isnan(back.per_speed[0]["sinking_ratio"])  # NaN survives as "nan"
    (tmp_path / "bad.toml").write_text("engine = 'x'\n")
    with pytest.raises(ValueError, match="missing 'timestep_s'"):
        load(tmp_path / "bad.toml")
    with pytest.raises(ValueError, match="no packaged advice for pymunk"):
        packaged_advice("pymunk", 0.123)
    assert ADVICE_DIR.is_dir()


def test_text_says_what_to_do_when_nothing_is_plausible() -> None:
    a = Advice("newton", 1 / 1200, "ke+kd", {"ke": 1e6, "kd": 10.0}, "cfg = ...", False,
               0.3, [], phases=tuple(k / 8 for k in range(8)), engine_version="1.8.0",
               searched_on="newton",
               fallback={"timestep_s": 1 / 2400, "worst_error": 0.336, "model": "ke+kd",
                         "accept": 0.328})
    out = text(a)
    assert "No setting is plausible at every speed and phase" in out
    assert "Run at dt <= 0.0004167 s (ke+kd: plausible, worst error 33.6 %)" in out
    assert "accept a worst error of 32.8 %" in out
