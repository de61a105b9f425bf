"""The shared metrics at their edges: records whose answer is worked out by hand (issue 25).

test_metrics.py checks the metrics on the Hunt–Crossley reference's own histories and
test_metrics_synthetic.py on a finely sampled clipped spring–damper; both are smooth, well
resolved contacts that start and end inside the record. The records here are the other cases a
producer hands over: one-step impulses (with and without overlap), contacts at the record's
ends, forces fading into the floor at the last moment, chatter inside a fading contact, a body
tunnelling on after its contact, a resting body, two free bodies. Samples are one time unit
apart (dt = 1) unless said otherwise, so every expected edge, velocity and ratio below is exact
arithmetic on the listed samples, following the rules in the docstring of
:mod:`impactbench.reference.metrics`.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from impactbench.reference import metrics
from impactbench.reference.metrics import FORCE_FLOOR_REL, TIME_RESOLVED
from impactbench.reference.record import ImpactRecord, Status
from test_metrics_synthetic import spring_damper_history


def record(x, f, rate=None, *, m1: float = 1.0) -> ImpactRecord:
    """Body 1 on a fixed plate, samples at t = 0, 1, 2, …; ẋ defaults to a constant 1."""
    x = np.asarray(x, dtype=float)
    t = np.arange(x.size, dtype=float)
    rate = np.ones_like(t) if rate is None else np.asarray(rate, dtype=float)
    return ImpactRecord(t, x, rate, f, rate, np.zeros_like(t), mass_1_kg=m1)


def edges(rec: ImpactRecord) -> list[tuple[float, float, int, int]]:
    return [(c.start_s, c.end_s, c.first, c.last) for c in metrics.contacts(rec)]


# --- relative_error -------------------------------------------------------------------------

def test_relative_error_divides_by_the_reference_magnitude() -> None:
    # (value − reference)/|reference|: (3 − 2)/2, (−3 + 2)/2, (1 − 4)/4
    assert metrics.relative_error(3.0, 2.0) == 0.5
    assert metrics.relative_error(-3.0, -2.0) == -0.5
    assert metrics.relative_error(1.0, 4.0) == -0.75


@pytest.mark.parametrize(("value", "reference"), [(math.inf, 1.0), (-math.inf, 2.0),
                                                  (1.0, math.inf), (1.0, math.nan)])
def test_relative_error_with_a_non_finite_side_is_undefined(value, reference) -> None:
    """A diverged engine value (±inf) has no relative error, not an infinite one."""
    assert math.isnan(metrics.relative_error(value, reference))


# --- one-step impulses ----------------------------------------------------------------------

IMPULSE_N = 12


def impulse_record(i: int, overlap: bool) -> ImpactRecord:
    """A 1 kg ball under gravity (ẋ grows by 0.1 per step in free flight) meets the plate in
    one step at sample ``i``: 3.0 just before, −1.5 just after (e = 0.5), impulse 4.5 N·s
    = m·(3.0 + 1.5) at dt = 1. ``overlap``: the surfaces overlap at sample i (x = +1, the
    surfaces cross x = 0 half a step before and a quarter step after it); otherwise the
    engine stops the ball short of the plate (speculative contact, x = −0.1 at sample i)."""
    k = np.arange(IMPULSE_N, dtype=float)
    rate = np.where(k < i, 3.0 + 0.1 * (k - (i - 1)), -1.5 + 0.1 * (k - (i + 1)))
    rate[i] = 0.75  # mid-step: whatever the engine reports inside the contact
    if overlap:
        x = np.where(k < i, -1.0 - 3.0 * (i - 1 - k), -3.0 - 1.5 * (k - (i + 1)))
        x[i] = 1.0
    else:
        x = np.where(k < i, -1.0 - 3.0 * (i - 1 - k), -1.0 - 1.5 * (k - (i + 1)))
        x[i] = -0.1
    f = np.zeros(IMPULSE_N)
    f[i] = 4.5
    return record(x, f, rate)


@pytest.mark.parametrize("overlap", [False, True], ids=["speculative", "overlapping"])
@pytest.mark.parametrize("i", [1, 5, IMPULSE_N - 2])
def test_one_step_impulse_reads_free_flight_velocities(i, overlap) -> None:
    """Fewer than MIN_CONTACT_SAMPLES force samples: the restitution uses the free-flight
    samples just before and after the contact (3.0 and −1.5 → e = 0.5), not velocities
    interpolated inside the step nor samples further out (2.9, −1.4)."""
    rec = impulse_record(i, overlap)
    got = metrics.compute(rec)
    assert got["impacts"] == 1
    assert got["restitution"] == pytest.approx(0.5, rel=1e-12)
    assert got["impulse_ns"] == pytest.approx(4.5, rel=1e-12)  # trapezoid of one spike: f·dt
    assert got["max_penetration_m"] == rec.penetration_m[i]  # the only sample in contact
    if overlap:  # x crosses zero half a step before and a quarter step after sample i
        assert edges(rec) == [(i - 0.5, i + 0.25, i, i)]
    else:  # no crossing, one force sample: the edges stay at the bracketing samples
        assert edges(rec) == [(i - 1.0, i + 1.0, i, i)]
    flags = metrics.resolved(rec)
    assert not any(flags[k] for k in TIME_RESOLVED)
    assert flags["restitution"] and flags["impulse_ns"] and flags["impacts"]


def test_impulse_on_the_last_sample_reads_the_record_end() -> None:
    """A record cut off on the impulse's own sample has no free flight after it: the exit
    velocity is read at the record's end (the contact's end), as for any cut-off contact."""
    i = IMPULSE_N - 1
    rec = impulse_record(i, overlap=False)
    got = metrics.compute(rec)
    assert edges(rec) == [(i - 1.0, float(i), i, i)]
    assert got["restitution"] == pytest.approx(-0.75 / 3.0, rel=1e-12)


# --- resolution threshold -------------------------------------------------------------------

def threshold_record(samples: int) -> ImpactRecord:
    """A contact of ``samples`` force samples starting at sample 3; the surfaces cross x = 0
    half a step before its first and after its last sample. Velocities: 3.0 → 1.0 across the
    entry step (2.0 at the crossing), −0.7 → −1.5 across the exit step (−1.1 at the crossing);
    free flight changes by 0.1 per step outside."""
    i, n = 3, samples + 7
    j = i + samples - 1
    k = np.arange(n, dtype=float)
    x = np.where(k < i, -1.0 - (i - 1 - k), -1.0 - (k - (j + 1)))
    x[i:j + 1] = 1.0 + np.minimum(k[i:j + 1] - i, j - k[i:j + 1])
    f = np.zeros(n)
    f[i:j + 1] = 10.0 * np.sin(math.pi * (k[i:j + 1] - i + 0.5) / samples)
    rate = np.where(k < i, 3.0 + 0.1 * (k - (i - 1)), -1.5 + 0.1 * (k - (j + 1)))
    rate[i:j + 1] = np.linspace(1.0, -0.7, samples)
    return record(x, f, rate)


def test_contact_of_min_samples_is_resolved_and_interpolates_its_edges() -> None:
    rec = threshold_record(metrics.MIN_CONTACT_SAMPLES)
    got = metrics.compute(rec)
    assert got["duration_s"] == metrics.MIN_CONTACT_SAMPLES  # (j + ½) − (i − ½)
    assert got["restitution"] == pytest.approx(1.1 / 2.0, rel=1e-12)  # at the crossings
    assert all(metrics.resolved(rec).values())


def test_contact_one_sample_short_reads_free_flight_and_is_not_resolved() -> None:
    rec = threshold_record(metrics.MIN_CONTACT_SAMPLES - 1)
    got = metrics.compute(rec)
    assert got["restitution"] == pytest.approx(1.5 / 3.0, rel=1e-12)  # free-flight samples
    flags = metrics.resolved(rec)
    assert {k for k, ok in flags.items() if not ok} == set(TIME_RESOLVED)


def test_no_contact_is_resolved_everywhere() -> None:
    rec = record([-3.0, -2.0, -1.0], [0.0, 0.0, 0.0])
    assert all(metrics.resolved(rec).values())
    assert all(metrics.resolved(ImpactRecord.failed(Status.CRASHED, "boom")).values())
    assert metrics.contacts(ImpactRecord.failed(Status.CRASHED, "boom")) == []


# --- contacts at the record's ends ----------------------------------------------------------

def test_record_opening_inside_a_contact() -> None:
    """The record's first sample is already in contact (x = 3.5 − t, force letting go
    linearly); a second, short touch follows. The first contact starts at the record's start,
    ends where x crosses zero (3.5); the second spans x's crossings 7.5 and 10.5. Short
    contacts read free flight, and there is none before the record: the approach velocity is
    the first sample's (2.0), never wrapped round to the record's last (−1.0 → e = 0.8/2)."""
    x = [3.5, 2.5, 1.5, 0.5, -0.5, -1.5, -1.0, -0.5, 0.5, 1.0, 0.5, -0.5, -1.0]
    f = [4.0, 3.0, 2.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 1.0, 0.0, 0.0]
    rate = [2.0, 1.0, 0.0, -1.0, -1.0, -1.0, 0.5, 0.5, 0.5, 0.0, -0.5, -0.8, -1.0]
    rec = record(x, f, rate)
    assert edges(rec) == [(0.0, 3.5, 0, 3), (7.5, 10.5, 8, 10)]
    got = metrics.compute(rec)
    assert got["impacts"] == 2
    assert got["restitution"] == pytest.approx(0.8 / 2.0, rel=1e-12)


def test_contact_starting_in_the_first_step_is_located_inside_it() -> None:
    rec = record([-0.25, 0.75, 0.5, -0.5], [0.0, 1.0, 1.0, 0.0])
    assert edges(rec) == [(0.25, 2.5, 1, 2)]


def test_contact_letting_go_in_the_last_step_is_located_inside_it() -> None:
    rec = record([-0.5, 0.5, 1.0, -3.0], [0.0, 1.0, 1.0, 0.0])
    assert edges(rec) == [(0.5, 2.25, 1, 2)]


@pytest.mark.parametrize("fading", [False, True], ids=["pressing", "fading"])
def test_record_cut_off_during_a_contact(fading) -> None:
    """A run stopped at max_time while the surfaces overlap: the contact lasts to the
    record's last sample, whether the force still presses or is fading (1, 1e-2, 1e-4, …)."""
    x = [-0.5, 0.5, 1.0, 1.5, 2.0, 2.0, 2.0]
    f = [0.0, 1.0, 1e-2, 1e-4, 1e-6, 1e-8, 1e-10] if fading else \
        [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    assert edges(record(x, f)) == [(0.5, 6.0, 1, 6)]


def test_force_fading_out_on_the_last_sample_lasts_to_the_record_end() -> None:
    """The force falls below the floor on the last sample while the surfaces still overlap:
    it faded (1e-3 per step, ratio 1 ≥ FADE_RATIO), so the contact lasts to the end."""
    x = [-0.5, 0.5, 1.0, 1.5, 1.5, 1.0, 0.75]
    f = [0.0, 1.0, 1e-3, 1e-6, 1e-9, 1e-12, 1e-15]  # 1e-15 < FORCE_FLOOR_REL · 1
    assert edges(record(x, f)) == [(0.5, 6.0, 1, 6)]


# --- fading, letting go, the force floor ---------------------------------------------------

FADE = [0.0, 1.0, 2.0, 2e-3, 2e-6, 2e-9, 2e-12, 2e-15, 2e-18]
"""A force rising to 2 and then decaying by 1e-3 per step (f_j·f_{j−2} = f_{j−1}²: ratio 1),
below the floor 2e-13 from sample 7 on."""


@pytest.mark.parametrize(("x_tail", "end"), [
    ([1.0, 0.25, -0.75, -2.75], 8.25),  # surfaces part two samples after the force's run
    ([0.25, -0.75, -2.75, -4.75], 7.25),  # ... one sample after it
])
def test_faded_force_ends_where_the_surfaces_part(x_tail, end) -> None:
    """Issue 16's rule: a fading force keeps the contact until x = 0, located by the line
    through the two samples bracketing the crossing (x = 0.25 → −0.75: a quarter step)."""
    x = [-0.5, 0.5, 1.5, 2.5, 2.5, 2.0, 1.5, *x_tail]
    f = np.where(np.array(x) > 0, FADE + [0.0] * (len(x) - len(FADE)), 0.0)
    rec = record(x, f)
    assert edges(rec) == [(0.5, end, 1, int(end))]
    assert metrics.compute(rec)["max_penetration_m"] == 2.5


def test_faded_force_ends_when_the_surfaces_come_to_rest_touching() -> None:
    """x ≤ 0 ends a faded contact, x = 0 included: a body left resting just touching the
    plate (x = 0, no force) parted at the first touching sample."""
    x = [-0.5, 0.5, 1.5, 2.5, 2.5, 2.0, 1.0, 0.5, 0.0, 0.0, 0.0]
    f = FADE[:8] + [0.0] * 3
    assert edges(record(x, f)) == [(0.5, 8.0, 1, 7)]


def test_fade_ratio_boundary_is_inclusive() -> None:
    """f_j·f_{j−2} ≥ FADE_RATIO·f_{j−1}² (module docstring): the last three samples 1, 1, 0.9
    sit exactly on the boundary and fade (the contact lasts until x crosses zero at 8.5);
    1, 1, 0.89 let go (the line through 1 and 0.89 reaches zero after the step, so the end
    is clamped to the next sample, 4)."""
    x = [-0.5, 0.5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5, -0.5]
    assert edges(record(x, [0.0, 1.0, 1.0, 0.9] + [0.0] * 6)) == [(0.5, 8.5, 1, 8)]
    assert edges(record(x, [0.0, 1.0, 1.0, 0.89] + [0.0] * 6)) == [(0.5, 4.0, 1, 3)]


def test_shortest_run_that_can_fade_has_three_samples() -> None:
    """Three samples 1, 1e-5, 1e-10 (ratio 1) fade: Hunt–Crossley at very high α sampled
    coarsely; the contact lasts until x crosses zero (7.5)."""
    x = [-0.5, 0.5, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5, -0.5]
    f = [0.0, 1.0, 1e-5, 1e-10, 1e-15, 0.0, 0.0, 0.0, 0.0]
    assert edges(record(x, f)) == [(0.5, 7.5, 1, 7)]


@pytest.mark.parametrize(("f_run", "end"), [
    ([4.0], 3.0),  # one sample: no interior, the edge stays at the next sample
    ([4.0, 4e-5], 3.00001),  # two: the line through 4 and 4e-5 reaches zero 1e-5 later
])
def test_one_or_two_force_samples_let_go(f_run, end) -> None:
    """A run of fewer than three samples cannot show a fade: an engine that applies a whole
    contact in one or two steps while the surfaces keep overlapping has let go."""
    x = [-1.0, -0.5, 0.5, 1.0, 1.0, 1.0, 1.0, 0.5, -0.5]
    f = [0.0, 0.0, *f_run] + [0.0] * (9 - 2 - len(f_run))
    (c,) = metrics.contacts(record(x, f))
    assert c.end_s == pytest.approx(end, abs=1e-9)
    assert c.last == 1 + len(f_run)


def _let_go_with_dust(dust: float, scale: float = 1.0) -> ImpactRecord:
    """Force 1, 2, 1 letting go (line through 2 and 1 reaches zero at 4, one step on),
    then ``dust`` while the surfaces overlap until 8.5."""
    x = [-0.5, 0.5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5, -0.5]
    f = np.array([0.0, 1.0, 2.0, 1.0, dust, dust, dust, dust, dust, 0.0]) * scale
    return record(x, f)


def test_dust_exactly_at_the_floor_is_not_contact() -> None:
    """Contact is force *above* FORCE_FLOOR_REL × max F: dust at exactly the floor is not."""
    assert edges(_let_go_with_dust(FORCE_FLOOR_REL * 2.0)) == [(0.5, 4.0, 1, 3)]


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3, 1e6])
def test_contacts_do_not_depend_on_the_force_unit(scale) -> None:
    """The floor is relative to the peak: N, mN or MN give the same contact (dust 1e-14 ×
    the peak of 2 is below the floor at every scale)."""
    assert edges(_let_go_with_dust(2e-14, scale)) == [(0.5, 4.0, 1, 3)]


