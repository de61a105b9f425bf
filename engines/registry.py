"""One :class:`EngineSpec` per engine, and the plug-in registry: standard library only.

An engine is its adapter module plus one spec here: the adapter's entry point
(``"module:Class"``, imported only when the engine is used), the pip command and extra that
install it, the distribution whose version results record, its tuning parameterisations
(``"module:function"`` building a tuning space, imported only by ``tune``) and its other fits'
knobs (``spaces``), the steps its users customarily run it at and its colour in every figure.
Everything else that needs an engine's facts — the CLI's choices, the store's versions, the
tests' skips, the tuner, the plots — reads them from here (:func:`spec`), never from a table
keyed by engine name.

Kept apart from :mod:`impactbench.engines.base` (which needs numpy for the records) so that the
command line can build its parser, with engine and mode choices, without importing numpy or
any engine. :mod:`impactbench.engines.base` re-exports every name here.

Third-party engines plug in two ways:

- the entry-point group ``impactbench.engines`` (as scenarios do through
  ``impactbench.scenarios``): the value is ``"module:attr"`` of an :class:`EngineSpec` whose
  ``name`` is the entry point's name, e.g. in the plug-in's ``pyproject.toml``::

      [project.entry-points."impactbench.engines"]
      euler = "impactbench_euler:SPEC"

  The entry points are read once per process (cached) when the registry is first asked for
  its names, which imports the named module: keep it light (the spec only, standard library;
  the adapter, which may import numpy and the engine, is ``SPEC.adapter`` and is imported
  when the engine runs). A plug-in cannot replace a packaged engine. A plug-in that fails to
  load (its module is missing or raises on import, the attribute is not a spec of that name)
  does not stop anything else: one line on stderr names the entry point, its package and the
  error, and the engine stays listed, ``unavailable`` with that message
  (``examples/plugin-engine-euler/`` in the repository is a complete plug-in);
- ``IMPACTBENCH_ENGINES=name=module:Class`` (a spec with that adapter and nothing else: no
  tuning, its version from the adapter's ``version()``); it may replace any engine.

Plug-in adapters are reached through :mod:`impactbench.engines.plugins`
(``"impactbench.engines.plugins:NAME"`` in :data:`ENGINES`), which imports ``SPEC.adapter``
and turns an import failure into :class:`~impactbench.engines.base.EngineUnavailable`.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import zlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass

MODES: tuple[str, ...] = ("native", "injected", "tuned", "default", "custom")

ENTRY_POINT_GROUP = "impactbench.engines"
"""The entry-point group third-party engines register in (value: ``"module:attr"`` of an
:class:`EngineSpec`)."""
PLUGIN_ADAPTERS = "impactbench.engines.plugins"
"""The module every entry-point plug-in's adapter is imported through (a guard: see
:mod:`impactbench.engines.plugins`)."""

FALLBACK_COLORS: tuple[str, ...] = ("darkgoldenrod", "indigo", "crimson", "navy", "darkkhaki",
                                    "slategray", "deeppink", "sienna", "darkseagreen",
                                    "maroon")
"""Colours (matplotlib names) of engines whose spec sets none, picked by a CRC-32 of the
name (the same colour in every run and process); none is a packaged engine's colour."""


