"""The box with compliant corners (impactbench.reference.box_contact) against physics it must
obey: free flight, static equilibrium, Coulomb sliding, the zoo's restitution, energy, and
one-line input errors. Each check names its source."""

from __future__ import annotations

import math

import numpy as np
import pytest
from impactbench.reference import box_contact as bc
from impactbench.reference import hunt_crossley, kelvin_voigt
from impactbench.reference.box_contact import Box, BoxContactParams

H, M, I0 = bc.HALF_WIDTH_M, bc.MASS_KG, bc.INERTIA_KG_M2
G = bc.GRAVITY_M_S2
FLAT = np.array([1.0, 0.0, 0.0, 0.0])


def quat_exp(rotvec: np.ndarray) -> np.ndarray:
    """exp of a rotation vector as a unit quaternion (w, x, y, z)."""
    a = float(np.linalg.norm(rotvec))
    if a == 0.0:
        return FLAT.copy()
    return np.concatenate([[math.cos(a / 2)], math.sin(a / 2) * np.asarray(rotvec) / a])


# ------------------------------------------------------------------------------ free flight


def test_free_flight_is_a_parabola_with_constant_spin() -> None:
    """Out of contact the centre moves on p0 + v0·t − ½g·t²·e_z (Newton) and the isotropic
    box spins at a constant body-frame ω (Euler's equations with I₁ = I₂ = I₃ and no torque:
    I·ω̇ = −ω × Iω = 0; Landau & Lifshitz, *Mechanics*, §36), so q(t) = q0 ⊗ exp(ω·t/2);
    angular momentum and kinetic energy stay constant."""
    q0 = np.array([0.8, 0.2, -0.4, 0.4])
    q0 /= np.linalg.norm(q0)
    p0, v0, w0 = np.array([0.1, -0.2, 1.0]), np.array([0.7, -0.3, 1.2]), np.array([3., -7., 11.])
    t = np.linspace(0.0, 0.35, 36)            # lowest corner stays above 0.3 m
    traj = bc.integrate_box(BoxContactParams(), bc.initial_state(p0, q0, v0, w0), t)
    assert traj.status == 0
    exact_p = p0 + np.outer(t, v0) - 0.5 * G * np.outer(t * t, [0.0, 0.0, 1.0])
    exact_q = np.array([bc.quat_multiply(q0, quat_exp(w0 * ti)) for ti in t])
    # measured: 8.3e-9 m (LSODA's first step), 3.7e-8 (quaternion), 0 rad/s
    assert np.max(np.abs(traj.p - exact_p)) < 3e-8
    assert np.max(np.abs(traj.q - exact_q)) < 1.2e-7
    assert np.max(np.abs(traj.w_body - w0)) < 1e-12
    model = bc.BoxOnBoard(BoxContactParams())
    moments = np.array([model.angular_momentum(y) for y in traj.states])
    # measured: 2e-15 (momentum, relative), 7.4e-9 (energy, relative; gravity's part)
    assert np.max(np.abs(moments - moments[0])) < 1e-12 * np.linalg.norm(moments[0])
    energy = [model.energy(y) for y in traj.states]
    assert np.ptp(energy) < 2.5e-8 * energy[0]


def test_torque_free_asymmetric_top_keeps_momentum_and_energy() -> None:
    """A box with three different moments, out of contact: ω changes (Euler's equations with
    the gyroscopic term) but the board-frame angular momentum R·I·ω and the rotational energy
    ½ω·Iω are constant (Landau & Lifshitz, *Mechanics*, §37). A wrong sign of the gyroscopic
    term breaks both."""
    box = Box(inertia_kg_m2=(4e-4, 8e-4, 1.1e-3))
    y0 = bc.initial_state([0, 0, 5.0], [1, 0, 0, 0], [0, 0, 0], [0.3, 9.0, 0.4])
    t = np.linspace(0.0, 0.9, 91)
    traj = bc.integrate_box(BoxContactParams(), y0, t, box=box, gravity_m_s2=0.0)
    model = bc.BoxOnBoard(BoxContactParams(), box, gravity_m_s2=0.0)
    moments = np.array([model.angular_momentum(y) for y in traj.states])
    energy = np.array([model.energy(y) for y in traj.states])
    assert np.ptp(traj.w_body[:, 0]) > 1.0   # the spin wanders: not a trivial check
    # measured: 1.1e-10 (momentum, relative) and 7.7e-12 (energy, relative)
    assert np.max(np.linalg.norm(moments - moments[0], axis=1)) < 3.5e-10 * np.linalg.norm(
        moments[0])
    assert np.ptp(energy) < 2.5e-11 * energy[0]


