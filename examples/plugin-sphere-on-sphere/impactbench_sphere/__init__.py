"""Sphere on sphere: an example impactbench scenario plug-in.

A steel ball (mass m, radius R1) hits a fixed steel sphere (radius R2) head-on. The contact
is Hunt–Crossley, F = c·x^1.5·(1 + b·ẋ), with the Hertz constant of two spheres::

    c = (4/3)·E*·√R*,   1/R* = 1/R1 + 1/R2,   1/E* = (1 − ν²)/E + (1 − ν²)/E   (both steel)

The package is found by impactbench through its entry point (``pyproject.toml``)::

    [project.entry-points."impactbench.scenarios"]
    sphere-on-sphere = "impactbench_sphere:SPEC"

and then runs everywhere a built-in scenario does: ``impactbench run --scenario
sphere-on-sphere``, a ``[sphere_on_sphere]`` table in a report config, a ``[[gate]]`` with
``scenario = "sphere-on-sphere"``.

What it brings:

- :class:`SphereOnSphere`, the frozen, validated dataclass of its physical fields (what
  every scenario dataclass shares, ``to_dict``, ``replace`` and ``field_names``, from
  impactbench's ``ScenarioFields``);
- the reference: the Hunt–Crossley closed form of :meth:`SphereOnSphere.equivalent_ball`
  (exact, see there);
- engine builders (:attr:`SphereOnSphere.engine_builders`) for mujoco, pymunk and pybullet,
  whose adapters do not know this scenario.

Caveat, on purpose: this example's builders (:mod:`impactbench_sphere.engines`) do not build
a sphere-on-sphere geometry. They map the scenario to the engine's existing ball-on-plate
set-up (a ball of radius R* and Hertz constant c on a plate), which is the same
one-dimensional impact. The point of the example is the plug-in mechanics; a real plug-in
builds its own geometry in each engine (two sphere bodies, one of them fixed) and records its
own contact output.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from impactbench.engines.base import Builder
from impactbench.reference import validation as check
from impactbench.reference.scenarios import ScenarioFields, check_each

from impactbench.scenarios.spec import Axis, Flag, ScenarioSpec

NAME = "sphere-on-sphere"

STEP_S = 1e-6
"""The engines' step for this scenario (s): the one of their ball-on-plate builders."""


@dataclass(frozen=True)
class SphereOnSphere(ScenarioFields):
    """A steel ball hitting a fixed steel sphere head-on (SI units; gravity off by default).

    Attributes:
        velocity_m_s: impact velocity V0 of the moving ball (m/s).
        mass_kg: mass of the moving ball (kg); 0.1 kg is a steel ball of radius 1.452 cm.
        radius_m: radius R1 of the moving ball (m).
        target_radius_m: radius R2 of the fixed sphere (m).
        youngs_modulus_pa: Young's modulus E of both spheres (Pa).
        poisson: Poisson's ratio ν of both spheres.
        damping_s_per_m: Hunt–Crossley damping b (s/m).
        gravity_m_s2: gravity in the engines (m/s²); the reference is the gravity-free impact.
    """

    name: ClassVar[str] = NAME
    engine_builders: ClassVar[dict[str, Builder]] = {
        "mujoco": Builder("impactbench_sphere.engines:run", STEP_S),
        "pymunk": Builder("impactbench_sphere.engines:run", STEP_S),
        "pybullet": Builder("impactbench_sphere.engines:run", STEP_S),
    }
    """Engine → builder: engines whose adapters do not know this scenario run it through
    these (:meth:`impactbench.engines.base.Adapter.builder`)."""

    velocity_m_s: float = 1.0
    mass_kg: float = 0.1
    radius_m: float = 0.01452
    target_radius_m: float = 0.05
    youngs_modulus_pa: float = 2e11
    poisson: float = 0.25
    damping_s_per_m: float = 0.1
    gravity_m_s2: float = 0.0

    def __post_init__(self) -> None:
        """A bad field raises a one-line ValueError naming it, its value and its rule."""
        check_each(check.positive, self, "velocity_m_s", "mass_kg", "radius_m",
                   "target_radius_m", "youngs_modulus_pa")
        nu = check.finite("poisson", self.poisson)
        if not -1.0 < nu <= 0.5:
            raise ValueError(f"poisson = {self.poisson!r}: must be in (-1, 0.5] (an isotropic "
                             "elastic solid)")
        check_each(check.non_negative, self, "damping_s_per_m", "gravity_m_s2")

    # ------------------------------------------------------------------ physics
    @property
    def reduced_radius_m(self) -> float:
        """R* = R1·R2/(R1 + R2) (m)."""
        return 1.0 / (1.0 / self.radius_m + 1.0 / self.target_radius_m)

    @property
    def stiffness(self) -> float:
        """Hertz c = (4/3)·E*·√R* of the two steel spheres (N/m^1.5)."""
        from impactbench.reference.scenarios import hertz_stiffness

        return hertz_stiffness(self.radius_m, self.youngs_modulus_pa, self.poisson,
                               radius_2_m=self.target_radius_m,
                               young_2_pa=self.youngs_modulus_pa, poisson_2=self.poisson)

    def equivalent_ball(self) -> Any:
        """The ball-on-plate impact with the same equation of motion (a ``BallOnPlate``).

        Exact, not an approximation: Hertz's solution for two spheres in contact depends on
        their radii only through the reduced radius R* (1/R* = 1/R1 + 1/R2) and on their
        elastic constants only through E*; a ball of radius R* on a flat plate (R2 = ∞) with
        the same E* has the same force–indentation law F = c·x^1.5. The target sphere is
        fixed (immovable, an infinite mass), so the reduced mass is the ball's own m, as it
        is against the massive plate. Both impacts are therefore m·ẍ = −c·x^1.5·(1 + b·ẋ)
        from x = 0, ẋ = V0, and the ball's Hunt–Crossley closed form solves this one exactly.
        """
        from impactbench.reference.scenarios import BallOnPlate

        return BallOnPlate(velocity_m_s=self.velocity_m_s, mass_kg=self.mass_kg,
                           stiffness=self.stiffness, exponent=1.5,
                           damping_s_per_m=self.damping_s_per_m,
                           radius_m=self.reduced_radius_m, gravity_m_s2=self.gravity_m_s2)


