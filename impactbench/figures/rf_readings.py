"""Readings of Zhou & Xiao's garbled eqs. 4–5 and unstated settings, against the paper's numbers.

Our copy of the paper loses eq. 5 (stiffness mutation) and the Greek letters of eq. 4; it
gives kt and k1' as "20 %" and "50 %", the k2 range with a typo ("k1 ∈ [10², 10⁶] N/m") and
the solver only as "ode45". Each reading below changes one of these; :func:`numbers`
computes, for one reading, every number the paper states that the reading can move, and
:func:`table` writes them against the paper's. The default reading is the one that
reproduces the most (``reports/rigid_flexible.md``); each other reading changes one item of it.

- ``default``: mutation = irreversible drop k1 → k1' when F1 first reaches F_m (the force
  jumps down); eq. 4 = elastic unloading from Δx_m with slope k1 (its subscripts
  "1 1 s m t m s" fit k1·(Δx + εs − Δx_m) + kt·(Δx_m − εs) exactly); kt, k1' fractions
  of k1 (scaled with k1 in the k1 sweep); the k2 range read in kN/m (10²…10⁶ kN/m, so
  the sweep ends at 10⁹ N/m: :data:`K2_END_N_PER_M`); the exact event-driven solver.
- ``k2-n-per-m``: the k2 range as printed, 10²…10⁶ N/m.
- ``mutation-continuous``: mutation with the force continuous at failure — k1 up to F_m,
  then slope k1', unloading from Δx_m with k1 (local law ``mutation-continuous``).
- ``k1-absolute``: kt = 20 kN/m and k1' = 50 kN/m absolute, not scaled in the k1 sweep
  (below k1 = 50 kN/m the "failed" and "plastic" slopes exceed k1).
- ``ode45``: the paper's solver at MATLAB's default tolerances
  (:mod:`impactbench.reference.two_dof_ode45`).
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Executor
from typing import Any

import numpy as np

from impactbench.reference import two_dof, two_dof_ode45
from impactbench.reference.scenarios import RigidFlexible

READINGS: dict[str, str] = {
    "default": "mutation: irreversible drop k1 → k1' at F_m; eq. 4: unloading from Δx_m with "
               "k1; kt, k1' fractions of k1; k2 range in kN/m (to 10⁹ N/m); exact solver",
    "k2-n-per-m": "k2 range in N/m as printed: the k2 sweep ends at 10⁶ N/m",
    "mutation-continuous": "mutation with the force continuous at failure (slope k1' beyond "
                           "F_m, unloading from Δx_m with k1)",
    "k1-absolute": "kt = 20 kN/m, k1' = 50 kN/m absolute (not scaled in the k1 sweep)",
    "ode45": "ode45 at MATLAB's defaults: RelTol 1e-3, AbsTol 1e-6, Refine 4",
}
K2_END_N_PER_M = 1e9
"""End of the k2 sweep under the default reading (10⁶ kN/m)."""
SWEEP_VELOCITY_M_S = 30.0
"""v1 of the k1, k2 and m2 sweeps (the paper does not state it)."""
PAPER: dict[str, Any] = {
    "reg2": (130.0, 140.0),  # % pulse-width increase, yielding/failure, linear structure
    "reg3": (70.0, 80.0),    # % pulse-width decrease by softening (vs linear/linear)
    "k2": {"elastoplastic": (-50.9, 35.1, -25.5), "mutation": (-31.0, 40.9, -1.3)},
    "m2": {"elastoplastic": (-51.1, 35.3, -25.5), "mutation": (-31.1, 41.2, -1.3)},
    "k1": 4.0,               # widest ratio of pulse widths between laws at low k1
}
TOLERANCE_PP = 1.5
"""A stated percentage counts as reproduced within ± this many percentage points."""
LOCALS = ("linear", "elastoplastic", "mutation")
STRUCTURES = ("linear", "softening")


def _local(reading: str, local: str) -> str:
    return "mutation-continuous" if reading == "mutation-continuous" and local == "mutation" \
        else local


def solve(scenario: RigidFlexible, reading: str = "default") -> dict[str, Any]:
    """The five metrics of ``scenario`` under ``reading`` (its local law swapped if needed)."""
    sc = scenario.replace(local=_local(reading, scenario.local))
    return two_dof_ode45.solve(sc) if reading == "ode45" else two_dof.solve(sc)


def _k1_scenario(reading: str, k1: float, base: RigidFlexible) -> RigidFlexible | None:
    if reading != "k1-absolute":
        return two_dof.with_parameter(base, "k1", k1)
    try:
        return base.replace(k1_n_per_m=k1)
    except ValueError:  # kt ≤ k1 and k1' ≤ k1 are scenario rules
        return None


V1_SWEEP_READINGS = ("default", "mutation-continuous", "ode45")
"""Readings that change the v1 sweep (the others change only the k1 or k2 sweep)."""
SOLVER_READINGS = ("ode45",)
"""Readings of the solver rather than of the equations (never the default)."""


_V1_LATER: dict[str, Any] = {"reg2": None, "reg3": None}
"""What a reading that leaves the v1 sweep computes with: its ``reg2``/``reg3`` are the default
reading's, filled in once that one is done (:func:`draw_numbers`)."""


