"""Zhou & Xiao's Figs. 3–18 (rigid body hitting a constrained flexible body) and the report
``reports/rigid_flexible.md`` that checks the paper's stated regularities with our numbers.

Figures (``rf_figNN_….png``): for each swept parameter (v1, k1, k2, m2) a force-history figure
F1(t) at the paper's three values, then peak force, pulse width and impulse against the
parameter, for the 3 local × 2 structural laws. Sweeps use the paper's full grids and the
reference solver (:func:`impactbench.reference.two_dof.sweep`); points whose structure collapsed are
left
out of the curves (and counted in the report). The paper does not state v1 for the k1, k2 and
m2 sweeps; :data:`SWEEP_VELOCITY_M_S` = 30 m/s reproduces its stiff/heavy-body percentages
(see the report).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from impactbench.reference import two_dof
from impactbench.reference.scenarios import RigidFlexible

SWEEP_VELOCITY_M_S = 30.0
LOCALS = ("linear", "elastoplastic", "mutation")
STRUCTURES = ("linear", "softening")
COLORS = {"linear": "tab:blue", "elastoplastic": "tab:red", "mutation": "tab:green"}

# (figure number of the history, swept name, field, grid start/stop/step, history values,
#  axis label, axis scale for the label)
SWEEPS: tuple[tuple[int, str, str, tuple[float, float, float], tuple[float, ...], str, float],
              ...] = (
    (3, "velocity", "velocity_m_s", (0.1, 1000.0, 0.1), (2.0, 10.0, 300.0), "v1 (m/s)", 1.0),
    (7, "k1", "k1_n_per_m", (100.0, 1e6, 100.0), (1e3, 1e4, 5e5), "k1 (kN/m)", 1e-3),
    (11, "k2", "k2_n_per_m", (100.0, 1e6, 100.0), (1e3, 2e4, 5e5), "k2 (kN/m)", 1e-3),
    (15, "m2", "m2_kg", (0.1, 1000.0, 0.1), (3.0, 10.0, 500.0), "m2 (kg)", 1.0),
)
METRICS = (("peak_force_n", "peak force (kN)", 1e-3), ("pulse_width_s", "pulse width (ms)", 1e3),
           ("impulse_ns", "impulse (N·s)", 1.0))


def _base(over: str) -> RigidFlexible:
    return RigidFlexible() if over == "velocity" else RigidFlexible(
        velocity_m_s=SWEEP_VELOCITY_M_S)


def _grid(start: float, stop: float, step: float) -> np.ndarray:
    return start + step * np.arange(round((stop - start) / step) + 1)


def sweeps() -> dict[str, pd.DataFrame]:
    """The four paper sweeps over all law combinations (full grids)."""
    return {over: two_dof.sweep(_base(over), over, _grid(*g))
            for _, over, _, g, *_ in SWEEPS}


def _history_figure(path: Path, num: int, over: str, field: str, values: tuple[float, ...],
                    label: str, scale: float) -> None:
    fig, axes = plt.subplots(len(values), 2, figsize=(10, 2.6 * len(values)), squeeze=False)
    for i, value in enumerate(values):
        for j, structure in enumerate(STRUCTURES):
            ax = axes[i, j]
            for local in LOCALS:
                sc = two_dof.with_parameter(_base(over), over, value).replace(
                    local=local, structure=structure)
                rec = two_dof.simulate(sc)
                tag = "" if rec.ok else f" [{rec.status}]"
                ax.plot(rec.time_s * 1e3, rec.normal_force_n * 1e-3, color=COLORS[local],
                        lw=1, label=local + tag)
            ax.set_title(f"{label.split(' ')[0]} = {value * scale:g}, {structure} structure",
                         fontsize=9)
            ax.set_xlabel("t (ms)")
            ax.set_ylabel("F1 (kN)")
            ax.legend(fontsize=7)
            ax.grid(alpha=0.3)
    fig.suptitle(f"Fig. {num}: local impact force histories ({over})")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _metric_figure(path: Path, num: int, df: pd.DataFrame, field: str, metric: str,
                   ylabel: str, yscale: float, label: str, xscale: float) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.4), sharey=False)
    for ax, structure in zip(axes, STRUCTURES, strict=True):
        for local in LOCALS:
            d = df[(df.local == local) & (df.structure == structure)]
            y = np.where(d.status == "ok", d[metric], np.nan)
            ax.plot(d[field] * xscale, y * yscale, color=COLORS[local], lw=1, label=local)
        collapsed = df[(df.structure == structure) & (df.status != "ok")]
        if len(collapsed):
            ax.text(0.02, 0.95, f"{len(collapsed)} points not ok (collapse) omitted",
                    transform=ax.transAxes, fontsize=7, va="top")
        ax.set_xscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel(ylabel)
        ax.set_title(f"{structure} structure", fontsize=9)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.suptitle(f"Fig. {num}: {ylabel} against {label}")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def write(out_dir: Path, report: Path | None = None) -> list[Path]:
    """Write rf_fig03 … rf_fig18 into ``out_dir`` and the report (default:
    ``out_dir/../rigid_flexible.md``); return the PNG paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    data = sweeps()
    paths: list[Path] = []
    for num, over, field, _, values, label, scale in SWEEPS:
        p = out_dir / f"rf_fig{num:02d}_history_{over}.png"
        _history_figure(p, num, over, field, values, label, scale)
        paths.append(p)
        for k, (metric, ylabel, yscale) in enumerate(METRICS, start=1):
            p = out_dir / f"rf_fig{num + k:02d}_{metric.rsplit('_', 1)[0]}_{over}.png"
            _metric_figure(p, num + k, data[over], field, metric, ylabel, yscale, label, scale)
            paths.append(p)
    write_report(report or out_dir.parent / "rigid_flexible.md", data, paths)
    return paths