def test_force_extrapolated_edges_use_the_two_samples_inside() -> None:
    """An elastoplastic re-impact on a dented plate starts and ends at the permanent set
    (x > 0 throughout): no crossing of x, so each edge is where the line through the two
    force samples inside the contact reaches zero. Force (t − 1)² on 1 ≤ t ≤ 5 and (9 − t)²
    after: lines through (2, 1), (3, 4) and (8, 1), (7, 4) give 5/3 and 25/3 (the true
    edges, 1 and 9, lie within a step)."""
    t = np.arange(11, dtype=float)
    f = np.where(t <= 5, np.clip(t - 1, 0, None) ** 2, np.clip(9 - t, 0, None) ** 2)
    (c,) = metrics.contacts(record(np.full(11, 0.3), f))
    assert (c.first, c.last) == (2, 8)
    assert c.start_s == pytest.approx(5 / 3, rel=1e-15)
    assert c.end_s == pytest.approx(25 / 3, rel=1e-15)


def test_chatter_inside_a_fading_contact_is_the_same_contact() -> None:
    """A force blip (sample 8) after the fade but before the surfaces part (x crosses zero at
    8.25) belongs to the fading contact; a touch after they parted (12.5 to 14.5) is a
    second impact."""
    x = [-0.5, 0.5, 1.5, 2.0, 2.0, 1.5, 1.0, 0.75, 0.25, -0.75, -2.0, -1.0, -0.5, 0.5, 0.5,
         -0.5, -1.5]
    f = [*FADE[:8], 1e-3, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0]
    rec = record(x, f)
    assert edges(rec) == [(0.5, 8.25, 1, 8), (12.5, 14.5, 13, 14)]
    assert metrics.compute(rec)["impacts"] == 2


