"""The one time-series record every producer (reference solver or engine adapter) returns.

Sign conventions (SI units throughout):

- body 1 moves toward body 2; velocities are positive in that direction;
- ``penetration_m`` is the overlap x = x1 − x2 of the two surfaces (> 0 in contact, < 0 a gap);
- ``penetration_rate_m_s`` is ẋ = v1 − v2 (> 0 while approaching);
- ``normal_force_n`` is the compressive contact force (≥ 0) from the producer's own contact
  output, sampled at ``time_s``.

For the ball on a fixed plate, body 2 is the plate: ``mass_2_kg = inf`` and ``velocity_2_m_s = 0``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np


class Status(StrEnum):
    """Physical or operational outcome of one run (never an exception)."""

    OK = "ok"
    NO_CONTACT = "no_contact"
    TUNNELED = "tunneled"
    DIVERGED = "diverged"
    MAX_TIME = "max_time"
    STRUCTURE_COLLAPSED = "structure_collapsed"
    UNSUPPORTED = "unsupported"
    UNAVAILABLE = "unavailable"
    CRASHED = "crashed"
    TIMEOUT = "timeout"
    """Outlasted its per-run timeout and was cancelled (the suite sets it, never an adapter;
    like ``crashed``, never stored: it reruns next time)."""
    IMPLAUSIBLE = "implausible"
    """Ran and measured, but beyond a plausibility limit (penetration, energy): the suite sets
    it (:mod:`impactbench.plausibility`), never an adapter."""


OPTIONAL_CHANNELS = ("displacement_2_m", "tangential_velocity_m_s", "spin_rad_s",
                     "tangential_force_n")
"""Channels a record carries only where its scenario needs them (None otherwise)."""


def _array(a: Any) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, dtype=float).reshape(-1))


@dataclass
class ImpactRecord:
    """Sampled history of one impact, plus its status and provenance.

    Attributes:
        time_s: sample times, non-decreasing (s); a force jump is two samples at one instant.
        penetration_m: overlap x of the surfaces (m).
        penetration_rate_m_s: ẋ (m/s).
        normal_force_n: contact force F ≥ 0 (N).
        velocity_1_m_s, velocity_2_m_s: body velocities along the impact axis (m/s).
        mass_1_kg, mass_2_kg: body masses (kg); ``inf`` for a fixed obstacle.
        status: outcome; metrics are computed only for ``ok`` (and ``max_time``) records.
        message: human explanation of a non-ok status.
        displacement_2_m: optional displacement of body 2 from its rest position (m), for the
            structural energy of the 2-DOF model.
        tangential_velocity_m_s, spin_rad_s, tangential_force_n: optional tangential channels
            of an oblique impact: the centre's velocity along the plate (m/s, along the
            incoming tangential direction t), the spin about n × t (rad/s; positive is forward
            rolling) and the friction force on body 1 along t (N).
        meta: provenance (engine, engine_version, mode, timestep_s, wall_s, parameters, …).
    """

    time_s: np.ndarray
    penetration_m: np.ndarray
    penetration_rate_m_s: np.ndarray
    normal_force_n: np.ndarray
    velocity_1_m_s: np.ndarray
    velocity_2_m_s: np.ndarray
    mass_1_kg: float
    mass_2_kg: float = float("inf")
    status: Status = Status.OK
    message: str = ""
    displacement_2_m: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    tangential_velocity_m_s: np.ndarray | None = None
    spin_rad_s: np.ndarray | None = None
    tangential_force_n: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.status = Status(self.status)
        for name in (
            "time_s",
            "penetration_m",
            "penetration_rate_m_s",
            "normal_force_n",
            "velocity_1_m_s",
            "velocity_2_m_s",
        ):
            setattr(self, name, _array(getattr(self, name)))
        n = self.time_s.size
        for name in OPTIONAL_CHANNELS:
            value = getattr(self, name)
            if value is not None:
                setattr(self, name, _array(value))
                if getattr(self, name).size != n:
                    raise ValueError(f"{name} has {getattr(self, name).size} samples: must "
                                     f"match time_s ({n})")
        for name in ("penetration_m", "penetration_rate_m_s", "normal_force_n",
                     "velocity_1_m_s", "velocity_2_m_s"):
            if getattr(self, name).size != n:
                raise ValueError(f"{name} has {getattr(self, name).size} samples: must match "
                                 f"time_s ({n})")

    @classmethod
    def failed(cls, status: Status | str, message: str, mass_1_kg: float = float("nan"),
               **meta: Any) -> ImpactRecord:
        """An empty record carrying only a non-ok status, its reason and provenance."""
        empty = np.empty(0)
        return cls(empty, empty, empty, empty, empty, empty, mass_1_kg=mass_1_kg,
                   status=Status(status), message=message, meta=dict(meta))

    @property
    def ok(self) -> bool:
        return self.status is Status.OK

    def __len__(self) -> int:
        return int(self.time_s.size)
