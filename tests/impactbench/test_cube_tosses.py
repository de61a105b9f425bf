"""The cube tosses (impactbench.cube_tosses): loader, split, DAIR's protocol, engine replays.

The engine tests replay five tosses (0, 1, 51, 57, 100: 51 starts too early for a refit) with
DAIR's published parameters and compare each toss's time-mean errors with values measured on
this machine kind (mujoco 4.0.0, pybullet 3.2.7, drake 1.51.1; 2026-11-24). The engines are
deterministic: three runs in separate processes gave bit-identical errors (spread 0), so the
tolerance is a tight relative 1e-6 (room for a different CPU's rounding, nothing more).
The full 456-toss reproduction (PyBullet 0.119, MuJoCo 0.248 / 0.224 ×3, Drake SAP 0.103,
TAMSI 0.158 median width fraction) takes a few minutes and is not run here.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import pandas as pd
import pytest

from impactbench.cube_tosses import Protocol, load, replay, split
from impactbench.cube_tosses.data import COLUMNS, in_test_set, toss, toss_ids
from impactbench.cube_tosses.protocol import prepare, refit_velocity, rotation_angle
from impactbench.cube_tosses.selection import RESULT_KEYS

H = 0.0524
DT = 1.0 / 148.0
IDS = [0, 1, 51, 57, 100]
RTOL = 1e-6


@pytest.fixture(scope="module")
def df() -> pd.DataFrame:
    return load()


def _write(tmp_path, frame: pd.DataFrame, name: str = "mine.csv"):
    path = tmp_path / name
    frame.to_csv(path, index=False)
    return path


def _one_line_error(path, *needles: str) -> str:
    with pytest.raises(ValueError) as info:
        load(path)
    msg = str(info.value)
    assert "\n" not in msg
    for needle in needles:
        assert needle in msg, msg
    return msg


# ------------------------------------------------------------------------------ the data


def test_packaged_data_loads(df: pd.DataFrame) -> None:
    assert tuple(df.columns) == COLUMNS
    assert len(df) == 48085
    ids = toss_ids(df)
    assert len(ids) == 456 and ids[0] == 0 and ids[-1] == 569


def test_a_users_csv_of_the_same_columns_loads(df: pd.DataFrame, tmp_path) -> None:
    mine = df[df["toss"].isin([0, 1])]
    got = load(_write(tmp_path, mine.sample(frac=1.0, random_state=0)))  # any row order
    assert toss_ids(got) == [0, 1]
    assert np.array_equal(got["z_m"].to_numpy(), mine["z_m"].to_numpy())


def test_a_file_rewritten_is_read_again_and_each_load_is_its_own(df: pd.DataFrame,
                                                                 tmp_path) -> None:
    """load keeps what it read per file (data.LOADED_FILES): a changed file is read again,
    and a caller's change to its frame never reaches the next caller."""
    path = _write(tmp_path, df[df["toss"] == 0])
    first = load(path)
    first.loc[0, "z_m"] = -1.0
    assert load(path)["z_m"].iloc[0] == df[df["toss"] == 0]["z_m"].iloc[0]
    _write(tmp_path, df[df["toss"].isin([0, 1])])
    assert toss_ids(load(path)) == [0, 1]


def test_missing_column(df: pd.DataFrame, tmp_path) -> None:
    path = _write(tmp_path, df[df["toss"] == 0].drop(columns=["qz"]))
    _one_line_error(path, "'qz'", "missing")


def test_non_unit_quaternion(df: pd.DataFrame, tmp_path) -> None:
    bad = df[df["toss"] == 0].copy()
    bad.loc[bad.index[5], "qw"] += 0.01
    _one_line_error(_write(tmp_path, bad), "qw, qx, qy, qz", "toss 0", "sample 5", "|q| =",
                    "must be 1 within 0.001")


def test_non_monotonic_time(df: pd.DataFrame, tmp_path) -> None:
    bad = df[df["toss"] == 0].copy()
    bad.loc[bad.index[7], "t_s"] = bad["t_s"].iloc[6]
    _one_line_error(_write(tmp_path, bad), "'t_s'", "toss 0", "sample 7",
                    "time must increase")


