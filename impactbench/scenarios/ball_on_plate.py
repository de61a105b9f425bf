"""The ball-on-plate scenario: a ball hitting a massive plate head-on (MODELS.md §1).

Physics: :class:`~impactbench.reference.scenarios.BallOnPlate` (Hunt–Crossley contact
F = c·xⁿ·(1 + b·ẋ), or any law of the zoo); reference: the Lambert-W closed form
(:mod:`impactbench.reference.hunt_crossley`). One point per impact velocity V0 (m/s).
Its subcommands (``reference ball-on-plate``, ``sweep ball-on-plate``) are in
:mod:`impactbench.commands.ball_on_plate`.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any

from impactbench.scenarios.spec import Axis, Flag, ScenarioSpec

NAME = "ball-on-plate"

FLAGS = (
    Flag("mass", "mass_kg", "ball mass (kg)"),
    Flag("stiffness", "stiffness",
         "Hunt–Crossley stiffness c (N/m^n; N/m for the linear models)"),
    Flag("exponent", "exponent", "force-law exponent n (1.5 Hertz, 1 linear)"),
    Flag("damping", "damping_s_per_m", "Hunt–Crossley damping b (s/m)"),
    Flag("radius", "radius_m", "ball radius R (m)"),
)


@dataclass(frozen=True)
class BallOnPlateSpec(ScenarioSpec):
    """The ball on the plate: its dataclass, the Lambert-W closed form, the plausibility of a
    run (overlap over the radius, e²), the contact-model and material flags, the report's F–x
    loops and restitution figure."""

    @property
    def cls(self) -> type:
        from impactbench.reference.scenarios import BallOnPlate

        return BallOnPlate

    def reference_metrics(self, scenario: Any) -> dict[str, Any]:
        """The closed-form metrics (restitution, duration_s, peak_force_n, max_penetration_m,
        energy_loss_fraction)."""
        from impactbench.reference import hunt_crossley

        return dict(hunt_crossley.solve(scenario))

    def history(self, scenario: Any) -> Any:
        from impactbench.reference import hunt_crossley

        return hunt_crossley.history(scenario)

    def measure(self, scenario: Any, rec: Any, metrics: dict[str, Any]) -> dict[str, float]:
        """The contact's sinking beyond the step's own overlap and that overlap, over the
        ball's radius (from the record itself, :func:`impactbench.plausibility.overlaps`),
        and the kinetic energy after over before, e² (ball on a fixed plate)."""
        import math

        from impactbench.plausibility import overlap_measures

        e = float(metrics.get("restitution", math.nan))
        return {**overlap_measures(rec, scenario.radius_m, scenario.gravity_m_s2),
                "energy_ratio": e * e}

    def problem(self, scenario: Any, ref: dict[str, Any]) -> str:
        """An indentation beyond the ball's radius: no contact law holds there."""
        return scenario.penetration_problem(float(ref.get("max_penetration_m", 0.0)))

    def add_options(self, group: argparse._ArgumentGroup, with_gravity: bool = True) -> None:
        """The contact model (zoo), the nominal restitution, the ball's material, a scenario file
        and (engines only: the reference is the paper's gravity-free impact) ``--gravity``."""
        from impactbench.cliutil import number
        from impactbench.reference.materials import materials
        from impactbench.reference.models import MODELS

        group.add_argument("--model", choices=MODELS, default=None,
                           help="contact model (default hunt-crossley; every other model needs "
                           "--nominal-restitution)")
        group.add_argument("--nominal-restitution", type=number, default=None,
                           dest="nominal_restitution", metavar="E",
                           help="nominal restitution e in (0, 1] the model's damping is set from "
                           "at each impact velocity (replaces --damping)")
        names = ", ".join(materials())
        # no argparse choices: a misspelt name gets the one-line error with a "did you mean"
        group.add_argument("--material", default=None, metavar="NAME",
                           help=f"ball material ({names}): mass from --radius and density, Hertz "
                           "c on the plate from E and ν, damping from its nominal restitution e "
                           "(explicit --mass, --damping, --nominal-restitution win)")
        group.add_argument("--plate-material", default=None, metavar="NAME",
                           help=f"plate material for the Hertz c ({names}; default steel)")
        group.add_argument("--youngs-modulus", type=number, default=None, dest="youngs_modulus_pa",
                           metavar="PA", help="ball Young's modulus E (Pa), with --poisson: "
                           "Hertz c (overrides the material's)")
        group.add_argument("--poisson", type=number, default=None, metavar="NU",
                           help="ball Poisson's ratio ν (overrides the material's)")
        group.add_argument("--scenario-file", default=None, metavar="FILE",
                           help="TOML with a [ball_on_plate] table of scenario fields (e.g. from "
                           "impactbench calibrate); flags given here override it")
        if with_gravity:
            group.add_argument("--gravity", type=number, default=0.0, dest="gravity_m_s2",
                               metavar="G", help="gravity (m/s², engines only); default 0 (off)")

    def from_args(self, args: argparse.Namespace, values: dict[str, Any]) -> dict[str, Any]:
        """Fill mass, c, n and R from a material or elastic constants, when given, and the damping
        from the material's nominal restitution e (``nominal_restitution``: the model derives b
        from e at each impact velocity) unless ``damping_s_per_m`` or ``nominal_restitution`` is
        given; a scenario file's fields under the flags.

        ``values`` holds the fields given explicitly. Also applies a config's or a scenario file's
        ``material``/``plate_material``/``youngs_modulus_pa``/``poisson`` keys (``args`` is then a
        namespace of those)."""
        material = getattr(args, "material", None)
        young = getattr(args, "youngs_modulus_pa", None)
        poisson = getattr(args, "poisson", None)
        plate = getattr(args, "plate_material", None)
        if material is None and young is None and poisson is None:
            if plate is not None:
                raise ValueError(f"plate_material = {plate!r}: needs --material or "
                                 "--youngs-modulus/--poisson")
        else:
            if "stiffness" in values:
                raise ValueError(f"stiffness = {values['stiffness']!r}: give either --stiffness "
                                 "or a material (--material, --youngs-modulus/--poisson), not both")
            if values.get("exponent", 1.5) != 1.5:
                raise ValueError(f"exponent = {values['exponent']!r}: a material gives the Hertz "
                                 "law; must be 1.5")
            from impactbench.reference.materials import ball_parameters
            from impactbench.reference.scenarios import BallOnPlate

            ball = ball_parameters(
                values.get("radius_m", BallOnPlate().radius_m), material_name=material,
                youngs_modulus_pa=young, poisson=poisson, mass_kg=values.get("mass_kg"),
                plate_material=plate or "steel")
            e = ball.pop("nominal_restitution")
            values.update(ball)
            if e is not None and "damping_s_per_m" not in values \
                    and "nominal_restitution" not in values:
                values["nominal_restitution"] = e  # the material's bounce (explicit b or e win)
        if getattr(args, "scenario_file", None):
            from impactbench.scenario_file import load_scenario_file

            base = load_scenario_file(args.scenario_file)
            if "damping_s_per_m" in values and "nominal_restitution" not in values \
                    and values.get("model", base.get("model", "hunt-crossley")) == "hunt-crossley":
                base.pop("nominal_restitution", None)  # an explicit b wins over the file's e
            values = {**base, **values}
        return values

    def report_figures(self, ctx: Any, runs: list, loops: list) -> None:
        """The ball's extra report figures: the F–x hysteresis loop per velocity (``loops``:
        (title, how, point, histories, reference)) and restitution against V0."""
        spec = self
        from impactbench import plots
        from impactbench.report import cfg_parameter, modes_text, timestep_text

        for title, how, point, hist, ref in loops:
            name = f"report_hysteresis_{spec.figure_name(point)}.png"
            path = ctx.draw(plots.hysteresis, hist, ref, title, how, ctx.fig_dir / name)
            ctx.add_figure(path, f"F–x loop, {title}; {how}", f"history:{spec.name}")
        if not runs:
            return
        vs = ", ".join(f"{v:g}" for v in sorted({r.job.get('velocity_m_s') for r in runs}))
        how = f"V0 = {vs} m/s; {modes_text(runs)}; {timestep_text(runs)}"
        b = cfg_parameter(ctx.cfg, spec.name, "damping_s_per_m")
        sm = next((s for s in ctx.cfg.scenarios if s.name == spec.name), None)
        model = spec.build(parameters=sm.parameters if sm is not None else {})
        path = ctx.draw(plots.restitution_vs_velocity, ctx.df, b, how,
                        ctx.fig_dir / "report_restitution_vs_velocity.png", scenario=model)
        ctx.add_figure(path, f"Restitution against V0, ball on plate; {how}", f"extra:{spec.name}")


SPEC = BallOnPlateSpec(
    name=NAME,
    title="Ball on plate",
    summary="the steel ball on a massive plate, Hunt–Crossley closed form",
    metrics=("restitution", "duration_s", "peak_force_n", "max_penetration_m",
             "energy_loss_fraction"),
    headline=("restitution", "duration_s", "peak_force_n"),
    axes=(Axis("velocity_m_s", "velocities_m_s", "V0 (m/s)", short="v"),),
    table="ball_on_plate",
    flags=FLAGS,
    gate_velocities_m_s=(0.5, 1.0, 2.0, 3.0, 4.0, 5.0),
    native={"": "a linear spring–damper matched to the reference at 1 m/s",
            "pymunk": "a rigid contact with the reference restitution at 1 m/s"},
    figure_stem="ball",
    velocity_symbol="V0",
    studies=("work_precision", "practical", "tuning", "calibrate"),
)
