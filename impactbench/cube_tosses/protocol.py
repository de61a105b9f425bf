"""DAIR's replay protocol for the cube tosses (Acosta, Yang & Posa, RA-L 2022), engine-free.

What one replay does (defaults = DAIR's ``cube_sim.py``/``evaluate_cube_parameters.py``, branch
``contact_model_verification`` of DAIRLab/dairlib):

1. **Start** (``start_rule="drop"``): ``i0 = max(0, i_drop − 3)``, where ``i_drop`` is the
   first sample whose centre height z ≤ h·√3 (h = 0.0524 m, the half width: below h·√3 a
   corner can touch the board). ``start_rule="first"`` starts at sample 0.
2. **Initial state**: the recorded sample ``i0``; when ``refit`` and at least
   ``min_preceding`` (4) samples precede it, its velocities are replaced by a fit to samples
   0 … i0−1 (``velocity_fit="dair"``, DAIR's formulas exactly, with τ = t − t_0):

   - x, y: the slope of the line through the first and the last of them,
     (p[i0−1] − p[0]) / τ[i0−1];
   - z: least squares of z + g·τ²/2 = a + b·τ (a parabola of curvature −g, g = 9.81 fixed),
     v_z = b − g·τ[i0−1] (the fitted velocity at the *last preceding* sample, as DAIR's code);
   - ω (body frame): rotvec(R_0ᵀ R_i0) / (τ[i0]) (the mean rate over the preceding samples).

   ``velocity_fit="lstsq"`` uses least-squares lines for x, y and evaluates all three at the
   start sample's own time τ[i0] instead (a variant, not DAIR's).
3. **Simulate** from that state with the engine stepping at ``dt_sample / substeps``
   (1/148/10 s by default) and record the pose at every remaining sample time (the sample
   ``k`` is reached after ``round((t_k − t_i0) / step)`` steps) to the end of the recorded toss.
4. **Errors** per sample: position |p_sim − p_real| / (2h) (a fraction of the width) and the
   rotation angle of q_sim⁻¹ q_real in degrees; per toss their time means over samples
   i0 … end (the start sample included, as DAIR's); across tosses mean, median and quartiles.

Everything here is numpy/scipy; the engines are in :mod:`impactbench.engines.cube_toss`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from impactbench.cube_tosses.data import Toss

# DAIR's cube (h: BLOCK_HALF_WIDTH, m, I) and the box type, defined with the reference model
from impactbench.reference.box_contact import (
    GRAVITY_M_S2,
    HALF_WIDTH_M,
    INERTIA_KG_M2,
    MASS_KG,
    Box,
    quat_matrix,
    quat_multiply,
)

SAMPLE_DT_S = 1.0 / 148.0
"""The motion capture's sample interval (148 Hz)."""

START_RULES = ("drop", "first")
VELOCITY_FITS = ("dair", "lstsq")


DAIR_BOX = Box()
"""DAIR's cube as the engines build it (:class:`impactbench.reference.box_contact.Box`, the
one box type of the scenario, the engines and the reference model)."""


@dataclass(frozen=True)
class Protocol:
    """The replay's options (recorded in every result by :meth:`describe`).

    Attributes:
        substeps: engine steps per sample interval (DAIR's evaluation: 10).
        start_rule: "drop" (3 samples before the centre first drops below h·√3) or "first".
        samples_before: how many samples before the drop the replay starts (3).
        refit: refit the start velocities from the preceding samples (DAIR: yes).
        min_preceding: the fewest preceding samples a refit needs (DAIR: 4).
        velocity_fit: "dair" (DAIR's formulas) or "lstsq" (module doc).
        sample_dt_s: the nominal sample interval (DAIR: 1/148 s); a toss whose median
            interval differs by more than 1e-6 (relative) is refused, so data at another rate
            needs its own value; None: each toss's median interval.
        board_z_m: height of the board's surface in the data's frame (DAIR: 0; the packaged
            data's board sits about 1 mm higher, see its README).
        half_width_m, gravity_m_s2: h and g.
    """

    substeps: int = 10
    start_rule: str = "drop"
    samples_before: int = 3
    refit: bool = True
    min_preceding: int = 4
    velocity_fit: str = "dair"
    sample_dt_s: float | None = SAMPLE_DT_S
    board_z_m: float = 0.0
    half_width_m: float = HALF_WIDTH_M
    gravity_m_s2: float = GRAVITY_M_S2

    def __post_init__(self) -> None:
        if not (isinstance(self.substeps, int) and self.substeps >= 1):
            raise ValueError(f"substeps = {self.substeps!r}: must be an integer ≥ 1")
        if self.start_rule not in START_RULES:
            raise ValueError(f"start_rule = {self.start_rule!r}: must be one of "
                             f"{', '.join(START_RULES)}")
        if self.velocity_fit not in VELOCITY_FITS:
            raise ValueError(f"velocity_fit = {self.velocity_fit!r}: must be one of "
                             f"{', '.join(VELOCITY_FITS)}")
        if self.samples_before < 0 or self.min_preceding < 2:
            raise ValueError(f"samples_before = {self.samples_before!r}, min_preceding = "
                             f"{self.min_preceding!r}: must be ≥ 0 and ≥ 2")
        if self.sample_dt_s is not None and not self.sample_dt_s > 0:
            raise ValueError(f"sample_dt_s = {self.sample_dt_s!r}: must be > 0 (or None)")
        for name in ("board_z_m", "half_width_m", "gravity_m_s2"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} = {getattr(self, name)!r}: must be finite")

    def describe(self) -> dict[str, Any]:
        """The options as a JSON-ready dict (with the engine step)."""
        out = asdict(self)
        out["name"] = "dair2022" if self == Protocol() else "custom"
        out["step_s"] = (self.sample_dt_s / self.substeps if self.sample_dt_s is not None
                         else None)
        return out