# ------------------------------------------------------------------------------ contact


def settle(params: BoxContactParams, seconds: float = 1.0) -> bc.Trajectory:
    """The box placed flat with its bottom face on the board, released from rest."""
    y0 = bc.initial_state([0.0, 0.0, H], FLAT, [0, 0, 0], [0, 0, 0])
    return bc.integrate_box(params, y0, np.linspace(0.0, seconds, 11))


def test_flat_box_settles_at_the_static_penetration_linear() -> None:
    """At rest on four corners each carries mg/4 (symmetry); the linear law gives k·x = mg/4,
    x = mg/(4k) (statics)."""
    k = 2e4
    d = 2 * 0.4 * math.sqrt(k * M / 4)          # ζ = 0.4 per corner (mass m/4)
    params = BoxContactParams("kelvin-voigt-clipped", k, 1.0, d, 0.3, 1e-3)
    traj = settle(params)
    x = H - traj.p[-1, 2]
    # measured: |x/x_s − 1| = 1e-13, v_z = 3e-15 m/s
    assert x == pytest.approx(M * G / (4 * k), rel=3e-13)
    assert abs(traj.v[-1, 2]) < 1e-12
    assert np.allclose(traj.q[-1], FLAT, atol=1e-12)


def test_flat_box_settles_at_the_static_penetration_hunt_crossley() -> None:
    """Hunt–Crossley corners: c·xⁿ = mg/4 at rest, x = (mg/(4c))^(1/n) (statics; the damping
    term b·ẋ vanishes at rest)."""
    c, n = 3e7, 1.5
    # b = 100 s/m: damping ratio ≈ 0.4 about the rest point (c·xⁿ·b against √(k·m/4))
    params = BoxContactParams("hunt-crossley", c, n, 100.0, 0.3, 1e-3)
    traj = settle(params, 1.0)
    x = H - traj.p[-1, 2]
    # measured: |x/x_s − 1| = 1.8e-13, v_z = 3e-15 m/s
    assert x == pytest.approx((M * G / (4 * c)) ** (1 / n), rel=6e-13)
    assert abs(traj.v[-1, 2]) < 1e-12


def test_sliding_box_decelerates_at_mu_g() -> None:
    """A flat box sliding at v ≫ v_s: every corner's friction is −μ·F_n·û_t, so
    m·v̇_x = −μ·ΣF_n and m·z̈ = ΣF_n − m·g (Newton): v_x(t) = v0 − μ·g·t − μ·ż(t) exactly,
    and the deceleration is μ·g up to the small bounce ż of the tipping box (Coulomb's law)."""
    k = 1e5
    mu, v0 = 0.3, 1.0
    params = BoxContactParams("kelvin-voigt-clipped", k, 1.0, 2 * 0.5 * math.sqrt(k * M / 4),
                              mu, 1e-4)
    z0 = H - M * G / (4 * k)
    t = np.linspace(0.0, 0.25, 26)            # stops at v0/(μg) = 0.34 s
    traj = bc.integrate_box(params, bc.initial_state([0, 0, z0], FLAT, [v0, 0, 0], [0, 0, 0]),
                            t)
    coulomb = v0 - mu * G * t
    # measured: 1.4e-8 m/s both (the tipping box's centre hardly moves vertically; the
    # regularisation's own share is μ·g·t·v_s²/(2v²) = 4e-9 m/s)
    assert np.max(np.abs(traj.v[:, 0] + mu * traj.v[:, 2] - coulomb)) < 5e-8
    assert np.max(np.abs(traj.v[:, 0] - coulomb)) < 5e-8
    assert np.max(np.abs(traj.v[:, 1])) < 1e-12   # no sideways drift