def test_too_few_samples(df: pd.DataFrame, tmp_path) -> None:
    short = df[(df["toss"] == 0) & (df["sample"] < 6)]
    _one_line_error(_write(tmp_path, short), "toss 0", "6 samples", "at least 10")


def test_non_numeric_value_and_missing_file(df: pd.DataFrame, tmp_path) -> None:
    bad = df[df["toss"] == 0].astype({"x_m": object})
    bad.loc[bad.index[3], "x_m"] = "oops"
    _one_line_error(_write(tmp_path, bad), "'x_m'", "toss 0", "'oops'", "finite number")
    _one_line_error(tmp_path / "none.csv", "no such file")


def test_split_is_deterministic_disjoint_and_80_20(df: pd.DataFrame) -> None:
    ids = toss_ids(df)
    train, test = split(ids, "train"), split(ids, "test")
    assert not set(train) & set(test)
    assert sorted(train + test) == ids == split(ids, "all")
    assert (len(train), len(test)) == (367, 89)
    # by the id alone: the same for a shuffled subset, and fixed values
    sub = list(reversed(ids[::3]))
    assert split(sub, "test") == [i for i in test if i in set(sub)]
    assert test[:5] == [0, 7, 9, 10, 19]
    assert [in_test_set(i) for i in (0, 1, 7)] == [True, False, True]
    with pytest.raises(ValueError, match="split = 'dev': must be one of train, test, all"):
        split(ids, "dev")


# ------------------------------------------------------------------------------ the protocol


def test_start_and_refit_on_toss_0_by_hand(df: pd.DataFrame) -> None:
    """Toss 0: z first ≤ h√3 = 0.09076 m at sample 12 (0.08984 m; sample 11: 0.09526), so the
    replay starts at sample 9 and refits from samples 0–8 (DAIR's formulas, written out)."""
    rows = df[df["toss"] == 0]
    z = rows["z_m"].to_numpy()
    assert z[11] > H * math.sqrt(3) >= z[12]
    start = prepare(toss(df, 0))
    assert (start.index, start.refit) == (9, True)

    tau = np.arange(9) * DT
    x, y = rows["x_m"].to_numpy()[:9], rows["y_m"].to_numpy()[:9]
    # z + g τ²/2 = a + b τ by the normal equations; v_z at the last preceding sample (τ = 8 dt)
    s0, s1, s2 = 9.0, tau.sum(), (tau ** 2).sum()
    w = z[:9] + 0.5 * 9.81 * tau ** 2
    b = (s0 * (tau * w).sum() - s1 * w.sum()) / (s0 * s2 - s1 ** 2)
    v_hand = [(x[8] - x[0]) / (8 * DT), (y[8] - y[0]) / (8 * DT), b - 9.81 * 8 * DT]
    assert start.v == pytest.approx(v_hand, rel=1e-9)
    assert start.v == pytest.approx([-1.038860145366969, -0.8454327128813823,
                                     -0.5770982629559709], rel=1e-12)

    from scipy.spatial.transform import Rotation

    def rot(i: int) -> Rotation:
        qw, qx, qy, qz = rows[["qw", "qx", "qy", "qz"]].to_numpy()[i]
        return Rotation.from_quat([qx, qy, qz, qw])

    w_hand = (rot(0).inv() * rot(9)).as_rotvec() / (9 * DT)
    assert start.w_body == pytest.approx(w_hand, rel=1e-9)
    assert start.w_body == pytest.approx([-3.4066180830921815, -0.7847736224736954,
                                          3.888233283116822], rel=1e-12)
    # the reference is samples 9 … end, reached every 10 engine steps of 1/1480 s
    assert start.record_steps[:3].tolist() == [0, 10, 20]
    assert len(start.t_ref) == len(rows) - 9
    assert start.step_s == pytest.approx(DT / 10, rel=1e-15)


def test_no_refit_when_fewer_than_4_samples_precede(df: pd.DataFrame) -> None:
    """Toss 51 drops below h√3 at sample 6: it starts at sample 3 with its recorded state."""
    t51 = toss(df, 51)
    start = prepare(t51)
    assert (start.index, start.refit) == (3, False)
    assert np.array_equal(start.v, t51.v[3]) and np.array_equal(start.w_body, t51.w_body[3])


