"""``impactbench tune`` for SAPIEN, DART, Box2D, MJX and Newton (``engines/tuning_spaces_extras.py``
and MuJoCo's space for MJX): each recovers its own parameters from targets the engine made, is
never worse than its start (the native conversion), and says what it cannot express."""

from __future__ import annotations

import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, run_safely
from impactbench.reference.scenarios import BallOnPlate
from test_tune import engine_references

from impactbench.evaluate import record_metrics

SCENARIO = BallOnPlate()
FEW = (1.0, 4.0)

# engine → (parameter set, truth in the adapter's tuned keys, velocities of the targets)
TRUTHS = {
    "sapien": ("compliant-stiffness", {"restitution": -1.6e8}, FEW),
    "dart": ("restitution", {"restitution_coeff": 0.8}, FEW),
    "box2d": ("restitution", {"restitution": 0.8}, (2.0, 4.0)),  # bounces only above 1 m/s
    "mjx": ("solref", {"solref": [-1.6e9, -2100.0], "solimp": [1e-4, 1e-4, 1e-3, 0.5, 2.0]},
            FEW),
    # Newton steps in a Python loop (~0.2 s a run): one velocity identifies both, since its
    # linear law's restitution and duration do not depend on V0
    "newton": ("ke+kd", {"ke": 1.0e8, "kd": 280.0}, (2.0,)),
}


@pytest.mark.parametrize("engine", list(TRUTHS))
def test_recovers_its_own_parameters(engine):
    """Targets made by the engine at known parameters: the fit lands on them (1 %), from a
    start (the native conversion) more than 5 % away."""
    require_engine(engine)
    from impactbench.tuning import tune

    variant, truth, velocities = TRUTHS[engine]
    refs = engine_references(engine, truth, velocities)
    res = tune(engine, SCENARIO, velocities, parameters=variant, references=refs, budget_s=60)
    assert res.tuned.objective < 1e-6, res.stages  # float32 engines: ~1e-3 metric noise
    for key, value in truth.items():
        got, start = res.parameters[key], res.start_parameters[key]
        if key == "solimp":
            assert got == value
            continue
        assert got == pytest.approx(value, rel=0.01), key
        assert max(abs(g / t - 1) for g, t in zip(
            [start] if not isinstance(start, list) else start,
            [value] if not isinstance(value, list) else value, strict=True)) > 0.05


@pytest.mark.parametrize("engine", list(TRUTHS))
def test_tuned_is_never_worse_than_the_native_start(engine):
    """A short search (5 evaluations) on the paper's 0.5 and 5 m/s: never worse than the
    start, which is native mode's contact (same restitution as a native run)."""
    require_engine(engine)
    from impactbench.tuning import tune

    velocities = (0.5, 5.0)
    res = tune(engine, SCENARIO, velocities, max_evals=5)
    assert res.tuned.objective <= res.start.objective
    for i, v in enumerate(velocities):
        s = SCENARIO.replace(velocity_m_s=v)
        native = record_metrics(run_safely(engine, s, "native"), s)
        assert res.start.metrics[i]["restitution"] == pytest.approx(native["restitution"],
                                                                     rel=1e-6)


def test_rigid_engines_fit_restitution_only_and_say_why():
    """DART and Box2D contacts are rigid: duration and peak force are excluded with the
    rigid-contact reason, and Box2D's compiled-in 1 m/s threshold is stated."""
    require_engine("box2d")
    from impactbench.tuning import tune

    res = tune("box2d", SCENARIO, (1.0, 3.0), max_evals=10)
    assert set(res.excluded) == {"duration_s", "peak_force_n"}
    assert "one-step impulse" in res.excluded["duration_s"]
    assert any("b2_velocityThreshold = 1 m/s" in line for line in res.space.limits)
    # at 1 m/s Box2D stops the ball dead whatever the coefficient: −100 % before and after
    assert res.start.rel_errors[0]["restitution"] == res.tuned.rel_errors[0]["restitution"] == -1
    assert abs(res.tuned.rel_errors[1]["restitution"]) < abs(
        res.start.rel_errors[1]["restitution"])


def test_sapien_compliant_contact_cannot_fit_restitution():
    """PhysX's compliant contact is undamped: restitution is excluded (weight 0) and stays
    ≈ 1 at any stiffness, while the stiffness moves duration and peak force."""
    require_engine("sapien")
    from impactbench.tuning import tune

    res = tune("sapien", SCENARIO, (0.5, 5.0), max_evals=6)
    assert list(res.excluded) == ["restitution"] and "undamped" in res.excluded["restitution"]
    assert res.objective.weights["restitution"] == 0.0
    assert all(m["restitution"] > 0.99 for m in res.tuned.metrics)
    assert res.parameters["restitution"] < 0.0  # PhysX's compliant form: restitution = −K
    assert "PhysxMaterial(0.0, 0.0, -" in res.space.snippet(res.parameters)


def test_newton_and_mjx_snippets_use_their_own_form():
    require_engine("newton")
    require_engine("mjx")
    from impactbench.tuning import make_space

    newton = make_space("newton", SCENARIO)
    assert "ShapeConfig(ke=" in newton.snippet(newton.to_tuned(newton.start))
    mjx = make_space("mjx", SCENARIO)
    assert mjx.engine == "mjx" and mjx.variant == "solref+solimp"
    text = mjx.snippet(mjx.to_tuned(mjx.start))
    assert text.startswith("<geom solref=") and "mjx.put_model" in text


@pytest.mark.parametrize("engine, variant", [("dart", "stiffness"), ("newton", "solref")])
def test_unknown_parameter_set_is_one_line(engine, variant):
    from impactbench.tuning import make_space

    with pytest.raises(ValueError, match=rf"^parameters = '{variant}': ") as info:
        make_space(engine, SCENARIO, variant)
    assert "\n" not in str(info.value)


def test_engine_settings_in_tuned_keys_run():
    """The rigid SAPIEN variant carries bounce_threshold 0 in its tuned keys, so a bounce at
    1 m/s (below PhysX's default 2 m/s threshold) happens."""
    require_engine("sapien")
    from impactbench.tuning import make_space

    space = make_space("sapien", SCENARIO, "restitution")
    tuned = space.to_tuned(space.start)
    assert tuned["bounce_threshold"] == 0.0
    s = SCENARIO.replace(velocity_m_s=1.0)
    got = record_metrics(run_safely("sapien", s, "tuned", RunSettings(tuned=tuned)), s)
    assert got["restitution"] == pytest.approx(tuned["restitution"], rel=1e-3)
