"""The oblique metrics: one function for both references and for engine records.

Definitions in :mod:`impactbench.reference.oblique` (module doc, **Metrics**); re-exported
there. Kept apart so that the closed form and the time integration
(:mod:`impactbench.reference.oblique_integrate`) share it without importing each other.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from impactbench.reference.oblique_scenario import (
    OBLIQUE_METRICS,
    REGIME_TOLERANCE,
    SLIDE,
    STICK,
    Oblique,
)


def metrics_of(velocity_m_s: Any, angle_deg: Any, spin_rad_s: Any, radius_m: float, *,
               normal_velocity_out: Any, tangential_velocity_out: Any, spin_out: Any,
               duration_s: Any, peak_force_n: Any, peak_tangential_force_n: Any
               ) -> dict[str, Any]:
    """The :data:`OBLIQUE_METRICS` of one impact or of arrays of them (module doc).

    Inputs: the incoming speed V, angle θ (degrees) and spin ω0, the radius R; the centre's
    velocity after (``normal_velocity_out`` v_n' > 0 away from the plate,
    ``tangential_velocity_out`` v_t' along t), ``spin_out`` ω'; the normal contact's duration
    and peak force and the peak |F_t|. Floats in, floats out; arrays broadcast.
    """
    scalar = all(np.ndim(a) == 0 for a in (velocity_m_s, angle_deg, spin_rad_s,
                                           normal_velocity_out, tangential_velocity_out,
                                           spin_out))
    v = np.asarray(velocity_m_s, dtype=float)
    th = np.radians(np.asarray(angle_deg, dtype=float))
    w0 = np.asarray(spin_rad_s, dtype=float)
    vn, vt = v * np.cos(th), v * np.sin(th)
    vn2 = np.asarray(normal_velocity_out, dtype=float)
    vt2 = np.asarray(tangential_velocity_out, dtype=float)
    w2 = np.asarray(spin_out, dtype=float)
    s0 = vt - radius_m * w0
    s2 = vt2 - radius_m * w2
    with np.errstate(divide="ignore", invalid="ignore"):
        e_t = np.where(vt != 0.0, vt2 / np.where(vt != 0.0, vt, 1.0), np.nan)
        beta = np.where(s0 != 0.0, -s2 / np.where(s0 != 0.0, s0, 1.0), np.nan)
    regime = np.where(beta < -REGIME_TOLERANCE, SLIDE, STICK)
    out = {
        "restitution": vn2 / vn,
        "tangential_restitution": e_t,
        "contact_point_ratio": beta,
        "rebound_angle_deg": np.degrees(np.arctan2(vt2, vn2)),
        "spin_out_rad_s": w2 + 0.0 * vn,
        "regime": regime + 0.0 * vn,
        "duration_s": np.asarray(duration_s, dtype=float) + 0.0 * vn,
        "peak_force_n": np.asarray(peak_force_n, dtype=float) + 0.0 * vn,
        "peak_tangential_force_n": np.asarray(peak_tangential_force_n, dtype=float) + 0.0 * vn,
    }
    assert tuple(out) == OBLIQUE_METRICS
    if scalar:
        return {k: float(val) for k, val in out.items()}
    return out


def record_metrics(rec: Any, scenario: Oblique) -> dict[str, float]:
    """The oblique metrics of a record (an engine's or the integrated reference's).

    The normal part comes from the one metrics path
    (:func:`impactbench.reference.metrics.compute`: restitution, duration, peak force); the
    tangential part from the record's tangential channels (aligned with ``rec.time_s``):
    ``tangential_velocity_m_s`` (v_t of the centre), ``spin_rad_s`` (ω, signed as
    :class:`Oblique`'s) and ``tangential_force_n`` (F_t on the ball). The velocities after
    are read at the last sample (free flight after the contact)."""
    from impactbench.reference import metrics

    if not len(rec) or rec.tangential_velocity_m_s is None or rec.spin_rad_s is None \
            or rec.tangential_force_n is None:
        return dict.fromkeys(OBLIQUE_METRICS, math.nan)
    normal = metrics.compute(rec)
    vt, w, ft = rec.tangential_velocity_m_s, rec.spin_rad_s, rec.tangential_force_n
    v_n = scenario.normal_velocity_m_s
    return metrics_of(scenario.velocity_m_s, scenario.angle_deg, scenario.spin_rad_s,
                      scenario.radius_m, normal_velocity_out=normal["restitution"] * v_n,
                      tangential_velocity_out=float(vt[-1]), spin_out=float(w[-1]),
                      duration_s=normal["duration_s"], peak_force_n=normal["peak_force_n"],
                      peak_tangential_force_n=float(np.max(np.abs(ft))))
