"""The adapter contract, the lazy registry and the safe runner.

An adapter turns a scenario (``impactbench.reference.scenarios``) into an
:class:`~impactbench.reference.record.ImpactRecord` measured from the engine's own contact output.
It never computes metrics: ``impactbench.reference.metrics.compute`` does, for every producer alike.

Adding an engine (a checklist, in the manner of scipy's ``OdeSolver``):

1. Write ``engines/<name>_adapter.py`` with a subclass of :class:`Adapter`; import the engine
   inside the module only (the registry imports the module only when the engine is used) and
   raise :class:`EngineUnavailable` if it is missing.
2. Set ``name``, ``pip`` (the install command) and implement ``version()``.
3. Declare one :class:`Builder` per scenario the engine supports in :attr:`Adapter.builders`
   (scenario name → the method that runs it, the customary step there and, where it differs
   from :attr:`Adapter.modes`, the modes it implements there). A scenario without a builder
   is ``unsupported`` with that reason; no adapter branches on scenario types. A builder
   only builds: :meth:`Adapter.run` has already checked the mode, the ``custom`` keys
   (the scenario's own subset: :attr:`Builder.parameter_keys`) and that a ``tuned`` run has
   tuned parameters (:attr:`Builder.tuned_check`, :attr:`Adapter.tuned_parameters`). It
   builds the scenario, steps it, and records every step from a little before first
   contact until the bodies have separated: time, penetration, penetration rate, the engine's
   normal force (force sample at t_k = the force acting over the step that starts at t_k),
   body velocities.
4. Return a non-ok :class:`~impactbench.reference.record.Status` for physical outcomes (no_contact,
   tunneled, diverged, max_time, unsupported) instead of raising.
5. Add one :class:`~impactbench.engines.registry.EngineSpec` to
   :data:`~impactbench.engines.registry.BUILTIN` (adapter ``"module:Class"``, pip command and
   extra, version distribution, tuning spaces, customary steps) and a test module in
   ``tests/engines/`` that skips through ``tests.conftest.require_engine``.
6. ``default`` and ``custom`` (the contract every adapter follows): ``default`` builds the
   scenario the way a user of the engine would with nothing but geometry, mass, the step,
   gravity and the scenario's own settings (zero friction), leaving every contact parameter at
   the engine's default, and records those defaults, read back from the engine where it can
   report them, in ``meta["engine_defaults"]``. ``custom`` is ``default`` plus
   ``settings.params``: the adapter lists the accepted names in :attr:`Adapter.parameter_keys`
   (the engine's own spelling: MJCF attributes, pybullet keyword arguments, Drake property and
   config names), validates the values with a one-line ValueError naming the key, and records
   what it applied in ``meta["params"]``. Pair values: where the engine combines two bodies'
   values (restitution products, stiffness in series), the plate gets the neutral value so the
   pair has exactly the user's number. Both modes must run at the engine's customary steps
   (up to 1e-2 s): a contact shorter than a step is still measured (the metrics flag what is
   not resolved), and a plate thick enough that one step cannot carry the ball through it.
   A scenario the modes do not cover returns ``unsupported``. Set ``modes`` to include
   them, ``parameter_keys`` to the names, and add the engine to ``tests/engines/
   test_default_custom.py`` (its customary step in ``CUSTOMARY_S``).

Modes: ``native`` (the engine's own contact model, parameters mapped from the physical ones),
``tuned`` (native with fitted parameters from a tuned-parameter file), ``injected`` (the
reference force law driven through the engine each step, so only the time stepping differs),
``default`` (the engine's out-of-the-box contact: nothing set beyond geometry, mass and the
scenario's own settings; the defaults used go into ``meta["engine_defaults"]``) and ``custom``
(the user's own engine parameters, ``settings.params``, keyed by the engine's own names; the
valid names are the adapter's :attr:`Adapter.parameter_keys`).

In ``injected`` mode the scenario's contact model (``BallOnPlate.model``, any of
:mod:`impactbench.reference.models` except the adhesive unclipped Kelvin–Voigt, which is
``unsupported``) is what ``scenario.law()`` returns, so every adapter follows it.

An adapter lists the modes it implements in :attr:`Adapter.modes`; :meth:`Adapter.run` owns the
mode prologue (as scipy's ``OdeSolver.step`` owns the bookkeeping around ``_step_impl``): it
turns any other mode, or one the scenario's builder does not implement, into an
``unsupported`` record, and a ``tuned`` run without tuned parameters too; it rejects unknown
``custom`` keys, and keys of another scenario, with a one-line ValueError.
"""

