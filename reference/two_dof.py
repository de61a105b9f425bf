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
to a few ulps of t — far below 1e-10 s), never stepped over. Multiple impacts follow.

The run ends
- ``ok``: when no further contact is possible — body 1 moves away (v1 ≤ 0) and is beyond the
  reach of body 2, whose energy E2 = ½·m2·v2² + Π(x2) bounds |x2|
  (:func:`impactbench.reference.laws.no_further_contact`, with the permanent set of the contact);
- ``structure_collapsed``: when E2 rises through the peak of the softening potential
  k2²/(4β). dE2/dt = F1·v2 ≥ 0 while v2 > 0 and E2 can only rise while v2 > 0, so from that
  instant ½·m2·v2² ≥ E2 − Π_max > 0 forever: x2 runs away. Detected, never integrated to
  overflow;
- ``max_time``: at the scenario's ``max_time_s``.

:func:`simulate` returns the time history (an :class:`~impactbench.reference.record.ImpactRecord`
with a
sample at every event and at every velocity reversal inside a contact, so the shared metrics
find exact contact edges and the exact peak); :func:`solve` returns the metrics and the energy
partition; :func:`sweep` runs a parameter sweep over all law combinations in parallel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from impactbench.reference import metrics
from impactbench.reference.laws import LocalLaw, Piece, StructuralLaw
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import RigidFlexible
from scipy import integrate, optimize

RTOL = 1e-11
ATOL_M = 1e-14
"""Default integration tolerances of :func:`simulate` (relative; absolute in m and m/s)."""

CONTACT_SAMPLES_PER_RAD = 2000.0
"""Samples per radian of the fastest mode inside a contact (trapezoid ∫F dt to ~1e-8)."""
FREE_SAMPLES_PER_RAD = 20.0
MAX_EVENTS = 100_000
MAX_STEP_RAD = 0.05
"""Largest integration step, in radians of the fastest mode of the piece."""

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


def _omega_max(piece: Piece, sc: RigidFlexible) -> float:
    """Upper bound of the fastest angular frequency (rad/s) in this piece."""
    return math.sqrt(piece.stiffness / sc.m1_kg + (piece.stiffness + sc.k2_n_per_m) / sc.m2_kg)


def _energy_2(structure: StructuralLaw, m2: float, x2: float, v2: float) -> float:
    return 0.5 * m2 * v2 * v2 + structure.potential(x2)


def _integrate(run: _Run, rtol: float, atol: float) -> None:
    sc, local, structure = run.scenario, run.local, run.structure
    m1, m2 = sc.m1_kg, sc.m2_kg
    t_cap = sc.max_time_s
    e_collapse = structure.collapse_energy
    y = np.array([0.0, 0.0, sc.velocity_m_s, 0.0])
    t = 0.0
    # the first contact starts at t = 0 (Δx = 0, Δẋ = v1 > 0)
    start = next(b for b in local.piece("free").boundaries if b.kind == "start")
    local.commit("start", 0.0)
    mode = start.next_mode
    run.events.append(Event(0.0, "start", mode, tuple(y)))
    atol_vec = np.array([atol, atol, atol * max(1.0, sc.velocity_m_s) * 1e3,
                         atol * max(1.0, sc.velocity_m_s) * 1e3])
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
        if piece.contact and math.isfinite(e_collapse):
            def g_c(_t: float, s: np.ndarray) -> float:
                return _energy_2(structure, m2, s[1], s[3]) - e_collapse
            g_c.terminal, g_c.direction = True, 1  # type: ignore[attr-defined]
            events.append(g_c)
            labels.append(("collapse", mode))
        if not piece.contact:
            threshold = local.contact_threshold()
            if _no_further_contact(y, threshold, m2, structure):
                run.events.append(Event(t, "done", mode, tuple(y)))
                return
            if y[2] < 0.0:
                reach = structure.reach(_energy_2(structure, m2, y[1], y[3]))

                def g_d(_t: float, s: np.ndarray, reach: float = reach,
                        threshold: float = threshold) -> float:
                    return s[0] - threshold + reach
                g_d.terminal, g_d.direction = True, -1  # type: ignore[attr-defined]
                events.append(g_d)
                labels.append(("done", mode))
        if t >= t_cap:
            run.status, run.message = Status.MAX_TIME, f"time cap {t_cap:g} s reached"
            return
        # events are detected as sign changes between steps: a step bounded by a fraction
        # of the fastest period cannot hide a dip and return of an event function
        sol = integrate.solve_ivp(rhs, (t, t_cap), y, method="DOP853", rtol=rtol,
                                  atol=atol_vec, events=events, dense_output=True,
                                  max_step=MAX_STEP_RAD / _omega_max(piece, sc))
        hit = [(te[0], i) for i, te in enumerate(sol.t_events) if te.size]
        t_end = float(sol.t[-1])
        if hit:
            t_end, idx = min(hit)
            t_end = float(t_end)
        y_end = sol.sol(t_end)
        run.phases.append(_sample_phase(sol.sol, t, t_end, piece, sc))
        t, y = t_end, np.asarray(y_end, dtype=float)
        if not hit:
            run.status, run.message = Status.MAX_TIME, f"time cap {t_cap:g} s reached"
            return
        kind, next_mode = labels[idx]
        if kind == "collapse":
            run.status = Status.STRUCTURE_COLLAPSED
            run.message = (f"body 2's energy passed the softening potential's peak "
                           f"k2²/(4β) = {e_collapse:.6g} J at t = {t:.6g} s")
            run.events.append(Event(t, kind, mode, tuple(y)))
            return
        if kind == "done":
            run.events.append(Event(t, kind, mode, tuple(y)))
            return
        local.commit(kind, float(y[0] - y[1]))
        mode = next_mode
        run.events.append(Event(t, kind, mode, tuple(y)))
    run.status, run.message = Status.MAX_TIME, f"more than {MAX_EVENTS} events"


