"""Tuning engine contact parameters to match the Hunt–Crossley reference (``impactbench tune``).

- :mod:`~impactbench.tuning.search`: the one tuner every fit uses — a space of knobs, an
  objective evaluated on a batch (a population at once) and a method (scipy least squares,
  scipy Nelder–Mead, nevergrad CMA-ES);
- :mod:`~impactbench.tuning.spaces`: per-engine parameterisations (bounds, closed-form start,
  the engine's own form, what it cannot express);
- :mod:`~impactbench.tuning.objective`: weighted squared relative errors over a velocity set;
- :mod:`~impactbench.tuning.optimize`: the ball's fit (:func:`tune`): the one tuner's least
  squares with budgets;
- :mod:`~impactbench.tuning.output`: residual table, plot, tuned file and honesty notes;
- :mod:`~impactbench.tuning.names`: target names, parameter sets and defaults (no imports);
- :mod:`~impactbench.tuning.oblique`: the oblique impact's friction fit over an angle sweep
  (``impactbench tune --scenario oblique``; the one tuner's Nelder–Mead).

The cube tosses are fitted to measurements instead (the one tuner's CMA-ES):
:mod:`impactbench.cube_tosses.tune`. Every engine's spaces are named by its
:class:`~impactbench.engines.registry.EngineSpec` (``tuning``: the ball's parameterisations;
``spaces``: the oblique friction knobs, ``engines/oblique_tuned.py``, and the cube tosses',
``impactbench/cube_tosses/spaces.py``).
"""

from importlib import import_module
from typing import Any

_EXPORTS = {
    "DEFAULT_TARGETS": "names", "TARGETS": "names", "VARIANTS": "names",
    "Objective": "objective", "parse_weights": "objective",
    "TuneResult": "optimize", "tune": "optimize",
    "Space": "spaces", "make_space": "spaces",
    "Knob": "search", "KnobSpace": "search",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    """Load the exports on first use (PEP 562): ``impactbench tune --help`` needs only
    :mod:`~impactbench.tuning.names`, not numpy or scipy."""
    if name in _EXPORTS:
        return getattr(import_module(f"impactbench.tuning.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
