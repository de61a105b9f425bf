"""Newton adapter: per-step cost before and after device-side stepping, against MuJoCo; and
the adapter's overhead over a bare Featherstone loop.

1. Before / after / MuJoCo. For each shared case (:data:`benchmarks.overhead.CASES`) three
   sides run the same scenario, mode and timestep, alternating (before, after, MuJoCo) in
   every repeat, and the medians are printed:

   - before: the adapter as it was with Python-loop stepping (20-odd warp launches from Python
     and three ``.numpy().tolist()`` copies per step), loaded from git at
     :data:`BEFORE_COMMIT` or from the file named by ``$IMPACTBENCH_NEWTON_BEFORE`` (e.g.
     ``git show 9d3db3b:engines/newton_adapter.py > /tmp/newton_old.py``); where neither
     loads, the current adapter's step-by-step reference path (``graphs=False``: the same
     kernels launched eagerly, the record still on the device), and the header says so;
   - after: the current adapter (one warp CPU-graph launch per step, the record written on
     the device and copied to numpy once per chunk);
   - MuJoCo: its adapter on the same case (C++ rollout, or its Python loop where the mode
     needs one).

   ``µs/step`` is the stepping phase (the adapter's ``drive``: stepping, recording, the end
   search) over the steps run; ``setup ms`` is the rest of the run (model build, Newton's
   collision pipeline and its kernels, graph capture, the record). Kernel compilation is
   excluded (a warm-up run of each side first). The ratios: before/after and after/MuJoCo
   (target ≤ 5).

3. Generation (printed last): a tuner's generation, 8 tuned (ke, kd) × the ball at three
   velocities, as :meth:`Adapter.run_many` (one model, a world per run,
   :func:`impactbench.engines.newton_adapter.run_ball_batch`) against one :meth:`Adapter.run`
   after another (:mod:`benchmarks.generation`).

2. Overhead: the adapter's stepping (its ``drive``, per step) against a bare loop over the
   same model and initial state by the same per-step path (the two captured graphs of
   collide + ``SolverFeatherstone.step``, replayed as many times as the adapter ran steps),
   reading and recording nothing; the set-up times (model, collision pipeline, capture) of
   both beside.

4. The report's runs (printed first; ``--report`` alone, ``--rounds N``): for each scenario
   the default report's Newton runs (:func:`report_items`: every job of the default config's
   plan, a phased job once per phase) through one :func:`impactbench.evaluate.compare_many`
   (each scenario's batch: a world per run) against :func:`impactbench.evaluate.compare`
   one after another, alternated, medians and the median per-round ratio; the objects are
   checked equal first (NaN = NaN: failed runs' metrics). Then the same runs through
   ``Adapter.run_many`` of the adapter before these batches (git
   :data:`BATCHES_BEFORE_COMMIT`: the ball's batch only) against now.

5. Cold start (``--cold`` alone): for each scenario a fresh process with warp's kernel cache
   empty (a temporary ``WARP_CACHE_PATH`` of its own), then another with it filled: the
   import and the scenario's first native run (its default step).

Run: ``python -m benchmarks bench_engine_newton`` (``... --report``, ``... --cold``).
"""

from __future__ import annotations

import atexit
import dataclasses
import functools
import importlib.util
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from impactbench.engines import mujoco_adapter
from impactbench.engines import newton_adapter as after_module
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.common import NATIVE_REFERENCE_VELOCITY_M_S
from impactbench.engines.newton_adapter import (
    CONTACT_CAPACITY,
    NARROW_PHASE_THREADS,
    _capture,
    _newton,
    ball_model,
    contact_parameters,
    native_ball,
    rigid_flexible_model,
)
from impactbench.reference.scenarios import BallOnPlate

from benchmarks.alternate import alternate, median_ratio
from benchmarks.overhead import CASES

REPEATS = 5  # the before side runs ~10³ steps/s: five repeats of every case take minutes
BEFORE_COMMIT = "9d3db3bbdfb9a8189d77bf3c6b465f27b2c62e1e"
"""The last commit whose Newton adapter stepped in a Python loop."""
BEFORE_ENV = "IMPACTBENCH_NEWTON_BEFORE"

Runner = Callable[[Any, str, RunSettings], Any]


# --------------------------------------------------------------------------- the sides