def combo(df: pd.DataFrame, local: str, structure: str) -> pd.DataFrame:
    return df[(df.local == local) & (df.structure == structure)]


def at(df: pd.DataFrame, field: str, value: float, local: str, structure: str) -> Any:
    d = combo(df, local, structure)
    return d.iloc[int(np.argmin(np.abs(d[field].to_numpy() - value)))]


def _pct(a: float, b: float) -> str:
    return f"{100.0 * (a / b - 1.0):+.1f} %"


def _verdict(ok: bool) -> str:
    return "**holds**" if ok else "**does not hold**"


def write_report(path: Path, data: dict[str, pd.DataFrame], figures: list[Path]) -> None:
    """The paper's regularities (MODELS.md §2), each stated with our numbers and a verdict."""
    v = data["velocity"]
    lines = ["# Rigid body hitting a constrained flexible body — the paper's regularities",
             "",
             "Generated by `impactbench figures` (`impactbench/figures/rigid_flexible.py`) from "
             "the reference solver `impactbench.reference.two_dof` (event-driven, exact event "
             "times) on the "
             "paper's full grids: v1 0.1…1000 m/s step 0.1; k1 and k2 0.1…1000 kN/m step "
             "0.1 kN/m; m2 0.1…1000 kg step 0.1 kg; 3 local × 2 structural laws, base "
             "parameters elsewhere (MODELS.md §2). Figures: "
             + ", ".join(f"`{p.name}`" for p in figures) + ".",
             "",
             f"The paper does not state v1 for the k1, k2 and m2 sweeps; we use "
             f"{SWEEP_VELOCITY_M_S:g} m/s, the value at which our stiff/heavy-body-2 "
             "percentages (regularity 4) come closest to the paper's. The stiffness-mutation "
             "law is our reading of the illegible eq. 5 (an irreversible drop k1 → k1' when F1 "
             "first reaches F_m).",
             ""]
    # collapse extent
    lines += ["## Collapse of the softening structure", ""]
    for local in LOCALS:
        d = combo(v, local, "softening")
        bad = d[d.status != "ok"]
        first = bad["velocity_m_s"].min() if len(bad) else float("nan")
        lines.append(f"- {local} / softening: status `structure_collapsed` at {len(bad)} of "
                     f"{len(d)} velocities, from v1 = {first:g} m/s up (body 2's energy passes "
                     "k2²/(4β) = 833 J).")
    lines += ["", "The paper plots softening curves over the whole range and says nothing of "
              "collapse; with β = 3 MN/m³ the structure's potential peaks at 833 J, which a "
              "10 kg body at ≳ 13 m/s can exceed. Our curves omit collapsed points.", ""]

    # 1. growth with v1, pulse width tends to a constant
    lines += ["## 1. Peak and impulse grow with v1; pulse width tends to a constant", "",
              "| local / structure | peak 1→10→100→1000 m/s (kN) | impulse (N·s) | pulse width "
              "(ms) | pulse-width change over the last decade of ok points |",
              "|---|---|---|---|---|"]
    grow_ok, const_ok = True, True
    drops: list[str] = []
    for local in LOCALS:
        for structure in STRUCTURES:
            d = combo(v, local, structure)
            d = d[d.status == "ok"]
            pts = [x for x in (1.0, 10.0, 100.0, 1000.0) if x <= d.velocity_m_s.max() + 1e-9]
            rows = [at(d, "velocity_m_s", x, local, structure) for x in pts]
            peak = " → ".join(f"{r.peak_force_n / 1e3:.4g}" for r in rows)
            imp = " → ".join(f"{r.impulse_ns:.4g}" for r in rows)
            pw = " → ".join(f"{r.pulse_width_s * 1e3:.4g}" for r in rows)
            for metric in ("peak_force_n", "impulse_ns"):
                y = d[metric].to_numpy()
                drop = np.diff(y) / y[1:]
                bad = np.flatnonzero(drop < -1e-9)
                if bad.size:
                    grow_ok = False
                    i = int(bad[np.argmin(drop[bad])])
                    drops.append(f"{local} / {structure}: {metric} falls at {bad.size} steps, "
                                 f"worst {100 * drop[i]:.2f} % at v1 = "
                                 f"{d.velocity_m_s.iloc[i + 1]:g} m/s")
            top = d.velocity_m_s.max()
            last = d[d.velocity_m_s >= top / 10]
            change = last.pulse_width_s.max() / last.pulse_width_s.min() - 1.0
            if structure == "linear":
                const_ok &= change < 0.05
            lines.append(f"| {local} / {structure} | {peak} | {imp} | {pw} | "
                         f"{100 * change:.2f} % (v1 {top / 10:g}…{top:g}) |")
    lines += ["", f"Peak and impulse never decrease with v1 on any ok point: "
              f"{_verdict(grow_ok)}" + (" — " + "; ".join(drops) + " (just below collapse, "
                                        "where body 2 runs far out and the second impact "
                                        "changes)" if drops else "")
              + ". Pulse width settles (< 5 % over the last decade) for the "
              f"linear structure: {_verdict(const_ok)}. For the softening structure the sweep "
              "ends at collapse, so there is no high-velocity plateau to speak of.", ""]

    # 2. yielding / failure: repeated impacts, wider pulses
    ll = combo(v, "linear", "linear").set_index("velocity_m_s")
    lines += ["## 2. Yielding or failure cause repeated impacts and wider pulses", ""]
    widest = {}
    for local in ("elastoplastic", "mutation"):
        d = combo(v, local, "linear").set_index("velocity_m_s")
        ratio = d.pulse_width_s / ll.pulse_width_s
        widest[local] = (ratio.max(), ratio.idxmax())
        lines.append(f"- {local} / linear: impacts up to {int(d.impacts.max())} "
                     f"(linear/linear: {int(ll.impacts.max())}); pulse width up to "
                     f"{_pct(ratio.max(), 1.0)} against linear/linear (at v1 = "
                     f"{ratio.idxmax():g} m/s).")
    lines += ["", f"Paper: up to +130…140 % for the linear structure. Ours: "
              f"{100 * (widest['elastoplastic'][0] - 1):.0f} % (elastoplastic) and "
              f"{100 * (widest['mutation'][0] - 1):.0f} % (mutation). Wider pulses: "
              f"{_verdict(max(w[0] for w in widest.values()) > 1.0)}; the paper's magnitude "
              + ("agrees." if 1.25 <= max(w[0] for w in widest.values()) - 1 <= 1.5
                 else "differs (see the numbers)."), ""]
    ep = combo(v, "elastoplastic", "linear")
    more = int((ep.impacts.to_numpy() > ll.impacts.to_numpy()).sum())
    lines += [f"Repeated impacts caused by yielding (more impacts than linear/linear): "
              f"{more} of {len(ep)} velocities; linear/linear itself already has "
              f"{int(ll.impacts.max())} impacts with the base parameters (m1 = m2, k1 = k2: "
              "body 2 comes back and hits body 1 once more).", ""]

    # 3. softening lowers the peak, can cut impacts and the pulse width
    lines += ["## 3. Structural softening lowers the peak and can cut the number of impacts", ""]
    all_lower = True
    for local in LOCALS:
        lin = combo(v, local, "linear").set_index("velocity_m_s")
        sof = combo(v, local, "softening").set_index("velocity_m_s")
        ok = sof.status == "ok"
        dp = (sof.peak_force_n[ok] / lin.peak_force_n[ok] - 1.0)
        dw = (sof.pulse_width_s[ok] / lin.pulse_width_s[ok] - 1.0)
        fewer = int((sof.impacts[ok] < lin.impacts[ok]).sum())
        more_i = int((sof.impacts[ok] > lin.impacts[ok]).sum())
        all_lower &= bool((dp <= 1e-12).all())
        lines.append(f"- {local}: softening changes the peak by {100 * dp.min():+.2f} … "
                     f"{100 * dp.max():+.2f} % (ok points); fewer impacts at {fewer}, more at "
                     f"{more_i} velocities; pulse width {100 * dw.min():+.1f} … "
                     f"{100 * dw.max():+.1f} %.")
    lines += ["", f"Softening never raises the peak: {_verdict(all_lower)}. With the base "
              "parameters the peak occurs in the first impact, before body 2 has moved far "
              "enough for the cubic term to matter, so softening changes the peak by well under "
              "1 % either way. On the v1 sweep softening never cuts the number of impacts and "
              "never narrows the pulse: it widens it (up to the values above), the opposite of "
              "the paper's 'pulse width down by up to 70–80 %'. We do not reproduce that claim "
              "with the stated parameters.", ""]

    # 4. stiff / heavy body 2: the local law alone matters
    lines += ["## 4. Very stiff or very heavy body 2: only the local law matters", "",
              f"v1 = {SWEEP_VELOCITY_M_S:g} m/s. Change against the linear local law:", "",
              "| end of sweep | law | peak | pulse width | impulse | paper (peak, width, "
              "impulse) | structure-law effect on peak |", "|---|---|---|---|---|---|---|"]
    paper = {("k2", "elastoplastic"): "−50.9 %, +35.1 %, −25.5 %",
             ("k2", "mutation"): "−31.0 %, +40.9 %, −1.3 %",
             ("m2", "elastoplastic"): "−51.1 %, +35.3 %, −25.5 %",
             ("m2", "mutation"): "−31.1 %, +41.2 %, −1.3 %"}
    holds4 = True
    failed4: list[str] = []
    for over, field, value in (("k2", "k2_n_per_m", 1e6), ("m2", "m2_kg", 1000.0)):
        df = data[over]
        lin = at(df, field, value, "linear", "linear")
        for local in ("elastoplastic", "mutation"):
            r = at(df, field, value, local, "linear")
            s_ = at(df, field, value, local, "softening")
            struct = abs(s_.peak_force_n / r.peak_force_n - 1.0)
            checks = {"peak lower": r.peak_force_n < lin.peak_force_n,
                      "pulse wider": r.pulse_width_s > lin.pulse_width_s,
                      "impulse lower": r.impulse_ns < lin.impulse_ns,
                      "structure law < 2 % on peak": struct < 0.02}
            for name, good in checks.items():
                if not good:
                    holds4 = False
                    failed4.append(f"{local} at {over} = {value:g}: not {name}")
            lines.append(f"| {over} = {value:g} | {local} | "
                         f"{_pct(r.peak_force_n, lin.peak_force_n)} | "
                         f"{_pct(r.pulse_width_s, lin.pulse_width_s)} | "
                         f"{_pct(r.impulse_ns, lin.impulse_ns)} | {paper[(over, local)]} | "
                         f"{100 * struct:.2f} % |")
    lines += ["", f"Elastoplastic and mutation lower the peak, widen the pulse and lower the "
              f"impulse, and the structural law barely matters: {_verdict(holds4)}"
              + (" (" + "; ".join(failed4) + ")" if failed4 else "") + ". "
              "The elastoplastic numbers match the paper's to about a percentage point. For "
              "the mutation law our impulse is lowered by only ~0.0 % (the drop releases "
              "½(k1 − k1')·(F_m/k1)² = 2.5 J of 4500 J) against the paper's 1.3 %, and our peak "
              "by 29.3 % (→ 1 − √(k1'/k1) on a rigid wall) against 31 %: our reading of the "
              "illegible eq. 5 is close but probably not identical to the paper's.", ""]

    # k1 sweep: peak grows with k1, pulse width and impulse tend to constants
    k1 = data["k1"]
    lines += ["## k1 sweep: the peak grows with k1; pulse width and impulse level off", ""]
    for local in LOCALS:
        d = combo(k1, local, "linear")
        a, b = at(d, "k1_n_per_m", 1e5, local, "linear"), at(d, "k1_n_per_m", 1e6, local,
                                                            "linear")
        lo = at(d, "k1_n_per_m", 1e3, local, "linear")
        lines.append(f"- {local} / linear: peak {lo.peak_force_n / 1e3:.4g} → "
                     f"{a.peak_force_n / 1e3:.4g} → {b.peak_force_n / 1e3:.4g} kN at k1 = 1, "
                     f"100, 1000 kN/m; pulse width {lo.pulse_width_s * 1e3:.4g} → "
                     f"{a.pulse_width_s * 1e3:.4g} → {b.pulse_width_s * 1e3:.4g} ms; impulse "
                     f"{lo.impulse_ns:.4g} → {a.impulse_ns:.4g} → {b.impulse_ns:.4g} N·s.")
    low = k1[(k1.k1_n_per_m <= 1e4) & (k1.status == "ok")]
    spread = low.groupby("k1_n_per_m").pulse_width_s.agg(lambda x: x.max() / x.min())
    lines += ["", f"At low k1 (≤ 10 kN/m) the pulse widths of the law combinations differ by up "
              f"to a factor {spread.max():.2f} (paper: up to 4×).", ""]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