@pytest.mark.parametrize("law", ["hunt-crossley", "kelvin-voigt-clipped"])
def test_flat_drop_rebounds_with_the_zoo_restitution(law: str) -> None:
    """A flat box dropped at V0 (gravity off) is four identical one-corner impacts of mass
    m/4: it leaves at e·V0 with the law's restitution — Hunt–Crossley's k(α = b·V0) (Lambert-W
    closed form, :func:`impactbench.reference.hunt_crossley.restitution`; Hunt & Crossley
    1975) or the clipped Kelvin–Voigt closed form in ζ = d/(2√(k·m/4))
    (:func:`impactbench.reference.kelvin_voigt.clipped_restitution`)."""
    v0 = 1.5
    if law == "hunt-crossley":
        params = BoxContactParams(law, 1e8, 1.5, 0.4, 0.3, 1e-3)
        expected = float(hunt_crossley.restitution(0.4 * v0))
    else:
        k, zeta = 5e4, 0.2
        params = BoxContactParams(law, k, 1.0, 2 * zeta * math.sqrt(k * M / 4), 0.3, 1e-3)
        expected = kelvin_voigt.clipped_restitution(zeta)
    y0 = bc.initial_state([0, 0, H + 1e-3], FLAT, [0, 0, -v0], [0, 0, 0])
    traj = bc.integrate_box(params, y0, np.array([0.0, 0.05]), gravity_m_s2=0.0)
    assert traj.v[-1, 2] > 0 and traj.p[-1, 2] > H   # gone up, out of contact
    # measured: 2.4e-7 (Hunt–Crossley), 3.7e-7 (Kelvin–Voigt) relative
    assert traj.v[-1, 2] / v0 == pytest.approx(expected, rel=1.1e-6)
    assert 0.3 < expected < 0.9


def test_energy_is_conserved_without_damping_and_lost_with_it() -> None:
    """With b = 0 and μ = 0 every force is conservative: kinetic + gravitational + the
    corners' spring energy c·xⁿ⁺¹/(n+1) is constant through tumbling bounces; friction and
    damping only remove energy."""
    y0 = bc.initial_state([0, 0, 0.12], [0.9, 0.3, 0.2, 0.1], [1.0, 0.3, -1.5], [3., -5., 8.])
    t = np.linspace(0.0, 1.0, 201)
    for mu, b, conserved in ((0.0, 0.0, True), (0.5, 2.0, False)):
        params = BoxContactParams("hunt-crossley", 1e6, 1.5, b, mu, 1e-3)
        model = bc.BoxOnBoard(params)
        # the dissipative case at 1/100 of the default tolerances: at the defaults the
        # sampled energy carries LSODA's error, which rose by 1.3e-10 (relative) over one
        # sample on one CPU (4e-16 on another): 7e-11 at 1/10, 4e-16 at 1/100 and 1/1000
        tight = 1.0 if conserved else 0.01
        traj = bc.integrate_box(params, y0, t, rtol=bc.RTOL * tight, atol=bc.ATOL * tight)
        energy = []
        for y in traj.states:
            z = y[2] + (bc.quat_matrix(y[3:7]) @ model.corners.T)[2]
            pen = np.maximum(-z, 0.0)
            energy.append(model.energy(y) + np.sum(1e6 * pen ** 2.5 / 2.5))
        energy = np.array(energy)
        if conserved:
            assert np.min(traj.p[:, 2]) < H * math.sqrt(3)   # it did hit the board
            # measured: 1.9e-6 relative
            assert np.ptp(energy) < 6e-6 * energy[0]
        else:
            # measured: rises by at most 4e-16 (relative, 2 ulps) between samples: round-off
            # of the energy's dozen terms; 1e-14 is some 45 ulps of it
            assert np.max(np.diff(energy)) < 1e-14 * energy[0]
            assert energy[-1] < 0.5 * energy[0]


