"""Ground truth for impactbench: numpy/scipy only, never imports an engine.

- :mod:`reference.scenarios` – the physical set-ups (ball on plate, rigid–flexible 2-DOF).
- :mod:`reference.laws` – contact and structural force laws.
- :mod:`reference.hunt_crossley` – closed-form Hunt–Crossley impact (Lambert W).
- :mod:`reference.two_dof` – event-driven rigid–flexible impact solver.
- :mod:`reference.record` / :mod:`reference.metrics` – the one record and the one metrics path
  shared by the reference and every engine adapter.
"""
