"""``impactbench report``: run the comparison matrix and write a self-explaining report.

Outputs in the report folder: ``README.md`` (headline tables and what they mean),
``index.html`` (the same with the plots inline; opens without a server), ``results.csv`` and
``results.parquet`` (tidy: one row per run and metric), ``metadata.json`` (versions, platform,
commit, config hash, per-run wall times) and ``figures/report_*.png``.
"""

from __future__ import annotations

import contextlib
import errno
import json
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from impactbench import config as config_mod
from impactbench import plots, practical, scenarios
from impactbench.cliutil import progress_bar
from impactbench.matrix import Interrupted, JobResult, plan, run_jobs, tidy
from impactbench.report_render import ReportContext, render_documents
from impactbench.report_sections import sections
from impactbench.report_store import KeepWhatFits


def sort_columns() -> list[str]:
    """The order of results rows: study, scenario, the point's axes, engine, mode, …"""
    cats, nums = scenarios.point_columns()
    return ["study", "scenario", *cats, *nums, "engine", "mode", "params", "timestep_s",
            "metric"]


@dataclass
class Report:
    out_dir: Path
    results: pd.DataFrame
    files: list[Path]
    wall_s: float
    kept: bool = False
    """True when the previous report was kept: the same results apart from wall times."""


def git_commit(exclude: Path | None = None) -> str:
    """The source commit (``+dirty`` when tracked files differ from it), or ``unknown``.

    ``exclude``: a folder inside the work tree left out — the report's own output folder,
    which a regeneration rewrites (it is output, not source): the commit is the last one that
    changed anything else, so committing a regenerated report does not change the commit the
    next regeneration records, and the dirty check ignores the folder."""
    root = Path(__file__).resolve().parent.parent
    try:
        spec = ["--", "."]
        if exclude is not None:
            with contextlib.suppress(ValueError):
                rel = Path(exclude).resolve().relative_to(root)
                if rel.parts:
                    spec.append(f":(exclude){rel.as_posix()}")
        sha = subprocess.run(["git", "log", "-1", "--format=%H", *spec], cwd=root,
                             capture_output=True, text=True, check=True,
                             timeout=10).stdout.strip() or "unknown"
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", *spec],
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


def timestep_text(runs: list[JobResult]) -> str:
    """``dt = 1e-06 s`` when every run used one step, else per engine."""
    steps: dict[str, set[float]] = {}
    for r in runs:
        if r.run.get("timestep_s"):
            steps.setdefault(r.job.engine, set()).add(float(r.run["timestep_s"]))
    every = set().union(*steps.values()) if steps else set()
    if len(every) == 1:
        return f"dt = {next(iter(every)):g} s"
    if not every:
        return "dt: the adapters' defaults"
    return "dt: " + ", ".join(f"{e} {'/'.join(f'{t:g}' for t in sorted(ts))} s"
                              for e, ts in sorted(steps.items()))


def points_text(spec: Any, runs: list[JobResult]) -> str:
    """The numeric axis values of ``runs`` for a caption: ``V0 = 0.5, 1 m/s`` (the impact
    velocity by the spec's symbol, where the scenario has one), else each numeric axis's,
    ``h = 0.2 m``."""
    parts = []
    for a in spec.axes:
        if a.categorical or ("velocity_m_s" in spec.axis_names and a.name != "velocity_m_s"):
            continue  # (a scenario with an impact velocity is named by it alone)
        parts.append(spec.values_text(a, sorted({float(r.job.get(a.name)) for r in runs
                                                 if r.job.get(a.name) is not None})))
    return "; ".join(parts)


def modes_text(runs: list[JobResult]) -> str:
    from impactbench.engines.base import MODES

    present = {r.job.mode for r in runs}
    return "modes " + ", ".join(m for m in MODES if m in present)



def _axis_format(column: str) -> str:
    """A point's label format from its axis column: ``θ (°)`` → ``θ = {:g} °``."""
    name, _, unit = column.partition(" (")
    return f"{name} = {{:g}}" + (f" {unit.rstrip(')')}" if unit else "")


