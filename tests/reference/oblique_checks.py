"""Shared by the oblique reference tests (test_oblique.py, test_oblique_shape.py,
test_oblique_microslip.py): the normal laws they run and the comparisons they make."""

from __future__ import annotations

import math

import pytest
from impactbench.reference import oblique
from impactbench.reference import oblique_integrate as oi
from impactbench.reference.oblique import OBLIQUE_METRICS, Oblique

LAWS = {
    "hunt-crossley (paper b)": {},
    "gonthier e=0.7": {"model": "gonthier", "nominal_restitution": 0.7},
    "flores e=0.5": {"model": "flores", "nominal_restitution": 0.5},
}
"""Three laws of the zoo: the preprint's fixed b (e depends on v_n) and two nominal-e models."""


def close(got: dict, want: dict, rel: float = 1e-8, abs_: float = 1e-10) -> list[str]:
    """Metrics of ``got`` not within ``rel`` (or ``abs_`` for values near zero) of ``want``."""
    bad = []
    for k in OBLIQUE_METRICS:
        a, b = got[k], want[k]
        if math.isnan(b) and math.isnan(a):
            continue
        if not abs(a - b) <= max(rel * abs(b), abs_):
            bad.append(f"{k}: {a!r} vs {b!r}")
    return bad


def assert_record_metrics_match(tangential: str) -> None:
    """The one metrics function applied to the sampled history (2001 samples) of a 30° run
    with ``tangential`` gives the reference's numbers: velocities exactly (read after the
    contact), the peaks and the located duration to the sampling."""
    s = Oblique(angle_deg=30.0, tangential=tangential)
    rec = oi.history(s)
    got, want = oblique.record_metrics(rec, s), oblique.solve(s)
    for k in ("tangential_restitution", "contact_point_ratio", "spin_out_rad_s", "regime"):
        assert got[k] == pytest.approx(want[k], rel=1e-9, abs=1e-9)
    for k in ("restitution", "rebound_angle_deg", "duration_s", "peak_force_n",
              "peak_tangential_force_n"):
        assert got[k] == pytest.approx(want[k], rel=1e-4)
