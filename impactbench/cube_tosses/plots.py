"""The report's figures of the cube tosses (matplotlib, Agg): the errors' cumulative distribution
across tosses, and measured against simulated trajectories of a best, a median and a worst toss.

Each function writes one PNG and returns its path; ``how`` is the subtitle (tosses, protocol,
step). Engines keep the colours of :mod:`impactbench.plots`, modes their line styles.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from impactbench.plots import ENGINE_COLORS, plt

STYLES = {"fitted": "-", "default": "-", "custom": "--", "tuned": ":", "native": "-.",
          "injected": (0, (3, 1, 1, 1, 1, 1))}
"""Line style per mode (colour: per engine, :data:`impactbench.plots.ENGINE_COLORS`)."""


def _save(fig: Any, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _heading(title: str, how: str) -> str:
    return title + ("\n" + "\n".join(textwrap.wrap(how, 110)) if how else "")


CdfRun = tuple[str, str, str, Sequence[Mapping[str, Any]]]
"""(label, engine, mode, per-toss rows with ``position_error`` and ``rotation_error_deg``)."""


def _ok(rows: Sequence[Mapping[str, Any]], key: str) -> np.ndarray:
    x = np.array([float(r[key]) for r in rows if r.get("status", "ok") == "ok"], dtype=float)
    return np.sort(x[np.isfinite(x)])


def error_cdf(runs: Sequence[CdfRun], how: str, path: Path) -> Path:
    """Two panels, position error (fraction of the width) and rotation error (degrees): per
    run the fraction of tosses at or below each error, the median marked."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 5.0))
    for ax, key, label in ((axes[0], "position_error", "time-mean position error / width"),
                           (axes[1], "rotation_error_deg", "time-mean rotation error (deg)")):
        for name, engine, mode, rows in runs:
            x = _ok(rows, key)
            if not x.size:
                continue
            y = np.arange(1, x.size + 1) / x.size
            line, = ax.step(np.r_[x[0], x], np.r_[0.0, y], where="post",
                            color=ENGINE_COLORS.get(engine), linestyle=STYLES.get(mode, ":"),
                            lw=2.0 if engine == "reference" else 1.2, label=name)
            ax.plot([np.median(x)], [0.5], "o", color=line.get_color(), ms=4)
        ax.set_xscale("log")
        ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(label)
        ax.set_ylabel("fraction of tosses")
        ax.set_ylim(0, 1.02)
        ax.axhline(0.5, color="0.8", lw=0.8, zorder=0)
        ax.grid(alpha=0.3, which="both")
    # two compact legends below the panels: the colour is the engine, the style the mode
    from matplotlib.lines import Line2D

    engines = list(dict.fromkeys(r[1] for r in runs))
    modes = list(dict.fromkeys(r[2] for r in runs))
    handles = [Line2D([], [], color=ENGINE_COLORS.get(e), lw=2,
                      label="reference model" if e == "reference" else e) for e in engines]
    styles = [Line2D([], [], color="0.3", linestyle=STYLES.get(m, ":"), label=m)
              for m in modes if m != "fitted"]
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 6), fontsize=8,
               frameon=False, bbox_to_anchor=(0.5, 0.06))
    fig.legend(handles=styles, loc="lower center", ncol=max(len(styles), 1), fontsize=8,
               frameon=False, bbox_to_anchor=(0.5, 0.0))
    fig.suptitle(_heading("Errors across tosses (dots: medians)", how), fontsize=9)
    fig.tight_layout(rect=(0, 0.14, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def trajectories(trajs: Sequence[Mapping[str, Any]], labels: Sequence[str], engine: str,
                 title: str, how: str, path: Path) -> Path:
    """Columns: the tosses of ``trajs`` (:func:`impactbench.cube_tosses.scenario.
    trajectories`; ``labels`` their captions, e.g. best, median, worst); rows: the centre's
    height and the rotation from the start orientation against time, measured (black) and
    simulated (the engine's colour)."""
    n = max(len(trajs), 1)
    fig, axes = plt.subplots(2, n, figsize=(3.6 * n, 5.2), squeeze=False, sharex="col")
    color = ENGINE_COLORS.get(engine, "tab:purple")
    for j, (tr, label) in enumerate(zip(trajs, labels, strict=True)):
        top, bottom = axes[0][j], axes[1][j]
        t = np.asarray(tr["t_s"])
        top.plot(t, 1e3 * np.asarray(tr["z_ref_m"]), color="black", lw=1.2, label="measured")
        top.plot(t, 1e3 * np.asarray(tr["z_sim_m"]), color=color, lw=1.2, label=engine)
        bottom.plot(t, tr["angle_ref_deg"], color="black", lw=1.2)
        bottom.plot(t, tr["angle_sim_deg"], color=color, lw=1.2)
        top.set_title(f"{label}: toss {tr['toss']}", fontsize=9)
        bottom.set_xlabel("time from the replay's start (s)")
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("centre height (mm)")
    axes[1][0].set_ylabel("rotation from start (deg)")
    axes[0][0].legend(fontsize=7)
    fig.suptitle(_heading(title, how), fontsize=9)
    return _save(fig, path)