def _figures(ctx: ReportContext) -> None:
    """Every report plot into ``ctx.fig_dir``, registered on ``ctx`` with its caption.

    Groups: ``heatmap:<scenario>``, ``history:<scenario>``, ``extra:<scenario>``,
    ``work_precision``. Each caption names scenario, modes, timesteps and velocities."""
    cfg, df, fig_dir = ctx.cfg, ctx.df, ctx.fig_dir
    matrix_runs = [r for r in ctx.results if r.job.study == "matrix"]
    # a rigid contact's impulse/dt is no force history: leave such runs out of F(t) and F–x
    drawable = [r for r in matrix_runs if r.history and scenarios.get(r.job.scenario).has_history
                and "peak_force_n" not in r.run.get("not_comparable", {})]
    groups: dict[tuple, list[JobResult]] = {}
    for r in drawable:
        groups.setdefault(r.job.reference_key, []).append(r)
    loops: dict[str, list] = {}
    # by scenario, then by point: categorical axes first, numbers numerically
    for key, runs in sorted(groups.items(), key=lambda kv: _point_order(kv[0])):
        scenario, point, params = key
        spec = scenarios.get(scenario)
        ref = plots.reference_history_for(spec.build(point, params))
        hist = {(r.job.engine, r.job.mode): r.history for r in runs}
        how = f"{modes_text(runs)}; {timestep_text(runs)}"
        title = point_title(spec, point)
        unit, label = spec.history_unit
        path = ctx.draw(plots.force_time, hist, ref, title, how,
                        fig_dir / f"report_force_{spec.figure_name(point)}.png", unit, label)
        ctx.add_figure(path, f"F(t), {title}; {how}", f"history:{scenario}")
        loops.setdefault(scenario, []).append((title, how, point, hist, ref))
    for spec in scenarios.specs():
        runs = [r for r in matrix_runs if r.job.scenario == spec.name]
        spec.report_figures(ctx, runs, loops.get(spec.name, []))
        if not runs:
            continue
        how = f"{points_text(spec, runs)}; {modes_text(runs)}; {timestep_text(runs)}"
        name = f"report_error_heatmap_{spec.name.replace('-', '_')}.png"
        path = ctx.draw(plots.error_heatmap, df, spec, how, fig_dir / name)
        ctx.add_figure(path, f"|relative error| per engine and mode, {spec.title}; {how}",
                       f"heatmap:{spec.name}")
    studied = [r for r in ctx.results if r.job.study == "work_precision"]
    for name in dict.fromkeys(r.job.scenario for r in studied):  # the ball's first
        wp = [r for r in studied if r.job.scenario == name]
        spec = scenarios.get(name)
        numeric = [a for a in spec.axes if not a.categorical]
        panels = tuple((a.name, _axis_format(a.column)) for a in numeric)
        if name == scenarios.for_study("work_precision").name:
            vs = ", ".join(f"{v:g}" for v in sorted({r.job.velocity_m_s for r in wp}))
            how = f"{spec.velocity_symbol} = {vs} m/s; {modes_text(wp)}; {timestep_text(wp)}"
            path = ctx.draw(plots.work_precision, df[df.scenario == name], spec.headline, how,
                            fig_dir / "report_work_precision.png")
        else:
            where = "; ".join(
                _axis_format(a.column).replace("{:g}", ", ".join(
                    f"{v:g}" for v in sorted({dict(r.job.point)[a.name] for r in wp})))
                for a in numeric)
            how = f"{where}; {modes_text(wp)}; {timestep_text(wp)}"
            stem = spec.figure_stem or name.replace("-", "_")
            path = ctx.draw(plots.work_precision, df[df.scenario == name], spec.headline, how,
                            fig_dir / f"report_work_precision_{stem}.png", panels=panels,
                            title=spec.title.lower())
        ctx.add_figure(path, f"Work–precision, {spec.title.lower()}; {how}", "work_precision")
    pr = [r for r in ctx.results if r.job.study == "practical"]
    if pr:
        spec = scenarios.get(pr[0].job.scenario)
        b = cfg_parameter(cfg, spec.name, "damping_s_per_m")
        how = f"{modes_text(pr)}; {timestep_text(pr)}"
        path = ctx.draw(practical.plot, df, b, how, fig_dir / "report_practical_restitution.png")
        ctx.add_figure(path, f"Restitution at practical timesteps, {spec.title.lower()}; "
                       f"{how}", "practical")


