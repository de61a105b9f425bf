"""The report section "at practical timesteps": each engine at the steps its users run it at.

Users run MuJoCo at 2 ms (its default) or 1 ms, PyBullet at 1/240 s, Drake with a 1 ms discrete
plant and pymunk at 1/60–1/1000 s — steps 10 to 200 times longer than the paper's ball contact
(≈ 0.1 ms). There the contact is a one- or few-step event: restitution stays comparable (the
metrics read it at the free-flight samples around a short contact), while duration and peak
force are not resolved (``impactbench.reference.metrics.resolved``) and are shown as such,
never compared. This module turns the ``practical`` study's tidy rows into the section's
tables, its figure (restitution against impact velocity beside the reference curve, one panel
per engine) and its text.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd


def _rows(df: pd.DataFrame) -> pd.DataFrame:
    return df[(df.study == "practical") & (df.metric == "restitution")].copy()


def _step(dt: float) -> str:
    """A step as users write it: 1/240 s, 2 ms, 1e-06 s."""
    for den in (60, 120, 240, 480, 1000):
        if math.isclose(dt * den, 1.0, rel_tol=1e-9):
            return "1 ms" if den == 1000 else f"1/{den} s"
    if dt >= 1e-4:
        return f"{dt * 1e3:g} ms"
    return f"{dt:g} s"


def column(row: pd.Series) -> str:
    """A column label: mode, its parameters (variant) and the step; ``advised`` for the
    packaged advice (its params are in the first section)."""
    if isinstance(row.get("advice"), str) and row.get("advice"):
        return f"advised @ {_step(float(row.timestep_s))}"
    params = f" [{row.params}]" if isinstance(row.params, str) and row.params else ""
    return f"{row['mode']}{params} @ {_step(float(row.timestep_s))}"


def _cell(row: pd.Series):
    """``value (±err %)`` banded, or the run's status (see report_sections.value_cell)."""
    from impactbench.report_render import Cell, band, format_error

    if row.status != "ok":
        return Cell(str(row.status), "fail", str(row.message or ""))
    value, err = row.value, row.rel_error
    if not (isinstance(value, float | int) and math.isfinite(value)):
        return Cell("n/a", "na", str(row.message or "not comparable"))
    text = f"{value:.3g}"
    lo, hi = row.get("value_min", math.nan), row.get("value_max", math.nan)
    if isinstance(lo, float) and math.isfinite(lo) and math.isfinite(hi):
        text += f" [{lo:.3g}–{hi:.3g}]"  # median [range] over the phases of the step
    if isinstance(err, float) and math.isfinite(err):
        text += f" ({format_error(err)})"
    return Cell(text, band(err))


