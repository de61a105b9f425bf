"""impactbench: cross-validation of multibody physics engines on impact.

The suite around the ground truth in :mod:`impactbench.reference` and the adapters in
:mod:`impactbench.engines`: comparison reports, contact-parameter tuning and CI accuracy gates,
all behind the ``impactbench`` command (:mod:`impactbench.cli`) and the Python API
(:mod:`impactbench.api`):

- ``impactbench.run(engine=..., scenario=..., mode=..., velocity_m_s=..., timestep_s=...)``
  → a :class:`~impactbench.api.RunResult` (``status``, ``metrics``, ``reference``,
  ``rel_error``, ``to_dict()`` = ``impactbench run --json``);
- ``impactbench.reference_solution(scenario=..., velocity_m_s=...)`` → the reference object
  (``impactbench reference NAME --json``);
- ``impactbench.tune(engine=..., ...)`` → a :class:`~impactbench.api.TuneFit`;
- ``impactbench.build_report(config=..., out=...)`` → the report (results DataFrame, files).

The API loads on first use (PEP 562), so ``import impactbench`` imports no numpy.
"""

from importlib import import_module
from typing import Any

__version__ = "0.1.0"

_API = ("RunResult", "TuneFit", "build_report", "reference_solution", "run", "tune")
__all__ = ["__version__", *_API]


def __getattr__(name: str) -> Any:
    if name in _API:
        return getattr(import_module(f"{__name__}.api"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
