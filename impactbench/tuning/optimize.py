"""Deterministic bounded optimisation of an engine's contact parameters (see :func:`tune`).

Coordinates: each parameter p in [lo, hi] is optimised as u = (ln p − ln lo)/(ln hi − ln lo)
∈ [0, 1], so every direction is a relative change of comparable size.

Search, all deterministic (the one tuner's ``least_squares`` method,
:mod:`impactbench.tuning.search`):

1. the closed-form start (the engine's native conversion) is evaluated first — the result is
   never worse than it, because the best evaluation seen is what is returned;
2. for spaces with more than two parameters (MuJoCo's solimp shape), a scrambled Sobol scan
   with a fixed seed (:data:`SEED`) of ``scan_points`` points over the box;
3. a local polish with ``scipy.optimize.least_squares`` (trust-region reflective, bounds on u,
   forward differences of step ``diff_step`` in u) from the start and then from the best scan
   points (``polish_starts``), on the residual vector √w_m·e_{v,m}; the difference step is
   the space's ``diff_step`` (1e-4 of u; larger for float32 engines, SAPIEN and Newton, whose
   metrics carry rounding noise a small step would differentiate).

Budgets: ``budget_s`` (wall time) and ``max_evals`` (objective evaluations) stop the search
cleanly at the next evaluation and keep the best so far; the result then says which budget
ended it. A search that ends by convergence is fully deterministic; one cut by the time budget
depends on the machine's speed (the ``stop`` field says so).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from impactbench.engines.base import get_adapter
from impactbench.engines.tuning_spaces import SAP_LIMIT, Space, make_space
from impactbench.evaluate import reference_metrics
from impactbench.reference import validation as check
from impactbench.reference.metrics import BALL_METRICS, MIN_CONTACT_SAMPLES, TIME_RESOLVED
from impactbench.reference.scenarios import BallOnPlate
from impactbench.scenarios import spec_of
from impactbench.tuning import search as search_mod
from impactbench.tuning.names import DEFAULT_BUDGET_S
from impactbench.tuning.objective import (
    Evaluation,
    Objective,
    parse_weights,
    quiet,
)
from impactbench.tuning.search import SEED

__all__ = ["COARSE_SCAN_POINTS", "SEED", "Interrupted", "TuneResult", "search", "tune"]
COARSE_SCAN_POINTS = 64
"""Sobol scan size at a step too coarse to resolve the contact, or when the start fails."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`tune`. Every finished engine run is in the store, and the search
    is deterministic, so the same tune replays them from it and goes on. ``str()`` is the
    one line the CLI prints."""

    def __init__(self, obj: Objective) -> None:
        super().__init__(obj.evaluations)
        done = f"interrupted after {obj.evaluations} evaluations"
        self.line = (f"{done}; {obj.stored} runs stored ({obj.served} served); rerun the same "
                     "tune to resume" if obj.store is not None
                     else f"{done} (no store: nothing kept)")

    def __str__(self) -> str:
        return self.line


@dataclass
class TuneResult:
    """The outcome of one tuning run (see :func:`tune`).

    Attributes:
        space: the engine's parameterisation.
        objective: the objective (velocities, references, effective weights, counters).
        start: the evaluation at the closed-form start (the native conversion).
        tuned: the best evaluation found.
        requested_weights: the weights asked for, before inexpressible targets were zeroed.
        excluded: metric key → why it was excluded (weight set to 0).
        stop: why the search ended (``converged``, or the budget that ran out).
        wall_s: tuning wall time (s).
        engine_version, timestep_s: provenance of the runs.
    """

    space: Space
    objective: Objective
    start: Evaluation
    tuned: Evaluation
    requested_weights: dict[str, float]
    excluded: dict[str, str]
    stop: str
    wall_s: float
    engine_version: str
    timestep_s: float
    stages: list[str] = field(default_factory=list)

    @property
    def parameters(self) -> dict[str, Any]:
        """The fitted parameters in the adapter's tuned keys."""
        return self.space.to_tuned(self.tuned.values)

    @property
    def start_parameters(self) -> dict[str, Any]:
        return self.space.to_tuned(self.start.values)

    @property
    def velocities_m_s(self) -> tuple[float, ...]:
        return self.objective.velocities_m_s

    def max_abs_error(self, which: str = "tuned") -> dict[str, float]:
        """max over velocities of |relative error| per metric, over the runs that compared
        (:meth:`compared` says how many); NaN where none did."""
        ev = self.tuned if which == "tuned" else self.start
        out = {}
        for key in BALL_METRICS:
            vals = [abs(e[key]) for e in ev.rel_errors if math.isfinite(e[key])]
            out[key] = max(vals) if vals else math.nan
        return out

    def compared(self, key: str) -> str:
        """``k/n``: the velocities at which both the start and the tuned run compared."""
        n = sum(math.isfinite(a[key]) and math.isfinite(b[key])
                for a, b in zip(self.start.rel_errors, self.tuned.rel_errors, strict=True))
        return f"{n}/{len(self.velocities_m_s)}"


