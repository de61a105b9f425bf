"""Euler: an example impactbench engine plug-in (a tiny pure-Python integrator).

The engine integrates the ball on the plate (impactbench's ``ball-on-plate`` scenario) with
semi-implicit (symplectic) Euler steps; its adapter is :class:`impactbench_euler.adapter.
EulerAdapter`. impactbench finds it through the entry point in ``pyproject.toml``::

    [project.entry-points."impactbench.engines"]
    euler = "impactbench_euler:SPEC"

and then runs it everywhere a packaged engine runs: ``impactbench run --engine euler``,
``engines = ["euler"]`` in a report config, ``engine = "euler"`` in a ``[[gate]]``.

This module is what the entry point imports whenever impactbench lists its engines (every
command builds its parser with them), so it holds the spec only and imports nothing but
impactbench's standard-library registry; the adapter (numpy, scipy) is imported when the
engine runs.
"""

from __future__ import annotations

from impactbench.engines.registry import EngineSpec

__version__ = "0.1.0"

NAME = "euler"

SPEC = EngineSpec(
    NAME,
    adapter="impactbench_euler.adapter:EulerAdapter",
    pip="pip install -e examples/plugin-engine-euler",
    distribution="impactbench-euler",
    module="impactbench_euler",
    color="teal",
)
"""What impactbench knows about the engine without importing it: its adapter, how to install
it, the distribution whose version results record, its colour in every figure. No tuning
spaces (``impactbench tune`` does not offer it) and no customary steps (it has no ``default``
mode, the only one that runs at them)."""
