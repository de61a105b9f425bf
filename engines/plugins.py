"""The adapters of entry-point engine plug-ins, reached as ``impactbench.engines.plugins:NAME``.

:data:`impactbench.engines.registry.ENGINES` maps every entry-point plug-in to an attribute of
this module rather than to the plug-in's own ``"module:Class"`` (its spec's ``adapter``), so
that :func:`impactbench.engines.base.get_adapter`, :func:`~impactbench.engines.base.
parameter_keys` and everything else that imports an adapter by name get a class in every
case: the plug-in's adapter when it imports, else a stand-in whose construction raises
:class:`~impactbench.engines.base.EngineUnavailable` with the reason (the plug-in's module is
missing or raises on import, its ``adapter`` is not an :class:`~impactbench.engines.base.
Adapter` subclass). A broken plug-in is then ``unavailable``, like an engine that is not
installed, and every other engine and command still works.
"""

from __future__ import annotations

import importlib

from impactbench.engines import registry
from impactbench.engines.base import Adapter, EngineUnavailable


def _stand_in(engine: str, error: str) -> type[Adapter]:
    """An adapter class for ``engine`` that cannot be built: ``unavailable`` with ``error``."""

    class Unavailable(Adapter):
        name = engine
        modes = ()

        def __init__(self) -> None:
            raise EngineUnavailable(engine, error)

        def version(self) -> str:
            raise EngineUnavailable(engine, error)

    Unavailable.__qualname__ = Unavailable.__name__ = f"Unavailable[{engine}]"
    return Unavailable


def adapter_class(engine: str) -> type[Adapter]:
    """The adapter class of the entry-point plug-in ``engine`` (a stand-in when it cannot be
    imported; module doc). AttributeError when ``engine`` is not such a plug-in."""
    found = registry.entry_point_specs().get(engine)
    if found is None:
        raise AttributeError(f"module {__name__!r} has no attribute {engine!r} (no "
                             f"{registry.ENTRY_POINT_GROUP} plug-in of that name)")
    error = registry.plugin_error(engine)
    if error:
        return _stand_in(engine, error)
    target = found.adapter
    module, _, attr = target.partition(":")
    try:
        cls = getattr(importlib.import_module(module), attr)
    except Exception as exc:  # the plug-in's adapter is broken: unavailable, with the reason
        why = f"{type(exc).__name__}: {exc}".splitlines()[0]
        return _stand_in(engine, f"plug-in adapter {target} failed to load: {why}")
    if not (isinstance(cls, type) and issubclass(cls, Adapter)):
        return _stand_in(engine, f"plug-in adapter {target}: must be a subclass of "
                                 "impactbench.engines.base.Adapter")
    return cls


def __getattr__(name: str) -> type[Adapter]:
    if name.startswith("__"):
        raise AttributeError(name)
    return adapter_class(name)
