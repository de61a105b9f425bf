"""What the engines' oblique tests share (issue 22): the cases, a run through
``evaluate.compare`` (the one metrics path) and the injected mode's check against the rigid
reference, each engine's tolerances its own."""

from __future__ import annotations

from typing import Any

from impactbench.engines.base import RunSettings
from impactbench.reference.oblique import Oblique

from impactbench.evaluate import compare

CASES = [(20.0, 0.0), (45.0, 0.0), (60.0, 0.0), (80.0, 0.0), (45.0, -60.0), (45.0, 60.0)]
"""(angle θ in degrees, initial spin ω0 in rad/s): stick at 20–60°, slide at 80°, back- and
topspin."""


def run(engine: str, mode: str, angle: float = 45.0, spin: float = 0.0, *,
        shape: str = "sphere", **settings: Any):
    """The paper's steel ball (or a disc) at 2 m/s, μ = 0.3, at ``angle`` with ``spin``, in
    ``engine``: ``compare``'s (run object, record)."""
    return compare(engine, Oblique(angle_deg=angle, spin_rad_s=spin, shape=shape), mode,
                   RunSettings(**settings))


def check_injected(out: dict[str, Any], tolerances: dict[str, float], beta_tol: float) -> None:
    """An injected run reproduces the rigid reference: ok, every |relative error| within its
    tolerance, the contact-point ratio β within ``beta_tol`` (absolute), the same regime."""
    assert out["status"] == "ok", out["message"]
    for key, tol in tolerances.items():
        assert abs(out["rel_error"][key]) <= tol, (key, out["rel_error"][key])
    assert abs(out["contact_point_ratio"] - out["reference"]["contact_point_ratio"]) <= beta_tol
    assert out["regime"] == out["reference"]["regime"]
