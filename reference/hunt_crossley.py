"""Hunt–Crossley impact of a body on a fixed obstacle (MODELS.md §1): closed form and quadrature.

Physics (SI). A body of mass m hits a fixed obstacle at V0 > 0; while the penetration x > 0,

    m·ẍ = −f(x)·(1 + b·ẋ),   x(0) = 0, ẋ(0) = V0,   f(x) = c·xⁿ or any increasing f, f(0) = 0.

Eliminating t (ẍ = V·dV/dx) gives the first integral with g(y) = y − ln(1 + y):

    Π(x) = (m/b²)·[g(α) − g(b·V)],   α = b·V0,   Π(x) = ∫₀ˣ f.

**The velocity variable.** Everything here is parametrised by ũ = ln(1 + b·V)/α (so
V = V0·(e^(αũ) − 1)/α and ũ = V/V0 when b = 0). In ũ the first integral reads

    Π(x) = m·V0²·H(ũ),   H(ũ) = [g(α) − p(αũ)]/α²,   p(y) = eʸ − 1 − y,

an entire function of ũ, and dt = −m·V0·dũ / f(x). The contact runs from ũ_c = ln(1+α)/α
(x = 0, approach) through ũ = 0 (x = x_max) to ũ_r < 0 (x = 0, separation), the other root of
H = 0. Every expression is evaluated in a form without cancellation that stays valid for
b → 0 (the Hertz limit is the same code at α = 0), so no Lambert W value near its branch point
z = −1/e is ever used unrefined:

- restitution k = (1 − e^(αũ_r))/α. The Lambert W closed form k = (1 + W₀(−(1+α)e^(−(1+α))))/α
  gives the start value; Newton steps on H(ũ_r) = 0 polish it to machine precision.
- max penetration: Π(x_max) = m·V0²·g(α)/α² (→ ½·m·V0² at b = 0).
- duration T = m·V0 ∫ dũ / f(x(ũ)) over [ũ_r, ũ_c]. For the power law f(x(ũ)) ∝ H^(n/(n+1)):
  the integrable end singularities (x → 0, where H vanishes linearly in ũ) are taken exactly by
  Gauss–Jacobi weights, the smooth rest by Gauss–Legendre panels graded toward ũ = 0 (for large
  α the restitution phase spans many e-folds of 1 + b·V). Relative error ≲ 1e-13.
- peak force F = f(x)·e^(αũ) in the compression phase, at the root of dF/dũ = 0
  (α·(n+1)·H = n·(e^(αũ) − 1)/α for the power law) by a bounded monotone Newton search.
- lost kinetic energy fraction 1 − k².

**Self-similarity** (power law): with x* = (m·V0²/c)^(1/(n+1)), t* = x*/V0, F* = c·x*ⁿ the
dimensionless problem depends on (α, n) only. :func:`sweep` solves it for every distinct α
directly when there are few, else builds a piecewise Chebyshev interpolant of the dimensionless
duration and peak force in s = ln(1 + α) with coefficients decaying below 1e-14 (checked), so
10⁶ velocities cost a few hundred dimensionless solves.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable
from functools import lru_cache
from typing import TYPE_CHECKING, Literal

import numpy as np
from impactbench.reference import validation as check
from impactbench.reference.laws import HuntCrossley
from impactbench.reference.metrics import BALL_METRICS
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate
from scipy import special

if TYPE_CHECKING:
    import pandas as pd

# pandas, scipy.integrate and scipy.optimize are imported where they are used: a sweep
# (``impactbench sweep ball-on-plate``) needs neither the quadrature nor the search, and the
# CLI writes its table without pandas (~0.3 s of start-up together).

Branch = Literal["compression", "restitution"]

_N_JACOBI = 40
_N_LEGENDRE = 24
_PANEL_U = 4.0  # graded restitution panels shrink until ≤ this many e-folds of 1 + b·V
_DIRECT_LIMIT = 256  # a sweep with more distinct α uses the Chebyshev interpolant
_CHEB_N = 32
_CHEB_TOL = 1e-14

# --------------------------------------------------------------------------------------------
# Cancellation-free elementary functions
# --------------------------------------------------------------------------------------------

_G_COEF = np.array([(-1.0) ** k / k for k in range(2, 32)])[::-1]  # (y − ln(1+y))/y²
_Q_COEF = np.array([1.0 / math.factorial(k) for k in range(2, 20)])[::-1]  # (eʸ − 1 − y)/y²


def _bounded_max(fn, a: float, b: float, xatol: float) -> float:
    """The maximum of a unimodal ``fn`` on [a, b]: a 65-node scan brackets it, then a bounded
    Brent search polishes it (never below the best node)."""
    nodes = np.linspace(a, b, 65)
    vals = np.array([fn(u) for u in nodes])
    i = int(np.argmax(vals))
    lo, hi = nodes[max(i - 1, 0)], nodes[min(i + 1, nodes.size - 1)]
    from scipy import optimize

    res = optimize.minimize_scalar(lambda u: -fn(u), bounds=(lo, hi), method="bounded",
                                   options={"xatol": xatol})
    return max(-float(res.fun), float(vals[i]))


def _series_near_zero(y: np.ndarray, coef: np.ndarray, closed) -> np.ndarray:
    """``closed(y)`` where |y| ≥ 0.2, its Taylor series ``coef`` near 0 (no cancellation)."""
    y = np.asarray(y, dtype=float)
    small = np.abs(y) < 0.2
    series = np.polyval(coef, np.where(small, y, 0.0))
    return np.where(small, series, closed(np.where(small, 1.0, y)))


def _g2(y: np.ndarray) -> np.ndarray:
    """G(y) = (y − ln(1+y))/y² for y > −1 (→ 1/2 at y = 0)."""
    return _series_near_zero(y, _G_COEF, lambda yb: (yb - np.log1p(yb)) / (yb * yb))


def _q2(y: np.ndarray) -> np.ndarray:
    """q(y) = (eʸ − 1 − y)/y² (→ 1/2 at y = 0)."""
    return _series_near_zero(y, _Q_COEF, lambda yb: (np.expm1(yb) - yb) / (yb * yb))


def _e1(y: np.ndarray) -> np.ndarray:
    """(eʸ − 1)/y (→ 1 at y = 0)."""
    y = np.asarray(y, dtype=float)
    zero = y == 0.0
    yb = np.where(zero, 1.0, y)
    return np.where(zero, 1.0, np.expm1(yb) / yb)


def _h_over_d(ut: np.ndarray, end: np.ndarray, a: np.ndarray) -> np.ndarray:
    """H(ũ)/(end − ũ) where ``end`` is a root of H (ũ_c or ũ_r); exact, no cancellation.

    H(ũ) = ũ·e1(αũ)·d·e1(αd) + d²·q(αd) with d = end − ũ: both terms have the sign of d
    on the physical branch, so their sum never cancels.
    """
    d = end - ut
    return ut * _e1(a * ut) * _e1(a * d) + d * _q2(a * d)


def _h(ut: np.ndarray, end: np.ndarray, a: np.ndarray) -> np.ndarray:
    """H(ũ) = Π(x)/(m·V0²) (dimensionless), measured from the root ``end``."""
    return (end - ut) * _h_over_d(ut, end, a)


def _u_compression(a: np.ndarray) -> np.ndarray:
    """ũ_c = ln(1+α)/α (→ 1 at α = 0): the velocity variable at first touch."""
    a = np.asarray(a, dtype=float)
    zero = a == 0.0
    ab = np.where(zero, 1.0, a)
    return np.where(zero, 1.0, np.log1p(ab) / ab)


def _lambert_guess(a: np.ndarray) -> np.ndarray:
    """ũ_r from the Lambert W closed form (accurate away from the branch point)."""
    a = np.asarray(a, dtype=float)
    big = a > 700.0  # z underflows: ω e^(−ω) = (1+α) e^(−(1+α)) ⇒ ln ω ≈ ln(1+α) − (1+α)
    ab = np.where(big | (a == 0.0), 1.0, a)
    z = -(1.0 + ab) * np.exp(-(1.0 + ab))
    w0 = special.lambertw(z, 0).real
    guess = np.log(np.maximum(-w0, 1e-300)) / ab
    asym = (np.log1p(a) - (1.0 + a)) / np.where(a == 0.0, 1.0, a)
    return np.where(big, asym, guess)


def _u_restitution(a: np.ndarray) -> np.ndarray:
    """ũ_r < 0, the root of H(ũ) = 0 on the restitution branch (→ −1 at α = 0).

    Solves ũ²·q(αũ) = G(α) (i.e. p(αũ) = g(α)) by Newton from the Lambert W value (for
    α ≥ 0.05) or from ũ = −1: the function is convex and decreasing for ũ < 0, so the
    iteration converges monotonically after at most one step.

    Only the points not yet converged iterate: after the first step over all of them, a
    sweep of 10⁶ velocities keeps iterating a few hundred (α < 0.05, started from −1), not
    the million. A point stops at the step that met the tolerance (≤ 4 ulp of ũ), where
    iterating the whole array until the last point converged moved it on by round-off.
    """
    a = np.asarray(a, dtype=float)
    target = _g2(a)
    u = np.where(a >= 0.05, _lambert_guess(a), -1.0)
    u = np.minimum(u, -1e-300)
    shape = u.shape
    u, a, target = u.reshape(-1), a.reshape(-1), target.reshape(-1)
    tol = 4.0 * np.finfo(float).eps
    active: np.ndarray | None = None  # indices still iterating; None: all (the first step)
    ua, aa, ta = u, a, target
    for _ in range(100):
        phi = ua * ua * _q2(aa * ua) - ta
        dphi = ua * _e1(aa * ua)
        step = phi / dphi
        ua = ua - step
        if active is None:
            u = ua
        else:
            u[active] = ua
        left = ~(np.abs(step) <= tol * np.abs(ua))
        if not left.any():
            break
        active = np.flatnonzero(left) if active is None else active[left]
        ua, aa, ta = ua[left], a[active], target[active]
    return u.reshape(shape)


# --------------------------------------------------------------------------------------------
# Closed forms
# --------------------------------------------------------------------------------------------


def restitution_lambert(alpha: float | np.ndarray) -> np.ndarray:
    """The textbook closed form k(α) = (1 + W₀(−(1+α)·e^(−(1+α))))/α (α = 0 → 1).

    Loses accuracy near the branch point (α → 0: relative error ~ √eps/α); use
    :func:`restitution`, which refines it.
    """
    a = np.asarray(alpha, dtype=float)
    ab = np.where(a == 0.0, 1.0, a)
    w0 = special.lambertw(-(1.0 + ab) * np.exp(-(1.0 + ab)), 0).real
    return np.where(a == 0.0, 1.0, (1.0 + w0) / ab)


def restitution(alpha: float | np.ndarray) -> float | np.ndarray:
    """Coefficient of restitution k(α) = −V_end/V0, α = b·V0 ≥ 0 (k(0) = 1).

    k solves (1+k)·α − ln(1+α) + ln(1 − kα) = 0, i.e. k = (1 + W₀(−(1+α)e^(−(1+α))))/α;
    evaluated as k = −ũ_r·e1(α·ũ_r) with ũ_r refined to machine precision (see module doc).
    Independent of f(x), m, c and n. Returns a float for scalar input.
    """
    a = np.asarray(alpha, dtype=float)
    if np.any(~np.isfinite(a)) or np.any(a < 0.0):
        bad = a[~(np.isfinite(a) & (a >= 0.0))].reshape(-1)[0]
        raise ValueError(f"alpha = {float(bad)!r}: must be >= 0 and finite")
    ur = _u_restitution(a)
    k = -ur * _e1(a * ur)
    return float(k) if k.ndim == 0 else k


def max_penetration_energy(alpha: float | np.ndarray) -> np.ndarray:
    """Π(x_max)/(m·V0²) = g(α)/α² (→ 1/2 at α = 0), dimensionless."""
    return _g2(np.asarray(alpha, dtype=float))


# --------------------------------------------------------------------------------------------
# Dimensionless power-law solve, vectorised over α
# --------------------------------------------------------------------------------------------


@lru_cache(maxsize=32)
def _jacobi(n: int, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    x, w = special.roots_jacobi(n, a, b)
    return x, w


@lru_cache(maxsize=8)
def _legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.polynomial.legendre.leggauss(n)


def _panels(a: np.ndarray, ur: np.ndarray) -> int:
    """Number K of halvings of the restitution range so the last panel spans ≤ 4 e-folds."""
    span = float(np.max(a * np.abs(ur))) if a.size else 0.0
    return max(1, math.ceil(math.log2(span / _PANEL_U))) if span > _PANEL_U else 1


def _compression_time(a: np.ndarray, n: float, uc: np.ndarray,
                      lo: np.ndarray | None = None) -> np.ndarray:
    """Dimensionless time ∫((n+1)H)^(−β) dũ over [``lo`` (default 0), ũ_c], β = n/(n+1).

    Gauss–Jacobi with the weight (ũ_c − ũ)^(−β) of the contact-start singularity.
    """
    beta = n / (n + 1.0)
    lo = np.zeros_like(uc) if lo is None else lo
    x, w = _jacobi(_N_JACOBI, -beta, 0.0)
    half = (uc - lo)[:, None] / 2.0
    u = lo[:, None] + half * (1.0 + x)
    psi = ((n + 1.0) * _h_over_d(u, uc[:, None], a[:, None])) ** (-beta)
    return half[:, 0] ** (1.0 - beta) * (psi @ w)


def _restitution_time(a: np.ndarray, n: float, ur: np.ndarray) -> np.ndarray:
    """Dimensionless time ∫((n+1)H)^(−β) dũ over [ũ_r, 0]: a Gauss–Jacobi panel
    [ũ_r, ũ_r/2] for the separation singularity, then Gauss–Legendre panels halving toward
    ũ = 0 until each spans ≤ 4 e-folds of 1 + b·V (large α)."""
    beta = n / (n + 1.0)
    a2 = a[:, None]
    xj, wj = _jacobi(_N_JACOBI, 0.0, -beta)
    half = (np.abs(ur) / 4.0)[:, None]
    u = ur[:, None] + half * (1.0 + xj)
    psi = ((n + 1.0) * -_h_over_d(u, ur[:, None], a2)) ** (-beta)
    tr = half[:, 0] ** (1.0 - beta) * (psi @ wj)
    xl, wl = _legendre(_N_LEGENDRE)
    k = _panels(a, ur)
    for j in range(1, k + 1):
        left = ur / 2.0**j
        right = ur / 2.0 ** (j + 1) if j < k else np.zeros_like(ur)
        half = ((right - left) / 2.0)[:, None]
        u = left[:, None] + half * (1.0 + xl)
        tr = tr + half[:, 0] * (((n + 1.0) * _h(u, ur[:, None], a2)) ** (-beta) @ wl)
    return tr


def _peak_u(a: np.ndarray, n: float, uc: np.ndarray) -> np.ndarray:
    """ũ* of the peak force: root of φ = α(n+1)H(ũ) − n·ũ·e1(αũ) on [0, ũ_c].

    φ is concave and decreasing with φ(0) ≥ 0 > φ(ũ_c): Newton from ũ_c converges
    monotonically (a bounded search that never leaves the compression phase).
    """
    u = uc.copy()
    for _ in range(200):
        phi = a * (n + 1.0) * _h(u, uc, a) - n * u * _e1(a * u)
        dphi = -a * (n + 1.0) * u * _e1(a * u) - n * np.exp(a * u)
        step = phi / dphi
        u = np.clip(u - step, 0.0, uc)
        if np.all(np.abs(step) <= 4.0 * np.finfo(float).eps * np.maximum(np.abs(u), 1e-300)):
            break
    return u


def dimensionless(alpha: float | np.ndarray, exponent: float) -> dict[str, np.ndarray]:
    """The power-law impact in units x*, t*, F* (module doc), vectorised over α.

    Returns arrays ``restitution``, ``duration`` (T/t*), ``peak_force`` (F_max/F*),
    ``max_penetration`` (x_max/x*), ``energy_loss_fraction``.
    """
    a = np.atleast_1d(np.asarray(alpha, dtype=float))
    n = float(exponent)
    uc = _u_compression(a)
    ur = _u_restitution(a)
    tc, tr = _compression_time(a, n, uc), _restitution_time(a, n, ur)
    us = _peak_u(a, n, uc)
    beta = n / (n + 1.0)
    peak = ((n + 1.0) * _h(us, uc, a)) ** beta * np.exp(a * us)
    k = -ur * _e1(a * ur)
    return {
        "restitution": k,
        "duration": tc + tr,
        "peak_force": peak,
        "max_penetration": ((n + 1.0) * _g2(a)) ** (1.0 / (n + 1.0)),
        "energy_loss_fraction": (1.0 - k) * (1.0 + k),
    }


def scales(mass_kg: float | np.ndarray, velocity_m_s: float | np.ndarray, stiffness: float,
           exponent: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x* in m, t* in s, F* in N) of the power law: x* = (m·V0²/c)^(1/(n+1))."""
    v = np.asarray(velocity_m_s, dtype=float)
    xs = (np.asarray(mass_kg, dtype=float) * v * v / stiffness) ** (1.0 / (exponent + 1.0))
    return xs, xs / v, stiffness * xs**exponent


