"""The report's document model: one template source gives the same Markdown and HTML, a new
section is a template plus a data function, and the scoreboard's words follow the numbers."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import pandas as pd
import pytest

from impactbench.report_render import (
    Cell,
    ReportContext,
    Section,
    Table,
    band,
    inline_html,
    render_documents,
)
from impactbench.report_sections import format_error, scoreboard, verdict


@pytest.mark.parametrize(("text", "html"), [
    ("**b** and *e*", "<b>b</b> and <em>e</em>"),
    ("`a<b`", "<code>a&lt;b</code>"),
    ("[fig](figures/x.png)", '<a href="figures/x.png">fig</a>'),
    ("2*3*4 & F·x*", "2*3*4 &amp; F·x*"),
])
def test_inline_markdown_becomes_escaped_html(text: str, html: str) -> None:
    assert inline_html(text) == html


def test_bands_and_signed_percentages() -> None:
    assert [band(x) for x in (0.0, -0.01, 0.0101, -0.05, 0.2, math.nan, None)] == \
        ["good", "good", "fair", "fair", "poor", "na", "na"]
    assert [format_error(x) for x in (0.0, 1.2e-5, -0.254, 1.0)] == \
        ["0 %", "+0.0012 %", "−25 %", "+100 %"]


def _ctx(tmp_path: Path, df: pd.DataFrame | None = None) -> ReportContext:
    cfg = SimpleNamespace(engines=("mujoco", "pymunk"), scenarios=(), work_precision=None)
    return ReportContext(cfg, df if df is not None else pd.DataFrame(), {}, tmp_path)


def test_a_new_section_is_a_template_and_a_data_function(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The built-in sections' own mechanism, exercised with a section written for the test."""
    from impactbench import report_render

    templates = tmp_path / "templates"
    (templates / "sections").mkdir(parents=True)
    for f in Path(report_render.__file__).with_name("templates").glob("*.*"):
        (templates / f.name).write_text(f.read_text())
    (templates / "sections" / "extra.j2").write_text(
        "{% call m.para() %}Worst: **{{ data.worst }}**.{% endcall %}\n"
        "{{ m.h(3, 'Details') }}\n{{ m.table(data.table) }}\n")
    table = Table(["engine", "error"], [[Cell("mujoco"), Cell("+2 %", "fair")]], marks=True)
    sections = [Section("extra", "An extra section", lambda ctx: {"worst": "2 %",
                                                                    "table": table}),
                Section("extra", "Left out", lambda ctx: None)]
    original = report_render.environment

    def env():
        import jinja2

        e = original()
        e.loader = jinja2.FileSystemLoader(templates)
        return e

    monkeypatch.setattr(report_render, "environment", env)
    docs = render_documents(_ctx(tmp_path), sections, "T", "intro")
    md, html = docs["md"], docs["html"]
    assert "## An extra section" in md and "Left out" not in md
    assert "Worst: **2 %**." in md and "| mujoco | 🟡 +2 % |" in md
    assert "[An extra section](#an-extra-section)" in md
    assert '<h2 id="an-extra-section">An extra section</h2>' in html
    assert '<a href="#details">Details</a>' in html and "Worst: <b>2 %</b>." in html
    assert '<td class="fair">+2 %</td>' in html


def _rows(engine: str, mode: str, errors: dict[float, float], status: str = "ok"):
    for v, err in errors.items():
        for metric in ("restitution", "duration_s", "peak_force_n"):
            e = err if metric == "peak_force_n" else err / 10
            yield {"study": "matrix", "scenario": "ball-on-plate", "local": "",
                   "structure": "", "engine": engine, "mode": mode, "velocity_m_s": v,
                   "timestep_s": 1e-6, "metric": metric, "value": 1 + e, "reference": 1.0,
                   "rel_error": e if status == "ok" else math.nan, "status": status,
                   "message": "" if status == "ok" else "kinetic energy gained",
                   "wall_s": 0.1, "engine_version": "1"}


def test_scoreboard_takes_the_worst_error_and_says_where(tmp_path: Path) -> None:
    df = pd.DataFrame([*_rows("mujoco", "native", {1.0: -0.02, 5.0: -0.35}),
                       *_rows("mujoco", "injected", {1.0: 0.001, 5.0: 0.0063}),
                       *_rows("pymunk", "injected", {1.0: 0.001}),
                       *_rows("pymunk", "injected", {5.0: 0.0}, status="diverged")])
    board = scoreboard(_ctx(tmp_path, df))["tables"][0]["table"]
    native, injected, pymunk = board.rows
    assert [c.text for c in native[2:5]] == ["−3.5 %", "−3.5 %", "−35 %"]
    assert [c.band for c in native[2:5]] == ["fair", "fair", "poor"]
    assert native[-1].text == ("Far off: peak force −35 % at V0 = 5 m/s; the others within "
                               "3.5 %.")
    assert injected[-1].text.startswith("Faithful: every measured metric within 1 % at 2")
    assert pymunk[5].text == "1/2"
    assert "1 of 2 runs gave no numbers (1 diverged)" in pymunk[-1].text
    assert verdict(df[df.engine == "nobody"], "ball-on-plate").startswith("No run")


def test_figure_index_links_the_papers_figures(tmp_path: Path) -> None:
    from impactbench.figures import hunt_crossley
    from impactbench.report_sections import figure_index

    written = hunt_crossley.write(tmp_path / "figures")
    data = figure_index(_ctx(tmp_path))
    assert data["paper_count"] == len(written) == 7
    assert data["paper"][0] == ("[Borovin et al. Fig. 1: phase trajectories V(x) for V0 = "
                                "0.5…5 m/s (ball on plate, reference)](figures/hc_fig1_phase.png)")


def _no_figure(path: Path) -> Path:
    raise RuntimeError(f"cannot draw {path.name}")


def test_the_figure_pool_draws_the_same_bytes_in_its_processes(tmp_path: Path,
                                                              monkeypatch) -> None:
    """A figure drawn by the pool's spawned processes is byte for byte the one drawn here;
    a small report's figures (fewer than MIN_PARALLEL) are drawn here, at close; workers = 0
    draws here; an error a figure raises is raised at close."""
    from impactbench.figures import zoo
    from impactbench.report_render import FigurePool

    here = zoo.figure(tmp_path / "here.png")
    monkeypatch.setattr(FigurePool, "MIN_PARALLEL", 1)
    with FigurePool(2) as pool:
        got = pool.submit(zoo.figure, tmp_path / "there.png")
        assert got == tmp_path / "there.png" and pool._executor is not None
    assert got.read_bytes() == here.read_bytes()
    monkeypatch.setattr(FigurePool, "MIN_PARALLEL", 8)
    with FigurePool(2) as pool:
        pool.submit(zoo.figure, path=tmp_path / "queued.png")
        assert pool._executor is None and not (tmp_path / "queued.png").exists()
    assert (tmp_path / "queued.png").read_bytes() == here.read_bytes()
    assert FigurePool(0).workers == 0
    with pytest.raises(RuntimeError, match=r"cannot draw x\.png"), FigurePool(2) as pool:
        pool.submit(_no_figure, tmp_path / "x.png")
