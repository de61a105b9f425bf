"""Direct time integration of the oblique impact: the rigid-Coulomb check and the compliant
references, Mindlin's no-slip spring and the Mindlin–Deresiewicz micro-slip law
(:mod:`impactbench.reference.oblique` has the physics and the closed form).

State y = (x, ẋ, v_t, ω, F_t): penetration and its rate (the normal law, m·ẍ = −F_n(x, ẋ)),
the centre's tangential velocity, the spin, and (Mindlin) the tangential force on the ball.
Tangential motion: m·v̇_t = F_t, m·k²·ω̇ = −R·F_t; slip s = v_t − R·ω, ṡ = F_t·(1 + R²/k²)/m.
Integrated with :func:`scipy.integrate.solve_ivp` (DOP853, rtol 1e-12 by default) in
segments of one *mode* each; the mode switches at events located on the dense output:

**Rigid Coulomb** (:func:`rigid`, the check of the closed form):

- *slip*: F_t = −μ·F_n·sign(s0) while the slip keeps the sign it came in with;
- the event s = 0 switches to *stick* if the force that keeps s = 0 is within the cone: for a
  sphere on a plane ṡ = 0 needs F_t = 0 ≤ μ·F_n, always; *stick* keeps v_t and ω.
- the event "contact ends" (x = 0 for the Hunt–Crossley family, k·x + d·ẋ = 0 for the clipped
  Kelvin–Voigt law, which lets go while still penetrating) ends the run.

**Mindlin** (:func:`mindlin`; ``tangential = "mindlin"``): the normal Hertz law of the zoo and
a tangential spring of the no-slip stiffness of Mindlin (1949),

    k_t = 8·G*·a,   a = √(R·x),   1/G* = (2 − ν₁)/G₁ + (2 − ν₂)/G₂,   G = E/(2(1 + ν)),

(:attr:`Oblique.shear_modulus_pa`; a rigid plate, E₂ = ∞, drops its term, as Chung & Ooi
2011's test 4 treats it), the tangential *force* as the history variable and the Coulomb limit
as a cap — the simplified "Hertz–Mindlin no-slip" law of DEM codes (Cundall & Strack 1979's
truncated tangential spring with Mindlin's stiffness; compared with the full
Mindlin–Deresiewicz law by Di Renzo & Di Maio 2004; the law of Chung & Ooi 2011's test 4):

    dF_t = −k_t·ds + [ẋ < 0]·F_t·dk_t/k_t   while |F_t| < μ·F_n   (mode *elastic*),
    F_t = σ·μ·F_n                           while on the cone      (mode *slide*, σ = ±1).

- *Loading* (the contact grows, ẋ > 0): the new annulus enters the contact unstressed, so only
  the increment counts, dF_t = −k_t·ds (Mindlin & Deresiewicz 1953).
- *Unloading* (the contact shrinks, ẋ < 0): the force shrinks with the contact,
  F_t ← F_t·a/a_old = F_t·k_t/k_t,old (here dk_t/k_t = dx/(2x)), the rescaling DEM
  implementations of Mindlin–Deresiewicz apply on unloading (Thornton & Yin 1991): Mindlin's
  no-slip solution F_t = 8·G*·a·δ for a contact whose every point carries the same
  displacement δ. A contact that grew under a changing δ does not: the points that joined
  last carry the displacement since they joined, and the exact no-slip limit of
  Mindlin–Deresiewicz (below, μ → ∞) lets each point leave with its own. That difference, not
  micro-slip, is most of what this law gets wrong below 5° (Kharaz's e_t: 0.88 here, 0.80 in
  that limit, 0.78 with micro-slip, 0.79 measured at 1.8°). The bare increment that keeps F_t
  while k_t falls (``unloading = "hold"``, for comparison only) raises the stored
  F_t²/(2k_t) from nothing: a stuck elastic sphere (μ = 100, e = 1, 5°) leaves with 0.67 %
  more tangential-plus-spin energy than it brought (``scale``: 19 % less).
- *The cone*: in continuous time the DEM step "F_trial = F_t + dF_t; if |F_trial| > μ·F_n:
  F_t = μ·F_n·sign(F_trial)" is the projection of the elastic rate onto |F_t| ≤ μ·F_n.
  *elastic* → *slide* at |F_t| = μ·F_n (events μ·F_n ∓ F_t = 0); *slide* stays on the cone
  while the elastic trial rate pushes out at least as fast as the cone moves,
  σ·dF_t^elastic/dt ≥ μ·Ḟ_n — so while F_n unloads, F_t is *rescaled with the shrinking
  cone*, F_t = σ·μ·F_n, the rule the DEM codes apply each step — and leaves it into *elastic*
  when that fails (event σ·dF_t^elastic/dt − μ·Ḟ_n = 0: the slip reversed, or the cone grows
  faster than the spring loads).
- At first touch (x = 0: k_t = 0, F_n = 0) both rates grow as √x: the contact starts sliding
  if 8·G*·√R·|s0| > μ·n·c·v_n·(1 + b·v_n) (Hertz, n = 3/2), else elastic.

This is *not* the full Mindlin & Deresiewicz (1953) law: its tangential stiffness softens with
the micro-slip annulus (k_t·(1 − |F_t|/μF_n)^(1/3) on first loading) and it keeps a memory of
load reversals and of how the contact was formed. Material inputs: E and ν of the ball and
the plate (:class:`Oblique` ``youngs_modulus_pa``, ``poisson``, ``plate_youngs_modulus_pa`` —
``inf``: rigid — and ``plate_poisson``); no tangential damping. An explicit DEM-style stepping
of the same law converges to this solution at first order in the step (tests).

**Mindlin–Deresiewicz** (:func:`micro_slip`; ``tangential = "mindlin-deresiewicz"``, the
compliant reference the suite draws, ``oblique_scenario.COMPLIANT_DEFAULT``): the full
Cattaneo–Mindlin/Mindlin–Deresiewicz theory of a Hertz contact under varying oblique forces —
partial slip in an annulus (the stiffness 8·G*·a·(1 − |F_t − F_r|/(ζ·μ·F_n))^(1/3) of Mindlin &
Deresiewicz at constant F_n, ζ = 1 on first loading and 2 after a reversal at F_r: Masing's
rules), no slip where the loading is proportional with |dF_t| < μ·dF_n (their oblique-loading
result), and the memory of how every point of the contact was loaded — for any history of F_n
and slip, through the method of dimensionality reduction (MDR; Popov & Heß 2015), which maps the
axisymmetric Cattaneo–Mindlin contact exactly onto a bed of independent 1D springs over ξ ∈ [−a,
a]: normal stiffness E*·dξ with the profile ξ²/R (so Σ = Hertz, c = (4/3)·E*·√R), tangential
stiffness 4·G*·dξ (so k_t = 8·G*·a with no slip), each spring with its *own* Coulomb limit μ
times its normal force (the law's damping factor 1 + b·ẋ on every spring, so the limits add up
to μ·F_n). A spring touches with no shear; while in contact it takes the contact point's slip
and slides at its limit; it lets go (and forgets) when the contact recedes past it. This is the
Cattaneo–Mindlin problem Maw, Barber & Fawcett (1976) solved for the oblique impact, treated
with the MDR by Lyashenko & Popov (2015) and Willert & Popov (2016). Limits: with μ → ∞ the
loading is Mindlin's no-slip law exactly and the unloading lets each point leave with its own
displacement (above); sliding throughout, every spring is at its limit and the result is the
rigid theory's. Numerics: the normal law integrated as above (DOP853, the zoo's metrics to
~1e-12); the tangential motion stepped on :data:`MD_STEPS` even steps (kick–drift–kick: F_t at
the step times) over a bed of :data:`MD_SPRINGS` springs, each handed only the slip since it
touched (its touch time from the normal solution): second order in both, ≤ 5e-8 in the metrics at
the defaults, 0.3 s per impact; the bed reproduces the constant-F_n Cattaneo–Mindlin and
Mindlin–Deresiewicz unloading and reloading curves to 1.3e-7 of μ·F_n (tests). No energy is
created (every spring's slip dissipates; a spring that lets go takes its stored energy).

Sources: R. D. Mindlin, "Compliance of elastic bodies in contact", J. Appl. Mech. 16:259–268,
1949; R. D. Mindlin, H. Deresiewicz, "Elastic spheres in contact under varying oblique forces",
J. Appl. Mech. 20:327–344, 1953; P. A. Cundall, O. D. L. Strack, "A discrete numerical model for
granular assemblies", Géotechnique 29(1):47–65, 1979; A. Di Renzo, F. P. Di Maio, "Comparison of
contact-force models for the simulation of collisions in DEM-based granular flow codes", Chem.
Eng. Sci. 59(3):525–541, 2004; Y. C. Chung, J. Y. Ooi, "Benchmark tests for verifying discrete
element modelling codes at particle impact level", Granular Matter 13:643–656, 2011; C.
Thornton, K. K. Yin, "Impact of elastic spheres with and without adhesion", Powder Technol.
65:153–166, 1991; N. Maw, J. R. Barber, J. N. Fawcett, "The oblique impact of elastic spheres",
Wear 38:101–114, 1976; V. L. Popov, M. Heß, *Method of Dimensionality Reduction in Contact
Mechanics and Friction*, Springer, 2015; I. A. Lyashenko, V. L. Popov, "Impact of an elastic
sphere with an elastic half space revisited: numerical analysis based on the method of
dimensionality reduction", Sci. Rep. 5:8479, 2015; E. Willert, V. L. Popov, "Impact of an
elastic sphere with an elastic half space with a constant coefficient of friction: numerical
analysis based on the method of dimensionality reduction", ZAMM 96(9):1089–1095, 2016.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from impactbench.reference import validation as check
from impactbench.reference.models import KelvinVoigt
from impactbench.reference.oblique_metrics import metrics_of
from impactbench.reference.oblique_scenario import OBLIQUE_METRICS, Oblique
from impactbench.reference.record import ImpactRecord, Status
from scipy import integrate, optimize

RTOL = 1e-12
"""Default relative tolerance of the integration (metrics agree with the closed form ≤ 1e-8)."""
MAX_SEGMENTS = 500
"""More mode switches than this in one impact is reported as an error (chattering)."""

SLIP, STICK, ELASTIC, SLIDE = "slip", "stick", "elastic", "slide"
MICRO_SLIP = "mindlin-deresiewicz"
EVENT_MODELS: tuple[str, ...] = ("rigid", "mindlin")
"""The tangential laws integrated event by event (:func:`integrate_scenario`)."""
MD_SPRINGS = 2000
"""Springs of the Mindlin–Deresiewicz bed (:func:`micro_slip`) across the largest contact
radius."""
MD_STEPS = 10000
"""Steps of the Mindlin–Deresiewicz stepping over the contact. With :data:`MD_SPRINGS` the
metrics are within ~5e-8 of the converged values (second order in both; tests)."""
UNLOADING_RULES: tuple[str, ...] = ("scale", "hold")
"""The Mindlin spring while the contact shrinks: ``scale`` (the reference: F_t ∝ a at fixed
stuck displacement, Mindlin's no-slip solution) or ``hold`` (F_t kept, the bare incremental
update; creates energy, for comparison only)."""


class _Normal:
    """The normal law in a fast form: F(x, ẋ), its time derivative, and the contact gap."""

    def __init__(self, scenario: Oblique) -> None:
        ball = scenario.normal_scenario()
        law = ball.law()
        self.m = scenario.mass_kg
        self.linear = isinstance(law, KelvinVoigt)
        if isinstance(law, KelvinVoigt):
            self.k, self.d = law.stiffness, law.damping_ns_per_m
            self.c = self.n = self.b = 0.0
        else:
            self.c, self.n, self.b = law.stiffness, law.exponent, law.damping
            self.k = self.d = 0.0

    def force(self, x: float, v: float) -> float:
        if self.linear:
            return max(0.0, self.k * x + self.d * v) if x > 0.0 else 0.0
        return self.c * x**self.n * (1.0 + self.b * v) if x > 0.0 else 0.0

    def rate(self, x: float, v: float) -> float:
        """dF_n/dt along the motion (ẍ = −F/m)."""
        f = self.force(x, v)
        if x <= 0.0 or f <= 0.0:
            return 0.0
        if self.linear:
            return self.k * v - self.d * f / self.m
        return (self.c * self.n * x ** (self.n - 1.0) * v * (1.0 + self.b * v)
                - self.c * x**self.n * self.b * f / self.m)

    def gap(self, x: float, v: float) -> float:
        """Zero where the contact ends: x (Hunt–Crossley family), k·x + d·ẋ (clipped KV)."""
        return self.k * x + self.d * v if self.linear else x

    def scales(self, v_n: float) -> tuple[float, float]:
        """(x*, F*): the elastic law's largest indentation and force at v_n."""
        if self.linear:
            xs = v_n * math.sqrt(self.m / self.k)
            return xs, self.k * xs
        xs = ((self.n + 1.0) * self.m * v_n * v_n / (2.0 * self.c)) ** (1.0 / (self.n + 1.0))
        return xs, self.c * xs**self.n


