"""Command-line flags of the scenarios' physical parameters, shared by every subcommand.

One table per scenario maps a flag to the scenario field it sets and its help text, so the
``reference``, ``sweep``, ``run`` and ``tune`` commands accept the same flags with the same
defaults (the papers'), and a scenario is built and validated in one place.
"""

from __future__ import annotations

import argparse
from typing import Any

from impactbench.cliutil import number
from impactbench.reference.laws import ALL_LOCAL_LAWS, STRUCTURAL_LAWS
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

BALL_FLAGS: dict[str, tuple[str, str]] = {
    "mass": ("mass_kg", "ball mass (kg)"),
    "stiffness": ("stiffness", "Hunt–Crossley stiffness c (N/m^n; N/m for the linear models)"),
    "exponent": ("exponent", "force-law exponent n (1.5 Hertz, 1 linear)"),
    "damping": ("damping_s_per_m", "Hunt–Crossley damping b (s/m)"),
    "radius": ("radius_m", "ball radius R (m)"),
}

RIGID_FLEXIBLE_FLAGS: dict[str, tuple[str, str]] = {
    "m1": ("m1_kg", "rigid body mass m1 (kg)"),
    "m2": ("m2_kg", "flexible body mass m2 (kg)"),
    "k1": ("k1_n_per_m", "local contact stiffness k1 (N/m)"),
    "k2": ("k2_n_per_m", "structural stiffness k2 (N/m)"),
    "kt": ("kt_n_per_m", "elastoplastic hardening stiffness kt (N/m)"),
    "k1-failed": ("k1_failed_n_per_m", "stiffness after local failure k1' (N/m)"),
    "eps-s": ("eps_s_m", "elastoplastic yield penetration εs (m)"),
    "beta": ("beta_n_per_m3", "cubic softening coefficient β (N/m³)"),
    "fm": ("fm_n", "failure force F_m of the mutation law (N)"),
}

SCENARIO_FLAGS = {"ball-on-plate": BALL_FLAGS, "rigid-flexible": RIGID_FLEXIBLE_FLAGS}
SCENARIO_CLASSES = {"ball-on-plate": BallOnPlate, "rigid-flexible": RigidFlexible}


def add_parameter_flags(parser: argparse.ArgumentParser, scenario: str, *,
                        with_gravity: bool = True) -> None:
    """Add the physical-parameter flags of ``scenario`` (defaults: the paper's values).

    ``with_gravity`` adds the ball's ``--gravity`` (engines only: the reference is the
    paper's gravity-free collinear impact)."""
    defaults = SCENARIO_CLASSES[scenario]()
    label = "ball on plate" if scenario == "ball-on-plate" else "rigid–flexible"
    group = parser.add_argument_group(f"{label}: physical parameters (SI; defaults are the "
                                      "paper's)")
    ball = scenario == "ball-on-plate"
    for flag, (field, help_text) in SCENARIO_FLAGS[scenario].items():
        # ball flags default to None (the scenario's default applies) so that a material
        # can tell an explicit --mass or --stiffness from the default
        group.add_argument(f"--{flag}", type=number,
                           default=None if ball else getattr(defaults, field),
                           dest=field, metavar="X",
                           help=f"{help_text}; default {getattr(defaults, field):g}")
    if ball:
        _add_ball_model_flags(group)
    if ball and with_gravity:
        group.add_argument("--gravity", type=number, default=0.0, dest="gravity_m_s2",
                           metavar="G", help="gravity (m/s², engines only); default 0 (off)")


def _add_ball_model_flags(group: argparse._ArgumentGroup) -> None:
    """The contact model (zoo), the nominal restitution and the ball's material."""
    from impactbench.reference.materials import materials
    from impactbench.reference.models import MODELS

    group.add_argument("--model", choices=MODELS, default=None,
                       help="contact model (default hunt-crossley; every other model needs "
                       "--nominal-restitution)")
    group.add_argument("--nominal-restitution", type=number, default=None,
                       dest="nominal_restitution", metavar="E",
                       help="nominal restitution e in (0, 1] the model's damping is set from "
                       "at each impact velocity (replaces --damping)")
    group.add_argument("--material", choices=tuple(materials()), default=None,
                       help="ball material: mass from --radius and density, Hertz c on the "
                       "plate from E and ν (explicit --mass wins)")
    group.add_argument("--plate-material", choices=tuple(materials()), default=None,
                       help="plate material for the Hertz c (default steel)")
    group.add_argument("--youngs-modulus", type=number, default=None, dest="youngs_modulus_pa",
                       metavar="PA", help="ball Young's modulus E (Pa), with --poisson: "
                       "Hertz c (overrides the material's)")
    group.add_argument("--poisson", type=number, default=None, metavar="NU",
                       help="ball Poisson's ratio ν (overrides the material's)")
    group.add_argument("--scenario-file", default=None, metavar="FILE",
                       help="TOML with a [ball_on_plate] table of scenario fields (e.g. from "
                       "impactbench calibrate); flags given here override it")


def _ball_values(args: argparse.Namespace, values: dict[str, Any]) -> dict[str, Any]:
    """Fill mass, c, n and R from a material or elastic constants, when given."""
    material = getattr(args, "material", None)
    young = getattr(args, "youngs_modulus_pa", None)
    poisson = getattr(args, "poisson", None)
    plate = getattr(args, "plate_material", None)
    if material is None and young is None and poisson is None:
        if plate is not None:
            raise ValueError(f"plate_material = {plate!r}: needs --material or "
                             "--youngs-modulus/--poisson")
        return values
    if "stiffness" in values:
        raise ValueError(f"stiffness = {values['stiffness']!r}: give either --stiffness or "
                         "a material (--material, --youngs-modulus/--poisson), not both")
    if values.get("exponent", 1.5) != 1.5:
        raise ValueError(f"exponent = {values['exponent']!r}: a material gives the Hertz "
                         "law; must be 1.5")
    from impactbench.reference.materials import ball_parameters

    values.update(ball_parameters(
        values.get("radius_m", BallOnPlate().radius_m), material_name=material,
        youngs_modulus_pa=young, poisson=poisson, mass_kg=values.get("mass_kg"),
        plate_material=plate or "steel"))
    return values


def add_law_flags(parser: argparse.ArgumentParser, *, default: str | None = "linear") -> None:
    """Add ``--local`` and ``--structure`` (rigid–flexible law choices)."""
    which = f"default {default}" if default else "default: every one, in turn"
    parser.add_argument("--local", choices=tuple(ALL_LOCAL_LAWS), default=default,
                        help=f"local contact law; {which}")
    parser.add_argument("--structure", choices=tuple(STRUCTURAL_LAWS), default=default,
                        help=f"structural law; {which}")


def scenario_from_args(scenario: str, args: argparse.Namespace,
                       **overrides: Any) -> BallOnPlate | RigidFlexible:
    """Build and validate the scenario from parsed flags (overrides win)."""
    cls = SCENARIO_CLASSES[scenario]
    fields = set(cls.field_names())
    values = {k: v for k, v in vars(args).items() if k in fields and v is not None}
    if cls is BallOnPlate:
        values = _ball_values(args, values)
        if getattr(args, "scenario_file", None):
            from impactbench.scenario_file import load_scenario_file

            values = {**load_scenario_file(args.scenario_file), **values}
    values.update(overrides)
    return cls(**values)
