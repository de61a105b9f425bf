"""Calibration against data the calibrator did not make.

``test_calibrate.py`` makes its synthetic data with ``zoo.sweep``, the calibrator's own forward
model, so an error shared by both (a wrong scaling, a wrong α(e)) would cancel. Here the data
come from a direct integration of the equation of motion in physical units (scipy DOP853
with events; MODELS.md §1: m·ẍ = −c·xⁿ·(1 + b·ẋ) from x = 0, ẋ = V0), the damping of a model
from its paper's formula written out here, and the fit must recover the parameters that made
them.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from impactbench.reference.scenarios import BallOnPlate
from scipy import integrate

from impactbench.calibrate import calibrate, measurements

VELOCITIES = (0.3, 0.8, 1.5, 2.5, 4.0)


def impact(m: float, v0: float, force, peak_event, push=None) -> dict[str, float]:
    """Restitution, duration and peak force of m·ẍ = −force(x, ẋ) from (0, V0), with events
    for leaving (x = 0, or ``push`` — the unclipped force of a clipped law — falling through 0)
    and the peak force."""

    def rhs(_t, y):
        return [y[1], -force(y[0], y[1]) / m]

    def leave(_t, y):
        return y[0]

    def let_go(_t, y):
        return 1.0 if push is None else push(y[0], y[1])

    leave.terminal = let_go.terminal = True
    leave.direction = let_go.direction = peak_event.direction = -1.0
    x_scale = 1e-4
    sol = integrate.solve_ivp(rhs, (0.0, 1.0), [0.0, v0], method="DOP853", rtol=1e-12,
                              atol=[1e-12 * x_scale, 1e-12 * v0],
                              events=(leave, let_go, peak_event))
    assert sol.status == 1, sol.message
    t_end = sol.t[-1]
    xp, vp = sol.y_events[2][0]
    return {"restitution": -sol.y[1, -1] / v0, "duration_s": t_end,
            "peak_force_n": force(xp, vp)}


def hunt_crossley_data(m: float, c: float, n: float, b_of_v) -> pd.DataFrame:
    rows = []
    for v0 in VELOCITIES:
        b = b_of_v(v0)

        def force(x, v, b=b):
            return c * max(x, 0.0) ** n * (1.0 + b * v)

        def peak(_t, y, b=b):  # dF/dt = 0 ⇔ n·ẋ = b·c·x^(n+1)/m (ẍ substituted)
            return n * y[1] - b * c * max(y[0], 0.0) ** (n + 1.0) / m

        rows.append({"velocity_m_s": v0, **impact(m, v0, force, peak)})
    return pd.DataFrame(rows)


def test_recovers_b_and_c_from_ode_data() -> None:
    m, c, n, b = 0.05, 3.1e9, 1.5, 0.23
    data = hunt_crossley_data(m, c, n, lambda _v: b)
    cal = calibrate(measurements(data), BallOnPlate(mass_kg=m))
    assert cal.estimates["damping_s_per_m"] == pytest.approx(b, rel=1e-7)
    assert cal.estimates["stiffness"] == pytest.approx(c, rel=1e-7)
    assert cal.residuals["rel_residual"].abs().max() < 1e-8


def test_recovers_the_exponent_from_ode_data() -> None:
    m, c, n, b = 0.1, 2e8, 1.3, 0.05
    data = hunt_crossley_data(m, c, n, lambda _v: b)
    cal = calibrate(measurements(data), BallOnPlate(stiffness=1e9), fit_exponent=True)
    assert cal.estimates["exponent"] == pytest.approx(n, rel=1e-6)
    assert cal.estimates["stiffness"] == pytest.approx(c, rel=1e-5)
    assert cal.estimates["damping_s_per_m"] == pytest.approx(b, rel=1e-6)


def test_recovers_flores_nominal_restitution_from_ode_data() -> None:
    """Flores et al., Multibody Syst. Dyn. 25:357, 2011: b = 8(1 − e)/(5e·V0), written here."""
    m, c, e = 0.1, 9e9, 0.62
    data = hunt_crossley_data(m, c, 1.5, lambda v: 8.0 * (1.0 - e) / (5.0 * e * v))
    start = BallOnPlate(model="flores", nominal_restitution=0.9, stiffness=2e10)
    cal = calibrate(measurements(data[["velocity_m_s", "restitution", "duration_s"]]), start)
    assert cal.estimates["nominal_restitution"] == pytest.approx(e, rel=1e-7)
    assert cal.estimates["stiffness"] == pytest.approx(c, rel=1e-7)


def test_recovers_clipped_kelvin_voigt_from_ode_data() -> None:
    """F = max(0, k·x + d·ẋ), d = 2ζ√(k·m), ζ = −ln e/√(π² + ln² e) (textbook), written here;
    contact ends where the force falls to 0."""
    m, k, e = 0.1, 4e6, 0.62
    zeta = -math.log(e) / math.hypot(math.pi, math.log(e))
    d = 2.0 * zeta * math.sqrt(k * m)

    def push(x, v):
        return k * x + d * v

    def force(x, v):
        return max(0.0, push(x, v)) if x > 0.0 else 0.0

    def peak(_t, y):  # dF/dt = k·ẋ + d·ẍ = 0
        return k * y[1] - d * force(y[0], y[1]) / m

    rows = [{"velocity_m_s": v0, **impact(m, v0, force, peak, push)} for v0 in VELOCITIES]
    data = pd.DataFrame(rows)[["velocity_m_s", "restitution", "duration_s"]]
    assert np.ptp(data["restitution"]) < 1e-9  # a linear law: the same bounce at every V0
    start = BallOnPlate(model="kelvin-voigt-clipped", nominal_restitution=0.9, exponent=1.0,
                        stiffness=1e6)
    cal = calibrate(measurements(data), start)
    assert cal.estimates["nominal_restitution"] == pytest.approx(e, rel=1e-7)
    assert cal.estimates["stiffness"] == pytest.approx(k, rel=1e-7)
