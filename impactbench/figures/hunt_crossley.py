"""Figures 1, 3–8 of Borovin, Dyagel & Lapshin (Keldysh preprint 53, 2008), from the reference.

The paper's case: steel ball m = 0.1 kg on a massive steel plate, Hertz c = 1.7135e10 N/m^1.5,
n = 3/2, b = 0.1 s/m, V0 = 0.5, 1, 2, 3, 4, 5 m/s (MODELS.md §1). Every curve comes from
:mod:`impactbench.reference.hunt_crossley` (closed form and its exact time histories).

- Fig. 1 ``hc_fig1_phase.png``: phase trajectories V(x); dashed: the line 1 + b·V = 0.
- Fig. 3 ``hc_fig3_restitution.png``: k and ΔT/T = 1 − k² against α = b·V0.
- Fig. 4 ``hc_fig4_histories.png``: x(t) and F(t) for the six V0.
- Fig. 5 ``hc_fig5_maxima.png``: x_max, F_max and contact duration against V0.
- Fig. 6 ``hc_fig6_hysteresis.png``: F against x (loop area = lost energy).
- Fig. 7 ``hc_fig7_energy_loss.png``: lost kinetic energy ΔT (J) against V0.
- Fig. 8 ``hc_fig8_lambert_w.png``: the real branches W₀ (solid) and W₋₁ (dashed).
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
from scipy import special

from impactbench.figures.pool import IN_PROCESS
from impactbench.reference import hunt_crossley as hc
from impactbench.reference.scenarios import PAPER_VELOCITIES_M_S, BallOnPlate

CASE = BallOnPlate()
DPI = 120


def _save(fig: plt.Figure, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def _label(v: float) -> str:
    return f"V0 = {v:g} m/s"


def fig1_phase(path: Path) -> Path:
    law, b = CASE.law(), CASE.damping_s_per_m
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for v in PAPER_VELOCITIES_M_S:
        xmax = hc.solve(CASE.replace(velocity_m_s=v))["max_penetration_m"]
        xi = xmax * (1.0 - np.linspace(0.0, 1.0, 400) ** 2)[::-1]
        vc = hc.velocity(xi, law, CASE.mass_kg, v, "compression")
        vr = hc.velocity(xi, law, CASE.mass_kg, v, "restitution")
        x = np.concatenate([xi, xi[::-1]]) * 1e6
        ax.plot(x, np.concatenate([vc, vr[::-1]]), label=_label(v))
    ax.axhline(-1.0 / b, ls="--", color="k", lw=1, label="1 + b·V = 0 (not reachable)")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel("penetration x (µm)")
    ax.set_ylabel("velocity V (m/s)")
    ax.set_title(f"Fig. 1: phase trajectories, b = {b:g} s/m")
    ax.legend(fontsize=8, loc="lower right")
    return _save(fig, path)


def _finish(fig: Any, ax: Any, path: Path, xlabel: str, ylabel: str, title: str) -> Path:
    """Label one panel, add its legend and save the figure."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    return _save(fig, path)


def fig3_restitution(path: Path) -> Path:
    alpha = np.linspace(0.0, 10.0, 1001)
    k = hc.restitution(alpha)
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    ax.plot(alpha, k, label="restitution k")
    ax.plot(alpha, 1.0 - k * k, "--", label="lost energy fraction ΔT/T = 1 − k²")
    small = alpha <= 0.75
    ax.plot(alpha[small], 1.0 - 2.0 * alpha[small] / 3.0, ":", color="0.4",
            label="small α: k ≈ 1 − 2α/3")
    ax.set_ylim(0.0, 1.02)
    return _finish(fig, ax, path, "α = b·V0 (dimensionless)", "k, ΔT/T (dimensionless)",
                   "Fig. 3: restitution and lost energy against α")


def fig4_histories(path: Path) -> Path:
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.4))
    for v in PAPER_VELOCITIES_M_S:
        rec = hc.history(CASE.replace(velocity_m_s=v), samples=801)
        ax1.plot(rec.time_s * 1e6, rec.penetration_m * 1e6, label=_label(v))
        ax2.plot(rec.time_s * 1e6, rec.normal_force_n * 1e-3, label=_label(v))
    ax1.set_xlabel("time t (µs)")
    ax1.set_ylabel("penetration x (µm)")
    ax1.set_ylim(bottom=0.0)
    ax1.set_title("Fig. 4a: penetration (deformation)")
    ax2.set_xlabel("time t (µs)")
    ax2.set_ylabel("contact force F (kN)")
    ax2.set_title("Fig. 4b: contact force")
    for ax in (ax1, ax2):
        ax.set_xlim(0.0, None)
        ax.legend(fontsize=8)
    return _save(fig, path)


