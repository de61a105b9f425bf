"""Ground truth for impactbench: numpy/scipy only, never imports an engine.

- :mod:`impactbench.reference.scenarios` – the physical set-ups (ball on plate, rigid–flexible
  2-DOF).
- :mod:`impactbench.reference.laws` – contact and structural force laws.
- :mod:`impactbench.reference.hunt_crossley` – closed-form Hunt–Crossley impact (Lambert W).
- :mod:`impactbench.reference.two_dof` – event-driven rigid–flexible impact solver.
- :mod:`impactbench.reference.record` / :mod:`impactbench.reference.metrics` – the one record and
  the one metrics path
  shared by the reference and every engine adapter.
"""
