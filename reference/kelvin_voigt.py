"""The linear Kelvin–Voigt spring–damper impact in closed form, clipped (F ≥ 0) and unclipped.

Physics (SI). A mass m hits a fixed obstacle at V0 > 0; while the penetration x > 0,

    m·ẍ = −(k·x + d·ẋ),   x(0) = 0, ẋ(0) = V0,

with ωn = √(k/m), ζ = d/(2√(k·m)) < 1 (underdamped), s = √(1−ζ²), ωd = ωn·s, σ = ζ·ωn:

    x(t) = (V0/ωd)·e^(−σt)·sin(ωd·t),
    F(t) = k·x + d·ẋ = m·V0·ωn·e^(−σt)·sin(ωd·t + ψ)/s,   ψ = 2·asin ζ.

The force starts with a jump F(0) = d·V0 and vanishes at the phase ωd·t = π − ψ while the body
still penetrates.

- **unclipped** (the force may pull, F < 0): contact ends at x = 0, ωd·T = π,
  restitution k = exp(−ζπ/s) (the textbook value; ζ from a nominal e is ζ = −ln e/√(π² + ln² e)).
- **clipped** (F = max(0, k·x + d·ẋ), as MuJoCo, Bullet and most engines do): contact ends where
  F = 0, θe = ωd·T = π − ψ, and k = −e^(−ζθe/s)·(cos θe − ζ/s·sin θe).
- peak force (both): dF/dt = 0 at ωd·t* = acos ζ − ψ if ζ ≤ ½, where F_max = m·V0·ωn·e^(−σt*);
  for ζ > ½ the largest force is the initial jump F(0) = d·V0 = 2ζ·m·ωn·V0.
- max penetration (ẋ = 0 at ωd·t = acos ζ): x_max = (V0/ωn)·exp(−ζ·acos ζ/s).
- lost kinetic energy fraction 1 − k² (the force is the only one acting).

Restitution depends on ζ alone, duration on (ζ, ωn), and every metric is exact.
``impactbench.engines.common`` imports :func:`clipped_phase` and :func:`clipped_restitution` from
here for its native conversion (one implementation).
"""

from __future__ import annotations

import math

import numpy as np
from impactbench.reference import validation as check
from impactbench.reference.record import ImpactRecord, Status


def clipped_phase(zeta: float) -> float:
    """θe = ωd·T of the clipped spring–damper (rad), for 0 ≤ ζ < 1."""
    s = math.sqrt(1.0 - zeta * zeta)
    return math.pi - math.atan2(2.0 * zeta * s, 1.0 - 2.0 * zeta * zeta)


def clipped_restitution(zeta: float) -> float:
    """Restitution e(ζ) of the clipped linear spring–damper, for 0 ≤ ζ < 1."""
    s = math.sqrt(1.0 - zeta * zeta)
    th = clipped_phase(zeta)
    return -math.exp(-zeta * th / s) * (math.cos(th) - zeta / s * math.sin(th))


def unclipped_restitution(zeta: float) -> float:
    """Restitution exp(−ζπ/√(1−ζ²)) of the unclipped spring–damper, for 0 ≤ ζ < 1."""
    return math.exp(-zeta * math.pi / math.sqrt(1.0 - zeta * zeta))


def zeta_from_restitution(restitution: float) -> float:
    """ζ = −ln e/√(π² + ln² e): the damping ratio whose unclipped restitution is e ∈ (0, 1]."""
    e = check.positive("nominal_restitution", restitution)
    if e > 1.0:
        raise ValueError(f"nominal_restitution = {restitution!r}: must be in (0, 1]")
    ln_e = math.log(e)
    return -ln_e / math.hypot(math.pi, ln_e)


def _check_zeta(zeta: float) -> float:
    z = check.non_negative("zeta", zeta)
    if z >= 1.0:
        raise ValueError(f"zeta = {zeta!r}: must be < 1 (an underdamped contact)")
    return z