def _no_further_contact(y: np.ndarray, threshold: float, m2: float,
                        structure: StructuralLaw) -> bool:
    from impactbench.reference.laws import no_further_contact

    return no_further_contact(float(y[0]) - threshold, float(y[2]), float(y[1]), float(y[3]),
                              m2, structure)


def _sample_phase(dense: Any, ta: float, tb: float, piece: Piece,
                  sc: RigidFlexible) -> _Phase:
    """Sample a piece densely; add every velocity reversal inside a contact (force maxima)."""
    omega = _omega_max(piece, sc)
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
    out: dict[str, Any] = {"status": str(rec.status)}
    out.update({k: m[k] for k in METRIC_KEYS})
    out["impacts"] = int(m["impacts"])
    out.update(energy_partition(scenario, run.events[-1].state, run.local))
    return out


def solve_fast(scenario: RigidFlexible) -> dict[str, Any]:
    """:func:`solve` through the compiled kernel (:mod:`impactbench.reference.two_dof_fast`)."""
    from impactbench.reference import two_dof_fast

    r = two_dof_fast.run(scenario)
    out: dict[str, Any] = {"status": two_dof_fast.STATUS_NAMES[int(r[0])]}
    out.update(zip(METRIC_KEYS, (float(r[1]), float(r[2]), float(r[3]), float(r[4]),
                                 int(r[5])), strict=True))
    local = scenario.local_law()
    if scenario.local == "elastoplastic":
        local.max_dx = float(r[11])  # type: ignore[attr-defined]
    elif scenario.local == "mutation":
        local.failed = bool(r[12])  # type: ignore[attr-defined]
    out.update(energy_partition(scenario, (r[7], r[8], r[9], r[10]), local))
    return out


def solve(scenario: RigidFlexible) -> dict[str, Any]:
    """Metrics and energy partition of one impact.

    Keys: ``status``, ``peak_force_n``, ``pulse_width_s``, ``contact_time_s``, ``impulse_ns``,
    ``impacts`` and those of :func:`energy_partition`. The built-in laws go through the
    compiled kernel (:func:`solve_fast`, ~30 µs), any other law through :func:`solve_slow`
    (simulate + the shared metrics); a test shows the two agree.
    """
    from impactbench.reference import two_dof_fast

    if scenario.local in two_dof_fast.LOCAL_CODES and scenario.structure in (
            "linear", "softening"):
        return solve_fast(scenario)
    return solve_slow(scenario)


SWEEP_FIELDS: dict[str, str] = {
    "velocity": "velocity_m_s", "k1": "k1_n_per_m", "k2": "k2_n_per_m", "m2": "m2_kg",
}
"""Sweepable parameters (CLI name → scenario field, SI)."""

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


def _sweep_chunk(args: tuple[RigidFlexible, str, list[float]]) -> list[dict[str, Any]]:
    base, over, values = args
    fld = SWEEP_FIELDS[over]
    rows = []
    for v in values:
        r = solve(with_parameter(base, over, v))
        row: dict[str, Any] = {"local": base.local, "structure": base.structure, fld: float(v)}
        row.update({k: r[k] for k in METRIC_KEYS})
        row["status"] = r["status"]
        rows.append(row)
    return rows


def sweep(base: RigidFlexible, over: str, values: Any, *,
          combos: Any = None, processes: int | None = None,
          progress: Any = None) -> Any:
    """Solve ``base`` with ``over`` (velocity, k1, k2, m2) set to each of ``values`` (SI).

    ``combos``: (local, structure) pairs; None sweeps all 3 × 2 law combinations.
    ``processes``: worker processes (default: all cores; 1 runs in this process).
    ``progress``: optional callable(n) called with the number of points just finished.
    A k1 sweep scales kt and k1' with k1 (:func:`with_parameter`).
    Returns a pandas DataFrame, one row per point in a deterministic order (combo, value):
    ``local``, ``structure``, the swept field, the five metrics, ``status``.
    """
    import os

    import pandas as pd
    from impactbench.reference import validation as check

    check.one_of("over", over, tuple(SWEEP_FIELDS))
    fld = SWEEP_FIELDS[over]
    vals = [check.positive(fld, float(v)) for v in np.asarray(values, dtype=float).reshape(-1)]
    combos = ALL_COMBOS if combos is None else tuple(tuple(c) for c in combos)
    procs = (os.cpu_count() or 1) if processes is None else int(processes)
    if procs < 1:
        raise ValueError(f"processes = {processes!r}: must be >= 1")
    chunk = max(1, min(500, math.ceil(len(vals) / (4 * procs))))
    tasks = [(base.replace(local=loc, structure=st), over, vals[i:i + chunk])
             for loc, st in combos for i in range(0, len(vals), chunk)]
    rows: list[dict[str, Any]] = []
    if procs == 1 or len(tasks) == 1:
        for task in tasks:
            rows.extend(_sweep_chunk(task))
            if progress:
                progress(len(task[2]))
    else:
        import multiprocessing as mp

        with mp.get_context("fork").Pool(procs) as pool:
            for part, task in zip(pool.imap(_sweep_chunk, tasks), tasks, strict=True):
                rows.extend(part)
                if progress:
                    progress(len(task[2]))
    columns = ["local", "structure", fld, *METRIC_KEYS, "status"]
    return pd.DataFrame(rows, columns=columns)