def test_a_force_run_that_outlasts_the_fading_contact_it_starts_in_extends_it() -> None:
    """A blip that starts before the surfaces part (sample 8, x = 0.25) and pushes on past the
    parting (samples 9–10 at x < 0: a contact margin's force) belongs to the fading contact,
    and so does its force: the contact ends with it (found by the mutation run: the run's end
    was dropped, leaving force at samples 9–10 in no contact)."""
    x = [-0.5, 0.5, 1.5, 2.0, 2.0, 1.5, 1.0, 0.75, 0.25, -0.75, -1.0, -1.5, -2.0]
    f = [*FADE[:8], 1e-3, 1e-3, 1e-3, 0.0, 0.0]
    (edge,) = edges(record(x, f))
    assert (edge[2], edge[3]) == (1, 10)


def test_penetration_after_the_force_let_go_is_not_the_contacts() -> None:
    """A ball tunnelling on through the plate after its contact let go (force 3, 2, 1, then
    none while x keeps growing): the max penetration is the contact's largest sample, 1.25,
    not the depth it reaches in free flight."""
    x = -0.25 + 0.5 * np.arange(8)
    f = [0.0, 3.0, 2.0, 1.0, 0.0, 0.0, 0.0, 0.0]
    rec = record(x, f)
    assert edges(rec) == [(0.5, 4.0, 1, 3)]
    assert metrics.compute(rec)["max_penetration_m"] == 1.25


