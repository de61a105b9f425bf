"""The report's sections: one data function per template in ``templates/sections/``.

:func:`sections` is the report in reading order. Each data function takes the
:class:`~impactbench.report_render.ReportContext` and returns the dict its template reads, or
``None`` to leave the section out. Relative errors are signed, (engine − reference)/|reference|.
"""

from __future__ import annotations

import math
import re
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from impactbench import scenarios
from impactbench.engines.base import MODES, PIP
from impactbench.report_render import (
    BANDS,
    Cell,
    FigureRef,
    ReportContext,
    Section,
    Table,
    band,
    format_error,
)

_LABELS = {"duration_s": "duration", "peak_force_n": "peak force",
           "energy_loss_fraction": "energy loss", "impulse_ns": "impulse",
           "spin_out_rad_s": "spin", "peak_tangential_force_n": "peak tangential force"}
_UNITS = (("_rad_s", "rad/s"), ("_deg", "°"), ("_ns", "N·s"), ("_n", "N"), ("_s", "s"),
          ("_m", "m"))


class _Labels(dict):
    """A metric's words (``peak_force_n`` → ``peak force``): the table above, else its name
    without the unit suffix."""

    def __missing__(self, metric: str) -> str:
        for suffix, _ in _UNITS:
            if metric.endswith(suffix):
                return metric.removesuffix(suffix).replace("_", " ")
        return metric.replace("_", " ")


class _Units(dict):
    """A metric's unit from its name's SI suffix (``_s`` → s, ``_deg`` → °); ``–`` for a
    dimensionless one, ``count`` for the impact count."""

    def __missing__(self, metric: str) -> str:
        if metric == "impacts":
            return "count"
        return next((unit for suffix, unit in _UNITS if metric.endswith(suffix)), "–")


LABELS = _Labels(_LABELS)
UNITS = _Units()
def run_keys() -> list[str]:
    """The columns that identify one run in the tidy table."""
    cats, nums = scenarios.point_columns()
    return ["study", "scenario", *cats, *nums, "engine", "mode", "timestep_s"]


# ----------------------------------------------------------------------------- formatting


def point_label(row: Any) -> str:
    """``V0 = 1 m/s`` (ball) or ``elastoplastic/linear, v1 = 2 m/s`` (rigid–flexible)."""
    spec = scenarios.get(row.scenario)
    return spec.point_text({a.name: getattr(row, a.name) for a in spec.axes})


def timestep_text(rows: pd.DataFrame) -> str:
    """``dt = 1e-06 s`` or the list of distinct steps, from the runs' recorded timesteps."""
    dts = sorted({float(t) for t in rows.timestep_s.dropna()})
    if not dts:
        return "the adapter's default step"
    return "dt = " + ", ".join(f"{t:g}" for t in dts) + " s"


def value_cell(row: Any) -> Cell:
    """``value (±err %)`` banded by |err|; a failed run's status; n/a with its reason; an
    implausible run's value marked as such (measured, but not a setting to use)."""
    if row.status == "implausible":
        value = row.value
        shown = f"{value:.5g} " if isinstance(value, int | float) and math.isfinite(value) \
            else ""
        return Cell(f"{shown}(implausible)", "fail", str(row.message or ""))
    if row.status != "ok":
        return Cell(str(row.status), "fail", str(row.message or ""))
    value, err = row.value, row.rel_error
    if not (isinstance(value, int | float) and math.isfinite(value)):
        return Cell("n/a", "na", str(row.message or "not comparable"))
    if not getattr(row, "resolved", True):
        return Cell(f"{value:.5g} (not resolved)", "na",
                    "the step is about as long as the contact: measured, not compared")
    if row.metric == "impacts":
        ok = isinstance(err, float) and err == 0
        return Cell(f"{value:g}" + ("" if ok else " ✗"), "good" if ok else "poor")
    text = f"{value:.5g}"
    if isinstance(err, int | float) and math.isfinite(err):
        text += f" ({format_error(err)})"
    return Cell(text, band(err))