@dataclass
class Segment:
    """One mode's stretch of the integration: [t0, t1], its mode and sign, dense output."""

    t0: float
    t1: float
    mode: str
    sign: float
    sol: Callable[[float], np.ndarray]


@dataclass
class Solution:
    """The integrated impact: its segments, end state and the scenario's metrics."""

    scenario: Oblique
    segments: list[Segment]
    end: np.ndarray
    metrics: dict[str, float]

    @property
    def switches(self) -> list[tuple[float, str]]:
        """(time, mode entered) of every mode switch."""
        return [(s.t0, s.mode) for s in self.segments[1:]]


def _segment_max(fn: Callable[[float], float], a: float, b: float) -> float:
    """The largest value of ``fn`` on [a, b]: a 257-node scan, polished by a bounded Brent
    search around the best node (never below the best node)."""
    if b <= a:
        return float(fn(a))
    nodes = np.linspace(a, b, 257)
    vals = np.array([fn(t) for t in nodes])
    i = int(np.argmax(vals))
    lo, hi = nodes[max(i - 1, 0)], nodes[min(i + 1, nodes.size - 1)]
    res = optimize.minimize_scalar(lambda t: -fn(t), bounds=(lo, hi), method="bounded",
                                   options={"xatol": 1e-15 * (b - a) + 1e-300})
    return max(-float(res.fun), float(vals[i]))