# --------------------------------------------------------------------------------------------
# Public solvers
# --------------------------------------------------------------------------------------------


def _metrics(k: float, duration: float, peak: float, xmax: float) -> dict[str, float]:
    out = {
        "restitution": float(k),
        "duration_s": float(duration),
        "peak_force_n": float(peak),
        "max_penetration_m": float(xmax),
        "energy_loss_fraction": float((1.0 - k) * (1.0 + k)),
    }
    assert tuple(out) == BALL_METRICS
    return out


def solve(scenario: BallOnPlate) -> dict[str, float]:
    """The five ball-on-plate metrics (SI), keyed as
    :data:`impactbench.reference.metrics.BALL_METRICS`."""
    if not isinstance(scenario, BallOnPlate):
        raise ValueError(f"scenario = {scenario!r}: must be a BallOnPlate")
    if scenario.is_linear:  # a Kelvin–Voigt model of the zoo: its own closed form
        return _linear(scenario)
    return solve_law(scenario.law(), scenario.mass_kg, scenario.velocity_m_s)


def _linear(scenario: BallOnPlate, samples: int | None = None):
    """The Kelvin–Voigt models' metrics (or, with ``samples``, history), in closed form."""
    from impactbench.reference import kelvin_voigt

    law = scenario.law()
    args = (scenario.mass_kg, law.stiffness, law.damping_ns_per_m, scenario.velocity_m_s,
            law.clipped)
    if samples is None:
        return kelvin_voigt.solve(*args)
    return kelvin_voigt.history(*args, samples=samples, meta={
        "engine": "reference", "mode": "closed_form", "scenario": scenario.name,
        "parameters": scenario.to_dict()})