def draw_numbers(pool: Executor) -> Callable[[], dict[str, dict[str, Any]]]:
    """:func:`numbers` of every reading, each a task of ``pool``; returns what waits for them
    and gives :func:`all_numbers`' mapping (the v1 sweep shared where a reading leaves it:
    the default's ``reg2`` and ``reg3``)."""
    futures = {name: pool.submit(numbers, name, name in SOLVER_READINGS,
                                 None if name in V1_SWEEP_READINGS else _V1_LATER)
               for name in READINGS}

    def collect() -> dict[str, dict[str, Any]]:
        out: dict[str, dict[str, Any]] = {}
        for name, future in futures.items():
            out[name] = future.result()
            if name not in V1_SWEEP_READINGS:
                out[name].update(reg2=out["default"]["reg2"], reg3=out["default"]["reg3"])
        return out

    return collect


def all_numbers() -> dict[str, dict[str, Any]]:
    """:func:`numbers` of every reading; the v1 sweep is shared where a reading leaves it."""
    from impactbench.figures.pool import IN_PROCESS

    return draw_numbers(IN_PROCESS)()


def _v1_numbers(run: Callable[[RigidFlexible], dict[str, Any]], coarse: bool
                ) -> dict[str, Any]:
    """``reg2``/``reg3`` on a log-spaced v1 grid from 0.1 to 1000 m/s (ends included)."""
    velocities = np.geomspace(0.1, 1000.0, 25 if coarse else 200)
    width = {(loc, st): np.array([run(RigidFlexible(velocity_m_s=float(v), local=loc,
                                                    structure=st))["pulse_width_s"]
                                  for v in velocities])
             for loc in LOCALS for st in STRUCTURES}
    ll = width[("linear", "linear")]
    return {
        "reg2": {loc: 100.0 * float(np.max(width[(loc, "linear")] / ll) - 1.0)
                 for loc in ("elastoplastic", "mutation")},
        "reg3": {loc: 100.0 * float(1.0 - np.min(width[(loc, "softening")] / ll))
                 for loc in LOCALS},
    }


