"""Engine adapters, imported lazily by name through :mod:`impactbench.engines.base`'s registry.

The names below are loaded on first use (PEP 562), so importing a light submodule such as
:mod:`impactbench.engines.registry` does not import numpy through :mod:`~.base`.
"""

from typing import Any

__all__ = [
    "ENGINES",
    "MODES",
    "Adapter",
    "EngineUnavailable",
    "RunSettings",
    "available_engines",
    "get_adapter",
    "run_safely",
]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from impactbench.engines import base

        return getattr(base, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
