"""What the stepped engines' bounce tests (SAPIEN, DART, Box2D) read from a record: the
statuses of a run that ran, the first contact, the apex of each flight."""

from __future__ import annotations

import numpy as np
from impactbench.reference.record import Status

PHYSICAL = {Status.OK, Status.NO_CONTACT, Status.TUNNELED, Status.DIVERGED, Status.MAX_TIME}
"""The statuses of a run that ran (a physical outcome)."""


def first_contact(rec) -> int:
    """The first sample with a reported contact force."""
    on = rec.normal_force_n > 0.0
    assert on.any()
    return int(np.argmax(on))


def apexes(rec) -> list[float]:
    """max(−x) (m) over each flight after the first contact (samples between contacts)."""
    on = rec.normal_force_n > 0.0
    out, i, n = [], first_contact(rec), on.size
    while i < n:
        while i < n and on[i]:
            i += 1
        j = i
        while j < n and not on[j]:
            j += 1
        if j > i:
            out.append(float(np.max(-rec.penetration_m[i:j])))
        i = j
    return out