class _Problem:
    """The equations of one scenario in one tangential model (``rigid`` or ``mindlin``)."""

    def __init__(self, scenario: Oblique, tangential: str, unloading: str = "scale") -> None:
        self.s = scenario
        self.unloading = unloading
        self.tangential = tangential
        self.law = _Normal(scenario)
        self.m = scenario.mass_kg
        self.r = scenario.radius_m
        self.mu = scenario.friction
        self.k2 = scenario.gyration_ratio * self.r**2  # k² (sphere 2R²/5, disc R²/2)
        self.v_n = scenario.normal_velocity_m_s
        self.s0 = scenario.slip_m_s
        if tangential == "mindlin":
            self.kt_coef = 8.0 * scenario.shear_modulus_pa * math.sqrt(self.r)  # k_t/√x

    # ---------------------------------------------------------------- forces
    def tangential_force(self, mode: str, sign: float, y: np.ndarray) -> float:
        if mode in (STICK,):
            return 0.0
        if mode == ELASTIC:
            return float(y[4])
        return sign * self.mu * self.law.force(y[0], y[1])  # SLIP and SLIDE: on the cone

    def k_t(self, x: float) -> float:
        return self.kt_coef * math.sqrt(x) if x > 0.0 else 0.0

    def elastic_rate(self, y: np.ndarray, ft: float) -> float:
        """dF_t/dt of the stuck contact: −k_t·s, plus F_t·(dk_t/dt)/k_t = F_t·ẋ/(2x) while the
        contact shrinks (ẋ < 0) with ``unloading = "scale"``."""
        x, v = y[0], y[1]
        rate = -self.k_t(x) * (y[2] - self.r * y[3])
        if self.unloading == "scale" and v < 0.0 and x > 0.0:
            rate += ft * v / (2.0 * x)
        return rate

    def rhs(self, mode: str, sign: float) -> Callable[[float, np.ndarray], list[float]]:
        m, r, k2, law = self.m, self.r, self.k2, self.law

        def f(_t: float, y: np.ndarray) -> list[float]:
            x, v = y[0], y[1]
            fn = law.force(x, v)
            ft = self.tangential_force(mode, sign, y)
            if mode == ELASTIC:
                dft = self.elastic_rate(y, ft)
            elif mode == SLIDE:
                dft = sign * self.mu * law.rate(x, v)
            else:
                dft = 0.0
            return [v, -fn / m, ft / m, -r * ft / (m * k2), dft]

        return f

    # ---------------------------------------------------------------- events
    def events(self, mode: str, sign: float) -> list[Callable]:
        law, r = self.law, self.r

        def end(_t: float, y: np.ndarray) -> float:
            return law.gap(y[0], y[1])

        end.terminal = True  # type: ignore[attr-defined]
        end.direction = -1.0  # type: ignore[attr-defined]
        out: list[Callable] = [end]
        if mode == SLIP:
            def slip_zero(_t: float, y: np.ndarray) -> float:
                return y[2] - r * y[3]

            slip_zero.terminal = True  # type: ignore[attr-defined]
            slip_zero.direction = sign  # the slip (sign −σ) rises/falls through zero
            out.append(slip_zero)
        elif mode == ELASTIC:
            for s in (1.0, -1.0):
                def cone(_t: float, y: np.ndarray, s: float = s) -> float:
                    return self.mu * law.force(y[0], y[1]) - s * y[4]

                cone.terminal = True  # type: ignore[attr-defined]
                cone.direction = -1.0  # type: ignore[attr-defined]
                out.append(cone)
        elif mode == SLIDE:
            def leave(_t: float, y: np.ndarray) -> float:
                on_cone = sign * self.mu * law.force(y[0], y[1])
                return sign * self.elastic_rate(y, on_cone) - self.mu * law.rate(y[0], y[1])

            leave.terminal = True  # type: ignore[attr-defined]
            leave.direction = -1.0  # type: ignore[attr-defined]
            out.append(leave)
        return out

    # ---------------------------------------------------------------- switching
    def first_mode(self) -> tuple[str, float]:
        if self.mu == 0.0 or self.s0 == 0.0:
            return (STICK if self.tangential == "rigid" or self.mu == 0.0 else ELASTIC), 0.0
        against = -math.copysign(1.0, self.s0)  # friction opposes the slip
        if self.tangential == "rigid":
            return SLIP, against
        law = self.law
        cone = self.mu * law.n * law.c * self.v_n * (1.0 + law.b * self.v_n)  # μ·dF_n/dt/√x
        if self.kt_coef * abs(self.s0) > cone:
            return SLIDE, against
        return ELASTIC, 0.0

    def next_mode(self, mode: str, sign: float, which: int, y: np.ndarray
                  ) -> tuple[str, float, np.ndarray]:
        """The mode after event ``which`` (≥ 1) of ``mode`` and the state to start it from."""
        y = y.copy()
        if mode == SLIP:
            # s = 0: stick if the force keeping it there is within the cone. For a sphere on a
            # plane ṡ = F_t·(1 + R²/k²)/m, so that force is 0 ≤ μ·F_n: always stick.
            required = 0.0
            assert abs(required) <= self.mu * self.law.force(y[0], y[1])
            y[4] = 0.0
            return STICK, 0.0, y
        if mode == ELASTIC:
            sign = 1.0 if which == 1 else -1.0
            y[4] = sign * self.mu * self.law.force(y[0], y[1])
            return SLIDE, sign, y
        if mode == SLIDE:
            y[4] = sign * self.mu * self.law.force(y[0], y[1])
            return ELASTIC, 0.0, y
        raise AssertionError(f"mode {mode!r} has no switching event")