def solve_law(law: HuntCrossley, mass_kg: float, velocity_m_s: float) -> dict[str, float]:
    """Metrics of a Hunt–Crossley impact of mass ``mass_kg`` at ``velocity_m_s`` (SI).

    Power laws use the dimensionless solve; a callable f uses adaptive quadrature of the same
    integrals in physical units (:func:`_solve_general`).
    """
    m = check.positive("mass_kg", mass_kg)
    v0 = check.positive("velocity_m_s", velocity_m_s)
    if not isinstance(law, HuntCrossley):
        raise ValueError(f"law = {law!r}: must be a HuntCrossley")
    if not law.is_power_law:
        return _solve_general(law, m, v0)
    d = dimensionless(law.damping * v0, law.exponent)
    xs, ts, fs = scales(m, v0, law.stiffness, law.exponent)
    return _metrics(d["restitution"][0], d["duration"][0] * ts, d["peak_force"][0] * fs,
                    d["max_penetration"][0] * xs)


def _validated_velocities(velocities: Iterable[float] | np.ndarray) -> np.ndarray:
    v = np.atleast_1d(np.asarray(list(velocities) if not isinstance(velocities, np.ndarray)
                                 else velocities))
    if v.dtype.kind not in "fiu" or v.dtype.kind == "b":
        raise ValueError(f"velocities = {v[:3].tolist()!r}...: must be real numbers")
    v = v.astype(float).reshape(-1)
    bad = ~(np.isfinite(v) & (v > 0.0))
    if np.any(bad):
        raise ValueError(f"velocity_m_s = {float(v[bad][0])!r}: must be > 0 and finite")
    return v


