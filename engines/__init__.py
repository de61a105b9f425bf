"""Engine adapters, imported lazily by name through :mod:`engines.base`'s registry."""

from engines.base import (
    ENGINES,
    MODES,
    Adapter,
    EngineUnavailable,
    RunSettings,
    available_engines,
    get_adapter,
    run_safely,
)

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
