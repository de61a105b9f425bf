"""What a tuning run hands back: residual tables, honesty notes, the plot and the tuned file.

Honesty: beside the start's and the tuned maximum relative errors, a *floor* is given for a
scale-invariant (linear) contact without gravity: its restitution, duration and loss fraction
do not depend on V0 and its peak force and penetration are ∝ V0, so for a quantity q that is
a constant c (or c·V0) the best possible maximum relative error over the references r_i is

    min_c max_i |c/r_i − 1| = (r_max − r_min)/(r_max + r_min)   (r_i divided by V0 where ∝ V0),

reached at c = 2·r_max·r_min/(r_max + r_min). No parameter choice can beat it; a weighted
least-squares fit sits above it.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from impactbench.reference.metrics import BALL_METRICS
from impactbench.tuning.optimize import SEED, TuneResult

SCALES_WITH_V = frozenset({"peak_force_n", "max_penetration_m"})
"""Metrics a linear contact makes proportional to V0 (the others are V0-independent)."""
REPORTED = ("restitution", "duration_s", "peak_force_n")
"""The metrics whose best maximum error the summary always states."""


def floor_error(result: TuneResult, key: str) -> float:
    """Best possible max |relative error| of a scale-invariant contact (NaN if not one)."""
    if not result.space.linear or result.objective.scenario.gravity_m_s2 != 0.0:
        return math.nan
    refs = [float(r[key]) / (v if key in SCALES_WITH_V else 1.0)
            for v, r in zip(result.velocities_m_s, result.objective.references, strict=True)]
    if not all(math.isfinite(r) and r > 0 for r in refs):
        return math.nan
    return (max(refs) - min(refs)) / (max(refs) + min(refs))


def shown_metrics(result: TuneResult) -> list[str]:
    """Targets first, then the three headline metrics, then the rest, where comparable."""
    keys = list(result.requested_weights)
    keys += [k for k in (*REPORTED, *BALL_METRICS) if k not in keys]
    return [k for k in keys
            if any(math.isfinite(e[k]) for e in (*result.tuned.rel_errors,
                                                 *result.start.rel_errors))]


def plotted_metrics(result: TuneResult) -> list[str]:
    """The targets and the headline metrics (restitution, duration, peak force)."""
    return [k for k in shown_metrics(result) if k in (*result.requested_weights, *REPORTED)]


def residual_rows(result: TuneResult) -> list[dict[str, Any]]:
    """Per velocity and plotted metric: reference, start and tuned values and errors."""
    rows = []
    weights = result.objective.weights
    for i, v in enumerate(result.velocities_m_s):
        ref = result.objective.references[i]
        for key in plotted_metrics(result):
            rows.append({
                "velocity_m_s": v, "metric": key, "weight": weights.get(key, 0.0),
                "reference": float(ref[key]),
                "start": result.start.metrics[i][key],
                "start_rel_error": result.start.rel_errors[i][key],
                "tuned": result.tuned.metrics[i][key],
                "tuned_rel_error": result.tuned.rel_errors[i][key],
            })
    return rows


def summary_rows(result: TuneResult) -> list[dict[str, Any]]:
    """Per metric: weight, start and tuned max |relative error|, and the linear floor."""
    start, tuned = result.max_abs_error("start"), result.max_abs_error("tuned")
    return [{"metric": k, "weight": result.objective.weights.get(k, 0.0),
             "compared": result.compared(k),
             "start_max_abs_rel_error": start[k], "tuned_max_abs_rel_error": tuned[k],
             "floor_max_abs_rel_error": floor_error(result, k)}
            for k in shown_metrics(result)]


def at_bounds(result: TuneResult, rel: float = 1e-3) -> list[str]:
    """Names of tuned parameters sitting on a bound (within ``rel`` of its log-range)."""
    out = []
    for p, v in zip(result.space.parameters, result.tuned.values, strict=True):
        span = math.log(p.upper / p.lower)
        where = math.log(v / p.lower) / span if span > 0 else 0.0
        if where <= rel or where >= 1.0 - rel:
            out.append(f"{p.name} = {v:.6g} {p.unit} (bounds {p.lower:.3g}–{p.upper:.3g})")
    return out


def limits_bind(result: TuneResult) -> bool:
    """True when a point the plausibility limits ruled out had smaller errors than the fit."""
    free = result.objective.best_implausible
    return free is not None and free.objective < result.tuned.objective


def plausibility_lines(result: TuneResult) -> list[str]:
    """What the plausibility limits (:mod:`impactbench.plausibility`) did to the fit."""
    from impactbench.plausibility import DEFAULT

    pen = result.tuned.max_penetration_ratio
    lines = []
    if math.isfinite(pen):
        verdict = "within" if pen <= DEFAULT.max_penetration_ratio else "beyond"
        lines.append(f"penetration: the tuned contact's largest is {pen:.3g} of the radius, "
                     f"{verdict} the plausibility limit {DEFAULT.max_penetration_ratio:g}")
    tuned = result.tuned
    bad = [v for v, st in zip(result.velocities_m_s, tuned.statuses, strict=True)
           if not st.startswith("ok")]
    if bad:
        lines.append(f"no plausible run at {', '.join(f'{v:g}' for v in bad)} m/s with the "
                     f"tuned parameters ({tuned.statuses[result.velocities_m_s.index(bad[0])]})")
    if limits_bind(result):
        free = result.objective.best_implausible
        errs = [abs(e["restitution"]) for e, st in zip(tuned.rel_errors, tuned.statuses,
                                                        strict=True)
                if st.startswith("ok") and math.isfinite(e["restitution"])]
        within = (f"restitution within {100 * max(errs):.3g} %" if errs
                  else "no plausible restitution at all")
        where = f" (at {', '.join(f'{v:g}' for v in result.velocities_m_s if v not in bad)} " \
                "m/s)" if bad and errs else ""
        lines.append(
            f"the plausibility limits bind: the best {result.space.engine} does at "
            f"{result.timestep_s:g} s with penetration <= "
            f"{DEFAULT.max_penetration_ratio:g} of the radius is {within}{where}; without "
            f"the limits the search found an objective of {free.objective:.4g} (against "
            f"{tuned.objective:.4g}) at a penetration of {free.max_penetration_ratio:.3g} "
            "radii, a setting that would sink the ball")
    return lines


def honesty_lines(result: TuneResult) -> list[str]:
    lines = [f"cannot express: {s}" for s in result.space.limits]
    lines += plausibility_lines(result)
    if result.space.mode != "tuned":
        lines.append(f"this parameter set runs in {result.space.mode} mode: the adapter's "
                     f"tuned mode cannot read {sorted(result.parameters)} yet")
    if result.excluded:
        for why in dict.fromkeys(result.excluded.values()):
            keys = [k for k, w in result.excluded.items() if w == why]
            lines.append(f"excluded from the objective (weight 0): {', '.join(keys)}: {why}")
    if result.start.objective > 0:
        lines.append(f"objective J: start {result.start.objective:.6g} → tuned "
                     f"{result.tuned.objective:.6g} "
                     f"({result.tuned.objective / result.start.objective:.3g}× the start)")
    for name in at_bounds(result):
        lines.append(f"at a bound: {name} — the optimum may lie beyond it")
    if result.stop != "converged":
        lines.append(f"search stopped early ({result.stop}): the best point so far is kept")
    return lines


TRADEOFF_FACTORS = (0.5, 0.7, 1.0, 1.4, 2.0)


def tradeoff_rows(result: TuneResult, factors: tuple[float, ...] = TRADEOFF_FACTORS
                  ) -> list[dict[str, Any]]:
    """The stiffness trade-off around the tuned point: the first parameter (a stiffness or
    timeconst) scaled by each factor, the others kept, and the max |relative error| of the
    headline metrics at each (one evaluation per factor; factor 1 is the tuned point)."""
    p0 = result.space.parameters[0]
    rows = []
    for f in factors:
        values = result.tuned.values.copy()
        values[0] = p0.clip(values[0] * f)
        ev = result.tuned if f == 1.0 else result.objective.evaluate(values, count_budget=False)
        row: dict[str, Any] = {p0.name: float(values[0]), "objective": ev.objective}
        for k in REPORTED:
            errs = [abs(e[k]) for e in ev.rel_errors]
            row[f"max_abs_{k}"] = max(errs) if all(math.isfinite(x) for x in errs) else math.nan
        rows.append(row)
    return rows


# ------------------------------------------------------------------------------ plot


def plot(result: TuneResult, path: Path) -> Path:
    """Residual plot: relative error (%) against V0 per metric, start vs tuned."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = plotted_metrics(result)
    if not keys:  # no run compared (every one implausible or failed): say so, not a crash
        fig, ax = plt.subplots(figsize=(6.4, 2.0))
        ax.axis("off")
        ax.text(0.5, 0.5, f"{result.space.engine}: no run compared with the reference at "
                f"{result.timestep_s:g} s (every one implausible or failed)", ha="center",
                va="center", fontsize=9, wrap=True)
        return _save_plot(fig, path)
    fig, axes = plt.subplots(1, len(keys), figsize=(3.6 * len(keys), 3.2), squeeze=False)
    v = list(result.velocities_m_s)
    for ax, key in zip(axes[0], keys, strict=True):
        for ev, style, label in ((result.start, "s--", "start (native conversion)"),
                                 (result.tuned, "o-", "tuned")):
            ax.plot(v, [100.0 * e[key] for e in ev.rel_errors], style, label=label, ms=4)
        floor = floor_error(result, key)
        if math.isfinite(floor):
            for sign in (-1, 1):
                ax.axhline(100.0 * sign * floor, color="0.6", lw=0.8, ls=":")
        ax.axhline(0.0, color="k", lw=0.6)
        w = result.objective.weights.get(key, 0.0)
        ax.set_title(f"{key} (w = {w:g})", fontsize=9)
        ax.set_xlabel("impact velocity V0 (m/s)")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("relative error vs Hunt–Crossley (%)")
    axes[0][0].legend(fontsize=7)
    floors = any(math.isfinite(floor_error(result, k)) for k in keys)
    fig.suptitle(f"{result.space.engine} {result.engine_version} tuned "
                 f"({result.space.variant})"
                 + ("; dotted: ± the best max error any linear contact can reach" if floors
                    else ""), fontsize=9)
    fig.tight_layout()
    return _save_plot(fig, path)


