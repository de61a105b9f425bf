"""The smaller engines' own checks (real engines, no mocks): pymunk's drift–kick penalty step
and its restitution injection, a rigid contact as one impulse, Box2D's compiled-in velocity
threshold, the 2D engines' disc, PhysX's undamped compliant contact and its rigid friction.
The shapes every adapter shares are in test_conformance.py; MuJoCo/MJX, PyBullet, Drake and
Newton have their own ``test_specifics_*.py``. Tolerances: the measurement beside each
(pymunk 7.3.1, Box2D 2.3.10, SAPIEN 3.0.3 / PhysX 5.3.1).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import rel, require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference import hunt_crossley, metrics
from impactbench.reference.oblique import Oblique
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate

from impactbench.evaluate import compare

FLOAT32 = 1.2e-7
"""Box2D keeps velocities in float32: one float32 ulp (2⁻²³), 3× the largest measured error
of an exact rigid restitution (3.97e-8 for e = 0.6 and 0.8)."""


def adapter(engine: str):
    """The engine's adapter, or a skip naming the pip command that installs it."""
    require_engine(engine)
    return get_adapter(engine)


def ball(engine: str, velocity: float, mode: str, dt: float, **settings):
    rec = adapter(engine).run(BallOnPlate(velocity_m_s=velocity), mode,
                              RunSettings(timestep_s=dt, **settings))
    return rec, metrics.compute(rec)


# ------------------------------------------------------------------------------------ pymunk


def test_pymunk_penalty_force_in_pre_solve_is_symplectic() -> None:
    """An elastic (b = 0) Hertz ball at ω·dt ≈ 0.04 (dt = 1e-6 s): explicit Euler (force from
    the state before the step) gains ~8 % of restitution; pymunk's drift–kick step with the
    force applied in pre_solve keeps it at 1 (measured within 5.9e-5)."""
    sc = BallOnPlate(velocity_m_s=5.0, damping_s_per_m=0.0)
    rec = adapter("pymunk").run(sc, "injected", RunSettings(timestep_s=1e-6))
    got = metrics.compute(rec)
    assert rec.status is Status.OK
    assert abs(got["restitution"] - 1.0) < 1.8e-4


@pytest.mark.parametrize("velocity", [0.5, 5.0])
def test_pymunk_restitution_injection_matches_hunt_crossley_restitution(velocity) -> None:
    rec, got = ball("pymunk", velocity, "injected", 1e-6, options={"injection": "restitution"})
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=velocity))
    assert rec.status is Status.OK
    assert rel(got["restitution"], ref["restitution"]) <= 1e-15  # measured 1.1e-16, 0
    assert rec.meta["injection"] == "restitution"


@pytest.mark.parametrize("velocity", [1.0, 5.0])
def test_pymunk_native_rigid_contact_is_one_impulse(velocity) -> None:
    """A rigid contact is one impulse: no physical duration, one force sample m·(1 + e)·V0/dt
    (its restitution, the reference's at 1 m/s, in test_conformance.py)."""
    k_ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=1.0))["restitution"]
    rec, got = ball("pymunk", velocity, "native", 1e-6)
    assert rec.status is Status.OK
    assert got["duration_s"] <= 2e-6 + 1e-15  # one impulse: no physical duration
    assert float(np.sum(rec.normal_force_n > 0)) == 1
    assert got["peak_force_n"] == pytest.approx(0.1 * (1 + k_ref) * velocity / 1e-6, rel=1e-9)


def test_pymunk_native_is_wrong_away_from_the_reference_velocity() -> None:
    """The reference's restitution falls with velocity; a rigid contact's does not."""
    k_ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=1.0))["restitution"]
    k_fast = hunt_crossley.solve(BallOnPlate(velocity_m_s=5.0))["restitution"]
    assert abs(k_fast - k_ref) > 0.1  # hence native is wrong away from v_ref


def test_pymunk_rigid_contact_at_ten_ms_keeps_its_restitution() -> None:
    """A rigid contact is one impulse at any step; the thick plate keeps a 5 cm step from
    carrying the ball through it, so native mode at 1e-2 s still bounces with e = elasticity."""
    rec, got = ball("pymunk", 5.0, "native", 1e-2)
    assert rec.status is Status.OK
    assert got["restitution"] == pytest.approx(rec.meta["elasticity"], rel=1e-12)
    assert not metrics.resolved(rec)["duration_s"]


