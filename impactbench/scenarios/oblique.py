"""The oblique scenario: a sphere hitting a plate at an angle, with friction and spin
(MODELS.md §3).

Physics: :class:`~impactbench.reference.oblique_scenario.Oblique` (any normal law of the zoo,
Coulomb friction μ, initial spin ω0; a sphere, or for the 2D engines a disc); references: the
rigid tangential theory in closed form (``tangential = "rigid"``,
:mod:`impactbench.reference.oblique`) or a tangentially compliant law, integrated
(``tangential = "mindlin"``: Mindlin's no-slip spring; ``"mindlin-deresiewicz"``: with
micro-slip and the contact's memory; :mod:`impactbench.reference.oblique_integrate`). One
point per incidence angle θ (degrees from the normal) and impact speed V (m/s). Its
subcommand (``reference oblique``) is in :mod:`impactbench.commands.oblique`.

"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from typing import Any

from impactbench.reference.oblique_scenario import OBLIQUE_METRICS
from impactbench.scenarios.ball_on_plate import FLAGS as BALL_FLAGS
from impactbench.scenarios.spec import Axis, Flag, ScenarioSpec

NAME = "oblique"

METRICS: tuple[str, ...] = OBLIQUE_METRICS
"""The reference's metrics, in table order (numpy is not imported by that module)."""
"""The reference's ``OBLIQUE_METRICS`` (tested equal), named here without importing it."""

FLAGS = (
    Flag("angle-deg", "angle_deg", "incidence angle θ from the plate normal (degrees, in "
         "[0, 90))"),
    Flag("friction", "friction", "Coulomb friction coefficient μ (>= 0)"),
    Flag("spin", "spin_rad_s", "initial spin ω0 about n × t (rad/s; positive: forward "
         "rolling)"),
    *BALL_FLAGS,  # the ball's own: mass, stiffness, exponent, damping, radius
    Flag("youngs-modulus", "youngs_modulus_pa",
         "ball Young's modulus E (Pa): Mindlin's G*, and the Hertz c unless --stiffness"),
    Flag("poisson", "poisson", "ball Poisson's ratio ν"),
    Flag("plate-youngs-modulus", "plate_youngs_modulus_pa",
         "plate Young's modulus (Pa; the --case kharaz2001 plate is rigid, inf)"),
    Flag("plate-poisson", "plate_poisson", "plate Poisson's ratio"),
)

MATERIAL_FIELDS = ("youngs_modulus_pa", "poisson", "plate_youngs_modulus_pa", "plate_poisson")

DESCRIPTIONS = {
    "velocity_m_s": "impact speed V (m/s)",
    "tangential": "tangential contact: rigid (ideal Coulomb, closed form), mindlin (no-slip "
                  "spring k_t = 8·G*·a capped at μ·F_n, integrated) or mindlin-deresiewicz "
                  "(with micro-slip and the contact's memory, integrated)",
    "shape": "the ball: sphere (k² = 2R²/5) or disc (k² = R²/2; the 2D engines only)",
    "model": "normal contact model of the zoo, set up at the normal velocity V·cos θ",
    "nominal_restitution": "nominal restitution e of the normal law (its damping follows at "
                           "V·cos θ); none: the paper's b",
}


