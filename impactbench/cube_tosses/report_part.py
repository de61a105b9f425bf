"""The cube tosses' part of the report's "Against real tosses" section (the spec's
:meth:`~impactbench.scenarios.spec.ScenarioSpec.report_part`): per engine, mode and published
parameter set — run through the one door (:func:`impactbench.matrix.run_jobs`, the engines'
cube-toss builders, the results store) — the tosses' median and quartiles of position and
rotation error, their distribution across tosses, and measured against simulated trajectories
of a best, a median and a worst toss; the reference model's replay first, the floor the
engines approach."""

from __future__ import annotations

import math
from typing import Any

from impactbench import scenarios
from impactbench.report_render import Cell, ReportContext, Table
from impactbench.report_sections import _section_store


def _quartiles(out: dict[str, Any], metric: str, fmt: str) -> Cell:
    med, q1, q3 = (float(out.get(f"{metric}_{s}", math.nan)) for s in ("median", "q1", "q3"))
    if not math.isfinite(med):
        return Cell("—", "na")
    return Cell(f"{med:{fmt}} [{q1:{fmt}}–{q3:{fmt}}]")


def _selection_text(tosses: str) -> str:
    return {"test": "the test split", "train": "the training split",
            "all": "every toss"}.get(tosses, f"tosses {tosses}")


def _replay_row(who: str, mode: str, param_set: str, out: dict[str, Any]) -> list[Cell]:
    """One row of the real-tosses table: who ran, mode, parameter set, tosses ok, the
    quartiles of both errors, their means and the run's message (a note under the table:
    :func:`footnoted`)."""
    status = str(out["status"])
    numbers = status in ("ok", "partial")
    n_ok = out.get("tosses", 0) - len(out.get("failed") or [])
    na = Cell("—", "na")
    return [Cell(who), Cell(mode), Cell(param_set),
            Cell(f"{n_ok}/{out.get('tosses', 0)}" if numbers else status,
                 "" if status == "ok" else "fail"),
            _quartiles(out, "position_error", ".3f") if numbers else na,
            _quartiles(out, "rotation_error_deg", ".1f") if numbers else na,
            Cell(f"{out['position_error_mean']:.3f} / {out['rotation_error_deg_mean']:.1f}")
            if numbers else na,
            Cell(str(out.get("message") or ""), wrap=True)]


_SUPERSCRIPTS = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


def footnoted(rows: list[list[Cell]], at: int) -> tuple[list[list[Cell]], list[str]]:
    """A table's trailing note column as numbered notes under it: each row without its last
    cell; a row with a note gets the note's number (superscript) after the text of its cell
    ``at``, the note as that cell's tooltip. The same note is one note. Returns the rows and
    the notes (``¹ text``), in order of first use."""
    numbers: dict[str, int] = {}
    out = []
    for row in rows:
        *cells, note = row
        text = (note.text if isinstance(note, Cell) else str(note)).strip()
        if text:
            n = numbers.setdefault(text, len(numbers) + 1)
            c = cells[at]
            cells[at] = Cell(f"{c.text} {str(n).translate(_SUPERSCRIPTS)}", c.band,
                             c.title or text, c.wrap)
        out.append(cells)
    return out, [f"{str(n).translate(_SUPERSCRIPTS)} {text}" for text, n in numbers.items()]


def replay_jobs(cfg: Any, spec: scenarios.ScenarioSpec, sm: Any,
                engines: Any = None) -> list:
    """The replays of one measured scenario in a report, as jobs (``study = real_tosses``,
    keeping their picked tosses' trajectories for the figures): per engine of its table
    (default: the report's ``engines``; a table's own list is kept to those), per mode (default
    :data:`~impactbench.config.REPLAY_MODES`), ``custom`` once per parameter set the engine
    has, in the table's order."""
    from impactbench.config import REPLAY_MODES
    from impactbench.matrix import Job

    table = cfg.raw.get(spec.table, {})
    chosen = list(engines) if engines is not None else list(cfg.engines)
    own = table.get("engines")
    engines = [e for e in own if engines is None or e in chosen] if own else chosen
    modes = table.get("modes", list(REPLAY_MODES))
    sets = table.get("param_sets", [])
    scenario = spec.build(parameters=sm.parameters)
    fields = tuple(sorted(sm.parameters.items()))
    jobs = []
    for engine in engines:  # the same door as every run: the engines' cube-toss builders
        for mode in modes:
            choices: list[tuple] = [()]
            if mode == "custom":
                choices = []
                for name in sets:
                    try:
                        scenario.engine_parameters(engine, mode, {"param_set": name}, None)
                        choices.append((("param_set", name),))
                    except ValueError:
                        pass  # this engine has no such set
            jobs += [Job(engine, spec.name, (), mode, None, fields, params,
                         study="real_tosses", keep_history=True) for params in choices]
    return jobs