def point_title(spec: scenarios.ScenarioSpec, point: scenarios.Point) -> str:
    """``Ball on plate, V0 = 2 m/s`` or ``Rigid–flexible linear/linear, v1 = 2 m/s``."""
    text = spec.point_text(point)
    cats = any(a.categorical for a in spec.axes)
    return f"{spec.title} {text}" if cats else f"{spec.title}, {text}"


def _point_order(key: tuple) -> tuple:
    scenario, point, _ = key
    spec = scenarios.get(scenario)
    values = dict(point)
    return (scenario, tuple(str(values[a.name]) for a in spec.axes if a.categorical),
            tuple(float(values[a.name]) for a in spec.axes if not a.categorical))


def cfg_parameter(cfg: config_mod.ReportConfig, scenario: str, name: str) -> Any:
    """A physical parameter of a scenario: the config's value, else the scenario default."""
    sm = next((s for s in cfg.scenarios if s.name == scenario), None)
    if sm is not None and name in sm.parameters:
        return sm.parameters[name]
    return getattr(scenarios.get(scenario).cls(), name)


def render(out_dir: Path, cfg: config_mod.ReportConfig, df: pd.DataFrame,
           meta: dict[str, Any], results: list[JobResult], *,
           show_progress: bool = False, store: Any = None,
           workers: int | None = None, pool: Any = None,
           background: dict[str, Any] | None = None) -> list[Path]:
    """Write the plots, ``README.md`` and ``index.html`` of a report into ``out_dir``.

    ``df`` is the tidy results table, ``meta`` what ``metadata.json`` holds, ``results`` the
    runs with their histories (for the force plots); ``show_progress``: sections that run
    work of their own (the real tosses' replays) count it on stderr and use ``store`` (the
    report's :class:`~impactbench.report_store.KeepWhatFits`) when theirs is the same file.
    Figures already in
    ``out_dir/figures`` that the report does not draw (the papers', the tuning plots) are
    indexed and linked. The figures are drawn in worker processes meanwhile
    (:class:`~impactbench.report_render.FigurePool`: ``workers`` of them, default one per
    core; 0 draws here; or ``pool``, one the caller started, closed here once the figures are
    drawn). ``background``: work started while the engines ran, by name (``ctx.background``).
    Returns the paths written."""
    fig_dir = out_dir / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    for old in fig_dir.glob("report_*.png"):
        old.unlink()
    from impactbench.report_render import FigurePool

    pool = pool if pool is not None else FigurePool(workers)
    with pool:  # the figures draw in worker processes meanwhile
        ctx = ReportContext(cfg, df, meta, out_dir, results, show_progress=show_progress,
                            store=store, pool=pool, background=dict(background or {}))
        _figures(ctx)
        engines = ", ".join(f"{k} {v}" for k, v in meta.get("engines", {}).items())
        intro = (f"Generated by `impactbench report` at commit "
                 f"`{meta.get('commit', 'unknown')}` from "
                 f"{meta.get('config') or 'an inline config'}. Engines: {engines}.")
        docs = render_documents(ctx, sections(), cfg.title, intro)
    paths = [out_dir / "README.md", out_dir / "index.html"]
    paths[0].write_text(docs["md"])
    paths[1].write_text(docs["html"])
    return paths + [out_dir / f.path for f in ctx.figures]


