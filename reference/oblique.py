"""Oblique impact of a sphere (or disc) on a plate, with Coulomb friction and spin (MODELS.md
§3).

A sphere of mass m, radius R and radius of gyration k (solid sphere k² = 2R²/5; with
``shape = "disc"``, the 2D engines' circle, a solid disc k² = R²/2: the same equations with
its k, :attr:`Oblique.gyration_ratio` and :attr:`Oblique.spin_factor` = 1 + R²/k²) hits a plate
at speed V, incidence angle θ from the plate normal n, spin ω0 about n × t (t: the incoming
tangential direction; ω0 > 0 is forward rolling). Normal and tangential components
v_n = V·cos θ, v_t = V·sin θ; the contact point's slip is s = v_t − R·ω. The normal contact
is any law of the zoo (:mod:`impactbench.reference.models`: Hunt–Crossley by default, the
preprint's steel ball), set up at the *normal* impact velocity v_n (a law given by a nominal
restitution gets b = α(e)/v_n); its restitution is e = e(v_n) of that law.

With a centre-of-mass contact (sphere on a plane) the normal problem does not feel the
tangential one, and the tangential force F_t only changes v_t and ω:

    m·v̇_t = F_t,   m·k²·ω̇ = −R·F_t,   so   ṡ = F_t·(1 + R²/k²)/m.

**Rigid tangential theory** (ideal Coulomb μ, no tangential compliance; Routh 1905, Brach 1991,
Stronge 2000). While the contact slips, |F_t| = μ·F_n against the slip, so the tangential
impulse is μ times the normal impulse P_n(t) = m·(v_n − ẋ(t)) whatever the normal law; the slip
falls by μ·(1 + R²/k²)·P_n/m and stops if it reaches zero; after that the required tangential
force is zero (ṡ = 0 needs F_t = 0 ≤ μ·F_n) and the sphere rolls. Hence (:func:`rigid`):

- s0 = V·sin θ − R·ω0;
- gross sliding when |s0| > μ·(1 + e)·v_n·(1 + R²/k²): Δv_t = −μ(1 + e)·v_n·sign(s0),
  Δω = (R/k²)·μ(1 + e)·v_n·sign(s0);
- otherwise rolling after: v_t' = v_t − s0/(1 + R²/k²), ω' = v_t'/R;
- the slip stops at the normal velocity ẋ_s = v_n − |s0|/(μ·(1 + R²/k²)), so the largest
  tangential force is μ times the largest normal force before then: μ·F_n(ẋ_s) when the normal
  force is still rising there, else μ·F_max. For the Hunt–Crossley family F_n(ẋ) is closed
  form through the first integral Π(x) = m·[Δ·ẋ/(1 + bẋ) + Δ²/(1 + bẋ)²·G(bΔ/(1 + bẋ))],
  Δ = v_n − ẋ, G(y) = (y − ln(1 + y))/y² (MODELS.md §1 rewritten without cancellation); it
  rises while n·ẋ > b·c·x^(n+1)/m. For the clipped Kelvin–Voigt law ẋ(t) is closed form and
  t_s is its root (bracketed on [0, T]).
Normal metrics (restitution, duration, peak force) are the zoo's closed forms
(:func:`impactbench.reference.zoo.sweep`), so the whole table is exact and vectorised over
angles (:func:`rigid_sweep`). The direct time integration of
:mod:`impactbench.reference.oblique_integrate` checks it (agreement ≤ 1e-8).

**Tangentially compliant references** (:mod:`impactbench.reference.oblique_integrate`, which
states the laws and their sources), with Mindlin's no-slip stiffness k_t = 8·G*·a,
a = √(R·x), 1/G* = (2 − ν₁)/G₁ + (2 − ν₂)/G₂, G = E/(2(1 + ν)); a rigid plate (E₂ = ∞) drops
its term:

- ``tangential = "mindlin"`` (:func:`~impactbench.reference.oblique_integrate.mindlin`): the
  DEM codes' simplified "Hertz–Mindlin no-slip" law (Chung & Ooi 2011), an incremental
  history dF_t = −k_t·ds, scaled with the contact radius while the contact shrinks and capped
  at |F_t| ≤ μ·F_n, integrated event by event;
- ``tangential = "mindlin-deresiewicz"``
  (:func:`~impactbench.reference.oblique_integrate.mindlin_deresiewicz`, the suite's compliant
  reference, :data:`COMPLIANT_DEFAULT`): the full Cattaneo–Mindlin/Mindlin–Deresiewicz law —
  micro-slip in an annulus, Masing's unloading and reloading, and each point of the contact
  leaving with its own displacement — through the method of dimensionality reduction. It is
  the one that fits Kharaz et al.'s measurements at every angle: below 5° the no-slip law's
  tangential restitution is 0.88 against 0.79 measured (its unloading rule, mostly), this law's
  0.78.

The scenario's dataclass :class:`Oblique` and its cases (``kharaz2001``) live in
:mod:`impactbench.reference.oblique_scenario` (light to import) and are re-exported here.

Sources of the rigid theory: E. J. Routh, *Dynamics of a System of Rigid Bodies, Elementary
Part*, 7th ed., Macmillan, 1905; R. M. Brach, *Mechanical Impact Dynamics*, Wiley, 1991;
W. J. Stronge, *Impact Mechanics*, Cambridge University Press, 2000.

**Metrics** (:func:`metrics_of`, one function for both references and engine records):

- ``restitution``: e = v_n'/v_n (the centre's normal velocity after over before);
- ``tangential_restitution``: v_t'/v_t of the centre (NaN at θ = 0);
- ``contact_point_ratio``: β = −s'/s0 (−1 frictionless, 0 rolling after, > 0 the contact point
  reversed; NaN when s0 = 0);
- ``rebound_angle_deg``: atan2(v_t', v_n') of the centre's rebound velocity from the normal;
- ``spin_out_rad_s``: ω' (signed as ω0: positive is forward rolling);
- ``regime``: a number, 1.0 = *slide* (the contact point leaves still slipping the incoming
  way, β < −:data:`REGIME_TOLERANCE`), 0.0 = *stick* (the slip stopped or reversed during the
  contact: β ≥ −tolerance; also s0 = 0). For the rigid theory 1.0 is gross sliding (but
  within 0.1 % of the threshold, where β ∈ (−1e-3, 0)); the tolerance leaves room for an
  engine's step-size noise. With tangential compliance the contact may slide at the end after
  sticking (β < 0 again): the label says how the contact point leaves, not its history;
- ``duration_s``, ``peak_force_n``: the normal contact's duration and largest normal force;
- ``peak_tangential_force_n``: the largest |F_t|.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
import pandas as pd
from impactbench.reference.models import HYSTERESIS_MODELS, KelvinVoigt
from impactbench.reference.oblique_metrics import metrics_of, record_metrics
from impactbench.reference.oblique_scenario import (
    CASE_POINTS,
    CASES,
    COMPLIANT_DEFAULT,
    GYRATION_RATIO,
    OBLIQUE_METRICS,
    OBLIQUE_MODELS,
    REGIME_TOLERANCE,
    SHAPES,
    SLIDE,
    SPIN_FACTOR,
    STICK,
    TANGENTIAL_MODELS,
    Oblique,
)
from impactbench.reference.scenarios import BallOnPlate

__all__ = [
    "CASES",
    "CASE_POINTS",
    "COMPLIANT_DEFAULT",
    "GYRATION_RATIO",
    "OBLIQUE_METRICS",
    "OBLIQUE_MODELS",
    "REGIME_TOLERANCE",
    "SHAPES",
    "SLIDE",
    "SPIN_FACTOR",
    "STICK",
    "TANGENTIAL_MODELS",
    "Oblique",
    "metrics_of",
    "normal_sweep",
    "record_metrics",
    "rigid",
    "rigid_sweep",
    "solve",
    "sweep",
    "threshold_angle_deg",
]


# ------------------------------------------------------------------------------ rigid theory


def _angles(scenario: Oblique, angles_deg: Iterable[float] | np.ndarray | None) -> np.ndarray:
    if angles_deg is None:
        return np.asarray([scenario.angle_deg], dtype=float)
    a = np.atleast_1d(np.asarray(list(angles_deg) if not isinstance(angles_deg, np.ndarray)
                                 else angles_deg, dtype=float)).reshape(-1)
    for value in a:  # validated as the scenario would (one line naming the field)
        scenario.replace(angle_deg=float(value))
    return a


def normal_sweep(scenario: Oblique, normal_velocities: np.ndarray) -> pd.DataFrame:
    """The normal law's closed-form metrics (the zoo's) at each normal velocity."""
    from impactbench.reference.zoo import sweep

    v = np.asarray(normal_velocities, dtype=float)
    return sweep(scenario.normal_scenario(float(v[0])), v)


def _hc_force_at(ball: BallOnPlate, v_n: np.ndarray, xdot: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(F_n, rising?) of the power-law Hunt–Crossley family at normal velocity ẋ ∈ (0, v_n]
    on the compression branch, from the first integral (module doc; no cancellation)."""
    from impactbench.reference.hunt_crossley import _g2

    m, c, n = ball.mass_kg, ball.stiffness, ball.exponent
    b = np.asarray(ball.damping_s_per_m if ball.nominal_restitution is None
                   else HYSTERESIS_MODELS[ball.model].alpha(float(ball.nominal_restitution))
                   / v_n, dtype=float)
    d = v_n - xdot
    w = 1.0 + b * xdot
    pot = m * (d * xdot / w + (d / w) ** 2 * _g2(b * d / w))
    x = ((n + 1.0) * pot / c) ** (1.0 / (n + 1.0))
    force = c * x**n * w
    rising = n * xdot > b * c * x ** (n + 1.0) / m
    return force, rising