def test_pymunk_oblique_injected_through_the_rigid_contact_is_the_rigid_theory():
    """``injection = "restitution"``: pymunk's own contact and Coulomb friction with the law's
    restitution k(b·ẋ) — the rigid reference to round-off (measured ≤ 3.3e-14)."""
    require_engine("pymunk")
    for angle in (20.0, 80.0):
        out, _ = compare("pymunk", Oblique(angle_deg=angle), "injected",
                         RunSettings(options={"injection": "restitution"}))
        assert out["status"] == "ok"
        for key in ("restitution", "tangential_restitution", "spin_out_rad_s"):
            assert abs(out["rel_error"][key]) <= 1e-9, (angle, key)


# --------------------------------------------------------------------------------------- Box2D


def test_box2d_native_ball_does_not_bounce_at_the_velocity_threshold() -> None:
    """Restitution is applied above b2_velocityThreshold = 1 m/s only: the ball at exactly
    1 m/s stops dead (at 5 m/s it leaves with e: test_conformance.py)."""
    rec, got = ball("box2d", 1.0, "native", 1e-6)
    assert rec.status is Status.OK, rec.message
    assert rec.meta["build_constants"]["b2_velocityThreshold"] == 1.0
    assert "1 m/s" in rec.meta["not_expressible"]
    assert got["restitution"] == pytest.approx(0.0, abs=FLOAT32)  # measured exactly 0


# ------------------------------------------------------------------- the 2D engines' disc


def _pymunk_moment(s: Oblique, mode: str) -> tuple[float, dict]:
    from impactbench.engines.pymunk_adapter import oblique_model

    model, meta = oblique_model(s, mode, RunSettings(timestep_s=1e-6), 1e-6, 10)
    assert meta["engine_defaults"]["moment_of_inertia_kg_m2"] == pytest.approx(
        model.body.moment, rel=1e-12)
    return model.body.moment, meta


def _box2d_moment(s: Oblique, mode: str) -> tuple[float, dict]:
    from impactbench.engines.box2d_adapter import ObliqueModel

    params, meta = get_adapter("box2d").oblique_parameters(s, mode,
                                                           RunSettings(timestep_s=1e-6))
    assert meta["planar"] is True
    return ObliqueModel(s, params, 1e-6).body.inertia, meta


@pytest.mark.parametrize(("engine", "modes", "moment", "tol"), [
    ("pymunk", ("native", "injected", "default"), _pymunk_moment, 1e-12),
    ("box2d", ("native", "default"), _box2d_moment, 1e-6),  # float32 mass data
])
def test_the_disc_is_a_circle_with_the_discs_moment_of_inertia(engine, modes, moment, tol):
    """Read back from the engine's body: m·R²/2 for the disc, (2/5)·m·R² for the sphere."""
    require_engine(engine)
    for shape, ratio in (("disc", 0.5), ("sphere", 0.4)):
        s = Oblique(shape=shape)
        for mode in modes:
            got, _ = moment(s, mode)
            assert got == pytest.approx(ratio * s.mass_kg * s.radius_m**2, rel=tol), \
                (shape, mode)


# ------------------------------------------------------------------------- SAPIEN (PhysX 5)


def test_sapien_native_ball_is_an_undamped_spring() -> None:
    """PhysX's compliant contact K = −restitution: duration π·√(m/K), peak V0·√(K·m), and no
    damping (restitution ≈ 1: the contact model's error)."""
    rec, got = ball("sapien", 1.0, "native", 1e-7)
    assert rec.status is Status.OK, rec.message
    stiffness = -rec.meta["restitution"]
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=1.0))
    assert rel(got["duration_s"], math.pi * math.sqrt(0.1 / stiffness)) <= 4.1e-4  # 1.37e-4
    assert rel(got["peak_force_n"], math.sqrt(stiffness * 0.1)) <= 7.6e-4  # 2.54e-4
    assert got["restitution"] > 0.998 > ref["restitution"] + 0.05  # measured 0.99940
    assert "damping" in rec.meta["not_expressible"]


def test_sapien_oblique_rigid_contact_friction_overshoots():
    """``options["contact"] = "rigid"``: PhysX's rigid contact with patch friction spins the
    ball faster than rolling at 45° (measured 97.4 against the rigid theory's 69.6 rad/s)."""
    require_engine("sapien")
    out, rec = compare("sapien", Oblique(angle_deg=45.0), "native",
                       RunSettings(options={"contact": "rigid"}))
    assert out["status"] == "ok" and rec.meta["contact"] == "rigid"
    assert out["spin_out_rad_s"] > 1.2 * out["reference"]["spin_out_rad_s"]
