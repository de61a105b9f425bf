"""The Newton advice, pasted: the snippet :func:`impactbench.advise.advise` prints, read back by
regexes and run in a plain Newton script (no impactbench engine code), restitutes the ball as
the advice claims at every phase of the step.

The plain script is what a user writes: a ``newton.ModelBuilder`` with gravity 0 (the head-on
ball has none), the snippet's ``ShapeConfig(ke, kd)`` (N/m, N·s/m) with zero friction on a
ground plane at z = 0 and on a sphere of the paper's ball (``BallOnPlate``: radius R, its mass
m through the sphere's density, a free body from ``add_body``), Newton's defaults otherwise,
``SolverFeatherstone`` at the snippet's step with Newton's ``CollisionPipeline``. The ball
starts (2 + φ)·V·dt above the plane moving at −V (m/s), so its first touch falls φ of the way
through a step, and is stepped until the contact is over; e = v_out/V (rebound speed over
impact speed, the suite's restitution without gravity).

A phase the suite calls ``diverged`` (kinetic energy up by more than 1 %: semi-implicit Euler
past its stability limit, ω·dt > 2 with ω = √(ke/m)) has no restitution in the advice's
range (``restitution_min``/``_max`` are over the phases that measured); the plain script must
gain the energy at the same speeds instead."""

from __future__ import annotations

import math
import re

import pytest
from conftest import require_engine
from impactbench.engines.advice_models import ENGINE_STEPS_S
from impactbench.reference.scenarios import BallOnPlate
from pasted_snippet import half_unit, measured

from impactbench.advice_files import packaged_advice

ENGINE = "newton"
SPEEDS = (1.0, 3.0)
"""Impact speeds (m/s) the advice is asked for."""
TOL = 2.3e-5
"""|e_plain − e_claimed| allowed (beyond a resolved contact's slack, :data:`RESOLVED_STEPS`):
float32 (warp). Measured (Newton 1.8.0, warp 1.19 on CPU, 1/1200 s, 8 phases, the snippet's 10
significant digits): for the packaged advice (ke = 129.6 N/m, kd = 221.2128961 N·s/m, whose
rebound is the damping overshooting within one step, kd·dt/m = 1.84) |Δe| 0 at 1 and at
3 m/s (bit for bit); against the adapter's custom runs for other ke, kd (N/m, N·s/m) per
phase: 1e5 and 10 1.4e-6 (1 m/s) and 6.4e-7 (3 m/s), 3.3e5 and 50 7.8e-6 and 3.5e-6 (phases
0–2/8 diverged in both), 123456.7891 and 12.34567891 1.6e-6 and 3.2e-7 (5e5 and 200 diverge
at every phase in both). That is float32 dust, not the printed digits: the adapter keeps the
ball's coordinate near 0 (the height of its lowest point); the plain free ball's centre sits at
z ≈ R, where a float32 ulp is 1.9e-9 m against a one-step overlap of 0.2 mm, and its mass
through the density is 0.099999994 kg. TOL is 3× the worst (7.8e-6). Soft contacts resolved
over many steps differ by up to 3.8e-3 (ke = 2345.678 N/m, kd = 1.2345678 N·s/m), all of it the
suite's interpolated separation velocity (the free-flight rebounds agree within 1.8e-7): the
slack covers it."""
LET_GO_STEPS = 3
"""Steps run after the ball has let go (moving away, clear of the plate)."""
MAX_STEPS = 5_000
RESOLVED_STEPS = 8
"""A contact of this many steps or more may be one the suite's metrics resolve in time
(``reference.metrics.MIN_CONTACT_SAMPLES``, 10 force samples; 8 here so a count that differs
by the edge steps errs on the safe side). There the suite's restitution is the velocity
interpolated at the located separation instant, inside the last contact step, not the
free-flight rebound the plain script reads after the contact: the two differ by up to that
step's velocity change, the slack allowed on top of TOL. Shorter contacts have slack 0."""
KNIFE_EDGE_ULPS = 4
"""At phase 0 the ball's lowest point reaches the plane exactly at the end of a step. The
adapter's coordinate (the lowest point's height) lands on 0 there: no overlap, no force in
that step. A free ball's centre lands on R ± a few float32 ulps (1.9e-9 m), and a step that
starts 1 ulp deep gets the whole kd·ẋ damping term of F = ke·x + kd·max(ẋ, 0), a kick of
kd·dt/m·V with next to no ke·x: the outcome of phase 0 is float32 dust (at the packaged
advice, kd·dt/m = 1.84, started without this nudge the ball rebounds from that step with
e = 0.84344 at 1 m/s where the suite's phase 0 gives 0.84448, 1.1e-4 below the claimed min).
The plain ball starts these many ulps higher at phase 0 (≈ 7e-9 m, 3e-6 of a step's travel at
3 m/s), which lands it clear of the plane, the suite's phase 0."""