def _kv_force_at(ball: BallOnPlate, v_n: float, xdot: float, duration: float
                 ) -> tuple[float, bool]:
    """(F_n, rising?) of the clipped Kelvin–Voigt law when the normal velocity is ẋ
    (closed form x(t), ẋ(t); t from a bracketed root on [0, T])."""
    from scipy import optimize

    law = ball.law()
    assert isinstance(law, KelvinVoigt)
    m, k, d = ball.mass_kg, law.stiffness, law.damping_ns_per_m
    wn = math.sqrt(k / m)
    zeta = d / (2.0 * math.sqrt(k * m))
    wd = wn * math.sqrt(1.0 - zeta * zeta)
    sig = zeta * wn

    def x_of(t: float) -> float:
        return v_n / wd * math.exp(-sig * t) * math.sin(wd * t)

    def v_of(t: float) -> float:
        return v_n * math.exp(-sig * t) * (math.cos(wd * t) - sig / wd * math.sin(wd * t))

    if xdot >= v_n:
        t = 0.0
    else:
        t = optimize.brentq(lambda s: v_of(s) - xdot, 0.0, duration, xtol=1e-15 * duration,
                            rtol=4.0 * np.finfo(float).eps, maxiter=400)
    x, v = x_of(t), v_of(t)
    force = max(0.0, k * x + d * v)
    return force, k * v - d * force / m > 0.0


