"""The MJX advice's snippet, pasted into a plain MJX script, gives the restitution the advice
claims.

``impactbench.advise`` searches MJX's contact settings at its customary 2 ms step (on C MuJoCo,
its twin, then runs the answer in MJX) and prints them as MJCF plus the ``mjx.put_model`` line.
Here that text alone is read (regexes, not ``advice.params``) into a plain MJCF — a plane and
the paper's steel ball (radius and mass of ``BallOnPlate()``) on a slide joint, no gravity,
MuJoCo's frictionless contact (``condim="1"``), MuJoCo's defaults otherwise — moved to JAX with
``mjx.put_model``/``put_data`` and stepped by ``mjx.step`` (jitted once, ``vmap`` over one
world per speed and phase, ``lax.scan`` over steps) with no impactbench code, the ball started
(2 + φ)·V·dt above the plane at −V for each speed V (m/s) and each of the advice's 8 phases φ.
The rebound speed over the impact speed (:mod:`pasted_snippet`) must lie in the advice's
claimed range per speed, and its min, median and max over the phases must be the claimed ones.

JAX computes in 64-bit floats here, as the suite's MJX adapter does (it switches
``jax_enable_x64`` on for the process): the advice's numbers are float64 MJX's.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import require_engine
from pasted_snippet import Run, assert_matches, mjcf, nudged, reading

SPEEDS = (1.0, 3.0)
"""Impact speeds (m/s)."""
TOL = 1e-9
"""e allowed outside what the plain script reads (the minimum: float64 MJX steps the same model
to the bit). Measured (MJX 3.17.0, 2 ms, 1 and 3 m/s, 8 phases, the snippet's 10 significant
digits): 0 outside the plain reading, for the packaged advice
(``solref="-220546.2776 -57.55881061"``) and for the MJX adapter's custom runs below, once the
printed numbers' rounding and the suite's interpolated reading of a long contact are allowed
for (:mod:`pasted_snippet`). Without those allowances the worst |Δe| per speed: the advice
1.8e-10 at 1 m/s and 1.6e-10 at 3 m/s, the 10-digit rounding (as C MuJoCo's); custom
``"0.02 1"`` 5.0e-4 (the interpolation), ``"0.00612345 0.512345"`` 0 (printed exactly) and
``"-246026.1235 -8.720312346"`` 1.7e-10 (the rounding; 1.8e-6 when printed with 6 digits)."""
CAP_S = 1.0
"""Steps after launch before a plain run gives up (s): the suite's own time cap for a
``custom`` MuJoCo/MJX ball (a run still in contact then is ``max_time``, left out)."""
AFTER_STEPS = 3
"""Steps of free flight, moving away, that say the contact is over."""
CHUNK = 64
"""Steps per compiled scan; chunks run until every world's contact is over or the cap."""


@pytest.fixture(scope="module")
def advice():
    """The packaged advice at MJX's customary 2 ms (the file the report shows), its
    rows at 1 and 3 m/s."""
    require_engine("mjx")
    from impactbench.engines.advice_models import ENGINE_STEPS_S

    from impactbench.advice_files import packaged_advice

    return packaged_advice("mjx", ENGINE_STEPS_S["mjx"][0], SPEEDS)


@pytest.fixture(scope="module")
def scan():
    """:func:`compiled_scan`, built once for the module."""
    require_engine("mjx")
    return compiled_scan()


def compiled_scan():
    """(``start``, ``scan``) for a batch of worlds: ``start(mjx_model, data)`` gives the data
    ``put_data`` made the types ``mjx.step`` returns (under x64 its contact indices come back
    64-bit, and a scan's carry must keep its types; traced, not compiled), and
    ``scan(mjx_model, data)``, compiled once, runs ``CHUNK`` ``mjx.step``s, returning the last
    data and each step's qpos and qvel (steps, worlds)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp
    from mujoco import mjx

    step = jax.vmap(mjx.step, in_axes=(None, 0))

    def start(model, data):
        returned = jax.eval_shape(step, model, data)
        return jax.tree.map(lambda x, r: jnp.asarray(x, r.dtype), data, returned)

    @jax.jit
    def run(model, data):
        def body(d, _):
            d = step(model, d)
            return d, (d.qpos[:, 0], d.qvel[:, 0])

        return jax.lax.scan(body, data, None, length=CHUNK)

    return start, run


def _end(pos: np.ndarray, vel: np.ndarray) -> int | None:
    """The step after which a world's contact is over (``AFTER_STEPS`` steps without force,
    apart and moving away, after a first touch), or None: ``pos``/``vel`` its height (m) and
    velocity (m/s) at the start of each step and after the last."""
    pushed = vel[1:] != vel[:-1]  # no gravity: only the contact changes the velocity
    if not pushed.any():
        return None
    free = 0
    for k in range(int(np.argmax(pushed)) + 1, pushed.size):
        free = free + 1 if not pushed[k] and vel[k] > 0.0 and pos[k] > 0.0 else 0
        if free > AFTER_STEPS:
            return k
    return None


def plain_runs(compiled, text: str, worlds: list[tuple[float, float]]) -> list[Run]:
    """The snippet ``text`` in a plain MJX script: one world per (V, phase), the ball
    (2 + phase)·V·dt above the plane at −V (m/s), stepped in chunks (``compiled``:
    :func:`compiled_scan`'s) until every world has flown free and away for a few steps (or
    the cap)."""
    import jax
    import jax.numpy as jnp
    import mujoco
    from impactbench.reference.scenarios import BallOnPlate
    from mujoco import mjx

    ball = BallOnPlate()
    model = mujoco.MjModel.from_xml_string(mjcf(text, ball.radius_m, ball.mass_kg))
    mjx_model = mjx.put_model(model)
    dt = float(model.opt.timestep)
    data = mjx.put_data(model, mujoco.MjData(model))
    qpos = jnp.array([[(2.0 + ph) * v * dt] for v, ph in worlds])
    qvel = jnp.array([[-v] for v, _ in worlds])
    start, scan = compiled
    batch = start(mjx_model, jax.vmap(lambda q, v: data.replace(qpos=q, qvel=v))(qpos, qvel))
    pos, vel = [np.asarray(qpos)[:, 0][None]], [np.asarray(qvel)[:, 0][None]]
    ends: list[int | None] = [None] * len(worlds)
    for _ in range(math.ceil(CAP_S / dt / CHUNK)):
        batch, (q, v) = scan(mjx_model, batch)
        pos.append(np.asarray(q))
        vel.append(np.asarray(v))
        p_all, v_all = np.concatenate(pos), np.concatenate(vel)
        ends = [_end(p_all[:, w], v_all[:, w]) for w in range(len(worlds))]
        if all(e is not None for e in ends):
            break
    out = []
    for w, (v0, _) in enumerate(worlds):
        stop = ends[w] if ends[w] is not None else v_all.shape[0] - 2
        trace = [float(x) for x in v_all[: stop + 2, w]]
        out.append(Run(trace, [a != b for a, b in zip(trace[1:], trace[:-1], strict=True)], v0,
                       diverged=not np.all(np.isfinite(v_all[:, w])),
                       ended=ends[w] is not None))
    return out


def test_the_snippet_is_mjcf_for_mjx_at_the_advised_step(advice) -> None:
    """The snippet sets the advice's step (s, to its 10 printed digits) and a solref, and says
    to move the model to MJX."""
    import re

    from pasted_snippet import half_unit

    dt = float(re.search(r'<option\s[^>]*timestep="([^"]+)"', advice.snippet).group(1))
    assert abs(dt - advice.timestep_s) <= half_unit(dt)
    assert re.search(r'<default>\s*<geom\s[^>]*solref="[^"]+"', advice.snippet)
    assert "mjx.put_model(" in advice.snippet
    assert [r["velocity_m_s"] for r in advice.per_speed] == list(SPEEDS)
    assert len(advice.phases) == 8


def test_the_pasted_snippet_gives_the_claimed_restitution(advice, scan) -> None:
    """Per speed, every phase's plain e (dimensionless) lies in the claimed [min, max] and the
    min, median and max over the phases are the claimed ones, within :data:`TOL`; a phase that
    gains over 1 % of its kinetic energy (the suite's ``diverged``, left out of the claim) does
    so in both."""
    worlds = [(v, ph) for v in SPEEDS for ph in advice.phases]
    texts = [advice.snippet, *nudged(advice.snippet)]
    runs = [plain_runs(scan, t, worlds) for t in texts]
    readings = {w: reading([r[i] for r in runs]) for i, w in enumerate(worlds)}
    assert_matches(advice.per_speed, advice.phases, readings, TOL)
