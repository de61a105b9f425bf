"""The bounce-to-rest scenario through the suite: the bounces read from a record, plausibility
(sinking beyond the step's own overlap, energy created), the run command, the ball's tuned
files at the engine's step, the config and the report's figure."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.bounce import BounceEnd
from impactbench.engines.common import Recorder
from impactbench.reference.bounce_scenario import Bounce

from impactbench import plausibility
from impactbench.cli import main
from impactbench.evaluate import compare
from impactbench.scenarios.bounce import SPEC, bounces_of, metrics_of_record

G = 9.80665


def _rigid_record(h: float, e: float, dt: float, bounces: int, rest_s: float = 0.3):
    """A ball dropped from ``h`` and bounced by an ideal rigid contact of restitution ``e``
    (exact flights sampled at ``dt``; a contact is one sample with F > 0), then at rest on
    the plate for ``rest_s``: the reader's test case, its apexes known, e^(2k)·h."""
    rec, t = Recorder(), 0.0
    v_up, first = 0.0, True
    for _ in range(bounces + 1):
        # flight from the plate (or from rest at h) down to the plate
        top = h if first else v_up**2 / (2 * G)
        rise = 0.0 if first else v_up / G
        span = rise + math.sqrt(2 * top / G)
        n = int(span // dt)
        for k in range(n):
            s = k * dt
            y = (top if first else 0.0) + (0.0 if first else v_up * s) - 0.5 * G * s * s
            rec.append(t + s, -y, -(0.0 if first else v_up) + G * s, 0.0, 0.0)
        v_in = math.sqrt(2 * G * top)
        t += n * dt
        rec.append(t, 0.0, v_in, 1.0, 0.0)  # the contact's one sample
        t += dt
        v_up, first = e * v_in, False
    for k in range(int(rest_s / dt)):
        rec.append(t + k * dt, 1e-6, 0.0, 0.98, 0.0)
    out = rec.record(0.1, settled=True, rest_from_s=t + dt, timestep_s=dt)
    return out


def test_the_reader_finds_each_apex_of_an_exact_bouncing_record():
    dt = 1e-4
    rec = _rigid_record(0.2, 0.8, dt, 6)
    got = bounces_of(rec)
    expected = [0.2 * 0.8 ** (2 * k) for k in range(1, 7)]
    # a parabola sampled at dt errs by at most g·dt²/8 (1.2e-8 m here)
    assert np.allclose(got.apex_heights_m, expected, rtol=0, atol=G * dt * dt / 8 + 1e-12)
    m = metrics_of_record(rec)
    assert m["first_apex_m"] == got.apex_heights_m[0]
    assert m["bounces_above_1mm"] == sum(a > 1e-3 for a in expected) == 6
    assert m["rest_sink_m"] == pytest.approx(1e-6) and m["rest_jitter_m_s"] == 0.0
    assert got.impact_speeds_m_s[0] == pytest.approx(math.sqrt(2 * G * 0.2), rel=1e-3)


def test_an_apex_above_the_one_before_is_energy_created_and_never_ok():
    s = Bounce(height_m=0.2)
    rec = _rigid_record(0.2, 1.05, 1e-4, 3)
    measures = SPEC.measure(s, rec, metrics_of_record(rec))
    assert measures["energy_ratio"] == pytest.approx(1.05**2, rel=1e-3)
    for status in ("ok", "max_time"):
        run = {"status": status, "message": "still moving", "plausibility": measures}
        judged = plausibility.judge(run)
        assert judged["status"] == "implausible" and "energy created" in judged["message"]
        # judged again with limits that allow it: what it was
        assert plausibility.judge(judged, plausibility.Limits(max_energy_ratio=1.2))["status"] \
            == status


def test_sinking_is_counted_beyond_the_steps_own_overlap():
    """A rigid contact met after one step's travel (v·dt) inside the plate sinks by nothing
    of its own; the same overlap plus 2 mm is 2 mm of sinking."""
    s, dt = Bounce(height_m=0.2), 1.0 / 240.0
    v = math.sqrt(2 * G * 0.2)
    rec = Recorder()
    rec.append(0.0, -0.001, v, 0.0, v)
    rec.append(dt, v * dt, v, 5.0, v)
    rec.append(2 * dt, -0.001, -v, 0.0, -v)
    out = rec.record(0.1, timestep_s=dt)
    assert SPEC.measure(s, out, {})["penetration_ratio"] == 0.0
    rec._rows[1] = (dt, v * dt + 0.002, v, 5.0, v, 0.0, 0.0)
    deeper = rec.record(0.1, timestep_s=dt)
    assert SPEC.measure(s, deeper, {})["penetration_ratio"] == pytest.approx(
        (0.002 - G * dt * dt) / s.radius_m)


def test_the_end_rule_stops_a_run_that_gains_energy_and_one_at_rest():
    s = Bounce(height_m=0.1)
    end = BounceEnd(s, 1e-3)
    assert not end.ended(-0.05, 1.0, 0.0)
    assert end.ended(-0.3, 0.0, 0.0)  # twice the drop's energy: diverged
    assert end.gained > 2.0
    end = BounceEnd(s, 1e-3)
    quiet = [end.ended(1e-7, 1e-4, 1.0) for _ in range(end.settle_steps)]
    assert quiet[-1] and not any(quiet[:-1]) and end.settled
    assert end.rest_from_s == pytest.approx(1e-3)


def test_run_bounce_json_prints_the_engines_bounces_beside_the_references(capsys):
    require_engine("pymunk")
    code = main(["run", "bounce", "--engine", "pymunk", "--mode", "custom", "--param",
                 "elasticity=0.9", "--height", "0.05", "--max-time", "3", "--json",
                 "--allow-status", "implausible,max_time"])
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert out["timestep_s"] == pytest.approx(1 / 60)
    assert {"apex_heights_m", "bounces_above_1mm", "static_sink_m", "stop_reason"} <= set(out)
    assert out["reference"]["apex_heights_m"][0] == pytest.approx(0.0439916, rel=1e-5)
    # elasticity 0.9 at 1/60 s: the first apex near e²·h (pymunk's own bounce test: 0.6 %)
    assert out["apex_heights_m"][0] == pytest.approx(0.81 * 0.05, rel=0.05)


def test_the_threshold_the_engine_reports_is_where_it_stops_bouncing():
    require_engine("pybullet")
    run, _ = compare("pybullet", Bounce(height_m=0.2), "custom",
                     _settings(params={"restitution": 0.5}))
    assert run["bounce_threshold_m_s"] == 0.2
    assert "below the engine's restitution threshold 0.2 m/s" in run["stop_reason"]


def _settings(**kw):
    from impactbench.engines.base import RunSettings

    return RunSettings(**kw)


def test_tuned_takes_the_balls_file_fitted_at_the_engines_step():
    require_engine("pybullet")
    from impactbench.tuned import tuned_settings

    params, prov = tuned_settings("pybullet", Bounce(), None)
    assert prov["file"] == "pybullet_ball_on_plate_dt1_240s.toml"
    assert prov["scenario"] == "bounce" and prov["fitted_on"] == "ball-on-plate"
    run, _ = compare("pybullet", Bounce(), "tuned",
                     _settings(tuned=params, tuned_for=prov))
    assert run["status"] in ("ok", "implausible", "max_time"), run["message"]
    assert run["timestep_s"] == pytest.approx(1 / 240)
    # at another step the file does not apply, and the message names the ball's fit
    run, _ = compare("pybullet", Bounce(), "tuned",
                     _settings(timestep_s=1e-3, tuned=params, tuned_for=prov))
    assert run["status"] == "unsupported"
    assert "impactbench tune --engine pybullet" in run["message"]
    assert "--scenario" not in run["message"]


def test_the_config_takes_a_bounce_table_with_its_own_modes():
    from impactbench import config

    cfg = config.parse({"report": {"engines": ["pymunk"]},
                        "bounce": {"heights_m": [0.05, 0.2], "modes": ["default"]}})
    sm = next(s for s in cfg.scenarios if s.name == "bounce")
    assert sm.modes == ("default",) and sm.values("height_m") == (0.05, 0.2)
    with pytest.raises(ValueError, match=r"bounce\.modes"):
        config.parse({"bounce": {"heights_m": [0.2], "modes": ["sideways"]}})
    with pytest.raises(ValueError, match=r"bounce\.heights_m"):
        config.parse({"bounce": {"heights_m": [-1.0]}})
    with pytest.raises(ValueError, match=r"bounce\.max_time_s = 0\.01: must be longer"):
        config.parse({"bounce": {"heights_m": [0.2], "max_time_s": 0.01}})


def test_tune_bounce_says_to_fit_the_balls_file(capsys):
    assert main(["tune", "--scenario", "bounce", "--engine", "pybullet", "--timestep", "0.004",
                 "--out", "unused.toml"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert "impactbench tune --engine pybullet --timestep S" in err
