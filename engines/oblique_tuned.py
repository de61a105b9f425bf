"""``tuned`` mode of the oblique scenario: the engine's ``native`` oblique run (its native
normal contact, μ from the scenario) with its FRICTION-RELATED parameters replaced by values
fitted against the rigid reference over an angle sweep at one timestep
(``impactbench tune --scenario oblique``, :mod:`impactbench.tuning.oblique`).

:data:`MUJOCO`, :data:`PYBULLET`, … (one tuple per engine, named by the engine's
:class:`~impactbench.engines.registry.EngineSpec` under ``spaces["friction"]``; :data:`SPACES`
reads them from the specs) state what a fit moves as :class:`~impactbench.engines.knobs.Knob`
(the one knob type of every fit; here relative to the scenario, resolved per scenario and step),
named by the engine's own keys (what its ``custom`` mode spells them, or its API's name where
``custom`` has none), its ``note`` what the key does: the scale (``log``,
``linear`` or a ``choice``), the bounds (absolute, or multiples of the scenario's μ or of the
start value) and the start, which is the native run's own value — so a tuned run at the start
values is the native run, and a fit that keeps its best evaluation is never worse than native
on its objective.

The adapters read a tuned file's ``[parameters]`` through :func:`refused` (no parameters, or
keys of another scenario's file: ``unsupported`` with the reason) and :func:`friction` (the
validated values, the native ones for keys the file leaves out), and put :func:`meta` into the
record. The 2D engines' spaces (pymunk, Box2D) are here too; their ``run_oblique`` is not wired
to them yet (it still returns ``unsupported`` for ``tuned``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Any

from impactbench.engines import registry
from impactbench.engines.knobs import Knob, scenario_friction
from impactbench.reference.record import ImpactRecord, Status

SCALES = ("log", "linear", "choice")
"""A knob's :attr:`~impactbench.engines.knobs.Knob.scale`."""


def _mu(meaning: str, key: str) -> Knob:
    return Knob(key, 0.5, 2.0, log=False, per="friction", initial=scenario_friction,
                note=meaning)


def _newton_kf(scenario: Any, dt: float | None) -> float:
    """Newton's native kf, the deadbeat m_s/dt (``newton_adapter.deadbeat_kf``)."""
    from impactbench.engines.stepping import slip_mass_kg

    if dt is None:
        raise ValueError("timestep_s = None: Newton's kf start (m_s/dt) needs the step")
    return slip_mass_kg(scenario) / dt


MUJOCO = (
    Knob("cone", choices=("pyramidal", "elliptic"), initial="pyramidal",
         note="MuJoCo's friction cone (option cone; native: its default pyramidal)"),
    Knob("impratio", 1.0, 1e4, initial=1.0,
         note="friction-to-normal impedance ratio (option impratio): the friction rows' "
                 "regulariser is the normal's / impratio (native: MuJoCo's default 1)"),
    _mu("the geoms' sliding friction (both geoms; MuJoCo takes the larger: the pair's μ)",
        "friction"),
)
"""MuJoCo's and MJX's knobs. Left out: ``solreffriction`` (it needs an explicit ``<pair>``;
the elliptic cone with a large ``impratio`` already sticks to 1e-4)."""
PYBULLET = (
    Knob("frictionAnchor", choices=(0, 1), initial=0,
         note="changeDynamics frictionAnchor on the ball: keep the contact point where "
                 "it was created (native: Bullet's default, off)"),
    _mu("changeDynamics lateralFriction on the ball (the plate's is 1; Bullet multiplies: "
        "the pair's μ)", "lateralFriction"),
)
DRAKE = (
    _mu("CoulombFriction(μ, μ) of both geometries (proximity property material/"
        "coulomb_friction, static = dynamic; Drake's pair rule 2ab/(a + b) gives μ)",
        "coulomb_friction"),
    Knob("stiction_tolerance", 1e-6, 1e-2, initial=1e-4,
         note="MultibodyPlant.set_stiction_tolerance (m/s): the regularised Stribeck "
                 "friction rises to μ·F_n over this slip speed (native: Drake's 1e-4)"),
)
SAPIEN = (
    _mu("PhysX material static friction (both materials; the pair averages)",
        "static_friction"),
    _mu("PhysX material dynamic friction (both materials; the pair averages)",
        "dynamic_friction"),
)
"""Left out: ``enable_friction_every_iteration`` (measured: the same objective to 1e-9 either
way on the paper's ball)."""
DART = (
    _mu("DynamicsAspect friction_coeff of both shapes (DART takes the smaller)",
        "friction_coeff"),
)
NEWTON = (
    _mu("ShapeConfig mu of both shapes (Newton averages)", "mu"),
    Knob("kf", 1e-3, 1.0, per="start", initial=_newton_kf,
         note="ShapeConfig kf (N·s/m): F_t = −kf·v_slip capped at μ·F_n; start the "
                 "deadbeat m_s/dt, the stiffest that does not overshoot the stick (above "
                 "it the slip alternates in sign each step, beyond 2·m_s/dt it diverges)"),
)
PYMUNK = (
    _mu("the ball shape's friction (the plate's is 1; Chipmunk multiplies: the pair's μ)",
        "friction"),
)
BOX2D = (
    _mu("both fixtures' friction (b2MixFriction √(μ·μ) = μ)", "friction"),
)

