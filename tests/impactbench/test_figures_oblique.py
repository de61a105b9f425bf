"""``impactbench figures``' oblique figure: Kharaz et al.'s measurements beside both
references, and the report hook's figure per configured speed."""

from __future__ import annotations

from pathlib import Path

from impactbench.figures import FIGURE_MODULES, oblique


def test_the_kharaz_figure_is_written(tmp_path: Path) -> None:
    assert "impactbench.figures.oblique" in FIGURE_MODULES
    (path,) = oblique.write(tmp_path)
    assert path.name == "oblique_kharaz2001.png" and path.stat().st_size > 20_000