def _peak_tangential(scenario: Oblique, v_n: np.ndarray, s0: np.ndarray, slide: np.ndarray,
                     peak: np.ndarray, duration: np.ndarray) -> np.ndarray:
    """μ times the largest normal force while the contact slips (module doc)."""
    mu = scenario.friction
    out = mu * peak
    stuck = ~slide & (s0 != 0.0) & (mu > 0.0)
    out = np.where((s0 == 0.0) | (mu == 0.0), 0.0, out)
    if not np.any(stuck):
        return out
    xdot_s = np.where(stuck, v_n - np.abs(s0) / (mu * scenario.spin_factor), 0.0)
    early = stuck & (xdot_s > 0.0)  # stops in the compression phase: maybe before the peak
    if not np.any(early):
        return out
    ball = scenario.normal_scenario(float(v_n[0]))
    if ball.is_linear:
        for i in np.flatnonzero(early):
            f, rising = _kv_force_at(scenario.normal_scenario(float(v_n[i])), float(v_n[i]),
                                     float(xdot_s[i]), float(duration[i]))
            if rising:
                out[i] = mu * f
        return out
    idx = np.flatnonzero(early)
    f, rising = _hc_force_at(ball, v_n[idx], xdot_s[idx])
    out[idx] = np.where(rising, mu * f, out[idx])
    return out


