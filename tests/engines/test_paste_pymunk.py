"""The pymunk advice, pasted: the snippet :func:`impactbench.advise.advise` prints, read back by
regexes and run in a plain pymunk script (no impactbench engine code), restitutes the ball
as the advice claims at every phase of the step.

The plain script is what a user writes: a ``pymunk.Space()`` (gravity 0, the head-on ball has
none), a circle body of the paper's ball (``BallOnPlate``: radius R, mass m) over a static box
whose top face is y = 0, zero friction, pymunk's defaults otherwise plus exactly what the
snippet sets (the step, the shapes' elasticities, ``collision_slop`` where given). The ball
starts (2 + φ)·V·dt above the plate moving at −V (m/s), so its first touch falls φ of the way
through a step, and is stepped until the contact is over; e = v_out/V (rebound speed over
impact speed, the suite's restitution without gravity)."""

from __future__ import annotations

import math
import re

import pytest
from conftest import require_engine
from impactbench.engines.advice_models import ENGINE_STEPS_S
from impactbench.reference.scenarios import BallOnPlate
from pasted_snippet import half_unit, measured

from impactbench.advice_files import packaged_advice

ENGINE = "pymunk"
SPEEDS = (1.0, 3.0)
"""Impact speeds (m/s) the advice is asked for."""
TOL = 1e-9
"""|e_plain − e_claimed| allowed (the minimum). Measured (pymunk 7.3.1, 1/60 s, 1 and 3 m/s, 8
phases): the plain e is the printed elasticity to round-off at every phase (Chipmunk's
velocity-level restitution, vₙ⁺ = −e·vₙ⁻), so the worst |Δe| over the phases is the snippet's
10 significant digits: 4.7e-11 at 1 and at 3 m/s for the packaged advice (0.8435629743474341,
printed 0.8435629743); against the adapter's custom runs 1.7e-11 for 0.8819692566826514 and
0.882683502116901, 1.2e-11 for 0.8123456789123, ≤ 3.3e-16 where the print is exact (0.5,
0.7000005, 0.8123455, 0.9, 0.9345675, 0.9876545). That rounding is at most 5e-11 for any e in
[0.1, 1); 3× it is below the 1e-9 floor. Printed with 6 digits it was up to 5e-7."""
LET_GO_STEPS = 3
"""Steps run after the ball has let go (moving away, clear of the plate)."""
MAX_STEPS = 10_000


def parse(snippet: str) -> dict[str, float]:
    """The settings of the pasted text: ``dt`` (s), ``ball_e``, ``plate_e`` and, where the
    snippet sets it, ``collision_slop`` (m). A line no regex knows fails the test (a snippet
    that grew a setting this plain script would not apply)."""
    patterns = {
        "dt": r"space\.step\(([^)]+)\)",
        "collision_slop": r"space\.collision_slop = (\S+)",
        "ball_e": r"ball_shape\.elasticity = (\S+)",
        "plate_e": r"plate_shape\.elasticity = (\S+)",
    }
    out: dict[str, float] = {}
    for line in snippet.splitlines():
        hits = [(key, m) for key, pat in patterns.items() if (m := re.match(pat, line))]
        assert len(hits) == 1, f"snippet line not understood: {line!r}"
        key, m = hits[0]
        out[key] = float(m.group(1))
    assert {"dt", "ball_e", "plate_e"} <= set(out), snippet
    return out


def plain_restitution(cfg: dict[str, float], velocity_m_s: float, phase: float) -> float:
    """e of one plain pymunk run of the ball at ``velocity_m_s`` (m/s), first touch at
    ``phase`` of the step (``cfg``: :func:`parse`'s settings)."""
    pymunk = require_engine(ENGINE)
    sc = BallOnPlate()
    r, m, dt, v = sc.radius_m, sc.mass_kg, cfg["dt"], velocity_m_s
    space = pymunk.Space()  # gravity (0, 0)
    if "collision_slop" in cfg:
        space.collision_slop = cfg["collision_slop"]
    body = pymunk.Body(m, pymunk.moment_for_circle(m, 0.0, r))
    body.position = (0.0, r + (2.0 + phase) * v * dt)
    body.velocity = (0.0, -v)
    ball_shape = pymunk.Circle(body, r)
    plate_shape = pymunk.Poly(space.static_body, [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.0),
                                                  (-0.5, 0.0)])  # a 1 m box, top face y = 0
    ball_shape.friction = plate_shape.friction = 0.0
    ball_shape.elasticity, plate_shape.elasticity = cfg["ball_e"], cfg["plate_e"]
    space.add(body, ball_shape, plate_shape)
    tail = None
    for _ in range(MAX_STEPS):
        space.step(dt)
        y, vy = body.position.y, body.velocity.y
        if tail is None and vy > 0.0 and y > r:  # moving away and out of contact
            tail = LET_GO_STEPS
        elif tail is not None:
            tail -= 1
            if tail == 0:
                return vy / v
    return math.nan


@pytest.fixture(scope="module")
def advice():
    """The packaged advice at pymunk's customary step (1/60 s, the file the report shows), its
    rows at 1 and 3 m/s."""
    require_engine(ENGINE)
    return packaged_advice(ENGINE, ENGINE_STEPS_S[ENGINE][0], SPEEDS)


@pytest.fixture(scope="module")
def plain(advice) -> dict[float, list[float]]:
    """Speed → the plain script's e at each of the advice's phases."""
    cfg = parse(advice.snippet)
    return {v: [plain_restitution(cfg, v, ph) for ph in advice.phases] for v in SPEEDS}



def test_the_snippet_is_the_step_and_the_pair_elasticity(advice) -> None:
    """The snippet names pymunk's step (s, to its 10 printed digits) and a pair restitution
    e ∈ [0, 1] (the product of the two elasticities, plate 1)."""
    cfg = parse(advice.snippet)
    assert abs(cfg["dt"] - ENGINE_STEPS_S[ENGINE][0]) <= half_unit(cfg["dt"])
    assert cfg["plate_e"] == 1.0
    assert 0.0 <= cfg["ball_e"] <= 1.0
    assert len(advice.phases) == 8


def test_every_phase_restitutes_within_the_claimed_range(advice, plain) -> None:
    """At each speed the plain script's e (dimensionless) lies in the advice's
    [restitution_min, restitution_max] ± TOL at every phase the suite measures, and a speed
    the advice calls diverged gains energy in the plain script too (and only then)."""
    for row in advice.per_speed:
        v = row["velocity_m_s"]
        es = plain[v]
        assert row["status"] in ("ok", "implausible", "diverged"), row
        assert (row["status"] == "diverged") == (len(measured(es)) < len(es)), (v, es, row)
        for phase, e in zip(advice.phases, es, strict=True):
            if e in measured(es):
                assert row["restitution_min"] - TOL <= e <= row["restitution_max"] + TOL, \
                    (v, phase, e, row)


def test_the_phase_extremes_match_the_claimed_ones(advice, plain) -> None:
    """Over the phases, the plain script's smallest and largest e equal the advice's
    restitution_min and restitution_max within TOL at each speed."""
    for row in advice.per_speed:
        es = measured(plain[row["velocity_m_s"]])
        assert es, row
        assert abs(min(es) - row["restitution_min"]) <= TOL, (es, row)
        assert abs(max(es) - row["restitution_max"]) <= TOL, (es, row)