@dataclass(frozen=True)
class ObliqueSpec(ScenarioSpec):
    """The oblique impact: its dataclass, the rigid-Coulomb closed form (or the Mindlin
    integration), the tangential metrics of a record, plausibility with spin energy, its flags
    and the report's figures against incidence angle."""

    @property
    def cls(self) -> type:
        from impactbench.reference.oblique_scenario import Oblique

        return Oblique

    def reference_metrics(self, scenario: Any) -> dict[str, Any]:
        """The reference metrics: rigid closed form or the Mindlin integration."""
        from impactbench.reference import oblique

        return dict(oblique.solve(scenario))

    def history(self, scenario: Any) -> Any:
        """The integrated impact as an ImpactRecord (tangential arrays in ``meta``)."""
        from impactbench.reference import oblique_integrate

        return oblique_integrate.history(scenario)

    def measure(self, scenario: Any, rec: Any, metrics: dict[str, Any]) -> dict[str, float]:
        """The contact's sinking beyond the step's own overlap and that overlap, over the
        ball's radius (from the record, :func:`impactbench.plausibility.overlaps` along the
        normal), and the kinetic energy
        after over before, translation and spin: (m·(v_n'² + v_t'²) + I·ω'²)/(m·V² + I·ω0²),
        I = m·k² of the shape ((2/5)·m·R² sphere, (1/2)·m·R² disc), with v_n' = e·v_n and
        v_t' = e_t·V·sin θ (the tangential restitution; at θ = 0, v_t' = 0)."""
        from impactbench.plausibility import overlap_measures

        e = float(metrics.get("restitution", math.nan))
        w = float(metrics.get("spin_out_rad_s", math.nan))
        m = scenario.mass_kg
        inertia = scenario.moment_of_inertia_kg_m2
        vn = e * scenario.normal_velocity_m_s
        v_t_in = scenario.velocity_m_s * math.sin(math.radians(scenario.angle_deg))
        vt = float(metrics.get("tangential_restitution", math.nan)) * v_t_in if v_t_in else 0.0
        before = m * scenario.velocity_m_s**2 + inertia * scenario.spin_rad_s**2
        after = m * (vn * vn + vt * vt) + inertia * w * w
        return {**overlap_measures(rec, scenario.radius_m), "energy_ratio": after / before}

    def problem(self, scenario: Any, ref: dict[str, Any]) -> str:
        """An indentation beyond the ball's radius (the normal closed form's): no contact law
        holds there."""
        import numpy as np

        from impactbench.reference.oblique import normal_sweep

        normal = normal_sweep(scenario, np.asarray([scenario.normal_velocity_m_s]))
        return scenario.penetration_problem(float(normal["max_penetration_m"].iloc[0]))

    def metrics_of(self, rec: Any, scenario: Any) -> dict[str, float]:
        """The oblique metrics of a record (for the suite's per-scenario metrics hook)."""
        from impactbench.reference import oblique

        return oblique.record_metrics(rec, scenario)

    def add_options(self, group: argparse._ArgumentGroup, with_gravity: bool = True) -> None:
        """The normal contact model and nominal restitution (shared with the ball when both are
        on one parser), the tangential model, the ball's shape and a named case. No gravity: the
        reference is the gravity-free impact (``with_gravity`` is accepted for the spec's
        signature)."""
        from impactbench.cliutil import number
        from impactbench.reference.oblique_scenario import (
            CASES,
            OBLIQUE_MODELS,
            SHAPES,
            TANGENTIAL_MODELS,
        )

        have = group._option_string_actions  # shared with the parser: another scenario's flags
        if "--model" not in have:
            group.add_argument("--model", choices=OBLIQUE_MODELS, default=None,
                               help="normal contact model (default hunt-crossley; every other "
                               "model needs --nominal-restitution)")
        if "--nominal-restitution" not in have:
            group.add_argument("--nominal-restitution", type=number, default=None,
                               dest="nominal_restitution", metavar="E",
                               help="nominal restitution e in (0, 1] the model's damping is set "
                               "from at the normal velocity (replaces --damping)")
        if "--tangential" not in have:
            group.add_argument("--tangential", choices=TANGENTIAL_MODELS, default=None,
                               help="tangential contact: rigid (ideal Coulomb, closed form; the "
                               "default), mindlin (no-slip spring k_t = 8·G*·a capped at μ·F_n, "
                               "integrated) or mindlin-deresiewicz (the full law: micro-slip and "
                               "the contact's memory, a spring bed)")
        if "--shape" not in have:
            group.add_argument("--shape", choices=SHAPES, default=None,
                               help="the ball: sphere (k² = 2R²/5, the default) or disc (k² = "
                               "R²/2: the 2D engines' circle with a disc's inertia; the 3D engines "
                               "return unsupported)")
        if "--case" not in have:
            group.add_argument("--case", choices=tuple(CASES), default=None,
                               help="a named set of fields (kharaz2001: Kharaz et al. 2001's "
                               "alumina sphere, μ 0.092, e 0.98, rigid plate; `reference` runs it "
                               "at its 3.9 m/s unless --velocity); flags given here override it")

    def from_args(self, args: argparse.Namespace, values: dict[str, Any]) -> dict[str, Any]:
        """The fields of a named case (``--case``) under the explicit ones (``values``); the
        Hertz c of the given elastic constants (ball and plate) when any is given and
        ``--stiffness`` is not. An explicit ``--damping`` drops a case's nominal restitution.
        The ball's material options (``--material``, ``--plate-material``, ``--scenario-file``,
        ``--gravity``) do not apply here: a one-line error says so."""
        from impactbench.reference import validation as check
        from impactbench.reference.oblique_scenario import CASES, Oblique
        from impactbench.reference.scenarios import hertz_stiffness

        for option, flag in (("material", "--material"), ("plate_material", "--plate-material"),
                             ("scenario_file", "--scenario-file")):
            value = getattr(args, option, None)
            if value is not None:
                raise ValueError(f"{option} = {value!r}: {flag} does not apply to the {NAME} "
                                 "scenario (give --youngs-modulus/--poisson/--plate-youngs-modulus"
                                 "/--plate-poisson, or --case)")
        gravity = getattr(args, "gravity_m_s2", None)
        if gravity:
            raise ValueError(f"gravity_m_s2 = {gravity!r}: the {NAME} scenario is gravity-free")
        case = getattr(args, "case", None)
        base: dict[str, Any] = {}
        if case is not None:
            check.one_of("case", case, tuple(CASES))
            base = dict(CASES[case])
            if "damping_s_per_m" in values and "nominal_restitution" not in values \
                    and values.get("model", base.get("model", "hunt-crossley")) == "hunt-crossley":
                base.pop("nominal_restitution", None)  # an explicit b wins over the case's e
        out = {**base, **values}
        if any(k in values for k in MATERIAL_FIELDS) and "stiffness" not in values:
            if out.get("exponent", 1.5) != 1.5:
                raise ValueError(f"exponent = {out['exponent']!r}: elastic constants give the "
                                 "Hertz law; must be 1.5 (or give --stiffness)")
            d = Oblique()
            get = {k: out.get(k, getattr(d, k)) for k in (*MATERIAL_FIELDS, "radius_m")}
            check.positive("radius_m", get["radius_m"])
            check.positive("youngs_modulus_pa", get["youngs_modulus_pa"])
            out["stiffness"] = hertz_stiffness(get["radius_m"], get["youngs_modulus_pa"],
                                               get["poisson"], math.inf,
                                               get["plate_youngs_modulus_pa"], get["plate_poisson"])
            out["exponent"] = 1.5
        return out

    def report_figures(self, ctx: Any, runs: list, loops: list) -> None:
        """The oblique figures: per configured speed, the quantities against incidence angle
        beside both references."""
        spec = self
        from impactbench.report import modes_text, timestep_text

        if not runs:
            return
        sm = next((s for s in ctx.cfg.scenarios if s.name == spec.name), None)
        params = sm.parameters if sm is not None else {}
        for v in sorted({r.job.velocity_m_s for r in runs}):
            at = [r for r in runs if r.job.velocity_m_s == v]
            scenario = spec.build((("angle_deg", 0.0), ("velocity_m_s", v)), params)
            how = f"{modes_text(at)}; {timestep_text(at)}"
            path = ctx.draw(angle_figure, ctx.df, scenario,
                            ctx.fig_dir / f"report_oblique_v{v:g}.png", how)
            ctx.add_figure(path, f"Rebound angle, spin and tangential restitution against "
                           f"incidence angle, V = {v:g} m/s; {how}", f"extra:{spec.name}")


