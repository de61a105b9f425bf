"""Shared test helpers."""

from __future__ import annotations

import pytest


def require_engine(name: str):
    """Import an engine's module or skip with the pip command that fixes it."""
    from impactbench.engines.base import PIP

    module = {"drake": "pydrake", "pymunk": "pymunk", "mujoco": "mujoco",
              "pybullet": "pybullet"}[name]
    return pytest.importorskip(module, reason=f"{name} not installed: run `{PIP[name]}`")