def test_protocol_options_and_variant_fit(df: pd.DataFrame) -> None:
    t0 = toss(df, 0)
    first = prepare(t0, Protocol(start_rule="first"))
    assert (first.index, first.refit) == (0, False)
    # least-squares lines, evaluated at the start sample: v_z one sample (g·dt) further on
    v_ls, _ = refit_velocity(t0.t, t0.p, t0.q, 9, Protocol(velocity_fit="lstsq"))
    v_dair = prepare(t0).v
    assert v_ls[2] - v_dair[2] == pytest.approx(-9.81 * DT, rel=1e-7)  # t_s: 1e-10 s steps
    assert Protocol().describe()["name"] == "dair2022"
    assert Protocol(substeps=100).describe()["name"] == "custom"
    with pytest.raises(ValueError, match="start_rule = 'late': must be one of drop, first"):
        Protocol(start_rule="late")
    with pytest.raises(ValueError, match=r"sample interval .* expects sample_dt_s"):
        prepare(t0, Protocol(sample_dt_s=0.01))


def test_rotation_angle() -> None:
    q = np.array([1.0, 0.0, 0.0, 0.0])
    half = math.radians(30.0)
    r = np.array([math.cos(half), 0.0, 0.0, math.sin(half)])
    assert rotation_angle(q, r) == pytest.approx(math.radians(60.0))
    assert rotation_angle(r, -r) == pytest.approx(0.0, abs=1e-7)  # q and −q: one rotation


# ------------------------------------------------------------------------------ replays

MEASURED = {  # per toss of IDS: (position error / width, rotation error in degrees), time means
    ("pybullet", "dair2022", None): [
        (0.20323784488506144, 9.222441134408225),
        (0.18836305501827996, 4.854699126635098),
        (0.4540246155139429, 61.63328461143051),
        (0.0901908630133728, 3.007789092524756),
        (0.19327665807691347, 65.09320044618364)],
    ("mujoco", "dair2022", None): [
        (0.5028498371618939, 4.561660164372459),
        (0.14180000414247998, 12.5571077758605),
        (0.3655073031082776, 59.446779220387555),
        (0.21865683007508177, 12.822619868386106),
        (0.42548813917480255, 64.23876632678933)],
    ("mujoco", "dair2022x3", None): [
        (0.2386314271524268, 10.870406243110715),
        (0.1175972522576254, 12.272752850471159),
        (0.4302013124163892, 59.85920156572726),
        (0.23358699122652213, 9.557020291264964),
        (0.1949169431430614, 65.81986818584069)],
    ("drake", "dair2022", None): [   # tamsi, as the Drake of 2022
        (0.753057059703808, 110.76753522721145),
        (0.14097620546899314, 7.202853859145692),
        (0.22435515780379928, 57.90632493186578),
        (0.07023307686227594, 7.479055343031285),
        (0.4911052707945709, 27.367232780214675)],
    ("drake", "dair2022", "sap"): [
        (0.15354086835003136, 9.009326297924188),
        (0.15364870158375235, 6.519866490951771),
        (0.39329264823505183, 61.67450538495816),
        (0.04535778916788256, 2.187663992162304),
        (0.33415415384734903, 66.0354290186968)],
}
MODULES = {"pybullet": "pybullet", "mujoco": "mujoco", "drake": "pydrake"}
EFFECTIVE_FRICTION = {"pybullet": 0.3580420664522583 * 0.5, "mujoco": 0.2180675752744882,
                      "drake": 2 * 0.09696370810340711 / 1.09696370810340711}