FIT = "friction"
"""The fit these knobs serve: an engine's :class:`~impactbench.engines.registry.EngineSpec`
names its tuple above under this key of ``spaces`` (the one place per engine)."""


class _Spaces(Mapping[str, tuple[Knob, ...]]):
    """engine → the knobs of its oblique ``tuned`` mode, read from each registered engine's
    spec (``spaces["friction"]``) at each access: a plug-in engine brings its own."""

    def __getitem__(self, engine: str) -> tuple[Knob, ...]:
        found = registry.tuning_space(engine, FIT)
        if found is None:
            raise KeyError(engine)
        return tuple(found)

    def __iter__(self) -> Iterator[str]:
        return iter(registry.with_space(FIT))

    def __len__(self) -> int:
        return len(registry.with_space(FIT))


SPACES: Mapping[str, tuple[Knob, ...]] = _Spaces()
"""Engine → the knobs of its oblique ``tuned`` mode (module doc), from the engines' specs. The
2D engines' (pymunk, Box2D) are stated for the fitting code; their adapters do not read them
yet."""


def knobs(engine: str) -> tuple[Knob, ...]:
    """The knobs of ``engine`` (ValueError naming the engines that have a space)."""
    if engine not in SPACES:
        raise ValueError(f"engine = {engine!r}: no oblique tuning space (engines: "
                         f"{', '.join(SPACES)})")
    return SPACES[engine]


def tuned_keys(engine: str) -> tuple[str, ...] | None:
    """The keys an oblique tuned file's ``[parameters]`` may hold for ``engine`` (None: an
    engine without an oblique space, whose files are not checked)."""
    return tuple(k.name for k in SPACES[engine]) if engine in SPACES else None


def start_values(engine: str, scenario: Any, dt: float | None) -> dict[str, Any]:
    """The native run's value of every knob (the fit's start)."""
    return {k.name: k.start_value(scenario, dt) for k in knobs(engine)}


def refused(engine: str, settings: Any) -> ImpactRecord | None:
    """``unsupported`` with the reason when a ``tuned`` oblique run has nothing to apply: no
    tuned parameters (no file), or keys that are not this engine's oblique friction keys (a
    ball-on-plate file); None when the run can go ahead."""
    valid = tuned_keys(engine) or ()
    how = (f"fit them with `impactbench tune --scenario oblique --engine {engine} "
           "--timestep S --out FILE`, then run --mode tuned --tuned FILE")
    tuned = settings.tuned or {}
    if not tuned:
        return ImpactRecord.failed(
            Status.UNSUPPORTED, f"tuned oblique: needs a tuned file of {engine}'s friction "
            f"parameters ({', '.join(valid)}), none given; {how}")
    foreign = [k for k in tuned if k not in valid]
    if foreign:
        return ImpactRecord.failed(
            Status.UNSUPPORTED, f"tuned oblique: {', '.join(foreign)} "
            f"{'is' if len(foreign) == 1 else 'are'} not {engine}'s oblique friction "
            f"parameter{'' if len(foreign) == 1 else 's'} ({', '.join(valid)}): the tuned "
            f"parameters are another scenario's (ball-on-plate?); {how}")
    return None


def friction(engine: str, settings: Any, scenario: Any, dt: float | None = None
             ) -> dict[str, Any]:
    """Every knob's value for a ``tuned`` run: the tuned parameters' (validated, one-line
    ValueError) and the native value for a key they leave out."""
    given = settings.tuned or {}
    out = {}
    for k in knobs(engine):
        out[k.name] = (k.check(given[k.name], engine) if k.name in given
                       else k.start_value(scenario, dt))
    return out


def meta(applied: dict[str, Any], settings: Any) -> dict[str, Any]:
    """What a tuned oblique record carries: the parameters applied (``params``, which
    ``run --json`` shows, and ``tuned``) and the tuned file they came from."""
    out: dict[str, Any] = {"params": dict(applied), "tuned": dict(applied)}
    prov = settings.tuned_for or {}
    if prov.get("file"):
        out["tuned_file"] = prov["file"]
    return out


def run_stepped(adapter: Any, scenario: Any, settings: Any,
                run: Callable[..., ImpactRecord] | None = None) -> ImpactRecord:
    """``tuned`` oblique for an adapter on :class:`impactbench.engines.stepping.SteppedAdapter`
    (SAPIEN, DART; Box2D once wired): :func:`refused`, then the adapter's
    ``oblique_parameters(scenario, "tuned", settings)`` (native plus :func:`friction`) run by
    its oblique model through ``stepping.run_oblique``."""
    from impactbench.engines import stepping

    no = refused(adapter.name, settings)
    if no is not None:
        return no
    dt = float(settings.timestep_s)
    params, info = adapter.oblique_parameters(scenario, "tuned", settings)
    model = adapter.oblique_model(scenario, params, dt, None)
    return (run or stepping.run_oblique)(model, scenario, dt, settings.max_time_s, info)


__all__ = ["BOX2D", "DART", "DRAKE", "FIT", "MUJOCO", "NEWTON", "PYBULLET", "PYMUNK",
           "SAPIEN", "SCALES", "SPACES", "Knob", "friction", "knobs", "meta", "refused",
           "run_stepped", "start_values", "tuned_keys"]
