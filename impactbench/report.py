"""``impactbench report``: run the comparison matrix and write a self-explaining report.

Outputs in the report folder: ``README.md`` (headline tables and what they mean),
``index.html`` (the same with the plots inline; opens without a server), ``results.csv`` and
``results.parquet`` (tidy: one row per run and metric), ``metadata.json`` (versions, platform,
commit, config hash, per-run wall times) and ``figures/report_*.png``.
"""

from __future__ import annotations

import html
import json
import math
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd
from tabulate import tabulate

from impactbench import config as config_mod
from impactbench import plots
from impactbench.cliutil import progress_bar
from impactbench.evaluate import SCENARIO_METRICS
from impactbench.matrix import JobResult, plan, run_jobs, tidy

HEADLINE = {
    "ball-on-plate": ("restitution", "duration_s", "peak_force_n"),
    "rigid-flexible": ("peak_force_n", "pulse_width_s", "impulse_ns", "impacts"),
}
UNITS = {"restitution": "–", "duration_s": "s", "peak_force_n": "N", "pulse_width_s": "s",
         "impulse_ns": "N·s", "impacts": "count", "contact_time_s": "s",
         "max_penetration_m": "m", "energy_loss_fraction": "–"}
SORT_COLUMNS = ["study", "scenario", "local", "structure", "velocity_m_s", "engine", "mode",
                "timestep_s", "metric"]


@dataclass
class Report:
    out_dir: Path
    results: pd.DataFrame
    files: list[Path]
    wall_s: float


