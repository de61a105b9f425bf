"""Report plots (matplotlib, Agg): force–time overlays, restitution against velocity, F–x
hysteresis loops, the relative-error heatmap and the work-precision diagram.

Every function takes the tidy results (a DataFrame) and/or the run histories and writes one PNG,
returning its path. Engines keep one colour everywhere; modes one line style.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

ENGINE_COLORS = {"reference": "black", "mujoco": "tab:blue", "pybullet": "tab:orange",
                 "pymunk": "tab:green", "drake": "tab:red"}
MODE_STYLES = {"native": "--", "injected": "-", "tuned": ":"}
MODE_MARKERS = {"native": "s", "injected": "o", "tuned": "^"}
LABELS = {"restitution": "restitution k", "duration_s": "duration", "peak_force_n": "peak force",
          "max_penetration_m": "max penetration", "energy_loss_fraction": "energy loss",
          "pulse_width_s": "pulse width", "contact_time_s": "contact time",
          "impulse_ns": "impulse", "impacts": "impacts"}

History = Mapping[str, np.ndarray]


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


def force_time(histories: Mapping[tuple[str, str], History], reference: History,
               title: str, path: Path, time_unit: float = 1e-6, unit_label: str = "µs") -> Path:
    """F(t) of the reference and of each (engine, mode), aligned at the contact start."""
    fig, ax = plt.subplots(figsize=(7, 4))
    ref = _aligned(reference)
    if ref is not None:
        ax.plot(ref[0] / time_unit, ref[1], color="black", lw=2.2, alpha=0.6, label="reference")
    for (engine, mode), h in sorted(histories.items()):
        a = _aligned(h)
        if a is None:
            continue
        ax.plot(a[0] / time_unit, a[1], MODE_STYLES.get(mode, "-"),
                color=ENGINE_COLORS.get(engine), lw=1.2, label=f"{engine} {mode}")
    if ref is not None:
        end = (ref[0][ref[1] > 0].max() if np.any(ref[1] > 0) else ref[0][-1]) / time_unit
        ax.set_xlim(-0.05 * end, 1.25 * end)
    ax.set_xlabel(f"time from first contact ({unit_label})")
    ax.set_ylabel("normal force F (N)")
    ax.set_title(title)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def hysteresis(histories: Mapping[tuple[str, str], History], reference: History,
               title: str, path: Path) -> Path:
    """F against penetration x: the loop area is the energy lost in the contact."""
    fig, ax = plt.subplots(figsize=(6, 4))
    if reference:
        m = reference["normal_force_n"] > 0
        ax.plot(reference["penetration_m"][m] * 1e6, reference["normal_force_n"][m],
                color="black", lw=2.2, alpha=0.6, label="reference")
    for (engine, mode), h in sorted(histories.items()):
        if not h:
            continue
        m = h["normal_force_n"] > 0
        ax.plot(h["penetration_m"][m] * 1e6, h["normal_force_n"][m], MODE_STYLES.get(mode, "-"),
                color=ENGINE_COLORS.get(engine), lw=1.1, label=f"{engine} {mode}")
    ax.set_xlabel("penetration x (µm)")
    ax.set_ylabel("normal force F (N)")
    ax.set_title(title)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def restitution_vs_velocity(df: pd.DataFrame, damping_s_per_m: float, path: Path) -> Path:
    """The reference curve k(b·V0) with every engine's measured points."""
    from impactbench.reference.hunt_crossley import restitution

    rows = df[(df.study == "matrix") & (df.scenario == "ball-on-plate")
              & (df.metric == "restitution")]
    vmax = max(float(rows.velocity_m_s.max()) if len(rows) else 5.0, 1.0) * 1.1
    v = np.linspace(0.0, vmax, 300)
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(v, restitution(damping_s_per_m * v), color="black", lw=2, label="Hunt–Crossley k(b·V0)")
    for (engine, mode), g in rows[rows.status == "ok"].groupby(["engine", "mode"]):
        ax.plot(g.velocity_m_s, g.value, MODE_MARKERS.get(mode, "o"), ls="none", ms=6,
                mfc="none" if mode == "native" else ENGINE_COLORS.get(engine),
                color=ENGINE_COLORS.get(engine), label=f"{engine} {mode}")
    ax.set_xlabel("impact velocity V0 (m/s)")
    ax.set_ylabel("restitution k (–)")
    ax.set_title("Restitution against impact velocity (ball on plate)")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def error_heatmap(df: pd.DataFrame, scenario: str, metric_names: tuple[str, ...],
                  path: Path) -> Path:
    """|relative error| per (engine, mode) against (metric, point); failed runs marked."""
    rows = df[(df.study == "matrix") & (df.scenario == scenario)
              & df.metric.isin(metric_names)].copy()
    point = rows.velocity_m_s.map(lambda v: f"{v:g}")
    if scenario == "rigid-flexible":
        point = rows.local.str[:4] + "/" + rows.structure.str[:4] + " " + point
    rows["col"] = rows.metric.map(lambda m: LABELS.get(m, m)) + "\n" + point
    rows["row"] = rows.engine + " " + rows["mode"]
    cols = list(dict.fromkeys(rows.sort_values(["metric", "local", "structure",
                                                "velocity_m_s"]).col))
    index = sorted(rows.row.unique())
    err = rows.pivot_table(index="row", columns="col", values="rel_error",
                           aggfunc="first", dropna=False).reindex(index=index, columns=cols)
    status = rows.pivot_table(index="row", columns="col", values="status",
                              aggfunc="first").reindex(index=index, columns=cols)
    data = np.log10(np.clip(np.abs(err.to_numpy(dtype=float)), 1e-6, 10))
    fig, ax = plt.subplots(figsize=(max(6, 0.42 * len(cols) + 2), 0.45 * len(index) + 2))
    im = ax.imshow(data, cmap="RdYlGn_r", vmin=-4, vmax=0, aspect="auto")
    for i in range(len(index)):
        for j in range(len(cols)):
            s = status.iat[i, j]
            if isinstance(s, str) and s != "ok":
                ax.text(j, i, s[:7], ha="center", va="center", fontsize=5, rotation=90)
    ax.set_xticks(range(len(cols)), cols, rotation=90, fontsize=6)
    ax.set_yticks(range(len(index)), index, fontsize=7)
    cb = fig.colorbar(im, ax=ax)
    cb.set_label("log10 |relative error|")
    ax.set_title(f"Relative error against the reference ({scenario})")
    return _save(fig, path)


