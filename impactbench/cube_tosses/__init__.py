"""Real cube tosses (MODELS.md §4): DAIR Lab's motion-capture data, their replay protocol and
replays in PyBullet, MuJoCo and Drake.

- :mod:`~impactbench.cube_tosses.data`: the packaged tosses (or a user's CSV) as a validated
  DataFrame, per-toss arrays, the deterministic 80/20 train/test split;
- :mod:`~impactbench.cube_tosses.protocol`: DAIR's replay protocol (start, refitted initial
  velocity, errors, statistics), numpy only;
- :mod:`~impactbench.cube_tosses.engines`: the cube on the board in each engine, DAIR's
  published parameter sets (``dair2022``);
- :mod:`~impactbench.cube_tosses.replay`: ``replay(engine, mode, tosses=…, param_set=…)``.

Engines are imported only when a replay runs.
"""

from __future__ import annotations

from impactbench.cube_tosses.data import load, split
from impactbench.cube_tosses.protocol import Protocol
from impactbench.cube_tosses.replay import replay

__all__ = ["Protocol", "load", "replay", "split"]
