"""The cube-toss scenario: real motion-capture tosses of a cube onto a board (MODELS.md §4).

Data-driven: its reference is the measurement (DAIR Lab's ContactNets tosses, or a user's CSV
of the same columns, :mod:`impactbench.cube_tosses.data`), its points are tosses, and it splits
into train and test (a hash of the toss id, 80/20). An engine run is a *replay*
(DAIR's protocol): each selected toss started from its measured state near the first impact and
simulated to its end, through the engines' cube-toss builders like every other scenario
(:func:`impactbench.engines.cube_toss.replay_tosses`, asking this dataclass for its inputs:
:meth:`CubeToss.starts`, :meth:`~CubeToss.box`, :meth:`~CubeToss.engine_parameters`,
:meth:`~CubeToss.injected_law`); the metrics are, over tosses, the median, quartiles and mean
of each toss's time-mean position error (a fraction of the cube's width 2h) and rotation error
(degrees), errors against the measurement (:mod:`impactbench.cube_tosses.scenario`). The spec
has no axes: a run is one point, ``()``. Its subcommand (``reference cube-toss``: what the
selected measurement holds) is in :mod:`impactbench.commands.cube_toss`; the report's "Against
real tosses" section runs it when a config has a ``[cube_toss]`` table.

This module imports nothing heavy (the command line builds its flags from the dataclass).
"""

from __future__ import annotations

import argparse
import math
import os
from dataclasses import asdict, dataclass, fields
from typing import Any, ClassVar

from impactbench.reference import validation as check
from impactbench.scenarios.spec import Flag, ScenarioSpec

NAME = "cube-toss"
TABLE = "cube_toss"

HALF_WIDTH_M = 0.0524
MASS_KG = 0.37
INERTIA_KG_M2 = 0.00081
SAMPLE_DT_S = 1.0 / 148.0
SUBSTEPS = 10
"""DAIR's cube and protocol (:mod:`impactbench.cube_tosses.protocol`'s values, named here
without importing numpy; tested equal)."""

SPLITS = ("test", "train", "all")
START_RULES = ("drop", "first")
VELOCITY_FITS = ("dair", "lstsq")

METRICS: tuple[str, ...] = (
    "position_error_median", "position_error_q1", "position_error_q3", "position_error_mean",
    "rotation_error_deg_median", "rotation_error_deg_q1", "rotation_error_deg_q3",
    "rotation_error_deg_mean",
)
"""Over the replayed tosses: each toss's time-mean position error |Δp|/(2h) and rotation
error (degrees), their median, quartiles and mean (``replay()``'s keys)."""


def parse_tosses(text: str) -> str | list[int]:
    """A toss selection: a split name (test, train, all) or ids ``0,1,57`` (one-line
    ValueError otherwise)."""
    text = str(text).strip()
    if text in SPLITS:
        return text
    parts = [p.strip() for p in text.split(",")]
    if not text or not all(p.isdigit() for p in parts):
        raise ValueError(f"tosses = {text!r}: must be test, train, all or toss ids separated "
                         "by commas (0,1,57)")
    return [int(p) for p in parts]


