"""The tuning command's names and defaults: standard library only, so ``impactbench tune
--help`` builds without numpy, scipy or an engine. Re-exported by the modules that use them."""

from __future__ import annotations

from impactbench.engines.registry import BUILTIN

TARGETS: dict[str, str] = {
    "restitution": "restitution",
    "duration": "duration_s",
    "peak_force": "peak_force_n",
    "max_penetration": "max_penetration_m",
    "energy_loss": "energy_loss_fraction",
}
"""CLI target names → metric keys (``impactbench.reference.metrics.BALL_METRICS``)."""
DEFAULT_TARGETS: tuple[str, ...] = ("restitution", "duration", "peak_force")

DEFAULT_BUDGET_S = 120.0
"""Wall-time budget of one tuning run (s)."""

SOLREF_FORMS = ("direct", "timeconst")
"""MuJoCo's solref forms, for ``--solref-form`` (the same as
:data:`impactbench.engines.tuning_spaces.SOLREF_FORMS`, which validates them: that module
imports numpy, this one must not)."""

VARIANTS: dict[str, tuple[str, ...]] = {s.name: s.variants for s in BUILTIN if s.variants}
"""Each tunable engine's parameter sets (the first is the default), from its
:class:`~impactbench.engines.registry.EngineSpec` (as
:data:`impactbench.engines.tuning_spaces.VARIANTS`, without numpy)."""