def _solve(scenario: Oblique, tangential: str, rtol: float, unloading: str) -> Solution:
    prob = _Problem(scenario, tangential, unloading)
    v_n = prob.v_n
    xs, fs = prob.law.scales(v_n)
    ts = xs / v_n
    vt0 = scenario.tangential_velocity_m_s
    w0 = scenario.spin_rad_s
    vscale = max(scenario.velocity_m_s, abs(prob.r * w0))
    atol = rtol * np.array([xs, v_n, vscale, vscale / prob.r, max(prob.mu, 1e-3) * fs])
    y = np.array([0.0, v_n, vt0, w0, 0.0])
    t0 = 0.0
    t_cap = 200.0 * ts
    mode, sign = prob.first_mode()
    segments: list[Segment] = []
    while True:
        if len(segments) >= MAX_SEGMENTS:
            raise RuntimeError(f"oblique integration: more than {MAX_SEGMENTS} mode switches "
                               f"(chattering) at angle_deg = {scenario.angle_deg!r}")
        sol = integrate.solve_ivp(prob.rhs(mode, sign), (t0, t0 + t_cap), y, method="DOP853",
                                  rtol=rtol, atol=atol, events=prob.events(mode, sign),
                                  dense_output=True)
        if sol.status != 1:
            raise RuntimeError(f"oblique integration: the contact did not end within "
                               f"{t_cap:.3g} s ({sol.message})")
        hits = [(float(te[0]), i) for i, te in enumerate(sol.t_events) if te.size]
        t1, which = min(hits)
        y1 = sol.y_events[which][0]
        segments.append(Segment(t0, t1, mode, sign, sol.sol))
        if which == 0:
            break
        mode, sign, y = prob.next_mode(mode, sign, which, y1)
        t0 = t1
    law = prob.law

    def fn_at(seg: Segment) -> Callable[[float], float]:
        return lambda t: law.force(*seg.sol(t)[:2])

    def ft_at(seg: Segment) -> Callable[[float], float]:
        return lambda t: abs(prob.tangential_force(seg.mode, seg.sign, seg.sol(t)))

    peak = max(_segment_max(fn_at(s), s.t0, s.t1) for s in segments)
    peak_t = max(0.0 if s.mode == STICK else _segment_max(ft_at(s), s.t0, s.t1)
                 for s in segments)
    out = metrics_of(scenario.velocity_m_s, scenario.angle_deg, w0, prob.r,
                     normal_velocity_out=-float(y1[1]), tangential_velocity_out=float(y1[2]),
                     spin_out=float(y1[3]), duration_s=t1, peak_force_n=peak,
                     peak_tangential_force_n=peak_t)
    assert tuple(out) == OBLIQUE_METRICS
    return Solution(scenario, segments, y1, out)


