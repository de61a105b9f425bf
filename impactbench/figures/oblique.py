"""The oblique-impact figure of ``impactbench figures``: Kharaz, Gorham & Salman's (2001)
measured rebound of alumina spheres on glass against both references (rigid Coulomb theory
in closed form; the tangentially compliant Mindlin law, integrated), with the inputs the DEM
benchmarks use for that experiment (Chung & Ooi 2011, test 4)."""

from __future__ import annotations

from pathlib import Path


def write(out_dir: Path) -> list[Path]:
    """``oblique_kharaz2001.png`` into ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    import pandas as pd

    from impactbench.reference.oblique_scenario import Oblique
    from impactbench.scenarios.oblique import angle_figure

    case = Oblique.kharaz2001()
    path = angle_figure(pd.DataFrame(), case, Path(out_dir) / "oblique_kharaz2001.png",
                        "Kharaz et al. 2001: alumina sphere, R = 2.5 mm, on glass at 3.9 m/s, "
                        "μ = 0.092", kharaz=True)
    return [path]