# ---------------------------------------------------------------------------- the reference


def reference(scenario: SphereOnSphere) -> dict[str, Any]:
    """The closed-form metrics of the equivalent ball (restitution, duration_s, peak_force_n,
    max_penetration_m, energy_loss_fraction)."""
    from impactbench.reference import hunt_crossley

    return dict(hunt_crossley.solve(scenario.equivalent_ball()))


def history(scenario: SphereOnSphere) -> Any:
    """The reference's time history (an ImpactRecord) of the equivalent ball."""
    from impactbench.reference import hunt_crossley

    return hunt_crossley.history(scenario.equivalent_ball())


def reference_problem(scenario: SphereOnSphere, ref: dict[str, Any]) -> str:
    """An indentation beyond R*: no small-indentation contact law holds there."""
    return scenario.equivalent_ball().penetration_problem(
        float(ref.get("max_penetration_m", 0.0)))


@dataclass(frozen=True)
class SphereOnSphereSpec(ScenarioSpec):
    """What impactbench needs of this scenario beyond its data: its dataclass, its reference
    and the limit of its contact law (methods; every other one keeps the default)."""

    @property
    def cls(self) -> type:
        return SphereOnSphere

    def reference_metrics(self, scenario: SphereOnSphere) -> dict[str, Any]:
        return reference(scenario)

    def history(self, scenario: SphereOnSphere) -> Any:
        return history(scenario)

    def problem(self, scenario: SphereOnSphere, ref: Any) -> str:
        return reference_problem(scenario, ref)


SPEC = SphereOnSphereSpec(
    name=NAME,
    title="Sphere on sphere",
    summary="a steel ball on a fixed steel sphere, Hertz/Hunt–Crossley closed form (plug-in "
    "example)",
    metrics=("restitution", "duration_s", "peak_force_n", "max_penetration_m",
             "energy_loss_fraction"),
    headline=("restitution", "duration_s", "peak_force_n"),
    axes=(Axis("velocity_m_s", "velocities_m_s", "V0 (m/s)", short="v"),),
    table="sphere_on_sphere",
    # --mass, --radius and --damping are the ball-on-plate's flags for the same field names,
    # so they are shared; --youngs-modulus and --poisson (fields youngs_modulus_pa, poisson)
    # come from the ball-on-plate's own options and reach these fields by the same names
    flags=(
        Flag("mass", "mass_kg", "mass of the moving ball (kg)"),
        Flag("radius", "radius_m", "radius R of the moving ball (m)"),
        Flag("target-radius", "target_radius_m", "radius of the fixed target sphere (m)"),
        Flag("damping", "damping_s_per_m", "Hunt–Crossley damping b (s/m)"),
    ),
    gate_velocities_m_s=(1.0, 5.0),
    native={"": "the engine's ball-on-plate mapping, on the equivalent ball"},
    figure_stem="sphere",
    velocity_symbol="V0",
)
