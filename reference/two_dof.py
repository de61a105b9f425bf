"""Event-driven reference solver of the rigid–flexible 2-DOF impact (MODELS.md §2).

Equations (SI: m, s, kg, N), x1, x2 measured from first touch, Δx = x1 − x2:

    m1·ẍ1 = −F1(Δx)              x1(0) = x2(0) = 0, ẋ1(0) = v1
    m2·ẍ2 =  F1(Δx) − F2(x2)     ẋ2(0) = 0

F1 (local law, ≥ 0, with memory) is piecewise affine in Δx; the law describes its pieces and
their switches (:class:`impactbench.reference.laws.Piece`,
:class:`impactbench.reference.laws.Boundary`). Within a
piece the motion is smooth and is integrated with scipy's DOP853 at tight tolerances; every
switch (contact start and end, yield, velocity reversal on the backbone, rejoining the
backbone, failure) is an event located by root finding on the dense output (scipy's brentq,
to a few ulps of t — far below 1e-10 s), never stepped over:

- in contact, Δx's extrema are located too; a Δx threshold crossed and recrossed within one
  step (a graze) shows as a crossing between two extrema (:func:`_missed_switch`);
- in free flight the gap g = Δx − threshold has g̈ = F2(x2)/m2 ≤ A, the structure's largest
  force within body 2's reach over m2, so it cannot reach zero for a time fixed by g, ġ and A
  (:func:`gap_step`); a march over the dense output in such steps finds every contact
  start, however short the separation before it (:func:`_first_start`).

Multiple impacts follow.

The run ends
- ``ok``: when no further contact is possible — body 1 moves away (v1 ≤ 0) and is beyond the
  reach of body 2, whose energy E2 = ½·m2·v2² + Π(x2) bounds |x2|
  (:func:`impactbench.reference.laws.no_further_contact`, with the permanent set of the contact);
- ``structure_collapsed``: the run passed the instant E2 rose through the peak of the softening
  potential k2²/(4β) (an event). dE2/dt = F1·v2 and v2 > 0 from then on (½·m2·v2² ≥
  E2 − Π_max > 0), so body 2 runs away; the run goes on — body 1 may still push or catch it —
  until body 2 is past the potential's peak x_c = √(k2/β) and outruns body 1 (v2 ≥ max(v1, 0)),
  after which no contact is possible (:func:`impactbench.reference.laws.escaped`). The metrics
  then describe the whole contact, as the paper's ode45 runs did;
- ``max_time``: at the scenario's ``max_time_s``, or when the run's step budget is spent
  (:data:`MAX_STEPS`; the compiled path's :data:`two_dof_fast.MAX_STEPS`): a body 2 far
  lighter or stiffer than body 1 vibrates so much faster than the contact lasts that
  resolving it would take hours. The message (``solve``'s ``message``) says which.

:func:`simulate` returns the time history (an :class:`~impactbench.reference.record.ImpactRecord`
with a
sample at every event and at every velocity reversal inside a contact, so the shared metrics
find exact contact edges and the exact peak); :func:`solve` returns the metrics and the energy
partition; :func:`sweep` runs a parameter sweep over all law combinations in parallel.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from impactbench.reference import metrics
from impactbench.reference.laws import LocalLaw, Piece, StructuralLaw, no_further_contact
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import SWEEP_FIELDS, RigidFlexible

# scipy.integrate and scipy.optimize (0.3 s to import) are imported by the functions of the
# event-driven path that use them: a sweep through the compiled kernel needs neither.

RTOL = 1e-11
ATOL_M = 1e-14
"""Default integration tolerances of :func:`simulate` (relative; absolute in m and m/s)."""

CONTACT_SAMPLES_PER_RAD = 2000.0
"""Samples per radian of the fastest mode inside a contact (trapezoid ∫F dt to ~1e-8)."""
FREE_SAMPLES_PER_RAD = 20.0
MAX_EVENTS = 100_000
MAX_STEPS = 10_000
"""Step budget of one :func:`simulate` run (scipy steps over all its pieces, each no longer than
``MAX_STEP_RAD`` of the fastest mode; a piece's span is cut at the budget's worth of
``max_step``, so it holds while the steps reach ``max_step``: 20 001 steps for a budget of
2e4, measured). 2e4 steps took 26 s here (1.3 ms a step with the dense samples). The tests'
and figures' runs take ≤ 4.4e3 (measured; the most: elastoplastic, m2 = 0.3 kg, k2 = 1e3 N/m,
v1 = 100 m/s). A body 2 far lighter or stiffer than body 1 vibrates so much faster than the
contact lasts (√((k1+k2)/m2) against √(k1/m1)) that resolving it takes hours (measured: m2 =
1e-3 kg with the paper's other parameters 1.3e4 steps; m2 = 1e-12 kg ~4e8, ω·T/MAX_STEP_RAD):
the run stops with status max_time and a message saying so."""
MAX_STEP_RAD = 0.05
"""Largest integration step, in radians of the fastest mode of the piece."""
GAP_FLOOR_RAD = 1e-6
"""Shortest step of the free-flight gap march (:func:`_first_start`), in radians of the
fastest contact mode: a contact shorter than that may go unseen."""

METRIC_KEYS: tuple[str, ...] = (
    "peak_force_n", "pulse_width_s", "contact_time_s", "impulse_ns", "impacts",
)
"""The five metrics of the paper (the CLI's JSON object, with ``status``)."""


@dataclass
class Event:
    """One switch: time (s), kind, the law's mode after it and the state [x1, x2, v1, v2]."""

    time_s: float
    kind: str
    mode: str
    state: tuple[float, float, float, float]


@dataclass
class _Phase:
    t: np.ndarray
    y: np.ndarray  # (4, n)
    f: np.ndarray
    piece: Piece


@dataclass
class _Run:
    scenario: RigidFlexible
    local: LocalLaw
    structure: StructuralLaw
    phases: list[_Phase] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    status: Status = Status.OK
    message: str = ""
    steps: int = 0


def _omega_max(piece: Piece, sc: RigidFlexible, x2: float = 0.0) -> float:
    """Upper bound of the fastest angular frequency (rad/s) in this piece, at x2 (m).

    A softening structure's tangent stiffness |k2 − 3β·x2²| exceeds k2 past
    x2 = √(2k2/(3β)) (a collapsed run).
    """
    k2 = sc.k2_n_per_m
    if sc.structure == "softening":
        k2 = max(k2, abs(k2 - 3.0 * sc.beta_n_per_m3 * x2 * x2))
    return math.sqrt(piece.stiffness / sc.m1_kg + (piece.stiffness + k2) / sc.m2_kg)


def _energy_2(structure: StructuralLaw, m2: float, x2: float, v2: float) -> float:
    return 0.5 * m2 * v2 * v2 + structure.potential(x2)


def gap_step(gap: float, rate: float, accel: float) -> float:
    """Time (s) before a free gap can reach zero: the positive root of g + ġ·s + A·s²/2.

    ``gap`` g = Δx − threshold ≤ 0 (m; a positive value counts as 0), ``rate`` ġ (m/s),
    ``accel`` A ≥ sup g̈ (m/s²). Out of contact g̈ = F2(x2)/m2, bounded by the structure's
    largest force within body 2's reach (:meth:`StructuralLaw.max_force`), so the gap
    cannot touch zero within this time: a free-flight step no longer than this cannot hide
    a contact that starts and ends inside it (a separation of 0.8 ms, say, inside a 1.7 ms
    step).
    """
    g = -min(gap, 0.0)
    if accel <= 0.0:
        return g / rate if rate > 0.0 else math.inf
    root = math.sqrt(rate * rate + 2.0 * accel * g)
    return (root - rate) / accel if rate <= 0.0 else 2.0 * g / (rate + root)


def _first_start(dense: Any, ta: float, tb: float, threshold: float, accel: float,
                 floor_s: float) -> float | None:
    """Earliest time in (ta, tb) where a free gap rises through 0, or None.

    Marches over the dense output with steps certified by :func:`gap_step` (never shorter
    than ``floor_s``): a contact cannot start between two points of the march, however
    short it is, unless it lasts less than ``floor_s``. Catches what sign changes between
    the integrator's steps cannot (a contact started and ended within one step).
    """
    from scipy import optimize

    def gap(t: float) -> float:
        s = dense(t)
        return float(s[0] - s[1]) - threshold

    t = ta
    s = dense(t)
    g, rate = float(s[0] - s[1]) - threshold, float(s[2] - s[3])
    for _ in range(MAX_EVENTS):
        tn = t + max(gap_step(g, rate, accel), floor_s)
        if tn >= tb:
            return None
        s = dense(tn)
        gn = float(s[0] - s[1]) - threshold
        if gn >= 0.0:
            if g >= 0.0:
                return tn
            return float(optimize.brentq(gap, t, tn, xtol=1e-15, rtol=1e-15))
        t, g, rate = tn, gn, float(s[2] - s[3])
    return None


def _missed_switch(dense: Any, ta: float, tb: float, extrema: np.ndarray,
                   piece: Piece) -> tuple[float, int] | None:
    """Earliest crossing of a Δx threshold of ``piece`` in (ta, tb) that the integrator's
    sign checks missed, as (time, boundary index), or None.

    Δx is monotone between its extrema, so a threshold crossed and recrossed within one
    step (a graze: Δx barely passing Δx_m to rejoin the backbone, or barely separating) shows
    as a crossing between two consecutive extrema (or the piece's start) — found by brentq.
    """
    from scipy import optimize

    def value(b: Any, t: float) -> float:
        s = dense(t)
        return float(b.value(s[0] - s[1], s[2] - s[3]))

    points = [ta, *(float(te) for te in extrema if ta < te < tb)]
    for t0, t1 in itertools.pairwise(points):
        best: tuple[float, int] | None = None
        for i, b in enumerate(piece.boundaries):
            if b.cv != 0.0:
                continue
            g0, g1 = value(b, t0), value(b, t1)
            if (b.direction > 0 and g0 < 0.0 <= g1) or (b.direction < 0 and g0 > 0.0 >= g1):
                tc = float(optimize.brentq(lambda t, b=b: value(b, t), t0, t1,
                                           xtol=1e-15, rtol=1e-15))
                if best is None or tc < best[0]:
                    best = (tc, i)
        if best is not None:
            return best
    return None


def _integrate(run: _Run, rtol: float, atol: float) -> None:
    from scipy import integrate

    sc, local, structure = run.scenario, run.local, run.structure
    m1, m2 = sc.m1_kg, sc.m2_kg
    t_cap = sc.max_time_s
    e_collapse = structure.collapse_energy
    x_c = structure.collapse_displacement
    k_max = max(sc.k1_n_per_m, sc.kt_n_per_m, sc.k1_failed_n_per_m)
    floor_s = GAP_FLOOR_RAD / math.sqrt(k_max / m1 + (k_max + sc.k2_n_per_m) / m2)
    y = np.array([0.0, 0.0, sc.velocity_m_s, 0.0])
    t = 0.0
    collapsed = False
    # the first contact starts at t = 0 (Δx = 0, Δẋ = v1 > 0)
    start = next(b for b in local.piece("free").boundaries if b.kind == "start")
    local.commit("start", 0.0)
    mode = start.next_mode
    run.events.append(Event(0.0, "start", mode, tuple(y)))
    atol_vec = np.array([atol, atol, atol * max(1.0, sc.velocity_m_s) * 1e3,
                         atol * max(1.0, sc.velocity_m_s) * 1e3])
    steps = 0
    for _ in range(MAX_EVENTS):
        piece = local.piece(mode)
        k, f0 = piece.stiffness, piece.offset

        def rhs(_t: float, s: np.ndarray, k: float = k, f0: float = f0) -> np.ndarray:
            f1 = k * (s[0] - s[1]) + f0 if k > 0.0 else 0.0
            return np.array([s[2], s[3], -f1 / m1, (f1 - structure.force(s[1])) / m2])

        events: list[Any] = []
        labels: list[tuple[str, str]] = []
        for b in piece.boundaries:
            def g(_t: float, s: np.ndarray, b: Any = b) -> float:
                return b.value(s[0] - s[1], s[2] - s[3])
            g.terminal, g.direction = True, b.direction  # type: ignore[attr-defined]
            events.append(g)
            labels.append((b.kind, b.next_mode))
        if piece.contact and math.isfinite(e_collapse) and not collapsed:
            def g_c(_t: float, s: np.ndarray) -> float:
                return _energy_2(structure, m2, s[1], s[3]) - e_collapse
            g_c.terminal, g_c.direction = True, 1  # type: ignore[attr-defined]
            events.append(g_c)
            labels.append(("collapse", mode))
        n_switch = len(events)
        if piece.contact:  # Δx's extrema (non-terminal), to find grazes (_missed_switch)
            def g_x(_t: float, s: np.ndarray) -> float:
                return s[2] - s[3]
            g_x.terminal, g_x.direction = False, 0  # type: ignore[attr-defined]
            events.append(g_x)
            labels.append(("extremum", mode))
        threshold = local.contact_threshold()
        accel = 0.0
        if not piece.contact:
            if _no_further_contact(y, threshold, m2, structure):
                run.events.append(Event(t, "done", mode, tuple(y)))
                return
            reach = structure.reach(_energy_2(structure, m2, y[1], y[3]))
            accel = structure.max_force(reach) / m2
            if y[2] < 0.0 and math.isfinite(reach):
                def g_d(_t: float, s: np.ndarray, reach: float = reach,
                        threshold: float = threshold) -> float:
                    return s[0] - threshold + reach
                g_d.terminal, g_d.direction = True, -1  # type: ignore[attr-defined]
                events.append(g_d)
                labels.append(("done", mode))
            elif not math.isfinite(reach):
                # escaped (laws.escaped): past x_c and at least as fast as body 1 (v1 fixed)
                def g_e(_t: float, s: np.ndarray, v: float = max(float(y[2]), 0.0)) -> float:
                    return min(s[1] - x_c, s[3] - v)
                g_e.terminal, g_e.direction = True, 1  # type: ignore[attr-defined]
                events.append(g_e)
                labels.append(("done", mode))
        if t >= t_cap:
            run.status, run.message = Status.MAX_TIME, f"time cap {t_cap:g} s reached"
            return
        # events are detected as sign changes between steps: a step bounded by a fraction
        # of the fastest period cannot hide a dip and return of a law's switch in contact;
        # in free flight the gap's own bound (_first_start) finds starts the steps hide
        # the step budget: steps are ≤ max_step, so the span left is at most the steps left
        # times max_step (the same steps as to t_cap until then)
        max_step = MAX_STEP_RAD / _omega_max(piece, sc, y[1])
        t_stop = min(t_cap, t + (MAX_STEPS - steps) * max_step)
        if t_stop <= t:
            run.status, run.message = Status.MAX_TIME, _budget_message(sc, t, MAX_STEPS)
            return
        sol = integrate.solve_ivp(rhs, (t, t_stop), y, method="DOP853", rtol=rtol,
                                  atol=atol_vec, events=events, dense_output=True,
                                  max_step=max_step)
        steps += sol.t.size - 1
        run.steps = steps
        hit = [(te[0], i) for i, te in enumerate(sol.t_events)
               if te.size and labels[i][0] != "extremum"]
        t_end = float(sol.t[-1])
        if hit:
            t_end, idx = min(hit)
            t_end = float(t_end)
        if piece.contact:
            missed = _missed_switch(sol.sol, t, t_end, sol.t_events[n_switch], piece)
            if missed is not None:
                t_end, idx = missed
                hit = [missed]
        else:
            early = _first_start(sol.sol, t, t_end, threshold, accel, floor_s)
            if early is not None:
                t_end = early
                idx = next(i for i, lab in enumerate(labels) if lab[0] == "start")
                hit = [(t_end, idx)]
        y_end = sol.sol(t_end)
        run.phases.append(_sample_phase(sol.sol, t, t_end, piece, sc))
        t, y = t_end, np.asarray(y_end, dtype=float)
        if not hit:
            run.status, run.message = Status.MAX_TIME, (
                f"time cap {t_cap:g} s reached" if t_stop >= t_cap
                else _budget_message(sc, t, MAX_STEPS))
            return
        kind, next_mode = labels[idx]
        if kind == "collapse":
            collapsed = True
            run.status = Status.STRUCTURE_COLLAPSED
            run.message = (f"body 2's energy passed the softening potential's peak "
                           f"k2²/(4β) = {e_collapse:.6g} J at t = {t:.6g} s")
            run.events.append(Event(t, kind, mode, tuple(y)))
            continue
        if kind == "done":
            run.events.append(Event(t, kind, mode, tuple(y)))
            return
        local.commit(kind, float(y[0] - y[1]))
        mode = next_mode
        run.events.append(Event(t, kind, mode, tuple(y)))
    run.status, run.message = Status.MAX_TIME, f"more than {MAX_EVENTS} events"


def _budget_message(sc: RigidFlexible, t: float, budget: int) -> str:
    """Why a run stopped on its step budget: the fastest mode against the contact's (rad/s)."""
    k = max(sc.k1_n_per_m, sc.kt_n_per_m, sc.k1_failed_n_per_m)
    fastest = math.sqrt(k / sc.m1_kg + (k + sc.k2_n_per_m) / sc.m2_kg)
    contact = math.sqrt(sc.k1_n_per_m / sc.m1_kg)
    return (f"step budget of {budget:.0e} steps spent at t = {t:.3g} s of max_time_s = "
            f"{sc.max_time_s:g} s: the fastest mode, {fastest:.3g} rad/s, is "
            f"{fastest / contact:.3g} times the contact's √(k1/m1) = {contact:.3g} rad/s "
            "(body 2 too light or too stiff for a step-by-step reference)")


def _no_further_contact(y: np.ndarray, threshold: float, m2: float,
                        structure: StructuralLaw) -> bool:
    return no_further_contact(float(y[0]) - threshold, float(y[2]), float(y[1]), float(y[3]),
                              m2, structure)


def _sample_phase(dense: Any, ta: float, tb: float, piece: Piece,
                  sc: RigidFlexible) -> _Phase:
    """Sample a piece densely; add every velocity reversal inside a contact (force maxima)."""
    from scipy import optimize

    # a collapsed structure stiffens (|k2 − 3β·x2²|) as x2 runs away: bound at both ends
    omega = max(_omega_max(piece, sc, float(dense(ta)[1])),
                _omega_max(piece, sc, float(dense(tb)[1])))
    per_rad = CONTACT_SAMPLES_PER_RAD if piece.contact else FREE_SAMPLES_PER_RAD
    n = int(min(max(math.ceil((tb - ta) * omega * per_rad), 2), 2_000_000)) + 1
    t = np.linspace(ta, tb, n)
    if tb <= ta:
        t = np.array([ta, tb])
    y = np.asarray(dense(t), dtype=float).reshape(4, -1)
    if piece.contact:
        rate = y[2] - y[3]
        turns = np.flatnonzero((rate[:-1] > 0.0) & (rate[1:] <= 0.0))
        extra = []
        for i in turns:
            if rate[i + 1] == 0.0:
                continue

            def r(s: float) -> float:
                v = dense(s)
                return float(v[2] - v[3])
            extra.append(optimize.brentq(r, t[i], t[i + 1], xtol=1e-15, rtol=1e-15))
        if extra:
            t = np.sort(np.concatenate([t, extra]))
            y = np.asarray(dense(t), dtype=float).reshape(4, -1)
    y[:, 0] = dense(ta)
    y[:, -1] = dense(tb)
    if piece.contact and t.size > 3:
        # samples just inside each edge (δ = 1e-6 rad): the shared metrics extrapolate the
        # force to zero from the first two samples inside a contact, to ~1e-14 s
        delta = 1e-6 / omega
        edge = np.array([ta + delta, tb - delta])
        t = np.concatenate([t[:1], edge[:1], t[1:-1], edge[1:], t[-1:]])
        y = np.concatenate([y[:, :1], dense(edge[0]).reshape(4, 1), y[:, 1:-1],
                            dense(edge[1]).reshape(4, 1), y[:, -1:]], axis=1)
    f = np.maximum(piece.stiffness * (y[0] - y[1]) + piece.offset, 0.0) if piece.contact \
        else np.zeros_like(t)
    return _Phase(t, y, f, piece)


def _run(scenario: RigidFlexible, rtol: float, atol: float) -> _Run:
    if not isinstance(scenario, RigidFlexible):
        raise ValueError(f"scenario = {type(scenario).__name__}: must be a RigidFlexible")
    run = _Run(scenario, scenario.local_law(), scenario.structural_law())
    _integrate(run, rtol, atol)
    return run


def _record(run: _Run) -> ImpactRecord:
    sc = run.scenario
    t = np.concatenate([p.t for p in run.phases])
    y = np.concatenate([p.y for p in run.phases], axis=1)
    f = np.concatenate([p.f for p in run.phases])
    # phases share their end points: keep one sample where the force is continuous, both
    # (at one instant) where it jumps (stiffness mutation)
    keep = np.ones(t.size, dtype=bool)
    i = 0
    for p in run.phases[:-1]:
        i += p.t.size
        if f[i - 1] == f[i]:
            keep[i - 1] = False
    t, y, f = t[keep], y[:, keep], f[keep]
    meta = {
        "producer": "impactbench.reference.two_dof",
        "scenario": sc.to_dict(),
        "events": [(e.time_s, e.kind, e.mode) for e in run.events],
        "final_state": run.events[-1].state if run.events else None,
    }
    return ImpactRecord(
        time_s=t, penetration_m=y[0] - y[1], penetration_rate_m_s=y[2] - y[3],
        normal_force_n=f, velocity_1_m_s=y[2], velocity_2_m_s=y[3], mass_1_kg=sc.m1_kg,
        mass_2_kg=sc.m2_kg, status=run.status, message=run.message, displacement_2_m=y[1],
        meta=meta,
    )


def simulate(scenario: RigidFlexible, *, rtol: float = RTOL, atol: float = ATOL_M
             ) -> ImpactRecord:
    """Time history of one rigid–flexible impact (see the module docstring).

    ``penetration_m`` is Δx = x1 − x2, ``velocity_1_m_s``/``velocity_2_m_s`` the body
    velocities, ``displacement_2_m`` is x2. A force jump (stiffness mutation) is two samples
    at one instant. ``meta["events"]`` lists (time_s, kind, mode) of every switch.
    """
    return _record(_run(scenario, rtol, atol))


def energy_partition(scenario: RigidFlexible, state: tuple[float, float, float, float],
                     local: LocalLaw) -> dict[str, float]:
    """Final velocities and energies (J): kinetic of each body, structural, contact, dissipated.

    ``dissipated_energy_j`` = initial kinetic energy − everything still stored (plastic work
    of the elastoplastic contact; the energy released by a stiffness mutation).
    """
    x1, x2, v1, v2 = (float(s) for s in state)
    structure = scenario.structural_law()
    e0 = 0.5 * scenario.m1_kg * scenario.velocity_m_s**2
    out = {
        "final_velocity_1_m_s": v1,
        "final_velocity_2_m_s": v2,
        "final_displacement_2_m": x2,
        "initial_energy_j": e0,
        "kinetic_energy_1_j": 0.5 * scenario.m1_kg * v1 * v1,
        "kinetic_energy_2_j": 0.5 * scenario.m2_kg * v2 * v2,
        "structural_energy_j": structure.potential(x2),
        "contact_energy_j": local.stored_energy(x1 - x2),
    }
    out["dissipated_energy_j"] = e0 - (out["kinetic_energy_1_j"] + out["kinetic_energy_2_j"]
                                       + out["structural_energy_j"] + out["contact_energy_j"])
    return out


def solve_slow(scenario: RigidFlexible, *, rtol: float = RTOL, atol: float = ATOL_M
               ) -> dict[str, Any]:
    """:func:`solve` through :func:`simulate` and :func:`impactbench.reference.metrics.compute`."""
    run = _run(scenario, rtol, atol)
    rec = _record(run)
    m = metrics.compute(rec)
    out: dict[str, Any] = {"status": str(rec.status), "message": rec.message}
    out.update({k: m[k] for k in METRIC_KEYS})
    out["impacts"] = int(m["impacts"])
    out.update(energy_partition(scenario, run.events[-1].state, run.local))
    return out


def solve_fast(scenario: RigidFlexible) -> dict[str, Any]:
    """:func:`solve` through the compiled kernel (:mod:`impactbench.reference.two_dof_fast`)."""
    from impactbench.reference import two_dof_fast

    r = two_dof_fast.run(scenario)
    status = two_dof_fast.STATUS_NAMES[int(r[0])]
    message = ""
    if r[13] >= two_dof_fast.MAX_STEPS:
        message = _budget_message(scenario, float(r[6]), two_dof_fast.MAX_STEPS)
    elif status == "max_time":
        message = f"time cap {scenario.max_time_s:g} s reached"
    out: dict[str, Any] = {"status": status, "message": message}
    out.update(zip(METRIC_KEYS, (float(r[1]), float(r[2]), float(r[3]), float(r[4]),
                                 int(r[5])), strict=True))
    local = scenario.local_law()
    if scenario.local in ("elastoplastic", "mutation-continuous"):
        local.max_dx = float(r[11])  # type: ignore[attr-defined]
    elif scenario.local == "mutation":
        local.failed = bool(r[12])  # type: ignore[attr-defined]
    out.update(energy_partition(scenario, (r[7], r[8], r[9], r[10]), local))
    return out


def solve(scenario: RigidFlexible) -> dict[str, Any]:
    """Metrics and energy partition of one impact.

    Keys: ``status``, ``message`` (why a run stopped short: its time cap or its step budget,
    :data:`two_dof_fast.MAX_STEPS` or :data:`MAX_STEPS`; else empty), ``peak_force_n``,
    ``pulse_width_s``, ``contact_time_s``, ``impulse_ns``, ``impacts`` and those of
    :func:`energy_partition`. The built-in laws go through the
    compiled kernel (:func:`solve_fast`, ~30 µs), any other law through :func:`solve_slow`
    (simulate + the shared metrics); a test shows the two agree.
    """
    from impactbench.reference import two_dof_fast

    if scenario.local in two_dof_fast.LOCAL_CODES and scenario.structure in (
            "linear", "softening"):
        return solve_fast(scenario)
    return solve_slow(scenario)


ALL_COMBOS: tuple[tuple[str, str], ...] = tuple(
    (loc, st) for loc in ("linear", "elastoplastic", "mutation") for st in ("linear", "softening")
)


def with_parameter(base: RigidFlexible, over: str, value: float) -> RigidFlexible:
    """``base`` with the swept parameter ``over`` set to ``value`` (SI).

    Sweeping k1 keeps kt and k1' the same fractions of k1 as in ``base`` (the paper gives
    them as 20 % and 50 % of k1); otherwise a small k1 would 'fail' to a stiffer k1'.
    """
    fld = SWEEP_FIELDS[over]
    changes: dict[str, float] = {fld: float(value)}
    if over == "k1":
        ratio = float(value) / base.k1_n_per_m
        changes["kt_n_per_m"] = base.kt_n_per_m * ratio
        changes["k1_failed_n_per_m"] = base.k1_failed_n_per_m * ratio
    return base.replace(**changes)


SWEEP_CHUNK = 250
"""Values per sweep task. Fixed, so the tasks (and the points a results store keeps) do not
depend on how many processes solve them; 250 solves take ~5 ms with the compiled kernel."""

SweepTask = tuple[RigidFlexible, str, list[float]]
"""(scenario with its laws, swept parameter, values): one chunk of a sweep."""


def _fast(scenario: RigidFlexible) -> bool:
    """True when the compiled kernel solves this scenario's laws (every built-in law)."""
    from impactbench.reference import two_dof_fast

    return scenario.local in two_dof_fast.LOCAL_CODES and scenario.structure in (
        "linear", "softening")


def _swept_values(over: str, values: Any) -> np.ndarray:
    """``values`` as a flat float array once ``over`` is a sweep field (:data:`SWEEP_FIELDS`)
    and every value is > 0 and finite; else the one-line ValueError of the first bad one."""
    from impactbench.reference import validation as check

    check.one_of("over", over, tuple(SWEEP_FIELDS))
    fld = SWEEP_FIELDS[over]
    v = np.asarray(values, dtype=float).reshape(-1)
    bad = ~(np.isfinite(v) & (v > 0.0))
    if bad.any():
        check.positive(fld, float(v[np.argmax(bad)]))
    return v


def check_points(base: RigidFlexible, over: str, values: Any) -> np.ndarray:
    """``values`` (SI) as a float array once every point of ``base`` swept over ``over`` is
    a valid scenario; else the ValueError that point's :class:`RigidFlexible` raises (the
    first bad one), without building a scenario per point.

    The swept field must be > 0 and finite; a k1 sweep scales kt and k1' with k1
    (:func:`with_parameter`), so they must stay > 0 and finite and keep the energy rules of
    ``base``'s local law (kt ≤ k1, k1' ≤ k1) after rounding."""
    v = _swept_values(over, values)
    if over == "k1":
        ratio = v / base.k1_n_per_m
        kt, k1f = base.kt_n_per_m * ratio, base.k1_failed_n_per_m * ratio
        bad = ~(np.isfinite(kt) & (kt > 0.0) & np.isfinite(k1f) & (k1f > 0.0))
        if base.local == "elastoplastic":
            bad |= kt > v
        elif base.local == "mutation":
            bad |= k1f > v
        if bad.any():
            with_parameter(base, over, float(v[np.argmax(bad)]))  # raises its own message
    return v


def sweep_params(base: RigidFlexible, over: str, values: Any) -> np.ndarray:
    """The compiled kernel's inputs (n, 11: :data:`two_dof_fast.PARAMS`) of ``base`` with
    ``over`` at each of ``values``, computed as :func:`with_parameter` and
    :func:`two_dof_fast.run` compute them for one point (the same floats), with the points
    validated at once (:func:`check_points`): a chunk costs one array, not a scenario and
    its validation per point."""
    from impactbench.reference import two_dof_fast

    v = check_points(base, over, values)
    _, row = two_dof_fast.kernel_params(base)
    p = np.tile(np.asarray(row, dtype=float), (v.size, 1))
    names = two_dof_fast.PARAMS
    if over == "k1":
        ratio = v / base.k1_n_per_m
        p[:, names.index("k1_n_per_m")] = v
        kt, k1f = base.kt_n_per_m * ratio, base.k1_failed_n_per_m * ratio
        p[:, names.index("k1_failed_n_per_m")] = k1f
        if base.local == "mutation-continuous":  # the kernel's kt = k1', εs = F_m/k1
            p[:, names.index("kt")] = k1f
            p[:, names.index("eps_s")] = base.fm_n / v
        else:
            p[:, names.index("kt")] = kt
    else:
        p[:, names.index(SWEEP_FIELDS[over])] = v
    return p


def sweep_tasks(base: RigidFlexible, over: str, values: Any, combos: Any = None
                ) -> list[SweepTask]:
    """The chunks of a sweep, in order (combo, value): ``base`` with each (local, structure)
    of ``combos`` (None: all 3 × 2), ``over`` (velocity, k1, k2, m2) at ``values`` (SI, > 0)
    in :data:`SWEEP_CHUNK`-value chunks. One-line ValueError on bad input: every point is
    checked here, once (:func:`check_points`)."""
    v = _swept_values(over, values)
    vals = v.tolist()
    combos = ALL_COMBOS if combos is None else tuple(tuple(c) for c in combos)
    tasks = []
    for loc, st in combos:
        sc = base.replace(local=loc, structure=st)
        if over == "k1":  # kt, k1' and this combination's energy rules at every point
            check_points(sc, over, v)
        tasks += [(sc, over, vals[i:i + SWEEP_CHUNK]) for i in range(0, len(vals), SWEEP_CHUNK)]
    return tasks


def sweep_block(task: SweepTask) -> dict[str, Any]:
    """Solve one chunk into columns: ``local`` and ``structure`` (one string each), the
    swept field (a float array), the five metrics (arrays; ``impacts`` int64) and ``status``
    (a list). The built-in laws go through one call of the compiled kernel for the whole
    chunk (:func:`two_dof_fast.run_many`): the numbers of :func:`solve` point by point, bit
    for bit."""
    from impactbench.reference import two_dof_fast

    base, over, values = task
    fld = SWEEP_FIELDS[over]
    v = np.asarray(values, dtype=float).reshape(-1)
    if not _fast(base):  # a law the kernel does not know: the event-driven path per point
        rows = sweep_chunk(task)
        return {"local": base.local, "structure": base.structure, fld: v,
                **{k: np.array([r[k] for r in rows]) for k in METRIC_KEYS},
                "status": [r["status"] for r in rows]}
    r = two_dof_fast.run_many(two_dof_fast.LOCAL_CODES[base.local],
                              sweep_params(base, over, v))
    names = two_dof_fast.RESULTS
    out: dict[str, Any] = {"local": base.local, "structure": base.structure, fld: v}
    for k in METRIC_KEYS:
        col = r[:, names.index(k)]
        out[k] = col.astype(np.int64) if k == "impacts" else col
    out["status"] = [two_dof_fast.STATUS_NAMES[int(c)] for c in r[:, names.index("status")]]
    return out


def sweep_chunk(task: SweepTask) -> list[dict[str, Any]]:
    """Solve one chunk: a row per value (``local``, ``structure``, the swept field, the
    metrics, ``status``)."""
    base, over, values = task
    fld = SWEEP_FIELDS[over]
    if _fast(base):
        block = sweep_block(task)
        return [{"local": base.local, "structure": base.structure, fld: float(v),
                 **{k: (int(block[k][i]) if k == "impacts" else float(block[k][i]))
                    for k in METRIC_KEYS}, "status": block["status"][i]}
                for i, v in enumerate(values)]
    rows = []
    for v in values:
        r = solve(with_parameter(base, over, v))
        row: dict[str, Any] = {"local": base.local, "structure": base.structure, fld: float(v)}
        row.update({k: r[k] for k in METRIC_KEYS})
        row["status"] = r["status"]
        rows.append(row)
    return rows


def sweep_columns(over: str) -> list[str]:
    """The columns of a sweep's frame."""
    return ["local", "structure", SWEEP_FIELDS[over], *METRIC_KEYS, "status"]


def sweep_frame(over: str, blocks: list[dict[str, Any]]) -> Any:
    """The sweep's frame from :func:`sweep_block` results in row order: the frame a list of
    :func:`sweep_chunk` rows gives (same dtypes: strings, float64, int64), built by column."""
    import pandas as pd

    columns = sweep_columns(over)
    if not blocks or not any(len(b["status"]) for b in blocks):
        return pd.DataFrame([], columns=columns)
    fld = SWEEP_FIELDS[over]
    data: dict[str, Any] = {}
    for name in ("local", "structure"):
        data[name] = [x for b in blocks for x in [b[name]] * len(b["status"])]
    for name in (fld, *METRIC_KEYS):
        data[name] = np.concatenate([np.asarray(b[name]) for b in blocks])
    data["status"] = [x for b in blocks for x in b["status"]]
    return pd.DataFrame(data, columns=columns)


def sweep(base: RigidFlexible, over: str, values: Any, *, combos: Any = None,
          progress: Any = None) -> Any:
    """Solve ``base`` with ``over`` (velocity, k1, k2, m2) set to each of ``values`` (SI),
    in this process (:func:`impactbench.sweeps.rigid_flexible` runs the same tasks on Dask
    workers with a results store and gives the same frame).

    ``combos``: (local, structure) pairs; None sweeps all 3 × 2 law combinations.
    ``progress``: optional callable(n) called with the number of points just finished.
    A k1 sweep scales kt and k1' with k1 (:func:`with_parameter`).
    Returns a pandas DataFrame, one row per point in a deterministic order (combo, value):
    ``local``, ``structure``, the swept field, the five metrics, ``status``.
    """
    blocks = []
    for task in sweep_tasks(base, over, values, combos):
        blocks.append(sweep_block(task))
        if progress:
            progress(len(task[2]))
    return sweep_frame(over, blocks)