from __future__ import annotations

import difflib
import importlib
import os
import time
import traceback
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

# the names and the plug-in registry live in a standard-library-only module (a light CLI);
# they are re-exported here
from impactbench.engines.registry import (  # noqa: F401
    DISABLE_ENV,
    ENGINES,
    ENGINES_ENV,
    MODES,
    PIP,
    _registry,
    engine_names,
)
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.validation import InvalidValue

Scenario = Any
"""A scenario: a frozen dataclass with a class attribute ``name`` (its registry name), e.g.
:class:`~impactbench.reference.scenarios.BallOnPlate`."""


@dataclass(frozen=True)
class Builder:
    """How an adapter runs one scenario.

    Attributes:
        run: the adapter method (its name) that simulates and records the scenario,
            ``(scenario, mode, settings) -> ImpactRecord``; or, for a builder a plug-in adds
            to an engine, ``"module:function"`` called as ``function(adapter, scenario, mode,
            settings)``.
        timestep_s: the adapter's default step for the scenario (s).
        modes: the modes implemented for this scenario (None: all of :attr:`Adapter.modes`).
    """

    run: str
    timestep_s: float
    modes: tuple[str, ...] | None = None
    why_not: str | Mapping[str, str] = ""
    """Why the modes outside ``modes`` do not run here (the ``unsupported`` message), one
    reason for all of them or one per mode (a mode left out gets the generic reason)."""
    own_keys: bool = False
    """The builder validates ``custom`` mode's keys and ``tuned`` mode's parameters itself
    (raising :class:`SettingsError`): a scenario whose engine parameters are not the
    adapter's :attr:`~Adapter.parameter_keys` (the cube tosses' ``board.``/``cube.`` keys)."""
    parameter_keys: tuple[str, ...] | None = None
    """The ``custom`` keys this scenario takes (None: all of the adapter's
    :attr:`~Adapter.parameter_keys`); another of the adapter's keys is a ValueError naming
    the scenarios it applies to (a friction key given to the head-on ball)."""
    tuned_check: Callable[[str, RunSettings], ImpactRecord | None] | None = None
    """Whether a ``tuned`` run can go ahead, ``tuned_check(engine, settings)`` returning the
    ``unsupported`` record or None: a scenario whose tuned parameters are its own (the
    oblique impact's friction knobs, :func:`impactbench.engines.oblique_tuned.refused`).
    None: the run needs tuned parameters (``settings.tuned``) and is ``unsupported`` without
    them (:meth:`Adapter.tuned_refusal`)."""
    batch: str = ""
    """An adapter method that runs many runs of this scenario in one call,
    ``(items: [(scenario, mode, settings)]) -> [ImpactRecord]``, each record the one
    :attr:`run` gives (MJX: one ``vmap`` over worlds); "" runs them one by one
    (:meth:`Adapter.run_many`)."""


CUBE_TOSS_STEP_S = 1.0 / 1480.0
"""The cube tosses' engine step (s): DAIR's, a tenth of the 1/148 s motion-capture interval
(the scenario's ``substeps`` set the step a run actually takes)."""

CUBE_TOSS_NOT_INJECTED = {
    "mjx": "injected mode needs the model's corner forces computed between steps; MJX steps "
           "the tosses inside one compiled, vmapped jax call (no Python between steps): the "
           "law would have to be written in jax",
    "newton": "injected mode needs the model's corner forces computed between steps; Newton "
              "steps every toss together in captured warp CPU graphs (no Python between "
              "steps): the law would have to be a warp kernel",
}
"""Batched engines, and why their cube-toss builders have no ``injected`` mode."""


