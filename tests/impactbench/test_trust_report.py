"""The report read at a glance and never lost: a store whose disk fills up costs the store's
writes, not the report; notes under the real tosses' table instead of a one-word column; the
practical figure full width with its legends outside the panels; relative errors printed as
plain percentages (round-off as 0, never an exponent); the Kharaz et al. figure linked; one
wording for the plausibility limit ("of its radius")."""

from __future__ import annotations

import errno
import math
import os
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from impactbench import cli, config, matrix
from impactbench.report_render import Cell, ReportContext, format_error, render_documents
from impactbench.store import Store
from tests.impactbench.test_faults import only_ball, plugins, stored_runs  # noqa: F401

# ----------------------------------------------------------------------------- a full store


def _no_space_duckdb_commit(path: Path) -> BaseException:
    """What DuckDB 2.0 raises when a commit finds the disk full (measured on a 3 MB loop-
    mounted ext4: ``TransactionException``)."""
    import duckdb

    return duckdb.TransactionException(
        f'TransactionContext Error: Failed to commit: Could not write file "{path}.wal": '
        "No space left on device")


def _no_space_duckdb_open(path: Path) -> BaseException:
    """What DuckDB raises when it cannot grow the file (an ``IOException``)."""
    import duckdb

    return duckdb.IOException(f'IO Error: Could not write file "{path}": No space left on '
                              "device")


def _no_space_os(path: Path) -> BaseException:
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


@pytest.mark.parametrize("fault", [_no_space_duckdb_commit, _no_space_duckdb_open,
                                   _no_space_os])