def rigid_sweep(scenario: Oblique, angles_deg: Iterable[float] | np.ndarray | None = None
                ) -> pd.DataFrame:
    """The rigid tangential theory in closed form (module doc), vectorised over angles.

    Returns ``angle_deg``, ``velocity_m_s`` and the :data:`OBLIQUE_METRICS` columns, one row
    per angle (the scenario's own angle when ``angles_deg`` is None), with the scenario's V,
    μ, ω0 and normal law.
    """
    if not isinstance(scenario, Oblique):
        raise ValueError(f"scenario = {scenario!r}: must be an Oblique")
    angles = _angles(scenario, angles_deg)
    v, r, w0, mu = scenario.velocity_m_s, scenario.radius_m, scenario.spin_rad_s, \
        scenario.friction
    th = np.radians(angles)
    v_n, v_t = v * np.cos(th), v * np.sin(th)
    normal = normal_sweep(scenario, v_n)
    e = normal["restitution"].to_numpy()
    duration = normal["duration_s"].to_numpy()
    peak = normal["peak_force_n"].to_numpy()
    s0 = v_t - r * w0
    impulse = mu * (1.0 + e) * v_n  # μ·P_n/m
    factor = scenario.spin_factor  # 1 + R²/k²
    slide = np.abs(s0) > impulse * factor
    sign = np.sign(s0)
    vt_slide = v_t - impulse * sign
    w_slide = w0 + r / (scenario.gyration_ratio * r * r) * impulse * sign
    vt_roll = v_t - s0 / factor
    vt_out = np.where(slide, vt_slide, vt_roll)
    w_out = np.where(slide, w_slide, vt_roll / r)
    peak_t = _peak_tangential(scenario, v_n, s0, slide, peak, duration)
    m = metrics_of(v, angles, w0, r, normal_velocity_out=e * v_n, tangential_velocity_out=vt_out,
                   spin_out=w_out, duration_s=duration, peak_force_n=peak,
                   peak_tangential_force_n=peak_t)
    return pd.DataFrame({"angle_deg": angles, "velocity_m_s": np.full(angles.shape, v),
                         **{k: np.asarray(m[k], dtype=float) for k in OBLIQUE_METRICS}})


def rigid(scenario: Oblique) -> dict[str, float]:
    """The rigid tangential theory's :data:`OBLIQUE_METRICS` for one scenario (exact)."""
    row = rigid_sweep(scenario).iloc[0]
    return {k: float(row[k]) for k in OBLIQUE_METRICS}


def threshold_angle_deg(scenario: Oblique) -> float:
    """The incidence angle (degrees) above which the ball slides through the whole impact,
    without initial spin: tan θ_c = (1 + R²/k²)·μ·(1 + e) (3.5·μ·(1 + e) for a sphere, 3·μ·(1 + e)
    for a disc) (e at that angle's normal velocity:
    found by bisection when e depends on v_n). NaN when ω0 ≠ 0 (no single threshold)."""
    if scenario.spin_rad_s != 0.0:
        return math.nan
    from scipy import optimize

    def gap(theta: float) -> float:
        v_n = scenario.velocity_m_s * math.cos(theta)
        e = float(normal_sweep(scenario, np.asarray([v_n]))["restitution"].iloc[0])
        return math.tan(theta) - scenario.spin_factor * scenario.friction * (1.0 + e)

    if scenario.friction == 0.0:
        return 0.0
    hi = math.radians(89.999999)
    if gap(hi) <= 0.0:
        return math.nan
    return math.degrees(optimize.brentq(gap, 0.0, hi, xtol=1e-15, rtol=1e-15))


def solve(scenario: Oblique) -> dict[str, float]:
    """The scenario's reference: the rigid closed form or the compliant integration
    (``mindlin`` or ``mindlin-deresiewicz``)."""
    if not isinstance(scenario, Oblique):
        raise ValueError(f"scenario = {scenario!r}: must be an Oblique")
    if scenario.tangential == "rigid":
        return rigid(scenario)
    from impactbench.reference.oblique_integrate import compliant

    return compliant(scenario)


def sweep(scenario: Oblique, angles_deg: Iterable[float] | np.ndarray) -> pd.DataFrame:
    """``angle_deg``, ``velocity_m_s`` and the metrics over angles, with the scenario's
    tangential model (rigid: one vectorised closed form; the compliant laws: one integration
    each)."""
    if scenario.tangential == "rigid":
        return rigid_sweep(scenario, angles_deg)
    angles = _angles(scenario, angles_deg)
    rows = [{"angle_deg": a, "velocity_m_s": scenario.velocity_m_s,
             **solve(scenario.replace(angle_deg=float(a)))} for a in angles]
    return pd.DataFrame(rows, columns=["angle_deg", "velocity_m_s", *OBLIQUE_METRICS])