def numbers(reading: str, coarse: bool = False,
            v1_from: dict[str, Any] | None = None) -> dict[str, Any]:
    """Every paper number ``reading`` can move: ``reg2`` and ``reg3`` (largest pulse-width
    increase by yielding/failure and decrease by softening against linear/linear on the v1
    sweep, %), ``k2``/``m2`` (per law: peak, width, impulse change against the linear local
    law at the sweep's end, %), ``k1`` (widest pulse-width ratio between law combinations at
    k1 ≤ 10 kN/m). ``coarse`` uses fewer points (the ode45 reading runs in Python);
    ``v1_from`` takes ``reg2`` and ``reg3`` from another reading's numbers."""
    run: Callable[[RigidFlexible], dict[str, Any]] = lambda sc: solve(sc, reading)  # noqa: E731
    out = _v1_numbers(run, coarse) if v1_from is None else {
        "reg2": v1_from["reg2"], "reg3": v1_from["reg3"]}
    base = RigidFlexible(velocity_m_s=SWEEP_VELOCITY_M_S)
    k2_end = 1e6 if reading == "k2-n-per-m" else K2_END_N_PER_M
    for key, change in (("k2", {"k2_n_per_m": k2_end}), ("m2", {"m2_kg": 1000.0})):
        lin = run(base.replace(**change))
        out[key] = {}
        for loc in ("elastoplastic", "mutation"):
            r = run(base.replace(local=loc, **change))
            out[key][loc] = tuple(100.0 * (r[k] / lin[k] - 1.0)
                                  for k in ("peak_force_n", "pulse_width_s", "impulse_ns"))
    ratios = []
    for k1 in np.geomspace(100.0, 1e4, 6 if coarse else 40):
        ws = []
        for loc in LOCALS:
            for st in STRUCTURES:
                sc = _k1_scenario(reading, float(k1), base.replace(local=loc, structure=st))
                if sc is not None:
                    ws.append(run(sc)["pulse_width_s"])
        if len(ws) == len(LOCALS) * len(STRUCTURES):
            ratios.append(max(ws) / min(ws))
    out["k1"] = max(ratios) if ratios else float("nan")
    return out


def score(n: dict[str, Any]) -> tuple[int, int]:
    """(reproduced, stated): numbers within the paper's range or ± TOLERANCE_PP."""
    hits = total = 0
    lo, hi = PAPER["reg2"]
    for got in n["reg2"].values():  # one number per law that yields or fails
        total += 1
        hits += lo - TOLERANCE_PP <= got <= hi + TOLERANCE_PP
    lo, hi = PAPER["reg3"]
    for got in n["reg3"].values():  # one number per local law
        total += 1
        hits += lo - TOLERANCE_PP <= got <= hi + TOLERANCE_PP
    for key in ("k2", "m2"):
        for loc, stated in PAPER[key].items():
            for got, want in zip(n[key][loc], stated, strict=True):
                total += 1
                hits += abs(got - want) <= TOLERANCE_PP
    total += 1
    hits += bool(np.isfinite(n["k1"]) and abs(n["k1"] - PAPER["k1"]) <= 0.5)
    return hits, total


def _triple(t: tuple[float, ...]) -> str:
    return " / ".join(f"{x:+.1f}" for x in t)


def table(results: dict[str, dict[str, Any]]) -> list[str]:
    """Markdown table: one row per reading, the paper's numbers in the header row."""
    p = PAPER
    lines = ["| reading | reg. 2: width up by yielding / failure (%) | reg. 3: width down by "
             "softening (%, lin / ep / mut) | k2 end, elastoplastic | k2 end, mutation | "
             "m2 end, elastoplastic | m2 end, mutation | low k1: width ratio | reproduced |",
             "|---|---|---|---|---|---|---|---|---|",
             f"| **paper** | up to {p['reg2'][0]:g}…{p['reg2'][1]:g} | up to {p['reg3'][0]:g}…"
             f"{p['reg3'][1]:g} | {_triple(p['k2']['elastoplastic'])} | "
             f"{_triple(p['k2']['mutation'])} | {_triple(p['m2']['elastoplastic'])} | "
             f"{_triple(p['m2']['mutation'])} | {p['k1']:g}× | |"]
    for name, n in results.items():
        hits, total = score(n)
        k1 = f"{n['k1']:.2f}×" if np.isfinite(n["k1"]) else "inadmissible"
        lines.append(
            f"| `{name}` | {n['reg2']['elastoplastic']:.1f} / {n['reg2']['mutation']:.1f} | "
            + " / ".join(f"{n['reg3'][loc]:.1f}" for loc in LOCALS) + " | "
            f"{_triple(n['k2']['elastoplastic'])} | {_triple(n['k2']['mutation'])} | "
            f"{_triple(n['m2']['elastoplastic'])} | {_triple(n['m2']['mutation'])} | {k1} | "
            f"{hits} of {total} |")
    return lines
