"""``impactbench figures`` writes the Hunt–Crossley PNGs (into tmp_path)."""

from __future__ import annotations

import pytest

from impactbench.cli import main
from impactbench.figures import FIGURE_MODULES
from impactbench.figures import hunt_crossley as figs

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("figures")
    return out, figs.write(out)


def test_all_seven_figures_written_in_order(written):
    out, paths = written
    names = [p.name for p in paths]
    assert names == sorted(names)
    assert [n.split("_")[1] for n in names] == ["fig1", "fig3", "fig4", "fig5", "fig6", "fig7",
                                                "fig8"]
    for p in paths:
        assert p.parent == out
        data = p.read_bytes()
        assert data[:8] == PNG and len(data) > 10_000


def test_registered_for_the_command():
    assert "impactbench.figures.hunt_crossley" in FIGURE_MODULES


def test_command_writes_into_out(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("impactbench.figures.FIGURE_MODULES",
                        ("impactbench.figures.hunt_crossley",))
    assert main(["figures", "--out", str(tmp_path / "f")]) == 0
    printed = capsys.readouterr().out.split()
    assert len(printed) == 7 and all((tmp_path / "f" / p.split("/")[-1]).exists()
                                     for p in printed)


def test_out_must_be_a_directory(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["figures", "--out", str(f)]) == 2