def _load_before(commit: str = BEFORE_COMMIT, env: str | None = BEFORE_ENV
                 ) -> tuple[ModuleType | None, str]:
    """The adapter module as it was at ``commit`` (or in the file ``$env`` names) and where
    it came from (None: not loadable)."""
    path = os.environ.get(env) if env else None
    source = f"${env} = {path}"
    try:
        if not path:
            repo = Path(__file__).resolve().parent.parent
            text = subprocess.run(
                ["git", "show", f"{commit}:engines/newton_adapter.py"], cwd=repo,
                capture_output=True, text=True, check=True).stdout
            handle = tempfile.NamedTemporaryFile("w", suffix="_newton_before.py", delete=False)
            with handle:
                handle.write(text)
            path, source = handle.name, f"git {commit[:7]}"
        spec = importlib.util.spec_from_file_location(f"impactbench_newton_{commit[:7]}", path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module  # dataclasses look their module up
        if source.startswith("git"):  # warp reads a kernel's source when it is defined
            atexit.register(Path(path).unlink, missing_ok=True)
        spec.loader.exec_module(module)
        module.NewtonAdapter().version()
    except Exception as exc:
        return None, f"not loadable ({type(exc).__name__}: {exc})"
    return module, source


class _Timed:
    """A side: runs a scenario, timing the whole run and its ``drive`` (the stepping)."""

    def __init__(self, run: Runner, modules: tuple[ModuleType, ...]) -> None:
        self.run, self.drive_s = run, 0.0
        for module in modules:
            inner = module.drive

            @functools.wraps(inner)
            def timed(*args: Any, _inner: Any = inner, **kwargs: Any) -> Any:
                t0 = time.perf_counter()
                try:
                    return _inner(*args, **kwargs)
                finally:
                    self.drive_s += time.perf_counter() - t0

            module.drive = timed

    def __call__(self, scenario: Any, mode: str, settings: RunSettings) -> tuple[float, float,
                                                                                  Any]:
        """(wall s, drive s, record) of one run."""
        self.drive_s = 0.0
        t0 = time.perf_counter()
        rec = self.run(scenario, mode, settings)
        return time.perf_counter() - t0, self.drive_s, rec


def _eager(scenario: Any, mode: str, settings: RunSettings) -> Any:
    run = (after_module.run_ball if isinstance(scenario, BallOnPlate)
           else after_module.run_rigid_flexible)
    return run(scenario, mode, settings, graphs=False)


def sides() -> tuple[dict[str, _Timed], str]:
    """The three timed sides and a line saying what 'before' is."""
    before, source = _load_before()
    if before is not None:
        old = before.NewtonAdapter()
        before_side = _Timed(old.run, (before,))
        what = f"before = Python-loop adapter ({source})"
    else:
        before_side = _Timed(_eager, (after_module,))
        what = f"before = step-by-step reference path (graphs=False); old adapter {source}"
    sides = {"before": before_side,
             "after": _Timed(get_adapter("newton").run, (after_module,)),
             "mujoco": _Timed(get_adapter("mujoco").run, (mujoco_adapter,))}
    return sides, what


def compare(repeats: int = REPEATS) -> list[dict[str, Any]]:
    """One row per case: medians of wall and stepping time per side, alternating sides."""
    timed, what = sides()
    print(what)
    rows = []
    for label, scenario, mode, dt in CASES:
        settings = RunSettings(timestep_s=dt)
        steps, statuses = {}, {}
        for name, side in timed.items():  # warm-up: kernels load or compile
            _, _, rec = side(scenario, mode, settings)
            steps[name], statuses[name] = int(rec.meta["steps"]), str(rec.status)
        walls: dict[str, list[float]] = {name: [] for name in timed}
        drives: dict[str, list[float]] = {name: [] for name in timed}
        for _ in range(repeats):
            for name, side in timed.items():
                wall, drive, _ = side(scenario, mode, settings)
                walls[name].append(wall)
                drives[name].append(drive)
        row: dict[str, Any] = {"case": label, "steps": steps["after"]}
        per_step = {}
        for name in timed:
            per_step[name] = 1e6 * statistics.median(drives[name]) / steps[name]
            row[f"{name} µs/step"] = per_step[name]
        row["before/after"] = per_step["before"] / per_step["after"]
        row["after/mujoco"] = per_step["after"] / per_step["mujoco"]
        for name in timed:
            row[f"{name} wall ms"] = 1e3 * statistics.median(walls[name])
        row["after setup ms"] = 1e3 * statistics.median(
            w - d for w, d in zip(walls["after"], drives["after"], strict=True))
        row["status"] = "/".join(dict.fromkeys(statuses.values()))
        if steps["before"] != steps["after"]:
            row["status"] += f" (before {steps['before']} steps)"
        rows.append(row)
    return rows


# --------------------------------------------------------------------------- overhead


def bare_stepper(scenario: Any, mode: str, dt: float) -> Callable[[int], None]:
    """The same model and initial state, set up for the adapter's per-step path (one captured
    graph launch per step, collide + Featherstone step) recording nothing; returns the loop."""
    wp, newton = _newton()
    ball = isinstance(scenario, BallOnPlate)
    values = {"ke": 0.0, "kd": 0.0, "kf": 0.0, "mu": 0.0}  # injected: ke is set per step
    if mode != "injected":
        native = native_ball(scenario.replace(
            velocity_m_s=NATIVE_REFERENCE_VELOCITY_M_S)) if ball else None
        values, _ = contact_parameters(
            mode, RunSettings(), (native.stiffness_n_per_m, native.damping_ns_per_m) if ball
            else (scenario.k1_n_per_m, 0.0))
    v0, gap = scenario.velocity_m_s, 2.5 * scenario.velocity_m_s * dt
    model = ball_model(scenario, values) if ball else rigid_flexible_model(scenario, values)
    s0, s1, control = model.state(), model.state(), model.control()
    s0.joint_q.assign(np.array([gap] if ball else [-gap, 0.0], dtype=np.float32))
    s0.joint_qd.assign(np.array([-v0] if ball else [v0, 0.0], dtype=np.float32))
    newton.eval_fk(model, s0.joint_q, s0.joint_qd, s0)
    solver = newton.solvers.SolverFeatherstone(model)
    pipeline = newton.CollisionPipeline(model, rigid_contact_max=CONTACT_CAPACITY)
    pipeline.narrow_phase.total_num_threads = NARROW_PHASE_THREADS
    contacts = pipeline.contacts()

    def advance(a: Any, b: Any) -> None:
        a.clear_forces()
        pipeline.collide(a, contacts)
        solver.step(a, b, control, contacts, dt)

    graphs = (_capture(wp, lambda: advance(s0, s1)), _capture(wp, lambda: advance(s1, s0)))
    launch = wp.capture_launch

    def loop(steps: int) -> None:
        for i in range(steps):
            launch(graphs[i & 1])

    return loop


def overhead(repeats: int = REPEATS) -> list[dict[str, Any]]:
    """One row per case: the adapter's stepping (its ``drive``) against the bare loop, both
    per step, medians over alternating repeats; and their set-up times."""
    adapter = _Timed(get_adapter("newton").run, (after_module,))
    rows = []
    for label, scenario, mode, dt in CASES:
        settings = RunSettings(timestep_s=dt)
        _, _, rec = adapter(scenario, mode, settings)  # warm-up
        steps = int(rec.meta["steps"])
        drive, bare, setup, bare_setup = [], [], [], []
        for _ in range(repeats):
            wall, d, _ = adapter(scenario, mode, settings)
            t0 = time.perf_counter()
            loop = bare_stepper(scenario, mode, dt)
            t1 = time.perf_counter()
            loop(steps)
            t2 = time.perf_counter()
            drive.append(d)
            setup.append(wall - d)
            bare.append(t2 - t1)
            bare_setup.append(t1 - t0)
        a, b = statistics.median(drive), statistics.median(bare)
        rows.append({"case": label, "steps": steps, "adapter µs/step": 1e6 * a / steps,
                     "bare µs/step": 1e6 * b / steps, "ratio": a / b,
                     "adapter setup ms": 1e3 * statistics.median(setup),
                     "bare setup ms": 1e3 * statistics.median(bare_setup),
                     "status": str(rec.status)})
    return rows


# --------------------------------------------------------------------------- the report's runs

REPORT_SCENARIOS = ("ball-on-plate", "rigid-flexible", "oblique", "bounce")
REPORT_ROUNDS = 3
BATCHES_BEFORE_COMMIT = "73ac2d797f25cfa96208551218b1e5ba523ae78d"
"""The last commit whose Newton adapter batched the ball alone (injected runs alone)."""


def report_items(scenario: str) -> list[tuple[Any, str, RunSettings, dict[str, Any]]]:
    """The default report's Newton runs of ``scenario`` as :func:`impactbench.evaluate.
    compare_many` items ``(scenario, mode, settings, reference)``: every job of
    :func:`impactbench.matrix.plan` (the default config), a phased job once per phase
    (:func:`impactbench.phases.offsets`)."""
    from impactbench import config, evaluate, phases
    from impactbench.matrix import job_settings, plan

    items = []
    for job in plan(config.load(None), engines=["newton"]):
        if job.engine != "newton" or job.scenario != scenario:
            continue
        built, settings = job.build_scenario(), job_settings(job)
        ref = evaluate.reference_metrics(built)
        for phase in (phases.offsets(job.phases) if job.phases > 1 else (None,)):
            run = settings if phase is None else dataclasses.replace(settings, phase=phase)
            items.append((built, job.mode, run, ref))
    return items


def same_result(a: Any, b: Any) -> bool:
    """Two :func:`~impactbench.evaluate.compare` objects equal to the last bit, NaN equal to
    NaN (a failed run's metrics), ``wall_s`` aside."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same_result(a[k], b[k]) for k in a
                                            if k != "wall_s")
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or (
            a == b and math.copysign(1.0, a) == math.copysign(1.0, b))
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same_result(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(a, b, equal_nan=True))
    return type(a) is type(b) and a == b


def report_batches(rounds: int = REPORT_ROUNDS) -> list[dict[str, Any]]:
    """One row per scenario: the default report's Newton runs of it
    (:func:`report_items`) through one :func:`~impactbench.evaluate.compare_many` call (the
    scenario's batch: a world per run) against :func:`~impactbench.evaluate.compare` one
    after another, alternated (medians over ``rounds``), after a warm-up of both whose
    objects are checked equal (:func:`same_result`)."""
    from impactbench import evaluate

    rows = []
    for scenario in REPORT_SCENARIOS:
        items = report_items(scenario)

        def one_by_one(items: list = items) -> list[dict[str, Any]]:
            return [evaluate.compare("newton", *item)[0] for item in items]

        def many(items: list = items) -> list[dict[str, Any]]:
            return evaluate.compare_many("newton", items)

        alone, batched = one_by_one(), many()
        equal = sum(same_result(a, b) for a, b in zip(alone, batched, strict=True))
        times = alternate({"one by one": one_by_one, "compare_many": many}, rounds)
        rows.append({"scenario": scenario, "runs": len(items),
                     "equal": f"{equal}/{len(items)}",
                     "one by one s": statistics.median(times["one by one"]),
                     "compare_many s": statistics.median(times["compare_many"]),
                     "new/old": median_ratio(times["compare_many"], times["one by one"])})
    return rows


def run_many_before_after(rounds: int = REPORT_ROUNDS) -> list[dict[str, Any]]:
    """One row per scenario: the report's Newton runs (:func:`report_items`, as
    :func:`~impactbench.evaluate.compare_many` hands them on) through ``Adapter.run_many`` of
    the adapter before these batches (:data:`BATCHES_BEFORE_COMMIT`: the ball's batch only,
    injected runs alone) and of the current one, alternated (medians over ``rounds``), after
    a warm-up whose records are checked equal (every array, NaN = NaN, and the meta's repr,
    ``wall_s`` aside)."""
    from impactbench import evaluate

    before, source = _load_before(BATCHES_BEFORE_COMMIT, None)
    if before is None:
        print(f"before batches: {source}")
        return []
    old, new = before.NewtonAdapter(), get_adapter("newton")
    rows = []
    for scenario in REPORT_SCENARIOS:
        items = []
        for built, mode, settings, ref in report_items(scenario):
            prepared = evaluate._prepared("newton", built, mode, settings, ref)
            items.append((prepared[0], mode, prepared[1]))
        equal = sum(_same_record(a, b) for a, b in zip(old.run_many(items),
                                                       new.run_many(items), strict=True))
        times = alternate({"before": lambda items=items: old.run_many(items),
                           "now": lambda items=items: new.run_many(items)}, rounds)
        rows.append({"scenario": scenario, "runs": len(items),
                     "equal": f"{equal}/{len(items)}",
                     f"before ({source}) s": statistics.median(times["before"]),
                     "now s": statistics.median(times["now"]),
                     "now/before": median_ratio(times["now"], times["before"])})
    return rows


def _same_record(a: Any, b: Any) -> bool:
    """Two records equal to the last bit: status, message, every array (NaN = NaN) and the
    meta's repr (``wall_s`` aside)."""
    arrays = ("time_s", "penetration_m", "penetration_rate_m_s", "normal_force_n",
              "velocity_1_m_s", "velocity_2_m_s", "displacement_2_m",
              "tangential_velocity_m_s", "spin_rad_s", "tangential_force_n")
    meta = [repr({k: v for k, v in r.meta.items() if k != "wall_s"}) for r in (a, b)]
    return (a.status, a.message) == (b.status, b.message) and meta[0] == meta[1] and all(
        (getattr(a, n) is None and getattr(b, n) is None) or (
            getattr(a, n) is not None and getattr(b, n) is not None
            and np.array_equal(getattr(a, n), getattr(b, n), equal_nan=True))
        for n in arrays)


# --------------------------------------------------------------------------- cold start

COLD_RUNS = {
    "ball-on-plate": "BallOnPlate(velocity_m_s=1.0)",
    "rigid-flexible": "RigidFlexible(velocity_m_s=2.0)",
    "oblique": "Oblique(angle_deg=45.0)",
    "bounce": "Bounce()",
}
"""One native run of each scenario (its default step), as the cold-start process builds it."""
COLD_SCRIPT = """
import sys, time
t0 = time.perf_counter()
from impactbench.engines.base import get_adapter
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible
from impactbench.reference.oblique_scenario import Oblique
from impactbench.reference.bounce_scenario import Bounce
adapter = get_adapter("newton")
adapter.version()
print("import", time.perf_counter() - t0, "", sep="\\t")
for name in sys.argv[1:]:
    t0 = time.perf_counter()
    rec = adapter.run(eval(name), "native")
    print(name, time.perf_counter() - t0, rec.status, sep="\\t")
"""


def cold_start() -> list[dict[str, Any]]:
    """Each scenario's first run in a fresh process with warp's kernel cache empty (a
    temporary ``WARP_CACHE_PATH`` of its own: every kernel module the run needs compiled),
    then in another with that cache filled (warm); and the import (s)."""
    rows = []
    for label, scenario in COLD_RUNS.items():
        cache = tempfile.mkdtemp(prefix="warp_cold_")
        row: dict[str, Any] = {"first run": label}
        try:
            for side in ("cold", "warm"):
                out = subprocess.run([sys.executable, "-c", COLD_SCRIPT, scenario],
                                     env={**os.environ, "WARP_CACHE_PATH": cache},
                                     capture_output=True, text=True, check=True).stdout
                for line in out.splitlines():
                    parts = line.split("\t")
                    if len(parts) == 3 and parts[0] == "import":
                        row[f"{side} import s"] = float(parts[1])
                    elif len(parts) == 3:
                        row[f"{side} run s"], row["status"] = float(parts[1]), parts[2]
        finally:
            shutil.rmtree(cache, ignore_errors=True)
        rows.append(row)
    return rows


def _table(rows: list[dict[str, Any]]) -> str:
    from tabulate import tabulate

    return tabulate(rows, headers="keys", floatfmt=".3g")


def main() -> None:
    """All sections; ``--report`` (the report's runs, batched against one by one; ``--rounds
    N``) or ``--cold`` (the cold start) alone."""
    from benchmarks.generation import generation

    args = sys.argv[1:]
    version = get_adapter("newton").version()
    if "--report" in args or not {"--report", "--cold"} & set(args):
        rounds = int(args[args.index("--rounds") + 1]) if "--rounds" in args else REPORT_ROUNDS
        print(f"Newton {version}: the default report's Newton runs of each scenario, "
              f"compare_many (a world per run) against compare one by one (alternated, "
              f"medians of {rounds}; 'equal': objects equal to the last bit, NaN = NaN)")
        print(_table(report_batches(rounds)))
        print()
        print(f"Newton {version}: the same runs through Adapter.run_many, the adapter before "
              f"these batches against now (alternated, medians of {rounds})")
        print(_table(run_many_before_after(rounds)))
        print()
    if "--cold" in args or not {"--report", "--cold"} & set(args):
        print(f"Newton {version}: each scenario's first run in a fresh process, warp's "
              f"kernel cache empty (cold) and filled (warm), s")
        print(_table(cold_start()))
        print()
    if {"--report", "--cold"} & set(args):
        return
    print(f"Newton {version} vs MuJoCo {get_adapter('mujoco').version()}: per-step cost, "
          f"before and after device-side stepping (medians of {REPEATS}, sides alternating)")
    print(_table(compare()))
    print()
    print(f"Newton {version}: adapter stepping (drive: graph launches, the record, the law in "
          f"injected mode, the end search) vs a bare loop of the same graph launches "
          f"(medians of {REPEATS})")
    print(_table(overhead()))
    generation("newton", [{"ke": float(k), "kd": 30.0} for k in np.geomspace(3e5, 3e7, 8)],
               REPEATS)


if __name__ == "__main__":
    main()