def test_a_store_that_fills_up_keeps_what_fits_and_the_report_is_still_written(
        fault, tmp_path: Path, plugins: dict[str, str],  # noqa: F811
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """18 runs, each written to the store as it finishes; the 6th write finds the disk full:
    5 runs are kept, the report is written from all 18 (exit 0) and one stderr line says so."""
    monkeypatch.setenv("IMPACTBENCH_TEST_SLEEP_S", "0")
    monkeypatch.setattr(matrix, "FLUSH_EVERY_S", -1.0)  # every finished run is written at once
    db = tmp_path / "s.duckdb"
    real_put, writes = Store._put, []

    def put(self, rows, runs, hist):
        writes.append(len(runs))
        if len(writes) > 5:
            raise fault(self.path)
        return real_put(self, rows, runs, hist)

    monkeypatch.setattr(Store, "_put", put)
    velocities = [round(0.5 + 0.1 * i, 1) for i in range(18)]
    cfg = tmp_path / "c.toml"
    cfg.write_text(only_ball("sleeper", velocities))
    out = tmp_path / "r"
    code = cli.main(["report", "--config", str(cfg), "--out", str(out), "--store", str(db),
                     "--workers", "0"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert f"impactbench: store '{db}': full after 5 of 18 runs kept; the report is written " \
           "from this run's results\n" in err
    assert "error" not in err
    assert writes[:5] == [1] * 5 and len(writes) == 6  # no write tried once the disk was full
    assert stored_runs(db) == 5
    for name in ("README.md", "index.html", "results.csv", "metadata.json"):
        assert (out / name).is_file(), name
    results = pd.read_csv(out / "results.csv")
    assert sorted(results.velocity_m_s.unique()) == velocities


def test_a_store_error_that_is_not_a_full_disk_still_stops_the_report(
        tmp_path: Path, plugins: dict[str, str],  # noqa: F811
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """Only a full disk is worked around: any other store fault is the one-line error."""
    import duckdb

    monkeypatch.setenv("IMPACTBENCH_TEST_SLEEP_S", "0")

    def put(self, rows, runs, hist):
        raise duckdb.IOException(f'IO Error: Cannot open file "{self.path}": Permission '
                                 "denied")

    monkeypatch.setattr(Store, "_put", put)
    cfg = tmp_path / "c.toml"
    cfg.write_text(only_ball("sleeper", [1.0]))
    out = tmp_path / "r"
    code = cli.main(["report", "--config", str(cfg), "--out", str(out), "--store",
                     str(tmp_path / "s.duckdb"), "--workers", "0"])
    err = capsys.readouterr().err
    assert code == 2 and "Permission denied" in err and "full after" not in err
    assert not out.exists()


def test_a_report_folder_on_a_full_disk_is_one_line_naming_it(
        tmp_path: Path, plugins: dict[str, str],  # noqa: F811
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """The runs are stored; writing the report finds its own disk full: one line naming the
    folder (the previous report stays, see test_faults), exit 2."""
    from impactbench import report

    monkeypatch.setenv("IMPACTBENCH_TEST_SLEEP_S", "0")

    def write(*_a, **_k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # no file name, as pandas'

    monkeypatch.setattr(report, "_write", write)
    cfg = tmp_path / "c.toml"
    cfg.write_text(only_ball("sleeper", [1.0]))
    out = tmp_path / "r"
    code = cli.main(["report", "--config", str(cfg), "--out", str(out), "--store",
                     str(tmp_path / "s.duckdb"), "--workers", "0"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.endswith(f"impactbench: error: out = '{out}': cannot write the report "
                        f"({os.strerror(errno.ENOSPC)}); its runs are in the store\n"), err
    assert not out.exists() and stored_runs(tmp_path / "s.duckdb") == 1


def test_the_sections_replays_share_the_reports_store_guard(tmp_path: Path) -> None:
    """A section that runs work of its own (the real tosses) writes through the report's
    guard when it uses the same store file, so a full disk is said once and not retried."""
    from impactbench.report_sections import _section_store
    from impactbench.report_store import KeepWhatFits

    guard = KeepWhatFits(Store(tmp_path / "s.duckdb"))
    cfg = SimpleNamespace(execution={"store": str(tmp_path / "s.duckdb")})
    ctx = ReportContext(cfg, pd.DataFrame(), {}, tmp_path, store=guard)
    assert _section_store(ctx) is guard
    other = _section_store(ReportContext(SimpleNamespace(execution={
        "store": str(tmp_path / "t.duckdb")}), pd.DataFrame(), {}, tmp_path, store=guard))
    assert isinstance(other, KeepWhatFits) and other is not guard
    assert other.path == tmp_path / "t.duckdb"


# ----------------------------------------------------------------------------- numbers


@pytest.mark.parametrize(("err", "text"), [
    (0.0, "0 %"), (1.2e-16, "0 %"), (-3e-10, "0 %"),     # round-off
    (4.6e-7, "+0.000046 %"), (1.2e-5, "+0.0012 %"), (-0.0123, "−1.2 %"),
    (-0.254, "−25 %"), (0.996, "+100 %"), (1.0, "+100 %"), (1.3, "+130 %"),
    (12.0, "+1200 %"), (-1.0, "−100 %"), (math.nan, "n/a"), (-math.inf, "−inf %"),
])
def test_a_relative_error_prints_as_a_plain_percentage(err: float, text: str) -> None:
    assert format_error(err) == text


def test_a_magnitude_prints_unsigned_and_no_error_ever_has_an_exponent() -> None:
    assert [format_error(x, signed=False) for x in (0.99, 1.0, 1.3, 4e-12, 0.0123)] == \
        ["99 %", "100 %", "130 %", "0 %", "1.2 %"]
    for x in np.geomspace(1e-12, 1e4, 400):
        for v in (x, -x):
            text = format_error(float(v))
            assert re.fullmatch(r"0 %|[+−](0\.0*[1-9]\d?|[1-9]\d*(\.\d)?) %", text), (v, text)


def test_the_heatmap_annotations_use_the_same_numbers() -> None:
    from impactbench import plots

    assert [plots._error_text(x) for x in (1.2e-16, 4.6e-7, -0.0123, 1.3)] == \
        ["0%", "+0.000046%", "−1.2%", "+130%"]
    assert plots.ROUND_OFF == 1e-9  # one floor: what prints as 0 takes the lowest colour


def _practical_rows(errors: dict[tuple[str, str], list[float]]) -> pd.DataFrame:
    """Tidy rows of the practical study: per (engine, mode) its restitution errors at 0.5 …
    5 m/s (NaN: the run is implausible)."""
    rows = []
    for (engine, mode), errs in errors.items():
        for v, e in zip((0.5, 1.0, 2.0, 3.0, 4.0, 5.0), errs, strict=False):
            ok = math.isfinite(e)
            for metric in ("restitution", "peak_force_n"):
                rows.append({"study": "practical", "scenario": "ball-on-plate",
                             "engine": engine, "mode": mode, "params": "",
                             "velocity_m_s": v, "timestep_s": 1e-3, "metric": metric,
                             "value": 0.9 * (1 + e) if ok else 0.5, "reference": 0.9,
                             "rel_error": e if ok else math.nan,
                             "status": "ok" if ok else "implausible",
                             "message": "" if ok else "penetration 0.3 of its radius (limit "
                             "0.1)", "engine_version": "1", "resolved": False})
    return pd.DataFrame(rows)


def test_the_practical_tables_print_100_percent_not_an_exponent(tmp_path: Path) -> None:
    from impactbench.practical import section

    df = _practical_rows({("drake", "default"): [-1.0, -0.99, math.nan],
                          ("mujoco", "tuned"): [1.2e-16, -0.016, math.nan]})
    data = section(ReportContext(config.parse({}), df, {}, tmp_path))
    texts = [c.text for row in data["summary"].rows for c in row]
    assert "100 %" in texts and "−100 %" in texts  # max |error| and the error at 0.5 m/s
    assert "0 %" in texts  # mujoco's round-off at 0.5 m/s
    assert not any(re.search(r"\de[+−-]?\d", t) for t in texts), texts
    cells = [c.text for e in data["engines"] for row in e["table"].rows for c in row
             if isinstance(c, Cell)]
    assert "0.9 (0 %)" in cells and not any("e−" in t or "e+" in t for t in cells), cells


# ----------------------------------------------------------------------------- real tosses


def test_real_tosses_notes_go_under_the_table_numbered(tmp_path: Path) -> None:
    """The note column is gone: a row's note is a numbered footnote (the same note once)
    under the table, its number beside the row's status."""
    from impactbench.cube_tosses.report_part import footnoted

    why_2d = "pymunk is a 2D engine: a cube tumbling in 3D cannot be expressed"
    why_jax = "mode injected in mjx: the law would have to be written in jax"
    rows = [[Cell("mujoco"), Cell("89/89"), Cell("")],
            [Cell("pymunk"), Cell("unsupported", "fail"), Cell(why_2d, wrap=True)],
            [Cell("mjx"), Cell("unsupported", "fail"), Cell(why_jax, wrap=True)],
            [Cell("box2d"), Cell("unsupported", "fail"), Cell(why_2d, wrap=True)]]
    kept, notes = footnoted(rows, at=1)
    assert [len(r) for r in kept] == [2, 2, 2, 2]
    assert [r[1].text for r in kept] == ["89/89", "unsupported ¹", "unsupported ²",
                                         "unsupported ¹"]
    assert kept[1][1].band == "fail" and kept[1][1].title == why_2d
    assert notes == [f"¹ {why_2d}", f"² {why_jax}"]


def test_the_real_tosses_section_has_no_note_column(
        tmp_path: Path, plugins: dict[str, str],  # noqa: F811
        monkeypatch: pytest.MonkeyPatch) -> None:
    """End to end, with engines that cannot replay a cube (2D): no `note` column, the reason
    once as a numbered note after the table in both documents."""
    pytest.importorskip("pymunk")
    monkeypatch.setenv("IMPACTBENCH_TEST_SLEEP_S", "0")
    cfg = tmp_path / "c.toml"
    # default mode only: a native pymunk replay cannot even be keyed today (reported)
    cfg.write_text(only_ball("sleeper", [1.0]).replace(
        "[cube_toss]\nengines = []", '[cube_toss]\nengines = ["pymunk"]\nmodes = ["default"]\n'
        "param_sets = []\nmodel = false"))
    out = tmp_path / "r"
    assert cli.main(["report", "--config", str(cfg), "--out", str(out), "--store",
                     str(tmp_path / "s.duckdb"), "--workers", "0"]) == 0
    md = (out / "README.md").read_text()
    html = (out / "index.html").read_text()
    part = md[md.index("## Against real tosses"):]
    part = part[:part.index("\n## ", 5)]
    header = next(line for line in part.splitlines() if line.startswith("| engine"))
    assert "note" not in header
    row = next(line for line in part.splitlines() if line.startswith("| pymunk"))
    assert "unsupported ¹" in row and "2D" not in row
    after = part[part.index(row):]
    assert re.search(r"\n> ¹ pymunk is a 2D engine[^\n]*3D", after), after
    section = html[html.index('id="against-real-tosses"'):]
    section = section[:section.index("</section>")]
    table, rest = section.split("</table>", 1)
    assert ">note<" not in table and "2D engine" not in table.replace(
        'title="pymunk is a 2D', "")
    assert re.search(r'<p class="note">¹ pymunk is a 2D engine', rest)


# ----------------------------------------------------------------------------- practical figure


def test_the_practical_figure_has_readable_legends_outside_its_panels(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Nine drake settings and failed runs: every legend is outside every panel, its text at
    least 8 pt, one entry per setting (failed runs share one entry per status)."""
    from impactbench import plots
    from impactbench.practical import plot

    settings = [f"discrete_contact_approximation={a}" for a in ("lagged", "sap", "similar",
                                                                "tamsi")]
    errs = [-0.96, -0.97, math.nan, math.nan, math.nan, math.nan]
    frames = [_practical_rows({("drake", m): errs}).assign(params=p)
              for m in ("custom", "tuned") for p in settings]
    frames += [_practical_rows({(e, m): errs}) for e in ("drake", "mujoco", "pybullet",
                                                         "pymunk")
               for m in ("default", "native")]
    df = pd.concat(frames, ignore_index=True)
    kept = {}

    def save(fig, path):
        fig.canvas.draw()
        kept["fig"] = fig
        return path

    monkeypatch.setattr(plots, "_save", save)
    plot(df, 0.08, "how", tmp_path / "p.png")
    fig = kept["fig"]
    renderer = fig.canvas.get_renderer()
    axes = [ax for ax in fig.axes if ax.has_data()]
    assert len(axes) == 4
    legends = [leg for ax in fig.axes if (leg := ax.get_legend()) is not None]
    legends += list(fig.legends)
    assert legends
    panels = [ax.get_window_extent(renderer) for ax in axes]
    for leg in legends:
        box = leg.get_window_extent(renderer)
        assert not any(box.overlaps(p) for p in panels), (box, panels)
        assert min(t.get_fontsize() for t in leg.get_texts()) >= 8
    drake = next(ax for ax in axes if "drake" in (ax.get_title(), ax.get_title(loc="left")))
    labels = [t.get_text() for leg in legends for t in leg.get_texts()
              if leg.axes is drake or leg in fig.legends]
    assert sum("lagged" in t for t in labels) == 2  # custom and tuned, no "…: implausible"
    assert sum("implausible" in t for t in labels) <= 1
    assert fig.get_size_inches()[0] >= 10  # drawn for the page's full width


def test_the_practical_figure_spans_the_page(tmp_path: Path) -> None:
    from impactbench.report_render import Section
    from impactbench.report_sections import practical_section

    df = _practical_rows({("drake", "default"): [-1.0, -0.99, math.nan]})
    ctx = ReportContext(config.parse({}), df, {}, tmp_path)
    (tmp_path / "figures").mkdir()
    ctx.add_figure(tmp_path / "figures" / "report_practical_restitution.png", "Practical",
                   "practical")
    html = render_documents(ctx, [Section("practical", "At practical timesteps",
                                          practical_section)], "T", "intro")["html"]
    fig = html.index('<figure><a href="figures/report_practical_restitution.png">')
    before = html[:fig]
    # not inside the two-column grid of thumbnails: no grid opened since the last </div>
    assert before.rfind('<div class="grid">') <= before.rfind("</div>"), before[-300:]


# ----------------------------------------------------------------------------- Kharaz et al.


def _oblique_ctx(tmp_path: Path) -> tuple[ReportContext, object]:
    from impactbench import scenarios

    spec = next(s for s in scenarios.specs() if s.figure_stem == "oblique")
    rows = [{"study": "matrix", "scenario": spec.name, "engine": "mujoco", "mode": "native",
             "angle_deg": 45.0, "velocity_m_s": 2.0, "timestep_s": 1e-6, "metric": m,
             "value": math.nan, "reference": 1.0, "rel_error": math.nan,
             "status": "unavailable", "message": "not installed", "engine_version": "",
             "params": ""} for m in spec.headline]
    return ReportContext(config.parse({}), pd.DataFrame(rows), {}, tmp_path), spec


def test_the_kharaz_figure_is_linked_from_the_oblique_section_and_the_index(
        tmp_path: Path) -> None:
    from impactbench.report_sections import figure_index, scenario_section

    ctx, spec = _oblique_ctx(tmp_path)
    assert not scenario_section(spec.name, ctx)["papers"]  # not written: no link
    (tmp_path / "figures").mkdir()
    (tmp_path / "figures" / "oblique_kharaz2001.png").write_bytes(b"png")
    papers = scenario_section(spec.name, ctx)["papers"]
    assert len(papers) == 1 and papers[0].path == "figures/oblique_kharaz2001.png"
    assert papers[0].caption.startswith("Kharaz, Gorham & Salman (2001)")
    index = figure_index(ctx)
    assert any(p.endswith("(figures/oblique_kharaz2001.png)") for p in index["paper"])
    from impactbench.report_render import Section

    md = render_documents(ctx, [Section("scenario", spec.title,
                                        lambda c: scenario_section(spec.name, c))],
                          "T", "intro")["md"]
    assert "](figures/oblique_kharaz2001.png)" in md


# ----------------------------------------------------------------------------- wording


def test_the_penetration_limit_is_said_of_the_radius() -> None:
    from impactbench import plausibility

    why = plausibility.problems({"penetration_ratio": 0.172})
    assert why == ["penetration 0.172 of its radius (limit 0.1)"]
    source = Path(plausibility.__file__).read_text()
    assert "body's size" not in source
