"""What each engine's cube-toss fit searches: named knobs and how they map onto its own keys.

One :class:`TossSpace` per engine (:data:`PYBULLET`, :data:`MUJOCO` — MJX's too —,
:data:`DRAKE`, :data:`SAPIEN`, :data:`DART`, :data:`NEWTON`), named by the engine's
:class:`~impactbench.engines.registry.EngineSpec` under ``spaces["tosses"]`` (:data:`FIT`):
the one place per engine, beside its ball and oblique spaces. :data:`SPACES` reads them from
the specs.

Knobs (:class:`impactbench.engines.knobs.Knob`, the one tuner's): bounds, log-scaled where a
knob spans decades, a categorical where the engine has a discrete choice (MuJoCo's friction
cone). The start is the middle of each box (the geometric mean of a log knob), never DAIR's
fitted values: those were fitted on all tosses, test tosses included. Each knob maps onto the
engine's keys so that the *effective* pair value is the knob (both bodies set where the engine
combines them).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from impactbench.engines import registry
from impactbench.engines.knobs import Knob

FIT = "tosses"
"""The fit these spaces serve (the key of ``EngineSpec.spaces``)."""

DRAKE_APPROXIMATION = "sap"
"""Drake's discrete solver in a fit, fixed: SAP (DAIR's parameters replay best under it, and it
is not deprecated as TAMSI is); lagged and similar, the other current choices, run at about the
same speed and would need a categorical knob — more evaluations than one Drake budget holds
(a training evaluation takes 10–30 s on 2 shared cores)."""


@dataclass(frozen=True)
class TossSpace:
    """An engine's cube-toss knobs and ``params``, knob values → the engine's own keys."""

    knobs: tuple[Knob, ...]
    params: Callable[[Mapping[str, Any]], dict[str, Any]]


def _friction(note: str) -> Knob:
    return Knob("friction", 0.02, 2.0, unit="", note=note)


def _pybullet(k: Mapping[str, Any]) -> dict[str, Any]:
    return {"board.contactStiffness": k["stiffness"], "board.contactDamping": k["damping"],
            "board.lateralFriction": k["friction"], "cube.lateralFriction": 1.0}


def _mujoco(k: Mapping[str, Any]) -> dict[str, Any]:
    solref = (-k["stiffness"], -k["damping"])
    friction = (k["friction"], 0.005, 0.0001)
    solimp = (k["solimp_dmin"], k["solimp_dmax"], k["solimp_width"], 0.5, 2.0)
    return {"board.solref": solref, "cube.solref": solref, "board.friction": friction,
            "cube.friction": friction, "board.solimp": solimp, "cube.solimp": solimp,
            "option.cone": k["cone"], "option.impratio": k["impratio"]}


def _drake(k: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {"contact_model": "point",
                           "discrete_contact_approximation": DRAKE_APPROXIMATION}
    for body in ("board", "cube"):
        out |= {f"{body}.point_contact_stiffness": 2.0 * k["stiffness"],
                f"{body}.mu": k["friction"],
                f"{body}.relaxation_time": k["relaxation_time"]}
    return out


def _sapien(k: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {"bounce_threshold": k["bounce_threshold"]}
    for body in ("board", "cube"):
        out |= {f"{body}.static_friction": k["friction"],
                f"{body}.dynamic_friction": k["friction"],
                f"{body}.restitution": k["restitution"]}
    return out


def _dart(k: Mapping[str, Any]) -> dict[str, Any]:
    return {"board.friction_coeff": k["friction"], "cube.friction_coeff": k["friction"],
            "board.restitution_coeff": k["restitution"], "cube.restitution_coeff": 1.0}


def _newton(k: Mapping[str, Any]) -> dict[str, Any]:
    return {f"{body}.{name}": k["friction" if name == "mu" else name]
            for body in ("board", "cube") for name in ("ke", "kd", "kf", "mu")}


PYBULLET = TossSpace((
    Knob("stiffness", 1e2, 1e6, unit="N/m", note="board.contactStiffness (the cube unset: "
         "1e30 in series, so the pair's value is the board's)"),
    Knob("damping", 0.1, 1e3, unit="N·s/m", note="board.contactDamping (pair: + the "
         "cube's 0.1)"),
    _friction("board.lateralFriction, cube.lateralFriction = 1 (Bullet multiplies)"),
), _pybullet)
MUJOCO = TossSpace((
    Knob("stiffness", 1e2, 1e6, unit="1/s² (per unit effective mass)",
         note="direct solref (−k, −b) on both geoms"),
    Knob("damping", 1.0, 1e3, unit="1/s", note="direct solref (−k, −b) on both geoms"),
    _friction("friction (μ, 0.005, 0.0001) on both geoms (MuJoCo takes the larger)"),
    Knob("solimp_dmin", 0.5, 0.9999, log=False, note="solimp[0] on both geoms"),
    Knob("solimp_dmax", 0.5, 0.9999, log=False, note="solimp[1] on both geoms"),
    Knob("solimp_width", 1e-4, 0.1, unit="m", note="solimp[2] on both geoms "
         "(midpoint 0.5, power 2 kept)"),
    Knob("cone", choices=("pyramidal", "elliptic"), note="option.cone"),
    Knob("impratio", 1.0, 100.0, note="option.impratio (frictional/normal impedance)"),
), _mujoco)
"""MuJoCo's knobs, and MJX's (the same model and keys)."""
DRAKE = TossSpace((
    Knob("stiffness", 1e3, 1e6, unit="N/m", note="effective pair point_contact_stiffness: "
         "both geometries 2k (in series)"),
    _friction("mu (static = dynamic) on both (Drake combines 2ab/(a + b))"),
    Knob("relaxation_time", 1e-4, 1.0, unit="s", note="relaxation_time on both (SAP's "
         "linear dissipation; SAP ignores hunt_crossley_dissipation)"),
), _drake)
SAPIEN = TossSpace((
    _friction("static = dynamic friction of both materials (PhysX averages)"),
    Knob("restitution", 0.0, 0.9, log=False, note="restitution of both materials "
         "(rigid contact; PhysX's compliant contact is undamped, not searched)"),
    Knob("bounce_threshold", 0.01, 5.0, unit="m/s", note="scene bounce_threshold"),
), _sapien)
DART = TossSpace((
    _friction("friction_coeff of both shapes (DART takes the smaller)"),
    Knob("restitution", 0.0, 0.9, log=False, note="board.restitution_coeff, cube 1 "
         "(DART multiplies)"),
), _dart)
NEWTON = TossSpace((
    Knob("ke", 1e2, 3e5, unit="N/m", note="ke of both shapes (averaged); semi-implicit "
         "stepping is unstable above ~3e5 at the protocol's step"),
    Knob("kd", 0.1, 300.0, unit="N·s/m", note="kd of both shapes"),
    Knob("kf", 1.0, 1e5, unit="N·s/m", note="kf (friction regularisation) of both shapes"),
    _friction("mu of both shapes"),
), _newton)


def toss_space(engine: str) -> TossSpace:
    """``engine``'s :class:`TossSpace`, from its spec (ValueError naming the tunable
    engines)."""
    found = registry.tuning_space(engine, FIT)
    if not isinstance(found, TossSpace):
        raise ValueError(f"engine = {engine!r}: tunable on the cube tosses: "
                         f"{', '.join(registry.with_space(FIT))}")
    return found


class _Spaces(Mapping[str, tuple[Knob, ...]]):
    """engine → its cube-toss knobs, from every registered engine's spec at each access."""

    def __getitem__(self, engine: str) -> tuple[Knob, ...]:
        found = registry.tuning_space(engine, FIT)
        if found is None:
            raise KeyError(engine)
        return found.knobs

    def __iter__(self) -> Iterator[str]:
        return iter(registry.with_space(FIT))

    def __len__(self) -> int:
        return len(registry.with_space(FIT))


SPACES: Mapping[str, tuple[Knob, ...]] = _Spaces()
"""engine → its knobs (bounds, scale), read from the engines' specs; :func:`engine_params`
maps them onto engine keys."""


def space(engine: str) -> tuple[Knob, ...]:
    """The knobs of ``engine`` (ValueError naming the tunable engines)."""
    return toss_space(engine).knobs


def engine_params(engine: str, knobs: Mapping[str, Any]) -> dict[str, Any]:
    """The engine's own keys for the knob values ``knobs`` (module doc)."""
    return toss_space(engine).params(dict(knobs))


__all__ = ["DART", "DRAKE", "DRAKE_APPROXIMATION", "FIT", "MUJOCO", "NEWTON", "PYBULLET",
           "SAPIEN", "SPACES", "Knob", "TossSpace", "engine_params", "space", "toss_space"]