def tables(df: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """Per engine: restitution cells against velocity, one column per mode/variant/step."""
    rows = _rows(df)
    out = []
    for engine, g in rows.groupby("engine", sort=True):
        g = g.copy()
        g["cell"] = g.apply(_cell, axis=1)
        g["column"] = g.apply(column, axis=1)
        order = list(dict.fromkeys(g.sort_values(["timestep_s", "mode", "params"],
                                                 ascending=[False, True, True]).column))
        table = g.pivot_table(index="velocity_m_s", columns="column", values="cell",
                              aggfunc="first")[order]
        table.insert(0, "reference", g.groupby("velocity_m_s")["reference"].first()
                     .map(lambda v: f"{v:.3g}"))
        version = next((v for v in g.engine_version if v), "")
        out.append((f"{engine} {version}".strip(), table.reset_index()))
    return out


def summary(df: pd.DataFrame) -> list[dict[str, object]]:
    """Per engine, step and mode/variant: restitution error at the slowest and fastest
    configured velocity and the worst |error| over the plausible runs (NaN where none), plus
    the counts of implausible and failed runs."""
    rows = _rows(df)
    out = []
    keys = ["engine", "timestep_s", "mode", "params"]
    for (engine, dt, mode, params), g in rows.groupby(keys, sort=True):
        ok = g[g.status == "ok"]
        lo, hi = float(g.velocity_m_s.min()), float(g.velocity_m_s.max())
        at = {v: g[np.isclose(g.velocity_m_s, v)].iloc[0] for v in (lo, hi)}
        err = ok.rel_error.abs()
        out.append({"engine": engine, "step": _step(float(dt)), "mode": mode,
                    "params": params, "slow_m_s": lo, "fast_m_s": hi,
                    "at_slow": at[lo], "at_fast": at[hi],
                    "max_abs_error": float(err.max()) if len(err) else math.nan,
                    "implausible": int((g.status == "implausible").sum()),
                    "failed": int((~g.status.isin(["ok", "implausible"])).sum())})
    return out


def unresolved_share(df: pd.DataFrame) -> tuple[int, int]:
    """(runs whose peak force is not resolved, ok runs) in the practical study."""
    rows = df[(df.study == "practical") & (df.metric == "peak_force_n") & (df.status == "ok")]
    return int((~rows.resolved.astype(bool)).sum()), len(rows)


def intro(df: pd.DataFrame) -> str:
    n_unres, n_ok = unresolved_share(df)
    rows = _rows(df)
    steps = "; ".join(
        f"{engine} " + ", ".join(_step(float(t)) for t in sorted(set(g.timestep_s),
                                                              reverse=True))
        for engine, g in rows.groupby("engine", sort=True))
    return (
        f"Each engine at the steps its users run it at (this config's: {steps}), against the "
        "reference ball, whose contact lasts about 0.1 ms. "
        "**default** is the engine out of the box (its own contact parameters, recorded in "
        "the results); **native** the mapped parameters of the headline tables (fitted for a "
        "1 µs step); **tuned** the packaged parameters fitted at that very step under the "
        "plausibility limits (`impactbench tune --timestep S`); **custom** the defaults plus "
        "the settings in brackets. Restitution is compared; a run whose ball sinks deeper "
        "than the plausibility limit is marked `implausible` and its error not counted; "
        "duration and peak force are not resolved when "
        f"the step is about as long as the contact ({n_unres} of {n_ok} measured runs here) "
        "and are marked `resolved = false` in `results.csv`, never compared.")


def plot(df: pd.DataFrame, damping_s_per_m: float, how: str, path: Path) -> Path:
    """Restitution against V0 per engine (one panel each, one above the other, for the page's
    full width) at its customary steps, beside the Hunt–Crossley reference k(b·V0). Each
    panel's legend sits to its right, 8 pt: the reference, one entry per mode, settings and
    step, and one per failure status; a failed run is drawn at the bottom of the panel in its
    setting's colour, its marker the status's (× implausible, + diverged, …)."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from impactbench.plots import ENGINE_COLORS, _save
    from impactbench.reference.hunt_crossley import restitution

    rows = _rows(df)
    engines = sorted(rows.engine.unique())
    statuses = sorted(set(rows.status) - {"ok"}, key=lambda st: (st != "implausible", st))
    failed_marker = dict(zip(statuses, "x+12348", strict=False))
    n = max(1, len(engines))
    fig, axes = plt.subplots(n, 1, figsize=(11, 2.7 * n + 0.9), squeeze=False, sharex=True)
    v = np.linspace(0.0, max(float(rows.velocity_m_s.max()) if len(rows) else 5.0, 1.0) * 1.05,
                    200)
    markers = "os^vDP*Xh<>"
    cmap = plt.get_cmap("tab10")
    for ax, engine in zip(axes[:, 0], engines, strict=False):
        ax.plot(v, restitution(damping_s_per_m * v), color="black", lw=2,
                label="Hunt–Crossley reference")
        g = rows[rows.engine == engine].copy()
        g["label"] = g.apply(column, axis=1)
        failures: set[str] = set()
        for i, (label, h) in enumerate(g.groupby("label", sort=True)):
            h = h.sort_values("velocity_m_s")
            ok = h[h.status == "ok"]
            style = dict(color=cmap(i % 10), marker=markers[i % len(markers)], ms=5)
            ax.plot(ok.velocity_m_s, ok.value, "-", lw=1, label=label, **style)
            for status, b in h[h.status != "ok"].groupby("status"):
                ax.plot(b.velocity_m_s, np.full(len(b), -0.05), ls="",
                        marker=failed_marker.get(status, "x"), color=style["color"], ms=7)
                failures.add(status)
        handles, labels = ax.get_legend_handles_labels()
        for status in (st for st in statuses if st in failures):
            handles.append(Line2D([], [], ls="", marker=failed_marker.get(status, "x"),
                                  color="dimgray", ms=7))
            labels.append(f"{status} (at the bottom)")
        ax.legend(handles, labels, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                  borderaxespad=0.0, frameon=False)
        ax.set_ylim(-0.1, 1.1)
        ax.set_title(engine, color=ENGINE_COLORS.get(engine, "black"), loc="left",
                     fontsize=10)
        ax.set_ylabel("restitution k (–)")
        ax.grid(alpha=0.3)
    axes[-1][0].set_xlabel("impact velocity V0 (m/s)")
    fig.suptitle("Restitution at practical timesteps (a failed run: at the bottom in its "
                 "setting's colour, its marker the status's)\n" + how, fontsize=9)
    return _save(fig, path)


def section(ctx) -> dict[str, object] | None:
    """The data of ``templates/sections/practical.j2`` (None without the practical study)."""
    from impactbench.report_render import Cell, Table, band, format_error

    df = ctx.df
    if df.empty or not (df.study == "practical").any():
        return None
    engines = []
    for title, table in tables(df):
        columns = ["V0 (m/s)", *[str(c) for c in table.columns[1:]]]
        rows = [[f"{r['velocity_m_s']:g}", *[c if isinstance(c, Cell) else Cell(str(c))
                                             for c in list(r)[1:]]]
                for _, r in table.iterrows()]
        engines.append({"title": title, "table": Table(columns, rows)})

    def at(row: pd.Series) -> Cell:
        """The signed error of one run, or its status."""
        err = float(row.rel_error) if row.status == "ok" else math.nan
        if not math.isfinite(err):
            return Cell(str(row.status), "fail", str(row.message or ""))
        return Cell(format_error(err), band(err))

    def worst(x: float) -> Cell:
        return Cell(format_error(x, signed=False), band(x)) if math.isfinite(x) \
            else Cell("none plausible", "fail")

    found = summary(df)
    slow = f"{found[0]['slow_m_s']:g}" if found else "slowest"
    fast = f"{found[0]['fast_m_s']:g}" if found else "fastest"
    summary_rows = [[Cell(r["engine"]), Cell(r["step"]), Cell(r["mode"]),
                     Cell(str(r["params"]) or "—"), at(r["at_slow"]), at(r["at_fast"]),
                     worst(r["max_abs_error"]), Cell(str(r["implausible"])),
                     Cell(str(r["failed"]))] for r in found]
    columns = ["engine", "step", "mode", "settings", f"error at {slow} m/s",
               f"error at {fast} m/s", "max |error| (plausible runs)", "implausible runs",
               "failed runs"]
    return {"intro": intro(df), "figures": ctx.figures_in("practical"), "engines": engines,
            "summary": Table(columns, summary_rows, text_columns=4)}


# ----------------------------------------------------------------------------- at your timestep


def _groups(results: list) -> dict[tuple, list]:
    """The practical study's runs by (engine, step, mode, engine parameters)."""
    out: dict[tuple, list] = {}
    for r in results:
        j = r.job
        if j.study == "practical":
            out.setdefault((j.engine, float(j.timestep_s), j.mode, j.params), []).append(r)
    return out


def worst_error(run: dict) -> float:
    """A run's |restitution error| at its worst phase: over the range of a run measured at
    several phases of its step (:func:`impactbench.phases.merge`), else its own."""
    spread = ((run.get("phases") or {}).get("spread") or {}).get("restitution")
    ref = float((run.get("reference") or {}).get("restitution", math.nan))
    if spread and math.isfinite(ref) and ref:
        return max(abs(spread[0] - ref), abs(spread[2] - ref)) / abs(ref)
    return abs(float(run["rel_error"].get("restitution", math.nan)))


def _score(runs: list) -> tuple[int, float]:
    """(plausible ok runs, worst |restitution error| over them, each at its worst phase):
    more ok runs first."""
    errs = [worst_error(r.run) for r in runs if r.run["status"] == "ok"]
    errs = [e for e in errs if math.isfinite(e)]
    return len(errs), (max(errs) if errs else math.inf)


def settings_snippet(runs: list) -> tuple[str, str]:
    """(words, the settings in the engine's own words) of one group of runs."""
    from impactbench.config import thawed

    job = runs[0].job
    params = thawed(job.params)
    if getattr(job, "advice", ""):
        from impactbench.advice_files import ADVICE_DIR, load

        advice = load(ADVICE_DIR / job.advice)
        return (f"the packaged advice ({advice['model']}; {job.advice}, written by "
                f"`impactbench advise`)", str(advice["snippet"]))
    if job.mode == "default":
        return "nothing to set: the engine out of the box", "# the engine's defaults"
    if job.mode == "custom":
        return ("the engine's defaults plus", "\n".join(f"{k} = {v!r}"
                                                        for k, v in params.items()))
    if job.mode == "native":
        return ("the native mapping (fitted for a 1 µs step; see the tables)",
                "# impactbench run --mode native")
    if job.mode != "tuned":
        return job.mode, ""
    from impactbench.engines.tuning_spaces import make_space
    from impactbench.matrix import job_settings

    settings = job_settings(job)
    tuned, prov = settings.tuned or {}, settings.tuned_for or {}
    variant, _, form = str(prov.get("parameter_set", "")).partition(" (")
    try:
        space = make_space(job.engine, job.build_scenario(), variant or None,
                           form.rstrip(")") or "direct", timestep_s=job.timestep_s)
        snippet = space.snippet(tuned)
    except (ValueError, KeyError) as exc:  # a user's tuned file of another parameter set
        snippet = "\n".join(f"{k} = {v!r}" for k, v in tuned.items()) + f"\n# ({exc})"
    where = prov.get("file", "the tuned file")
    return f"the parameters fitted at this step ({where})", snippet


def your_timestep(ctx) -> dict[str, object] | None:
    """The report's first section: per engine at each of its steps (the config's practical
    steps), the best mode's restitution error, its plausibility and the settings to paste."""
    from impactbench.report_render import Cell, Table, band, format_error

    limits = ctx.cfg.limits
    groups = _groups(ctx.results)
    if not groups:
        return None
    best: dict[tuple, tuple] = {}
    for (engine, dt, mode, params), runs in groups.items():
        key = (engine, dt)
        score = _score(runs)
        if key not in best or (-score[0], score[1]) < (-best[key][0][0], best[key][0][1]):
            best[key] = (score, mode, params, runs)
    rows, settings = [], []
    for (engine, dt), (score, mode, params, runs) in sorted(best.items()):
        n_ok, worst = score
        from impactbench.config import thawed

        label = "advised" if runs[0].job.advice else mode + (
            f" [{', '.join(f'{k}={v}' for k, v in thawed(params).items())}]" if params else "")
        pens = [float((r.run.get("plausibility") or {}).get("penetration_ratio", math.nan))
                for r in runs]
        pens = [p for p in pens if math.isfinite(p)]
        bad = sorted(r.job.velocity_m_s for r in runs if r.run["status"] != "ok")
        ok_text = f"{n_ok}/{len(runs)}" + (f" (not at {', '.join(f'{v:g}' for v in bad)} m/s)"
                                           if bad else "")
        err = Cell(format_error(worst, signed=False), band(worst)) if math.isfinite(worst) \
            else Cell("none plausible", "fail")
        pen = max(pens) if pens else math.nan
        pen_cell = Cell(f"{pen:.2g} R", "good" if pen <= limits.max_penetration_ratio
                        else "poor") if math.isfinite(pen) else Cell("—", "na")
        version = next((r.run.get("engine_version") for r in runs
                        if r.run.get("engine_version")), "")
        rows.append([Cell(f"{engine} {version}".strip()), Cell(_step(dt)), Cell(label), err,
                     Cell(ok_text), pen_cell])
        words, snippet = settings_snippet(runs)
        settings.append({"title": f"{engine} at {_step(dt)}: {label}",
                         "words": f"{words}; max |restitution error| "
                                  + (format_error(worst, signed=False)
                                     if math.isfinite(worst)
                                     else "— (no plausible run)")
                                  + f" over {n_ok} plausible of {len(runs)} runs.",
                         "snippet": snippet})
    v = sorted({r.job.velocity_m_s for runs in groups.values() for r in runs})
    intro = (
        "Which engine comes closest at the step you run it at, and what to set. Per engine "
        "and step (the config's `[practical]` steps), the mode with the most plausible runs "
        "and then the smallest worst restitution error over V0 = "
        f"{', '.join(f'{x:g}' for x in v)} m/s against the reference. **advised** is the "
        "packaged advice for that step (`impactbench advise`: every contact model the engine "
        "offers, searched on its worst phase). At these steps, longer than the contact, the "
        "outcome depends on where the first touch falls inside a step, so every run here is "
        "measured at 8 evenly spaced phases of the step: the error is the worst phase's, and "
        "a run is plausible only when, at every phase, the contact lets the ball sink at "
        f"most {limits.max_penetration_ratio:g} of its radius beyond the step's own overlap "
        "(v·dt + g·dt², which no contact can avoid) and creates no energy "
        "(`impactbench.plausibility`); an implausible run's error is not counted, however "
        "small. Duration and peak force are not resolved at such steps: restitution is the "
        "answer here.")
    columns = ["engine", "step", "best mode", "max |restitution error| (worst phase)",
               "plausible runs", "max sinking beyond the step"]
    return {"intro": intro, "table": Table(columns, rows, text_columns=3),
            "after": "The settings behind each row, in the engine's own words:",
            "settings": settings}
