"""Engine adapters, imported lazily by name through :mod:`impactbench.engines.base`'s registry."""

from impactbench.engines.base import (
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
