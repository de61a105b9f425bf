"""The bounce-to-rest reference: convergence, an independent integration path, the gravity-free
limit against the Lambert-W closed form, the switch's error, and bad input."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from impactbench.reference import bounce, hunt_crossley
from impactbench.reference.bounce_scenario import APEX_COUNT_M, Bounce
from scipy.integrate import solve_ivp

from impactbench.cli import main


@pytest.mark.parametrize("height_m", [0.05, 0.2, 1.0])
def test_first_eight_apexes_converge_to_1e_minus_6(height_m):
    s = Bounce(height_m=height_m)
    fine = np.array(bounce.solve(s).apex_heights_m[:8])
    coarse = np.array(bounce.solve(s, rtol=1e-9).apex_heights_m[:8])
    assert fine.size == 8
    # measured 1.7e-9 (0.05 m), 2.9e-9 (0.2 m), 2.3e-8 (1 m) between rtol 1e-9 and 1e-12;
    # the issue asks 1e-6, held here at ~3x the worst measured
    assert np.max(np.abs(coarse / fine - 1.0)) < 7e-8


def _continuous_apexes(s: Bounce, count: int, rtol: float) -> list[float]:
    """A second path: the ball's one state (x, ẋ) integrated from rest at h through flights
    and contacts alike (Radau, an implicit method; flights not taken in closed form), the
    apexes located as events where ẋ turns from rising to falling."""
    g, c, n, b, m = s.gravity_m_s2, s.stiffness, s.exponent, s.damping_s_per_m, s.mass_kg

    def rhs(_t, y):
        x, v = y
        return [v, g - (c * x**n * max(1.0 + b * v, 0.0) / m if x > 0.0 else 0.0)]

    def touch(_t, y):
        return y[0]

    def apex(_t, y):
        return y[1]

    def leave(_t, y):
        return y[0]

    touch.terminal, touch.direction = True, 1.0
    apex.direction = 1.0
    leave.terminal, leave.direction = True, -1.0
    apexes: list[float] = []
    t, y = 0.0, [-s.height_m, 0.0]
    for k in range(count + 1):
        fly = solve_ivp(rhs, (t, t + 100.0), y, method="Radau", rtol=rtol, atol=1e-15,
                        events=(touch, apex))
        if k:
            apexes.append(-float(fly.y_events[1][-1][0]))
        t, v_in = float(fly.t_events[0][0]), float(fly.y_events[0][0][1])
        if k == count:
            return apexes
        hit = solve_ivp(rhs, (t, t + 1.0), [0.0, v_in], method="Radau", rtol=rtol, atol=1e-15,
                        events=(leave,), first_step=1e-9, max_step=1e-6)
        t, y = float(hit.t_events[0][0]), [0.0, float(hit.y_events[0][0][1])]
    return apexes


def test_an_independent_integration_path_gives_the_same_apexes():
    s = Bounce(height_m=0.2)
    ours = np.array(bounce.solve(s).apex_heights_m[:8])
    other = np.array(_continuous_apexes(s, 8, 1e-10))
    # measured 3.6e-10 (Radau at rtol 1e-10, the whole motion, against exact flights and
    # DOP853 contacts at 1e-12)
    assert np.max(np.abs(other / ours - 1.0)) < 1.1e-9


def test_without_gravity_a_contact_is_the_lambert_w_closed_form():
    s = Bounce(gravity_m_s2=1e-12, max_time_s=1e9)
    integrated = bounce.integrate_contact(s, 1.98)
    closed = bounce.closed_form_contact(s, 1.98)
    assert integrated.integrated and not closed.integrated
    # measured 2.5e-12 (rebound) and 7e-13 (duration)
    assert integrated.rebound_speed_m_s == pytest.approx(closed.rebound_speed_m_s, rel=1e-11)
    assert integrated.duration_s == pytest.approx(closed.duration_s, rel=1e-11)


def test_the_closed_form_switch_errs_by_gravitys_share_of_the_contact():
    """Taking every contact gravity-free (the switch at its widest) shifts the first apex by
    a fraction of g·t_c/V, the share the switch is decided on (measured: 9.4e-5 against a
    share of 4.5e-4, ratio 0.21, from 0.2 m)."""
    s = Bounce(height_m=0.2)
    exact = bounce.solve(s)
    switched = bounce.solve(s, closed_form_below=1.0)
    assert all(not c.integrated for c in switched.contacts)
    assert all(c.integrated for c in exact.contacts)  # the default integrates every one
    share = bounce.gravity_share(s, s.impact_velocity_m_s)
    err = abs(switched.apex_heights_m[0] / exact.apex_heights_m[0] - 1.0)
    assert 0.07 * share < err < 0.63 * share


def test_bounce_count_agrees_with_the_gravity_free_restitution_map():
    """Iterating the closed-form restitution, v_{k+1} = e(v_k)·v_k with exact flights,
    counts the bounces above 1 mm within one of the reference (the map errs by gravity's
    share, ~1e-4 of each apex)."""
    for h in (0.05, 1.0):
        s = Bounce(height_m=h)
        v, count = s.impact_velocity_m_s, 0
        while True:
            v *= float(hunt_crossley.solve_law(s.law(), s.mass_kg, v)["restitution"])
            if v * v / (2.0 * s.gravity_m_s2) <= APEX_COUNT_M:
                break
            count += 1
        assert abs(bounce.solve(s).bounces_above_1mm - count) <= 1


def test_the_sequence_loses_energy_and_ends_below_a_millimetre():
    sol = bounce.solve(Bounce(height_m=0.2))
    apexes = np.array(sol.apex_heights_m)
    assert apexes[0] < 0.2
    assert np.all(np.diff(apexes) < 0.0)
    assert apexes[-1] <= APEX_COUNT_M < apexes[-2]
    m = sol.metrics()
    assert m["bounces_above_1mm"] == apexes.size - 1
    assert m["last_bounce_time_s"] == sol.leave_times_s[-2]
    # flights are exact: the k-th impact comes 2·v_k/g after the k-th leave
    g = 9.80665
    gaps = np.array(sol.impact_times_s[1:]) - np.array(sol.leave_times_s)[:-1]
    assert np.allclose(gaps, 2.0 * np.array(m["rebound_speeds_m_s"][:-1]) / g, rtol=1e-12)


def test_static_sink_is_where_the_spring_carries_the_weight():
    s = Bounce()
    assert s.stiffness * s.static_sink_m ** s.exponent == pytest.approx(s.mass_kg * 9.80665,
                                                                        rel=1e-12)


def test_a_ball_that_cannot_climb_out_of_its_sink_stays_on_the_plate():
    """Dropped from 0.1 µm (below the 0.15 µm static sink) with b = 200 s/m, the ball turns
    back inside the plate: it stays, and never bounces; with b = 10 s/m it bounces 11 times
    first, each apex lower."""
    sol = bounce.solve(Bounce(height_m=1e-7, damping_s_per_m=200.0), floor_m=0.0)
    assert sol.stays and sol.bounces_above_1mm == 0 and not sol.apex_heights_m
    assert sol.contacts[-1].stays and sol.contacts[-1].rebound_speed_m_s == 0.0
    some = bounce.solve(Bounce(height_m=1e-7, damping_s_per_m=10.0), floor_m=0.0)
    assert some.stays and len(some.apex_heights_m) == len(some.contacts) - 1 > 1
    assert np.all(np.diff(some.apex_heights_m) < 0.0)
    assert sol.metrics()["first_apex_m"] == 0.0
    assert math.isnan(sol.metrics()["last_bounce_time_s"])


@pytest.mark.parametrize(("fields", "needle"), [
    ({"height_m": 0.0}, "height_m = 0.0"),
    ({"height_m": math.nan}, "height_m = nan"),
    ({"gravity_m_s2": 0.0}, "gravity_m_s2 = 0.0"),
    ({"max_time_s": 0.1}, "max_time_s = 0.1: must be longer than the fall"),
])
def test_bad_fields_name_the_field(fields, needle):
    with pytest.raises(ValueError, match=needle.replace("(", r"\(")):
        Bounce(**fields)


def test_reference_bounce_json_prints_the_sequence(capsys):
    assert main(["reference", "bounce", "--height", "0.05", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["height_m"] == 0.05
    assert out["apex_heights_m"][0] == out["first_apex_m"] < 0.05
    assert out["bounces_above_1mm"] == sum(a > 1e-3 for a in out["apex_heights_m"])
    assert out["static_sink_m"] == pytest.approx(Bounce().static_sink_m)


@pytest.mark.parametrize("argv", [["--height", "0"], ["--height", "0.2", "--max-time", "0.1"],
                                  ["--height", "x"]])
def test_reference_bounce_bad_input_exits_2_in_one_line(argv, capsys):
    try:
        code = main(["reference", "bounce", *argv])
    except SystemExit as exc:  # (argparse's own errors)
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "error" in err