def sweep(velocities: Iterable[float] | np.ndarray, *, mass_kg: float = 0.1,
          stiffness: float = 1.7135e10, exponent: float = 1.5,
          damping_s_per_m: float = 0.1) -> pd.DataFrame:
    """Metrics for many impact velocities of one power-law ball (vectorised, self-similar).

    Returns a DataFrame with ``velocity_m_s`` and the five :data:`BALL_METRICS` columns, in
    the order of ``velocities``.
    """
    import pandas as pd

    return pd.DataFrame(sweep_columns(velocities, mass_kg=mass_kg, stiffness=stiffness,
                                      exponent=exponent, damping_s_per_m=damping_s_per_m))


def sweep_columns(velocities: Iterable[float] | np.ndarray, *, mass_kg: float = 0.1,
                  stiffness: float = 1.7135e10, exponent: float = 1.5,
                  damping_s_per_m: float = 0.1) -> dict[str, np.ndarray]:
    """:func:`sweep`'s columns as numpy arrays (name → array), without pandas."""
    m = check.positive("mass_kg", mass_kg)
    c = check.positive("stiffness", stiffness)
    n = check.positive("exponent", exponent)
    b = check.non_negative("damping_s_per_m", damping_s_per_m)
    v = _validated_velocities(velocities)
    a = b * v
    k = restitution(a) if a.size else np.empty(0)
    k = np.atleast_1d(k)
    if a.size:
        tau, peak = _duration_peak(a, n)
    else:
        tau = peak = np.empty(0)
    xs, ts, fs = scales(m, v, c, n)
    return {
        "velocity_m_s": v,
        "restitution": k,
        "duration_s": tau * ts,
        "peak_force_n": peak * fs,
        "max_penetration_m": ((n + 1.0) * _g2(a)) ** (1.0 / (n + 1.0)) * xs,
        "energy_loss_fraction": (1.0 - k) * (1.0 + k),
    }