def _save_plot(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, metadata={"Software": None})
    plt.close(fig)
    return path


# ------------------------------------------------------------------------------ tuned file


def tuned_tables(result: TuneResult) -> dict[str, dict[str, Any]]:
    """The tuned file's tables: parameters (adapter keys), start, provenance, residuals.

    Date- and wall-time-free, so the same tuning writes the same bytes.
    """
    s = result.objective.scenario
    weights = result.objective.weights
    prov: dict[str, Any] = {
        "engine": result.space.engine,
        "engine_version": result.engine_version,
        "scenario": s.name,
        "parameter_set": result.space.variant,
        "mode": result.space.mode,
        "velocities_m_s": list(result.velocities_m_s),
        "targets": list(weights),
        "weights": [weights[k] for k in weights],
        "requested_weights": [result.requested_weights[k] for k in weights],
        "excluded_targets": list(result.excluded),
        "timestep_s": result.timestep_s,
        "objective": "sum over velocities and targets of weight * relative_error^2",
        "objective_start": result.start.objective,
        "objective_tuned": result.tuned.objective,
        "evaluations": result.objective.evaluations,
        "runs_per_evaluation": len(result.velocities_m_s) * len(result.objective.phases),
        "phases": len(result.objective.phases),
        "stop": result.stop,
        "optimizer": "log-parameter box; Sobol scan (scrambled, seed) when > 2 parameters; "
                     "scipy least_squares trf polish",
        "seed": SEED,
        "limits": list(result.space.limits),
        **{f"scenario_{k}": v for k, v in s.to_dict().items()
           if k != "velocity_m_s" and v is not None},  # TOML has no null
    }
    start, tuned = result.max_abs_error("start"), result.max_abs_error("tuned")
    for k in REPORTED:
        prov[f"max_abs_rel_error_{k}_start"] = start[k]
        prov[f"max_abs_rel_error_{k}_tuned"] = tuned[k]
    pen = result.tuned.max_penetration_ratio
    if math.isfinite(pen):
        prov["max_penetration_ratio_tuned"] = pen
    prov["plausibility_limit_binds"] = limits_bind(result)
    plausible = [i for i, st in enumerate(result.tuned.statuses) if st == "ok"]
    prov["plausible_velocities_m_s"] = [result.velocities_m_s[i] for i in plausible]
    for k in REPORTED:  # the worst error where the tuned contact is plausible
        errs = [abs(result.tuned.rel_errors[i][k]) for i in plausible]
        if errs and all(math.isfinite(e) for e in errs):
            prov[f"max_abs_rel_error_{k}_plausible"] = max(errs)
    res: dict[str, Any] = {"velocities_m_s": list(result.velocities_m_s)}
    for k in shown_metrics(result):
        res[f"{k}_reference"] = [float(r[k]) for r in result.objective.references]
        res[f"{k}_rel_error_start"] = [e[k] for e in result.start.rel_errors]
        res[f"{k}_rel_error_tuned"] = [e[k] for e in result.tuned.rel_errors]
    return {"parameters": result.parameters, "start": result.start_parameters,
            "provenance": prov, "residuals": res}


def as_json(result: TuneResult, files: dict[str, str] | None = None) -> dict[str, Any]:
    """Everything a caller needs, JSON-ready (the CLI's ``--json``)."""
    tables = tuned_tables(result)
    return {
        "engine": result.space.engine, "engine_version": result.engine_version,
        "parameter_set": result.space.variant, "parameters": tables["parameters"],
        "start_parameters": tables["start"], "snippet": result.space.snippet(result.parameters),
        "objective_start": result.start.objective, "objective_tuned": result.tuned.objective,
        "evaluations": result.objective.evaluations, "wall_s": result.wall_s,
        "runs_from_store": result.objective.served, "runs_stored": result.objective.stored,
        "stop": result.stop, "stages": result.stages, "timestep_s": result.timestep_s,
        "phases": len(result.objective.phases), "excluded": result.excluded,
        "honesty": honesty_lines(result),
        "summary": summary_rows(result), "residuals": residual_rows(result),
        "tradeoff": tradeoff_rows(result) if result.space.engine == "drake" else [],
        "files": files or {},
    }