def integrate_scenario(scenario: Oblique, tangential: str | None = None,
                       rtol: float = RTOL, unloading: str = "scale") -> Solution:
    """The integrated impact (segments, end state, metrics) in the scenario's tangential
    model or in ``tangential`` (``rigid`` | ``mindlin``: the event-switched laws;
    ``mindlin-deresiewicz`` is :func:`micro_slip`'s); ``unloading`` is the Mindlin spring's
    rule while the contact shrinks (:data:`UNLOADING_RULES`)."""
    if not isinstance(scenario, Oblique):
        raise ValueError(f"scenario = {scenario!r}: must be an Oblique")
    which = tangential or scenario.tangential
    check.one_of("tangential", which, EVENT_MODELS)
    if which == "mindlin" and scenario.tangential != "mindlin":
        scenario = scenario.replace(tangential="mindlin")  # validates the Hertz law
    if not (isinstance(rtol, float) and 1e-14 <= rtol <= 1e-3):
        raise ValueError(f"rtol = {rtol!r}: must be a float in [1e-14, 1e-3]")
    check.one_of("unloading", unloading, UNLOADING_RULES)
    return _solve(scenario, which, rtol, unloading)


def rigid(scenario: Oblique, rtol: float = RTOL) -> dict[str, float]:
    """The rigid-Coulomb impact by direct integration (the closed form's check)."""
    return integrate_scenario(scenario, "rigid", rtol).metrics