_NUMBER = r"([-+0-9.eE]+)"


def parse(snippet: str) -> dict[str, float]:
    """The settings of the pasted text: ``ke`` (N/m), ``kd`` (N·s/m), ``dt`` (s). A comment
    line (the remark the snippet adds where kd·dt/m > 1) sets nothing and is skipped; a line no
    regex knows, or a ShapeConfig setting other than ke and kd, fails the test (a snippet that
    grew a setting this plain script would not apply)."""
    out: dict[str, float] = {}
    for line in snippet.splitlines():
        code = line.split("#")[0].strip()
        if not code:  # a comment line: nothing to set
            continue
        if m := re.fullmatch(r"cfg = newton\.ModelBuilder\.ShapeConfig\((.*)\)", code):
            for arg in m.group(1).split(","):
                key, value = (s.strip() for s in arg.split("="))
                assert key in ("ke", "kd"), f"ShapeConfig setting not understood: {arg!r}"
                out[key] = float(value)
        elif m := re.fullmatch(r"solver = newton\.solvers\.SolverFeatherstone\(model\); "
                               r"step dt = " + _NUMBER, code):
            out["dt"] = float(m.group(1))
        else:
            raise AssertionError(f"snippet line not understood: {line!r}")
    assert set(out) == {"ke", "kd", "dt"}, snippet
    return out


def plain_run(cfg: dict[str, float], velocity_m_s: float, phase: float
              ) -> tuple[float, float]:
    """One plain Newton run of the ball at ``velocity_m_s`` (m/s), first touch at ``phase`` of
    the step (``cfg``: :func:`parse`'s settings): (e, slack), slack = the last contact step's
    velocity change over V where the contact spans :data:`RESOLVED_STEPS` steps or more, else 0
    (as test_paste_drake's)."""
    newton = require_engine(ENGINE)
    import numpy as np
    import warp as wp

    wp.config.quiet = True
    sc = BallOnPlate()
    r, m, v, dt = sc.radius_m, sc.mass_kg, velocity_m_s, cfg["dt"]
    z0 = np.float32(r + (2.0 + phase) * v * dt)
    if phase == 0.0:  # the touch on a step's end: clear of float32 dust (KNIFE_EDGE_ULPS)
        for _ in range(KNIFE_EDGE_ULPS):
            z0 = np.nextafter(z0, np.float32(1.0))
    builder = newton.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    contact = {"ke": cfg["ke"], "kd": cfg["kd"], "mu": 0.0}
    builder.add_ground_plane(cfg=newton.ModelBuilder.ShapeConfig(**contact))
    steel = m / (4.0 / 3.0 * math.pi * r**3)  # kg/m³: the sphere carries the ball's mass
    ball = builder.add_body(xform=wp.transform((0.0, 0.0, float(z0)), wp.quat_identity()))
    builder.add_shape_sphere(ball, radius=r,
                             cfg=newton.ModelBuilder.ShapeConfig(density=steel, **contact))
    model = builder.finalize(device="cpu")
    state_0, state_1, control = model.state(), model.state(), model.control()
    qd = state_0.joint_qd.numpy()
    qd[2] = -v  # the free joint's linear velocity, z
    state_0.joint_qd.assign(qd)
    newton.eval_fk(model, state_0.joint_q, state_0.joint_qd, state_0)
    solver = newton.solvers.SolverFeatherstone(model)
    pipeline = newton.CollisionPipeline(model)
    contacts = pipeline.contacts()
    tail, touching, last_kick, vz = None, 0, 0.0, -v
    for _ in range(MAX_STEPS):
        vz_before = vz
        state_0.clear_forces()
        pipeline.collide(state_0, contacts)
        solver.step(state_0, state_1, control, contacts, dt)
        state_0, state_1 = state_1, state_0
        z = float(state_0.body_q.numpy()[ball][2])
        vz = float(state_0.body_qd.numpy()[ball][2])
        if not (math.isfinite(z) and math.isfinite(vz)):
            return math.nan, 0.0
        if vz != vz_before:  # a contact step: nothing else acts on the ball
            touching += 1
            last_kick = abs(vz - vz_before) / v
        if tail is None and vz > 0.0 and z > r:  # moving away and out of contact
            tail = LET_GO_STEPS
        elif tail is not None:
            tail -= 1
            if tail == 0:
                return vz / v, (last_kick if touching >= RESOLVED_STEPS else 0.0)
    return math.nan, 0.0