def fallback_color(name: str) -> str:
    """The colour of an engine without one on its spec: deterministic in ``name``."""
    return FALLBACK_COLORS[zlib.crc32(name.encode()) % len(FALLBACK_COLORS)]


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
            function builds the contact fit's space (the ball's, ``impactbench tune``),
            ``f(scenario, variant, timestep_s, **options)``.
        customary_timesteps_s: the steps its users run it at (s), for "at your timestep".
        advice_timesteps_s: the steps the advice covers (s; ``impactbench advise``'s default
            is the first): the customary steps, or for an engine without a default step of
            its own the one its examples use (SAPIEN's 10 ms, DART's 1 ms, Box2D's frame,
            Newton's 1/1200 s).
        color: its colour in every figure (a matplotlib colour); "" for
            :func:`fallback_color` (see :attr:`plot_color`).
        spaces: ``{fit: "module:attr"}``: the knobs of its other fits, by the fit's name
            (:data:`FITS`: ``friction``, the oblique impact's friction knobs; ``tosses``, the
            cube tosses' contact knobs), each read by that fit's module
            (:func:`tuning_space`). With ``tuning``, every tuning space of the engine is
            reached from here, in one place per engine.
        first_use_s: what a run's timeout allows on top for the engine's first use in a
            process, compiling (s): JIT engines compile their kernels on first use, which
            is no hang; 0 for an engine that does not compile.
        compile_cache: ``"module:function"`` of a function (standard library only) giving
            the folder where the engine keeps what it compiles; "" for an engine that
            compiles nothing (:meth:`compile_cache_warm`).
    """

    name: str
    adapter: str
    pip: str
    extra: str = ""
    distribution: str = ""
    module: str = ""
    tuning: tuple[tuple[str, str], ...] = ()
    customary_timesteps_s: tuple[float, ...] = ()
    advice_timesteps_s: tuple[float, ...] = ()
    color: str = ""
    spaces: tuple[tuple[str, str], ...] = ()
    first_use_s: float = 0.0
    compile_cache: str = ""

    def compile_cache_warm(self) -> bool | None:
        """Whether the engine's compile cache (:attr:`compile_cache`) holds anything — its
        first run here loads what an earlier one compiled — or None where it keeps none."""
        if not self.compile_cache:
            return None
        import importlib

        from impactbench.engines.compile_caches import holds_anything

        module, _, attr = self.compile_cache.partition(":")
        return holds_anything(getattr(importlib.import_module(module), attr)())

    @property
    def variants(self) -> tuple[str, ...]:
        """The tuning parameterisations (the first is the default); () when not tunable."""
        return tuple(name for name, _ in self.tuning)

    @property
    def plot_color(self) -> str:
        """:attr:`color`, or the deterministic fallback for a spec that sets none."""
        return self.color or fallback_color(self.name)


FITS: dict[str, str] = {
    "friction": "the oblique impact's friction knobs (impactbench.tuning.oblique)",
    "tosses": "the cube tosses' contact knobs (impactbench.cube_tosses.tune)",
}
"""The fits whose knobs an :class:`EngineSpec` lists in ``spaces`` (besides ``tuning``)."""

# Every tuning space is an engine-layer module's (impactbench.engines.tuning_spaces and
# tuning_spaces_extras: the ball's; oblique_tuned: the oblique friction knobs;
# cube_toss_spaces: the cube tosses'), spelled out in full: tests/impactbench/
# test_architecture.py reads these strings as import arrows.
BUILTIN: tuple[EngineSpec, ...] = (
    EngineSpec("mujoco", "impactbench.engines.mujoco_adapter:MujocoAdapter",
               "pip install mujoco", "mujoco", "mujoco", "mujoco",
               (("solref+solimp", "impactbench.engines.tuning_spaces:mujoco_space"),
                ("solref", "impactbench.engines.tuning_spaces:mujoco_space")),
               (2e-3, 1e-3), color="tab:blue", advice_timesteps_s=(2e-3, 1e-3),
               spaces=(("friction", "impactbench.engines.oblique_tuned:MUJOCO"),
                       ("tosses", "impactbench.engines.cube_toss_spaces:MUJOCO"))),
    EngineSpec("pybullet", "impactbench.engines.pybullet_adapter:PybulletAdapter",
               "pip install pybullet", "pybullet", "pybullet", "pybullet",
               (("stiffness+damping", "impactbench.engines.tuning_spaces:pybullet_space"),),
               (1 / 240,), color="tab:orange", advice_timesteps_s=(1 / 240,),
               spaces=(("friction", "impactbench.engines.oblique_tuned:PYBULLET"),
                       ("tosses", "impactbench.engines.cube_toss_spaces:PYBULLET"))),
    EngineSpec("pymunk", "impactbench.engines.pymunk_adapter:PymunkAdapter",
               "pip install pymunk", "pymunk", "pymunk", "pymunk",
               (("elasticity", "impactbench.engines.tuning_spaces:pymunk_space"),
                ("restitution-law", "impactbench.engines.tuning_spaces:pymunk_space")),
               (1 / 60, 1e-3), color="tab:green", advice_timesteps_s=(1 / 60, 1e-3),
               spaces=(("friction", "impactbench.engines.oblique_tuned:PYMUNK"),)),
    EngineSpec("drake", "impactbench.engines.drake_adapter:DrakeAdapter",
               "pip install drake", "drake", "drake", "pydrake",
               (("stiffness+dissipation", "impactbench.engines.tuning_spaces:drake_space"),
                ("stiffness+relaxation",
                 "impactbench.engines.tuning_spaces:drake_relaxation_space")),
               (1e-3,), color="tab:red", advice_timesteps_s=(1e-3,),
               spaces=(("friction", "impactbench.engines.oblique_tuned:DRAKE"),
                       ("tosses", "impactbench.engines.cube_toss_spaces:DRAKE"))),
    EngineSpec("sapien", "impactbench.engines.sapien_adapter:SapienAdapter",
               "pip install sapien", "sapien", "sapien", "sapien",
               (("compliant-stiffness", "impactbench.engines.tuning_spaces_extras:sapien_space"),
                ("restitution", "impactbench.engines.tuning_spaces_extras:sapien_space")),
               color="tab:purple", advice_timesteps_s=(1e-2,),
               spaces=(("friction", "impactbench.engines.oblique_tuned:SAPIEN"),
                       ("tosses", "impactbench.engines.cube_toss_spaces:SAPIEN"))),
    EngineSpec("dart", "impactbench.engines.dart_adapter:DartAdapter",
               "pip install dartpy", "dart", "dartpy", "dartpy",
               (("restitution", "impactbench.engines.tuning_spaces_extras:dart_space"),),
               color="tab:brown", advice_timesteps_s=(1e-3,),
               spaces=(("friction", "impactbench.engines.oblique_tuned:DART"),
                       ("tosses", "impactbench.engines.cube_toss_spaces:DART"))),
    EngineSpec("box2d", "impactbench.engines.box2d_adapter:Box2dAdapter",
               "pip install box2d", "box2d", "box2d", "Box2D",
               (("restitution", "impactbench.engines.tuning_spaces_extras:box2d_space"),),
               color="tab:pink", advice_timesteps_s=(1 / 60,),
               spaces=(("friction", "impactbench.engines.oblique_tuned:BOX2D"),)),
    EngineSpec("mjx", "impactbench.engines.mjx_adapter:MjxAdapter",
               "pip install mujoco-mjx jax", "mjx", "mujoco-mjx", "mujoco.mjx",
               (("solref+solimp", "impactbench.engines.tuning_spaces:mujoco_space"),
                ("solref", "impactbench.engines.tuning_spaces:mujoco_space")),
               color="tab:cyan", advice_timesteps_s=(2e-3, 1e-3),
               spaces=(("friction", "impactbench.engines.oblique_tuned:MUJOCO"),
                       ("tosses", "impactbench.engines.cube_toss_spaces:MUJOCO")),
               # jax compiles each scan kind on first use (2–5 s each on a quiet machine,
               # several kinds per scenario; a busy one timed out at 60 s): ~3× that
               first_use_s=120.0,
               compile_cache="impactbench.engines.compile_caches:jax_cache_dir"),
    EngineSpec("newton", "impactbench.engines.newton_adapter:NewtonAdapter",
               "pip install newton", "newton", "newton", "newton",
               (("ke+kd", "impactbench.engines.tuning_spaces_extras:newton_space"),),
               color="tab:olive", advice_timesteps_s=(1 / 1200,),
               spaces=(("friction", "impactbench.engines.oblique_tuned:NEWTON"),
                       ("tosses", "impactbench.engines.cube_toss_spaces:NEWTON")),
               # warp compiles its kernels on first use: 20–40 s on a quiet machine, ~3×
               first_use_s=120.0,
               compile_cache="impactbench.engines.compile_caches:warp_cache_dir"),
)
"""The packaged engines, in the report's order (colours: matplotlib's tab10, one each)."""

SPECS: dict[str, EngineSpec] = {s.name: s for s in BUILTIN}
"""engine → spec of the packaged engines (:func:`spec` covers plug-ins too)."""

ENGINES_ENV = "IMPACTBENCH_ENGINES"
"""Extra adapters, ``name=module:Class`` separated by commas (plug in your own engine)."""
DISABLE_ENV = "IMPACTBENCH_DISABLE_ENGINES"
"""Engines to treat as not installed, comma separated (e.g. to skip a broken install)."""
WARNED_ENV = "IMPACTBENCH_WARNED_PLUGINS"
"""Entry points whose load failure this process or a parent already reported (comma
separated; set by the registry): worker processes inherit it and stay quiet, so a broken
plug-in costs one line per command, not one per worker."""


@dataclass(frozen=True)
class _Plugins:
    """The entry-point plug-ins: their specs (in name order) and, per broken one, why."""

    specs: dict[str, EngineSpec]
    errors: dict[str, str]


def _warn(key: str, line: str) -> None:
    """Write ``line`` to stderr unless this process or a parent has reported ``key``."""
    warned = {x for x in os.environ.get(WARNED_ENV, "").split(",") if x}
    if key in warned:
        return
    sys.stderr.write(line + "\n")
    sys.stderr.flush()
    os.environ[WARNED_ENV] = ",".join(sorted(warned | {key}))


@functools.cache
def _plugins() -> _Plugins:
    """The ``impactbench.engines`` entry points, loaded once (module doc)."""
    from importlib import metadata

    specs: dict[str, EngineSpec] = {}
    errors: dict[str, str] = {}
    for ep in sorted(metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
        dist = getattr(ep, "dist", None)
        package = f"{dist.name} {dist.version}" if dist is not None else "unknown package"
        where = f"{ep.name} = {ep.value} ({package})"
        group = f"in entry-point group {ENTRY_POINT_GROUP}"
        if ep.name in SPECS:
            _warn(ep.name, f"impactbench: ignored engine plug-in {where} {group}: "
                           f"{ep.name!r} is a packaged engine (a plug-in cannot replace it)")
            continue
        if ep.name in specs:
            _warn(ep.name, f"impactbench: ignored engine plug-in {where} {group}: another "
                           f"package already registers {ep.name!r}")
            continue
        try:
            loaded = ep.load()
        except Exception as exc:  # a broken plug-in must not take the suite down
            why = f"{type(exc).__name__}: {exc}".splitlines()[0]
        else:
            if isinstance(loaded, EngineSpec) and loaded.name == ep.name:
                specs[ep.name] = loaded
                continue
            why = (f"{ep.value} is {type(loaded).__name__} {getattr(loaded, 'name', '')!r}"
                   f": must be an impactbench.engines.registry.EngineSpec named {ep.name!r}")
        errors[ep.name] = f"plug-in {where} failed to load: {why}"
        _warn(ep.name, f"impactbench: engine plug-in {where} {group} failed to load: {why}; "
                       f"engine {ep.name!r} is unavailable")
        pip = f"pip install {dist.name}" if dist is not None else f"pip install {ep.name}"
        specs[ep.name] = EngineSpec(ep.name, f"{PLUGIN_ADAPTERS}:{ep.name}", pip,
                                    distribution=dist.name if dist is not None else "")
    return _Plugins(specs, errors)


def entry_point_specs() -> dict[str, EngineSpec]:
    """The entry-point plug-ins' specs (a stand-in spec for a broken one), in name order."""
    return dict(_plugins().specs)


def plugin_error(name: str) -> str:
    """Why the entry-point plug-in ``name`` failed to load ("" when it loaded, or is none)."""
    return _plugins().errors.get(name, "")


def forget_plugins() -> None:
    """Read the entry points again on next use (tests that install or remove a plug-in)."""
    _plugins.cache_clear()


def _environment() -> dict[str, str]:
    out: dict[str, str] = {}
    for item in filter(None, (x.strip() for x in os.environ.get(ENGINES_ENV, "").split(","))):
        name, sep, target = item.partition("=")
        if not sep or ":" not in target:
            raise ValueError(f"{ENGINES_ENV} entry {item!r}: must be name=module:Class")
        out[name.strip()] = target.strip()
    return out


def _registry() -> dict[str, str]:
    """engine → the ``"module:Class"`` :func:`impactbench.engines.base.get_adapter` imports:
    the packaged engines, the entry-point plug-ins (through :data:`PLUGIN_ADAPTERS`), then
    ``IMPACTBENCH_ENGINES`` (which may replace any of them)."""
    out = {s.name: s.adapter for s in BUILTIN}
    out.update((name, f"{PLUGIN_ADAPTERS}:{name}") for name in _plugins().specs)
    out.update(_environment())
    return out


def engine_names() -> tuple[str, ...]:
    """Registered engine names: the packaged ones, the entry-point plug-ins (sorted), then
    new names from ``IMPACTBENCH_ENGINES``."""
    return tuple(_registry())


def spec(name: str) -> EngineSpec:
    """The spec of engine ``name``: the packaged one, an entry-point plug-in's, or for an
    ``IMPACTBENCH_ENGINES`` entry one with its adapter only. ValueError for an unknown name."""
    registry = _registry()
    if name not in registry:
        import difflib

        hint = difflib.get_close_matches(name, registry, n=1)
        more = f" (did you mean {hint[0]!r}?)" if hint else ""
        raise ValueError(f"engine = {name!r}: must be one of {', '.join(registry)}{more}")
    builtin = SPECS.get(name)
    if builtin is not None and builtin.adapter == registry[name]:
        return builtin
    plugin = _plugins().specs.get(name)
    if plugin is not None and registry[name] == f"{PLUGIN_ADAPTERS}:{name}":
        return plugin
    return EngineSpec(name, registry[name], f"pip install {name}")


def tuning_space(name: str, fit: str) -> object | None:
    """The knobs of engine ``name``'s fit ``fit`` (:data:`FITS`): its spec's ``spaces``
    entry, imported (None when the engine has none, or is not registered)."""
    import importlib

    if name not in _registry():
        return None
    target = dict(spec(name).spaces).get(fit)
    if target is None:
        return None
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def with_space(fit: str) -> tuple[str, ...]:
    """The registered engines whose spec has knobs for ``fit``, in the registry's order."""
    return tuple(name for name in _registry() if fit in dict(spec(name).spaces))


def is_builtin(name: str) -> bool:
    """True when ``name`` is a packaged engine not replaced by a plug-in."""
    return name in SPECS and _registry().get(name) == SPECS[name].adapter


class _Facts(Mapping[str, str]):
    """A read-only view, engine → one fact, over every registered engine (plug-ins
    included), read from the registry at each access."""

    def __init__(self, fact: Callable[[str, str], str], doc: str) -> None:
        self._fact = fact
        self.__doc__ = doc

    def __getitem__(self, name: str) -> str:
        registry = _registry()
        if name not in registry:
            raise KeyError(name)
        return self._fact(name, registry[name])

    def __iter__(self) -> Iterator[str]:
        return iter(_registry())

    def __len__(self) -> int:
        return len(_registry())

    def __repr__(self) -> str:
        return repr(dict(self))


ENGINES: Mapping[str, str] = _Facts(
    lambda _name, target: target,
    "engine → ``\"module:Class\"`` of its adapter, every registered engine (plug-ins too).")
PIP: Mapping[str, str] = _Facts(
    lambda name, _target: spec(name).pip,
    "engine → the pip command that installs it, every registered engine (plug-ins too).")


@contextlib.contextmanager
def fds_redirected(target: int, *fds: int) -> Iterator[None]:
    """Point the file descriptors ``fds`` (1, stdout; 2, stderr) at the open descriptor
    ``target`` for the duration. The descriptors themselves are swapped, so what C code
    prints (a ``printf``, which Python-level redirection cannot catch) follows them; Python's
    buffers of those streams are flushed first, C's stdio buffers before they are restored."""
    import ctypes

    for fd in fds:
        {1: sys.stdout, 2: sys.stderr}[fd].flush()
    saved = [os.dup(fd) for fd in fds]
    try:
        for fd in fds:
            os.dup2(target, fd)
        yield
    finally:
        with contextlib.suppress(Exception):
            ctypes.CDLL(None).fflush(None)
        for fd, kept in zip(fds, saved, strict=True):
            os.dup2(kept, fd)
            os.close(kept)


@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """Send C-level stdout to stderr for the duration (engines print banners on import —
    pybullet its build time — which would corrupt ``--json`` output)."""
    with fds_redirected(2, 1):
        yield
