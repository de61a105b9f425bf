"""Report plots (matplotlib, Agg): force–time overlays, restitution against velocity, F–x
hysteresis loops, the relative-error heatmap and the work-precision diagram.

Every function takes the tidy results (a DataFrame) and/or the run histories and writes one PNG,
returning its path. ``how`` is the subtitle every plot carries: modes, timesteps and velocities.
Engines keep one colour everywhere; modes one line style.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.colors import LogNorm

from impactbench import report_render
from impactbench.engines.registry import engine_names, fallback_color, spec

REFERENCE_COLOR = "black"
"""The reference's colour in every figure."""


def engine_color(engine: str) -> str:
    """The colour of ``engine`` in every figure: its spec's
    (:attr:`~impactbench.engines.registry.EngineSpec.plot_color`: its own, or a deterministic
    fallback for a plug-in that sets none); the same fallback for a name no longer registered
    (rows in an old store); :data:`REFERENCE_COLOR` for ``reference``."""
    if engine == "reference":
        return REFERENCE_COLOR
    try:
        return spec(engine).plot_color
    except ValueError:
        return fallback_color(engine)


class _EngineColors(Mapping[str, str]):
    """``reference`` and every registered engine → its colour (:func:`engine_color`), in the
    registry's order; any other name maps to its fallback colour."""

    def __getitem__(self, engine: str) -> str:
        return engine_color(engine)

    def __iter__(self) -> Iterator[str]:
        return iter(("reference", *engine_names()))

    def __len__(self) -> int:
        return 1 + len(engine_names())


ENGINE_COLORS: Mapping[str, str] = _EngineColors()
"""One colour per engine in every figure, read from the engines' specs (kept as a mapping for
the modules that index it: ``ENGINE_COLORS.get(engine)``, iteration in the registry's order)."""
MODE_STYLES = {"native": "--", "injected": "-", "tuned": ":", "default": "-.",
               "custom": (0, (5, 1, 1, 1))}
MODE_MARKERS = {"native": "s", "injected": "o", "tuned": "^", "default": "D", "custom": "v"}
LABELS = {"restitution": "restitution k", "duration_s": "duration", "peak_force_n": "peak force",
          "max_penetration_m": "max penetration", "energy_loss_fraction": "energy loss",
          "pulse_width_s": "pulse width", "contact_time_s": "contact time",
          "impulse_ns": "impulse", "impacts": "impacts", "rebound_angle_deg": "rebound angle",
          "spin_out_rad_s": "spin after", "tangential_restitution": "tangential restitution",
          "contact_point_ratio": "contact-point ratio β",
          "peak_tangential_force_n": "peak friction force"}
MODE_ORDER = ("native", "injected", "tuned", "default", "custom")
BAND_LINES = (0.01, 0.05)
"""The report's error bands (1 %, 5 %), marked on the heatmap's colour bar."""
ROUND_OFF = report_render.ROUND_OFF
"""Relative errors below this are round-off (the tables print 0): the heatmap's colour scale
starts no lower."""

History = Mapping[str, np.ndarray]


def _order(engine: str, mode: str) -> tuple:
    """Legend order: engines in the registry's order, modes as in :data:`MODE_ORDER`."""
    engines = list(ENGINE_COLORS)
    return (engines.index(engine) if engine in engines else 99, engine,
            MODE_ORDER.index(mode) if mode in MODE_ORDER else 99, mode)


def _title(ax, title: str, how: str) -> None:
    """Title plus a smaller wrapped line saying modes, timesteps and velocities."""
    sub = "\n".join(textwrap.wrap(how, 95))
    ax.set_title(f"{title}\n{sub}" if sub else title, fontsize=9)