@pytest.fixture(scope="module")
def advice():
    """The packaged advice at Newton's customary step (1/1200 s, the file the report shows),
    its rows at 1 and 3 m/s."""
    require_engine(ENGINE)
    return packaged_advice(ENGINE, ENGINE_STEPS_S[ENGINE][0], SPEEDS)


@pytest.fixture(scope="module")
def plain(advice) -> dict[float, list[tuple[float, float]]]:
    """Speed → the plain script's (e, slack) at each of the advice's phases."""
    cfg = parse(advice.snippet)
    return {v: [plain_run(cfg, v, ph) for ph in advice.phases] for v in SPEEDS}



def test_the_snippet_is_featherstone_penalty_contact_at_the_step(advice) -> None:
    """The snippet names a positive contact stiffness ke (N/m), a damping kd ≥ 0 (N·s/m)
    and Newton's step (s, to its 10 printed digits), and says so where the explicit damping
    overshoots within one step (kd·dt/m > 1, m the ball's mass in kg)."""
    cfg = parse(advice.snippet)
    assert abs(cfg["dt"] - ENGINE_STEPS_S[ENGINE][0]) <= half_unit(cfg["dt"])
    overshoot = cfg["kd"] * cfg["dt"] / BallOnPlate().mass_kg
    assert (overshoot > 1.0) == ("kd·dt/m" in advice.snippet), (overshoot, advice.snippet)
    assert cfg["ke"] > 0.0
    assert cfg["kd"] >= 0.0
    assert len(advice.phases) == 8


def test_every_phase_restitutes_within_the_claimed_range(advice, plain) -> None:
    """At each speed the plain script's e (dimensionless) lies in the advice's
    [restitution_min, restitution_max] ± (TOL + slack) at every phase the suite measures, and
    a speed the advice calls diverged gains energy in the plain script too (and only then)."""
    for row in advice.per_speed:
        v = row["velocity_m_s"]
        runs = plain[v]
        assert row["status"] in ("ok", "implausible", "diverged"), row
        assert (row["status"] == "diverged") == (len(measured(runs)) < len(runs)), \
            (v, runs, row)
        for phase, (e, slack) in zip(advice.phases, runs, strict=True):
            if (e, slack) in measured(runs):
                tol = TOL + slack
                assert row["restitution_min"] - tol <= e <= row["restitution_max"] + tol, \
                    (v, phase, e, slack, row)


def test_the_phase_extremes_match_the_claimed_ones(advice, plain) -> None:
    """Over the phases, the plain script's smallest and largest e equal the advice's
    restitution_min and restitution_max within TOL (+ the largest slack) at each speed (over
    the phases that measured; where none did the advice's range is NaN, nothing to match)."""
    for row in advice.per_speed:
        runs = measured(plain[row["velocity_m_s"]])
        if not runs:
            assert math.isnan(row["restitution_min"]) and math.isnan(row["restitution_max"])
            continue
        es = [e for e, _ in runs]
        tol = TOL + max(slack for _, slack in runs)
        assert abs(min(es) - row["restitution_min"]) <= tol, (runs, row)
        assert abs(max(es) - row["restitution_max"]) <= tol, (runs, row)