def cube_toss_builder(engine: str) -> Builder:
    """The cube-toss builder of a 3D engine (:meth:`Adapter.replay_tosses`, the scenario's
    own keys); a batched engine's has no ``injected`` mode (:data:`CUBE_TOSS_NOT_INJECTED`)."""
    if engine in CUBE_TOSS_NOT_INJECTED:
        return Builder("replay_tosses", CUBE_TOSS_STEP_S,
                       modes=("default", "custom", "tuned", "native"), own_keys=True,
                       why_not=CUBE_TOSS_NOT_INJECTED[engine])
    return Builder("replay_tosses", CUBE_TOSS_STEP_S, own_keys=True)


def checked_params(params: dict[str, Any], keys: tuple[str, ...],
                   rule: Callable[[str, Any], Any]) -> dict[str, Any]:
    """The ``custom`` parameters among ``keys`` that ``params`` gives (an engine's own names and
    units), in the order of ``keys``, each checked by ``rule(f"param {key}", value)`` (a rule
    of :mod:`impactbench.reference.validation`: the value, or a one-line InvalidValue naming
    the key): the pieces of an :attr:`Adapter.value_check`."""
    return {key: rule(f"param {key}", params[key]) for key in keys if key in params}


RIGID_FLEXIBLE_MODES = ("native", "injected", "tuned")
"""The 2-DOF pair's modes in an engine whose ``default``/``custom`` contact cannot carry it."""


def scenario_builders(*, ball_s: float, pair_s: float, oblique_s: float,
                      oblique_tuned_check: Callable[[str, RunSettings], ImpactRecord | None],
                      engine_3d: str | None = None, pair_run: str = "run_rigid_flexible",
                      pair_modes: tuple[str, ...] | None = None,
                      ball_keys: tuple[str, ...] | None = None,
                      ball_batch: str = "", bounce_s: float | None = None,
                      pair_batch: str = "", oblique_batch: str = "", bounce_batch: str = ""
                      ) -> dict[str, Builder]:
    """An adapter's :attr:`Adapter.builders` for the suite's scenarios: the ball on the plate
    (``run_ball`` at the default step ``ball_s``, s; ``ball_keys``: its ``custom`` keys;
    ``ball_batch``: its :attr:`Builder.batch` method; ``pair_batch``, ``oblique_batch`` and
    ``bounce_batch`` the other scenarios'), the
    2-DOF pair (``pair_run`` at ``pair_s``; ``pair_modes``: the modes it runs in, None for
    all) and the oblique impact (``run_oblique`` at ``oblique_s``, its ``tuned`` runs decided
    by ``oblique_tuned_check``, :func:`impactbench.engines.oblique_tuned.refused`); the
    bounce to rest (``run_bounce`` at ``bounce_s``, the engine's customary step, with the
    ball's ``custom`` keys) where ``bounce_s`` is given; a 3D engine (``engine_3d``, its name)
    adds the cube tosses (:func:`cube_toss_builder`)."""
    builders = {
        "ball-on-plate": Builder("run_ball", ball_s, parameter_keys=ball_keys, batch=ball_batch),
        "rigid-flexible": Builder(pair_run, pair_s, modes=pair_modes, batch=pair_batch),
        "oblique": Builder("run_oblique", oblique_s, tuned_check=oblique_tuned_check,
                           batch=oblique_batch),
    }
    if bounce_s is not None:
        bounce_builders = {"bounce": Builder("run_bounce", bounce_s, parameter_keys=ball_keys,
                                              batch=bounce_batch)}
        builders.update(bounce_builders)
    if engine_3d is None:
        return builders
    cube_builders = {"cube-toss": cube_toss_builder(engine_3d)}
    return {**builders, **cube_builders}


