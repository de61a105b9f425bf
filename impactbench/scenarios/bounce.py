"""The bounce-to-rest scenario: the ball dropped on the plate, followed until it rests.

Physics: :class:`~impactbench.reference.bounce_scenario.Bounce` (the head-on ball's
Hunt–Crossley contact, gravity throughout); reference: :mod:`impactbench.reference.bounce`
(exact flights, every contact integrated with gravity). One point per drop height h (m).

What is measured, alike from the reference and from every engine's record
(:func:`bounces_of`): the apex of every flight after the first impact (the largest gap
max(−x) between two contacts), the impact and rebound speeds around each contact, the number
of bounces whose apex exceeds 1 mm and when the last of them left the plate; then, where the
ball came to rest (:mod:`impactbench.engines.bounce`), its mean overlap over the last
0.1 s against the static sink (m·g/c)^(1/n) and the largest speed there (the jitter).
Where and why the engine stopped bouncing is said in ``stop_reason``: at a restitution
velocity threshold the engine reports, or by its contact's own losses. An apex above the
one before it (or the first above the drop) is energy created: ``energy_ratio`` over 1, so
the run is ``implausible``, never ``ok``.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from impactbench.scenarios.spec import Axis, Flag, ScenarioSpec

NAME = "bounce"

METRICS = ("first_apex_m", "bounces_above_1mm", "last_bounce_time_s", "rest_sink_m",
           "rest_jitter_m_s")
"""Scalar metrics of a results row (the sequences are in the run object)."""

APEX_COUNT_M = 1e-3
"""The apex a bounce must exceed to count (m; the reference's ``APEX_COUNT_M``)."""
SETTLE_S = 0.1
"""The window at rest the sinking and jitter are read over (s; the engines' ``SETTLE_S``)."""

FLAGS = (
    Flag("height", "height_m", "drop height h: the ball's lowest point above the plate at "
         "release, from rest (m)"),
    Flag("mass", "mass_kg", "ball mass (kg)"),
    Flag("stiffness", "stiffness", "Hunt–Crossley stiffness c (N/m^n)"),
    Flag("exponent", "exponent", "force-law exponent n (1.5 Hertz)"),
    Flag("damping", "damping_s_per_m", "Hunt–Crossley damping b (s/m)"),
    Flag("radius", "radius_m", "ball radius R (m)"),
    Flag("gravity", "gravity_m_s2", "gravity g (m/s², > 0)"),
    Flag("max-time", "max_time_s", "time cap (s): a ball still moving then is max_time"),
)


@dataclass
class Bounces:
    """The bounces read from one record (SI; ``apex_heights_m[k]`` after contact k)."""

    apex_heights_m: list[float]
    impact_speeds_m_s: list[float]
    rebound_speeds_m_s: list[float]
    leave_times_s: list[float]

    @property
    def above(self) -> list[int]:
        return [k for k, a in enumerate(self.apex_heights_m) if a > APEX_COUNT_M]


def _runs(mask: Any) -> list[tuple[int, int]]:
    """[start, stop) index ranges of the True runs of ``mask`` (a boolean array)."""
    import numpy as np

    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def bounces_of(rec: Any) -> Bounces:
    """The flights between contacts of an engine record (contact: the engine reports a
    force, F > 0). Each flight that ends in a contact gives an apex max(−x), the speed the
    ball left with (−ẋ at its first sample) and arrived with (ẋ at its last), and when it
    left (s). The fall before the first contact and a flight cut by the end are not bounces."""
    import numpy as np

    force = rec.normal_force_n
    contacts = _runs(force > 0.0)
    out = Bounces([], [], [], [])
    if not contacts:
        return out
    x, v, t = rec.penetration_m, rec.penetration_rate_m_s, rec.time_s
    out.impact_speeds_m_s.append(float(v[contacts[0][0] - 1]) if contacts[0][0] else
                                 float(v[0]))
    for (_, stop), (start, _) in itertools.pairwise(contacts):
        out.apex_heights_m.append(float(np.max(-x[stop:start])))
        out.rebound_speeds_m_s.append(float(-v[stop]))
        out.leave_times_s.append(float(t[stop]))
        out.impact_speeds_m_s.append(float(v[start - 1]))
    return out


def metrics_of_record(rec: Any, b: Bounces | None = None) -> dict[str, Any]:
    """The scenario's metrics and sequences of an engine record (see the module; ``b``: its
    bounces, when already read)."""
    import numpy as np

    b = bounces_of(rec) if b is None else b
    above = b.above
    settled = bool(rec.meta.get("settled", False)) and len(rec) > 0
    if settled:
        window = rec.time_s >= rec.meta.get("rest_from_s", rec.time_s[-1] - SETTLE_S)
        sink = float(np.mean(rec.penetration_m[window]))
        jitter = float(np.max(np.abs(rec.penetration_rate_m_s[window])))
    else:
        sink = jitter = math.nan
    return {
        "first_apex_m": b.apex_heights_m[0] if b.apex_heights_m else 0.0,
        "bounces_above_1mm": len(above),
        "last_bounce_time_s": b.leave_times_s[above[-1]] if above else math.nan,
        "rest_sink_m": sink,
        "rest_jitter_m_s": jitter,
        "apex_heights_m": b.apex_heights_m,
        "impact_speeds_m_s": b.impact_speeds_m_s,
        "rebound_speeds_m_s": b.rebound_speeds_m_s,
    }


def stop_reason(rec: Any, b: Bounces) -> str:
    """Where the engine stopped bouncing (above 1 mm) and why, in words."""
    n = len(b.above)
    if not b.impact_speeds_m_s:
        return "no contact"
    # apex k follows impact k: the first apex at or below 1 mm, n, followed impact n
    last = b.impact_speeds_m_s[min(n, len(b.impact_speeds_m_s) - 1)]
    where = f"after {n} bounce{'s' if n != 1 else ''} above 1 mm"
    threshold = rec.meta.get("bounce_threshold_m_s")
    if threshold is not None and 0.0 < last < float(threshold):  # (approaching, below it)
        return (f"{where}: the next impact, at {last:.3g} m/s, is below the engine's "
                f"restitution threshold {float(threshold):g} m/s (no bounce below it)")
    if not rec.meta.get("settled", False):
        return f"{where}; still moving at the time cap"
    return f"{where}: its contact's own losses (next impact at {last:.3g} m/s)"


def _sink_text(run: dict[str, Any], ref: dict[str, Any]) -> str:
    """``1.2e-06 m (3.4e-04 m/s); static 1.49e-07`` — or why there is none."""
    sink, jitter = run.get("rest_sink_m"), run.get("rest_jitter_m_s")
    static = f"static {float(ref.get('static_sink_m', math.nan)):.3g}"
    if not (isinstance(sink, float) and math.isfinite(sink)):
        return f"never at rest; {static}"
    return f"{sink:.3g} ({float(jitter):.2g} m/s); {static}"


@lru_cache(maxsize=64)
def _reference(scenario: Any) -> dict[str, Any]:
    from impactbench.reference import bounce

    return bounce.metrics(scenario)


@dataclass(frozen=True)
class BounceSpec(ScenarioSpec):
    """The bounce to rest: its dataclass, the reference sequence, the bounces of a record,
    plausibility (overlap over R, the largest apex growth) and the ball's tuned files."""

    @property
    def cls(self) -> type:
        from impactbench.reference.bounce_scenario import Bounce

        return Bounce

    def reference_metrics(self, scenario: Any) -> dict[str, Any]:
        """The reference's ``reference bounce --json`` object (cached per scenario: ~1 s)."""
        return dict(_reference(scenario))

    def metrics_of(self, record: Any, scenario: Any) -> dict[str, Any]:
        return {k: v for k, v in metrics_of_record(record).items() if k in METRICS}

    def run_details(self, record: Any, scenario: Any, mode: str) -> dict[str, Any]:
        """The sequences (``apex_heights_m``, ``impact_speeds_m_s``, ``rebound_speeds_m_s``),
        ``static_sink_m``, ``stop_reason`` and the engine's ``bounce_threshold_m_s``."""
        b = bounces_of(record)
        got = metrics_of_record(record, b)
        out = {k: got[k] for k in ("apex_heights_m", "impact_speeds_m_s",
                                   "rebound_speeds_m_s")}
        out["static_sink_m"] = scenario.static_sink_m
        out["stop_reason"] = stop_reason(record, b)
        out["bounce_threshold_m_s"] = record.meta.get("bounce_threshold_m_s")
        return out

    def run_errors(self, run: Any, metrics: Any, reference: Any, resolved: Any
                   ) -> dict[str, float]:
        """Relative errors; the jitter at rest is reported, not compared (the reference's
        is 0)."""
        out = super().run_errors(run, metrics, reference, resolved)
        out["rest_jitter_m_s"] = math.nan
        return out

    def measure(self, scenario: Any, rec: Any, metrics: Any) -> dict[str, float]:
        """``penetration_ratio``: the deepest sinking over R — at rest, or in a contact beyond
        the step's own overlap (a discrete engine may cross the surface by one step's travel
        at the impact speed, v·dt + g·dt², before any contact acts; a rigid contact at
        1/240 s and 2 m/s shows 8 mm, 0.57 R, that no contact setting can avoid).
        ``energy_ratio``: the largest growth of an apex over the one before it, a bounce above
        1 mm (the first over the drop height), each apex given the sampling error of a
        parabola sampled at the step dt, g·dt²/8, in its favour: over 1, energy was created
        (by the contact, or by a position correction that lifts the ball)."""
        from impactbench.plausibility import overlaps

        b = bounces_of(rec)
        dt = float(rec.meta.get("timestep_s") or 0.0)
        step, pen = overlaps(rec, dt, scenario.gravity_m_s2)
        sink = float(metrics.get("rest_sink_m", math.nan))
        if math.isfinite(sink):
            pen = max(pen, sink)
        slack = scenario.gravity_m_s2 * dt * dt / 8.0
        apexes = [scenario.height_m, *b.apex_heights_m]
        growth = [max(0.0, after - slack) / (before + slack)
                  for before, after in itertools.pairwise(apexes) if before > APEX_COUNT_M]
        return {"penetration_ratio": pen / scenario.radius_m,
                "step_overlap_ratio": step / scenario.radius_m,
                "energy_ratio": max(growth, default=math.nan)}

    def report_tables(self, ctx: Any, runs: list) -> list[dict[str, Any]]:
        """"Where and why each engine stops": per run, its bounces above 1 mm against the
        reference's, the first apex, where and why it stopped bouncing, the sinking and
        jitter at rest against the static sink, and energy created."""
        from impactbench.plots import _order
        from impactbench.report_render import Cell, Table, band, format_error

        rows = []
        for r in sorted(runs, key=lambda r: (float(r.job.get("height_m")),
                                             _order(r.job.engine, r.job.mode))):
            run, ref = r.run, r.run.get("reference") or {}
            status = str(run.get("status"))
            measured = status in ("ok", "max_time", "implausible")
            err = (run.get("rel_error") or {}).get("first_apex_m")
            growth = (run.get("plausibility") or {}).get("energy_ratio")
            rows.append([
                f"{float(r.job.get('height_m')):g}", r.job.engine, r.job.mode,
                f"{float(run.get('timestep_s') or math.nan):.4g}",
                Cell(status, "" if status == "ok" else "fail", str(run.get("message") or "")),
                f"{run.get('bounces_above_1mm', '—') if measured else '—'} "
                f"/ {ref.get('bounces_above_1mm', '—')}",
                Cell(f"{run['first_apex_m']:.3g} ({format_error(err)})", band(err))
                if measured and err is not None and math.isfinite(err) else Cell("—", "na"),
                _sink_text(run, ref) if measured else "—",
                f"×{growth:.3g}" if isinstance(growth, float) and math.isfinite(growth)
                and growth > 1.0 else "",
                Cell(str(run.get("stop_reason") or run.get("message") or ""), wrap=True),
            ])
        if not rows:
            return []
        columns = ["h (m)", "engine", "mode", "dt (s)", "status", "bounces > 1 mm (ref)",
                   "first apex (m)", "at rest: sink (jitter)", "apex growth", "where and why "
                   "it stops"]
        note = ("Each engine at its step, dropped from rest: its bounces above 1 mm beside the "
                "reference's, the first apex and its error, the mean overlap over the last "
                "0.1 s at rest beside the reference's static sink (m·g/c)^(1/n) with the "
                "largest speed there (jitter; — when it never came to rest), the largest "
                "growth of an apex over the one before (energy created: over ×1.01 the run "
                "is implausible), and where it stopped bouncing and why: at the restitution "
                "velocity threshold the engine reports, or by its contact's own losses.")
        return [{"title": "Where and why each engine stops", "note": note,
                 "table": Table(columns, rows, text_columns=5, prose_columns=1)}]

    def report_figures(self, ctx: Any, runs: list, loops: list) -> None:
        """Per drop height: the apex of each bounce against its number (log scale), the
        reference in black, one colour per engine, one marker per mode."""
        from impactbench.report import modes_text, timestep_text

        sm = next((s for s in ctx.cfg.scenarios if s.name == self.name), None)
        params = sm.parameters if sm is not None else {}
        for h in sorted({float(r.job.get("height_m")) for r in runs}):
            at = [r for r in runs if float(r.job.get("height_m")) == h]
            scenario = self.build((("height_m", h),), params)
            how = f"{modes_text(at)}; {timestep_text(at)}"
            path = ctx.draw(apex_figure, at, self.reference_metrics(scenario), scenario,
                            ctx.fig_dir / f"report_bounce_apexes_h{h:g}.png", how)
            ctx.add_figure(path, f"Apex height against bounce number, dropped from h = {h:g} m "
                           f"(log scale; the reference in black); {how}",
                           f"extra:{self.name}")

    def load_tuned(self, engine: str, scenario: Any, timestep_s: float | None,
                   tuned_file: Any = None, variant: Any = None) -> Any:
        """The head-on ball's tuned file (the same body and contact) at this step, bound to
        this scenario: its provenance names the ball's file, and leaves out the impact speed
        and gravity it was fitted at (the bounce's first impact is √(2gh), gravity on)."""
        from impactbench import tuned

        if timestep_s is None:  # the run's step: the engine's builder's for the bounce
            from impactbench.engines.base import get_adapter

            timestep_s = get_adapter(engine).default_timestep_s(scenario, "tuned")
        params, prov = tuned.load_tuned_settings(engine, self.tuned_from, timestep_s,
                                                 tuned_file, variant)
        if prov is None:
            return params, prov
        prov = {k: v for k, v in prov.items()
                if k not in ("scenario_velocity_m_s", "scenario_gravity_m_s2")}
        prov.update(scenario=self.name, fitted_on=self.tuned_from)
        return params, prov


def apex_figure(runs: list, reference: dict[str, Any], scenario: Any, path: Any,
                how: str) -> Any:
    """Apex height (m, log) against bounce number: the reference's sequence as a black line,
    each run's (``apex_heights_m`` of its run object) in its engine's colour and its mode's
    marker; a run that failed is left out (its status is in the tables)."""
    import matplotlib.pyplot as plt

    from impactbench.plots import ENGINE_COLORS, MODE_MARKERS, MODE_STYLES, _order, _save, _title

    fig, ax = plt.subplots(figsize=(8.5, 4.8))
    ref = [a for a in reference["apex_heights_m"] if a > 0.0]
    ax.plot(range(1, len(ref) + 1), ref, color="black", lw=2,
            label=f"reference ({reference['bounces_above_1mm']} above 1 mm)")
    for r in sorted(runs, key=lambda r: _order(r.job.engine, r.job.mode)):
        apexes = [a for a in r.run.get("apex_heights_m") or [] if a > 0.0]
        if r.run.get("status") not in ("ok", "max_time", "implausible") or not apexes:
            continue
        engine, mode = r.job.engine, r.job.mode
        ax.plot(range(1, len(apexes) + 1), apexes, MODE_MARKERS.get(mode, "o"),
                ls=MODE_STYLES.get(mode, "-"), lw=0.8, ms=3.5, color=ENGINE_COLORS.get(engine),
                label=f"{engine} {mode} ({r.run.get('bounces_above_1mm', 0)})")
    ax.axhline(APEX_COUNT_M, color="0.5", lw=0.8, ls=":")
    ax.set_yscale("log")
    ax.set_ylim(bottom=1e-6, top=scenario.height_m * 1.5)
    ax.set_xlabel("bounce number")
    ax.set_ylabel("apex height above the plate (m)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=6.5, ncol=2, loc="upper right")
    _title(ax, f"Bounce to rest from h = {scenario.height_m:g} m: apexes (dotted: 1 mm)", how)
    fig.tight_layout()
    return _save(fig, path)


SPEC = BounceSpec(
    name=NAME,
    title="Bounce to rest",
    summary="the steel ball dropped on the plate and followed to rest, gravity on",
    metrics=METRICS,
    headline=("first_apex_m", "bounces_above_1mm", "rest_sink_m"),
    axes=(Axis("height_m", "heights_m", "h (m)", short="h"),),
    table="bounce",
    flags=FLAGS,
    gate_velocities_m_s=(),
    figure_stem="bounce",
    velocity_symbol="V1",
    tuned_from="ball-on-plate",
    descriptions={"height_m": "drop height h (m): the ball's lowest point above the plate, "
                              "released from rest"},
)
