"""Nominal against effective restitution of every contact model (``impactbench figures``).

Each hysteresis-damping model sets b = α(e)/V0 from a nominal restitution e; its effective
restitution is exactly k(α(e)) (:mod:`impactbench.reference.models`), the same at every V0, m,
c and n. The linear Kelvin–Voigt law set from e is exact unclipped and bounces higher when
clipped at F ≥ 0. Files:

- ``zoo_restitution.png``: effective against nominal restitution, e ∈ (0, 1], one curve per
  model, the diagonal dashed;
- ``zoo_restitution.csv`` / ``zoo_restitution.md``: the table at e = 0.1, 0.2, …, 1.0
  (:func:`table`).
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Executor
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from tabulate import tabulate

from impactbench.figures.pool import IN_PROCESS
from impactbench.reference.models import MODEL_CITATIONS, MODELS
from impactbench.reference.zoo import restitution_table

TABLE_NOMINAL: tuple[float, ...] = tuple(round(0.1 * i, 1) for i in range(1, 11))
CURVE_NOMINAL = np.linspace(0.005, 1.0, 200)


def table(nominal: tuple[float, ...] = TABLE_NOMINAL) -> pd.DataFrame:
    """Wide table: one row per model, one column per nominal e (effective restitution)."""
    long = restitution_table(nominal)
    wide = long.pivot(index="model", columns="nominal_restitution",
                      values="effective_restitution").reindex(list(MODELS))
    wide.columns = [f"e = {e:g}" for e in wide.columns]
    return wide.reset_index()


def markdown(nominal: tuple[float, ...] = TABLE_NOMINAL) -> str:
    """The table as GitHub Markdown (effective restitution, 4 decimals), with citations."""
    wide = table(nominal)
    wide.insert(1, "source", [MODEL_CITATIONS[m] for m in wide["model"]])
    return tabulate(wide, headers="keys", tablefmt="github", showindex=False, floatfmt=".4f")


def figure(path: Path) -> Path:
    long = restitution_table(CURVE_NOMINAL)
    fig, ax = plt.subplots(figsize=(7.2, 5.4))
    styles = ["-", "--", "-.", ":"]
    for i, model in enumerate(MODELS):
        d = long[long.model == model]
        ax.plot(d.nominal_restitution, d.effective_restitution, styles[i % 4], lw=1.4,
                label=model)
    ax.plot([0, 1], [0, 1], color="k", lw=0.8, ls=(0, (2, 2)), label="effective = nominal")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_xlabel("nominal restitution e (the model's input)")
    ax.set_ylabel("effective restitution k (exact)")
    ax.set_title("Contact models set from a nominal restitution: what they really give")
    ax.legend(fontsize=7, ncol=2, loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def tables(out_dir: Path) -> list[Path]:
    """Write the table as CSV and Markdown into ``out_dir``; their paths."""
    csv = out_dir / "zoo_restitution.csv"
    table().to_csv(csv, index=False, float_format="%.10g")
    md = out_dir / "zoo_restitution.md"
    md.write_text("# Nominal against effective restitution\n\n" + markdown() + "\n")
    return [csv, md]


def draw(out_dir: Path, pool: Executor) -> Callable[[], list[Path]]:
    """Queue the figure and the tables on ``pool`` (two tasks); returns what waits for them
    and gives the paths: figure, CSV, Markdown."""
    out_dir = Path(out_dir)
    png = pool.submit(figure, out_dir / "zoo_restitution.png")
    rest = pool.submit(tables, out_dir)
    return lambda: [png.result(), *rest.result()]


def write(out_dir: Path) -> list[Path]:
    """Write the figure and the table (CSV, Markdown) into ``out_dir``."""
    return draw(out_dir, IN_PROCESS)()