def _direct(a: np.ndarray, n: float) -> tuple[np.ndarray, np.ndarray]:
    uc = _u_compression(a)
    tc, tr = _compression_time(a, n, uc), _restitution_time(a, n, _u_restitution(a))
    us = _peak_u(a, n, uc)
    peak = ((n + 1.0) * _h(us, uc, a)) ** (n / (n + 1.0)) * np.exp(a * us)
    return tc + tr, peak


def _duration_peak(a: np.ndarray, n: float) -> tuple[np.ndarray, np.ndarray]:
    """Dimensionless (T/t*, F_max/F*) for every α: directly, or by the Chebyshev interpolant."""
    uniq, inverse = np.unique(a, return_inverse=True)
    if uniq.size <= _DIRECT_LIMIT:
        tau, peak = _direct(uniq, n)
        return tau[inverse], peak[inverse]
    interp = ChebyshevTable.build(float(uniq[0]), float(uniq[-1]), n)
    return interp(a)


class ChebyshevTable:
    """Piecewise Chebyshev interpolant of (T/t*, F_max/F*) in s = ln(1 + α) for one n.

    Each piece is accepted when its last three Chebyshev coefficients fall below 1e-14 of the
    largest (otherwise it is halved), so interpolation adds ≲ 1e-13 relative error.
    """

    def __init__(self, breaks: np.ndarray, coefs: np.ndarray) -> None:
        self.breaks = breaks  # (P+1,) in s
        self.coefs = coefs  # (P, 2, N)

    @classmethod
    def build(cls, alpha_lo: float, alpha_hi: float, n: float) -> ChebyshevTable:
        s_lo, s_hi = math.log1p(alpha_lo), math.log1p(alpha_hi)
        if s_hi <= s_lo:
            s_hi = s_lo + 1e-12
        nodes = np.cos(np.pi * (np.arange(_CHEB_N) + 0.5) / _CHEB_N)
        basis = np.cos(np.outer(np.arange(_CHEB_N), np.pi * (np.arange(_CHEB_N) + 0.5) / _CHEB_N))
        todo = [(s_lo, s_hi)]
        done: list[tuple[float, float, np.ndarray]] = []
        for _ in range(40):
            if not todo:
                break
            lo = np.array([p[0] for p in todo])
            hi = np.array([p[1] for p in todo])
            s = (lo[:, None] + hi[:, None]) / 2.0 + (hi - lo)[:, None] / 2.0 * nodes
            tau, peak = _direct(np.expm1(s).reshape(-1), n)
            vals = np.stack([tau.reshape(s.shape), peak.reshape(s.shape)], axis=1)  # (P,2,N)
            coef = vals @ basis.T * (2.0 / _CHEB_N)
            coef[..., 0] /= 2.0
            scale = np.max(np.abs(coef), axis=-1)
            tail = np.max(np.abs(coef[..., -3:]), axis=-1)
            ok = np.all(tail <= _CHEB_TOL * scale, axis=-1) | ((hi - lo) < 1e-9)
            nxt = []
            for i, (left, right) in enumerate(todo):
                if ok[i]:
                    done.append((left, right, coef[i]))
                else:
                    mid = 0.5 * (left + right)
                    nxt += [(left, mid), (mid, right)]
            todo = nxt
        if todo:
            raise RuntimeError("Chebyshev table did not converge")
        done.sort(key=lambda p: p[0])
        breaks = np.array([p[0] for p in done] + [done[-1][1]])
        return cls(breaks, np.stack([p[2] for p in done]))

    def __call__(self, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = np.log1p(np.asarray(alpha, dtype=float))
        last = len(self.coefs) - 1
        piece = np.clip(np.searchsorted(self.breaks, s, side="right") - 1, 0, last)
        tau = np.empty_like(s)
        peak = np.empty_like(s)
        if piece.ndim == 1 and np.all(piece[1:] >= piece[:-1]):  # sorted α (a grid): slices
            bounds = np.searchsorted(piece, np.arange(last + 2))
            parts = [slice(bounds[p], bounds[p + 1]) for p in range(last + 1)]
        else:
            order = np.argsort(piece, kind="stable")
            bounds = np.searchsorted(piece[order], np.arange(last + 2))
            parts = [order[bounds[p]:bounds[p + 1]] for p in range(last + 1)]
        for p, idx in enumerate(parts):
            sp = s[idx]
            if sp.size == 0:
                continue
            lo, hi = self.breaks[p], self.breaks[p + 1]
            t = (2.0 * sp - lo - hi) / (hi - lo)
            both = _chebval_pair(t.reshape(-1), self.coefs[p])
            tau[idx] = both[0].reshape(sp.shape)
            peak[idx] = both[1].reshape(sp.shape)
        return tau, peak


_CLENSHAW_BLOCK = 8192
"""Points per block of :func:`_chebval_pair` (its work arrays stay in cache)."""


def _chebval_pair(t: np.ndarray, coefs: np.ndarray) -> np.ndarray:
    """``numpy.polynomial.chebyshev.chebval(t, c)`` for both rows c of ``coefs`` (2, N ≥ 3),
    bit for bit (the same Clenshaw operations in the same order), in cache-sized blocks with
    work arrays reused: three times faster on 10⁶ points."""
    out = np.empty((2, t.size))
    n = coefs.shape[1]
    first = (coefs[:, -3] - coefs[:, -1])[:, None]  # chebval's c0 = c[-3] − c[-1]
    for start in range(0, t.size, _CLENSHAW_BLOCK):
        x = t[start:start + _CLENSHAW_BLOCK]
        x2 = 2 * x
        c0 = np.empty((2, x.size))
        c1 = np.empty_like(c0)
        work = np.empty_like(c0)
        np.multiply(coefs[:, -1, None], x2, out=work)
        np.add(coefs[:, -2, None], work, out=c1)  # c1 = c[-2] + c[-1]·2x
        c0[...] = first
        for i in range(4, n + 1):  # tmp = c0; c0 = c[-i] − c1; c1 = tmp + c1·2x
            np.multiply(c1, x2, out=work)
            np.subtract(coefs[:, -i, None], c1, out=c1)
            np.add(c0, work, out=c0)
            c0, c1 = c1, c0
        np.multiply(c1, x, out=work)
        np.add(c0, work, out=out[:, start:start + x.size])
    return out


# --------------------------------------------------------------------------------------------
# V(x) on both branches
# --------------------------------------------------------------------------------------------


def velocity(x: float | np.ndarray, law: HuntCrossley, mass_kg: float, velocity_m_s: float,
             branch: Branch) -> float | np.ndarray:
    """Velocity V(x) (m/s) at penetration x (m) on one branch of the phase trajectory.

    Closed form V = −(1 + W_i(z))/b, z = −(1+α)e^(−(1+α))·e^(b²Π(x)/m), i = −1 on
    ``"compression"`` (V > 0) and i = 0 on ``"restitution"`` (V < 0); b = 0 gives
    V = ±√(V0² − 2Π/m). Evaluated through the velocity variable ũ (module doc) by a monotone
    Newton solve of H(ũ) = Π(x)/(m·V0²) from the branch's contact end, which stays accurate
    up to the branch point x_max. NaN outside 0 ≤ x ≤ x_max.
    """
    m = check.positive("mass_kg", mass_kg)
    v0 = check.positive("velocity_m_s", velocity_m_s)
    check.one_of("branch", branch, ("compression", "restitution"))
    xa = np.asarray(x, dtype=float)
    a = np.asarray(law.damping * v0, dtype=float)
    pot = np.vectorize(law.potential, otypes=[float])(np.maximum(xa, 0.0)) / (m * v0 * v0)
    hmax = float(_g2(a))
    end = _u_compression(a) if branch == "compression" else _u_restitution(a)
    u = np.broadcast_to(end, xa.shape).astype(float).copy()
    target = np.minimum(pot, hmax)
    for _ in range(200):
        phi = _h(u, end, a) - target
        dphi = -u * _e1(a * u)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(dphi != 0.0, phi / dphi, 0.0)
        new = np.clip(u - step, min(0.0, end), max(0.0, end))
        if np.all(np.abs(new - u) <= 4.0 * np.finfo(float).eps * np.maximum(np.abs(new),
                                                                           1e-300)):
            u = new
            break
        u = new
    vel = v0 * u * _e1(a * u)
    vel = np.where((xa < 0.0) | (pot > hmax * (1.0 + 1e-12)), np.nan, vel)
    return float(vel) if vel.ndim == 0 else vel


# --------------------------------------------------------------------------------------------
# General (callable) f: adaptive quadrature in physical units
# --------------------------------------------------------------------------------------------


def _inverse_potential(law: HuntCrossley, energy_j: float, x_hint: float) -> float:
    """x ≥ 0 with Π(x) = energy_j (Π is increasing)."""
    if energy_j <= 0.0:
        return 0.0
    from scipy import optimize

    hi = max(x_hint, 1e-300)
    while law.potential(hi) < energy_j:
        hi *= 2.0
    lo = hi / 2.0
    while lo > 0.0 and law.potential(lo) > energy_j:
        lo /= 2.0
        if lo < 1e-300:
            lo = 0.0
    return optimize.brentq(lambda s: law.potential(s) - energy_j, lo, hi, xtol=1e-300,
                           rtol=4.0 * np.finfo(float).eps, maxiter=400)


def _solve_general(law: HuntCrossley, m: float, v0: float) -> dict[str, float]:
    """Metrics for a callable f: T by quadrature of dt = dx/|V| near the contact ends and of
    dt = −m·V0·dũ/f(x(ũ)) around x_max; the peak force by a bounded scalar search."""
    a = np.asarray(law.damping * v0)
    e0 = m * v0 * v0
    uc, ur = float(_u_compression(a)), float(_u_restitution(a))
    k = -ur * float(_e1(a * ur))
    xmax = _inverse_potential(law, e0 * float(_g2(a)), 1e-3)

    def x_of(u: float, end: float) -> float:
        return _inverse_potential(law, e0 * float(_h(np.asarray(u), np.asarray(end), a)), xmax)

    def vel_of(xv: float, branch: Branch) -> float:
        return float(velocity(xv, law, m, v0, branch))

    from scipy import integrate

    opts = {"epsabs": 0.0, "epsrel": 1e-12, "limit": 200}
    total = 0.0
    for end, branch in ((uc, "compression"), (ur, "restitution")):
        half = end / 2.0
        x_half = x_of(half, end)
        total += integrate.quad(lambda xv, br=branch: 1.0 / abs(vel_of(xv, br)), 0.0, x_half,
                                **opts)[0]
        total += integrate.quad(lambda u, e=end: m * v0 / law.elastic_force(x_of(u, e)),
                                min(0.0, half), max(0.0, half), **opts)[0]

    peak = _bounded_max(lambda u: law.elastic_force(x_of(u, uc)) * math.exp(float(a) * u),
                        0.0, uc, xatol=1e-14 * uc)
    return _metrics(k, total, peak, xmax)


# --------------------------------------------------------------------------------------------
# Time history
# --------------------------------------------------------------------------------------------


def _time_compression(u: np.ndarray, a: float, n: float, uc: float) -> np.ndarray:
    """Dimensionless time from first touch to the state ũ ∈ [0, ũ_c] (Jacobi at ũ_c)."""
    return _compression_time(np.full(u.shape, a), n, np.full(u.shape, uc), lo=u)


def _time_to_end(u: np.ndarray, a: float, n: float, ur: float) -> np.ndarray:
    """Dimensionless time from the state ũ ∈ [ũ_r, 0] to separation."""
    beta = n / (n + 1.0)
    a2 = np.full((u.size, 1), a)
    # Jacobi from ũ_r to min(ũ, ũ_r/2), then Legendre panels up to ũ
    x, w = _jacobi(_N_JACOBI, 0.0, -beta)
    top = np.minimum(u, ur / 2.0)
    half = ((top - ur) / 2.0)[:, None]
    uu = ur + half * (1.0 + x)
    psi = ((n + 1.0) * -_h_over_d(uu, np.asarray(ur), a2)) ** (-beta)
    out = half[:, 0] ** (1.0 - beta) * (psi @ w)
    xl, wl = _legendre(_N_LEGENDRE)
    k = _panels(np.asarray([a]), np.asarray([ur]))
    edges = [ur / 2.0**j for j in range(1, k + 1)] + [0.0]
    for left, right in itertools.pairwise(edges):
        lo_ = np.full(u.shape, left)
        hi_ = np.clip(u, left, right)
        half = ((hi_ - lo_) / 2.0)[:, None]
        uu = lo_[:, None] + half * (1.0 + xl)
        out = out + half[:, 0] * (((n + 1.0) * _h(uu, np.asarray(ur), a2)) ** (-beta) @ wl)
    return out


def history(scenario: BallOnPlate, samples: int = 4001) -> ImpactRecord:
    """Time history x(t), ẋ(t), F(t) of the impact as an :class:`ImpactRecord`.

    ``samples`` points, nearly evenly spaced in time, cover the contact [0, T] exactly (first
    touch and separation are samples with x = 0) plus four samples of free flight on each side;
    the instants of maximum penetration and of peak force are inserted as exact samples. Every
    sample is exact (time by Gauss–Jacobi quadrature of the closed-form integrand).
    """
    if not isinstance(scenario, BallOnPlate):
        raise ValueError(f"scenario = {scenario!r}: must be a BallOnPlate")
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 16:
        raise ValueError(f"samples = {samples!r}: must be an integer >= 16")
    if scenario.is_linear:
        return _linear(scenario, samples)
    m, v0 = scenario.mass_kg, scenario.velocity_m_s
    c, n, b = scenario.stiffness, scenario.exponent, scenario.damping_s_per_m
    a = b * v0
    av = np.asarray([a])
    uc, ur = float(_u_compression(av)[0]), float(_u_restitution(av)[0])
    xs, ts, fs = (float(s) for s in scales(m, v0, c, n))
    # phase variable θ ∈ [0, 1] per phase, ũ = end·(1 − θ^(n+1)): time is smooth in θ
    fine = np.linspace(0.0, 1.0, 513)
    uc_f = uc * (1.0 - fine ** (n + 1.0))
    ur_f = ur * (1.0 - fine ** (n + 1.0))
    t_c = _time_compression(uc_f, a, n, uc)
    t_r = _time_to_end(ur_f, a, n, ur)
    tc_total, tr_total = t_c[-1], t_r[-1]
    total = tc_total + tr_total
    pad = 4
    n_in = samples - 2 * pad
    targets = np.linspace(0.0, total, n_in)
    comp = targets[targets <= tc_total]
    rest = targets[targets > tc_total]
    th_c = np.interp(comp, t_c, fine)
    th_r = np.interp(total - rest, t_r, fine)
    u_comp = uc * (1.0 - th_c ** (n + 1.0))
    u_rest = ur * (1.0 - th_r ** (n + 1.0))
    us = _peak_u(av, n, np.asarray([uc]))[0]
    u_comp = np.unique(np.concatenate([u_comp, [us, 0.0]]))[::-1]  # decreasing ũ = time order
    u_rest = u_rest[u_rest < 0.0]
    tau_c = _time_compression(u_comp, a, n, uc)
    tau_r = total - _time_to_end(u_rest, a, n, ur)
    tau_r[-1] = total if u_rest[-1] == ur else tau_r[-1]
    u_all = np.concatenate([u_comp, u_rest])
    tau = np.concatenate([tau_c, tau_r])
    tau[0] = 0.0
    keep = np.concatenate([[True], np.diff(tau) > 1e-12 * total])
    u_all, tau = u_all[keep], tau[keep]
    h_all = np.where(u_all >= 0.0, _h(u_all, np.asarray(uc), av), _h(u_all, np.asarray(ur), av))
    h_all = np.maximum(h_all, 0.0)
    xi = ((n + 1.0) * h_all) ** (1.0 / (n + 1.0))
    vel = u_all * _e1(a * u_all)
    force = xi**n * np.exp(a * u_all)
    dt = total / (n_in - 1)
    k = -ur * float(_e1(av * ur)[0])
    before = -dt * np.arange(pad, 0, -1)
    after = total + dt * np.arange(1, pad + 1)
    t = np.concatenate([before, tau, after]) * ts
    x = np.concatenate([before, xi, -k * (after - total)]) * xs
    v = np.concatenate([np.ones(pad), vel, np.full(pad, -k)]) * v0
    f = np.concatenate([np.zeros(pad), force, np.zeros(pad)]) * fs
    return ImpactRecord(
        time_s=t, penetration_m=x, penetration_rate_m_s=v, normal_force_n=f,
        velocity_1_m_s=v, velocity_2_m_s=np.zeros_like(t), mass_1_kg=m,
        mass_2_kg=math.inf, status=Status.OK,
        meta={"engine": "reference", "mode": "closed_form", "scenario": scenario.name,
              "parameters": scenario.to_dict()},
    )


# --------------------------------------------------------------------------------------------
# Independent per-point ODE (cross-check and benchmark baseline)
# --------------------------------------------------------------------------------------------


def solve_ode(law: HuntCrossley, mass_kg: float, velocity_m_s: float,
              rtol: float = 1e-12) -> dict[str, float]:
    """The same metrics from a direct integration of m·ẍ = −f(x)(1 + b·ẋ) (DOP853).

    Independent of the quadrature above: scaled state (x/x_s, ẋ/V0) with x_s the elastic
    max penetration, terminal event x = 0 on the way out, the x_max event at ẋ = 0 and the
    peak force by a bounded search on the dense output of the compression phase.
    """
    m = check.positive("mass_kg", mass_kg)
    v0 = check.positive("velocity_m_s", velocity_m_s)
    xs = _inverse_potential(law, 0.5 * m * v0 * v0, 1e-3)
    ts = xs / v0
    kappa = xs / (m * v0 * v0)
    a = law.damping * v0

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        return [y[1], -kappa * law.elastic_force(xs * y[0]) * (1.0 + a * y[1])]

    def leave(_t: float, y: np.ndarray) -> float:
        return y[0]

    leave.terminal = True  # type: ignore[attr-defined]
    leave.direction = -1.0  # type: ignore[attr-defined]

    def turn(_t: float, y: np.ndarray) -> float:
        return y[1]

    from scipy import integrate

    sol = integrate.solve_ivp(rhs, (0.0, 1e3), [0.0, 1.0], method="DOP853", rtol=rtol,
                              atol=rtol * 1e-3, events=(leave, turn), dense_output=True)
    t_end = float(sol.t_events[0][0])
    y_end = sol.y_events[0][0]
    t_turn = float(sol.t_events[1][0])
    xmax = float(sol.y_events[1][0][0]) * xs

    def force(t: float) -> float:
        y = sol.sol(t)
        return law.force(xs * y[0], v0 * y[1])

    k = -float(y_end[1])
    peak = _bounded_max(force, 0.0, t_turn, xatol=1e-13 * t_turn)
    return _metrics(k, t_end * ts, peak, xmax)
