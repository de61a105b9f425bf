"""The shared metrics on synthetic records with known answers (clipped spring–damper)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from impactbench.engines.common import SpringDamper
from impactbench.reference import metrics
from impactbench.reference.record import ImpactRecord


def spring_damper_history(k: float, d: float, m: float, v0: float, dt: float,
                          pre_s: float = 2e-6) -> tuple[np.ndarray, ...]:
    """Exact sampled (t, x, ẋ, F) of a mass m meeting a clipped linear spring–damper at v0,
    from ``pre_s`` before the touch."""
    wn = math.sqrt(k / m)
    zeta = d / (2 * math.sqrt(k * m))
    wd = wn * math.sqrt(1 - zeta**2)
    t = np.arange(-pre_s, 3.0 * math.pi / wd, dt)
    tc = np.clip(t, 0.0, None)
    decay = np.exp(-zeta * wn * tc)
    x = v0 / wd * decay * np.sin(wd * tc)
    v = v0 * decay * (np.cos(wd * tc) - zeta * wn / wd * np.sin(wd * tc))
    f = k * x + d * v
    # after the force first vanishes the body flies free at its release velocity
    release = np.flatnonzero((t > 0) & (f <= 0))[0]
    v[release:] = v[release]
    x[release:] = x[release] + v[release] * (t[release:] - t[release])
    f[release:] = 0.0
    x[t < 0] = v0 * t[t < 0]
    f[t < 0] = 0.0
    return t, x, v, f


def spring_damper_record(k: float, d: float, m: float, v0: float, dt: float,
                         pre_s: float = 2e-6) -> ImpactRecord:
    """Exact sampled history of a ball (mass m) hitting a clipped linear spring–damper."""
    t, x, v, f = spring_damper_history(k, d, m, v0, dt, pre_s)
    return ImpactRecord(t, x, v, f, v, np.zeros_like(t), mass_1_kg=m)


def test_clipped_spring_damper_metrics_match_closed_form() -> None:
    m, k, d, v0 = 0.1, 1.4e8, 700.0, 1.0
    sd = SpringDamper(k, d)
    rec = spring_damper_record(k, d, m, v0, dt=1e-8)
    got = metrics.compute(rec)
    assert got["impacts"] == 1
    assert got["duration_s"] == pytest.approx(sd.duration_s(m), rel=1e-4)
    assert got["restitution"] == pytest.approx(sd.restitution(m), rel=1e-4)
    # impulse = m·(1 + e)·v0 and the lost energy = 1 − e² for a rigid obstacle
    assert got["impulse_ns"] == pytest.approx(m * v0 * (1 + sd.restitution(m)), rel=1e-4)
    assert got["energy_loss_fraction"] == pytest.approx(1 - sd.restitution(m) ** 2, rel=1e-3)
    assert got["pulse_width_s"] == got["contact_time_s"] == got["duration_s"]


def test_contact_edges_are_interpolated_between_samples() -> None:
    """Coarse sampling still locates start and end well inside one step."""
    m, k, d, v0 = 0.1, 1.4e8, 700.0, 1.0
    sd = SpringDamper(k, d)
    dt = sd.duration_s(m) / 37.3
    rec = spring_damper_record(k, d, m, v0, dt=dt, pre_s=3.3 * dt)
    (c,) = metrics.contacts(rec)
    # linear interpolation of x across the step errs by ≤ ½·|ẍ|·dt²/v0, ẍ(0⁺) = −d·v0/m
    assert abs(c.start_s) < 0.5 * (d / m) * dt**2
    assert abs(c.end_s - sd.duration_s(m)) < 0.05 * dt


def test_two_contacts_are_counted_and_spanned() -> None:
    t = np.linspace(0.0, 10.0, 1001)
    f = np.where((t > 1) & (t < 2), 1.0, 0.0) + np.where((t > 5) & (t < 7), 2.0, 0.0)
    x = np.where(f > 0, 0.1, -0.1)
    rec = ImpactRecord(t, x, np.ones_like(t), f, np.ones_like(t), np.zeros_like(t),
                       mass_1_kg=1.0)
    got = metrics.compute(rec)
    assert got["impacts"] == 2
    assert got["pulse_width_s"] == pytest.approx(6.0, abs=0.02)
    assert got["contact_time_s"] == pytest.approx(3.0, abs=0.02)
    assert got["impulse_ns"] == pytest.approx(5.0, abs=0.05)


def test_no_contact_gives_nan_metrics() -> None:
    t = np.linspace(0, 1, 11)
    rec = ImpactRecord(t, -t, np.ones_like(t), np.zeros_like(t), np.ones_like(t),
                       np.zeros_like(t), mass_1_kg=1.0)
    got = metrics.compute(rec)
    assert got["impacts"] == 0
    assert math.isnan(got["peak_force_n"])
    assert metrics.compute(ImpactRecord.failed("crashed", "boom"))["impacts"] == 0


def test_relative_error() -> None:
    assert metrics.relative_error(1.1, 1.0) == pytest.approx(0.1)
    assert metrics.relative_error(-1.1, -1.0) == pytest.approx(-0.1)
    assert math.isnan(metrics.relative_error(math.nan, 1.0))
    assert metrics.relative_error(0.0, 0.0) == 0.0


def _release_record(tail: str) -> ImpactRecord:
    """Ball leaving a contact at x = 1 µm → 0 in 10 µs: force ``tail`` ends the contact early
    (a linear let-go at t = 0 with Bullet-like clamp dust after) or fades (exponential)."""
    t = np.linspace(-10e-6, 20e-6, 3001)
    x = 1e-6 * (1.0 - t / 10e-6)
    if tail == "let-go":
        f = np.where(t < 0, -t / 10e-6, 1e-20)  # 1 at t = −10 µs → 0 at t = 0, then dust
    else:
        f = np.exp(-t / 0.2e-6)  # e^-50 at t = 10 µs: below 1e-13 from t = 6 µs
    f = np.where(x > 0, f, 0.0)
    v = np.full_like(t, -0.1)
    return ImpactRecord(t, x, v, f, v, np.zeros_like(t), mass_1_kg=1.0)


def test_faded_force_lasts_until_the_surfaces_part_but_a_let_go_does_not() -> None:
    """Issue 16: one contact-end rule. A force fading geometrically below the floor (Hunt–
    Crossley's 1 + b·ẋ = e^(−∫…)) keeps the contact until x = 0; a force reaching zero at a
    finite rate ends it there, and the dust an engine clamp leaves after it is not contact."""
    (fade,) = metrics.contacts(_release_record("fade"))
    assert fade.end_s == pytest.approx(10e-6, abs=1e-12)
    (let_go,) = metrics.contacts(_release_record("let-go"))
    assert let_go.end_s == pytest.approx(0.0, abs=1e-12)