# --- kinetic energy bookkeeping -------------------------------------------------------------

def test_body_resting_in_contact_has_no_restitution_or_loss_fraction() -> None:
    """A 2 kg body at rest on the plate from the first sample (x = 1e-6, F = m·g): there is
    no approach velocity and no kinetic energy, so restitution and the loss fraction are
    undefined (NaN), while the force metrics are the static ones."""
    n, m, g = 20, 2.0, 9.81
    rec = record(np.full(n, 1e-6), np.full(n, m * g), np.zeros(n), m1=m)
    got = metrics.compute(rec)
    assert got["impacts"] == 1
    assert math.isnan(got["restitution"])
    assert math.isnan(got["energy_loss_fraction"])
    assert got["peak_force_n"] == m * g
    assert got["impulse_ns"] == pytest.approx(m * g * (n - 1), rel=1e-12)


def test_two_free_bodies_lose_the_kinetic_energy_the_loop_encloses() -> None:
    """Two free bodies (0.3 kg and 0.6 kg, centre of mass moving at 0.2 m/s) meet through a
    clipped linear spring–damper. The hysteresis loop ∮F dx is the kinetic energy lost, so the
    loss fraction is (KE before − KE after)/KE before with KE = ½m1v1² + ½m2v2², read from the
    record's first and last (free-flight) samples. Trapezoid error at dt = 1e-8 over a
    ~84 µs contact: well under 1e-3."""
    m1, m2, vc, v0 = 0.3, 0.6, 0.2, 1.0
    # the relative coordinate x = x1 − x2: the reduced mass on the clipped spring–damper
    t, x, xd, f = spring_damper_history(1.4e8, 700.0, m1 * m2 / (m1 + m2), v0, dt=1e-8)
    v1 = vc + m2 / (m1 + m2) * xd
    v2 = vc - m1 / (m1 + m2) * xd
    rec = ImpactRecord(t, x, xd, f, v1, v2, mass_1_kg=m1, mass_2_kg=m2)

    def kinetic(s: int) -> float:
        return 0.5 * m1 * v1[s] ** 2 + 0.5 * m2 * v2[s] ** 2

    want = (kinetic(0) - kinetic(-1)) / kinetic(0)
    assert 0.2 < want < 0.9  # a real loss, not a vanishing one
    assert metrics.compute(rec)["energy_loss_fraction"] == pytest.approx(want, rel=1e-3)


