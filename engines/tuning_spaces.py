"""What each engine can tune: its native contact parameters, their bounds and its own form.

A :class:`Space` maps a vector of positive parameter values (SI, listed in ``parameters``) to
one engine run (scenario, mode, :class:`~impactbench.engines.base.RunSettings`) and to the adapter's
tuned-parameter keys, knows the closed-form start (the native conversion) and prints the
result the way a user of that engine writes it. The optimiser works on the logarithms.

Engines and their force laws (x penetration, ẋ its rate, m the ball's mass):

- **MuJoCo** (soft constraint, one contact row of inverse inertia A = efc_diagA = 1/m):
  with direct solref (−S, −D) and impedance imp(x) ∈ [dmin, dmax] from solimp the contact
  force is F = (S/A)·(imp/dmax)²·x + (D/A)·(imp/dmax)·ẋ (clipped at F ≥ 0), so the physical
  stiffness and damping at full impedance are K = S/A (N/m) and D_phys = D/A (N·s/m).
  The positive form (timeconst τ, dampratio ζ) is the same law with K = 1/(A·τ²·ζ²) and
  D_phys = 2/(A·τ) (MuJoCo's ``refsafe`` clamps τ ≥ 2·dt, so τ is bounded there). Measured
  on mujoco 4.0.0: with the positive form and dmin = dmax = mjMINIMP (1e-4, the adapter's
  native impedance) the contact is ~70× softer than this formula says, while dmax = 0.01 or
  0.95 agree with it — so the timeconst form uses a constant impedance of dmax = 0.95.
  solimp shapes imp(x): imp = dmin + (dmax − dmin)·y(x/width), y rising from 0 to 1 over
  the ``width`` (m) with a power-``power`` curve on each side of ``midpoint`` (y = r for
  power 1). The stiffness term carries (imp/dmax)², so an impedance that rises over the
  penetration range makes the force–penetration curve stiffen: with ρ = dmin/dmax and a
  linear rise, F ≈ K·(ρ + (1−ρ)·x/width)²·x, whose secant stiffness grows with x as Hertz's
  c·x^0.5 does (2.4× between the 20 µm and 114 µm penetrations of the paper's 0.5 and 5 m/s)
  — a constant impedance (dmin = dmax) is a linear spring, secant constant. Only imp/dmax
  matters for the force, so dmax is fixed (:data:`MUJOCO_DMAX`, MuJoCo's default 0.95) and
  ρ is tuned. The damping term carries imp/dmax, not its square: the damping ratio is the
  same at every penetration scale, so restitution stays nearly independent of the impact
  velocity (exactly so for a pure power-law impedance) — MuJoCo cannot follow
  Hunt–Crossley's falling restitution by tuning.
- **PyBullet**: pair ``contactStiffness`` K (N/m) and ``contactDamping`` D (N·s/m), a linear
  spring–damper stepped by backward Euler.
- **pymunk**: rigid contact with a constant ``elasticity`` e (the pair's restitution); or, as a
  separate option, the velocity-dependent rule k(V) = Hunt–Crossley's k(α = b·V) injected per
  contact through ``arbiter.restitution`` in ``pre_solve``, with b tuned.
- **Drake**: point contact f = k·x·(1 + d·ẋ)₊, pair point stiffness k (N/m) and Hunt–Crossley
  dissipation d (s/m).
- **MJX**: MuJoCo's model and soft-constraint law run in JAX, so MuJoCo's space (above) with
  the engine name ``mjx``: the same solref/solimp keys and efc_diagA.
- **SAPIEN (PhysX 5)**: a negative material ``restitution`` −K is a compliant contact, the
  *undamped* spring F = K·x (K in N/m; the pair averages the two materials, so both get −K):
  K is tuned, restitution stays ≈ 1 (no contact damping to set). Or, as a separate option, a
  rigid contact with a constant ``restitution`` e ≥ 0 (pair: the average) and
  ``bounce_threshold`` 0 m/s.
- **DART**: rigid LCP contact with a constant ``restitution_coeff`` e (pair: the product; the
  plate's is 1).
- **Box2D**: rigid contact with a constant fixture ``restitution`` e (pair: the maximum; the
  plate's is 0), applied only above the compiled-in 1 m/s ``b2_velocityThreshold``.
- **Newton** (Featherstone, semi-implicit Euler): penalty contact F = ke·x + kd·max(ẋ, 0),
  shape ``ke`` (N/m) and ``kd`` (N·s/m), averaged over the two shapes; damping acts only while
  approaching, so e = exp(−ζφ/√(1−ζ²)) with ζ = kd/(2√(ke·m)), φ = atan2(√(1−ζ²), ζ).

The last four (the optional extras) live in :mod:`~impactbench.engines.tuning_spaces_extras`.
Each engine's :class:`~impactbench.engines.registry.EngineSpec` names its functions here
(``tuning``); :func:`make_space` builds the one asked for. Engine layer: the suite's tuner
(:mod:`impactbench.tuning.optimize`) imports these, never the other way.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from impactbench.engines.base import RunSettings
from impactbench.engines.knobs import Knob
from impactbench.engines.registry import BUILTIN, SPECS
from impactbench.reference import validation as check
from impactbench.reference.metrics import BALL_METRICS
from impactbench.reference.scenarios import BallOnPlate

SOLREF_FORMS = ("direct", "timeconst")
"""MuJoCo's two solref forms (``--solref-form``; :mod:`impactbench.tuning.names` spells the
same for the command line, which must not import numpy)."""

VARIANTS: dict[str, tuple[str, ...]] = {s.name: s.variants for s in BUILTIN if s.variants}
"""Each tunable packaged engine's parameter sets (the first is the default), from its
:class:`~impactbench.engines.registry.EngineSpec`."""

MUJOCO_DMAX = 0.95
"""solimp dmax of the tuned MuJoCo contact (MuJoCo's default); only dmin/dmax is tuned."""

ALL_METRICS = frozenset(BALL_METRICS)
"""What a compliant contact (a force law over penetration) can express: every ball metric."""

LINEAR_LIMITS = (
    "a linear spring–damper's restitution and contact duration do not depend on the impact "
    "velocity (the contact is scale-invariant: x ∝ V0), and its peak force is ∝ V0, while "
    "Hunt–Crossley's restitution falls with α = b·V0 and its duration and peak force follow "
    "Hertz's V0^(−1/5) and V0^(6/5)",
)


@dataclass(frozen=True)
class Parameter:
    """One tuned quantity (positive; optimised as its logarithm within [lower, upper])."""

    name: str
    unit: str
    lower: float
    upper: float

    def clip(self, value: float) -> float:
        return min(max(value, self.lower), self.upper)


RunArgs = Callable[[np.ndarray, BallOnPlate, float | None], tuple[BallOnPlate, str, RunSettings]]


@dataclass(frozen=True)
class Space:
    """An engine's tunable parameterisation.

    Attributes:
        engine: registry name of the engine.
        variant: which parameter set (``impactbench tune --parameters``).
        parameters: the tuned quantities, in vector order.
        start: closed-form start values (the native conversion), within bounds.
        mode: the adapter mode the run uses (``tuned``; ``injected`` for pymunk's law).
        expressible: metric keys the engine can express (the others are weighted 0).
        limits: what the engine cannot express, one sentence each.
        to_tuned: values → the adapter's tuned keys (its own units and form).
        run_args: (values, scenario, timestep) → (scenario, mode, settings) when the run is
            not plain tuned mode with ``to_tuned(values)``.
        snippet: tuned keys → the text a user pastes into the engine.
        linear: the contact is scale-invariant (restitution and duration independent of V0).
        diff_step: the polish's relative finite-difference step in the unit box; a float32
            engine needs one whose metric change clears its rounding noise.
    """

    engine: str
    variant: str
    parameters: tuple[Parameter, ...]
    start: tuple[float, ...]
    mode: str
    expressible: frozenset[str]
    limits: tuple[str, ...]
    to_tuned: Callable[[np.ndarray], dict[str, Any]]
    snippet: Callable[[dict[str, Any]], str]
    run_args: RunArgs | None = field(default=None, repr=False)
    linear: bool = False
    diff_step: float = 1e-4

    def run(self, values: np.ndarray, scenario: BallOnPlate, timestep_s: float | None
            ) -> tuple[BallOnPlate, str, RunSettings]:
        """(scenario, mode, settings) of one run at ``values`` (default: tuned mode)."""
        if self.run_args is not None:
            return self.run_args(values, scenario, timestep_s)
        return scenario, self.mode, RunSettings(timestep_s=timestep_s,
                                                tuned=self.to_tuned(values))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    def log_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return (np.log([p.lower for p in self.parameters]),
                np.log([p.upper for p in self.parameters]))

    # the one tuner's space (impactbench.tuning.search.UnitSpace): every parameter a log knob,
    # u = (ln p − ln lower)/(ln upper − ln lower) ∈ [0, 1], mapped with numpy
    def candidate(self, values: np.ndarray) -> dict[str, float]:
        """Parameter name → value (the search's candidate) of a vector in :attr:`names` order."""
        return {n: float(v) for n, v in zip(self.names, values, strict=True)}

    def values_of(self, candidate: Mapping[str, Any]) -> np.ndarray:
        """The vector of a candidate, in :attr:`names` order."""
        return np.array([float(candidate[n]) for n in self.names])

    @property
    def start_candidate(self) -> dict[str, float]:
        return self.candidate(np.asarray(self.start, dtype=float))

    def to_unit(self, candidate: Mapping[str, Any]) -> np.ndarray:
        lo, hi = self.log_bounds()
        return np.clip((np.log(self.values_of(candidate)) - lo) / (hi - lo), 0.0, 1.0)

    def from_unit(self, u: Any, fixed: Mapping[str, Any] | None = None) -> dict[str, float]:
        lo, hi = self.log_bounds()
        return self.candidate(np.exp(lo + np.clip(u, 0.0, 1.0) * (hi - lo)))

    @property
    def knobs(self) -> tuple[Knob, ...]:
        """The parameters as the one tuner's knobs (log, with the start)."""
        return tuple(Knob(p.name, p.lower, p.upper, unit=p.unit, initial=float(s))
                     for p, s in zip(self.parameters, self.start, strict=True))


def _decades(value: float, down: float, up: float) -> tuple[float, float]:
    return value * 10.0 ** (-down), value * 10.0 ** up


def _fmt(values: list[float] | tuple[float, ...]) -> str:
    return " ".join(f"{float(v):.10g}" for v in values)


# ------------------------------------------------------------------------------- MuJoCo


def _mujoco_diag_a(scenario: BallOnPlate, timestep_s: float | None) -> float:
    """efc_diagA of the ball's contact row, measured from the adapter's own model."""
    import mujoco
    from impactbench.engines.mujoco_adapter import BALL_TIMESTEP_S, ball_mjcf, measured_diag_a

    model = mujoco.MjModel.from_xml_string(ball_mjcf(scenario, timestep_s or BALL_TIMESTEP_S))
    return measured_diag_a(model, mujoco.MjData(model), (-1e-9,))


def mujoco_space(scenario: BallOnPlate, variant: str = "solref+solimp",
                 solref_form: str = "direct", timestep_s: float | None = None,
                 engine: str = "mujoco") -> Space:
    """MuJoCo: solref in either form, optionally with the solimp shape (see module doc).

    ``engine`` ``mjx`` is the same space for MJX, which runs MuJoCo's model (same
    efc_diagA) and contact law and reads the same tuned keys."""
    from impactbench.engines.common import native_ball_spring_damper
    from impactbench.engines.mujoco_adapter import BALL_TIMESTEP_S, SOLIMP

    check.one_of("parameters", variant, VARIANTS[engine])
    check.one_of("solref_form", solref_form, SOLREF_FORMS)
    a = _mujoco_diag_a(scenario, timestep_s)
    sd = native_ball_spring_damper(scenario)
    k0, d0 = sd.stiffness_n_per_m, sd.damping_ns_per_m
    with_imp = variant == "solref+solimp"
    dt = timestep_s or BALL_TIMESTEP_S
    if solref_form == "direct":
        up = 4.0 if with_imp else 2.0  # a low dmin/dmax needs a stiffer saturated spring
        params = [Parameter("stiffness_n_per_m", "N/m", *_decades(k0, 2.0, up)),
                  Parameter("damping_ns_per_m", "N·s/m", *_decades(d0, 2.0, up))]
        start = [k0, d0]
    else:
        tau0, zeta0 = 2.0 / (a * d0), d0 / (2.0 * math.sqrt(k0 / a))
        lo_tau, hi_tau = _decades(tau0, 3.0 if with_imp else 2.0, 2.0)
        params = [Parameter("timeconst_s", "s", max(lo_tau, 2.0 * dt * 1.001), hi_tau),
                  Parameter("dampratio", "1", *_decades(zeta0, 2.0, 2.0))]
        start = [tau0, zeta0]
    if with_imp:
        params += [Parameter("dmin_over_dmax", "1", 1e-3, 1.0),
                   Parameter("width_m", "m", 1e-6, 1e-2),
                   Parameter("midpoint", "1", 1e-3, 0.999),
                   Parameter("power", "1", 1.0, 100.0)]
        start += [1.0, SOLIMP[2], SOLIMP[3], SOLIMP[4]]  # constant impedance: the native law

    def to_tuned(v: np.ndarray) -> dict[str, Any]:
        v = [float(x) for x in v]
        if solref_form == "direct":
            # F = (S/A)(imp/dmax)²x + (D/A)(imp/dmax)ẋ: S = K·A, D = D_phys·A at imp = dmax
            solref = [-v[0] * a, -v[1] * a]
        else:
            solref = [v[0], v[1]]
        if with_imp:
            solimp = [v[2] * MUJOCO_DMAX, MUJOCO_DMAX, v[3], v[4], v[5]]
        elif solref_form == "direct":
            solimp = list(SOLIMP)  # the native constant impedance: start = native exactly
        else:
            solimp = [MUJOCO_DMAX, MUJOCO_DMAX, *SOLIMP[2:]]
        return {"solref": solref, "solimp": solimp}

    def snippet(t: dict[str, Any]) -> str:
        mjx = ("; then mjx.put_model(mujoco.MjModel.from_xml_string(xml))"
               if engine == "mjx" else "")
        return (f'<geom solref="{_fmt(t["solref"])}" solimp="{_fmt(t["solimp"])}"/>\n'
                f"(on both the ball and the plate geoms, or as <default><geom .../>; "
                f"efc_diagA = {a:.10g} 1/kg, solref {solref_form} form{mjx})\n"
                f"or in Python: model.geom_solref[:] = [{_fmt(t['solref'])}]; "
                f"model.geom_solimp[:] = [{_fmt(t['solimp'])}]")

    limits = (
        "restitution is nearly independent of the impact velocity: the impedance scales "
        "stiffness by (imp/dmax)² and damping by imp/dmax, which leaves the damping ratio "
        "unchanged across penetration scales, so Hunt–Crossley's falling k(b·V0) cannot be "
        "followed",
    ) if with_imp else LINEAR_LIMITS
    return Space(engine, variant if solref_form == "direct" else f"{variant} ({solref_form})",
                 tuple(params), tuple(p.clip(s) for p, s in zip(params, start, strict=True)),
                 "tuned", ALL_METRICS,
                 limits, to_tuned, snippet, linear=not with_imp)


# ------------------------------------------------------------------------------- PyBullet


def _step_floor(mass_kg: float, timestep_s: float | None) -> float:
    """A stiffness (N/m) soft enough to be well resolved at this step: ω·dt = 0.03,
    k = m·(0.03/dt)². The lower bound of a stiffness reaches down to it at a practical step
    (1 ms: 90 N/m for the paper's ball), where the paper's 1e8 N/m contact is a one-step
    impulse."""
    return mass_kg * (0.03 / timestep_s) ** 2 if timestep_s else math.inf


SAP_LIMIT = ("Drake's SAP approximation ignores the Hunt–Crossley dissipation (it dissipates "
             "through a linear Kelvin–Voigt relaxation_time: tune it with --parameters "
             "stiffness+relaxation), so only the stiffness acts")


def pybullet_space(scenario: BallOnPlate, timestep_s: float | None = None) -> Space:
    """PyBullet: pair contactStiffness and contactDamping (physical N/m and N·s/m)."""
    from impactbench.engines.common import native_ball_spring_damper

    sd = native_ball_spring_damper(scenario)
    k0, d0 = sd.stiffness_n_per_m, sd.damping_ns_per_m
    k_lo, k_hi = _decades(k0, 2.0, 2.0)
    d_lo, d_hi = _decades(max(d0, 1e-9), 2.0, 2.0)
    floor = _step_floor(scenario.mass_kg, timestep_s)
    if floor < k_lo:
        k_lo, d_lo = floor, d_lo * math.sqrt(floor / k_lo)
    params = (Parameter("contact_stiffness", "N/m", k_lo, k_hi),
              Parameter("contact_damping", "N·s/m", d_lo, d_hi))

    def to_tuned(v: np.ndarray) -> dict[str, Any]:
        return {"contact_stiffness": float(v[0]), "contact_damping": float(v[1])}

    def snippet(t: dict[str, Any]) -> str:
        return (f"p.changeDynamics(ball, -1, contactStiffness={t['contact_stiffness']:.10g}, "
                f"contactDamping={t['contact_damping']:.10g}, restitution=0)\n"
                "(pair values: give the plate stiffness inf-like and damping 0, or halve/"
                "combine as Bullet does: stiffness in series, damping summed)")

    return Space("pybullet", "stiffness+damping", params, (k0, max(d0, 1e-9)), "tuned",
                 ALL_METRICS,
                 LINEAR_LIMITS, to_tuned, snippet, linear=True)


# ------------------------------------------------------------------------------- pymunk

RIGID_LIMITS = (
    "a rigid contact is a one-step impulse: it has no duration, no peak force and no "
    "penetration",
)


def pymunk_space(scenario: BallOnPlate, variant: str = "elasticity") -> Space:
    """pymunk: a constant elasticity, or b of the injected restitution law k(α = b·V)."""
    from impactbench.engines.common import NATIVE_REFERENCE_VELOCITY_M_S
    from impactbench.reference import hunt_crossley

    check.one_of("parameters", variant, VARIANTS["pymunk"])
    expressible = frozenset({"restitution"})
    if variant == "elasticity":
        e0 = hunt_crossley.solve(scenario.replace(
            velocity_m_s=NATIVE_REFERENCE_VELOCITY_M_S))["restitution"]
        param = Parameter("elasticity", "1", 1e-3, 1.0)

        def to_tuned(v: np.ndarray) -> dict[str, Any]:
            return {"elasticity": float(v[0])}

        def snippet(t: dict[str, Any]) -> str:
            return (f"ball_shape.elasticity = {t['elasticity']:.10g}\n"
                    "plate_shape.elasticity = 1.0   # pair restitution = product")

        limits = (*RIGID_LIMITS, "a constant elasticity cannot follow Hunt–Crossley's "
                                 "restitution, which falls with the impact velocity")
        return Space("pymunk", variant, (param,), (param.clip(e0),), "tuned", expressible,
                     limits, to_tuned, snippet, linear=True)

    b0 = scenario.damping_s_per_m
    param = Parameter("restitution_damping_s_per_m", "s/m", 1e-4, 10.0)

    def law_tuned(v: np.ndarray) -> dict[str, Any]:
        return {"restitution_law": "hunt_crossley", "restitution_damping_s_per_m": float(v[0])}

    def law_run(v: np.ndarray, s: BallOnPlate, timestep_s: float | None
                ) -> tuple[BallOnPlate, str, RunSettings]:
        # the adapter's injected restitution rule uses the scenario's b: hand it the tuned b
        # (as a plain Hunt–Crossley b: a model's nominal restitution would re-derive b)
        return (s.replace(damping_s_per_m=float(v[0]), model="hunt-crossley",
                          nominal_restitution=None), "injected",
                RunSettings(timestep_s=timestep_s, options={"injection": "restitution"}))

    def law_snippet(t: dict[str, Any]) -> str:
        b = t["restitution_damping_s_per_m"]
        return ("def pre_solve(arbiter, space, data):\n"
                "    v = ...  # approach speed along the contact normal (m/s, > 0 closing)\n"
                f"    arbiter.restitution = k(alpha={b:.10g} * max(v, 0.0))\n"
                "# k(α) = (1 + W0(−(1+α)·e^−(1+α)))/α, reference.hunt_crossley.restitution")

    limits = (*RIGID_LIMITS, "the restitution law is Hunt–Crossley's own closed form, so it "
                             "matches by construction; it is a per-contact rule the user "
                             "injects, not a pymunk parameter")
    return Space("pymunk", variant, (param,), (param.clip(max(b0, 1e-4)),), "injected",
                 expressible, limits, law_tuned, law_snippet, run_args=law_run)


# ------------------------------------------------------------------------------- Drake


RELAXATION_LIMITS = (
    "SAP's linear Kelvin–Voigt contact f = k·(x + τ·ẋ) (relaxation_time τ) is a linear "
    "spring–damper: its restitution and duration do not depend on the impact velocity",)


def drake_relaxation_space(scenario: BallOnPlate, timestep_s: float | None = None) -> Space:
    """Drake's SAP-family discrete plants: pair point stiffness k (N/m) and the
    ``relaxation_time`` τ (s) of their linear dissipation (they ignore Hunt–Crossley's d)."""
    from impactbench.engines.drake_adapter import native_ball_point_contact

    k0, _ = native_ball_point_contact(scenario)
    k_lo, k_hi = _decades(k0, 2.0, 2.0)
    params = (Parameter("point_stiffness_n_per_m", "N/m",
                        min(k_lo, _step_floor(scenario.mass_kg, timestep_s)), k_hi),
              Parameter("relaxation_time_s", "s", 1e-6, 1e-1))

    def to_tuned(v: np.ndarray) -> dict[str, Any]:
        return {"point_stiffness_n_per_m": float(v[0]), "relaxation_time_s": float(v[1])}

    def snippet(t: dict[str, Any]) -> str:
        k, tau = t["point_stiffness_n_per_m"], t["relaxation_time_s"]
        return (f"AddContactMaterial(point_stiffness={2 * k:.10g}, friction=CoulombFriction(0, "
                f"0), properties=props); props.AddProperty('material', 'relaxation_time', "
                f"{tau:.10g})\n(on both geometries; pair k = {k:.10g} N/m)")

    return Space("drake", "stiffness+relaxation", params,
                 tuple(p.clip(s) for p, s in zip(params, (k0, 1e-3), strict=True)),
                 "tuned", ALL_METRICS,
                 RELAXATION_LIMITS, to_tuned, snippet, linear=True)


def drake_space(scenario: BallOnPlate, timestep_s: float | None = None) -> Space:
    """Drake: pair point stiffness k (N/m) and Hunt–Crossley dissipation d (s/m)."""
    from impactbench.engines.drake_adapter import native_ball_point_contact

    k0, d0 = native_ball_point_contact(scenario)
    k_lo, k_hi = _decades(k0, 2.0, 2.0)
    params = (Parameter("point_stiffness_n_per_m", "N/m",
                        min(k_lo, _step_floor(scenario.mass_kg, timestep_s)), k_hi),
              Parameter("hunt_crossley_dissipation_s_per_m", "s/m",
                        *_decades(max(d0, 1e-6), 2.0, 2.0)))

    def to_tuned(v: np.ndarray) -> dict[str, Any]:
        return {"point_stiffness_n_per_m": float(v[0]),
                "hunt_crossley_dissipation_s_per_m": float(v[1])}

    def snippet(t: dict[str, Any]) -> str:
        k, d = t["point_stiffness_n_per_m"], t["hunt_crossley_dissipation_s_per_m"]
        return (f"AddContactMaterial(dissipation={d:.10g}, point_stiffness={2 * k:.10g}, "
                "friction=CoulombFriction(0, 0), properties=props)\n"
                f"(on both geometries: stiffnesses combine in series, so each gets 2k for a "
                f"pair k = {k:.10g} N/m; ContactModel.kPoint)")

    limits = ("point contact is f = k·x·(1 + d·ẋ): its restitution is Hunt–Crossley's k(d·V0) "
              "for any stiffness law, but its stiffness is linear, so duration and peak force "
              "cannot follow Hertz's V0^(−1/5) and V0^(6/5) together: one k trades one "
              "against the other",)
    return Space("drake", "stiffness+dissipation", params,
                 tuple(p.clip(s) for p, s in zip(params, (k0, max(d0, 1e-6)), strict=True)),
                 "tuned", ALL_METRICS,
                 limits, to_tuned, snippet)


# ------------------------------------------------------------------------------- registry


def make_space(engine: str, scenario: BallOnPlate, variant: str | None = None,
               solref_form: str = "direct", timestep_s: float | None = None) -> Space:
    """The engine's parameterisation ``variant`` (default: its spec's first): the function
    its :class:`~impactbench.engines.registry.EngineSpec` names for it, called with the
    options it takes (``variant``, ``timestep_s``, ``engine``, ``solref_form``)."""
    import importlib
    import inspect

    check.one_of("engine", engine, tuple(VARIANTS))
    variant = check.one_of("parameters", variant or VARIANTS[engine][0], VARIANTS[engine])
    module, _, name = dict(SPECS[engine].tuning)[variant].partition(":")
    build = getattr(importlib.import_module(module), name)
    options = {"variant": variant, "timestep_s": timestep_s, "engine": engine,
               "solref_form": solref_form}
    taken = inspect.signature(build).parameters
    return build(scenario, **{k: v for k, v in options.items() if k in taken})


def with_start(space: Space, start: tuple[float, ...]) -> Space:
    """The same space starting from ``start`` (clipped into the bounds)."""
    return replace(space, start=tuple(p.clip(float(s))
                                      for p, s in zip(space.parameters, start, strict=True)))
