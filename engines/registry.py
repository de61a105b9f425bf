"""One :class:`EngineSpec` per engine, and the plug-in registry: standard library only.

An engine is its adapter module plus one spec here: the adapter's entry point
(``"module:Class"``, imported only when the engine is used), the pip command and extra that
install it, the distribution whose version results record, its tuning parameterisations
(``"module:function"`` building a tuning space, imported only by ``tune``) and the steps its
users customarily run it at. Everything else that needs an engine's facts — the CLI's choices,
the store's versions, the tests' skips, the tuner — reads them from :data:`SPECS`.

Kept apart from :mod:`impactbench.engines.base` (which needs numpy for the records) so that the
command line can build its parser, with engine and mode choices, without importing numpy or
any engine. :mod:`impactbench.engines.base` re-exports every name here.

Third-party engines register through ``IMPACTBENCH_ENGINES=name=module:Class`` (a spec with
that adapter and nothing else: no tuning, its version from the adapter's ``version()``).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass

MODES: tuple[str, ...] = ("native", "injected", "tuned", "default", "custom")


@dataclass(frozen=True)
class EngineSpec:
    """What the suite knows about one engine without importing it.

    Attributes:
        name: the registry name (``--engine``).
        adapter: ``"module:Class"`` of its :class:`~impactbench.engines.base.Adapter`.
        pip: the command that installs it (named in every ``unavailable`` message and skip).
        extra: impactbench's optional-dependency extra (``pip install 'impactbench[extra]'``).
        distribution: the PyPI distribution whose version results record.
        module: the top-level module it is imported as (tests skip on it; version checks
            make sure that module comes from ``distribution``).
        tuning: ``{parameterisation: "module:function"}`` (the first is the default): the
            function builds the tuning space, ``f(scenario, variant, timestep_s, **options)``.
        customary_timesteps_s: the steps its users run it at (s), for "at your timestep".
    """

    name: str
    adapter: str
    pip: str
    extra: str = ""
    distribution: str = ""
    module: str = ""
    tuning: tuple[tuple[str, str], ...] = ()
    customary_timesteps_s: tuple[float, ...] = ()

    @property
    def variants(self) -> tuple[str, ...]:
        """The tuning parameterisations (the first is the default); () when not tunable."""
        return tuple(name for name, _ in self.tuning)


_TUNE = "impactbench.tuning.spaces"
_MORE = "impactbench.tuning.spaces_extras"

BUILTIN: tuple[EngineSpec, ...] = (
    EngineSpec("mujoco", "impactbench.engines.mujoco_adapter:MujocoAdapter",
               "pip install mujoco", "mujoco", "mujoco", "mujoco",
               (("solref+solimp", f"{_TUNE}:mujoco_space"), ("solref", f"{_TUNE}:mujoco_space")),
               (2e-3, 1e-3)),
    EngineSpec("pybullet", "impactbench.engines.pybullet_adapter:PybulletAdapter",
               "pip install pybullet", "pybullet", "pybullet", "pybullet",
               (("stiffness+damping", f"{_TUNE}:pybullet_space"),), (1 / 240,)),
    EngineSpec("pymunk", "impactbench.engines.pymunk_adapter:PymunkAdapter",
               "pip install pymunk", "pymunk", "pymunk", "pymunk",
               (("elasticity", f"{_TUNE}:pymunk_space"),
                ("restitution-law", f"{_TUNE}:pymunk_space")), (1 / 60, 1e-3)),
    EngineSpec("drake", "impactbench.engines.drake_adapter:DrakeAdapter",
               "pip install drake", "drake", "drake", "pydrake",
               (("stiffness+dissipation", f"{_TUNE}:drake_space"),
                ("stiffness+relaxation", f"{_TUNE}:drake_relaxation_space")), (1e-3,)),
    EngineSpec("sapien", "impactbench.engines.sapien_adapter:SapienAdapter",
               "pip install sapien", "sapien", "sapien", "sapien",
               (("compliant-stiffness", f"{_MORE}:sapien_space"),
                ("restitution", f"{_MORE}:sapien_space"))),
    EngineSpec("dart", "impactbench.engines.dart_adapter:DartAdapter",
               "pip install dartpy", "dart", "dartpy", "dartpy",
               (("restitution", f"{_MORE}:dart_space"),)),
    EngineSpec("box2d", "impactbench.engines.box2d_adapter:Box2dAdapter",
               "pip install box2d", "box2d", "box2d", "Box2D",
               (("restitution", f"{_MORE}:box2d_space"),)),
    EngineSpec("mjx", "impactbench.engines.mjx_adapter:MjxAdapter",
               "pip install mujoco-mjx jax", "mjx", "mujoco-mjx", "mujoco.mjx",
               (("solref+solimp", f"{_TUNE}:mujoco_space"), ("solref", f"{_TUNE}:mujoco_space"))),
    EngineSpec("newton", "impactbench.engines.newton_adapter:NewtonAdapter",
               "pip install newton", "newton", "newton", "newton",
               (("ke+kd", f"{_MORE}:newton_space"),)),
)
"""The packaged engines, in the report's order."""

SPECS: dict[str, EngineSpec] = {s.name: s for s in BUILTIN}
ENGINES: dict[str, str] = {s.name: s.adapter for s in BUILTIN}
"""engine → ``"module:Class"`` of the packaged adapters."""
PIP: dict[str, str] = {s.name: s.pip for s in BUILTIN}
"""engine → the pip command that installs it."""

ENGINES_ENV = "IMPACTBENCH_ENGINES"
"""Extra adapters, ``name=module:Class`` separated by commas (plug in your own engine)."""
DISABLE_ENV = "IMPACTBENCH_DISABLE_ENGINES"
"""Engines to treat as not installed, comma separated (e.g. to skip a broken install)."""


def _registry() -> dict[str, str]:
    out = dict(ENGINES)
    for item in filter(None, (x.strip() for x in os.environ.get(ENGINES_ENV, "").split(","))):
        name, sep, target = item.partition("=")
        if not sep or ":" not in target:
            raise ValueError(f"{ENGINES_ENV} entry {item!r}: must be name=module:Class")
        out[name.strip()] = target.strip()
    return out


def engine_names() -> tuple[str, ...]:
    """Registered engine names, including plug-ins from ``IMPACTBENCH_ENGINES``."""
    return tuple(_registry())


def spec(name: str) -> EngineSpec:
    """The spec of engine ``name``: the packaged one, or a plug-in's (its adapter only).
    ValueError for an unknown name."""
    registry = _registry()
    if name not in registry:
        import difflib

        hint = difflib.get_close_matches(name, registry, n=1)
        more = f" (did you mean {hint[0]!r}?)" if hint else ""
        raise ValueError(f"engine = {name!r}: must be one of {', '.join(registry)}{more}")
    builtin = SPECS.get(name)
    if builtin is not None and builtin.adapter == registry[name]:
        return builtin
    return EngineSpec(name, registry[name], f"pip install {name}")


def is_builtin(name: str) -> bool:
    """True when ``name`` is a packaged engine not replaced by a plug-in."""
    return name in SPECS and _registry().get(name) == SPECS[name].adapter


@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """Send C-level stdout to stderr for the duration (engines print banners on import —
    pybullet its build time — which would corrupt ``--json`` output)."""
    import ctypes

    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        with contextlib.suppress(Exception):
            ctypes.CDLL(None).fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