def search(obj: Objective, *, scan_points: int | None = None, polish_starts: int = 2,
           diff_step: float | None = None, max_polish_evals: int = 400
           ) -> tuple[str, list[str]]:
    """Run the search stages on ``obj`` (its best evaluation is the answer): the one tuner's
    ``least_squares`` method (:func:`impactbench.tuning.search.least_squares`) on the space's
    log coordinates, the Sobol scan handed over ``obj.batch_size`` points at a time;
    ``diff_step`` defaults to the space's (larger for float32 engines, whose metrics carry
    rounding noise).

    Returns (stop reason, a line per stage).
    """
    space = obj.space
    if scan_points is None:
        scan_points = 128 if len(space.parameters) > 2 else 0
    outcome = search_mod.least_squares(
        space, obj, scan_points=scan_points, seed=SEED, polish_starts=polish_starts,
        diff_step=space.diff_step if diff_step is None else diff_step,
        max_nfev=max_polish_evals, slice_size=obj.batch_size)
    return outcome.stop, outcome.stages


def tune(engine: str, scenario: BallOnPlate | None = None,
         velocities_m_s: tuple[float, ...] | list[float] | None = None,
         targets: list[str] | tuple[str, ...] | None = None,
         weights: list[float] | tuple[float, ...] | None = None, *,
         parameters: str | None = None, solref_form: str = "direct",
         timestep_s: float | None = None, budget_s: float = DEFAULT_BUDGET_S,
         max_evals: int | None = None, scan_points: int | None = None,
         start: tuple[float, ...] | None = None, references: list[dict] | None = None,
         fixed: dict[str, Any] | None = None, store: Any = None,
         fresh: bool = False, runner: Any = None,
         phases: int | None = None) -> TuneResult:
    """Fit ``engine``'s native contact parameters to the Hunt–Crossley reference.

    Args:
        engine: registry name with a tuning space (:data:`~impactbench.tuning.names.VARIANTS`).
        scenario: the ball on the plate (default: the paper's); its velocity is ignored.
        velocities_m_s: impact velocities of the objective (default the paper's 0.5–5 m/s).
        targets: metric names (:data:`~impactbench.tuning.objective.TARGETS`; default
            restitution, duration, peak_force) and ``weights`` (≥ 0, one per target).
        parameters: the engine's parameter set
            (:data:`~impactbench.engines.tuning_spaces.VARIANTS`).
        solref_form: MuJoCo's solref form, ``direct`` (−S, −D) or ``timeconst`` (τ, ζ).
        timestep_s: integration step (default: the adapter's, 1e-6 s for the ball).
        budget_s, max_evals: wall-time and evaluation budgets (stop cleanly, keep the best).
        scan_points: Sobol scan size (default 128 for > 2 parameters, else 0).
        start: override the closed-form start (natural units, in the space's order).
        references: precomputed reference metrics per velocity (tests use engine-made ones).
        fixed: engine settings held fixed during the fit and written with the parameters
            (e.g. Drake's ``discrete_contact_approximation``: a discrete plant at the step).
        store: an :class:`impactbench.store.Store`: engine runs it holds are served from it
            (same keys as the run matrix), new ones are stored; ``fresh`` runs everything
            again (and stores it). The result does not depend on the store.
        runner: an :class:`impactbench.cluster.Runner` that executes the engine runs of each
            Sobol-scan slice and each finite-difference Jacobian at once (Dask workers); None
            runs them in this process. The result does not depend on it.
        phases: how many phases of the step each velocity is run at
            (:mod:`impactbench.phases`: the first touch at k/phases of a step), scored at the
            worst; None: :data:`impactbench.phases.PHASES` at a step not much shorter than
            the reference contact (:func:`impactbench.phases.needs_phases`), else 1 (the
            adapters' one phase).

    At a step too long to resolve the reference contact (fewer than
    ``impactbench.reference.metrics.MIN_CONTACT_SAMPLES`` steps in its shortest duration)
    the time-resolved targets (duration, peak force, penetration, energy loss) are excluded
    with that reason: only restitution is fitted, after a Sobol scan of the whole box
    (:data:`COARSE_SCAN_POINTS`; also when the start itself fails).

    Raises ValueError (one line) on bad input; engine trouble becomes failed runs instead.
    """
    from impactbench.reference.scenarios import PAPER_VELOCITIES_M_S

    t0 = time.perf_counter()
    scenario = scenario or BallOnPlate()
    spec = spec_of(scenario)
    if "tuning" not in spec.studies:
        raise ValueError(f"scenario = {spec.name!r}: tuning is not supported yet for it")
    budget_s = check.positive("budget_s", budget_s)
    if max_evals is not None and (isinstance(max_evals, bool) or int(max_evals) < 1):
        raise ValueError(f"max_evals = {max_evals!r}: must be an integer >= 1")
    velocities = tuple(PAPER_VELOCITIES_M_S if velocities_m_s is None else velocities_m_s)
    if not velocities:
        raise ValueError("velocities = []: must list at least one impact velocity")
    requested = parse_weights(targets, weights)
    adapter = get_adapter(engine)  # ValueError for an unknown engine; EngineUnavailable
    space = make_space(engine, scenario, parameters, solref_form, timestep_s)
    if start is not None:
        from impactbench.engines.tuning_spaces import with_start

        space = with_start(space, tuple(start))
    if fixed:
        to_tuned = space.to_tuned
        space = replace(space, to_tuned=lambda v: {**to_tuned(v), **fixed})
        if engine == "drake" and fixed.get("discrete_contact_approximation") == "sap" \
                and space.variant == "stiffness+dissipation":
            space = replace(space, limits=(*space.limits, SAP_LIMIT))
    excluded = {k: space.limits[0] for k in requested if k not in space.expressible}
    dt_run = timestep_s or adapter.default_timestep_s(scenario, space.mode)
    if not references:
        references = [reference_metrics(scenario.replace(velocity_m_s=v)) for v in velocities]
    shortest = min(float(r["duration_s"]) for r in references)
    coarse = shortest < MIN_CONTACT_SAMPLES * dt_run
    if coarse:
        why = (f"not resolved at dt = {dt_run:g} s: the reference contact lasts "
               f"{shortest:.3g} s, fewer than {MIN_CONTACT_SAMPLES} steps")
        excluded.update({k: why for k in requested if k in TIME_RESOLVED and k not in excluded})
    effective = {k: (0.0 if k in excluded else w) for k, w in requested.items()}
    if not any(w > 0 for w in effective.values()):
        raise ValueError(f"targets = {list(requested)}: {engine} can express none of them "
                         f"(only {', '.join(sorted(space.expressible))})")
    from impactbench import phases as phases_mod

    if phases is None:
        phases = phases_mod.PHASES if phases_mod.needs_phases(dt_run, shortest) else 1
    phases_mod.offsets(phases)  # ValueError (one line) unless an integer >= 1
    obj = Objective(space, scenario, velocities, effective, timestep_s,
                    references=list(references or []), store=store, fresh=fresh,
                    runner=runner,
                    phases=phases_mod.offsets(phases) if phases > 1 else (None,))
    try:
        first = obj.evaluate(np.asarray(space.start), count_budget=False)
        obj.deadline = t0 + budget_s
        obj.max_evals = max_evals
        if scan_points is None and (coarse or any(st != "ok" for st in first.statuses)):
            # a coarse step makes the start a one-step impulse whose restitution barely moves
            # with the parameters (or the start fails): search the whole box first
            scan_points = COARSE_SCAN_POINTS
        with quiet(engine):
            stop, stages = search(obj, scan_points=scan_points)
    except KeyboardInterrupt:
        obj.flush()
        raise Interrupted(obj) from None
    obj.flush()
    assert obj.best is not None
    dt = timestep_s or adapter.default_timestep_s(scenario, space.mode)
    return TuneResult(space, obj, first, obj.best, requested, excluded, stop,
                      time.perf_counter() - t0, adapter.version(), float(dt), stages)