def mindlin(scenario: Oblique, rtol: float = RTOL, unloading: str = "scale"
            ) -> dict[str, float]:
    """The Mindlin (no-slip tangential spring, Coulomb-capped) reference's metrics."""
    return integrate_scenario(scenario, "mindlin", rtol, unloading).metrics


# ------------------------------------------------------------------ Mindlin–Deresiewicz


class SpringBed:
    """The tangential state of a Hertz contact in the method of dimensionality reduction
    (module doc, **Mindlin–Deresiewicz**): ``springs`` independent springs across
    ξ ∈ [0, a_max] (both sides counted: the bed is symmetric), spring i at ξ_i = (i + ½)·h
    touching once the indentation passes ξ_i²/R, with normal stiffness E*·h, tangential
    stiffness G·h (G = 4·G*) and its own Coulomb limit μ times its normal force.

    ``touch_times`` (optional): when each spring first touches, so that a step hands it only
    the shear since then (second-order accuracy in the step).
    """

    def __init__(self, radius_m: float, e_star: float, g_mdr: float, friction: float,
                 a_max: float, springs: int, touch_times: np.ndarray | None = None) -> None:
        self.g, self.mu, self.e_star = g_mdr, friction, e_star
        self.h = a_max / springs
        self.depth = ((np.arange(springs) + 0.5) * self.h) ** 2 / radius_m
        self.u = np.zeros(springs)
        self.touch_times = touch_times
        self.touched = 0  # springs 0 … touched − 1 have touched (the contact grows from ξ = 0)

    def force(self) -> float:
        """F_t on the ball along t: −Σ G·h·u_i over both sides."""
        return -2.0 * self.g * self.h * float(self.u.sum())

    def advance(self, x: float, factor: float, slip: float, dt: float,
                t_next: float | None = None) -> float:
        """Move the bed to indentation ``x`` (normal forces × ``factor``, the law's damping
        factor 1 + b·ẋ) while the contact point slips ``slip``·``dt`` along t: the springs in
        contact are sheared by it (one touching in this step only since its touch time, when
        ``t_next`` and the touch times are given), those out of contact let go, and each is
        held to its Coulomb limit. Returns the new F_t on the ball."""
        u = self.u
        n = int(np.searchsorted(self.depth, x, side="left"))  # springs with depth < x
        old = min(n, self.touched)
        u[n:self.touched] = 0.0  # left the contact
        u[:old] += slip * dt
        if n > self.touched:
            if self.touch_times is None or t_next is None:
                u[self.touched:n] = slip * dt
            else:
                u[self.touched:n] = slip * np.clip(t_next - self.touch_times[self.touched:n],
                                                   0.0, dt)
            self.touched = n
        lim = (self.mu * self.e_star * factor / self.g) * (x - self.depth[:n])
        np.clip(u[:n], -lim, lim, out=u[:n])
        return self.force()


@dataclass
class MicroSlip:
    """A Mindlin–Deresiewicz impact (:func:`micro_slip`): the scenario, the samples at the
    step times (``time_s``, ``x``, ``rate`` ẋ, ``normal_force_n``, ``tangential_velocity``
    v_t, ``spin`` ω, ``tangential_force_n`` F_t on the ball) and the metrics."""

    scenario: Oblique
    time_s: np.ndarray
    x: np.ndarray
    rate: np.ndarray
    normal_force_n: np.ndarray
    tangential_velocity: np.ndarray
    spin: np.ndarray
    tangential_force_n: np.ndarray
    metrics: dict[str, float]