WRITE_FAULTS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS)
"""The OSErrors of a report folder's disk (full, over quota, read-only): a one-line error
naming the folder."""
REPORT_FILES = ("README.md", "index.html", "results.csv", "results.parquet", "metadata.json")


def owned_by_report(rel: Path) -> bool:
    """Files of a report folder the report rewrites (others, e.g. the papers' figures in
    ``figures/``, are kept)."""
    return str(rel) in REPORT_FILES or (rel.parent == Path("figures")
                                        and rel.name.startswith("report_"))


def scenario_parameters(cfg: config_mod.ReportConfig) -> list[dict[str, Any]]:
    """Every scenario of the config with all its physical parameters (SI; the config's
    values over the defaults), velocities, laws and timesteps — what metadata.json records."""
    out = []
    for sm in cfg.scenarios:
        spec = scenarios.get(sm.name)
        physics = spec.build(parameters=sm.parameters).to_dict()
        for key in spec.axis_names:
            physics.pop(key, None)
        entry: dict[str, Any] = {"scenario": sm.name}
        for a in spec.axes:
            entry[a.config_key] = list(sm.values(a.name))
        out.append({**entry, "parameters": physics, "timestep_s": dict(sm.timestep_s)})
    wp = cfg.work_precision
    if wp is not None:
        out.append({"scenario": "work_precision", "velocities_m_s": [wp.velocity_m_s],
                    "timesteps_s": list(wp.timesteps_s), "modes": list(wp.modes)})
    return out


def build(cfg: config_mod.ReportConfig, out_dir: Path, *, engines: list[str] | None = None,
          workers: int | None = None, show_progress: bool = True, store=None,
          fresh: bool = False, scheduler: str | None = None, yes: bool = True,
          keep_unchanged: bool = False) -> Report:
    """Run the matrix of ``cfg`` and write every report file into ``out_dir``.

    Holds the folder's writer lock throughout; runs come from ``store`` where finished
    (``fresh``: run all again); the files are written into a temporary folder beside
    ``out_dir`` and swapped in only when complete, so an error or Ctrl-C leaves the previous
    report intact. A store whose disk fills up keeps the runs it had room for and the report
    is written from this run's results (:mod:`impactbench.report_store`; one stderr line).
    """
    from impactbench import publish

    t0 = time.perf_counter()
    commit = git_commit(exclude=out_dir)  # before anything is written
    with publish.writer_lock(out_dir):
        jobs = plan(cfg, engines)
        replays = [s for s in cfg.scenarios if scenarios.get(s.name).measured]
        if not jobs and not replays:
            tables = " or ".join(f"[{s.table}] {s.axes[0].config_key}" for s in
                                 scenarios.specs() if s.axes and not s.measured)
            data = " or ".join(f"[{s.table}]" for s in scenarios.specs() if s.measured)
            raise ValueError(f"config {cfg.source or '<inline>'}: nothing to run (no "
                             f"{tables}, no [work_precision] timesteps_s"
                             + (f", no {data} table" if data else "") + "); see "
                             "impactbench/data/default.toml")
        update, close = progress_bar(len(jobs)) if show_progress else ((lambda n: None),
                                                                        (lambda: None))
        if store is not None:  # a full disk ends the store's writes, not the report
            store = KeepWhatFits(store)
        from impactbench.report_render import FigurePool

        # the figures' worker processes, started now when a section has work that needs no
        # runs (the reference model's replay): it goes on while the engines run
        pool = FigurePool(None if scheduler else workers)
        try:
            background = _background(cfg, store, pool)
            try:
                results = run_jobs(jobs, workers, progress=update, store=store, fresh=fresh,
                                   scheduler=scheduler, yes=yes, limits=cfg.limits)
            finally:
                close()
        except BaseException:
            pool.end()
            raise
        if store is not None and store.full is not None:
            store.say_full(store.kept_of(jobs), len(jobs))
        try:
            with publish.staged(out_dir, owned_by_report) as stage:
                rep = _write(cfg, stage, results, engines, commit, t0, previous=out_dir,
                             keep_unchanged=keep_unchanged, show_progress=show_progress,
                             workers=None if scheduler else workers,
                             store=store, pool=pool, background=background)
        except KeyboardInterrupt:  # every run is stored; only the rendering is lost
            raise Interrupted(len(results), len(jobs), store is not None) from None
        except OSError as exc:  # the report's own disk is full or read-only
            if exc.errno not in WRITE_FAULTS:
                raise
            kept = "; its runs are in the store" if store is not None and store.full is None \
                else ""
            raise ValueError(f"out = '{out_dir}': cannot write the report "
                             f"({exc.strerror or exc}){kept}") from None
        finally:  # closed by the rendering; else (a kept report, an error) ended here
            pool.end()
    rep.out_dir = out_dir
    rep.files = [out_dir / f.relative_to(stage) for f in rep.files]
    return rep


