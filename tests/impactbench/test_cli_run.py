"""``impactbench run``: one engine against the reference, through the shared metrics."""

from __future__ import annotations

import json

import pytest
from conftest import require_engine

from impactbench.cli import main

# Issue 16's case: α = b·V0 = 50. The Hunt–Crossley force fades below 1e-13 of its peak over
# the last 68 % of the contact, while the surfaces still overlap; the contact (reference and
# engines alike) ends at x = 0. Measured |rel error| of the duration: Drake (RK3, 1e-6 s)
# 2.9e-5, MuJoCo (Euler, 1e-7 s) 4.4e-3 — the size of their peak-force and max-penetration
# errors (Drake 3.1e-4 / 3.7e-5, MuJoCo 6.1e-3 / 4.3e-3); before the fix both gave −68 %.
HEAVY_DAMPING = {"drake": ("1e-6", 1e-4), "mujoco": ("1e-7", 0.015)}


@pytest.mark.parametrize("engine", sorted(HEAVY_DAMPING))
def test_heavily_damped_duration_agrees_with_reference(capsys, engine):
    require_engine(engine)
    dt, tol = HEAVY_DAMPING[engine]
    code = main(["run", "--engine", engine, "--scenario", "ball-on-plate", "--mode", "injected",
                 "--damping", "10", "--velocity", "5", "--timestep", dt, "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["status"] == "ok"
    worst_other = max(abs(out["rel_error"][k]) for k in ("peak_force_n", "max_penetration_m"))
    assert abs(out["rel_error"]["duration_s"]) <= tol
    assert abs(out["rel_error"]["duration_s"]) <= 3.0 * worst_other + 1e-4
