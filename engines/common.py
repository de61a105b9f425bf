"""Pieces every adapter shares: the step recorder, outcome classification and the
closed-form conversion of a Hunt–Crossley ball impact to a linear spring–damper.

Linear spring–damper with a unilateral (clipped, F ≥ 0) force, as MuJoCo, Bullet and most
engines implement a soft contact: m·ẍ + d·ẋ + k·x = 0 while k·x + d·ẋ > 0, with
ωn = √(k/m), ζ = d/(2·√(k·m)), ωd = ωn·√(1−ζ²) and x(t) = (V0/ωd)·e^(−ζωn t)·sin(ωd t).
The force k·x + d·ẋ vanishes (the bodies let go, still overlapping) at the phase

    θe = ωd·T = π − atan2(2ζ√(1−ζ²), 1 − 2ζ²)

so the contact duration is T = θe/ωd and the restitution, a function of ζ alone, is

    e(ζ) = −ẋ(T)/V0 = −e^(−ζθe/√(1−ζ²)) · (cos θe − ζ/√(1−ζ²)·sin θe).

(Without the clip, θe = π and e = exp(−ζπ/√(1−ζ²)), the textbook values.)
:func:`spring_damper_matching` inverts these: given a target restitution and duration at one
reference velocity it returns k (N/m) and d (N·s/m). A linear spring–damper's restitution does
not depend on velocity, so it can match Hunt–Crossley at that one velocity only.
The closed forms live in :mod:`impactbench.reference.kelvin_voigt` (also the reference of the
zoo's Kelvin–Voigt models); they are re-exported here.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from impactbench.engines.registry import fds_redirected
from impactbench.reference.kelvin_voigt import clipped_phase, clipped_restitution
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.validation import InvalidValue
from scipy import optimize

NATIVE_REFERENCE_VELOCITY_M_S = 1.0
"""The impact velocity at which native-mode conversions match the reference (the stated
reference velocity; ``RunSettings.options["reference_velocity_m_s"]`` overrides it)."""

ENERGY_GAIN_LIMIT = 0.01
"""A run that ends with more than 1 % more kinetic energy than it started with diverged."""


@dataclass(frozen=True)
class SpringDamper:
    """A linear contact: stiffness_n_per_m k and damping_ns_per_m d (physical units)."""

    stiffness_n_per_m: float
    damping_ns_per_m: float

    def restitution(self, mass_kg: float) -> float:
        return clipped_restitution(self.zeta(mass_kg))

    def zeta(self, mass_kg: float) -> float:
        return self.damping_ns_per_m / (2.0 * math.sqrt(self.stiffness_n_per_m * mass_kg))

    def duration_s(self, mass_kg: float) -> float:
        z = self.zeta(mass_kg)
        wd = math.sqrt(self.stiffness_n_per_m / mass_kg) * math.sqrt(1.0 - z * z)
        return clipped_phase(z) / wd


MAX_MATCHED_ZETA = 0.7
"""The largest damping ratio :func:`spring_damper_matching` searches (its restitution is the
lowest a native mapping matches)."""


def spring_damper_matching(mass_kg: float, restitution: float, duration_s: float) -> SpringDamper:
    """The clipped linear spring–damper with this restitution and contact duration.

    Solves e(ζ) = restitution for ζ (e decreases monotonically from 1 at ζ = 0), then
    ωd = θe(ζ)/T, ωn = ωd/√(1−ζ²), k = m·ωn², d = 2ζ·√(k·m).
    """
    if not 0.0 < restitution <= 1.0:
        raise ValueError(f"restitution = {restitution!r}: must be in (0, 1]")
    floor = clipped_restitution(MAX_MATCHED_ZETA)
    if restitution < floor:  # a nearly dead ball: no clipped spring–damper bounces that low
        raise InvalidValue(f"restitution = {restitution:.4g}: the native mapping's clipped "
                           f"linear spring–damper matches restitution >= {floor:.4g} "
                           f"(damping ratio <= {MAX_MATCHED_ZETA}); lower the damping or use "
                           "mode injected")
    if restitution == 1.0:
        zeta = 0.0
    else:
        zeta = optimize.brentq(lambda z: clipped_restitution(z) - restitution, 0.0,
                               MAX_MATCHED_ZETA,
                               xtol=1e-15, rtol=1e-15)
    wd = clipped_phase(zeta) / duration_s
    wn = wd / math.sqrt(1.0 - zeta * zeta)
    k = mass_kg * wn * wn
    return SpringDamper(k, 2.0 * zeta * math.sqrt(k * mass_kg))


class Recorder:
    """Collects one sample per step, then builds an ImpactRecord.

    Append the state at the start of a step together with the force that acts over that
    step: sample k is (t_k, x_k, ẋ_k, F_k, v1_k, v2_k[, x2_k]). Appending a tuple to a list
    costs ~0.1 µs, well below an engine step; the arrays are built once in :meth:`record`.
    """

    __slots__ = ("_rows",)

    def __init__(self) -> None:
        self._rows: list[tuple[float, ...]] = []

    def append(self, t: float, x: float, xdot: float, force: float, v1: float,
               v2: float = 0.0, x2: float = 0.0) -> None:
        self._rows.append((t, x, xdot, force, v1, v2, x2))

    def __len__(self) -> int:
        return len(self._rows)

    def record(self, mass_1_kg: float, mass_2_kg: float = math.inf,
               with_displacement_2: bool = False, **meta) -> ImpactRecord:
        d = np.array(self._rows, dtype=float).reshape(-1, 7).T
        return ImpactRecord(
            d[0], d[1], d[2], d[3], d[4], d[5], mass_1_kg=mass_1_kg, mass_2_kg=mass_2_kg,
            displacement_2_m=d[6].copy() if with_displacement_2 else None, meta=dict(meta),
        )


def classify(rec: ImpactRecord, *, initial_kinetic_j: float, final_kinetic_j: float,
             tunneled: bool = False, timed_out: bool = False) -> ImpactRecord:
    """Set the record's status from what happened, in order of precedence:

    diverged (NaN/inf anywhere, or final kinetic energy > (1 + 1 %) × initial), tunneled (the
    body ended beyond the obstacle), no_contact (no positive force was ever reported),
    max_time (still in contact or approaching at the time cap), else ok.
    """
    arrays = (rec.time_s, rec.penetration_m, rec.penetration_rate_m_s, rec.normal_force_n,
              rec.velocity_1_m_s, rec.velocity_2_m_s)
    if not all(np.all(np.isfinite(a)) for a in arrays) or not math.isfinite(final_kinetic_j):
        rec.status, rec.message = Status.DIVERGED, "non-finite state"
    elif final_kinetic_j > (1.0 + ENERGY_GAIN_LIMIT) * initial_kinetic_j:
        gain = final_kinetic_j / initial_kinetic_j - 1.0
        rec.status, rec.message = Status.DIVERGED, f"kinetic energy gained {gain:.1%}"
    elif tunneled:
        rec.status, rec.message = Status.TUNNELED, "the body ended beyond the obstacle"
    elif rec.normal_force_n.size == 0 or not np.any(rec.normal_force_n > 0.0):
        rec.status, rec.message = Status.NO_CONTACT, "the engine reported no contact force"
    elif timed_out:
        rec.status, rec.message = Status.MAX_TIME, "time cap reached before separation"
    else:
        rec.status = Status.OK
    return rec


def native_ball_spring_damper(scenario, reference_velocity_m_s: float | None = None
                              ) -> SpringDamper:
    """The clipped linear spring–damper matching the Hunt–Crossley reference's restitution
    and contact duration for ``scenario`` at the reference velocity (default
    :data:`NATIVE_REFERENCE_VELOCITY_M_S`), the conversion behind MuJoCo's and PyBullet's
    native mode."""
    from impactbench.reference import hunt_crossley

    v_ref = reference_velocity_m_s or NATIVE_REFERENCE_VELOCITY_M_S
    ref = hunt_crossley.solve(scenario.replace(velocity_m_s=v_ref))
    return spring_damper_matching(scenario.mass_kg, ref["restitution"], ref["duration_s"])


@contextlib.contextmanager
def silenced_fds() -> Iterator[None]:
    """Send the process's file descriptors 1 and 2 to /dev/null for the duration.

    For engines whose C extension prints a banner when imported (pybullet: its build time,
    with printf): Python-level redirection cannot catch a C printf, so the descriptors
    themselves are swapped, and C's stdio buffer is flushed before they are restored.
    Python exceptions (an ImportError) are unaffected."""
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        with fds_redirected(null, 1, 2):
            yield
    finally:
        os.close(null)


@contextlib.contextmanager
def stderr_without(*noise: str) -> Iterator[None]:
    """Drop the lines containing any of ``noise`` from what C code writes to file descriptor 2
    for the duration (e.g. warp's "could not load the CUDA driver" on a CPU-only machine, which
    a C ``fprintf`` prints whatever Python's warning filters say); every other line is
    written to stderr afterwards, unchanged."""
    import tempfile

    with tempfile.TemporaryFile() as buf:
        try:
            with fds_redirected(buf.fileno(), 2):
                yield
        finally:
            buf.seek(0)
            kept = [line for line in buf.read().decode(errors="replace").splitlines(True)
                    if not any(n in line for n in noise)]
            if kept:
                sys.stderr.write("".join(kept))
                sys.stderr.flush()


DRAKE_NOISE = ("The TAMSI solver is deprecated",
               "Rigid (non-deformable) half spaces are not currently supported for deformable")
"""Drake log lines that say nothing about a rigid-body impact run: TAMSI's deprecation (TAMSI
is one of the discrete solvers compared, on purpose) and the deformable-contact note on half
spaces (no deformable bodies here)."""


def quiet_drake_log() -> None:
    """Drop :data:`DRAKE_NOISE` from the ``drake`` logger (idempotent)."""
    import logging

    log = logging.getLogger("drake")
    if not any(getattr(f, "impactbench", False) for f in log.filters):
        def keep(record: logging.LogRecord) -> bool:
            return not any(n in record.getMessage() for n in DRAKE_NOISE)

        keep.impactbench = True  # type: ignore[attr-defined]
        log.addFilter(keep)


def reference_velocity(options: dict) -> float:
    """The native conversion's reference velocity (m/s): ``options["reference_velocity_m_s"]``
    or :data:`NATIVE_REFERENCE_VELOCITY_M_S`; a non-positive value is a ValueError."""
    from impactbench.reference import validation as check

    return check.positive("options.reference_velocity_m_s",
                          options.get("reference_velocity_m_s", NATIVE_REFERENCE_VELOCITY_M_S))


@functools.lru_cache(maxsize=256)
def _hunt_crossley(scenario) -> dict[str, float]:
    from impactbench.reference import hunt_crossley

    return dict(hunt_crossley.solve(scenario))


def native_ball_restitution(scenario, reference_velocity_m_s: float) -> float:
    """The Hunt–Crossley restitution of ``scenario`` at the reference velocity: the constant
    coefficient a user gives a rigid contact (cached: sweeps ask for the same one again)."""
    return float(_hunt_crossley(scenario.replace(velocity_m_s=reference_velocity_m_s))
                 ["restitution"])


def native_ball_spring(scenario, reference_velocity_m_s: float) -> float:
    """Stiffness k (N/m) of the *undamped* linear spring whose contact duration π·√(m/k)
    equals the Hunt–Crossley reference's at the reference velocity (for an engine whose
    compliant contact has no damping: duration matches there, restitution is 1)."""
    duration = _hunt_crossley(scenario.replace(velocity_m_s=reference_velocity_m_s))["duration_s"]
    return spring_damper_matching(scenario.mass_kg, 1.0, duration).stiffness_n_per_m