@dataclass(frozen=True)
class CubeToss:
    """The cube tosses to replay: the box, the data, the tosses and DAIR's protocol options.

    Attributes:
        half_width_m: half the cube's edge h (m): the box the engines build, the start rule's
            h·√3 and the error's width 2h.
        mass_kg: the cube's mass (kg).
        inertia_kg_m2: its moment of inertia about each principal axis (kg·m²).
        data: a CSV of tosses (:mod:`impactbench.cube_tosses.data`'s columns); "" for the
            packaged ContactNets tosses.
        tosses: ``test``, ``train``, ``all`` or ids ``0,1,57``; None (the default) is ``test`` for
            the packaged data and ``all`` for a user's file (normalised on construction).
        substeps: engine steps per sample interval (DAIR: 10; the engine step is
            sample_dt_s / substeps).
        start_rule, samples_before, refit, min_preceding, velocity_fit, sample_dt_s,
        board_z_m: :class:`~impactbench.cube_tosses.protocol.Protocol`'s options (DAIR's by
            default; ``sample_dt_s = None``: each toss's median interval).
    """

    name: ClassVar[str] = NAME

    half_width_m: float = HALF_WIDTH_M
    mass_kg: float = MASS_KG
    inertia_kg_m2: float = INERTIA_KG_M2
    data: str = ""
    tosses: str | None = None
    substeps: int = SUBSTEPS
    start_rule: str = "drop"
    samples_before: int = 3
    refit: bool = True
    min_preceding: int = 4
    velocity_fit: str = "dair"
    sample_dt_s: float | None = SAMPLE_DT_S
    board_z_m: float = 0.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for name in ("half_width_m", "mass_kg", "inertia_kg_m2"):
            set_(self, name, check.positive(name, getattr(self, name)))
        if not isinstance(self.data, str):
            raise ValueError(f"data = {self.data!r}: must be a path (a string)")
        if self.data and not os.path.isfile(self.data):
            raise ValueError(f"data = {self.data!r}: no such file")
        if self.tosses is None:  # (an empty selection, "", is an error: parse_tosses)
            set_(self, "tosses", "all" if self.data else "test")
        selection = parse_tosses(self.tosses)
        set_(self, "tosses", selection if isinstance(selection, str)
             else ",".join(str(i) for i in selection))
        for name, low in (("substeps", 1), ("samples_before", 0), ("min_preceding", 2)):
            value = getattr(self, name)
            if isinstance(value, bool) or not (isinstance(value, int) or (
                    isinstance(value, float) and value.is_integer())) or value < low:
                raise ValueError(f"{name} = {value!r}: must be an integer >= {low}")
            set_(self, name, int(value))
        check.one_of("start_rule", self.start_rule, START_RULES)
        check.one_of("velocity_fit", self.velocity_fit, VELOCITY_FITS)
        if not isinstance(self.refit, bool):
            raise ValueError(f"refit = {self.refit!r}: must be true or false")
        if self.sample_dt_s is not None:
            set_(self, "sample_dt_s", check.positive("sample_dt_s", self.sample_dt_s))
        if isinstance(self.board_z_m, bool) or not isinstance(self.board_z_m, int | float) \
                or not math.isfinite(self.board_z_m):
            raise ValueError(f"board_z_m = {self.board_z_m!r}: must be a finite number (m)")
        set_(self, "board_z_m", float(self.board_z_m))

    # -- what the engines' cube-toss builder asks of the scenario (engines import nothing
    # from the suite: these methods are the scenario's side of the door)
    def starts(self) -> tuple[list[Any], list[dict[str, Any]]]:
        """(the selected tosses' replay starts, a ``failed`` row per toss that cannot start)."""
        from impactbench.cube_tosses.scenario import starts

        return starts(self)

    def box(self) -> Any:
        """The cube as the engines build it (:class:`~impactbench.reference.box_contact.Box`)."""
        from impactbench.cube_tosses.scenario import box_of

        return box_of(self)

    def step_s(self) -> float:
        """The engine step (s): the sample interval over the substeps."""
        from impactbench.cube_tosses.scenario import step_s

        return step_s(self)

    def engine_parameters(self, engine: str, mode: str, params: Any, tuned: Any
                          ) -> dict[str, Any]:
        """The engine parameters a replay in ``mode`` sets (one-line ValueError for bad ones)."""
        from impactbench.cube_tosses.scenario import engine_parameters

        return engine_parameters(engine, self, mode, params, tuned)

    def injected_law(self) -> Any:
        """The reference model's fitted contact, applied in ``injected`` mode."""
        from impactbench.cube_tosses.scenario import injected_law

        return injected_law(self)

    @property
    def selection(self) -> str | list[int]:
        """The tosses as ``replay()`` takes them: a split name or a list of ids."""
        return parse_tosses(self.tosses)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def replace(self, **changes: Any) -> CubeToss:
        from dataclasses import replace

        return replace(self, **changes)

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))


FLAGS = (
    Flag("half-width", "half_width_m", "cube tosses: the cube's half width h (m)"),
    Flag("mass", "mass_kg", "body mass (kg; the ball, or the tossed cube)"),
    Flag("inertia", "inertia_kg_m2",
         "cube tosses: the cube's moment of inertia about each principal axis (kg·m²)"),
)

DESCRIPTIONS = {
    "half_width_m": "half the cube's edge h (m)",
    "mass_kg": "the cube's mass (kg)",
    "inertia_kg_m2": "the cube's moment of inertia about each principal axis (kg·m²)",
    "data": "the tosses' CSV (empty: the packaged ContactNets tosses)",
    "tosses": "the tosses replayed: test, train, all or ids",
    "substeps": "engine steps per motion-capture sample (DAIR: 10, a 1/1480 s step)",
    "start_rule": "where a replay starts: drop (3 samples before the centre drops below "
                  "h·√3) or first",
    "samples_before": "samples before the drop the replay starts",
    "refit": "refit the start velocities from the preceding samples",
    "min_preceding": "fewest preceding samples a refit needs",
    "velocity_fit": "dair (DAIR's formulas) or lstsq",
    "sample_dt_s": "the motion capture's sample interval (s)",
    "board_z_m": "height of the board's surface in the data's frame (m)",
}


def _side() -> Any:
    """The scenario's side of a replay (inputs, scoring, store key, step, tuned files),
    imported when first used: it needs numpy and pandas."""
    import impactbench.cube_tosses.scenario as side

    return side


