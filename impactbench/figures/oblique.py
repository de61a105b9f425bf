"""The oblique-impact figure of ``impactbench figures``: Kharaz, Gorham & Salman's (2001)
measured rebound of alumina spheres on glass against both references (rigid Coulomb theory
in closed form; the tangentially compliant Mindlin law, integrated), with the inputs the DEM
benchmarks use for that experiment (Chung & Ooi 2011, test 4)."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Executor
from pathlib import Path

from impactbench.figures.pool import IN_PROCESS

NAME = "oblique_kharaz2001.png"


def kharaz_figure(path: Path) -> Path:
    """The figure at ``path``: the rigid and Mindlin references over the incidence angle (two
    integrated sweeps, most of its ~10 s) and Kharaz et al.'s points."""
    import matplotlib

    matplotlib.use("Agg")
    import pandas as pd

    from impactbench.reference.oblique_scenario import Oblique
    from impactbench.scenarios.oblique import angle_figure

    case = Oblique.kharaz2001()
    return angle_figure(pd.DataFrame(), case, path,
                        "Kharaz et al. 2001: alumina sphere, R = 2.5 mm, on glass at 3.9 m/s, "
                        "μ = 0.092", kharaz=True)


def draw(out_dir: Path, pool: Executor) -> Callable[[], list[Path]]:
    """Queue ``oblique_kharaz2001.png`` on ``pool`` (one task); returns what waits for it."""
    future = pool.submit(kharaz_figure, Path(out_dir) / NAME)
    return lambda: [future.result()]


def write(out_dir: Path) -> list[Path]:
    """``oblique_kharaz2001.png`` into ``out_dir``."""
    return draw(out_dir, IN_PROCESS)()