CUBE_TOSS_TWO_D = ("{} is a 2D engine (bodies move in a plane with one rotation angle): a cube "
                   "tumbling in 3D with a 3-axis spin cannot be expressed")
"""Why a 2D engine has no cube-toss builder (``.format(engine label)``)."""


class SettingsError(ValueError):
    """Bad settings found by a builder (a parameter the engine does not take, a value it
    refuses): bad input, re-raised by :func:`run_safely` as a ValueError, never ``crashed``."""


class EngineUnavailable(RuntimeError):
    """The engine's Python package is not installed; the message names the pip command."""

    def __init__(self, engine: str, detail: str = "") -> None:
        pip = PIP.get(engine, f"pip install {engine}")
        more = f" ({detail})" if detail else ""
        super().__init__(f"engine {engine!r} is not installed{more}: run `{pip}`")
        self.engine = engine
        self.pip = pip


def import_engine(engine: str, module: str) -> Any:
    """The engine's Python module, or :class:`EngineUnavailable` (naming the pip command
    that installs it) when it is not installed."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise EngineUnavailable(engine, str(exc)) from None


@dataclass(frozen=True)
class RunSettings:
    """How to run one scenario in an engine.

    Attributes:
        timestep_s: integration step (s); ``None`` takes the adapter's default for the scenario.
        max_time_s: simulated-time cap (s); ``None`` lets the adapter choose from the scenario.
        tuned: fitted native parameters for ``tuned`` mode (engine-specific keys).
        params: the user's engine parameters for ``custom`` mode (engine's own key names).
        tuned_for: the provenance of ``tuned`` (a tuned file's ``[provenance]``: engine,
            scenario parameters, timestep). The suite refuses a ``tuned`` run of another
            scenario or timestep as ``unsupported`` before it reaches the adapter
            (:func:`impactbench.evaluate.compare`); None: not checked.
        options: engine-specific extras (e.g. an integrator name), recorded in the metadata.
        phase: where the head-on ball's first touch falls inside a step, as a fraction of the
            step in [0, 1): the ball starts (2 + phase)·V0·dt above the plate, so it reaches
            the surface that fraction of the way through its third step. At a step longer
            than the contact the outcome depends on it (:mod:`impactbench.phases` runs
            several); ``None``: the adapters' fixed :data:`DEFAULT_PHASE` (half a step).
    """

    timestep_s: float | None = None
    max_time_s: float | None = None
    tuned: dict[str, Any] | None = None
    params: dict[str, Any] | None = None
    tuned_for: dict[str, Any] | None = None
    options: dict[str, Any] = field(default_factory=dict)
    phase: float | None = None

    def __post_init__(self) -> None:
        from impactbench.reference import validation as check

        if self.timestep_s is not None:
            check.positive("timestep_s", self.timestep_s)
        if self.max_time_s is not None:
            check.positive("max_time_s", self.max_time_s)
        if self.phase is not None and not 0.0 <= self.phase < 1.0:
            raise SettingsError(f"phase = {self.phase!r}: must be a fraction of a step in "
                                f"[0, 1)")


DEFAULT_PHASE = 0.5
"""The head-on ball's first touch falls half-way through a step unless a run asks for another
:attr:`RunSettings.phase` (the ball starts 2.5 steps of flight above the plate)."""


def ball_phase(phase: float | None) -> float:
    """The phase a head-on ball run starts at, its ``meta["phase"]``: ``phase``
    (:attr:`RunSettings.phase`), else :data:`DEFAULT_PHASE`."""
    return DEFAULT_PHASE if phase is None else float(phase)


def ball_gap_m(velocity_m_s: float, dt: float, phase: float | None = None) -> float:
    """The head-on ball's initial free-flight distance (m): (2 + phase) steps at the impact
    velocity, so the first touch falls ``phase`` of the way through a step (``None``:
    :data:`DEFAULT_PHASE`, 2.5 steps, as every adapter had before phases)."""
    return (2.0 + (DEFAULT_PHASE if phase is None else phase)) * velocity_m_s * dt


class Adapter(ABC):
    """One engine. Subclasses implement ``version`` and declare their :attr:`builders`."""

    name: ClassVar[str]
    modes: ClassVar[tuple[str, ...]] = ("native", "injected", "tuned")
    """The modes this adapter implements (a subset of :data:`MODES`)."""
    builders: ClassVar[dict[str, Builder]] = {}
    """Scenario name → :class:`Builder`: the scenarios this engine runs."""
    missing_builders: ClassVar[dict[str, str]] = {}
    """Scenario name → why this engine cannot express it (a 2D engine and a tumbling cube):
    the ``unsupported`` message of such a run."""
    parameter_keys: ClassVar[tuple[str, ...]] = ()
    """The engine's own parameter names accepted in ``custom`` mode (``settings.params``)."""
    tuned_parameters: ClassVar[str] = ""
    """What ``tuned`` mode reads from a tuned-parameter file, in one line (its keys; the
    ``unsupported`` message of a tuned run without one names it); "": any of
    :attr:`parameter_keys`."""
    injection: ClassVar[str] = ""
    """How ``injected`` mode reaches this engine, in one line (the report shows it).

    Injection has one meaning in every adapter: the reference force law through the engine's
    own contact integration (its contact solver and time stepping, with their errors). An
    engine that cannot run a force law through its contact starts the line with ``cannot:``
    and says how the law is applied instead, so its injected numbers are read accordingly."""

    value_check: ClassVar[Callable[[dict[str, Any]], Any] | None] = None
    """The adapter's parser of ``custom`` values (raises :class:`~impactbench.reference.
    validation.InvalidValue` naming the key and its rule), run by :meth:`check_params`
    before any run; None: the values are checked when a run starts."""

    def check_params(self, params: dict[str, Any]) -> None:
        """Validate ``custom`` values without running the engine (a config, a gate file:
        all of them before the first run)."""
        check = type(self).value_check
        if check is not None:
            check(dict(params))

    @abstractmethod
    def version(self) -> str:
        """The engine package's version string."""

    def replay_tosses(self, scenario: Scenario, mode: str, settings: RunSettings
                      ) -> ImpactRecord:
        """The cube-toss builder of the 3D engines (:func:`impactbench.engines.cube_toss.
        replay_tosses`: the engine's cube on the board, every selected toss replayed). A
        ValueError before the first step (a parameter the engine does not take, a published
        set it lacks) is bad input: :class:`SettingsError`."""
        from impactbench.engines.cube_toss import replay_tosses

        try:
            return replay_tosses(self.name, scenario, mode, settings)
        except SettingsError:
            raise
        except ValueError as exc:
            raise SettingsError(str(exc)) from None

    def builder(self, scenario: Scenario) -> Builder | None:
        """The builder of ``scenario``: the adapter's own, else one the scenario's class
        brings for this engine (``engine_builders``, a plug-in's); None when neither."""
        name = getattr(scenario, "name", type(scenario).__name__)
        found = self.builders.get(name)
        if found is None:
            found = dict(getattr(type(scenario), "engine_builders", {})).get(self.name)
        return found

    def default_timestep_s(self, scenario: Scenario, mode: str) -> float | None:
        """The adapter's default integration step (s) for this scenario (None: no builder)."""
        found = self.builder(scenario)
        return None if found is None else found.timestep_s

    def run(self, scenario: Scenario, mode: str = "native",
            settings: RunSettings | None = None) -> ImpactRecord:
        """Run one scenario; fills provenance (engine, version, mode, timestep_s, wall_s).

        The mode prologue is here, so builders only build: an unknown ``custom`` key (or one
        of another scenario's) is a ValueError; a mode the adapter or the scenario's builder
        does not implement, an unclipped Kelvin–Voigt law to inject, or a ``tuned`` run
        without tuned parameters (:meth:`tuned_refusal`) is an ``unsupported`` record."""
        found, settings, rec = self._prologue(scenario, mode, settings)
        if rec is not None:
            return rec
        t0 = time.perf_counter()
        return self._provenance(self._build(found, scenario, mode, settings), mode, settings,
                                time.perf_counter() - t0)

    def run_many(self, items: Sequence[tuple[Scenario, str, RunSettings | None]]
                 ) -> list[ImpactRecord]:
        """``[self.run(*item) for item in items]``, the same records: the runs whose
        scenario's builder has a :attr:`Builder.batch` method go to it in one call (each
        record's ``wall_s``: the call's time shared out), the others one by one."""
        out: list[ImpactRecord | None] = [None] * len(items)
        batched: dict[str, list[tuple[int, tuple[Scenario, str, RunSettings]]]] = {}
        for i, (scenario, mode, settings) in enumerate(items):
            found = self.builder(scenario)
            if found is None or not found.batch:
                out[i] = self.run(scenario, mode, settings)
                continue
            found, settings, rec = self._prologue(scenario, mode, settings)
            if rec is not None:
                out[i] = rec
            else:
                batched.setdefault(found.batch, []).append((i, (scenario, mode, settings)))
        for method, group in batched.items():
            t0 = time.perf_counter()
            recs = getattr(self, method)([item for _, item in group])
            wall = (time.perf_counter() - t0) / len(group)
            for (i, (_, mode, settings)), rec in zip(group, recs, strict=True):
                out[i] = self._provenance(rec, mode, settings, wall)
        return [r for r in out if r is not None]

    def _prologue(self, scenario: Scenario, mode: str, settings: RunSettings | None
                  ) -> tuple[Builder, RunSettings, ImpactRecord | None]:
        """The mode prologue of :meth:`run`: (the builder, the settings with the step filled
        in, the record when the run stops here: ``unsupported``, or a ``tuned`` refusal)."""
        if mode not in MODES:
            raise ValueError(f"mode = {mode!r}: must be one of {', '.join(MODES)}")
        settings = settings or RunSettings()
        found = self.builder(scenario)
        if mode == "custom" and not (found is not None and found.own_keys):
            self._check_keys(scenario, found, settings.params or {})
        refused = self._refused(scenario, mode, settings, found)
        if refused is not None:
            return found, settings, refused  # type: ignore[return-value]
        assert found is not None  # a missing builder is refused
        dt = settings.timestep_s or found.timestep_s
        if settings.timestep_s is None:
            settings = replace(settings, timestep_s=dt)
        rec = self.tuned_refusal(found, settings) if mode == "tuned" else None
        if rec is not None:
            rec = self._provenance(rec, mode, settings, 0.0)
        return found, settings, rec

    def _provenance(self, rec: ImpactRecord, mode: str, settings: RunSettings,
                    wall_s: float) -> ImpactRecord:
        """``rec`` with its provenance: engine, version, mode, step (s), wall time (s), the
        run's options."""
        rec.meta.update(
            engine=self.name,
            engine_version=self.version(),
            mode=mode,
            timestep_s=rec.meta.get("timestep_s", settings.timestep_s),  # (a scenario's own)
            wall_s=wall_s,
            **{k: v for k, v in settings.options.items() if k not in rec.meta},
        )
        return rec

    def _build(self, found: Builder, scenario: Scenario, mode: str, settings: RunSettings
               ) -> ImpactRecord:
        """Call the builder: the adapter's method, or a plug-in's ``module:function``."""
        if ":" in found.run:
            module_name, _, attr = found.run.partition(":")
            return getattr(importlib.import_module(module_name), attr)(self, scenario, mode,
                                                                       settings)
        return getattr(self, found.run)(scenario, mode, settings)

    def _check_keys(self, scenario: Scenario, found: Builder | None,
                    params: Mapping[str, Any]) -> None:
        """A ``custom`` key the engine does not take, or one that only another scenario
        takes (:attr:`Builder.parameter_keys`): a one-line ValueError naming the valid keys,
        or the scenarios the key applies to."""
        unknown = sorted(set(params) - set(self.parameter_keys))
        if unknown:
            valid = ", ".join(self.parameter_keys) or "(none)"
            raise InvalidValue(f"param = {unknown[0]!r}: not a {self.name} parameter; "
                             f"valid keys: {valid}")
        if found is None or found.parameter_keys is None:
            return
        for key in sorted(set(params) - set(found.parameter_keys)):
            where = " and ".join(
                n for n, b in self.builders.items() if not b.own_keys
                and (b.modes is None or "custom" in b.modes)
                and (b.parameter_keys is None or key in b.parameter_keys))
            name = getattr(scenario, "name", type(scenario).__name__)
            raise InvalidValue(f"param {key} = {params[key]!r}: applies to the {where} "
                             f"scenario only, not {name!r}")

    def _refused(self, scenario: Scenario, mode: str, settings: RunSettings,
                 found: Builder | None) -> ImpactRecord | None:
        """The ``unsupported`` record of a mode this engine, or the scenario's builder, does
        not run; None when the builder runs it."""
        if mode not in self.modes:
            return ImpactRecord.failed(
                Status.UNSUPPORTED, f"{self.name} does not implement mode {mode!r} "
                f"(it implements {', '.join(self.modes)})", engine=self.name, mode=mode)
        name = getattr(scenario, "name", type(scenario).__name__)
        if found is None:
            why = self.missing_builders.get(name) or (
                f"{self.name} has no builder for scenario {name!r} (it runs "
                f"{', '.join(self.builders) or 'none'})")
            return ImpactRecord.failed(Status.UNSUPPORTED, why, engine=self.name, mode=mode)
        if found.modes is not None and mode not in found.modes:
            reason = (found.why_not.get(mode, "") if isinstance(found.why_not, Mapping)
                      else found.why_not)
            why = f"mode {mode} in {self.name}: {reason}" if reason else (
                f"{mode} mode is implemented for "
                f"{' and '.join(s for s, b in self.builders.items() if b.modes is None)} only")
            return ImpactRecord.failed(
                Status.UNSUPPORTED, why, engine=self.name, engine_version=self.version(),
                mode=mode, timestep_s=settings.timestep_s or found.timestep_s)
        if mode == "injected" and getattr(scenario, "model", None) == "kelvin-voigt":
            return ImpactRecord.failed(
                Status.UNSUPPORTED, "model 'kelvin-voigt' (unclipped) pulls the ball back "
                "(F < 0): no engine contact can pull, and the metrics path measures contact "
                "by F > 0; inject 'kelvin-voigt-clipped'", engine=self.name, mode=mode)
        return None

    def tuned_refusal(self, found: Builder, settings: RunSettings) -> ImpactRecord | None:
        """The ``unsupported`` record of a ``tuned`` run that has nothing to apply (None: it
        can go ahead): the builder's own check (:attr:`Builder.tuned_check`), else no tuned
        parameters; the message names what ``tuned`` mode reads
        (:attr:`tuned_parameters`)."""
        if found.own_keys:
            return None
        if found.tuned_check is not None:
            return found.tuned_check(self.name, settings)
        if settings.tuned:
            return None
        what = (f"{self.name}'s {self.tuned_parameters}" if self.tuned_parameters else
                f"any of {self.name}'s {', '.join(self.parameter_keys) or 'parameters'}")
        return ImpactRecord.failed(
            Status.UNSUPPORTED, f"tuned mode needs a tuned-parameter file (settings.tuned: "
            f"{what}), none given")