def _background(cfg: config_mod.ReportConfig, store: Any, pool: Any) -> dict[str, Any]:
    """The sections' work that needs no runs (:meth:`~impactbench.scenarios.spec.
    ScenarioSpec.report_background` of each measured scenario), started in ``pool``'s workers
    (:meth:`~impactbench.report_render.FigurePool.call`; here, when asked for, where the
    pool has no workers)."""
    from impactbench.report_sections import section_store

    work: dict[str, Any] = {}
    own = section_store(cfg, store)
    for sm in cfg.scenarios:
        spec = scenarios.get(sm.name)
        if spec.measured and spec.table in cfg.raw:
            work.update(spec.report_background(cfg, sm, own))
    if work:
        pool.start()
    return {name: pool.call(fn) for name, fn in work.items()}


def render_key(df: pd.DataFrame, results: list[JobResult], meta: dict[str, Any],
               cfg: config_mod.ReportConfig, fig_dir: Path) -> str:
    """A hash of everything the rendered files depend on: the results table and histories,
    the metadata shown (commit, versions, parameters, failed runs; not wall times), the
    config, impactbench's source and templates, and the other figures ``figures/`` indexes."""
    import hashlib

    from impactbench.store import impactbench_version

    h = hashlib.sha256()
    h.update(df.to_csv(index=False).encode())
    for r in results:
        for name in sorted(r.history):
            h.update(f"{r.job.id}/{name}".encode())
            # + 0.0 turns −0.0 into 0.0: the store's DOUBLE[] keeps no sign of zero, and a
            # plot does not show one (Newton's histories start at −0.0)
            h.update((r.history[name] + 0.0).tobytes())
    shown = {k: v for k, v in meta.items()
             if k not in ("runs", "wall_s", "command", "content_key", "render_key")}
    h.update(json.dumps(shown, sort_keys=True, default=str).encode())
    h.update(f"{cfg.title}\0{impactbench_version()}".encode())
    templates = Path(__file__).parent / "templates"
    for path in sorted(templates.rglob("*")) if templates.is_dir() else ():
        if path.is_file():
            h.update(path.name.encode())
            h.update(path.read_bytes())
    # (the PNGs: what the index links; not ``impactbench figures``' manifest beside them)
    others = sorted(p.name for p in fig_dir.glob("*.png") if not p.name.startswith("report_")) \
        if fig_dir.is_dir() else []
    h.update("\0".join(others).encode())
    return h.hexdigest()[:16]


def _unchanged(previous: Path | None, key: str) -> bool:
    """True when ``previous`` holds a complete report rendered from the same inputs."""
    return previous is not None and _same(previous, "render_key", key)


def _same(previous: Path, name: str, key: str) -> bool:
    """True when ``previous`` holds a complete report whose metadata has this key."""
    try:
        old = json.loads((previous / "metadata.json").read_text())
    except (OSError, ValueError):
        return False
    return old.get(name) == key and all((previous / n).is_file() for n in REPORT_FILES)


