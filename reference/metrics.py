"""The one metrics path: :class:`~impactbench.reference.record.ImpactRecord` → impact metrics.

The reference solvers and every engine adapter go through :func:`compute`, so any difference
in a comparison table is a difference in physics or numerics, never in bookkeeping.

Definitions (SI):

- A *contact* lasts from the instant the surfaces start to press on each other until they
  part: where the force *lets go* (reaches zero at a finite rate) or the surfaces separate
  (x = 0), whichever comes first. In a record: a run of samples with normal force F above a
  floor of ``FORCE_FLOOR_REL`` × max F (round-off and engine-clamp dust are not contact),
  extended to the separation x = 0 when the force has *faded* into the floor rather than let
  go (:data:`FADE_RATIO`). A Hunt–Crossley force F = f(x)·(1 + b·ẋ) fades: its factor obeys
  d(1 + b·ẋ)/dt = −(b/m)·f(x)·(1 + b·ẋ), so 1 + b·ẋ = exp(−∫(b/m)·f dt) > 0 — the velocity
  never reaches −1/b and F > 0 until x = 0, the closed form's end, even where F/F_max is far
  below round-off (α = b·V0 = 50: F < 1e-13·F_max over the last 68 % of the contact). A
  clipped spring–damper or an elastoplastic permanent set lets go at a finite rate while
  still penetrating, and the contact ends there.
  Its start and end are located between samples: at the zero crossing of the penetration
  when it changes sign in the bracketing step (Hunt–Crossley, linear laws); otherwise by
  extrapolating the force linearly to zero from the two samples inside the contact, clamped
  to the bracketing step (a clipped spring–damper lets go while still penetrating; an
  elastoplastic contact starts and ends at its permanent set).
- ``restitution`` k = −ẋ(end of last contact) / ẋ(start of first contact), relative normal
  velocities interpolated at those instants. A contact spanning fewer than
  ``MIN_CONTACT_SAMPLES`` force samples (a step as long as the contact) has no interior to
  interpolate in: its velocities are read at the free-flight samples just outside it (the
  velocity before the first contact sample and after the last), so the restitution of a
  one-step impulse stays comparable.
- *Resolution* (:func:`resolved`): with fewer than ``MIN_CONTACT_SAMPLES`` samples in the
  first contact, the time-resolved metrics (duration, pulse width, contact time, peak force,
  max penetration, energy loss) are one- or few-step artefacts of the step size and are flagged
  not resolved; restitution, impulse and the impact count stay comparable.
- ``duration_s``: the first contact's duration. ``pulse_width_s``: first contact's start to
  the last contact's end. ``contact_time_s``: summed contact durations. ``impacts``: count.
- ``peak_force_n``: the largest force sample; ``max_penetration_m``: the largest penetration
  sample inside a contact.
- ``impulse_ns``: ∫F dt (trapezoid over the record).
- ``energy_loss_fraction``: the hysteresis loop area ∮F dx over the kinetic energy at the
  first contact's start (½·m1·v1² + ½·m2·v2²). For a ball on a rigid plate it equals 1 − k².
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from impactbench.reference.record import ImpactRecord

FORCE_FLOOR_REL = 1e-13
"""Forces below this fraction of the peak are round-off dust, not contact. A force computed
from O(F_max) quantities carries errors of ~1e-16·F_max, and engine clamps leave less (Bullet's
minimum contact stiffness, 2.2e-16 N/m, gives ~1e-20·F_max in an elastoplastic permanent set);
a physical force can be far smaller than 1e-9·F_max yet real (a Hunt–Crossley contact at
α = b·V0 = 10 lets go with F ≈ 2e-10·F_max one sample before x = 0)."""

FADE_RATIO = 0.9
"""A force run ending at sample j while the surfaces still overlap has *faded* (not let go)
when its last three samples fall at least geometrically, f_j·f_{j−2} ≥ FADE_RATIO·f_{j−1}²
(log F not concave: an exponential decay such as Hunt–Crossley's, ratio ≥ 1). A force that
reaches zero at a finite rate, f ∝ (t0 − t)^p, gives at most 1 − 1/(1+θ)^(2p) ≤ 3/4 for
p = 1 (θ·dt = t0 − t_j ≤ dt), so 0.9 separates the two with margin."""

MIN_CONTACT_SAMPLES = 10
"""A contact sampled fewer times than this is not time-resolved: a half-sine pulse sampled 10
times has its peak within 5 % and its located duration within ~10 % of a step."""

TIME_RESOLVED: tuple[str, ...] = (
    "duration_s",
    "peak_force_n",
    "max_penetration_m",
    "energy_loss_fraction",
    "pulse_width_s",
    "contact_time_s",
)
"""Metrics that need the contact resolved in time (see :func:`resolved`)."""

METRICS: tuple[str, ...] = (
    "restitution",
    "duration_s",
    "peak_force_n",
    "max_penetration_m",
    "impulse_ns",
    "energy_loss_fraction",
    "pulse_width_s",
    "contact_time_s",
    "impacts",
)

BALL_METRICS: tuple[str, ...] = (
    "restitution",
    "duration_s",
    "peak_force_n",
    "max_penetration_m",
    "energy_loss_fraction",
)
"""The five ball-on-plate metrics, in the order of the CLI's JSON output."""


@dataclass(frozen=True)
class Contact:
    """One contact interval: located start/end times (s) and its first/last force samples."""

    start_s: float
    end_s: float
    first: int
    last: int

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def _lerp_root(t0: float, y0: float, t1: float, y1: float) -> float:
    """Time where the line through (t0, y0), (t1, y1) crosses zero."""
    return t0 + (t1 - t0) * (-y0) / (y1 - y0)


def _edge_time(rec: ImpactRecord, outside: int, inside: int, inner: int) -> float:
    """Locate a contact edge between sample ``outside`` (no force) and ``inside`` (force).

    ``inner`` is the next sample further inside the contact (used for force extrapolation).
    """
    t, x, f = rec.time_s, rec.penetration_m, rec.normal_force_n
    lo, hi = sorted((t[outside], t[inside]))
    # the surfaces meet (or part) between the two samples, or exactly on one of them (a
    # spring–damper's force is d·ẋ > 0 at the touch itself, so x = 0 can carry force)
    if x[outside] <= 0.0 <= x[inside] and x[outside] < x[inside]:
        return _lerp_root(t[outside], x[outside], t[inside], x[inside])
    if inner != inside and f[inner] != f[inside]:
        root = _lerp_root(t[inside], f[inside], t[inner], f[inner])
        return min(max(root, lo), hi)
    return t[outside]


def _faded(f: np.ndarray, i: int, j: int) -> bool:
    """Whether the force run ``f[i..j]`` decays into the floor instead of letting go."""
    if j - i < 2:
        return False
    return bool(f[j] * f[j - 2] >= FADE_RATIO * f[j - 1] ** 2)


def _extend_faded(rec: ImpactRecord, firsts: list[int], lasts: list[int],
                  ) -> tuple[list[int], list[int]]:
    """Runs whose force faded while the surfaces overlap last until x ≤ 0 (merging any run
    that starts before then); the end is then located at the penetration's zero crossing."""
    f, x = rec.normal_force_n, rec.penetration_m
    n = f.size
    out_f: list[int] = []
    out_l: list[int] = []
    for i, j in zip(firsts, lasts, strict=True):
        if out_l and i <= out_l[-1]:
            # starts inside the previous, extended contact: part of it, to its own end if
            # that is later (force beyond the parting point, e.g. from a contact margin)
            out_l[-1] = max(out_l[-1], j)
            continue
        if j < n - 1 and x[j + 1] > 0.0 and _faded(f, i, j):
            apart = np.flatnonzero(x[j + 1:] <= 0.0)
            j = j + apart[0] if apart.size else n - 1
        out_f.append(i)
        out_l.append(j)
    return out_f, out_l


def contacts(rec: ImpactRecord) -> list[Contact]:
    """All contact intervals of ``rec``, in time order."""
    f = rec.normal_force_n
    n = f.size
    if n == 0:
        return []
    fmax = float(np.max(f))
    if not fmax > 0.0:
        return []
    active = f > FORCE_FLOOR_REL * fmax
    edges = np.diff(active.astype(np.int8))
    firsts = list(np.flatnonzero(edges == 1) + 1)
    lasts = list(np.flatnonzero(edges == -1))
    if active[0]:
        firsts.insert(0, 0)
    if active[-1]:
        lasts.append(n - 1)
    firsts, lasts = _extend_faded(rec, firsts, lasts)
    out = []
    for i, j in zip(firsts, lasts, strict=True):
        start = (
            _edge_time(rec, i - 1, i, min(i + 1, j)) if i > 0 else float(rec.time_s[0])
        )
        end = (
            _edge_time(rec, j + 1, j, max(j - 1, i)) if j < n - 1 else float(rec.time_s[-1])
        )
        out.append(Contact(float(start), float(end), int(i), int(j)))
    return out


def _interp(rec: ImpactRecord, y: np.ndarray, t: float) -> float:
    return float(np.interp(t, rec.time_s, y))


def compute(rec: ImpactRecord) -> dict[str, float]:
    """Metrics of one record (see module docstring). All NaN (impacts 0) without contact."""
    nan = math.nan
    out: dict[str, float] = dict.fromkeys(METRICS, nan)
    out["impacts"] = 0
    cs = contacts(rec) if len(rec) else []
    if not cs:
        return out
    first, last = cs[0], cs[-1]
    rate = rec.penetration_rate_m_s
    if first.last - first.first + 1 < MIN_CONTACT_SAMPLES and first.first > 0:
        v_in = float(rate[first.first - 1])  # free flight just before the contact
    else:
        v_in = _interp(rec, rate, first.start_s)
    if last.last - last.first + 1 < MIN_CONTACT_SAMPLES and last.last < rate.size - 1:
        v_out = float(rate[last.last + 1])  # free flight just after the contact
    else:
        v_out = _interp(rec, rate, last.end_s)
    f, x = rec.normal_force_n, rec.penetration_m
    inside = np.zeros(f.size, dtype=bool)
    for c in cs:
        inside[c.first : c.last + 1] = True
    v1 = _interp(rec, rec.velocity_1_m_s, first.start_s)
    kinetic = 0.5 * rec.mass_1_kg * v1**2
    if math.isfinite(rec.mass_2_kg):
        kinetic += 0.5 * rec.mass_2_kg * _interp(rec, rec.velocity_2_m_s, first.start_s) ** 2
    out.update(
        restitution=-v_out / v_in if v_in != 0.0 else nan,
        duration_s=first.duration_s,
        peak_force_n=float(np.max(f)),
        max_penetration_m=float(np.max(x[inside])),
        impulse_ns=float(np.trapezoid(f, rec.time_s)),
        energy_loss_fraction=float(np.trapezoid(f, x)) / kinetic if kinetic > 0 else nan,
        pulse_width_s=last.end_s - first.start_s,
        contact_time_s=float(sum(c.duration_s for c in cs)),
        impacts=len(cs),
    )
    return out


def resolved(rec: ImpactRecord) -> dict[str, bool]:
    """Per metric: is it resolved in time? False for :data:`TIME_RESOLVED` metrics when the
    first contact spans fewer than :data:`MIN_CONTACT_SAMPLES` force samples (the step is about
    as long as the contact); always True for the others and for a record without contact."""
    cs = contacts(rec) if len(rec) else []
    ok = not cs or cs[0].last - cs[0].first + 1 >= MIN_CONTACT_SAMPLES
    return {k: (ok or k not in TIME_RESOLVED) for k in METRICS}


def relative_error(value: float, reference: float) -> float:
    """Signed relative error (value − reference)/|reference|; NaN where undefined."""
    if not (math.isfinite(value) and math.isfinite(reference)) or reference == 0.0:
        return 0.0 if value == reference else math.nan
    return (value - reference) / abs(reference)