def work_precision(df: pd.DataFrame, metric_names: tuple[str, ...], path: Path) -> Path:
    """Error against wall time over timesteps, one curve per engine × mode (log–log)."""
    rows = df[(df.study == "work_precision") & (df.status == "ok")]
    fig, axes = plt.subplots(1, len(metric_names), figsize=(4.2 * len(metric_names), 4))
    for ax, metric in zip(np.atleast_1d(axes), metric_names, strict=True):
        for (engine, mode), g in rows[rows.metric == metric].groupby(["engine", "mode"]):
            g = g.sort_values("timestep_s", ascending=False)
            err = np.abs(g.rel_error.to_numpy(dtype=float))
            ax.loglog(g.wall_s, np.clip(err, 1e-10, None), MODE_STYLES.get(mode, "-"),
                      marker=MODE_MARKERS.get(mode, "o"), ms=4,
                      color=ENGINE_COLORS.get(engine), label=f"{engine} {mode}")
        ax.set_xlabel("wall time per run (s)")
        ax.set_ylabel(f"|relative error| of {LABELS.get(metric, metric)}")
        ax.grid(alpha=0.3, which="both")
    v = rows.velocity_m_s.iloc[0] if len(rows) else math.nan
    fig.suptitle(f"Work–precision, ball on plate at V0 = {v:g} m/s "
                 "(points: timesteps, coarse to fine)")
    np.atleast_1d(axes)[0].legend(fontsize=7)
    return _save(fig, path)


def reference_history_for(scenario) -> dict[str, np.ndarray]:
    """The reference's time history for plotting (thinned like the engines')."""
    from impactbench.evaluate import scenario_name

    if scenario_name(scenario) == "ball-on-plate":
        from impactbench.reference import hunt_crossley

        rec = hunt_crossley.history(scenario)
    else:
        from impactbench.reference import two_dof

        rec = two_dof.simulate(scenario)
    return {"time_s": rec.time_s, "normal_force_n": rec.normal_force_n,
            "penetration_m": rec.penetration_m}
