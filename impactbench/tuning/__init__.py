"""Tuning engine contact parameters to match the Hunt–Crossley reference (``impactbench tune``).

- :mod:`~impactbench.tuning.spaces`: per-engine parameterisations (bounds, closed-form start,
  the engine's own form, what it cannot express);
- :mod:`~impactbench.tuning.objective`: weighted squared relative errors over a velocity set;
- :mod:`~impactbench.tuning.optimize`: deterministic bounded search with budgets (:func:`tune`);
- :mod:`~impactbench.tuning.output`: residual table, plot, tuned file and honesty notes.
"""

from impactbench.tuning.objective import DEFAULT_TARGETS, TARGETS, Objective, parse_weights
from impactbench.tuning.optimize import TuneResult, tune
from impactbench.tuning.spaces import VARIANTS, Space, make_space

__all__ = ["DEFAULT_TARGETS", "TARGETS", "VARIANTS", "Objective", "Space", "TuneResult",
           "make_space", "parse_weights", "tune"]