# --- a touch exactly on a sample ------------------------------------------------------------

def test_a_touch_exactly_on_a_sample_starts_the_contact_there() -> None:
    """A clipped spring–damper sampled so that the touch falls on sample 2 (x = 0.0 there)
    pushes with d·ẋ > 0 already at the touch: the contact starts at t = 2, the sample where
    x crosses zero (found by a mutation run: the edge was extrapolated from the force to
    t = 1, one step early, when the crossing was ≤ 0 < x only)."""
    x = np.array([-2.0, -1.0, 0.0, 1.0, 1.5, 1.0, 0.0, -1.0, -2.0])
    f = np.array([0.0, 0.0, 3.0, 4.0, 2.0, 1.0, 0.0, 0.0, 0.0])
    (edge,) = edges(record(x, f))
    assert edge[0] == 2.0 and (edge[2], edge[3]) == (2, 5)
    # the same contact touching a hair after the sample: the same start
    (near,) = edges(record(np.where(x == 0.0, [1e-300] * 9, x), f))
    assert near[0] == pytest.approx(2.0, abs=1e-12)


def test_a_touch_on_two_samples_at_exactly_zero_starts_from_the_force() -> None:
    """The surfaces meet and stay exactly touching for a sample (x = 0.0 at t = 1 and 2)
    before the force rises: no crossing to interpolate, so the start is where the force line
    through samples 2 and 3 (2, then 3) reaches zero, t = 0, clamped to the interval [1, 2]:
    t = 1 (found by the mutation run: interpolating x between the two zeros gave NaN)."""
    x = np.array([-1.0, 0.0, 0.0, 1.0, 0.5, -1.0, -2.0])
    f = np.array([0.0, 0.0, 2.0, 3.0, 1.0, 0.0, 0.0])
    (edge,) = edges(record(x, f))
    assert edge[0] == 1.0 and math.isfinite(edge[1])
