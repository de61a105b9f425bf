"""MJX: adapter overhead against a bare compiled scan, and batched MJX against ``mujoco.rollout``.

1. Overhead, per shared case (:data:`benchmarks.overhead.CASES`; the injected rigid–flexible
   case is ``unsupported`` in MJX and skipped): the adapter run (model build, device transfer,
   fixed-length scans, host copies, end search, record) against one jitted ``lax.scan`` of
   ``mjx.step`` over as many steps as the adapter's record holds, on the same model and state,
   returning only the final state. Compilation is excluded (a warm-up call of each first).
2. Batch: W ball worlds with W different direct solrefs for N steps — MJX ``vmap`` of one scan
   (:func:`impactbench.engines.mjx_adapter.ball_batch`) against ``mujoco.rollout`` with one
   model per world on 1 and 2 threads. Both print world-steps per second; the ratio is
   rollout (2 threads) over MJX.
3. Generation: a tuner's generation through the adapter — 8 tuned solrefs × the ball at
   three velocities — as :meth:`Adapter.run_many` (one ``vmap`` over the worlds,
   :func:`impactbench.engines.mjx_adapter.run_ball_batch`) against one :meth:`Adapter.run`
   after another (:mod:`benchmarks.generation`; the records checked equal bit for bit).

Every comparison runs its sides alternately (A B A B …) and reports medians
(:mod:`benchmarks.alternate`): the machine is shared, and a best-of rewards the luckiest run.

Run: ``python -m benchmarks bench_engine_mjx``.
"""

from __future__ import annotations

import statistics
from typing import Any

import numpy as np
from impactbench.engines.mjx_adapter import _batched_scan, _mjx, ball_batch
from impactbench.engines.mujoco_adapter import ball_mjcf, measured_diag_a, rigid_flexible_mjcf
from impactbench.reference.scenarios import BallOnPlate

from benchmarks.alternate import alternate, median_pair
from benchmarks.overhead import rerun, table_head, warmed_up

REPEATS = 5
WORLDS = 64
BATCH_STEPS = 256


def _bare_scan() -> Any:
    _, jax, mjx = _mjx()

    def run(mx: Any, dx: Any, length: int) -> Any:
        return jax.lax.scan(lambda d, _: (mjx.step(mx, d), None), dx, None, length=length)[0]

    return jax.jit(run, static_argnames=("length",))


def bare_setup(scenario: Any, dt: float, solref: list[float] | None) -> tuple[Any, Any]:
    """(mx, dx): the adapter's model and initial state on the device."""
    mujoco, _, mjx = _mjx()
    ball = isinstance(scenario, BallOnPlate)
    xml = ball_mjcf(scenario, dt) if ball else rigid_flexible_mjcf(scenario, dt)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    if solref is not None:
        model.geom_solref[:] = solref
    v = scenario.velocity_m_s
    if ball:
        data.qpos[0], data.qvel[0] = 2.5 * v * dt, -v
    else:
        data.qpos[:], data.qvel[:] = (-2.5 * v * dt, 0.0), (v, 0.0)
    mx = mjx.put_model(model)
    return mx, _mjx()[1].jit(mjx.forward)(mx, mjx.put_data(model, data))


def overhead() -> None:
    adapter = table_head("mjx", "MJX", "bare jitted scan", REPEATS,
                         f"{'case':36s} {'steps':>7s} {'stepped':>7s} {'adapter ms':>10s} "
                         f"{'bare ms':>8s} {'ratio':>6s}")
    _, jax, _ = _mjx()
    scan = _bare_scan()
    # the warm-up compiles the adapter's scans
    for label, scenario, mode, dt, settings, rec in warmed_up(adapter):
        if rec.status == "unsupported":
            print(f"{label:36s} unsupported: {rec.message}")
            continue
        steps = len(rec)
        mx, dx = bare_setup(scenario, dt, rec.meta.get("solref"))
        jax.block_until_ready(scan(mx, dx, steps))  # warm-up (compiles this length)
        t_adapter, t_bare = median_pair(
            rerun(adapter, scenario, mode, settings),
            lambda a=mx, b=dx, n=steps: jax.block_until_ready(scan(a, b, n)), REPEATS)
        print(f"{label:36s} {steps:7d} {rec.meta['steps']:7d} {t_adapter * 1e3:10.1f} "
              f"{t_bare * 1e3:8.1f} {t_adapter / t_bare:6.2f} [{rec.status}]")


def rollout_setup(scenario: BallOnPlate, solrefs: np.ndarray, dt: float,
                  nthread: int) -> Any:
    """C MuJoCo: one model per world (its own solref); returns a call of ``mujoco.rollout``
    on ``nthread`` threads (one MjData each)."""
    mujoco, _, _ = _mjx()
    import mujoco.rollout as rollout

    models = []
    for ref in solrefs:
        m = mujoco.MjModel.from_xml_string(ball_mjcf(scenario, dt))
        m.geom_solref[:] = ref
        models.append(m)
    datas = [mujoco.MjData(models[0]) for _ in range(nthread)]
    d = datas[0]
    d.qpos[0], d.qvel[0] = 2.5 * scenario.velocity_m_s * dt, -scenario.velocity_m_s
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    s0 = np.empty(mujoco.mj_stateSize(models[0], spec))
    mujoco.mj_getState(models[0], d, s0, spec)
    states = np.tile(s0, (len(models), 1))
    return lambda: rollout.rollout(models, datas, states, nstep=BATCH_STEPS)


def batch() -> None:
    mujoco, jax, _ = _mjx()
    scenario, dt = BallOnPlate(velocity_m_s=1.0), 1e-6
    model = mujoco.MjModel.from_xml_string(ball_mjcf(scenario, dt))
    a = measured_diag_a(model, mujoco.MjData(model), (-1e-9,))
    stiffness = np.geomspace(3e7, 3e8, WORLDS)
    solrefs = np.column_stack([-stiffness * a, np.full(WORLDS, -316.2 * a)])
    _, rate, _ = ball_batch(scenario, solrefs, dt, BATCH_STEPS)  # warm-up (compiles)
    mx, dx = bare_setup(scenario, dt, None)
    refs = jax.numpy.asarray(solrefs)
    vmapped = _batched_scan()
    runs = alternate({
        "mjx vmap": lambda: jax.block_until_ready(vmapped(mx, dx, refs, BATCH_STEPS)),
        "rollout 1 thread": rollout_setup(scenario, solrefs, dt, 1),
        "rollout 2 threads": rollout_setup(scenario, solrefs, dt, 2),
    }, REPEATS)
    times = {name: statistics.median(t) for name, t in runs.items()}
    e = rate[:, -1] / scenario.velocity_m_s
    print(f"\nBatch: {WORLDS} ball worlds (K = 3e7…3e8 N/m, e = {e[0]:.3f}…{e[-1]:.3f}) × "
          f"{BATCH_STEPS} steps (alternated, median of {REPEATS}, models built beforehand)")
    for name, t in times.items():
        print(f"{name:20s} {t * 1e3:9.1f} ms {WORLDS * BATCH_STEPS / t:12.0f} world-steps/s")
    ratio = times["rollout 2 threads"] / times["mjx vmap"]
    print(f"ratio rollout(2 threads)/mjx time: {ratio:.2f}")


def generation() -> None:
    from benchmarks.generation import generation as run

    run("mjx", [{"solref": [-float(k), -30.0]} for k in np.geomspace(3e5, 3e7, 8)], REPEATS)


def main() -> None:
    overhead()
    batch()
    generation()


if __name__ == "__main__":
    main()