@dataclass(frozen=True)
class Start:
    """Where and how one toss's replay starts.

    Attributes:
        toss: the toss id.
        index: the start sample i0.
        refit: whether the velocities were refitted.
        p, q, v, w_body: the initial state (m, wxyz, m/s, rad/s body frame).
        t_ref, p_ref, q_ref: the recorded samples i0 … end (the comparison's reference).
        record_steps: engine steps from the start to each reference sample (0 first).
        step_s: the engine step (s).
    """

    toss: int
    index: int
    refit: bool
    p: np.ndarray
    q: np.ndarray
    v: np.ndarray
    w_body: np.ndarray
    t_ref: np.ndarray
    p_ref: np.ndarray
    q_ref: np.ndarray
    record_steps: np.ndarray
    step_s: float

    @property
    def w_world(self) -> np.ndarray:
        """The initial angular velocity in the board's frame."""
        return quat_to_matrix(self.q) @ self.w_body


# ------------------------------------------------------------------------------ quaternions


quat_to_matrix = quat_matrix
"""Rotation matrix of the quaternion ``q`` (w, x, y, z; normalised first): the reference
model's (:func:`impactbench.reference.box_contact.quat_matrix`)."""


def quat_conj_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a⁻¹ ⊗ b for (arrays of) unit quaternions w, x, y, z (last axis)."""
    a = np.asarray(a, dtype=float)
    return quat_multiply(np.concatenate([a[..., :1], -a[..., 1:]], axis=-1), b)


def rotation_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The angle (rad, in [0, π]) of the rotation a⁻¹ b, for (arrays of) quaternions."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    r = quat_conj_mul(a, b)
    return 2.0 * np.arctan2(np.linalg.norm(r[..., 1:], axis=-1), np.abs(r[..., 0]))


def rotation_vector(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation vector (rad) of a⁻¹ b, in a's body frame (the shortest rotation)."""
    r = quat_conj_mul(np.asarray(a, float) / np.linalg.norm(a),
                      np.asarray(b, float) / np.linalg.norm(b))
    if r[0] < 0:
        r = -r
    s = np.linalg.norm(r[1:])
    if s < 1e-15:
        return 2.0 * r[1:]
    return 2.0 * math.atan2(s, r[0]) * r[1:] / s


# ------------------------------------------------------------------------------ the start


def sample_dt(t: np.ndarray, protocol: Protocol) -> float:
    """The sample interval a replay of samples at times ``t`` uses (ValueError when the data's
    own median interval is not the protocol's ``sample_dt_s``)."""
    median = float(np.median(np.diff(t)))
    if protocol.sample_dt_s is None:
        return median
    if abs(median - protocol.sample_dt_s) > 1e-6 * protocol.sample_dt_s:
        raise ValueError(f"sample interval {median:.9g} s (median): the protocol expects "
                         f"sample_dt_s = {protocol.sample_dt_s:.9g} s; give "
                         "Protocol(sample_dt_s=None) or the data's interval")
    return float(protocol.sample_dt_s)


def start_index(z: np.ndarray, protocol: Protocol = Protocol(), toss_id: Any = None) -> int:
    """The start sample i0 of a toss whose centre heights are ``z`` (module doc, step 1)."""
    if protocol.start_rule == "first":
        return 0
    threshold = protocol.board_z_m + protocol.half_width_m * math.sqrt(3.0)
    below = np.flatnonzero(np.asarray(z) <= threshold)
    if below.size == 0:
        raise ValueError(f"toss {toss_id}: the centre never drops below h·√3 = "
                         f"{threshold:.4f} m (lowest z {float(np.min(z)):.4f} m); no impact")
    return max(0, int(below[0]) - protocol.samples_before)