def solve(mass_kg: float, stiffness_n_per_m: float, damping_ns_per_m: float,
          velocity_m_s: float, clipped: bool) -> dict[str, float]:
    """The five ball-on-plate metrics (SI) of the linear spring–damper impact (module doc)."""
    m = check.positive("mass_kg", mass_kg)
    k = check.positive("stiffness", stiffness_n_per_m)
    d = check.non_negative("damping_ns_per_m", damping_ns_per_m)
    v0 = check.positive("velocity_m_s", velocity_m_s)
    wn = math.sqrt(k / m)
    z = _check_zeta(d / (2.0 * math.sqrt(k * m)))
    s = math.sqrt(1.0 - z * z)
    if clipped:
        phase, restitution = clipped_phase(z), clipped_restitution(z)
    else:
        phase, restitution = math.pi, unclipped_restitution(z)
    if z <= 0.5:
        t_peak = (math.acos(z) - 2.0 * math.asin(z)) / (wn * s)
        peak = m * v0 * wn * math.exp(-z * wn * t_peak)
    else:
        peak = d * v0
    return {
        "restitution": restitution,
        "duration_s": phase / (wn * s),
        "peak_force_n": peak,
        "max_penetration_m": v0 / wn * math.exp(-z * math.acos(z) / s),
        "energy_loss_fraction": (1.0 - restitution) * (1.0 + restitution),
    }


def history(mass_kg: float, stiffness_n_per_m: float, damping_ns_per_m: float,
            velocity_m_s: float, clipped: bool, samples: int = 4001,
            meta: dict | None = None) -> ImpactRecord:
    """Exact time history of the impact as an :class:`ImpactRecord`.

    ``samples`` points: the contact [0, T] evenly (first touch and separation included, the
    instant of peak force inserted) plus four samples of free flight on each side. The
    unclipped law's force turns negative (it pulls) before x returns to 0; the record keeps
    that force as it is.
    """
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 16:
        raise ValueError(f"samples = {samples!r}: must be an integer >= 16")
    metrics = solve(mass_kg, stiffness_n_per_m, damping_ns_per_m, velocity_m_s, clipped)
    m, k, d, v0 = mass_kg, stiffness_n_per_m, damping_ns_per_m, velocity_m_s
    wn = math.sqrt(k / m)
    z = d / (2.0 * math.sqrt(k * m))
    wd, sigma = wn * math.sqrt(1.0 - z * z), z * wn
    total = metrics["duration_s"]
    pad = 4
    t_in = np.linspace(0.0, total, samples - 2 * pad - 1)
    t_peak = (math.acos(z) - 2.0 * math.asin(z)) / wd if z < 0.5 else total / 2.0
    t_in = np.sort(np.append(t_in, t_peak))  # the peak force is an exact sample
    decay = np.exp(-sigma * t_in)
    x = v0 / wd * decay * np.sin(wd * t_in)
    v = v0 * decay * (np.cos(wd * t_in) - sigma / wd * np.sin(wd * t_in))
    x[0] = 0.0
    if not clipped:
        x[-1] = 0.0
    f = k * x + d * v
    # first touch: F(0⁺) = d·V0 is the peak when ζ > ½ (recorded there); otherwise x = 0 and
    # F = 0 (the metrics path then locates the start at the zero of x, exactly t = 0)
    f[0] = d * v0 if z > 0.5 else 0.0
    f[-1] = 0.0  # separation: F = 0 (clipped) or x = 0 (unclipped)
    if clipped:
        f = np.maximum(f, 0.0)
    dt = total / (t_in.size - 2)
    v_end, x_end = float(v[-1]), float(x[-1])
    before = -dt * np.arange(pad, 0, -1)
    after = dt * np.arange(1, pad + 1)
    t = np.concatenate([before, t_in, total + after])
    xs = np.concatenate([v0 * before, x, x_end + v_end * after])
    vs = np.concatenate([np.full(pad, v0), v, np.full(pad, v_end)])
    fs = np.concatenate([np.zeros(pad), f, np.zeros(pad)])
    return ImpactRecord(
        time_s=t, penetration_m=xs, penetration_rate_m_s=vs, normal_force_n=fs,
        velocity_1_m_s=vs, velocity_2_m_s=np.zeros_like(t), mass_1_kg=m,
        mass_2_kg=math.inf, status=Status.OK, meta=dict(meta or {}),
    )