SPEC = ObliqueSpec(
    name=NAME,
    title="Oblique impact",
    summary="a sphere hitting a plate at an angle with friction and spin, rigid-Coulomb closed "
            "form or Mindlin reference",
    metrics=METRICS,
    headline=("rebound_angle_deg", "spin_out_rad_s", "tangential_restitution"),
    axes=(Axis("angle_deg", "angles_deg", "θ (°)", short="a", zero=True),
          Axis("velocity_m_s", "velocities_m_s", "V (m/s)", short="v")),
    table="oblique",
    flags=FLAGS,
    gate_velocities_m_s=(2.0,),
    figure_stem="oblique",
    velocity_symbol="V",
    descriptions=DESCRIPTIONS,
)


FIGURE_METRICS = (("rebound_angle_deg", "rebound angle (°)"),
                  ("spin_out_rad_s", "spin after (rad/s)"),
                  ("tangential_restitution", "tangential restitution (–)"))
"""The quantities of the oblique figures, against incidence angle."""


def angle_figure(df: Any, scenario: Any, path: Any, how: str, kharaz: bool = False) -> Any:
    """Rebound angle, spin and tangential restitution against incidence angle: the references
    (rigid Coulomb, closed form; Mindlin–Deresiewicz, the compliant reference; Mindlin's
    no-slip law, thin) as curves, every engine and mode of ``df``'s oblique rows at
    ``scenario``'s speed as points, and Kharaz et al.'s measurements when ``kharaz`` (the
    experiment's own sphere)."""
    import matplotlib.pyplot as plt
    import numpy as np

    from impactbench.plots import ENGINE_COLORS, MODE_MARKERS, _save
    from impactbench.reference import oblique

    fine = np.linspace(0.0, 85.0, 69)
    rigid = oblique.sweep(scenario.replace(tangential="rigid"), fine)
    coarse = np.sort(np.concatenate([[1.0, 2.0, 3.5], np.linspace(0.0, 85.0, 18)]))  # + near-normal
    mindlin = oblique.sweep(scenario.replace(tangential="mindlin"), coarse)
    compliant = oblique.sweep(scenario.replace(tangential=oblique.COMPLIANT_DEFAULT), coarse)
    fig, axes = plt.subplots(1, 3, figsize=(13.5, 4.2))
    for ax, (key, label) in zip(axes, FIGURE_METRICS, strict=True):
        ax.plot(rigid.angle_deg, rigid[key], color="black", lw=2, label="rigid Coulomb")
        ax.plot(compliant.angle_deg, compliant[key], color="black", lw=1.5, ls="--",
                label="Mindlin–Deresiewicz (compliant)")
        ax.plot(mindlin.angle_deg, mindlin[key], color="0.4", lw=0.8, ls=":",
                label="Mindlin no-slip")
        if kharaz:
            from impactbench.reference import kharaz2001

            pts = kharaz2001.points(key)
            ax.plot(pts.angle_deg, pts.value, "s", color="0.45", ms=5, mfc="none",
                    label="Kharaz et al. 2001")
        rows = df[(df.scenario == NAME) & (df.metric == key) & (df.status == "ok")] \
            if len(df) else df
        for (engine, mode), g in rows.groupby(["engine", "mode"]) if len(rows) else ():
            g = g[np.isclose(g.velocity_m_s.astype(float), scenario.velocity_m_s)]
            g = g.sort_values("angle_deg")
            ax.plot(g.angle_deg, g.value.astype(float), MODE_MARKERS.get(mode, "o"),
                    ls="none", ms=6, color=ENGINE_COLORS.get(engine),
                    mfc="none" if mode == "native" else ENGINE_COLORS.get(engine),
                    label=f"{engine} {mode}")
        ax.set_xlabel("incidence angle θ (°)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=1)
    what = "references and engines" if len(df) else \
        ("references and measurements" if kharaz else "references")
    fig.suptitle(f"Oblique impact, V = {scenario.velocity_m_s:g} m/s, μ = "
                 f"{scenario.friction:g}: {what}\n{how}", fontsize=9)
    fig.tight_layout()
    return _save(fig, path)


