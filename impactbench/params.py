"""Command-line flags of the scenarios' physical parameters, shared by every subcommand.

One table per scenario maps a flag to the scenario field it sets and its help text, so the
``reference``, ``sweep``, ``run`` and ``tune`` commands accept the same flags with the same
defaults (the papers'), and a scenario is built and validated in one place.
"""

from __future__ import annotations

import argparse
from typing import Any

from impactbench.cliutil import number
from impactbench.reference.laws import LOCAL_LAWS, STRUCTURAL_LAWS
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

BALL_FLAGS: dict[str, tuple[str, str]] = {
    "mass": ("mass_kg", "ball mass (kg)"),
    "stiffness": ("stiffness", "Hunt–Crossley stiffness c (N/m^n)"),
    "exponent": ("exponent", "force-law exponent n (1.5 Hertz, 1 linear)"),
    "damping": ("damping_s_per_m", "Hunt–Crossley damping b (s/m)"),
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
    group = parser.add_argument_group("physical parameters (SI; defaults are the paper's)")
    for flag, (field, help_text) in SCENARIO_FLAGS[scenario].items():
        group.add_argument(f"--{flag}", type=number, default=getattr(defaults, field),
                           dest=field, metavar="X",
                           help=f"{help_text}; default {getattr(defaults, field):g}")
    if scenario == "ball-on-plate" and with_gravity:
        group.add_argument("--gravity", type=number, default=0.0, dest="gravity_m_s2",
                           metavar="G", help="gravity (m/s², engines only); default 0 (off)")


def add_law_flags(parser: argparse.ArgumentParser, *, default: str | None = "linear") -> None:
    """Add ``--local`` and ``--structure`` (rigid–flexible law choices)."""
    parser.add_argument("--local", choices=tuple(LOCAL_LAWS), default=default,
                        help=f"local contact law; default {default}")
    parser.add_argument("--structure", choices=tuple(STRUCTURAL_LAWS), default=default,
                        help=f"structural law; default {default}")


def scenario_from_args(scenario: str, args: argparse.Namespace,
                       **overrides: Any) -> BallOnPlate | RigidFlexible:
    """Build and validate the scenario from parsed flags (overrides win)."""
    cls = SCENARIO_CLASSES[scenario]
    fields = set(cls.field_names())
    values = {k: v for k, v in vars(args).items() if k in fields and v is not None}
    values.update(overrides)
    return cls(**values)