def _aligned(h: History) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(t − first contact start, F, x) of a history, or None if it has no contact."""
    if not h or not np.any(h["normal_force_n"] > 0):
        return None
    f = h["normal_force_n"]
    i = int(np.argmax(f > 0))
    t0 = h["time_s"][max(i - 1, 0)]
    return h["time_s"] - t0, f, h["penetration_m"]


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def contact_span(curves: list[tuple[np.ndarray, np.ndarray]]) -> float:
    """The latest time any curve still carries force (aligned time, s); 0 without contact."""
    ends = [float(t[f > 0].max()) for t, f in curves if np.any(f > 0)]
    return max(ends, default=0.0)


def force_time(histories: Mapping[tuple[str, str], History], reference: History,
               title: str, how: str, path: Path, time_unit: float = 1e-6,
               unit_label: str = "µs") -> Path:
    """F(t) of the reference and of each (engine, mode), aligned at the contact start.

    The time axis spans every curve up to its last sample with force (not only the
    reference's contact), so a longer engine contact is shown whole."""
    fig, ax = plt.subplots(figsize=(7, 4.2))
    curves = []
    ref = _aligned(reference)
    if ref is not None:
        ax.plot(ref[0] / time_unit, ref[1], color="black", lw=2.2, alpha=0.6, label="reference")
        curves.append(ref[:2])
    for (engine, mode), h in sorted(histories.items(), key=lambda kv: _order(*kv[0])):
        a = _aligned(h)
        if a is None:
            continue
        ax.plot(a[0] / time_unit, a[1], linestyle=MODE_STYLES.get(mode, "-"),
                color=engine_color(engine), lw=1.2, label=f"{engine} {mode}")
        curves.append(a[:2])
    end = contact_span(curves) / time_unit
    if end > 0:
        ax.set_xlim(-0.03 * end, 1.06 * end)
    ax.set_xlabel(f"time from first contact ({unit_label})")
    ax.set_ylabel("normal force F (N)")
    _title(ax, f"Force against time, {title}", how)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def hysteresis(histories: Mapping[tuple[str, str], History], reference: History,
               title: str, how: str, path: Path) -> Path:
    """F against penetration x: the loop area is the energy lost in the contact."""
    fig, ax = plt.subplots(figsize=(7, 4.2))
    if reference:
        m = reference["normal_force_n"] > 0
        ax.plot(reference["penetration_m"][m] * 1e6, reference["normal_force_n"][m],
                color="black", lw=2.2, alpha=0.6, label="reference")
    for (engine, mode), h in sorted(histories.items(), key=lambda kv: _order(*kv[0])):
        if not h:
            continue
        m = h["normal_force_n"] > 0
        ax.plot(h["penetration_m"][m] * 1e6, h["normal_force_n"][m],
                linestyle=MODE_STYLES.get(mode, "-"), color=engine_color(engine), lw=1.1,
                label=f"{engine} {mode}")
    ax.set_xlabel("penetration x (µm)")
    ax.set_ylabel("normal force F (N)")
    _title(ax, f"Force against penetration, {title}", how)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def restitution_vs_velocity(df: pd.DataFrame, damping_s_per_m: float, how: str,
                            path: Path, scenario: Any) -> Path:
    """The reference curve k(b·V0) with every engine's measured points of ``scenario``'s
    rows (a BallOnPlate). When its contact model is set from a nominal restitution, that
    model's exact curve instead (:func:`impactbench.reference.zoo.sweep`)."""
    from impactbench.reference.hunt_crossley import restitution

    rows = df[(df.study == "matrix") & (df.scenario == scenario.name)
              & (df.metric == "restitution")]
    vmax = max(float(rows.velocity_m_s.max()) if len(rows) else 5.0, 1.0) * 1.1
    v = np.linspace(0.0, vmax, 300)
    fig, ax = plt.subplots(figsize=(7, 4.2))
    if scenario.nominal_restitution is not None:
        from impactbench.reference.zoo import sweep

        ax.plot(v[1:], sweep(scenario, v[1:])["restitution"], color="black", lw=2,
                label=f"{scenario.model}, nominal e = {scenario.nominal_restitution:g}")
    else:
        ax.plot(v, restitution(damping_s_per_m * v), color="black", lw=2,
                label="Hunt–Crossley k(b·V0)")
    for (engine, mode), g in rows[rows.status == "ok"].groupby(["engine", "mode"]):
        ax.plot(g.velocity_m_s, g.value, MODE_MARKERS.get(mode, "o"), ls="none", ms=6,
                mfc="none" if mode == "native" else engine_color(engine),
                color=engine_color(engine), label=f"{engine} {mode}")
    lo, hi = ax.get_ylim()
    if hi - lo < 0.1:  # a flat curve (a model set from a nominal e): no 1e-6 zoom
        mid = 0.5 * (lo + hi)
        ax.set_ylim(max(0.0, mid - 0.05), min(1.05, mid + 0.05))
    ax.set_xlabel("impact velocity V0 (m/s)")
    ax.set_ylabel("restitution k (–)")
    _title(ax, "Restitution against impact velocity, ball on plate", how)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def _point_label(row, spec) -> str:
    """A heatmap column's label: the categorical axes, one per line, then the numbers."""
    parts = [str(getattr(row, a.name)) for a in spec.axes if a.categorical]
    for a in spec.axes:
        if not a.categorical:
            unit = a.column.partition(" (")[2].rstrip(")")
            parts.append(f"{getattr(row, a.name):g}" + (f" {unit}" if unit not in ("", "°")
                                                         else unit))
    return "\n".join(parts)


def _error_text(err: float) -> str:
    """A heatmap cell's signed error: the tables' number (:func:`report_render.format_error`),
    without the space."""
    return report_render.format_error(err).replace(" ", "")


def error_heatmap(df: pd.DataFrame, spec: Any, how: str, path: Path) -> Path:
    """|relative error| per (engine, mode) row and scenario point column, one panel per
    metric; each cell annotated with the signed error (or the run's status). The colour scale
    is logarithmic over the true range of the nonzero errors shown (exact zeros take its
    lowest colour), with the 1 % and 5 % bands marked on the colour bar. ``spec``: the
    scenario's :class:`~impactbench.scenarios.ScenarioSpec` (its headline metrics and axes)."""
    metric_names = spec.headline
    rows = df[(df.study == "matrix") & (df.scenario == spec.name)
              & df.metric.isin(metric_names)].copy()
    rows["col"] = [_point_label(r, spec) for r in rows.itertuples()]
    rows["row"] = rows.engine + " " + rows["mode"]
    order = rows.sort_values(list(spec.axis_names))
    cols = list(dict.fromkeys(order.col))
    index = sorted(rows.row.unique(), key=lambda r: _order(*r.split(" ", 1)))
    err = np.abs(pd.to_numeric(rows.rel_error, errors="coerce").to_numpy(dtype=float))
    finite = err[np.isfinite(err) & (err > 0) & (rows.status == "ok").to_numpy()]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (1e-3, 1e-1)
    floored = lo < ROUND_OFF
    lo = max(lo, ROUND_OFF)
    if hi <= lo * 1.0001:
        lo, hi = lo / 3, max(hi, lo) * 3
    norm = LogNorm(vmin=lo, vmax=hi)
    cmap = plt.get_cmap("RdYlGn_r").with_extremes(bad="#e6e6e6")
    n_rows, n_cols = len(index), len(cols)
    heights = [0.28 * n_rows + 0.45] * len(metric_names)
    label_h = 0.25 * min(len(spec.axes), 2)
    fig_w = max(7.5, 0.8 * n_cols + 3.4)
    fig_h = sum(heights) + label_h * len(metric_names) + 0.9
    fig, axes = plt.subplots(len(metric_names), 1, figsize=(fig_w, fig_h), squeeze=False,
                             gridspec_kw={"height_ratios": heights}, layout="constrained")
    im = None
    for ax, metric in zip(axes[:, 0], metric_names, strict=True):
        m = rows[rows.metric == metric]
        e = m.pivot_table(index="row", columns="col", values="rel_error", aggfunc="first",
                          dropna=False).reindex(index=index, columns=cols)
        st = m.pivot_table(index="row", columns="col", values="status",
                           aggfunc="first").reindex(index=index, columns=cols)
        signed = e.to_numpy(dtype=float)
        data = np.where(np.isfinite(signed), np.maximum(np.abs(signed), lo), np.nan)
        im = ax.imshow(np.ma.masked_invalid(data), cmap=cmap, norm=norm, aspect="auto")
        for i in range(n_rows):
            for j in range(n_cols):
                s, v = st.iat[i, j], signed[i, j]
                if not isinstance(s, str):
                    text, color = "", "black"
                elif s != "ok":
                    text, color = s[:11], "#6a1b9a"
                elif not math.isfinite(v):
                    text, color = "n/a", "#555555"
                else:
                    text = _error_text(v)
                    color = "black"
                ax.text(j, i, text, ha="center", va="center", fontsize=6.5, color=color)
        ax.set_xticks(range(n_cols), cols, fontsize=7)
        ax.set_yticks(range(n_rows), index, fontsize=7.5)
        ax.set_title(f"{LABELS.get(metric, metric)}", fontsize=9, loc="left")
        ax.tick_params(length=0)
    cb = fig.colorbar(im, ax=axes[:, 0].tolist(), fraction=0.03, pad=0.01,
                      extend="min" if floored else "neither")
    cb.set_label("|relative error| (log scale over the values shown"
                 + (f"; below {ROUND_OFF:g}: round-off)" if floored else ")"), fontsize=8)
    for bound in BAND_LINES:
        if lo < bound < hi:
            cb.ax.axhline(bound, color="black", lw=1.2)
            cb.ax.text(-0.15, bound, f"{100 * bound:g} %", fontsize=7, va="center", ha="right",
                       transform=cb.ax.get_yaxis_transform())
    fig.suptitle(f"Relative error against the reference, {spec.name}\n"
                 + "\n".join(textwrap.wrap(how, 110)), fontsize=9)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


FAILED_ERROR = 10.0
"""Where a failed run (or an unresolved metric) is drawn on a work–precision panel: at
|error| = 1000 %, above every measured point, marked × (failed) or ▽ (not resolved)."""


def work_precision(df: pd.DataFrame, metric_names: tuple[str, ...], how: str,
                   path: Path, *, panels: tuple[tuple[str, str], ...] = (
                       ("velocity_m_s", "V0 = {:g} m/s"),),
                   title: str = "ball on plate") -> Path:
    """Error against wall time over timesteps, one curve per engine × mode (log–log), one row
    of panels per point (``panels``: (column, label format) of the point's axes; the ball's
    impact velocity by default). Failed runs are drawn as × at |error| = 1000 % (listed in
    the report's failed runs), unresolved metrics as ▽ there: nothing is dropped."""
    rows = df[df.study == "work_precision"]
    cols = [c for c, _ in panels]
    points = sorted({tuple(r) for r in rows[cols].itertuples(index=False)}) or [
        (math.nan,) * len(cols)]
    fig, axes = plt.subplots(len(points), len(metric_names),
                             figsize=(4.2 * len(metric_names), 3.8 * len(points)),
                             squeeze=False)
    resolved = rows.resolved.astype(bool) if "resolved" in rows else rows.status == rows.status
    for r, point in enumerate(points):
        at_v = rows[np.logical_and.reduce([rows[c] == x for c, x in zip(cols, point,
                                                                           strict=True)])]
        label = ", ".join(fmt.format(x) for (_, fmt), x in zip(panels, point, strict=True))
        for ax, metric in zip(axes[r], metric_names, strict=True):
            m = at_v[at_v.metric == metric]
            for (engine, mode), g in m.groupby(["engine", "mode"]):
                g = g.sort_values("timestep_s", ascending=False)
                color = engine_color(engine)
                good = (g.status == "ok") & resolved[g.index]
                ok = g[good]
                err = np.abs(ok.rel_error.to_numpy(dtype=float))
                ax.loglog(ok.wall_s, np.clip(err, 1e-10, None),
                          linestyle=MODE_STYLES.get(mode, "-"),
                          marker=MODE_MARKERS.get(mode, "o"), ms=4, color=color,
                          label=f"{engine} {mode}")
                for sub, marker in ((g[g.status != "ok"], "x"),
                                    (g[(g.status == "ok") & ~good], "v")):
                    if len(sub):
                        wall = sub.wall_s.to_numpy(dtype=float)
                        wall = np.where(np.isfinite(wall) & (wall > 0), wall, 1e-4)
                        ax.loglog(wall, np.full(wall.size, FAILED_ERROR), marker, ms=6,
                                  mfc="none", color=color, ls="none")
            ax.axhline(FAILED_ERROR, color="grey", lw=0.5, ls=":")
            ax.set_xlabel("wall time per run (s)")
            ax.set_ylabel(f"|relative error| of {LABELS.get(metric, metric)}")
            ax.set_title(label, fontsize=9)
            ax.grid(alpha=0.3, which="both")
    fig.suptitle(f"Work–precision, {title} (points: timesteps, coarse to fine; × failed, "
                 "▽ not resolved, both drawn at 1000 %)\n" + how, fontsize=9)
    axes[0][0].legend(fontsize=7)
    return _save(fig, path)


def reference_history_for(scenario) -> dict[str, np.ndarray]:
    """The reference's time history for plotting (thinned like the engines')."""
    from impactbench.scenarios import spec_of

    rec = spec_of(scenario).history(scenario)
    return {"time_s": rec.time_s, "normal_force_n": rec.normal_force_n,
            "penetration_m": rec.penetration_m}


def advice_figure(advice: Any, path: str | Path) -> Path:
    """The advisor's trade-off: every candidate's worst restitution error (over speeds and
    phases, whatever its plausibility) against the contact's deepest sinking beyond the
    step's own overlap (over the radius), one colour per contact model; hollow: implausible;
    the star: the advice. The dotted line is the plausibility limit (0.1 R)."""
    from impactbench.plausibility import DEFAULT

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    names = list(dict.fromkeys(t.model for t in advice.tried))
    cmap = plt.get_cmap("tab10")
    for i, name in enumerate(names):
        for ok in (True, False):
            pts = [(max(t.max_sinking, 1e-6), t.worst_error) for t in advice.tried
                   if t.model == name and t.plausible == ok and math.isfinite(t.worst_error)
                   and math.isfinite(t.max_sinking)]
            if pts:
                x, y = zip(*pts, strict=True)
                ax.scatter(x, y, s=14, label=name if ok else None,
                           facecolors=cmap(i % 10) if ok else "none", edgecolors=cmap(i % 10))
    sink = max((r["sinking_ratio"] for r in advice.per_speed
                if math.isfinite(r["sinking_ratio"])), default=0.0)
    ax.scatter([max(sink, 1e-6)], [advice.worst_error], marker="*", s=160, c="black",
               label="advice", zorder=5)
    ax.axvline(DEFAULT.max_penetration_ratio, ls=":", c="grey")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("contact sinking beyond the step's overlap / R (worst phase; 1e-6: none)")
    ax.set_ylabel("worst |restitution error| over speeds and phases")
    ax.set_title(f"{advice.engine} at {advice.timestep_s:.4g} s: {len(advice.tried)} "
                 "candidates (hollow: implausible)", fontsize=10)
    ax.legend(fontsize=8)
    return _save(fig, Path(path))
