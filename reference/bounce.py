"""Reference of the bounce to rest: a Hunt–Crossley ball dropped on a massive plate under gravity.

Physics (MODELS.md §1 with gravity kept): the ball falls from rest at height h, hits the plate at
V₁ = √(2gh), and in contact obeys m·ẍ = m·g − c·xⁿ·(1 + b·ẋ) (x ≥ 0 the overlap, ẋ its rate;
the force never pulls). It leaves the plate when x returns to 0, flies ballistically — the
flight is exact: it rises to the apex h_k = v_k²/(2g) and comes back at the speed it left with
after 2·v_k/g — and hits again. Hunt–Crossley's loss 1 − e ≈ (2/3)·... grows with the impact
speed, so the bounces decay slowly (v_{k+1} ≈ v_k·(1 − α·v_k): about a hundred bounces above
1 mm from 0.2 m for the paper's ball, over ≈ 8 s). The ball stays on the plate once a contact
no longer brings it back to x = 0: it then oscillates about the static sink
x_s = (m·g/c)^(1/n), where c·xⁿ = m·g.

Contacts are integrated with gravity (DOP853 in variables scaled by the elastic indentation X
and X/V, relative tolerance ``rtol``), because gravity's share of a contact's rebound,
≈ g·t_c/V, is 2e-4 at 4.4 m/s and 1e-2 at 0.14 m/s for the paper's ball: never negligible at
the 1e-6 the apexes converge to. Where it is — g·t_c/V below ``closed_form_below`` (default
1e-9: a far stiffer or faster contact) — the contact takes the gravity-free Lambert-W closed
form (:mod:`impactbench.reference.hunt_crossley`): the switch's error is that share (tested
against the integration). The sequence is followed until an apex falls below ``floor_m``
(default 1 mm, so every bounce above 1 mm is in it and the first one below) or the ball stays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from impactbench.reference.bounce_scenario import APEX_COUNT_M, Bounce
from scipy.integrate import solve_ivp

RTOL = 1e-12
"""Relative tolerance of each contact's integration (the apexes converge to ~1e-10)."""
CLOSED_FORM_BELOW = 1e-9
"""Contacts whose gravity share g·t_c/V is below this take the gravity-free closed form."""
MAX_BOUNCES = 100_000
"""A guard on the sequence's length (a ball with b = 0 never stops bouncing)."""
ELASTIC_DURATION = 2.943631
"""The elastic Hertz contact's duration in units of X/V (X the elastic indentation,
(n+1)·m·V²/(2c))^(1/(n+1)), n = 1.5), for the gravity share g·t_c/V."""


@dataclass(frozen=True)
class Contact:
    """One contact: impact and rebound speeds (m/s; rebound 0 when the ball stays), its
    duration (s; until the ball stays, when it does) and whether the ball stayed on the
    plate; ``integrated``: by integration (False: the closed form)."""

    impact_speed_m_s: float
    rebound_speed_m_s: float
    duration_s: float
    stays: bool
    integrated: bool


@dataclass(frozen=True)
class BounceSolution:
    """The bounce sequence, first impact first (SI): ``apex_heights_m[k]`` is the apex after
    contact k, ``leave_times_s[k]`` when the ball left the plate after contact k."""

    impact_times_s: list[float] = field(default_factory=list)
    contacts: list[Contact] = field(default_factory=list)
    apex_heights_m: list[float] = field(default_factory=list)
    leave_times_s: list[float] = field(default_factory=list)
    stays: bool = False
    static_sink_m: float = math.nan

    @property
    def bounces_above_1mm(self) -> int:
        return int(sum(a > APEX_COUNT_M for a in self.apex_heights_m))

    @property
    def last_bounce_time_s(self) -> float:
        """When the last bounce above 1 mm left the plate (s; NaN when none did)."""
        above = [t for a, t in zip(self.apex_heights_m, self.leave_times_s, strict=False)
                 if a > APEX_COUNT_M]
        return above[-1] if above else math.nan

    def metrics(self) -> dict[str, Any]:
        """The ``reference bounce --json`` object: the scalar metrics of results rows
        (first_apex_m, bounces_above_1mm, last_bounce_time_s, rest_sink_m, rest_jitter_m_s)
        and the sequences (apex_heights_m, impact_speeds_m_s, rebound_speeds_m_s,
        contact_durations_s, impact_times_s), plus static_sink_m."""
        c = self.contacts
        return {
            "first_apex_m": self.apex_heights_m[0] if self.apex_heights_m else 0.0,
            "bounces_above_1mm": self.bounces_above_1mm,
            "last_bounce_time_s": self.last_bounce_time_s,
            "rest_sink_m": self.static_sink_m,
            "rest_jitter_m_s": 0.0,
            "static_sink_m": self.static_sink_m,
            "apex_heights_m": list(self.apex_heights_m),
            "impact_speeds_m_s": [k.impact_speed_m_s for k in c],
            "rebound_speeds_m_s": [k.rebound_speed_m_s for k in c],
            "contact_durations_s": [k.duration_s for k in c],
            "impact_times_s": list(self.impact_times_s),
        }