def micro_slip(scenario: Oblique, springs: int = MD_SPRINGS, steps: int = MD_STEPS,
               rtol: float = RTOL) -> MicroSlip:
    """The Mindlin–Deresiewicz impact (module doc): the normal law integrated as the other
    references (DOP853, ``rtol``; its metrics are the closed form's), the tangential motion
    stepped ``steps`` times over the contact with a bed of ``springs`` springs."""
    if not isinstance(scenario, Oblique):
        raise ValueError(f"scenario = {scenario!r}: must be an Oblique")
    for name, value, low in (("springs", springs, 10), ("steps", steps, 10)):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise ValueError(f"{name} = {value!r}: must be an integer >= {low}")
    if not (isinstance(rtol, float) and 1e-14 <= rtol <= 1e-3):
        raise ValueError(f"rtol = {rtol!r}: must be a float in [1e-14, 1e-3]")
    if scenario.tangential != MICRO_SLIP:
        scenario = scenario.replace(tangential=MICRO_SLIP)  # validates the Hertz law
    law = _Normal(scenario)
    m, r, mu = scenario.mass_kg, scenario.radius_m, scenario.friction
    v_n = scenario.normal_velocity_m_s
    xs, _ = law.scales(v_n)

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        return [y[1], -law.force(y[0], y[1]) / m]

    def end(_t: float, y: np.ndarray) -> float:
        return y[0]

    def peak(_t: float, y: np.ndarray) -> float:
        return y[1]

    end.terminal = True  # type: ignore[attr-defined]
    end.direction = -1.0  # type: ignore[attr-defined]
    peak.direction = -1.0  # type: ignore[attr-defined]
    sol = integrate.solve_ivp(rhs, (0.0, 200.0 * xs / v_n), [0.0, v_n], method="DOP853",
                              rtol=rtol, atol=rtol * np.array([xs, v_n]), events=[end, peak],
                              dense_output=True)
    if sol.status != 1:
        raise RuntimeError(f"oblique integration: the contact did not end ({sol.message})")
    t_end, t_peak = float(sol.t_events[0][0]), float(sol.t_events[1][0])
    time = np.linspace(0.0, t_end, steps + 1)
    y = sol.sol(time)
    x, rate = np.maximum(y[0], 0.0), y[1].copy()
    x[0] = x[-1] = 0.0
    rate[-1] = float(sol.y_events[0][0][1])
    fn = np.array([law.force(a, b) for a, b in zip(x, rate, strict=True)])
    factor = 1.0 + law.b * rate  # the Hunt–Crossley factor on every spring's normal force
    a_max = math.sqrt(r * float(sol.sol(t_peak)[0]))
    depth = ((np.arange(springs) + 0.5) * (a_max / springs)) ** 2 / r
    lo, hi = np.zeros(springs), np.full(springs, t_peak)  # touch times: x(t) = depth
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        below = sol.sol(mid)[0] < depth
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    bed = SpringBed(r, 3.0 * law.c / (4.0 * math.sqrt(r)), 4.0 * scenario.shear_modulus_pa,
                    mu, a_max, springs, 0.5 * (lo + hi))
    dt = time[1] - time[0]
    k2 = scenario.gyration_ratio * r * r
    vt, w, ft = scenario.tangential_velocity_m_s, scenario.spin_rad_s, 0.0
    vts, ws, fts = np.empty(steps + 1), np.empty(steps + 1), np.empty(steps + 1)
    vts[0], ws[0], fts[0] = vt, w, ft
    for k in range(steps):  # kick, drift (the bed), kick: the force at the step times
        vt += 0.5 * dt * ft / m
        w -= 0.5 * dt * r * ft / (m * k2)
        ft = bed.advance(float(x[k + 1]), float(factor[k + 1]), vt - r * w, dt,
                         float(time[k + 1]))
        vt += 0.5 * dt * ft / m
        w -= 0.5 * dt * r * ft / (m * k2)
        vts[k + 1], ws[k + 1], fts[k + 1] = vt, w, ft
    peak_n = _segment_max(lambda t: law.force(*sol.sol(t)), 0.0, t_end)
    out = metrics_of(scenario.velocity_m_s, scenario.angle_deg, scenario.spin_rad_s, r,
                     normal_velocity_out=-float(rate[-1]), tangential_velocity_out=vt,
                     spin_out=w, duration_s=t_end, peak_force_n=peak_n,
                     peak_tangential_force_n=float(np.max(np.abs(fts))))
    return MicroSlip(scenario, time, x, rate, fn, vts, ws, fts, out)


def mindlin_deresiewicz(scenario: Oblique, springs: int = MD_SPRINGS, steps: int = MD_STEPS
                        ) -> dict[str, float]:
    """The Mindlin–Deresiewicz (micro-slip) reference's metrics (:func:`micro_slip`)."""
    return micro_slip(scenario, springs, steps).metrics


def compliant(scenario: Oblique) -> dict[str, float]:
    """The tangentially compliant reference of the scenario's ``tangential``: ``mindlin``
    (event-switched) or ``mindlin-deresiewicz`` (the spring bed)."""
    if scenario.tangential == MICRO_SLIP:
        return mindlin_deresiewicz(scenario)
    return mindlin(scenario)