def _disabled() -> set[str]:
    return {x.strip() for x in os.environ.get(DISABLE_ENV, "").split(",") if x.strip()}


def _suggest(name: str) -> str:
    hint = difflib.get_close_matches(name, ENGINES, n=1)
    return f" (did you mean {hint[0]!r}?)" if hint else ""


def adapter_class(name: str) -> type[Adapter]:
    """The adapter class registered as ``name``: its module imported, not the engine (the
    class's declarations, such as :attr:`Adapter.parameter_keys`, need no engine). Raises
    ValueError for an unknown name."""
    registry = _registry()
    if name not in registry:
        raise ValueError(
            f"engine = {name!r}: must be one of {', '.join(registry)}{_suggest(name)}"
        )
    module_name, _, attr = registry[name].partition(":")
    return getattr(importlib.import_module(module_name), attr)


def get_adapter(name: str) -> Adapter:
    """Import and instantiate the adapter registered as ``name``.

    Raises ValueError for an unknown name and :class:`EngineUnavailable` when the engine's
    package is not installed.
    """
    cls = adapter_class(name)
    if name in _disabled():
        raise EngineUnavailable(name, f"disabled by {DISABLE_ENV}")
    return cls()


def parameter_keys(name: str) -> tuple[str, ...]:
    """The ``custom``-mode keys of engine ``name`` (:attr:`Adapter.parameter_keys`), read from
    the adapter class without importing the engine itself."""
    return tuple(adapter_class(name).parameter_keys)


