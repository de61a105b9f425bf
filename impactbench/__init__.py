"""impactbench: cross-validation of multibody physics engines on impact.

The suite around the ground truth in :mod:`reference` and the adapters in :mod:`engines`:
comparison reports, contact-parameter tuning and CI accuracy gates, all behind the
``impactbench`` command (:mod:`impactbench.cli`).
"""

__version__ = "0.1.0"