def fig5_maxima(path: Path) -> Path:
    v = np.linspace(0.1, 5.0, 400)
    pts = hc.sweep(PAPER_VELOCITIES_M_S, mass_kg=CASE.mass_kg, stiffness=CASE.stiffness,
                   exponent=CASE.exponent, damping_s_per_m=CASE.damping_s_per_m)
    df = hc.sweep(v, mass_kg=CASE.mass_kg, stiffness=CASE.stiffness, exponent=CASE.exponent,
                  damping_s_per_m=CASE.damping_s_per_m)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2))
    panels = (("max_penetration_m", 1e6, "max penetration x_max (µm)"),
              ("peak_force_n", 1e-3, "peak force F_max (kN)"),
              ("duration_s", 1e6, "contact duration T (µs)"))
    for ax, (col, scale, label) in zip(axes, panels, strict=True):
        ax.plot(v, df[col] * scale, label=f"b = {CASE.damping_s_per_m:g} s/m")
        ax.plot(pts["velocity_m_s"], pts[col] * scale, "o", label="the six V0 of Fig. 4")
        ax.set_xlabel("impact velocity V0 (m/s)")
        ax.set_ylabel(label)
        ax.legend(fontsize=8)
    axes[0].set_title("Fig. 5a: max penetration")
    axes[1].set_title("Fig. 5b: peak force")
    axes[2].set_title("Fig. 5c: duration")
    return _save(fig, path)


def fig6_hysteresis(path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for v in PAPER_VELOCITIES_M_S:
        rec = hc.history(CASE.replace(velocity_m_s=v), samples=801)
        inside = rec.penetration_m >= 0.0
        ax.plot(rec.penetration_m[inside] * 1e6, rec.normal_force_n[inside] * 1e-3,
                label=_label(v))
    return _finish(fig, ax, path, "penetration x (µm)", "contact force F (kN)",
                   "Fig. 6: force against penetration (loop area = lost energy)")


def fig7_energy_loss(path: Path) -> Path:
    def lost_j(v: np.ndarray) -> np.ndarray:  # ΔT = (1 − k²)·½·m·V0²
        return (1.0 - hc.restitution(CASE.damping_s_per_m * v) ** 2) * 0.5 * CASE.mass_kg * v**2

    v = np.linspace(0.0, 5.0, 400)
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    ax.plot(v, lost_j(v), label=f"b = {CASE.damping_s_per_m:g} s/m, m = {CASE.mass_kg:g} kg")
    pts = np.asarray(PAPER_VELOCITIES_M_S)
    ax.plot(pts, lost_j(pts), "o", label="the six V0 of Figs. 4, 6")
    return _finish(fig, ax, path, "impact velocity V0 (m/s)", "lost kinetic energy ΔT (J)",
                   "Fig. 7: kinetic energy lost in the impact")


def fig8_lambert_w(path: Path) -> Path:
    e = np.e
    z0 = -1.0 / e + np.geomspace(1e-12, 3.0 + 1.0 / e, 600)
    zm = -1.0 / e + (1.0 / e) * np.linspace(1e-12, 1.0, 600) ** 2
    zm = zm[zm < -1e-3]
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    ax.plot(z0, special.lambertw(z0, 0).real, label="W₀ (principal branch)")
    ax.plot(zm, special.lambertw(zm, -1).real, "--", label="W₋₁ (second real branch)")
    ax.plot([-1.0 / e], [-1.0], "ko", ms=4, label="branch point (−1/e, −1)")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.axvline(0.0, color="0.6", lw=0.6)
    ax.set_ylim(-6.0, 1.5)
    ax.set_xlabel("z (dimensionless)")
    ax.set_ylabel("W(z) (dimensionless)")
    ax.set_title("Fig. 8: the real branches of the Lambert W function")
    ax.legend(fontsize=8, loc="lower right")
    return _save(fig, path)


FIGURES = (
    ("hc_fig1_phase.png", fig1_phase),
    ("hc_fig3_restitution.png", fig3_restitution),
    ("hc_fig4_histories.png", fig4_histories),
    ("hc_fig5_maxima.png", fig5_maxima),
    ("hc_fig6_hysteresis.png", fig6_hysteresis),
    ("hc_fig7_energy_loss.png", fig7_energy_loss),
    ("hc_fig8_lambert_w.png", fig8_lambert_w),
)


def draw(out_dir: Path, pool: Executor) -> Callable[[], list[Path]]:
    """Queue the seven PNGs on ``pool``, one task each; returns what waits for them and gives
    their paths in figure order."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    futures = [pool.submit(make, out_dir / name) for name, make in FIGURES]
    return lambda: [f.result() for f in futures]


def write(out_dir: Path) -> list[Path]:
    """Write the seven PNGs into ``out_dir`` (here, in figure order); return their paths."""
    return draw(out_dir, IN_PROCESS)()