@pytest.mark.parametrize(("engine", "param_set", "approximation"), list(MEASURED))
def test_dair2022_replays_match_the_measurement(df: pd.DataFrame, engine: str,
                                                param_set: str, approximation: str | None
                                                ) -> None:
    pytest.importorskip(MODULES[engine], reason=f"{engine} not installed")
    logging.getLogger("drake").setLevel(logging.ERROR)  # TAMSI deprecation, half-space notes
    params = {"discrete_contact_approximation": approximation} if approximation else None
    r = replay(engine, "custom", tosses=IDS, param_set=param_set, data=df, params=params)
    assert set(RESULT_KEYS) <= set(r)
    assert (r["status"], r["tosses"], r["failed"]) == ("ok", 5, [])
    got = [(t["toss"], t["position_error"], t["rotation_error_deg"]) for t in r["per_toss"]]
    want = MEASURED[engine, param_set, approximation]
    for (i, pos, rot), j, (pos_ref, rot_ref) in zip(got, IDS, want, strict=True):
        assert i == j
        assert pos == pytest.approx(pos_ref, rel=RTOL), (engine, i)
        assert rot == pytest.approx(rot_ref, rel=RTOL), (engine, i)
    assert r["position_error_median"] == pytest.approx(
        float(np.median([g[1] for g in got])), rel=1e-12)
    eff = r["engine_setup"]["effective"]
    assert eff["friction"] == pytest.approx(EFFECTIVE_FRICTION[engine], rel=1e-12)
    assert eff["friction_rule"]
    assert r["protocol"]["name"] == "dair2022" and r["protocol"]["substeps"] == 10


def test_one_engine_reused_equals_fresh_ones(df: pd.DataFrame) -> None:
    """One instance across tosses, in any order, gives what a fresh instance per toss gives."""
    pytest.importorskip("mujoco", reason="mujoco not installed")
    together = replay("mujoco", "custom", tosses=[57, 0, 1], param_set="dair2022", data=df)
    for row in together["per_toss"]:
        alone = replay("mujoco", "custom", tosses=[row["toss"]], param_set="dair2022",
                       data=df)["per_toss"][0]
        assert (alone["position_error"], alone["rotation_error_deg"]) == \
            (row["position_error"], row["rotation_error_deg"])


def test_default_mode_records_the_engines_own_settings(df: pd.DataFrame) -> None:
    pytest.importorskip("pybullet", reason="pybullet not installed")
    r = replay("pybullet", "default", tosses="test", data=df[df["toss"].isin([0, 1, 7])])
    assert (r["tosses"], [t["toss"] for t in r["per_toss"]]) == (2, [0, 7])
    setup = r["engine_setup"]
    assert setup["params"] == {} and setup["effective"]["friction"] == 0.25
    assert setup["cube_inertia_kg_m2"] == pytest.approx(0.00081)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"engine": "bullet", "mode": "custom", "param_set": "dair2022"},
     "engine = 'bullet': must be one of"),
    ({"engine": "mujoco", "mode": "custom", "param_set": "dair2023"},
     "param-set = 'dair2023': mujoco has dair2022, dair2022x3"),
    ({"engine": "mujoco", "mode": "default", "param_set": "dair2022"},
     "default mode sets no engine parameters"),
    ({"engine": "mujoco", "mode": "custom"}, "mode = 'custom': needs --param-set (dair2022"),
    ({"engine": "mujoco", "mode": "mapped"},
     "mode = 'mapped': must be one of native, injected, tuned, default, custom"),
    ({"engine": "mujoco", "mode": "native", "param_set": "dair2022"},
     "param_set = 'dair2022': native mode maps the reference model's contact"),
    ({"engine": "mujoco", "mode": "tuned"}, "params = None: tuned mode needs the fitted"),
    ({"engine": "mujoco", "mode": "tuned", "param_set": "dair2022", "params": {"x": 1}},
     "param_set = 'dair2022': tuned mode takes the fitted parameters"),
    ({"engine": "mujoco", "mode": "default", "tosses": [3]}, "toss 3 not in the data"),
    ({"engine": "pybullet", "mode": "custom", "params": {"board.stiffness": 1.0}},
     "param 'board.stiffness': not a pybullet cube parameter"),
])
def test_bad_requests_are_one_line_errors(df: pd.DataFrame, kwargs: dict, message: str
                                          ) -> None:
    pytest.importorskip("pybullet", reason="pybullet not installed")
    with pytest.raises(ValueError) as info:
        replay(data=df[df["toss"].isin([0, 1])], **kwargs)
    assert message in str(info.value) and "\n" not in str(info.value)