def check_params(name: str, params: dict[str, Any]) -> None:
    """Validate ``custom`` values of engine ``name`` before any run. Through the class's
    :attr:`Adapter.value_check` where the adapter keeps the base :meth:`Adapter.check_params`
    (a parser in Python: the engine is not imported, and the values are checked whether it
    is installed or not); through an adapter's own :meth:`Adapter.check_params` otherwise,
    where the engine is installed (elsewhere its run checks them)."""
    cls = adapter_class(name)
    if cls.check_params is Adapter.check_params:
        if cls.value_check is not None:
            cls.value_check(dict(params))
        return
    try:
        adapter = get_adapter(name)
    except EngineUnavailable:
        return
    adapter.check_params(dict(params))


def available_engines() -> list[str]:
    """Registered engines whose package imports on this machine."""
    out = []
    for name in _registry():
        try:
            get_adapter(name).version()
        except EngineUnavailable:
            continue
        out.append(name)
    return out


def run_safely(engine: str, scenario: Scenario, mode: str = "native",
               settings: RunSettings | None = None) -> ImpactRecord:
    """Run and never raise for engine trouble: a missing engine becomes ``unavailable``,
    an exception inside the engine becomes ``crashed`` (with the error in the message).

    Bad input (unknown engine or mode, invalid settings) still raises ValueError.
    """
    registry = _registry()
    if engine not in registry:
        raise ValueError(
            f"engine = {engine!r}: must be one of {', '.join(registry)}{_suggest(engine)}"
        )
    if mode not in MODES:
        raise ValueError(f"mode = {mode!r}: must be one of {', '.join(MODES)}")
    meta = {"engine": engine, "mode": mode}
    try:
        adapter = get_adapter(engine)
    except EngineUnavailable as exc:
        return ImpactRecord.failed(Status.UNAVAILABLE, str(exc), **meta)
    try:
        return adapter.run(scenario, mode, settings)
    except (SettingsError, InvalidValue) as exc:  # bad input a builder found (a value
        raise ValueError(str(exc)) from None  # that breaks its rule): the one-line error
    except EngineUnavailable as exc:  # adapters import their engine lazily, inside run
        return ImpactRecord.failed(Status.UNAVAILABLE, str(exc), **meta)
    except Exception as exc:  # an engine failure must not lose the other results
        last = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return ImpactRecord.failed(Status.CRASHED, last, **meta)


def run_many_safely(engine: str, items: Sequence[tuple[Scenario, str, RunSettings | None]]
                    ) -> list[ImpactRecord]:
    """:func:`run_safely` of every ``(scenario, mode, settings)`` item, through
    :meth:`Adapter.run_many` (one call for a builder that batches); should the batch fail,
    each run again alone, so that each gets its own status."""
    try:
        adapter = get_adapter(engine)
        return adapter.run_many(items)
    except Exception:  # bad input, a missing engine, a crash: each alone says which
        return [run_safely(engine, *item) for item in items]