def _runs(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per run (the tidy table has one per run and metric)."""
    return rows.drop_duplicates([c for c in run_keys() if c in rows.columns])


def _status_counts(runs: pd.DataFrame) -> str:
    counts = runs.status.value_counts()
    return ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))


# ----------------------------------------------------------------------------- scoreboard


def worst(rows: pd.DataFrame, metric: str) -> tuple[float, Any]:
    """The signed relative error of largest magnitude among ok runs, and its row."""
    # on the columns' arrays, not filtered frames: the report asks ~1000 times (each filter
    # of the tidy table copied all its columns: 5.9 s of the documents' 15.7 s)
    at = np.flatnonzero((rows.metric.to_numpy() == metric) & (rows.status.to_numpy() == "ok"))
    errors = pd.to_numeric(rows.rel_error.iloc[at], errors="coerce").to_numpy(dtype=float)
    keep = ~np.isnan(errors)
    if not keep.any():
        return math.nan, None
    i = int(np.argmax(np.abs(errors[keep])))  # the first of equal magnitudes, as idxmax
    return float(errors[keep][i]), rows.iloc[at[keep][i]]


def verdict(rows: pd.DataFrame, scenario: str) -> str:
    """One sentence on one engine and mode over one scenario's points."""
    runs = _runs(rows)
    n, ok = len(runs), int((runs.status == "ok").sum())
    if ok == 0:
        status = runs.status.iloc[0] if n else "none"
        if (runs.status == status).all() and status == "unsupported":
            return "The adapter does not implement this mode."
        if (runs.status == status).all() and status == "unavailable":
            return "The engine is not installed here."
        return f"No run gave numbers ({_status_counts(runs)})."
    headline = scenarios.get(scenario).headline
    found = [(m, *worst(rows, m)) for m in headline if m != "impacts"]
    measured = [(m, e, r) for m, e, r in found if math.isfinite(e)]
    missing = [LABELS[m] for m, e, _ in found if not math.isfinite(e)]
    parts = []
    if measured:
        m, e, r = max(measured, key=lambda t: abs(t[1]))
        name = band(e)
        if name == "good":
            parts.append(f"Faithful: every measured metric within 1 % at {ok} point"
                         + ("s" if ok > 1 else ""))
        else:
            rest = [abs(x) for mm, x, _ in measured if mm != m]
            word = "Noticeably off" if name == "fair" else "Far off"
            tail = (f"; the others within {format_error(max(rest), signed=False)}"
                    if rest else "")
            parts.append(f"{word}: {LABELS[m]} {format_error(e)} at {point_label(r)}{tail}")
    if missing:
        parts.append(f"{' and '.join(missing)} not comparable")
    if "impacts" in headline:
        counts = rows[(rows.metric == "impacts") & (rows.status == "ok")]
        wrong = counts[pd.to_numeric(counts.rel_error, errors="coerce").fillna(1) != 0]
        if len(wrong):
            parts.append(f"the impact count differs at {len(wrong)} of {len(counts)} points")
    sentence = "; ".join(parts) + "."
    if ok < n:
        bad = runs[runs.status != "ok"]
        sentence += f" {n - ok} of {n} runs gave no numbers ({_status_counts(bad)})."
    return sentence


def scoreboard(ctx: ReportContext) -> dict[str, Any] | None:
    """Per scenario a table: engine × mode rows, the worst relative error of each metric."""
    m = ctx.matrix
    if m.empty:
        return None
    tables = []
    for spec in scenarios.specs():
        scenario = spec.name
        s = m[m.scenario == scenario]
        if s.empty:
            continue
        metrics = spec.headline
        rows = []
        for engine in ctx.engines:
            e = s[s.engine == engine]
            if e.empty:
                continue
            if (e.status == "unavailable").all():
                rows.append([Cell(engine), Cell("all"), *[Cell("—", "na")] * len(metrics),
                             Cell("0/" + str(len(_runs(e)))),
                             Cell(f"Not installed here (`{PIP.get(engine, 'pip install')}`).",
                                  wrap=True)])
                continue
            for mode in [x for x in MODES if x in set(e["mode"])]:
                g = e[e["mode"] == mode]
                runs = _runs(g)
                cells = [Cell(engine), Cell(mode)]
                for metric in metrics:
                    err, _ = worst(g, metric)
                    cells.append(Cell(format_error(err), band(err)) if math.isfinite(err)
                                 else Cell("—", "na"))
                cells.append(Cell(f"{int((runs.status == 'ok').sum())}/{len(runs)}"))
                cells.append(Cell(verdict(g, scenario), wrap=True))
                rows.append(cells)
        columns = ["engine", "mode", *[LABELS[x] for x in metrics], "runs ok", "in one sentence"]
        tables.append({"title": f"Scoreboard: {spec.title.lower()}, {timestep_text(s)}",
                       "table": Table(columns, rows, text_columns=2, marks=True,
                                      prose_columns=1)})
    legend = ", ".join(f"{name}: {words}" for name, _, words in BANDS)
    return {"tables": tables, "legend": legend}


# ----------------------------------------------------------------------------- per scenario


_CELL_COLUMNS = ("mode", "metric", "params", "reference", "value", "rel_error", "resolved",
                 "status", "message")
"""The result columns a scenario table's cells read (:func:`value_cell`, the settings)."""


def scenario_tables(ctx: ReportContext, scenario: str) -> list[dict[str, Any]]:
    """Per engine: rows = scenario point × (reference, modes), columns = headline metrics."""
    s = ctx.matrix[ctx.matrix.scenario == scenario]
    spec = scenarios.get(scenario)
    keys = list(spec.axis_names)
    metrics = spec.headline
    key_columns = [a.column for a in spec.axes]
    columns = [*key_columns, "run", *[f"{LABELS[x]} ({UNITS[x]})" for x in metrics]]
    out = []
    for engine in ctx.engines:
        e = s[s.engine == engine]
        if e.empty:
            continue
        version = next((v for v in e.engine_version if v), "")
        if (e.status == "unavailable").all():
            out.append({"title": engine, "note": f"Not installed here "
                        f"(`{PIP.get(engine, 'pip install')}`); every run is `unavailable`.",
                        "table": None})
            continue
        rows = []
        # the columns the cells read, once per engine (a frame's itertuples costs per column)
        cells_of = e[[*keys, *(c for c in _CELL_COLUMNS if c in e.columns and c not in keys)]]
        for point, p in cells_of.groupby(keys, sort=True):
            point = point if isinstance(point, tuple) else (point,)
            labels = [f"{x:g}" if isinstance(x, float) else str(x) for x in point]
            records = list(p.itertuples())
            first: dict[str, Any] = {}  # each metric's reference: its first row's
            for r in records:
                first.setdefault(r.metric, r.reference)
            ref = [first.get(x, math.nan) for x in metrics]
            rows.append([*labels, Cell("**reference**"),
                         *[Cell(f"{v:.5g}" if isinstance(v, int | float) else str(v))
                           for v in ref]])
            runs = {(r.mode, r.metric): r for r in records}
            settings = {r.mode: getattr(r, "params", "") for r in records}
            for mode in [x for x in MODES if x in settings]:
                label = f"{mode} [{settings[mode]}]" if settings.get(mode) else mode
                rows.append([*[""] * len(labels), Cell(label),
                             *[value_cell(runs[mode, x]) if (mode, x) in runs
                               else Cell("—", "na") for x in metrics]])
        out.append({"title": f"{engine} {version}".strip(),
                    "note": f"{timestep_text(e)}; modes "
                    + ", ".join(x for x in MODES if x in set(e["mode"])) + ".",
                    "table": Table(columns, rows, text_columns=len(key_columns) + 1)})
    return out


def scenario_section(scenario: str, ctx: ReportContext) -> dict[str, Any] | None:
    s = ctx.matrix[ctx.matrix.scenario == scenario] if not ctx.matrix.empty else ctx.matrix
    if s.empty:
        return None
    spec = scenarios.get(scenario)
    if "velocity_m_s" in spec.axis_names:
        v = sorted(set(s.velocity_m_s))
        points = f"{len(v)} velocit{'y' if len(v) == 1 else 'ies'} " \
                 f"({', '.join(f'{x:g}' for x in v)} m/s)"
    else:  # its numeric axes by their columns: h (m) → "h = 0.05, 0.2 m"
        points = ", ".join(spec.values_text(a, sorted(set(s[a.name].astype(float))))
                           for a in spec.axes if not a.categorical)
    cats = [a.name for a in spec.axes if a.categorical]
    if cats:
        combos = sorted(set(zip(*(s[c] for c in cats), strict=True)))
        points += f" × {len(combos)} law pairs ({'/'.join(cats)}: " \
                  + ", ".join("/".join(c) for c in combos) + ")"
    return {
        "intro": f"{spec.title}: {spec.summary}; {points}. Each cell: the engine's value and "
                 "its signed relative error against the reference; a word is the run's status.",
        "heatmaps": ctx.figures_in(f"heatmap:{scenario}"),
        "engines": scenario_tables(ctx, scenario),
        "more": spec.report_tables(ctx, [r for r in ctx.results if r.job.study == "matrix"
                                         and r.job.scenario == scenario]),
        "figures": ctx.figures_in(f"history:{scenario}"),
        "extra": ctx.figures_in(f"extra:{scenario}"),
        "papers": (papers := paper_figures_of(ctx, spec)),
        "paper_links": paper_links(papers),
    }


# ----------------------------------------------------------------------------- interpretation


def _worst_text(rows: pd.DataFrame, names: list[str]) -> str:
    out = []
    for m in names:
        e, _ = worst(rows, m)
        if math.isfinite(e):
            out.append(f"{LABELS[m]} {format_error(e)}")
    return ", ".join(out)


def _judge(err: float) -> str:
    if not math.isfinite(err):
        return "not measured"
    return {"good": "faithful", "fair": "noticeably off", "poor": "far off"}[band(err)]


def injection_line(engine: str) -> str:
    """The adapter's one-line statement of what injected mode means in it (``""`` if the
    adapter cannot be loaded here)."""
    try:
        from impactbench.engines.base import get_adapter

        return str(get_adapter(engine).injection)
    except Exception:
        return ""


def interpretation(df: pd.DataFrame, engine: str) -> str:
    """A generated paragraph: which metric is off by how much, and whose error it is."""
    rows = df[(df.study == "matrix") & (df.engine == engine)]
    if rows.empty:
        return ""
    version = next((v for v in rows.engine_version if v), "")
    if (rows.status == "unavailable").all():
        return f"**{engine}** is not installed here ({rows.message.iloc[0]}); its rows say " \
               "`unavailable`."
    parts = [f"**{engine} {version}**."]
    how = injection_line(engine)
    for spec in scenarios.specs():
        s = rows[rows.scenario == spec.name]
        if s.empty:
            continue
        label = spec.title
        names = [m for m in spec.headline if m != "impacts"]
        inj, nat = s[s["mode"] == "injected"], s[s["mode"] == "native"]
        inj_w = max((abs(worst(inj, m)[0]) for m in names), default=math.nan)
        nat_w = max((abs(worst(nat, m)[0]) for m in names), default=math.nan)
        if len(inj):
            parts.append(f"{label}, injected mode (the reference law integrated by {engine} at "
                         f"{timestep_text(inj)}): worst errors "
                         f"{_worst_text(inj, names) or 'none measured'} — the time stepping "
                         f"is {_judge(inj_w)}.")
            if how:
                parts.append(f"Injection in {engine}: {how}.")
                how = ""  # once per engine
        if len(nat):
            if not (math.isfinite(inj_w) and math.isfinite(nat_w)):
                owner = ""
            elif nat_w <= 0.01:
                owner = "within 1 % of the reference"
            elif nat_w > 3 * inj_w:
                owner = "the gap is the contact model's, not the integrator's"
            else:
                owner = "comparable to injected mode, so the time stepping dominates"
            mapping = spec.native.get(engine) or spec.native.get("", "mapped parameters")
            parts.append(f"Native mode (its own contact, {mapping}): "
                         f"{_worst_text(nat, names) or 'none measured'}"
                         + (f"; {owner}." if owner else "."))
        tun = s[s["mode"] == "tuned"]
        if len(tun):
            parts.append("Tuned mode (fitted parameters, the best its contact model does over "
                         f"the velocity set): {_worst_text(tun, names) or 'none measured'}.")
        bad = _runs(s[s.status != "ok"])
        if len(bad):
            parts.append(f"{len(bad)} {label.lower()} runs gave no numbers "
                         f"({_status_counts(bad)}).")
    return " ".join(parts)


def meaning(ctx: ReportContext) -> dict[str, Any] | None:
    paragraphs = [t for e in ctx.engines if (t := interpretation(ctx.df, e))]
    return {"paragraphs": paragraphs} if paragraphs else None


# ----------------------------------------------------------------------------- other sections


def how_to_read(ctx: ReportContext) -> dict[str, Any]:
    return {"bands": [(name, words) for name, _, words in BANDS]}


def work_precision(ctx: ReportContext) -> dict[str, Any] | None:
    figs = ctx.figures_in("work_precision")
    if not figs:
        return None
    return {"figures": figs}


def failed_runs(ctx: ReportContext) -> dict[str, Any] | None:
    """Every run without numbers, grouped by engine, mode, scenario, status and message."""
    if ctx.df.empty:
        return None
    runs = _runs(ctx.df[ctx.df.status != "ok"]).copy()
    if runs.empty:
        return {"table": None, "count": 0}
    runs["point"] = [point_label(r) for r in runs.itertuples()]
    runs["message"] = runs.message.fillna("").astype(str)
    rows = []
    keys = ["engine", "mode", "study", "scenario", "status", "message"]
    for (engine, mode, study, scenario, status, message), g in runs.groupby(keys, sort=True):
        dt = timestep_text(g).removeprefix("dt = ")
        points = "; ".join(g.point)
        rows.append([Cell(engine), Cell(mode), Cell(f"{scenario} ({study})"),
                     Cell(status, "fail"), Cell(str(len(g))), Cell(dt),
                     Cell(points, wrap=True), Cell(message or "—", wrap=True)])
    columns = ["engine", "mode", "scenario", "status", "runs", "timestep (s)", "points",
               "message"]
    return {"table": Table(columns, rows, text_columns=4, prose_columns=2),
            "count": len(runs)}


def parameter_table(rows: list[list[Cell]]) -> Table:
    return Table(["parameter", "value", "meaning"], rows, text_columns=2, prose_columns=1)


PARAMETER_TEXT = {
    "velocity_m_s": "impact velocity (m/s)", "radius_m": "ball radius (m), engines' geometry",
    "gravity_m_s2": "gravity (m/s²), engines only", "local": "local contact law",
    "structure": "structural law", "max_time_s": "time cap of a run (s)",
    "model": "contact model of the ball (see Contact models)",
    "nominal_restitution": "nominal restitution e the model's damping is set from (— : the "
                           "damping b is given directly)",
}


def parameters(ctx: ReportContext) -> dict[str, Any] | None:
    """The physical parameters of every scenario of the config (SI), and its timesteps."""
    out = []
    for sm in ctx.cfg.scenarios:
        if not sm.velocities_m_s:
            continue
        spec = scenarios.get(sm.name)
        flags = {**spec.descriptions, **{f.field: f.help for f in spec.flags}}
        sc = spec.build(parameters=sm.parameters)
        rows = []
        for name, value in sc.to_dict().items():
            if name in spec.axis_names:
                continue
            text = flags.get(name) or PARAMETER_TEXT.get(name, "")
            changed = " (set by the config)" if name in sm.parameters else ""
            shown = "—" if value is None else f"{value:g}" if isinstance(value, float) \
                else str(value)
            rows.append([Cell(f"`{name}`"), Cell(shown), Cell(text + changed)])
        rows.append([Cell("`velocities_m_s`"),
                     Cell(", ".join(f"{v:g}" for v in sm.velocities_m_s)),
                     Cell("impact velocities of the matrix (m/s)")])
        cats = [a for a in spec.axes if a.categorical]
        if cats:
            rows.append([Cell(" × ".join(f"`{a.name}`" for a in cats)),
                         Cell(" × ".join(", ".join(sm.values(a.name)) for a in cats)),
                         Cell("contact and structural laws")])
        for engine, dt in sorted(sm.timestep_s.items()):
            rows.append([Cell(f"`timestep_s.{engine}`"), Cell(f"{dt:g}"),
                         Cell("integration step (s)")])
        out.append({"title": spec.title,
                    "table": parameter_table(rows)})
    wp = ctx.cfg.work_precision
    if wp is not None:
        rows = [[Cell("`velocities_m_s`"),
                 Cell(", ".join(f"{v:g}" for v in wp.velocities_m_s)), Cell("ball V0 (m/s)")],
                [Cell("`timesteps_s`"), Cell(", ".join(f"{t:g}" for t in wp.timesteps_s)),
                 Cell("integration steps (s)")],
                [Cell("`modes`"), Cell(", ".join(wp.modes)), Cell("modes run")]]
        out.append({"title": "Work–precision",
                    "table": parameter_table(rows)})
    return {"scenarios": out} if out else None


HC_FIGURES = {
    "hc_fig1_phase": "phase trajectories V(x) for V0 = 0.5…5 m/s",
    "hc_fig3_restitution": "restitution k and ΔT/T = 1 − k² against α = b·V0",
    "hc_fig4_histories": "x(t) and F(t) for the six V0",
    "hc_fig5_maxima": "x_max, F_max and contact duration against V0",
    "hc_fig6_hysteresis": "F against x (loop area = lost energy)",
    "hc_fig7_energy_loss": "lost kinetic energy ΔT against V0",
    "hc_fig8_lambert_w": "the real branches of Lambert W",
}
RF_WHAT = {"history": "force histories", "peak_force": "peak force", "pulse_width":
           "pulse width", "impulse": "impulse"}
RF_OVER = {"velocity": "impact velocity v1", "k1": "contact stiffness k1",
           "k2": "structural stiffness k2", "m2": "flexible mass m2"}


# ------------------------------------------------------------------------ contact models

ZOO_NOMINAL: tuple[float, ...] = (0.2, 0.5, 0.8, 0.9, 0.95)


def contact_models(ctx: ReportContext) -> dict[str, Any] | None:
    """The contact-model zoo: every model's exact effective restitution at nominal e
    (:mod:`impactbench.reference.models`; any V0, m, c, n), as a table and a figure."""
    from impactbench.figures import zoo
    from impactbench.reference.models import MODEL_CITATIONS

    name = scenarios.for_study("tuning").name
    ball = next((s for s in ctx.cfg.scenarios if s.name == name), None)
    if ball is None:  # the zoo is the ball's contact models: no ball, no section
        return None
    params = dict(ball.parameters)
    wide = zoo.table(ZOO_NOMINAL)
    columns = [c for c in wide.columns if c != "model"]
    rows = [[Cell(f"`{r['model']}`"), Cell(MODEL_CITATIONS[r["model"]], wrap=True),
             *(Cell(f"{r[c]:.4f}") for c in columns)] for _, r in wide.iterrows()]
    path = ctx.draw(zoo.figure, ctx.fig_dir / "report_zoo_restitution.png")
    fig = ctx.add_figure(path, "Effective against nominal restitution of every contact "
                         "model (exact)", group="contact_models")
    model = params.get("model", "hunt-crossley")
    e = params.get("nominal_restitution")
    used = (f"This report's ball uses `{model}` with nominal e = {e:g}." if e is not None
            else f"This report's ball uses `{model}` with its damping b given directly.")
    return {"table": Table(["model", "source", *columns], rows, text_columns=2,
                           prose_columns=0), "figure": fig, "used": used}


KHARAZ_FIGURE = "oblique_kharaz2001"
"""The stem of ``impactbench figures``' Kharaz, Gorham & Salman (2001) figure."""


def paper_figure(stem: str) -> dict[str, str] | None:
    """One of ``impactbench figures``' PNGs, from its file name: ``caption``, the papers'
    ``source`` and a short ``label`` (a link's text), and the ``scenario`` (its title in
    lower case) it belongs to ("" for none); None for another file."""
    if stem in HC_FIGURES:
        num = re.search(r"fig(\d+)", stem).group(1)
        return {"caption": f"Borovin et al. Fig. {num}: {HC_FIGURES[stem]} (ball on plate, "
                           "reference)", "source": "Borovin et al.", "label": f"Fig. {num}",
                "scenario": "ball on plate"}
    if stem == "zoo_restitution":
        return {"caption": "Contact models: effective against nominal restitution "
                           "(reference, exact)", "source": "", "label": "contact models",
                "scenario": ""}
    m = re.fullmatch(r"rf_fig(\d+)_(history|peak_force|pulse_width|impulse)_(\w+)", stem)
    if m and m.group(3) in RF_OVER:
        num = int(m.group(1))
        return {"caption": f"Zhou & Xiao Fig. {num}: {RF_WHAT[m.group(2)]} against "
                           f"{RF_OVER[m.group(3)]} (rigid–flexible, reference)",
                "source": "Zhou & Xiao", "label": f"Fig. {num}", "scenario": "rigid–flexible"}
    if stem == KHARAZ_FIGURE:
        return {"caption": "Kharaz, Gorham & Salman (2001): measured rebound angle, spin and "
                           "tangential restitution of alumina spheres on glass against "
                           "incidence angle, beside the rigid Coulomb and Mindlin references "
                           "(oblique impact, measured)",
                "source": "Kharaz, Gorham & Salman (2001)",
                "label": "measured rebounds beside both references",
                "scenario": "oblique impact"}
    return None


def paper_caption(stem: str) -> str | None:
    """The caption of one of ``impactbench figures``' PNGs, from its file name."""
    found = paper_figure(stem)
    return found["caption"] if found else None


def paper_figures_of(ctx: ReportContext, spec: scenarios.ScenarioSpec) -> list[FigureRef]:
    """The papers' figures of one scenario that ``impactbench figures`` wrote into the report
    folder's ``figures/`` (none when it did not): their paths, captions and sources."""
    out = []
    for p in sorted(ctx.fig_dir.glob("*.png")) if ctx.fig_dir.is_dir() else []:
        found = paper_figure(p.stem)
        if found and found["scenario"] == spec.title.lower():
            out.append(FigureRef(p.relative_to(ctx.out_dir).as_posix(), found["caption"],
                                 found["source"]))
    return sorted(out, key=lambda f: (f.group, _figure_number(f.caption), f.path))


def _figure_number(caption: str) -> int:
    m = re.search(r"Fig\. (\d+)", caption)
    return int(m.group(1)) if m else 0


def paper_links(figures: list[FigureRef]) -> str:
    """One line linking a scenario's papers' figures, by source: ``Zhou & Xiao: [Fig. 3](…),
    [Fig. 4](…)``; "" without any."""
    by_source: dict[str, list[str]] = {}
    for f in figures:
        found = paper_figure(Path(f.path).stem) or {"label": f.caption}
        by_source.setdefault(f.group, []).append(f"[{found['label']}]({f.path})")
    if not by_source:
        return ""
    return ("The papers' figures for this scenario (written by `impactbench figures`): "
            + "; ".join(f"{src}: {', '.join(links)}" for src, links in by_source.items())
            + ".")


def tuning_caption(engine: str) -> str:
    """What ``tune_<engine>.png`` shows, with the mode, timestep and velocities of the packaged
    tuned file it was written with (``impactbench tune --write-default``)."""
    from impactbench.tuned import load_tuned_file, tuned_path

    text = (f"Tuning residuals, {engine}, ball on plate: relative error per velocity and "
            "metric, closed-form start against the fit")
    try:
        scenario = scenarios.for_study("tuning").name
        prov = (load_tuned_file(tuned_path(engine, scenario)) or {}).get("provenance", {})
    except ValueError:
        prov = {}
    if prov:
        v = ", ".join(f"{x:g}" for x in prov.get("velocities_m_s", []))
        text += (f"; mode tuned ({prov.get('parameter_set', '')}), "
                 f"dt = {prov.get('timestep_s', math.nan):g} s, V0 = {v} m/s")
    return text


def figure_index(ctx: ReportContext) -> dict[str, Any]:
    """Every figure of the report folder: this report's plots, the papers', the tuning plots."""
    own = [{"path": f.path, "caption": f.caption} for f in ctx.figures]
    paper, tuning = [], []
    for p in sorted(ctx.fig_dir.glob("*.png")) if ctx.fig_dir.is_dir() else []:
        path = p.relative_to(ctx.out_dir).as_posix()
        if (caption := paper_caption(p.stem)) is not None:
            paper.append({"path": path, "caption": caption})
        elif p.stem.startswith("tune_"):
            engine = p.stem.removeprefix("tune_")
            tuning.append({"path": path, "caption": tuning_caption(engine)})
    def links(figs: list[dict[str, str]]) -> list[str]:
        return [f"[{f['caption']}]({f['path']})" for f in figs]

    return {"own": links(own), "paper": links(paper), "paper_count": len(paper),
            "tuning": [FigureRef(**f) for f in tuning]}


def files(ctx: ReportContext) -> dict[str, Any]:
    meta = ctx.meta
    libs = meta.get("libraries", {})
    return {
        "commit": meta.get("commit", "unknown"), "config": meta.get("config", ""),
        "config_hash": meta.get("config_hash", ""), "python": meta.get("python", ""),
        "platform": meta.get("platform", ""),
        "engines": ", ".join(f"{k} {v}" for k, v in meta.get("engines", {}).items()),
        "libraries": ", ".join(f"{k} {v}" for k, v in libs.items()),
    }


def practical_section(ctx: ReportContext) -> dict[str, Any] | None:
    from impactbench.practical import section

    return section(ctx)


def your_timestep_section(ctx: ReportContext) -> dict[str, Any] | None:
    from impactbench.practical import your_timestep

    return your_timestep(ctx)


# ----------------------------------------------------------------------------- real tosses


def _section_store(ctx: ReportContext) -> Any:
    """The results store of a report's replays (:func:`section_store` of its config and
    store)."""
    return section_store(ctx.cfg, ctx.store)


def section_store(cfg: Any, store: Any = None) -> Any:
    """The results store of a report's replays: the config's ``[execution] store``, else the
    default one (``$IMPACTBENCH_STORE`` or the per-user cache). ``report --store`` does not
    reach a section. Where that is the report's own store file (``store``), the report's
    :class:`~impactbench.report_store.KeepWhatFits` (a full disk is found, and said, once);
    else one of its own."""
    from impactbench.report_store import KeepWhatFits
    from impactbench.store import Store, default_path

    path = (getattr(cfg, "execution", None) or {}).get("store")
    path = Path(path) if path else default_path()
    if store is not None and Path(store.path).resolve() == path.resolve():
        return store
    return KeepWhatFits(Store(path))


def real_tosses(ctx: ReportContext) -> dict[str, Any] | None:
    """"Against real tosses": for each data-driven scenario (a ``measured`` spec)
    whose table the config has (``[cube_toss]``: ``engines``, ``modes``, ``param_sets`` and the
    scenario's fields, ``tosses`` the test split by default), per engine, mode and parameter
    set the tosses' median and quartiles of position and rotation error, their cumulative
    distribution across tosses, and measured against simulated trajectories (height and
    rotation against time) of a best, a median and a worst toss. The replays go through the
    results store (:func:`_section_store`)."""
    parts = []
    for spec in scenarios.specs():
        sm = next((s for s in ctx.cfg.scenarios if s.name == spec.name), None)
        if spec.measured and sm is not None:
            parts.append(spec.report_part(ctx, sm))
    return {"parts": parts} if parts else None


def sections() -> list[Section]:
    """The report in reading order: one section per registered scenario after the
    scoreboard. Insert a :class:`Section` here to add one."""
    return [
        Section("your_timestep", "At your timestep", your_timestep_section),
        Section("scoreboard", "Scoreboard", scoreboard),
        Section("how_to_read", "How to read it", how_to_read),
        *(Section("scenario", spec.title, partial(scenario_section, spec.name))
          for spec in scenarios.specs()),
        Section("real_tosses", "Against real tosses", real_tosses),
        Section("practical", "At practical timesteps", practical_section),
        Section("work_precision", "Work–precision", work_precision),
        Section("meaning", "What this means", meaning),
        Section("contact_models", "Contact models: nominal against effective restitution",
                contact_models),
        Section("failed_runs", "Failed runs", failed_runs),
        Section("parameters", "Physical parameters", parameters),
        Section("figure_index", "Index of figures", figure_index),
        Section("files", "Files and provenance", files),
    ]