def refit_velocity(t: np.ndarray, p: np.ndarray, q: np.ndarray, index: int,
                   protocol: Protocol = Protocol()) -> tuple[np.ndarray, np.ndarray]:
    """(v, ω_body) at sample ``index`` fitted from samples 0 … index−1 (module doc, step 2)."""
    if index < 2:
        raise ValueError(f"index = {index}: a refit needs at least 2 preceding samples")
    g = protocol.gravity_m_s2
    tau = np.asarray(t[:index], dtype=float) - float(t[0])
    pos = np.asarray(p[:index], dtype=float)
    w_body = rotation_vector(q[0], q[index]) / (float(t[index]) - float(t[0]))
    a = np.column_stack([np.ones(index), tau])
    coef_z = np.linalg.lstsq(a, pos[:, 2] + 0.5 * g * tau ** 2, rcond=None)[0]
    if protocol.velocity_fit == "dair":
        t_fit = tau[-1]
        vxy = (pos[-1, :2] - pos[0, :2]) / tau[-1]
    else:
        t_fit = float(t[index]) - float(t[0])
        vxy = np.linalg.lstsq(a, pos[:, :2], rcond=None)[0][1]
    v = np.array([vxy[0], vxy[1], coef_z[1] - g * t_fit])
    return v, w_body


def prepare(toss: Toss, protocol: Protocol = Protocol()) -> Start:
    """Where ``toss``'s replay starts, its initial state and its reference (module doc)."""
    i0 = start_index(toss.p[:, 2], protocol, toss.toss)
    if len(toss) - i0 < 2:
        raise ValueError(f"toss {toss.toss}: starts at sample {i0} of {len(toss)}; nothing "
                         "left to compare")
    refit = protocol.refit and i0 >= protocol.min_preceding
    if refit:
        v, w_body = refit_velocity(toss.t, toss.p, toss.q, i0, protocol)
    else:
        v, w_body = toss.v[i0].copy(), toss.w_body[i0].copy()
    try:
        dt = sample_dt(toss.t, protocol)
    except ValueError as exc:
        raise ValueError(f"toss {toss.toss}: {exc}") from None
    step = dt / protocol.substeps
    t_ref = toss.t[i0:]
    steps = np.rint((t_ref - t_ref[0]) / step).astype(np.int64)
    if np.any(np.diff(steps) <= 0):
        raise ValueError(f"toss {toss.toss}: two samples closer than one engine step "
                         f"({step:.3g} s)")
    return Start(toss.toss, i0, bool(refit), toss.p[i0].copy(), toss.q[i0].copy(), v, w_body,
                 t_ref.copy(), toss.p[i0:].copy(), toss.q[i0:].copy(), steps, step)


# ------------------------------------------------------------------------------ the errors


def toss_errors(start: Start, p_sim: np.ndarray, q_sim: np.ndarray,
                protocol: Protocol = Protocol()) -> dict[str, Any]:
    """One toss's errors: the time means over its reference samples of |Δp| / (2h)
    (``position_error``) and of the rotation angle in degrees (``rotation_error_deg``), and
    their values at the last sample (``final_…``)."""
    p_sim = np.asarray(p_sim, dtype=float)
    q_sim = np.asarray(q_sim, dtype=float)
    if p_sim.shape != start.p_ref.shape or q_sim.shape != start.q_ref.shape:
        raise ValueError(f"toss {start.toss}: simulated shapes {p_sim.shape}/{q_sim.shape} "
                         f"differ from the reference {start.p_ref.shape}/{start.q_ref.shape}")
    pos = np.linalg.norm(p_sim - start.p_ref, axis=1) / (2.0 * protocol.half_width_m)
    rot = np.degrees(rotation_angle(q_sim, start.q_ref))
    return {"toss": int(start.toss), "start_sample": int(start.index),
            "samples": len(start.t_ref), "refit": start.refit,
            "position_error": float(pos.mean()), "rotation_error_deg": float(rot.mean()),
            "final_position_error": float(pos[-1]), "final_rotation_error_deg": float(rot[-1])}


METRICS = ("position_error", "rotation_error_deg")


def summarize(per_toss: Iterable[Mapping[str, Any]]) -> dict[str, Any]:
    """Across tosses (those with finite errors): mean, median and quartiles of each metric,
    ``position_error_mean``, ``…_median``, ``…_q1``, ``…_q3`` (NaN when none)."""
    rows = [r for r in per_toss if r.get("status", "ok") == "ok"]
    out: dict[str, Any] = {}
    for m in METRICS:
        x = np.array([r[m] for r in rows], dtype=float)
        x = x[np.isfinite(x)]
        if x.size:
            q1, med, q3 = np.percentile(x, [25, 50, 75])
            out |= {f"{m}_mean": float(x.mean()), f"{m}_median": float(med),
                    f"{m}_q1": float(q1), f"{m}_q3": float(q3)}
        else:
            out |= {f"{m}_{s}": math.nan for s in ("mean", "median", "q1", "q3")}
    return out


__all__ = ["DAIR_BOX", "GRAVITY_M_S2", "HALF_WIDTH_M", "INERTIA_KG_M2", "MASS_KG", "SAMPLE_DT_S",
           "Box", "Protocol", "Start", "prepare", "refit_velocity", "rotation_angle",
           "sample_dt", "start_index", "summarize", "toss_errors"]
