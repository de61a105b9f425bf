"""Real cube tosses (MODELS.md §4): DAIR Lab's motion-capture data, their replay protocol, the
reference model and the fits.

- :mod:`~impactbench.cube_tosses.data`: the packaged tosses (or a user's CSV) as a validated
  DataFrame, per-toss arrays, the deterministic 80/20 train/test split;
- :mod:`~impactbench.cube_tosses.protocol`: DAIR's replay protocol (start, refitted initial
  velocity, errors, statistics), numpy only;
- :mod:`~impactbench.cube_tosses.scenario`: the scenario's side of an engine replay (the
  engines' cube-toss builders, :mod:`impactbench.engines.cube_toss`, replay the tosses; the
  scenario prepares their inputs and scores their records);
- :mod:`~impactbench.cube_tosses.replays`: ``replay(engine, mode, tosses=…, param_set=…)``.

Engines are imported only when a replay runs.
"""

from __future__ import annotations

from impactbench.cube_tosses.data import load, split
from impactbench.cube_tosses.protocol import Protocol
from impactbench.cube_tosses.replays import replay

__all__ = ["Protocol", "load", "replay", "split"]