@dataclass(frozen=True)
class CubeTossSpec(ScenarioSpec):
    """The cube tosses' behaviour: a measured scenario, its reference the measurement and
    its metrics errors against it (:mod:`impactbench.cube_tosses.scenario` holds the
    functions each method calls)."""

    @property
    def cls(self) -> type:
        return CubeToss

    @property
    def measured(self) -> bool:
        return True


    def metrics_of(self, record: Any, scenario: Any) -> dict[str, Any]:
        return dict(_side().record_metrics(record, scenario))

    def run_details(self, record: Any, scenario: Any, mode: str) -> dict[str, Any]:
        return dict(_side().details(record, scenario, mode))

    def run_errors(self, run: Any, metrics: Any, reference: Any, resolved: Any
                   ) -> dict[str, float]:
        return dict(_side().errors(run, metrics))

    def store_inputs(self, engine: str, scenario: Any, mode: str) -> dict[str, Any]:
        return dict(_side().key_inputs(engine, scenario, mode))

    def at_timestep(self, scenario: Any, timestep_s: float | None) -> tuple[Any, str]:
        return _side().with_timestep(scenario, timestep_s)

    def load_tuned(self, engine: str, scenario: Any, timestep_s: float | None,
                   tuned_file: Any = None, variant: Any = None) -> tuple[Any, Any]:
        """The cube tosses' own tuned files (``data/tuned/cube_toss/<engine>.toml``), bound to
        the protocol's step and the cube's half width (the scenario already at the step)."""
        return _side().tuned_settings(engine, scenario, tuned_file)

    def reference_metrics(self, scenario: CubeToss) -> dict[str, Any]:
        """What the measurement holds for the selected tosses (``reference cube-toss --json``)."""
        from impactbench.cube_tosses.scenario import measurement

        return measurement(scenario)

    def report_part(self, ctx: Any, table: Any) -> dict[str, Any]:
        from impactbench.cube_tosses.report_part import report_part

        return report_part(ctx, self, table)

    def report_jobs(self, cfg: Any, table: Any, engines: Any) -> list:
        """The replays of the config's ``[cube_toss]`` table (engines, modes, parameter sets),
        planned with the matrix (:func:`impactbench.cube_tosses.report_part.replay_jobs`)."""
        from impactbench.cube_tosses.report_part import replay_jobs

        return replay_jobs(cfg, self, table, engines)

    def report_background(self, cfg: Any, table: Any, store: Any) -> dict[str, Any]:
        """The reference model's replay (``model = true``, the default), unless ``store``
        has it: ~6 s of scipy on one core, which ran in the report's process after the
        engines' runs."""
        import functools

        from impactbench.cube_tosses.scenario import model_replay, model_stored

        if not cfg.raw.get(self.table, {}).get("model", True):
            return {}
        scenario = self.build(parameters=table.parameters)
        if model_stored(scenario, store):
            return {}
        return {f"{self.name}:model": functools.partial(model_replay, scenario)}

    def estimated_steps(self, scenario: Any, reference: Any, timestep_s: Any) -> float:
        """A replay's engine steps: every sample of the selected tosses, ``substeps`` each."""
        samples = reference.get("samples", 0) if isinstance(reference, dict) else 0
        return float(samples) * scenario.substeps

    def kept_history(self, record: Any, run: Any, scenario: Any) -> dict[str, Any]:
        """The best, median and worst toss's trajectories, for the report's figures."""
        return dict(_side().kept_history(record, run, scenario))

    def add_options(self, group: argparse._ArgumentGroup, with_gravity: bool = True) -> None:
        """The data file and the toss selection (``with_gravity`` is the ball's; unused)."""
        group.add_argument("--data", default=None, metavar="FILE",
                           help="cube tosses: a CSV of tosses (columns toss, sample, t_s, x_m … "
                           "wz_rad_s; impactbench/cube_tosses/data.py); default the packaged "
                           "ContactNets tosses")
        group.add_argument("--tosses", default=None, metavar="WHICH",
                           help="cube tosses: test, train, all or ids 0,1,57 (default test; with "
                           "--data, every toss of the file)")


SPEC = CubeTossSpec(
    name=NAME,
    title="Cube tosses",
    summary="real motion-capture tosses of a cube onto a board, replayed (DAIR's protocol); "
            "the measurement is the reference",
    metrics=METRICS,
    headline=("position_error_median", "rotation_error_deg_median"),
    axes=(),
    table=TABLE,
    flags=FLAGS,
    gate_velocities_m_s=(),
    figure_stem="cube_toss",
    velocity_symbol="",
    descriptions=DESCRIPTIONS,
    default_mode="default",
    # a box with eight corners on a board, in injected mode the model's corner law in Python
    # every step: measured 20–160 µs a step (MuJoCo native … DART injected), against the
    # suite's prior of 20 µs (impactbench.cluster.STEP_S)
    step_cost=5.0,
)
