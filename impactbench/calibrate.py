"""Calibrate a contact model to measured impacts: least squares with confidence intervals.

Data: a CSV with columns ``velocity_m_s`` and ``restitution`` (required) and, optionally,
``duration_s`` and ``peak_force_n`` (blank cells allowed). Each row is one ball-on-plate impact
of the scenario's ball (mass from ``--mass`` or ``--material``/``--radius``).

Fitted parameters θ:

- the damping: b (s/m) for ``hunt-crossley`` without a nominal restitution (restitution
  k(b·V) falls with V), else the model's nominal restitution e (restitution is then the same
  at every V);
- the stiffness c (N/m^n; k in N/m for the linear models), fitted as ln c, when a duration or
  a peak force column is given;
- the exponent n (``fit_exponent``, hysteresis models only), when durations or forces are given.

Residuals are relative, r = (model − data)/data, for every given value; the model is the exact
closed form (:func:`impactbench.reference.zoo.sweep`). ``scipy.optimize.least_squares``
(trust-region reflective, bounds) minimises ½Σr². Confidence intervals come from its Jacobian J
at the optimum: cov(θ) = s²·(JᵀJ)⁻¹ with s² = Σr²/(N − p), half-width t_{N−p}(0.975)·√cov_ii
(Student t, 95 % by default); ln c's interval is mapped through exp (asymmetric in c). With
N = p the fit interpolates and the intervals are undefined (NaN).

The fit says which law it fitted (:attr:`Calibration.law`) and warns
(:attr:`Calibration.warnings`) where it should not be read as a fit: residuals that trend
with impact velocity (the law does not follow the data), an interval reaching a physically
impossible value (negative damping, a restitution above 1: the data do not determine that
parameter), and an rms relative residual above the stated bound ``max_rms``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import optimize, stats

from impactbench.reference import validation as check
from impactbench.reference.scenarios import BallOnPlate
from impactbench.reference.zoo import effective_restitution
from impactbench.scenarios import for_study

MAX_RMS_REL = 0.03
"""Default bound of a fit's rms relative residual (a stated choice; ``--max-rms``): six times
the 0.5 % noise of the packaged example, whose velocity-dependent Hunt–Crossley fit leaves
0.4 % and a constant-restitution law 5.4 % (measured)."""
TREND_P = 0.01
TREND_R2 = 0.5
"""A metric's residuals trend with velocity when their straight-line fit against v explains
at least half their variance (R² ≥ 0.5) with a slope significant at p < 0.01 (4 points or
more): random scatter of a law that fits rarely does (p < 0.01 by chance for 1 % of metrics)."""
PHYSICAL: dict[str, tuple[float, float, str]] = {
    "damping_s_per_m": (0.0, math.inf, "b ≥ 0: a negative b feeds energy in"),
    "nominal_restitution": (0.0, 1.0, "0 < e ≤ 1"),
    "exponent": (0.0, math.inf, "n > 0"),
}
"""Physically possible values of the fitted parameters (lower, upper, rule); the stiffness is
fitted as ln c, so its interval stays > 0."""

REQUIRED = ("velocity_m_s", "restitution")
OPTIONAL = ("duration_s", "peak_force_n")
COLUMNS = (*REQUIRED, *OPTIONAL)


@dataclass(frozen=True)
class Measurements:
    """Measured impacts (SI); optional columns are None when absent, NaN where blank."""

    velocity_m_s: np.ndarray
    restitution: np.ndarray
    duration_s: np.ndarray | None = None
    peak_force_n: np.ndarray | None = None
    source: str = ""

    @property
    def columns(self) -> tuple[str, ...]:
        """The metric columns present (restitution first)."""
        return ("restitution", *(c for c in OPTIONAL if getattr(self, c) is not None))

    @property
    def points(self) -> int:
        """Number of measured values (residuals)."""
        return sum(int(np.sum(np.isfinite(getattr(self, c)))) for c in self.columns)


def _row_error(column: str, row: int, value: float, rule: str) -> ValueError:
    return ValueError(f"{column}[row {row + 1}] = {value!r}: {rule}")


def measurements(frame: pd.DataFrame, source: str = "") -> Measurements:
    """Validate a table of measurements (one-line errors naming column, row and rule)."""
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise ValueError(f"columns = {list(frame.columns)!r}: missing {missing[0]!r} "
                         f"(need {', '.join(REQUIRED)}; optional {', '.join(OPTIONAL)})")
    unknown = [c for c in frame.columns if c not in COLUMNS]
    if unknown:
        raise ValueError(f"column {unknown[0]!r}: unknown; allowed: {', '.join(COLUMNS)}")
    if len(frame) == 0:
        raise ValueError(f"data {source!r}: no rows")
    values: dict[str, np.ndarray] = {}
    for c in frame.columns:
        col = pd.to_numeric(frame[c], errors="coerce").to_numpy(dtype=float)
        for i, (raw, v) in enumerate(zip(frame[c], col, strict=True)):
            blank = raw is None or (isinstance(raw, float) and math.isnan(raw)) or raw == ""
            if c in REQUIRED and not math.isfinite(v):
                raise _row_error(c, i, raw, "must be a finite number")
            if not blank and not math.isfinite(v):
                raise _row_error(c, i, raw, "must be a finite number or blank")
            if c == "restitution" and not 0.0 < v <= 1.0:
                raise _row_error(c, i, float(v), "must be in (0, 1]")
            if c != "restitution" and math.isfinite(v) and not v > 0.0:
                raise _row_error(c, i, float(v), "must be > 0")
        values[c] = col
    return Measurements(values["velocity_m_s"], values["restitution"],
                        values.get("duration_s"), values.get("peak_force_n"), source)


def read_measurements(path: str | Path) -> Measurements:
    """Read and validate a measurements CSV (``#`` starts a comment line)."""
    try:
        frame = pd.read_csv(path, comment="#", skipinitialspace=True)
    except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise ValueError(f"data {str(path)!r}: cannot read as CSV ({exc})") from None
    return measurements(frame, source=str(path))


@dataclass(frozen=True)
class Parameter:
    """A fitted parameter: its name in the scenario, unit, and whether it is fitted as ln."""

    name: str
    unit: str
    log: bool
    lower: float
    upper: float


@dataclass
class Calibration:
    """The fit: the calibrated scenario, estimates, 95 % intervals, residuals and provenance."""

    scenario: BallOnPlate
    parameters: tuple[Parameter, ...]
    estimates: dict[str, float]
    intervals: dict[str, tuple[float, float]]
    standard_errors: dict[str, float]
    residuals: pd.DataFrame
    points: int
    dof: int
    rms_rel_error: float
    confidence: float
    message: str
    data: Measurements
    extra: dict[str, Any] = field(default_factory=dict)
    law: str = ""
    """The law fitted, in words (which parameters, and how its restitution varies)."""
    warnings: list[str] = field(default_factory=list)
    """Why the fit should not be read as one (module doc); empty when none applies."""
    max_rms: float = MAX_RMS_REL
    """The bound the rms relative residual was held to."""


def free_parameters(base: BallOnPlate, data: Measurements, fit_exponent: bool = False
                    ) -> tuple[Parameter, ...]:
    """The parameters the data can determine for ``base``'s model (module doc)."""
    if base.model == "hunt-crossley" and base.nominal_restitution is None:
        params = [Parameter("damping_s_per_m", "s/m", False, 0.0, np.inf)]
    else:
        params = [Parameter("nominal_restitution", "1", False, 1e-9, 1.0)]
    if len(data.columns) > 1:
        params.append(Parameter("stiffness", "N/m^n", True, -np.inf, np.inf))
        if fit_exponent:
            if base.is_linear:
                raise ValueError(f"fit_exponent = True: model {base.model!r} is linear "
                                 "(n = 1); fit the exponent with a hysteresis model")
            params.append(Parameter("exponent", "1", False, 0.5, 4.0))
    elif fit_exponent:
        raise ValueError("fit_exponent = True: needs a duration_s or peak_force_n column")
    return tuple(params)


def law_description(base: BallOnPlate, params: tuple[Parameter, ...]) -> str:
    """The fitted law in words: which parameters, and how its restitution varies with v."""
    names = {p.name for p in params}
    if "damping_s_per_m" in names:
        law = ("Hunt–Crossley F = c·xⁿ·(1 + b·ẋ), b fitted: its restitution falls with "
               "impact velocity")
    else:
        law = (f"{base.model} with its nominal restitution e fitted: the same restitution at "
               "every impact velocity")
    if "stiffness" in names:
        law += "; c fitted" + (" and n" if "exponent" in names else "")
    return law


def fit_warnings(residuals: pd.DataFrame, estimates: dict[str, float],
                 intervals: dict[str, tuple[float, float]], rms: float, max_rms: float,
                 confidence: float) -> list[str]:
    """One line per reason not to read the fit as one (module doc): a metric's residual trend
    with velocity (:data:`TREND_R2`, :data:`TREND_P`), an interval beyond :data:`PHYSICAL`,
    an rms relative residual above ``max_rms``."""
    out = []
    for metric, part in residuals.groupby("metric", sort=False):
        v = part["velocity_m_s"].to_numpy(dtype=float)
        r = part["rel_residual"].to_numpy(dtype=float)
        if len(part) < 4 or np.ptp(v) == 0.0 or np.ptp(r) == 0.0:
            continue
        fit = stats.linregress(v, r)
        if fit.pvalue < TREND_P and fit.rvalue ** 2 >= TREND_R2:
            lo, hi = int(np.argmin(v)), int(np.argmax(v))
            out.append(f"{metric} residuals trend with impact velocity ({100 * r[lo]:+.1f} % "
                       f"at {v[lo]:g} m/s to {100 * r[hi]:+.1f} % at {v[hi]:g} m/s; "
                       f"R² {fit.rvalue ** 2:.2f}, p {fit.pvalue:.1g}): the fitted law does not "
                       "follow how the data change with velocity")
    pct = f"{100 * confidence:g} %"
    for name, (lower, upper, rule) in PHYSICAL.items():
        if name not in intervals or not all(map(math.isfinite, intervals[name])):
            continue
        lo, hi = intervals[name]
        if lo < lower or (hi > upper and name == "nominal_restitution"):
            side = (f"reaches {lo:.3g}, below {lower:g}" if lo < lower
                    else f"reaches {hi:.3g}, above {upper:g}")
            out.append(f"{name} = {estimates[name]:.6g}: its {pct} interval [{lo:.3g}, "
                       f"{hi:.3g}] {side} ({rule}): the data do not determine it")
    if rms > max_rms:
        out.append(f"rms relative residual {100 * rms:.3g} % > {100 * max_rms:g} % (max_rms "
                   f"{max_rms:g}): the fitted law misses the data by more than the stated bound")
    return out


def _scenario(base: BallOnPlate, params: tuple[Parameter, ...], theta: np.ndarray
              ) -> BallOnPlate:
    values = {p.name: (math.exp(t) if p.log else float(t))
              for p, t in zip(params, theta, strict=True)}
    return base.replace(**values)


def _predict(scenario: BallOnPlate, data: Measurements) -> pd.DataFrame:
    from impactbench.reference.zoo import sweep

    return sweep(scenario, data.velocity_m_s)


def _residuals(base: BallOnPlate, params: tuple[Parameter, ...], data: Measurements,
               theta: np.ndarray) -> np.ndarray:
    pred = _predict(_scenario(base, params, theta), data)
    out = []
    for c in data.columns:
        measured = getattr(data, c)
        ok = np.isfinite(measured)
        out.append((pred[c].to_numpy()[ok] - measured[ok]) / measured[ok])
    return np.concatenate(out)


def _start(base: BallOnPlate, params: tuple[Parameter, ...], data: Measurements
           ) -> np.ndarray:
    """A start inside the basin: the damping from the median restitution, c from the
    median ratio of measured to predicted duration (T ∝ c^(−1/(n+1))) or force
    (F ∝ c^(1/(n+1)))."""
    from impactbench.reference.hunt_crossley import restitution

    k_med = float(np.median(data.restitution))
    theta = []
    for p in params:
        if p.name == "damping_s_per_m":
            if k_med >= 1.0:
                alpha = 0.0
            elif restitution(1e6) > k_med:
                # a nearly dead ball (k < 1e-6): k(α) → 1/α for α ≫ 1 (k(1e6) = 1e-6,
                # k(1e9) = 1e-9: hunt_crossley.restitution), past brentq's bracket
                alpha = min(1.0 / k_med, 1e300)
            else:
                alpha = optimize.brentq(lambda a: restitution(a) - k_med, 0.0, 1e6,
                                        xtol=1e-14)
            theta.append(alpha / float(np.median(data.velocity_m_s)))
        elif p.name == "nominal_restitution":
            # the effective restitution rises monotonically with e: invert it (or clip)
            if effective_restitution(base.model, 1.0) <= k_med:
                theta.append(1.0)
            elif effective_restitution(base.model, 1e-9) >= k_med:
                theta.append(1e-9)
            else:
                theta.append(optimize.brentq(
                    lambda e: effective_restitution(base.model, e) - k_med, 1e-9, 1.0,
                    xtol=1e-14))
        elif p.name == "stiffness":
            theta.append(math.log(base.stiffness))
        else:
            theta.append(base.exponent)
    theta_arr = np.asarray(theta, dtype=float)
    names = [p.name for p in params]
    if "stiffness" in names:
        i_c = names.index("stiffness")
        pred = _predict(_scenario(base, params, theta_arr), data)
        n = base.exponent
        for c, power in (("duration_s", -(n + 1.0)), ("peak_force_n", n + 1.0)):
            measured = getattr(data, c)
            if measured is not None and np.any(np.isfinite(measured)):
                ok = np.isfinite(measured)
                ratio = float(np.median(measured[ok] / pred[c].to_numpy()[ok]))
                theta_arr[i_c] += power * math.log(ratio)
                break
    return theta_arr


def calibrate(data: Measurements, base: BallOnPlate, *, fit_exponent: bool = False,
              confidence: float = 0.95, max_rms: float = MAX_RMS_REL) -> Calibration:
    """Fit ``base``'s model to ``data`` (module doc); ``base`` supplies every fixed field.
    ``max_rms``: the bound on the rms relative residual beyond which the fit warns."""
    if not isinstance(base, BallOnPlate):
        raise ValueError(f"scenario = {base!r}: must be a BallOnPlate")
    conf = check.positive("confidence", confidence)
    if conf >= 1.0:
        raise ValueError(f"confidence = {confidence!r}: must be in (0, 1)")
    bound = check.positive("max_rms", max_rms)
    params = free_parameters(base, data, fit_exponent)
    n_pts, n_par = data.points, len(params)
    if n_pts < n_par:
        names = ", ".join(p.name for p in params)
        raise ValueError(f"data = {n_pts} values: fewer than the {n_par} parameters to fit "
                         f"({names}); give more impacts")
    theta0 = _start(base, params, data)
    lower = np.array([p.lower for p in params])
    upper = np.array([p.upper for p in params])
    theta0 = np.clip(theta0, lower, upper)
    res = optimize.least_squares(
        lambda th: _residuals(base, params, data, th), theta0, bounds=(lower, upper),
        method="trf", jac="3-point", x_scale="jac", xtol=1e-15, ftol=1e-15, gtol=1e-15,
        max_nfev=2000)
    theta = res.x
    dof = n_pts - n_par
    r = res.fun
    estimates, intervals, errors = {}, {}, {}
    if dof > 0:
        s2 = float(r @ r) / dof
        jtj = res.jac.T @ res.jac
        cov = s2 * np.linalg.pinv(jtj)
        se = np.sqrt(np.maximum(np.diag(cov), 0.0))
        half = float(stats.t.ppf(0.5 + conf / 2.0, dof)) * se
    else:
        se = half = np.full(n_par, np.nan)
    for p, t, s, h in zip(params, theta, se, half, strict=True):
        if p.log:
            value = math.exp(t)
            estimates[p.name], errors[p.name] = value, value * s
            intervals[p.name] = (math.exp(t - h), math.exp(t + h))
        else:
            estimates[p.name], errors[p.name] = float(t), float(s)
            intervals[p.name] = (float(t - h), float(t + h))
    scenario = _scenario(base, params, theta)
    pred = _predict(scenario, data)
    rows = []
    for c in data.columns:
        measured = getattr(data, c)
        for v, y, yhat in zip(data.velocity_m_s, measured, pred[c], strict=True):
            if math.isfinite(y):
                rows.append({"velocity_m_s": v, "metric": c, "measured": y, "model": yhat,
                             "rel_residual": (yhat - y) / y})
    residuals = pd.DataFrame(rows)
    rms = float(math.sqrt(float(r @ r) / n_pts))
    return Calibration(scenario, params, estimates, intervals, errors, residuals,
                       n_pts, dof, rms, conf, str(res.message), data,
                       law=law_description(base, params),
                       warnings=fit_warnings(residuals, estimates, intervals, rms, bound, conf),
                       max_rms=bound)


def scenario_table(cal: Calibration) -> dict[str, Any]:
    """The calibrated scenario's fields for a scenario file (no velocity; no unset fields)."""
    return {k: v for k, v in cal.scenario.to_dict().items()
            if k != "velocity_m_s" and v is not None}


def write_scenario_file(cal: Calibration, path: str | Path, command: str = "") -> Path:
    """Write a scenario file: ``[ball_on_plate]`` (BallOnPlate fields, read by ``run``,
    ``tune`` and ``report`` with ``--scenario-file``) and ``[calibration]`` (provenance:
    data, estimates, intervals, residual summary)."""
    import tomli_w

    path = Path(path)
    prov: dict[str, Any] = {
        "data": cal.data.source, "points": cal.points, "dof": cal.dof,
        "confidence": cal.confidence, "rms_rel_error": cal.rms_rel_error,
        "optimizer": "scipy least_squares (trf, 3-point Jacobian)", "message": cal.message,
        "law": cal.law, "max_rms": cal.max_rms, "warnings": list(cal.warnings),
    }
    if command:
        prov["command"] = command
    for p in cal.parameters:
        prov[f"{p.name}"] = cal.estimates[p.name]
        lo, hi = cal.intervals[p.name]
        prov[f"{p.name}_interval"] = [lo, hi] if math.isfinite(lo) else []
    header = ("# impactbench scenario file written by `impactbench calibrate`.\n"
              "# [ball_on_plate] holds BallOnPlate fields (SI): pass the file to run, tune and\n"
              "# report with --scenario-file. [calibration] is provenance only.\n")
    table = for_study("calibrate").table
    body = tomli_w.dumps({table: scenario_table(cal), "calibration": prov})
    from impactbench.publish import atomic_write

    return atomic_write(path, header + body, "out")  # all or nothing; one-line I/O errors
