"""Packaged advice: :func:`impactbench.advise.advise`'s answer for each engine at its customary
steps, written by ``impactbench advise --engine E --timestep S --write`` into
``impactbench/data/advice/<engine>_dt<step>.toml`` and read by the report's first section,
which reruns each at every phase of its step beside the engine's defaults and tuned files.

A file holds the chosen contact ``model``, the ``[params]`` (the engine's own ``custom`` keys),
the ``snippet`` to paste, what the advisor claimed (``plausible``, ``worst_error`` and one
``[[per_speed]]`` table per speed: the restitution's median and range over the phases) and its
``[provenance]`` (engine and impactbench versions, the step, speeds, phases, target and body).
The search is a fixed number of evaluations, so rewriting a file on the same versions gives
the same numbers.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

ADVICE_DIR = Path(__file__).parent / "data" / "advice"


def step_label(timestep_s: float) -> str:
    """A step in a file name as users say it: ``1_240s``, ``2ms``, ``10ms``, ``1e-05s``."""
    for den in (60, 120, 240, 480, 1200):
        if math.isclose(timestep_s * den, 1.0, rel_tol=1e-9):
            return f"1_{den}s"
    ms = timestep_s * 1e3
    if ms >= 0.1 and math.isclose(ms, round(ms, 3), rel_tol=1e-9):
        return f"{round(ms, 3):g}ms".replace(".", "p")
    return f"{timestep_s:g}s"


def advice_path(engine: str, timestep_s: float) -> Path:
    """Where the packaged advice for ``engine`` at ``timestep_s`` lives."""
    return ADVICE_DIR / f"{engine}_dt{step_label(timestep_s)}.toml"


def write(advice: Any, path: str | Path) -> Path:
    """Write an :class:`impactbench.advise.Advice` as an advice file (see the module)."""
    import tomli_w

    from impactbench.store import impactbench_version

    def clean(v: Any) -> Any:
        if isinstance(v, float) and not math.isfinite(v):
            return "nan"
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items() if x is not None}
        if isinstance(v, list | tuple):
            return [clean(x) for x in v]
        return v

    data = {
        "engine": advice.engine, "timestep_s": advice.timestep_s, "model": advice.model,
        "note": advice.note,
        "plausible": advice.plausible, "worst_error": clean(advice.worst_error),
        "snippet": advice.snippet, "params": clean(advice.params),
        "provenance": clean({
            "engine_version": advice.engine_version,
            "impactbench_version": impactbench_version(),
            "velocities_m_s": [r["velocity_m_s"] for r in advice.per_speed],
            "phases": list(advice.phases), "target": advice.target,
            "searched_on": advice.searched_on, "candidates": len(advice.tried),
            "stop": advice.stop, "scenario": advice.scenario,
            "command": f"impactbench advise --engine {advice.engine} --timestep "
                       f"{advice.timestep_s!r} --write"}),
        "per_speed": [clean(r) for r in advice.per_speed],
    }
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = ("# impactbench advice: the best contact settings at this step, judged at the worst "
            "of 8 phases\n# (impactbench advise; see impactbench/advice_files.py)\n"
            + tomli_w.dumps(data, multiline_strings=True))
    path.write_text(text)
    return path


def load(path: str | Path) -> dict[str, Any]:
    """An advice file's tables (ValueError, one line, when it is not one)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ValueError(f"advice file = {str(path)!r}: unreadable ({exc})") from None
    for key in ("engine", "timestep_s", "model", "params", "snippet"):
        if key not in data:
            raise ValueError(f"advice file = {str(path)!r}: missing {key!r}")
    return data


def packaged(engine: str, timestep_s: float) -> dict[str, Any] | None:
    """The packaged advice for ``engine`` at ``timestep_s`` (with ``file``: its name), or
    None."""
    path = advice_path(engine, timestep_s)
    if not path.is_file():
        return None
    data = load(path)
    if not math.isclose(float(data["timestep_s"]), timestep_s, rel_tol=1e-9):
        return None
    return {**data, "file": path.name}


def as_advice(data: dict[str, Any], speeds: tuple[float, ...] | None = None) -> Any:
    """An advice file's tables as an :class:`impactbench.advise.Advice` (what it claimed;
    ``speeds``: only those rows), for code that reads either."""
    from impactbench.advise import Advice

    prov = data.get("provenance", {})

    def num(v: Any) -> Any:
        return math.nan if v == "nan" else v

    rows = [{k: num(v) for k, v in r.items()} for r in data.get("per_speed", [])
            if speeds is None or any(math.isclose(r["velocity_m_s"], v) for v in speeds)]
    return Advice(data["engine"], float(data["timestep_s"]), data["model"],
                  dict(data["params"]), data["snippet"], bool(data.get("plausible")),
                  float(num(data.get("worst_error", math.nan))), rows,
                  phases=tuple(prov.get("phases", ())),
                  engine_version=prov.get("engine_version", ""),
                  target=prov.get("target", ""), searched_on=prov.get("searched_on", ""),
                  scenario=dict(prov.get("scenario", {})), stop=prov.get("stop", ""),
                  note=data.get("note", ""))


def packaged_advice(engine: str, timestep_s: float,
                    speeds: tuple[float, ...] | None = None) -> Any:
    """The packaged advice for ``engine`` at ``timestep_s`` as an
    :class:`impactbench.advise.Advice` (:func:`as_advice`); ValueError when there is none."""
    data = packaged(engine, timestep_s)
    if data is None:
        raise ValueError(f"timestep_s = {timestep_s!r}: no packaged advice for {engine} at it "
                         f"({advice_path(engine, timestep_s).name}; write it with "
                         f"`impactbench advise --engine {engine} --timestep {timestep_s!r} "
                         "--write`)")
    return as_advice(data, speeds)
