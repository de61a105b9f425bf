"""Tuning engine contact parameters to match the Hunt–Crossley reference (``impactbench tune``).

- :mod:`~impactbench.tuning.search`: the one tuner every fit uses — a space of knobs, an
  objective evaluated on a batch (a population at once) and a method (scipy least squares,
  scipy Nelder–Mead, nevergrad CMA-ES);
- :mod:`~impactbench.tuning.objective`: weighted squared relative errors over a velocity set;
- :mod:`~impactbench.tuning.optimize`: the ball's fit (:func:`tune`): the one tuner's least
  squares with budgets;
- :mod:`~impactbench.tuning.output`: residual table, plot, tuned file and honesty notes;
- :mod:`~impactbench.tuning.names`: target names, parameter sets and defaults (no imports);
- :mod:`~impactbench.tuning.oblique`: the oblique impact's friction fit over an angle sweep
  (``impactbench tune --scenario oblique``; the one tuner's Nelder–Mead).

The cube tosses are fitted to measurements instead (the one tuner's CMA-ES):
:mod:`impactbench.cube_tosses.tune`.

The spaces live with the engines, in the engine layer, each named by its engine's
:class:`~impactbench.engines.registry.EngineSpec` (``tuning``: the ball's parameterisations,
:mod:`impactbench.engines.tuning_spaces` and :mod:`~impactbench.engines.tuning_spaces_extras`:
bounds, closed-form start, the engine's own form, what it cannot express; ``spaces``: the
oblique friction knobs, :mod:`impactbench.engines.oblique_tuned`, and the cube tosses',
:mod:`impactbench.engines.cube_toss_spaces`); their knob type is
:mod:`impactbench.engines.knobs`'.
"""

from importlib import import_module
from typing import Any

_EXPORTS = {
    "DEFAULT_TARGETS": "impactbench.tuning.names", "TARGETS": "impactbench.tuning.names",
    "VARIANTS": "impactbench.tuning.names",
    "Objective": "impactbench.tuning.objective", "parse_weights": "impactbench.tuning.objective",
    "TuneResult": "impactbench.tuning.optimize", "tune": "impactbench.tuning.optimize",
    "Space": "impactbench.engines.tuning_spaces",
    "make_space": "impactbench.engines.tuning_spaces",
    "Knob": "impactbench.engines.knobs", "KnobSpace": "impactbench.engines.knobs",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    """Load the exports on first use (PEP 562): ``impactbench tune --help`` needs only
    :mod:`~impactbench.tuning.names`, not numpy or scipy."""
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
