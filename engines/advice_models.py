"""Every contact model each engine offers a user, as ``custom``-mode settings the advisor searches.

The advisor (:mod:`impactbench.advise`) answers "what do I set in my engine, at my step": so
its candidates are what a user adds to the engine *out of the box* — the adapter's ``custom``
mode (the engine's defaults plus ``settings.params`` by the engine's own names) — never the
adapter's own tuned world. Each :class:`ContactModel` is one way the engine can make a contact
(a constant restitution with its velocity threshold switched off, a compliant spring–damper,
MuJoCo's two solref forms, Drake's discrete approximations, …), its searched knobs, the
settings it holds fixed and the text a user pastes (:func:`snippet`: the engine's own words,
from the parameters alone). A constant restitution is always a candidate where the engine has
one, so the advice is never worse than the simplest setting.

Pair values: every key is the pair's, as the adapter's ``custom`` mode applies it (PyBullet:
the ball gets the restitution, the plate 1 — Bullet multiplies; Drake: each geometry gets
2k — stiffnesses in series; pymunk: ball e, plate 1 — the product; SAPIEN: both materials —
the average; DART: ball e, plate 1 — the product; Box2D: ball e, plate 0 — the maximum;
Newton: both shapes — the average; MuJoCo: both geoms — equal solref, so the mix is the same).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from impactbench.engines.registry import spec

ENGINES = ("mujoco", "mjx", "pybullet", "drake", "pymunk", "sapien", "dart", "box2d", "newton")
"""The engines the advisor knows the contact models of (:func:`models`)."""


def advice_steps_s(engine: str) -> tuple[float, ...]:
    """The steps (s) the advice for ``engine`` covers, its spec's ``advice_timesteps_s``:
    its users' defaults (MuJoCo/MJX 2 ms and a finer 1 ms, PyBullet 1/240 s, Drake's discrete
    plant 1 ms, pymunk a frame and 1 ms, SAPIEN's 10 ms, DART 1 ms, Box2D a frame, Newton's
    1/1200 s examples)."""
    return spec(engine).advice_timesteps_s


ENGINE_STEPS_S: dict[str, tuple[float, ...]] = {e: advice_steps_s(e) for e in ENGINES}
"""engine → :func:`advice_steps_s` (read from the specs)."""


@dataclass(frozen=True)
class Setting:
    """One searched setting: the engine key it sets, its bounds (searched in ln) and start."""

    key: str
    low: float
    high: float
    start: float
    unit: str = ""


@dataclass(frozen=True)
class ContactModel:
    """One contact model of an engine: ``settings`` searched, ``fixed`` set as given; the
    params of a candidate are ``{**fixed, key: value, …}``, or ``to_params`` of the values
    where a key is a function of them (MuJoCo's two-number solref)."""

    engine: str
    name: str
    settings: tuple[Setting, ...]
    fixed: Mapping[str, Any] = field(default_factory=dict)
    to_params: Callable[[dict[str, float]], dict[str, Any]] | None = None
    note: str = ""

    def params(self, values: Mapping[str, float]) -> dict[str, Any]:
        """The ``custom`` params of searched values (setting key → value)."""
        vals = {s.key: float(values[s.key]) for s in self.settings}
        return {**self.fixed, **(self.to_params(vals) if self.to_params else vals)}


def _mujoco(engine: str, dt: float) -> tuple[ContactModel, ...]:
    # refsafe: MuJoCo clamps a time constant below 2·dt to 2·dt
    timeconst = ContactModel(
        engine, "solref time constant", (Setting("timeconst", 2.0 * dt, 1.0, max(0.02, 2 * dt),
                                                 "s"),
                                         Setting("dampratio", 1e-3, 10.0, 1.0)),
        to_params=lambda v: {"solref": [v["timeconst"], v["dampratio"]]},
        note="solref=\"timeconst dampratio\" (MuJoCo's default form, 0.02 1)")
    direct = ContactModel(
        engine, "solref direct", (Setting("stiffness", 1e1, 1e12, 2.5e3, "1/s²"),
                                  Setting("damping", 1e-3, 1e6, 1e2, "1/s")),
        to_params=lambda v: {"solref": [-v["stiffness"], -v["damping"]]},
        note="solref=\"-stiffness -damping\" (the direct form)")
    return timeconst, direct


def models(engine: str, timestep_s: float, mass_kg: float) -> tuple[ContactModel, ...]:
    """The contact models of ``engine`` a user can set at ``timestep_s`` for a body of
    ``mass_kg`` (the stiffness floor of a compliant model is one resolved at the step:
    ω·dt = 0.03, k = m·(0.03/dt)²)."""
    dt = timestep_s
    floor = mass_kg * (0.03 / dt) ** 2
    e = Setting("restitution", 1e-3, 1.0, 0.9)
    if engine in ("mujoco", "mjx"):
        return _mujoco(engine, dt)
    if engine == "pybullet":
        return (
            ContactModel(engine, "restitution, no push-out", (e,),
                         {"restitutionVelocityThreshold": 0.0, "contactERP": 0.0,
                          "contactBreakingThreshold": 1e-4},
                         note="rigid contact, restitution at every speed; no ERP push-out of "
                              "the step's overlap (which adds energy by how deep the step "
                              "lands: e 0.73–0.93 for 0.86 at 0.5 m/s, 1/240 s) and a 0.1 mm "
                              "contact margin (Bullet's 2 cm one catches the ball a step "
                              "early at some phases)"),
            ContactModel(engine, "restitution", (e,), {"restitutionVelocityThreshold": 0.0},
                         note="rigid contact, restitution applied at every speed"),
            ContactModel(engine, "stiffness+damping",
                         (Setting("contactStiffness", floor, 1e12, max(floor, 1e6), "N/m"),
                          Setting("contactDamping", 1e-6, 1e6, 1.0, "N·s/m")),
                         note="compliant spring–damper, restitution 0"))
    if engine == "pymunk":
        elasticity = Setting("elasticity", 1e-3, 1.0, 0.9)
        return (ContactModel(engine, "elasticity", (elasticity,)),
                ContactModel(engine, "elasticity, no slop", (elasticity,),
                             {"collision_slop": 0.0},
                             note="collision_slop 0: no allowed overlap (pymunk's 0.1 m)"))
    if engine == "drake":
        k = Setting("point_stiffness", floor, 1e10, max(floor, 1e6), "N/m")
        out = [ContactModel(engine, f"point, {ap}",
                            (k, Setting("hunt_crossley_dissipation", 1e-3, 1e3, 1.0, "s/m")),
                            {"discrete_contact_approximation": ap, "contact_model": "point"})
               for ap in ("tamsi", "similar", "lagged")]
        out.append(ContactModel(engine, "point, sap",
                                (k, Setting("relaxation_time", 1e-6, 1e-1, 1e-3, "s")),
                                {"discrete_contact_approximation": "sap",
                                 "contact_model": "point"}))
        return tuple(out)
    if engine == "sapien":
        return (ContactModel(engine, "restitution", (e,), {"bounce_threshold": 0.0},
                             note="rigid, PhysX's 2 m/s bounce threshold switched off"),
                ContactModel(engine, "compliant", (Setting("stiffness", floor, 1e12,
                                                           max(floor, 1e6), "N/m"),),
                             to_params=lambda v: {"restitution": -v["stiffness"]},
                             note="a negative restitution −K: PhysX's undamped compliant "
                                  "contact of stiffness K"))
    if engine == "dart":
        return (ContactModel(engine, "restitution", (Setting("restitution_coeff", 1e-3, 1.0,
                                                             0.9),)),)
    if engine == "box2d":
        return (ContactModel(engine, "restitution", (e,),
                             note="applied only above Box2D's compiled-in 1 m/s "
                                  "b2_velocityThreshold"),)
    if engine == "newton":
        return (ContactModel(engine, "ke+kd", (Setting("ke", floor, 1e12, max(floor, 1e6),
                                                       "N/m"),
                                               Setting("kd", 1e-4, 1e6, 10.0, "N·s/m"))),)
    raise ValueError(f"engine = {engine!r}: the advisor knows no contact models for it "
                     f"(one of {', '.join(ENGINES)})")


def _g(x: float) -> str:
    return f"{float(x):.10g}"


def snippet(engine: str, params: Mapping[str, Any], timestep_s: float,
            mass_kg: float | None = None) -> str:
    """The settings to paste, in the engine's own words, from ``params`` (``custom`` keys)
    and the step alone (``mass_kg``: the body's, for a remark where it matters). Each is a
    complete recipe on top of the engine's defaults, for a ball body ``ball`` (shape
    ``ball_shape``, …) over a static plate ``plate``."""
    p, dt = dict(params), timestep_s
    if engine in ("mujoco", "mjx"):
        sr = " ".join(_g(x) for x in p["solref"])
        text = (f'<option timestep="{_g(dt)}"/>\n'
                f'<default><geom solref="{sr}"/></default>  <!-- ball and plate geoms -->')
        if engine == "mjx":
            text += "\nmjx_model = mjx.put_model(mujoco.MjModel.from_xml_string(xml))"
        return text
    if engine == "pybullet":
        rate = round(1.0 / dt)  # a step 1/n s that 6 digits round (1/240: 0.00416667) exactly
        step = f"1 / {rate}" if rate >= 1 and 1.0 / rate == dt != float(_g(dt)) else _g(dt)
        lines = [f"p.setTimeStep({step})"]
        engine_keys = [k for k in p if k not in ("restitution", "contactStiffness",
                                                 "contactDamping")]
        if engine_keys:
            lines.append("p.setPhysicsEngineParameter("
                         + ", ".join(f"{k}={_g(p[k])}" for k in engine_keys) + ")")
        if "restitution" in p:
            lines += [f"p.changeDynamics(ball, -1, restitution={_g(p['restitution'])})",
                      "p.changeDynamics(plate, -1, restitution=1.0)  # Bullet multiplies"]
        if "contactStiffness" in p:
            lines += [f"p.changeDynamics(ball, -1, contactStiffness="
                      f"{_g(p['contactStiffness'])}, contactDamping="
                      f"{_g(p['contactDamping'])})  # the pair's",
                      "p.changeDynamics(plate, -1, contactStiffness=float(\"inf\"), "
                      "contactDamping=0.0)  # else Bullet adds the plate's 0.1 N·s/m"]
        return "\n".join(lines)
    if engine == "pymunk":
        lines = [f"space.step({_g(dt)})  # every step"]
        if "collision_slop" in p:
            lines.append(f"space.collision_slop = {_g(p['collision_slop'])}")
        lines += [f"ball_shape.elasticity = {_g(p['elasticity'])}",
                  "plate_shape.elasticity = 1.0  # pymunk multiplies"]
        return "\n".join(lines)
    if engine == "drake":
        diss = (f"dissipation={_g(p['hunt_crossley_dissipation'])}, "
                if "hunt_crossley_dissipation" in p else "")
        lines = [f"plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step="
                 f"{_g(dt)}, discrete_contact_approximation="
                 f"\"{p['discrete_contact_approximation']}\", contact_model="
                 f"\"{p.get('contact_model', 'point')}\"), builder)",
                 "props = ProximityProperties()  # for the ball and the plate each",
                 f"AddContactMaterial({diss}point_stiffness="
                 f"{_g(2.0 * float(p['point_stiffness']))}, friction=CoulombFriction(0, 0), "
                 "properties=props)  # each 2k: the pair is k"]
        if "relaxation_time" in p:
            lines.append(f"props.AddProperty(\"material\", \"relaxation_time\", "
                         f"{_g(p['relaxation_time'])})")
        return "\n".join(lines)
    if engine == "sapien":
        lines = ["cfg = sapien.physx.PhysxSceneConfig()"]
        if "bounce_threshold" in p:
            lines.append(f"cfg.bounce_threshold = {_g(p['bounce_threshold'])}")
        lines += ["sapien.physx.set_scene_config(cfg)  # before creating the scene",
                  f"scene.set_timestep({_g(dt)})",
                  f"material = sapien.physx.PhysxMaterial(0.0, 0.0, {_g(p['restitution'])})"
                  "  # ball and plate"]
        return "\n".join(lines)
    if engine == "dart":
        return (f"world.setTimeStep({_g(dt)})\n"
                f"ball_shape_node.getDynamicsAspect().setRestitutionCoeff("
                f"{_g(p['restitution_coeff'])})\n"
                "plate_shape_node.getDynamicsAspect().setRestitutionCoeff(1.0)  # DART multiplies")
    if engine == "box2d":
        return (f"world.Step({_g(dt)}, 8, 3)  # every step\n"
                f"ball.CreateCircleFixture(radius=R, density=rho, restitution="
                f"{_g(p['restitution'])})  # plate fixture: restitution 0 (Box2D takes the max)")
    if engine == "newton":
        text = (f"cfg = newton.ModelBuilder.ShapeConfig(ke={_g(p['ke'])}, kd={_g(p['kd'])})"
                "  # ball and plate shapes\n"
                f"solver = newton.solvers.SolverFeatherstone(model); step dt = {_g(dt)}")
        if mass_kg and float(p["kd"]) * dt / mass_kg > 1.0:
            text += (f"\n# kd·dt/m = {float(p['kd']) * dt / mass_kg:.3g} > 1: the approach "
                     "speed reverses within one step (the explicit damping overshoots), which "
                     "is where this rebound comes from: valid at this step only")
        return text
    raise ValueError(f"engine = {engine!r}: no snippet for it")


def restitution_floor_m_s(engine: str) -> float:
    """The approach speed below which the engine applies no restitution whatever is set
    (m/s; 0 where none is left after the model's fixed settings): Box2D's compiled-in
    ``b2_velocityThreshold`` (1 m/s); PyBullet and SAPIEN set theirs to 0; DART's 0.1 m/s
    applies to the rebound target e·v, pymunk has none."""
    return 1.0 if engine == "box2d" else 0.0


def finite_params(params: Mapping[str, Any]) -> bool:
    """True when every number in ``params`` is finite (a candidate worth running)."""
    def ok(v: Any) -> bool:
        if isinstance(v, list | tuple):
            return all(ok(x) for x in v)
        return not isinstance(v, float) or math.isfinite(v)
    return all(ok(v) for v in params.values())
