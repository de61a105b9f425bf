"""The rigid-flexible scenario: a rigid body hitting a constrained flexible body (MODELS.md §2).

Physics: :class:`~impactbench.reference.scenarios.RigidFlexible` (Zhou & Xiao's 2-DOF model with
linear, elastoplastic or stiffness-mutation local laws on a linear or softening structure);
reference: the event-driven solver (:mod:`impactbench.reference.two_dof`). One point per law
pair (local, structure) and impact velocity v1 (m/s). Its subcommands (``reference
rigid-flexible``, ``sweep rigid-flexible``) are in :mod:`impactbench.commands.rigid_flexible`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from impactbench.scenarios.spec import Axis, Flag, ScenarioSpec

NAME = "rigid-flexible"

METRICS: tuple[str, ...] = ("peak_force_n", "pulse_width_s", "contact_time_s", "impulse_ns",
                            "impacts")
"""The 2-DOF solver's ``METRIC_KEYS`` (tested equal), named here without importing it."""

FLAGS = (
    Flag("m1", "m1_kg", "rigid body mass m1 (kg)"),
    Flag("m2", "m2_kg", "flexible body mass m2 (kg)"),
    Flag("k1", "k1_n_per_m", "local contact stiffness k1 (N/m)"),
    Flag("k2", "k2_n_per_m", "structural stiffness k2 (N/m)"),
    Flag("kt", "kt_n_per_m", "elastoplastic hardening stiffness kt (N/m)"),
    Flag("k1-failed", "k1_failed_n_per_m", "stiffness after local failure k1' (N/m)"),
    Flag("eps-s", "eps_s_m", "elastoplastic yield penetration εs (m)"),
    Flag("beta", "beta_n_per_m3", "cubic softening coefficient β (N/m³)"),
    Flag("fm", "fm_n", "failure force F_m of the mutation law (N)"),
)


def _laws(name: str) -> tuple[str, ...]:
    """A table of :mod:`impactbench.reference.laws` (imported when asked for)."""
    from impactbench.reference import laws

    return tuple(getattr(laws, name))


def _all_local_laws() -> tuple[str, ...]:
    return _laws("ALL_LOCAL_LAWS")


def _local_laws() -> tuple[str, ...]:
    return _laws("LOCAL_LAWS")


def _structural_laws() -> tuple[str, ...]:
    return _laws("STRUCTURAL_LAWS")


@dataclass(frozen=True)
class RigidFlexibleSpec(ScenarioSpec):
    """The rigid–flexible impact: its dataclass, the event-driven 2-DOF reference and the
    plausibility of a run."""

    @property
    def cls(self) -> type:
        from impactbench.reference.scenarios import RigidFlexible

        return RigidFlexible

    def reference_metrics(self, scenario: Any) -> dict[str, Any]:
        """The event-driven reference: status and the five pulse metrics."""
        from impactbench.reference import two_dof

        ref = two_dof.solve(scenario)
        return {"status": str(ref["status"]), **{k: ref[k] for k in METRICS}}

    def history(self, scenario: Any) -> Any:
        from impactbench.reference import two_dof

        return two_dof.simulate(scenario)

    def measure(self, scenario: Any, rec: Any, metrics: dict[str, Any]) -> dict[str, float]:
        """Body 1's kinetic energy after the last impact over before ((v1'/v1)²: body 2 starts at
        rest, so body 1 cannot leave with more than it brought). No size to measure penetration
        against: the local law's deformation is the physics here (NaN)."""
        import math

        v_end = float(rec.velocity_1_m_s[-1]) if len(rec) else math.nan
        return {"penetration_ratio": math.nan,
                "energy_ratio": (v_end / scenario.velocity_m_s) ** 2}


SPEC = RigidFlexibleSpec(
    name=NAME,
    title="Rigid–flexible",
    summary="a rigid body on a flexible body (2-DOF), event-driven reference",
    metrics=METRICS,
    headline=("peak_force_n", "pulse_width_s", "impulse_ns", "impacts"),
    axes=(Axis("local", "local", "local", choices=_all_local_laws, default=_local_laws),
          Axis("structure", "structure", "structure", choices=_structural_laws,
               default=_structural_laws),
          Axis("velocity_m_s", "velocities_m_s", "v1 (m/s)", short="v")),
    table="rigid_flexible",
    flags=FLAGS,
    gate_velocities_m_s=(2.0,),
    native={"": "a linear, undamped k1 contact, which cannot yield or fail",
            "pymunk": "a rigid, perfectly elastic contact with e = 1, which has no stiffness "
                      "k1 at all"},
    history_unit=(1e-3, "ms"),
    figure_stem="rf",
    velocity_symbol="v1",
)
