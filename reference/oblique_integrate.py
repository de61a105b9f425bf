"""Direct time integration of the oblique impact: the rigid-Coulomb check and the Mindlin
reference (:mod:`impactbench.reference.oblique` has the physics and the closed form).

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
- *Unloading* (the contact shrinks, ẋ < 0): at a fixed stuck displacement δ Mindlin's no-slip
  solution for the current radius is F_t = 8·G*·a·δ, so the force shrinks with the contact,
  F_t ← F_t·a/a_old = F_t·k_t/k_t,old (here dk_t/k_t = dx/(2x)); the rescaling DEM
  implementations of Mindlin–Deresiewicz apply on unloading (Thornton & Yin 1991). The bare
  increment that keeps F_t while k_t falls (``unloading = "hold"``, for comparison only)
  raises the stored F_t²/(2k_t) from nothing: a stuck elastic sphere (μ = 100, e = 1, 5°)
  leaves with 0.67 % more tangential-plus-spin energy than it brought (``scale``: 19 % less).
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
load reversals, as Thornton's implementations do. Material inputs: E and ν of the ball and the
plate (:class:`Oblique` ``youngs_modulus_pa``, ``poisson``, ``plate_youngs_modulus_pa`` —
``inf``: rigid — and ``plate_poisson``); no tangential damping. An explicit DEM-style stepping
of the same law converges to this solution at first order in the step (tests).

Sources: R. D. Mindlin, "Compliance of elastic bodies in contact", J. Appl. Mech. 16:259–268,
1949; R. D. Mindlin, H. Deresiewicz, "Elastic spheres in contact under varying oblique forces",
J. Appl. Mech. 20:327–344, 1953; P. A. Cundall, O. D. L. Strack, "A discrete numerical model for
granular assemblies", Géotechnique 29(1):47–65, 1979; A. Di Renzo, F. P. Di Maio, "Comparison
of contact-force models for the simulation of collisions in DEM-based granular flow codes",
Chem. Eng. Sci. 59(3):525–541, 2004; Y. C. Chung, J. Y. Ooi, "Benchmark tests for verifying
discrete element modelling codes at particle impact level", Granular Matter 13:643–656, 2011;
C. Thornton, K. K. Yin, "Impact of elastic spheres with and without adhesion", Powder Technol.
65:153–166, 1991.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from impactbench.reference import validation as check
from impactbench.reference.models import KelvinVoigt
from impactbench.reference.oblique_metrics import metrics_of
from impactbench.reference.oblique_scenario import GYRATION_RATIO, OBLIQUE_METRICS, Oblique
from impactbench.reference.record import ImpactRecord, Status
from scipy import integrate, optimize

RTOL = 1e-12
"""Default relative tolerance of the integration (metrics agree with the closed form ≤ 1e-8)."""
MAX_SEGMENTS = 500
"""More mode switches than this in one impact is reported as an error (chattering)."""

SLIP, STICK, ELASTIC, SLIDE = "slip", "stick", "elastic", "slide"
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
        self.k2 = GYRATION_RATIO * self.r**2
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
    model or in ``tangential`` (``rigid`` | ``mindlin``); ``unloading`` is the Mindlin
    spring's rule while the contact shrinks (:data:`UNLOADING_RULES`)."""
    if not isinstance(scenario, Oblique):
        raise ValueError(f"scenario = {scenario!r}: must be an Oblique")
    which = tangential or scenario.tangential
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