def _elastic_indentation(s: Bounce, v: float) -> float:
    """X = ((n+1)·m·V²/(2c))^(1/(n+1)) (m): the gravity-free elastic contact's deepest
    overlap, the length scale of the integration."""
    n = s.exponent
    return ((n + 1.0) * s.mass_kg * v * v / (2.0 * s.stiffness)) ** (1.0 / (n + 1.0))


def gravity_share(s: Bounce, v: float) -> float:
    """g·t_c/V: gravity's impulse over a contact at impact speed V relative to the ball's
    momentum (t_c the elastic Hertz duration) — the relative error of ignoring it."""
    return s.gravity_m_s2 * ELASTIC_DURATION * _elastic_indentation(s, v) / (v * v)


def integrate_contact(s: Bounce, v: float, rtol: float = RTOL) -> Contact:
    """The contact at impact speed ``v`` (m/s) with gravity, integrated.

    Scaled by X (:func:`_elastic_indentation`) and T = X/V, u = x/X and w = ẋ/V obey
    u' = w, w' = G − K·max(u, 0)ⁿ·max(1 + β·w, 0) with G = g·T/V, K = (n+1)/2, β = b·V.
    It ends when u returns to 0 (the ball leaves) or w turns positive again inside the
    plate (the ball stays: it will oscillate about the static sink, never leaving)."""
    n = s.exponent
    x_scale = _elastic_indentation(s, v)
    t_scale = x_scale / v
    g_term = s.gravity_m_s2 * t_scale / v
    k_term = 0.5 * (n + 1.0)
    beta = s.damping_s_per_m * v

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        u, w = y
        push = k_term * max(u, 0.0) ** n * max(1.0 + beta * w, 0.0)
        return [w, g_term - push]

    def leaves(_t: float, y: np.ndarray) -> float:
        return y[0]

    def stays(_t: float, y: np.ndarray) -> float:
        return y[1]

    leaves.terminal, leaves.direction = True, -1.0  # type: ignore[attr-defined]
    stays.terminal, stays.direction = True, 1.0  # type: ignore[attr-defined]
    sol = solve_ivp(rhs, (0.0, 1e6), [0.0, 1.0], method="DOP853", rtol=rtol,
                    atol=rtol * 1e-2, events=(leaves, stays))
    if sol.t_events[0].size:
        w_out = float(sol.y_events[0][0][1])
        return Contact(v, -w_out * v, float(sol.t_events[0][0]) * t_scale, False, True)
    end = float(sol.t_events[1][0]) if sol.t_events[1].size else float(sol.t[-1])
    return Contact(v, 0.0, end * t_scale, True, True)


def closed_form_contact(s: Bounce, v: float) -> Contact:
    """The gravity-free contact at impact speed ``v`` (the Lambert-W closed form)."""
    from impactbench.reference import hunt_crossley

    out = hunt_crossley.solve_law(s.law(), s.mass_kg, v)
    return Contact(v, float(out["restitution"]) * v, float(out["duration_s"]), False, False)


def solve(s: Bounce, *, rtol: float = RTOL, closed_form_below: float = CLOSED_FORM_BELOW,
          floor_m: float = APEX_COUNT_M) -> BounceSolution:
    """The bounce sequence of ``s`` until an apex falls below ``floor_m`` (m) or the ball
    stays on the plate (see the module)."""
    g = s.gravity_m_s2
    v = s.impact_velocity_m_s
    t = s.fall_time_s
    out = BounceSolution(static_sink_m=s.static_sink_m)
    for _ in range(MAX_BOUNCES):
        c = (closed_form_contact(s, v) if gravity_share(s, v) < closed_form_below
             else integrate_contact(s, v, rtol))
        out.impact_times_s.append(t)
        out.contacts.append(c)
        t += c.duration_s
        if c.stays or c.rebound_speed_m_s <= 0.0:
            return _stayed(out)
        apex = c.rebound_speed_m_s**2 / (2.0 * g)
        out.apex_heights_m.append(apex)
        out.leave_times_s.append(t)
        if apex < floor_m:
            return out
        v = c.rebound_speed_m_s  # the exact flight brings it back at the speed it left
        t += 2.0 * v / g
    return out


def _stayed(out: BounceSolution) -> BounceSolution:
    return BounceSolution(out.impact_times_s, out.contacts, out.apex_heights_m,
                          out.leave_times_s, True, out.static_sink_m)


def metrics(s: Bounce, **options: Any) -> dict[str, Any]:
    """:func:`solve`'s ``reference bounce --json`` object."""
    return solve(s, **options).metrics()
