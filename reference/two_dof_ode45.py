"""The 2-DOF model as the paper solved it: MATLAB ``ode45`` at its default tolerances.

Zhou & Xiao integrate eq. 1 with ``ode45`` (Dormand–Prince 5(4)); they do not state its
options. This emulation uses scipy's RK45 (the same Dormand–Prince pair) at ode45's defaults
— RelTol 1e-3, AbsTol 1e-6 (m, m/s), MaxStep a tenth of the span, output ``Refine`` 4 (four
dense-output samples per step) — on the whole right-hand side with no event location: the
local law's memory (largest penetration, failure) is committed after each accepted step, as a
``global`` updated in the ODE function would be. The metrics then go through the one shared
path (:func:`impactbench.reference.metrics.compute`) from the sampled force, so the peak and
the contact edges are read from samples, as from the paper's curves. It exists to test
whether ode45's tolerances explain the paper's numbers (``reports/rigid_flexible.md``), not
as a reference.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from impactbench.reference import metrics
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import RigidFlexible
from scipy.integrate import RK45

RELTOL = 1e-3
ABSTOL = 1e-6
REFINE = 4


def simulate(scenario: RigidFlexible, t_end_s: float, *, rtol: float = RELTOL,
             atol: float = ABSTOL, refine: int = REFINE) -> ImpactRecord:
    """Time history on [0, t_end_s] (s) at ode45-like settings (see the module docstring)."""
    sc = scenario
    law, structure = sc.local_law(), sc.structural_law()
    m1, m2 = sc.m1_kg, sc.m2_kg

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        f1 = law.force(y[0] - y[1])
        return np.array([y[2], y[3], -f1 / m1, (f1 - structure.force(y[1])) / m2])

    solver = RK45(rhs, 0.0, np.array([0.0, 0.0, sc.velocity_m_s, 0.0]), t_end_s, rtol=rtol,
                  atol=atol, max_step=0.1 * t_end_s)
    ts, ys, fs = [0.0], [solver.y.copy()], [0.0]
    while solver.status == "running":
        solver.step()
        dense = solver.dense_output()
        for k in range(1, refine + 1):
            tk = solver.t_old + (solver.t - solver.t_old) * k / refine
            yk = solver.y if k == refine else dense(tk)
            ts.append(tk)
            ys.append(np.array(yk, dtype=float))
            fs.append(law.force(yk[0] - yk[1]))
        law.update(solver.y[0] - solver.y[1])
    y = np.array(ys).T
    status = Status.OK if solver.status == "finished" else Status.DIVERGED
    return ImpactRecord(
        time_s=np.array(ts), penetration_m=y[0] - y[1], penetration_rate_m_s=y[2] - y[3],
        normal_force_n=np.array(fs), velocity_1_m_s=y[2], velocity_2_m_s=y[3],
        mass_1_kg=m1, mass_2_kg=m2, status=status, displacement_2_m=y[1],
        meta={"producer": "impactbench.reference.two_dof_ode45", "rtol": rtol, "atol": atol,
              "refine": refine})


def solve(scenario: RigidFlexible) -> dict[str, Any]:
    """The five metrics at ode45-like settings, run over the reference's own span (the
    event-driven fast path's end time, so both see the same contacts)."""
    from impactbench.reference import two_dof, two_dof_fast

    t_end = float(two_dof_fast.run(scenario)[6]) if scenario.local in two_dof_fast.LOCAL_CODES \
        else float(two_dof.simulate(scenario).time_s[-1])
    m = metrics.compute(simulate(scenario, max(t_end, 1e-9)))
    out: dict[str, Any] = {k: m[k] for k in two_dof.METRIC_KEYS}
    out["impacts"] = int(out["impacts"])
    return out
