"""Exact metrics of every contact model of the zoo, over velocities and nominal restitutions.

- :func:`sweep`: the five ball-on-plate metrics of one scenario (any ``model``) over many
  impact velocities. A hysteresis-damping model set from a nominal e has the same α = α(e) at
  every V0, so one dimensionless solve (:func:`impactbench.reference.hunt_crossley.dimensionless`)
  serves the whole sweep, scaled by x*, t*, F* per velocity; the paper's fixed-b Hunt–Crossley
  is :func:`impactbench.reference.hunt_crossley.sweep`; the linear models are closed forms.
  :func:`sweep_columns` gives the same columns as numpy arrays, without pandas (the CLI
  writes them straight to pyarrow).
- :func:`restitution_table`: nominal against effective restitution for every model (a tidy
  table: model, nominal_restitution, effective_restitution, alpha).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from impactbench.reference import hunt_crossley, kelvin_voigt
from impactbench.reference import validation as check
from impactbench.reference.metrics import BALL_METRICS
from impactbench.reference.models import (
    HYSTERESIS_MODELS,
    LINEAR_MODELS,
    MODELS,
    check_restitution,
)
from impactbench.reference.scenarios import BallOnPlate

if TYPE_CHECKING:
    import pandas as pd


def effective_restitution(model: str, nominal_restitution: float) -> float:
    """The exact restitution of ``model`` set up for nominal restitution e (any V0, m, c, n):
    Hunt–Crossley's k(α(e)) for the hysteresis-damping models (it depends on α alone), the
    clipped or unclipped Kelvin–Voigt closed form for the linear ones."""
    check.one_of("model", model, MODELS)
    e = check_restitution("nominal_restitution", nominal_restitution)
    if model in HYSTERESIS_MODELS:
        return float(hunt_crossley.restitution(HYSTERESIS_MODELS[model].alpha(e)))
    zeta = kelvin_voigt.zeta_from_restitution(e)
    if LINEAR_MODELS[model]:
        return kelvin_voigt.clipped_restitution(zeta)
    return kelvin_voigt.unclipped_restitution(zeta)


def sweep(scenario: BallOnPlate, velocities: Iterable[float] | np.ndarray) -> pd.DataFrame:
    """``velocity_m_s`` and the five :data:`BALL_METRICS` columns, in input order (SI)."""
    import pandas as pd

    return pd.DataFrame(sweep_columns(scenario, velocities))


def sweep_columns(scenario: BallOnPlate, velocities: Iterable[float] | np.ndarray
                  ) -> dict[str, np.ndarray]:
    """:func:`sweep`'s columns as numpy arrays (name → array), without pandas (the CLI
    writes them as they are)."""
    if not isinstance(scenario, BallOnPlate):
        raise ValueError(f"scenario = {scenario!r}: must be a BallOnPlate")
    v = hunt_crossley._validated_velocities(velocities)
    s = scenario
    if s.nominal_restitution is None:
        return hunt_crossley.sweep_columns(v, mass_kg=s.mass_kg, stiffness=s.stiffness,
                                           exponent=s.exponent,
                                           damping_s_per_m=s.damping_s_per_m)
    if s.is_linear:
        law = s.law()
        rows = [kelvin_voigt.solve(s.mass_kg, law.stiffness, law.damping_ns_per_m, float(vi),
                                   law.clipped) for vi in v]
        return {"velocity_m_s": v,
                **{k: np.array([r[k] for r in rows], dtype=float) for k in BALL_METRICS}}
    alpha = HYSTERESIS_MODELS[s.model].alpha(float(s.nominal_restitution))
    d = hunt_crossley.dimensionless(alpha, s.exponent)
    xs, ts, fs = hunt_crossley.scales(s.mass_kg, v, s.stiffness, s.exponent)
    ones = np.ones_like(v)
    return {
        "velocity_m_s": v,
        "restitution": d["restitution"][0] * ones,
        "duration_s": d["duration"][0] * ts,
        "peak_force_n": d["peak_force"][0] * fs,
        "max_penetration_m": d["max_penetration"][0] * xs,
        "energy_loss_fraction": d["energy_loss_fraction"][0] * ones,
    }


def restitution_table(nominal: Iterable[float] | np.ndarray,
                      models: Iterable[str] = MODELS) -> pd.DataFrame:
    """Effective against nominal restitution for each model (exact; any V0, m, c, n).

    Columns: model, nominal_restitution, effective_restitution, alpha (b·V0 of the
    hysteresis models, NaN for the linear ones).
    """
    import pandas as pd

    es = [check_restitution("nominal_restitution", float(e)) for e in nominal]
    rows = []
    for model in models:
        for e in es:
            k = effective_restitution(model, e)  # validates the model name
            alpha = (HYSTERESIS_MODELS[model].alpha(e) if model not in LINEAR_MODELS
                     else float("nan"))
            rows.append({"model": model, "nominal_restitution": e,
                         "effective_restitution": k, "alpha": alpha})
    return pd.DataFrame(rows)