def test_scalar_right_hand_side_matches_the_numpy_forces() -> None:
    """The fast right-hand side (plain scalars) against the same equations written with
    numpy arrays (:meth:`BoxOnBoard.contact_forces`, Newton–Euler assembled here)."""
    rng = np.random.default_rng(3)
    for law, n in (("hunt-crossley", 1.3), ("kelvin-voigt-clipped", 1.0)):
        box = Box(inertia_kg_m2=(5e-4, 8e-4, 1e-3))
        model = bc.BoxOnBoard(BoxContactParams(law, 2e4, n, 3.0, 0.4, 1e-2), box)
        touched = 0
        for _ in range(300):
            q = rng.normal(size=4)
            y = np.concatenate([rng.normal(size=2) * 0.1, [H + rng.uniform(-0.01, 0.03)],
                                q / np.linalg.norm(q), rng.normal(size=3), 5 * rng.normal(
                                    size=3)])
            r, f = model.contact_forces(y)
            touched += len(r) > 0
            rot = bc.quat_matrix(y[3:7])
            w = y[10:13]
            inertia = box.inertia
            torque = rot.T @ np.cross(r, f).sum(axis=0)
            expected = np.concatenate([
                y[7:10], 0.5 * bc.quat_multiply(y[3:7], np.concatenate([[0.0], w])),
                f.sum(axis=0) / M - [0, 0, G],
                (torque - np.cross(w, inertia * w)) / inertia])
            assert np.allclose(model.rhs(0.0, y), expected, rtol=1e-12, atol=1e-9)
        assert touched > 100


# ------------------------------------------------------------------------------ inputs


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"stiffness": -1.0}, "stiffness = -1.0: must be > 0 and finite"),
    ({"law": "hertz"}, "law = 'hertz': must be one of hunt-crossley, kelvin-voigt-clipped"),
    ({"law": "kelvin-voigt-clipped", "exponent": 1.5},
     "exponent = 1.5: must be 1 for law 'kelvin-voigt-clipped'"),
    ({"exponent": 5.0}, "exponent = 5.0: must be in [1, 3]"),
    ({"damping": math.nan}, "damping = nan: must be >= 0 and finite"),
    ({"friction": -0.1}, "friction = -0.1: must be >= 0 and finite"),
    ({"slip_velocity_m_s": 0.0}, "slip_velocity_m_s = 0.0: must be > 0 and finite"),
    ({"stiffness": "1e5"}, "stiffness = '1e5': must be a real number"),
])
def test_bad_parameters_give_one_line_errors(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError) as err:
        BoxContactParams(**kwargs)
    assert str(err.value) == message


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"half_width_m": 0.0}, "half_width_m = 0.0: must be > 0 and finite"),
    ({"mass_kg": math.inf}, "mass_kg = inf: must be > 0 and finite"),
    ({"inertia_kg_m2": (1e-4, 1e-4)}, "inertia_kg_m2 = (0.0001, 0.0001): must be one number "
                                      "or three (the principal moments)"),
    ({"inertia_kg_m2": (1e-4, 1e-4, 5e-4)}, "inertia_kg_m2 = (0.0001, 0.0001, 0.0005): must "
                                            "satisfy the triangle inequality"),
])
def test_bad_box_gives_one_line_errors(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError) as err:
        Box(**kwargs)
    assert str(err.value).startswith(message)
    assert "\n" not in str(err.value)


def test_bad_integration_inputs() -> None:
    y0 = bc.initial_state([0, 0, 1], FLAT, [0, 0, 0], [0, 0, 0])
    with pytest.raises(ValueError, match="strictly increasing"):
        bc.integrate_box(BoxContactParams(), y0, np.array([0.0, 0.2, 0.1]))
    with pytest.raises(ValueError, match=r"^q = \[0.0, 0.0, 0.0, 0.0\]: must be a non-zero"):
        bc.initial_state([0, 0, 1], [0, 0, 0, 0], [0, 0, 0], [0, 0, 0])
    traj = bc.integrate_box(BoxContactParams(), y0, np.linspace(0, 1, 5), max_evaluations=50)
    assert traj.status == -2 and np.isnan(traj.p[-1]).all() and "50" in traj.message