def _write(cfg: config_mod.ReportConfig, out_dir: Path, results: list[JobResult],
           engines: list[str] | None, commit: str, t0: float,
           previous: Path | None = None, keep_unchanged: bool = False,
           show_progress: bool = False, store: Any = None,
           workers: int | None = None, pool: Any = None,
           background: dict[str, Any] | None = None) -> Report:
    """Write results.csv/.parquet, metadata.json and the rendered report into ``out_dir``.

    When ``previous`` (the folder being replaced) was rendered from the same inputs
    (:func:`render_key`), its files are kept (hard links) and only metadata.json is new:
    the rendering would give the same bytes. With ``keep_unchanged``, a previous report whose
    results differ only in wall times (``content_key``) is kept whole, metadata included."""
    df = pd.DataFrame(tidy(results))
    if not df.empty:
        df = df.sort_values(sort_columns(), kind="stable").reset_index(drop=True)
    engine_versions = {}
    for r in results:
        if r.run.get("engine_version"):
            engine_versions.setdefault(r.job.engine, r.run["engine_version"])
    for e in (engines or cfg.engines):
        engine_versions.setdefault(e, "unavailable")
    meta = {
        "commit": commit,
        "config": cfg.source or "an inline config",
        "config_hash": cfg.hash,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "engines": dict(sorted(engine_versions.items())),
        "libraries": _library_versions(),
        "metrics_per_scenario": {k: list(v) for k, v in scenarios.metric_names().items()},
        "runs": [{"id": r.job.id, "status": r.run["status"], "wall_s": r.run.get("wall_s"),
                  "timestep_s": r.run.get("timestep_s"), "stored": r.cached}
                 for r in results],
        "command": " ".join(["impactbench", *sys.argv[1:]]) if sys.argv else "",
        "scenarios": scenario_parameters(cfg),
        "failed_runs": [{"id": r.job.id, "status": r.run["status"],
                         "message": r.run.get("message", "")}
                        for r in results if r.run["status"] != "ok"],
    }
    meta["content_key"] = render_key(df.drop(columns=["wall_s"], errors="ignore"), results,
                                     meta, cfg, out_dir / "figures")
    meta["render_key"] = render_key(df, results, meta, cfg, out_dir / "figures")
    if keep_unchanged and previous is not None and _same(previous, "content_key",
                                                          meta["content_key"]):
        # the same results apart from wall times: the previous folder, byte for byte
        from impactbench.publish import link_tree

        link_tree(previous, out_dir, lambda rel: not owned_by_report(rel))
        files = [out_dir / rel for rel in (Path(n) for n in REPORT_FILES)]
        old = pd.read_csv(previous / "results.csv", keep_default_na=False, na_values=[""])
        return Report(out_dir, old, files, time.perf_counter() - t0, kept=True)
    if _unchanged(previous, meta["render_key"]):
        from impactbench.publish import link_tree

        link_tree(previous, out_dir, lambda rel: not owned_by_report(rel)
                  or rel == Path("metadata.json"))
        files = [out_dir / rel for rel in (Path(n) for n in REPORT_FILES)]
        files += sorted((out_dir / "figures").glob("report_*"))
        meta["wall_s"] = time.perf_counter() - t0
        (out_dir / "metadata.json").write_text(json.dumps(meta, indent=2, default=str) + "\n")
        return Report(out_dir, df, files, time.perf_counter() - t0)
    files = [out_dir / "results.csv", out_dir / "results.parquet"]
    df.to_csv(files[0], index=False)
    df.to_parquet(files[1], index=False)
    meta["wall_s"] = time.perf_counter() - t0
    (out_dir / "metadata.json").write_text(json.dumps(meta, indent=2, default=str) + "\n")
    files += [out_dir / "metadata.json",
              *render(out_dir, cfg, df, meta, results, show_progress=show_progress,
                      workers=workers, store=store, pool=pool, background=background)]
    return Report(out_dir, df, files, time.perf_counter() - t0)