def git_commit() -> str:
    """The source commit (``+dirty`` when the work tree differs), or ``unknown``."""
    root = Path(__file__).resolve().parent.parent
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True,
                             text=True, check=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=root, capture_output=True, text=True, timeout=10).stdout
        return sha + ("+dirty" if dirty.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def _library_versions() -> dict[str, str]:
    from importlib import metadata

    out = {}
    for dist in ("numpy", "scipy", "pandas", "matplotlib", "mujoco", "pybullet", "pymunk",
                 "drake"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[dist] = "not installed"
    return out


def _cell(row: pd.Series) -> str:
    if row.status != "ok":
        return str(row.status)
    value, err = row.value, row.rel_error
    if not (isinstance(value, float | int) and math.isfinite(value)):
        return "n/a"
    if row.metric == "impacts":
        return f"{value:g}" + ("" if err == 0 or not math.isfinite(err) else " ✗")
    text = f"{value:.5g}"
    if isinstance(err, float) and math.isfinite(err):
        text += f" ({format_error(err)})"
    return text


def format_error(err: float) -> str:
    """A signed relative error in percent with two significant digits (+0.0012 %, −25 %)."""
    if err == 0.0:
        return "0 %"
    return f"{100.0 * err:+.2g} %"


def headline_tables(df: pd.DataFrame, scenario: str) -> list[tuple[str, pd.DataFrame]]:
    """Per headline metric: rows = scenario points, columns = reference and engine × mode."""
    rows = df[(df.study == "matrix") & (df.scenario == scenario)]
    out = []
    keys = ["local", "structure", "velocity_m_s"] if scenario == "rigid-flexible" \
        else ["velocity_m_s"]
    for metric in HEADLINE[scenario]:
        m = rows[rows.metric == metric].copy()
        if m.empty:
            continue
        m["cell"] = m.apply(_cell, axis=1)
        m["column"] = m.engine + " " + m["mode"]
        table = m.pivot_table(index=keys, columns="column", values="cell", aggfunc="first")
        ref = m.groupby(keys)["reference"].first()
        table.insert(0, "reference", ref.map(lambda v: f"{v:.5g}" if isinstance(v, float)
                                             else str(v)))
        out.append((f"{metric} ({UNITS.get(metric, '')})", table.reset_index()))
    return out


def _worst(df: pd.DataFrame, metric: str) -> float:
    e = df[(df.metric == metric) & (df.status == "ok")].rel_error.abs()
    return float(e.max()) if len(e) else math.nan


def _judge(err: float) -> str:
    if not math.isfinite(err):
        return "not measured"
    return "faithful" if err <= 0.01 else "noticeably off" if err <= 0.05 else "far off"


def injection_line(engine: str) -> str:
    """The adapter's one-line statement of what injected mode means in it (``""`` if the
    adapter cannot be loaded here)."""
    try:
        from impactbench.engines.base import get_adapter

        return str(get_adapter(engine).injection)
    except Exception:
        return ""


def interpretation(df: pd.DataFrame, engine: str) -> str:
    """A generated paragraph: which metric is off by how much, and whose error it is."""
    rows = df[(df.study == "matrix") & (df.engine == engine)]
    if rows.empty:
        return ""
    version = next((v for v in rows.engine_version if v), "")
    if (rows.status == "unavailable").all():
        return f"**{engine}** is not installed here ({rows.message.iloc[0]}); its rows say " \
               "`unavailable`."
    parts = [f"**{engine} {version}**."]
    how = injection_line(engine)
    for scenario, metric_names in HEADLINE.items():
        s = rows[rows.scenario == scenario]
        if s.empty:
            continue
        label = scenario.replace("-", " ")
        inj, nat = s[s["mode"] == "injected"], s[s["mode"] == "native"]
        names = [m for m in metric_names if m != "impacts"]

        def worst(d: pd.DataFrame, names: list[str] = names) -> str:
            return ", ".join(f"{plots.LABELS[m]} {format_error(_worst(d, m))[1:]}"
                             for m in names if math.isfinite(_worst(d, m)))

        inj_w = max((_worst(inj, m) for m in names), default=math.nan)
        nat_w = max((_worst(nat, m) for m in names), default=math.nan)
        dt = s.timestep_s.dropna()
        dt_text = f"dt = {dt.iloc[0]:g} s" if len(dt) else "its default step"
        if len(inj):
            parts.append(
                f"{label.capitalize()}, injected mode (the reference law stepped by {engine} at "
                f"{dt_text}): worst errors {worst(inj) or 'none measured'} — the time "
                f"stepping is {_judge(inj_w)}."
            )
            if how:
                parts.append(f"Injection in {engine}: {how}.")
                how = ""  # once per engine
        if len(nat):
            if not (math.isfinite(inj_w) and math.isfinite(nat_w)):
                owner = ""
            elif nat_w <= 0.01:
                owner = "within 1 % of the reference"
            elif nat_w > 3 * inj_w:
                owner = "the gap is the contact model's, not the integrator's"
            else:
                owner = "comparable to injected mode, so the time stepping dominates"
            mapping = ("a linear k1 contact, which cannot yield or fail"
                       if scenario == "rigid-flexible" else "parameters mapped at 1 m/s")
            parts.append(f"Native mode (its own contact, {mapping}): "
                         f"{worst(nat) or 'none measured'}" + (f"; {owner}." if owner else "."))
        tun = s[s["mode"] == "tuned"]
        if len(tun):
            parts.append(f"Tuned mode (fitted parameters, the best its contact model does over "
                         f"the velocity set): {worst(tun) or 'none measured'}.")
        bad = s[~s.status.isin(["ok"])].drop_duplicates(
            ["mode", "velocity_m_s", "local", "structure"])
        if len(bad):
            counts = bad.status.value_counts().to_dict()
            parts.append(f"{len(bad)} {label} runs did not give numbers: "
                         + ", ".join(f"{n} {st}" for st, n in sorted(counts.items()))
                         + f" (e.g. {bad.message.iloc[0] or bad.status.iloc[0]}).")
    return " ".join(parts)


def _markdown_table(table: pd.DataFrame) -> str:
    return tabulate(table, headers="keys", tablefmt="github", showindex=False,
                    disable_numparse=True)


def write_markdown(path: Path, cfg: config_mod.ReportConfig, df: pd.DataFrame,
                   meta: dict[str, Any], figures: dict[str, Path]) -> None:
    lines = [f"# {cfg.title}", "",
             "Generated by `impactbench report` (`make report`). Each cell: the engine's value "
             "and its signed relative error against the reference; a word instead of a number "
             "is the run's status.", "",
             "How to read it: **injected** mode drives the reference force law through the "
             "engine each step, so its error is the engine's time stepping alone; **native** "
             "mode uses the engine's own contact model with parameters mapped from the "
             "physical ones (for the ball: a linear spring–damper matched to the reference's "
             "restitution and duration at 1 m/s; pymunk: a rigid contact with the reference's "
             "restitution at 1 m/s), so native minus injected is the contact model's error; "
             "**tuned** mode uses fitted parameters (`impactbench tune`). `n/a`: the engine "
             "cannot express the metric (a rigid contact has no duration or finite force).", "",
             f"Commit `{meta['commit']}`, config `{meta['config']}` (hash {meta['config_hash']}), "
             f"Python {meta['python']}. Engines: "
             + ", ".join(f"{k} {v}" for k, v in meta["engines"].items()) + ".", ""]
    for scenario in ("ball-on-plate", "rigid-flexible"):
        tables = headline_tables(df, scenario)
        if not tables:
            continue
        lines += [f"## {scenario}", ""]
        for title, table in tables:
            lines += [f"### {title}", "", _markdown_table(table), ""]
    lines += ["## What this means", ""]
    for engine in cfg.engines:
        text = interpretation(df, engine)
        if text:
            lines += [text, ""]
    lines += ["## Figures", ""]
    for name, fig in figures.items():
        lines += [f"![{name}](figures/{fig.name})", ""]
    lines += ["## Files", "", "- `results.csv`, `results.parquet`: one row per run and metric.",
              "- `metadata.json`: versions, platform, commit, config and per-run wall times.",
              "- `index.html`: this page with the figures inline.", ""]
    path.write_text("\n".join(lines))


def write_html(path: Path, cfg: config_mod.ReportConfig, df: pd.DataFrame,
               meta: dict[str, Any], figures: dict[str, Path]) -> None:
    esc = html.escape
    body = [f"<h1>{esc(cfg.title)}</h1>",
            f"<p>Commit <code>{esc(meta['commit'])}</code>, config hash "
            f"<code>{esc(meta['config_hash'])}</code>. Engines: "
            + esc(", ".join(f"{k} {v}" for k, v in meta["engines"].items())) + "</p>"]
    for scenario in ("ball-on-plate", "rigid-flexible"):
        tables = headline_tables(df, scenario)
        if not tables:
            continue
        body.append(f"<h2>{esc(scenario)}</h2>")
        for title, table in tables:
            body.append(f"<h3>{esc(title)}</h3>")
            body.append(tabulate(table, headers="keys", tablefmt="html", showindex=False,
                                 disable_numparse=True))
    body.append("<h2>What this means</h2>")
    for engine in cfg.engines:
        text = interpretation(df, engine)
        if text:
            text = esc(text)
            while "**" in text:
                text = text.replace("**", "<b>", 1).replace("**", "</b>", 1)
            body.append(f"<p>{text.replace('`', '')}</p>")
    body.append("<h2>Figures</h2>")
    for name, fig in figures.items():
        body.append(f'<figure><img src="figures/{esc(fig.name)}" alt="{esc(name)}">'
                    f"<figcaption>{esc(name)}</figcaption></figure>")
    style = ("body{font-family:sans-serif;max-width:1200px;margin:auto;padding:1em}"
             "table{border-collapse:collapse;font-size:12px;margin-bottom:1em}"
             "td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}"
             "img{max-width:100%}")
    path.write_text("<!doctype html><html><head><meta charset='utf-8'>"
                    f"<title>{esc(cfg.title)}</title><style>{style}</style></head><body>"
                    + "\n".join(body) + "</body></html>\n")


def _figures(cfg: config_mod.ReportConfig, df: pd.DataFrame, results: list[JobResult],
             fig_dir: Path) -> dict[str, Path]:
    """All report plots; returns caption → path."""
    from impactbench.params import SCENARIO_CLASSES

    out: dict[str, Path] = {}
    # a rigid contact's impulse/dt is no force history: leave such runs out of F(t) and F–x
    matrix = [r for r in results if r.job.study == "matrix" and r.history
              and "peak_force_n" not in r.run.get("not_comparable", {})]
    groups: dict[tuple, dict[tuple[str, str], dict]] = {}
    for r in matrix:
        groups.setdefault(r.job.reference_key, {})[(r.job.engine, r.job.mode)] = r.history
    ball_loops: list[tuple] = []
    for key, hist in sorted(groups.items(), key=lambda kv: str(kv[0])):
        scenario, v, local, structure, params = key
        sc = SCENARIO_CLASSES[scenario](**dict(params), velocity_m_s=v,
                                        **({"local": local, "structure": structure}
                                           if local else {}))
        ref = plots.reference_history_for(sc)
        if scenario == "ball-on-plate":
            name = f"report_force_ball_v{v:g}.png"
            out[f"F(t), ball at V0 = {v:g} m/s"] = plots.force_time(
                hist, ref, f"Ball on plate, V0 = {v:g} m/s", fig_dir / name)
            ball_loops.append((v, hist, ref))
        else:
            name = f"report_force_rf_{local}_{structure}_v{v:g}.png"
            out[f"F(t), rigid–flexible {local}/{structure} at v1 = {v:g} m/s"] = \
                plots.force_time(hist, ref, f"Rigid–flexible {local}/{structure}, "
                                 f"v1 = {v:g} m/s", fig_dir / name, 1e-3, "ms")
    for v, hist, ref in ball_loops:
        out[f"F–x loop, ball at V0 = {v:g} m/s"] = plots.hysteresis(
            hist, ref, f"Hysteresis, ball at V0 = {v:g} m/s",
            fig_dir / f"report_hysteresis_ball_v{v:g}.png")
    ball = next((s for s in cfg.scenarios if s.name == "ball-on-plate"), None)
    if ball is not None:
        b = ball.parameters.get("damping_s_per_m", SCENARIO_CLASSES["ball-on-plate"]()
                                .damping_s_per_m)
        out["restitution against V0"] = plots.restitution_vs_velocity(
            df, b, fig_dir / "report_restitution_vs_velocity.png")
    for scenario in ("ball-on-plate", "rigid-flexible"):
        if ((df.study == "matrix") & (df.scenario == scenario)).any():
            out[f"error heatmap, {scenario}"] = plots.error_heatmap(
                df, scenario, HEADLINE[scenario],
                fig_dir / f"report_error_heatmap_{scenario.replace('-', '_')}.png")
    if (df.study == "work_precision").any():
        out["work–precision"] = plots.work_precision(
            df, HEADLINE["ball-on-plate"], fig_dir / "report_work_precision.png")
    return out


def build(cfg: config_mod.ReportConfig, out_dir: Path, *, engines: list[str] | None = None,
          workers: int | None = None, show_progress: bool = True) -> Report:
    """Run the matrix of ``cfg`` and write every report file into ``out_dir``."""
    t0 = time.perf_counter()
    out_dir.mkdir(parents=True, exist_ok=True)
    fig_dir = out_dir / "figures"
    fig_dir.mkdir(exist_ok=True)
    for old in fig_dir.glob("report_*.png"):
        old.unlink()
    jobs = plan(cfg, engines)
    update, close = progress_bar(len(jobs)) if show_progress else ((lambda n: None),
                                                                    (lambda: None))
    try:
        results = run_jobs(jobs, workers, progress=update)
    finally:
        close()
    df = pd.DataFrame(tidy(results))
    if not df.empty:
        df = df.sort_values(SORT_COLUMNS, kind="stable").reset_index(drop=True)
    engine_versions = {}
    for r in results:
        if r.run.get("engine_version"):
            engine_versions.setdefault(r.job.engine, r.run["engine_version"])
    for e in (engines or cfg.engines):
        engine_versions.setdefault(e, "unavailable")
    meta = {
        "commit": git_commit(),
        "config": cfg.source or "<inline>",
        "config_hash": cfg.hash,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "engines": dict(sorted(engine_versions.items())),
        "libraries": _library_versions(),
        "metrics_per_scenario": {k: list(v) for k, v in SCENARIO_METRICS.items()},
        "runs": [{"id": r.job.id, "status": r.run["status"], "wall_s": r.run.get("wall_s"),
                  "timestep_s": r.run.get("timestep_s")} for r in results],
        "command": " ".join(["impactbench", *sys.argv[1:]]) if sys.argv else "",
    }
    files = [out_dir / "results.csv", out_dir / "results.parquet"]
    df.to_csv(files[0], index=False)
    df.to_parquet(files[1], index=False)
    figures = _figures(cfg, df, results, fig_dir)
    meta["wall_s"] = time.perf_counter() - t0
    (out_dir / "metadata.json").write_text(json.dumps(meta, indent=2, default=str) + "\n")
    write_markdown(out_dir / "README.md", cfg, df, meta, figures)
    write_html(out_dir / "index.html", cfg, df, meta, figures)
    files += [out_dir / "metadata.json", out_dir / "README.md", out_dir / "index.html",
              *figures.values()]
    return Report(out_dir, df, files, time.perf_counter() - t0)