def _replays(ctx: ReportContext, jobs: list, missing: list, tick: Any) -> dict[str, Any]:
    """Each job's result (by job id): the report's own (its runs, which had these jobs in
    its plan), the ``missing`` ones run here through the section's store."""
    from impactbench.engines.registry import stdout_to_stderr
    from impactbench.matrix import run_jobs

    wanted = {job.id for job in jobs}
    done = {r.job.id: r for r in ctx.results if r.job.id in wanted}
    if missing:
        store = _section_store(ctx)
        with stdout_to_stderr():
            got = run_jobs(missing, 0, progress=lambda n: tick(n) if n else None, store=store)
        if store.full is not None:  # said once per store: the report's own may have said it
            store.say_full(store.kept_of(missing), len(missing), f"{missing[0].scenario} replays")
        done.update((r.job.id, r) for r in got)
    return done


def report_part(ctx: ReportContext, spec: scenarios.ScenarioSpec, sm: Any) -> dict[str, Any]:
    """One data-driven scenario's part of "Against real tosses" (see :func:`real_tosses`).

    Its replays (:func:`replay_jobs`) come from the report's runs (planned beside the matrix,
    so they share its workers and store); called on its own (a context without them), the
    part runs them here. The figures of the best, median and worst toss are drawn from the
    trajectories each replay kept (:func:`~impactbench.cube_tosses.scenario.kept_history`),
    re-run only for a replay that kept none."""
    import impactbench.cube_tosses.plots as toss_plots
    from impactbench.cube_tosses.scenario import picks, trajectories, trajectories_of_history
    from impactbench.engines.registry import stdout_to_stderr

    table = ctx.cfg.raw.get(spec.table, {})
    scenario = spec.build(parameters=sm.parameters)
    which = _selection_text(scenario.tosses)
    rows, cdf, done = [], [], []
    from impactbench.cliutil import progress_bar

    jobs = replay_jobs(ctx.cfg, spec, sm, _report_engines(ctx, table))
    ran = {r.job.id for r in ctx.results}
    missing = [job for job in jobs if job.id not in ran]
    total = int(bool(table.get("model", True))) + len(missing)
    tick, close = (progress_bar(total, f"{spec.name} replay") if ctx.show_progress
                   else ((lambda n: None), (lambda: None)))
    if table.get("model", True):  # the reference model first: the floor the engines approach
        from impactbench.cube_tosses.scenario import MODEL_LABEL, model_run

        out = model_run(scenario, store=_section_store(ctx),
                        computed=ctx.background.get(f"{spec.name}:model"))
        tick(1)
        numbers = out["status"] in ("ok", "partial")
        rows.append(_replay_row(f"{MODEL_LABEL} ({out['engine_version']})", "fitted",
                                "reference.toml", out))
        if numbers:
            cdf.append((MODEL_LABEL, "reference", "fitted", out["per_toss"]))
    results = _replays(ctx, jobs, missing, tick)
    by_engine: dict[str, list] = {}
    for job in jobs:  # in the config's order (results come sorted by job id)
        by_engine.setdefault(job.engine, []).append(job)
    found = {job_id: r.run for job_id, r in results.items()}
    for engine, own in by_engine.items():
        outs = [(job, found[job.id]) for job in own]
        whys = {out["message"] for _, out in outs}
        if all(out["status"] == "unsupported" for _, out in outs) and len(whys) == 1:
            rows.append([Cell(engine), Cell("all"), Cell("—"), Cell("unsupported", "fail"),
                         Cell("—", "na"), Cell("—", "na"), Cell("—", "na"),
                         Cell(whys.pop(), wrap=True)])  # no replay in this engine at all
            continue
        for job, out in outs:
            param_set = dict(job.params).get("param_set")
            numbers = out["status"] == "ok"
            label = f"{engine} {job.mode}" + (f" {param_set}" if param_set else "")
            rows.append(_replay_row(f"{engine} {out.get('engine_version') or ''}".strip(),
                                    job.mode, param_set or "—", out))
            if numbers:
                cdf.append((label, engine, job.mode, out["per_toss"]))
                done.append((label, engine, job.mode, param_set, out,
                             results[job.id].history))
    close()
    step = next((d[4] for d in done), {})
    dt = float(step.get("timestep_s") or math.nan)
    dt_text = (f"1/{round(1 / dt)} s" if abs(1 / dt - round(1 / dt)) < 1e-6 / dt
               else f"{dt:.4g} s") if math.isfinite(dt) and dt > 0 else ""
    how = (f"{which} ({len(cdf[0][3]) if cdf else 0} tosses), "
           f"{'packaged ContactNets data' if not scenario.data else scenario.data}; "
           f"DAIR's protocol" + (f", dt = {dt_text}" if dt_text else ""))
    figures, trajs = [], []
    stem = spec.figure_stem or spec.name.replace("-", "_")
    if cdf:
        path = ctx.draw(toss_plots.error_cdf, cdf, how,
                        ctx.fig_dir / f"report_{stem}_error_cdf.png")
        figures.append(ctx.add_figure(path, f"Cumulative distribution of the errors across "
                                      f"tosses, {spec.title.lower()}; {how}",
                                      f"real_tosses:{spec.name}"))
    if table.get("trajectories", "best") == "best":  # each engine's best setting only
        best: dict[str, tuple] = {}
        for run in done:
            median = float(run[4]["position_error_median"])
            if run[1] not in best or median < float(best[run[1]][4]["position_error_median"]):
                best[run[1]] = run
        done = [run for run in done if best.get(run[1]) is run]
    for label, engine, mode, param_set, out, history in done:
        chosen = picks(out["per_toss"])
        got = trajectories_of_history(history)
        if [g["toss"] for g in got] != [t for _, t in chosen]:  # kept none: run them again
            with stdout_to_stderr():
                got = trajectories(engine, scenario, mode, [t for _, t in chosen],
                                   params={"param_set": param_set} if param_set else None,
                                   tuned=out.get("params") if mode == "tuned" else None)
        name = "_".join(x for x in (stem, engine, mode, param_set) if x)
        title = f"Measured and simulated, {label}"
        path = ctx.draw(toss_plots.trajectories, got, [p for p, _ in chosen], engine, title,
                        how, ctx.fig_dir / f"report_{name}_trajectories.png")
        trajs.append(ctx.add_figure(path, f"{title}: the best, median and worst toss by "
                                    f"position error; {how}", f"real_tosses:{spec.name}"))
    columns = ["engine", "mode", "parameter set", "tosses ok",
               "position error / width: median [q1–q3]",
               "rotation error (°): median [q1–q3]", "mean: position / rotation"]
    rows, notes = footnoted(rows, at=columns.index("tosses ok"))
    intro = (f"{spec.title}: {spec.summary}. Replayed: {which} of "
             + ("the packaged ContactNets tosses (DAIR Lab, BSD-3; 89 test and 367 training "
                "tosses by a hash of the toss id)" if not scenario.data
                else f"`{scenario.data}`")
             + f", cube h = {scenario.half_width_m:g} m, m = {scenario.mass_kg:g} kg, "
             f"I = {scenario.inertia_kg_m2:g} kg·m². Each toss starts from its measured state "
             "3 samples before the cube first comes within reach of the board (velocities "
             "refitted from the free flight, DAIR's protocol) and runs to the end of the "
             "recording; a toss's errors are the time means of |Δp| over the cube's width 2h "
             "and of the rotation angle between the simulated and measured orientations. "
             "Per engine: `default` is the engine out of the box at the protocol's step; "
             "`custom` with a parameter set applies its published values (`dair2022`: "
             "Acosta, Yang & Posa, RA-L 2022, fitted on all tosses, the test split included, "
             "so their test errors are not held out); `tuned` applies impactbench's own fit "
             "(nevergrad CMA-ES on the training split only, "
             "`impactbench tune --scenario cube-toss`), so its test errors are held out; `native` "
             "maps the reference model's fitted corner law into the engine's own contact (a "
             "spring–damper matching its restitution and duration at the tosses' median "
             "first touch, 1.10 m/s on an effective mass of 0.224 kg), and `injected` applies "
             "the model's own corner forces through the engine's integrator, its contact "
             "switched off, so its gap to the model is the engine's stepping. The "
             "first row is impactbench's reference model, the floor the engines approach: a "
             "rigid box with a Hunt–Crossley law at each corner and regularised Coulomb "
             "friction, integrated to convergence (scipy LSODA), fitted on training tosses "
             "(`impactbench/data/tuned/cube_toss/reference.toml`).")
    return {"title": f"{spec.title}: {which}", "intro": intro,
            "table": Table(columns, rows, text_columns=3), "notes": notes,
            "cdf": figures, "trajectories": trajs}


def _report_engines(ctx: ReportContext, table: Any) -> list[str] | None:
    """The engines a report ran (its results'), to which a table's own list is kept; None
    (every engine of the config) for a context without results."""
    ran = {r.job.engine for r in ctx.results}
    return [e for e in ctx.cfg.engines if e in ran] + sorted(ran - set(ctx.cfg.engines)) \
        if ran else None