def history(scenario: Oblique, samples: int = 2001, rtol: float = RTOL) -> ImpactRecord:
    """The integrated impact as an :class:`ImpactRecord` in the scenario's tangential model.

    Normal quantities in the record's fields (``velocity_1_m_s`` = ẋ, the normal velocity
    toward the plate); the tangential ones in the record's tangential channels
    (``tangential_velocity_m_s``, ``spin_rad_s``, ``tangential_force_n``; the contact point's
    slip is v_t − R·ω), as :func:`impactbench.reference.oblique.record_metrics` reads them.
    ``samples`` nearly even samples cover the contact, each mode switch is a sample (two at a
    force jump), plus four samples of free flight on each side.
    """
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 16:
        raise ValueError(f"samples = {samples!r}: must be an integer >= 16")
    if scenario.tangential == MICRO_SLIP:
        return _micro_history(scenario, samples, rtol)
    solution = integrate_scenario(scenario, None, rtol)
    prob = _Problem(scenario, scenario.tangential)
    segs = solution.segments
    total = segs[-1].t1
    pad = 4
    grid = np.linspace(0.0, total, samples - 2 * pad)
    rows: list[tuple[float, np.ndarray, float]] = []
    for seg in segs:
        ts = np.concatenate([[seg.t0], grid[(grid > seg.t0) & (grid < seg.t1)], [seg.t1]])
        for t in ts:
            y = seg.sol(t)
            rows.append((float(t), y, prob.tangential_force(seg.mode, seg.sign, y)))
    t = np.array([r[0] for r in rows])
    y = np.array([r[1] for r in rows])
    ft = np.array([r[2] for r in rows])
    fn = np.array([prob.law.force(yy[0], yy[1]) for yy in y])
    # the contact ends exactly here (the event's root carries ~1e-19 m of round-off)
    fn[-1] = 0.0
    if not prob.law.linear:
        y[-1, 0] = 0.0
    dt = total / (samples - 2 * pad - 1)
    before = -dt * np.arange(pad, 0, -1)
    after = dt * np.arange(1, pad + 1)
    v_n, end = prob.v_n, solution.end
    x = np.concatenate([v_n * before, y[:, 0], y[-1, 0] + end[1] * after])
    v = np.concatenate([np.full(pad, v_n), y[:, 1], np.full(pad, end[1])])
    vt = np.concatenate([np.full(pad, scenario.tangential_velocity_m_s), y[:, 2],
                         np.full(pad, end[2])])
    w = np.concatenate([np.full(pad, scenario.spin_rad_s), y[:, 3], np.full(pad, end[3])])
    f_t = np.concatenate([np.zeros(pad), ft, np.zeros(pad)])
    time = np.concatenate([before, t, total + after])
    return ImpactRecord(
        time_s=time, penetration_m=x, penetration_rate_m_s=v,
        normal_force_n=np.concatenate([np.zeros(pad), fn, np.zeros(pad)]),
        velocity_1_m_s=v, velocity_2_m_s=np.zeros_like(time), mass_1_kg=scenario.mass_kg,
        mass_2_kg=math.inf, status=Status.OK,
        meta={"engine": "reference", "mode": f"integrated_{scenario.tangential}",
              "scenario": scenario.name, "parameters": scenario.to_dict()},
        tangential_velocity_m_s=vt, spin_rad_s=w, tangential_force_n=f_t,
    )


def _micro_history(scenario: Oblique, samples: int, rtol: float) -> ImpactRecord:
    """:func:`history` of the Mindlin–Deresiewicz impact: ``samples`` − 8 of its step times
    (evenly spread, the first and the last included) plus four samples of free flight on each
    side."""
    md = micro_slip(scenario, rtol=rtol)
    pad = 4
    idx = np.unique(np.linspace(0, md.time_s.size - 1, samples - 2 * pad).round().astype(int))
    total = float(md.time_s[-1])
    dt = total / (samples - 2 * pad - 1)
    before = -dt * np.arange(pad, 0, -1)
    after = dt * np.arange(1, pad + 1)
    v_n, v_end = scenario.normal_velocity_m_s, float(md.rate[-1])
    vt_end, w_end = float(md.tangential_velocity[-1]), float(md.spin[-1])
    x = np.concatenate([v_n * before, md.x[idx], v_end * after])
    v = np.concatenate([np.full(pad, v_n), md.rate[idx], np.full(pad, v_end)])
    time = np.concatenate([before, md.time_s[idx], total + after])
    return ImpactRecord(
        time_s=time, penetration_m=x, penetration_rate_m_s=v,
        normal_force_n=np.concatenate([np.zeros(pad), md.normal_force_n[idx], np.zeros(pad)]),
        velocity_1_m_s=v, velocity_2_m_s=np.zeros_like(time), mass_1_kg=scenario.mass_kg,
        mass_2_kg=math.inf, status=Status.OK,
        meta={"engine": "reference", "mode": f"integrated_{scenario.tangential}",
              "scenario": scenario.name, "parameters": scenario.to_dict()},
        tangential_velocity_m_s=np.concatenate([
            np.full(pad, scenario.tangential_velocity_m_s), md.tangential_velocity[idx],
            np.full(pad, vt_end)]),
        spin_rad_s=np.concatenate([np.full(pad, scenario.spin_rad_s), md.spin[idx],
                                   np.full(pad, w_end)]),
        tangential_force_n=np.concatenate([np.zeros(pad), md.tangential_force_n[idx],
                                           np.zeros(pad)]),
    )
