"""The engine and mode names, their pip commands and the plug-in registry: standard library only.

Kept apart from :mod:`impactbench.engines.base` (which needs numpy for the records) so that the
command line can build its parser, with engine and mode choices, without importing numpy or
any engine. :mod:`impactbench.engines.base` re-exports every name here.
"""

from __future__ import annotations

import os

MODES: tuple[str, ...] = ("native", "injected", "tuned", "default", "custom")

ENGINES: dict[str, str] = {
    "mujoco": "impactbench.engines.mujoco_adapter:MujocoAdapter",
    "pybullet": "impactbench.engines.pybullet_adapter:PybulletAdapter",
    "pymunk": "impactbench.engines.pymunk_adapter:PymunkAdapter",
    "drake": "impactbench.engines.drake_adapter:DrakeAdapter",
    "sapien": "impactbench.engines.sapien_adapter:SapienAdapter",
    "dart": "impactbench.engines.dart_adapter:DartAdapter",
    "box2d": "impactbench.engines.box2d_adapter:Box2dAdapter",
    "mjx": "impactbench.engines.mjx_adapter:MjxAdapter",
    "newton": "impactbench.engines.newton_adapter:NewtonAdapter",
}

PIP: dict[str, str] = {
    "mujoco": "pip install mujoco",
    "pybullet": "pip install pybullet",
    "pymunk": "pip install pymunk",
    "drake": "pip install drake",
    "sapien": "pip install sapien",
    "dart": "pip install dartpy",
    "box2d": "pip install box2d",
    "mjx": "pip install mujoco-mjx jax",
    "newton": "pip install newton",
}

ENGINES_ENV = "IMPACTBENCH_ENGINES"
"""Extra adapters, ``name=module:Class`` separated by commas (plug in your own engine)."""
DISABLE_ENV = "IMPACTBENCH_DISABLE_ENGINES"
"""Engines to treat as not installed, comma separated (e.g. to skip a broken install)."""


def _registry() -> dict[str, str]:
    out = dict(ENGINES)
    for item in filter(None, (x.strip() for x in os.environ.get(ENGINES_ENV, "").split(","))):
        name, sep, target = item.partition("=")
        if not sep or ":" not in target:
            raise ValueError(f"{ENGINES_ENV} entry {item!r}: must be name=module:Class")
        out[name.strip()] = target.strip()
    return out


def engine_names() -> tuple[str, ...]:
    """Registered engine names, including plug-ins from ``IMPACTBENCH_ENGINES``."""
    return tuple(_registry())
