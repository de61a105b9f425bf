"""Tuned-parameter files: fitted native contact parameters per engine and scenario.

A file is TOML with a ``[parameters]`` table in the engine's own form (the keys each adapter
documents for ``tuned`` mode), plus provenance. The package ships defaults for the paper's
case in ``impactbench/data/tuned/<engine>_<scenario>.toml``; ``impactbench tune`` writes new ones
(:func:`write_tuned`): ``[parameters]``, ``[start]`` (the closed-form starting point),
``[provenance]`` (engine version, velocities, targets, weights, objective before/after,
timestep; no date or wall time, so the same tuning writes the same bytes) and ``[residuals]``.

The keys of ``[parameters]`` are checked against the engine's tuned keys (:func:`tuned_keys`):
an unknown one (MuJoCo's ``solimpp``) is a one-line error with the valid keys and a "did you
mean", never silently ignored. A scenario whose tuned mode fits keys of its own (the oblique
impact's friction knobs) has a module ``impactbench.engines.<scenario>_tuned`` with
``tuned_keys(engine)`` (:func:`own_keys_module`; :mod:`impactbench.engines.oblique_tuned`); its
files are written by its own fit (:mod:`impactbench.tuning.oblique`) in the same form
(``[parameters]``, ``[provenance]`` with engine, scenario, timestep and the scenario's fields
but its axes).
"""

from __future__ import annotations

import copy
import json
import math
import re
import tomllib
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Any

from impactbench.scenarios import spec_of

TUNED_DIR = Path(__file__).parent / "data" / "tuned"
_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def own_keys_module(scenario: str | None) -> str | None:
    """``impactbench.engines.<scenario>_tuned`` when it exists: the scenario's tuned files hold
    keys of its own (its ``tuned_keys(engine)``), not the ball's tuning spaces'; else None."""
    if not scenario:
        return None
    from importlib.util import find_spec

    name = f"impactbench.engines.{scenario.replace('-', '_')}_tuned"
    return name if find_spec(name) is not None else None


def tuned_path(engine: str, scenario: str) -> Path:
    """Where the packaged tuned file for ``engine`` and ``scenario`` lives."""
    return TUNED_DIR / f"{engine}_{scenario.replace('-', '_')}.toml"


def load_tuned(engine: str, scenario: str, path: Path | None = None) -> dict[str, Any] | None:
    """The ``[parameters]`` table of a tuned file; None when no file exists."""
    data = load_tuned_file(path if path is not None else tuned_path(engine, scenario))
    return None if data is None else data["parameters"]


def load_tuned_file(path: Path | str) -> dict[str, Any] | None:
    """All tables of a tuned file (``[parameters]`` checked); None when it does not exist.
    A file is parsed once while it is unchanged (its size and modification time: a report
    plans a thousand runs over a few dozen files); each call gets its own copy."""
    path = Path(path)
    try:
        st = path.stat()
    except OSError:
        return None
    if not path.is_file():
        return None
    key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    if key not in _PARSED:
        try:
            data = tomllib.loads(path.read_text())
        except UnicodeDecodeError:
            raise ValueError(f"tuned = {str(path)!r}: not a tuned file (not UTF-8 text)"
                             ) from None
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not valid TOML ({exc})") from None
        params = data.get("parameters")
        if not isinstance(params, dict):
            raise ValueError(f"{path}: [parameters] table is missing")
        _PARSED[key] = data
    return copy.deepcopy(_PARSED[key])


_PARSED: dict[tuple[str, int, int], dict[str, Any]] = {}
"""Tuned files parsed, by (resolved path, size, modification time in ns)."""


@cache
def tuned_keys(engine: str, scenario: str | None = None) -> tuple[str, ...] | None:
    """The keys a tuned file's ``[parameters]`` may hold for ``engine`` (what its ``tuned`` mode
    reads): what each of its tuning spaces writes (``Space.to_tuned``, every parameter set),
    plus the adapter's ``tuned_keys`` where it declares settings a fit holds fixed (Drake's
    ``discrete_contact_approximation``). None for an engine without a tuning space (a
    plug-in's), whose files are not checked. A ``scenario`` with keys of its own
    (:func:`own_keys_module`): those."""
    import importlib

    import numpy as np

    own = own_keys_module(scenario)
    if own is not None:
        return importlib.import_module(own).tuned_keys(engine)

    from impactbench.engines.base import EngineUnavailable
    from impactbench.engines.registry import spec
    from impactbench.engines.tuning_spaces import make_space
    from impactbench.scenarios import for_study

    engine_spec = spec(engine)
    keys: dict[str, None] = {}
    scenario = for_study("tuning").cls()
    for variant in engine_spec.variants:
        try:
            space = make_space(engine, scenario, variant)
        except (ImportError, EngineUnavailable):  # engine absent: the declared keys count
            continue
        keys.update(dict.fromkeys(space.to_tuned(np.array(space.start))))
    module, _, attr = engine_spec.adapter.partition(":")
    try:
        declared = getattr(getattr(importlib.import_module(module), attr), "tuned_keys", ())
    except ImportError:
        declared = ()
    keys.update(dict.fromkeys(declared))
    return tuple(keys) if keys else None


def check_tuned_keys(engine: str, parameters: Mapping[str, Any], where: str = "",
                     scenario: str | None = None) -> None:
    """A one-line ValueError for a key of ``parameters`` that ``engine``'s tuned mode does not
    read (``where``: the file, for the message; ``scenario``: :func:`tuned_keys`')."""
    valid = tuned_keys(engine, scenario)
    if valid is None:
        return
    for key in parameters:
        if key not in valid:
            from impactbench.config import did_you_mean

            raise ValueError(f"{where + ': ' if where else ''}parameters.{key}: not a {engine} "
                             f"tuned key{did_you_mean(key, valid)}; valid keys: "
                             f"{', '.join(valid)}")


TIMESTEP_RTOL = 1e-9


def _close(a: Any, b: Any) -> bool:
    try:
        a, b = float(a), float(b)
    except (TypeError, ValueError):
        return a == b
    return a == b or abs(a - b) <= TIMESTEP_RTOL * max(abs(a), abs(b))


def packaged_tuned_files(engine: str, scenario: str) -> list[Path]:
    """The packaged tuned files of ``engine`` and ``scenario`` (every fitted timestep)."""
    return sorted(TUNED_DIR.glob(f"{engine}_{scenario.replace('-', '_')}*.toml"))


def find_tuned(engine: str, scenario: str, timestep_s: float | None = None,
               variant: dict[str, Any] | None = None) -> Path:
    """The packaged tuned file fitted at ``timestep_s`` (and with the fixed engine settings of
    ``variant``, e.g. Drake's ``discrete_contact_approximation``); the main file
    (:func:`tuned_path`, fitted at 1e-6 s) when none matches — the run then reports the
    mismatch as ``unsupported`` (:func:`binding_mismatch`)."""
    for path in packaged_tuned_files(engine, scenario):
        data = load_tuned_file(path) or {}
        prov, params = data.get("provenance", {}), data.get("parameters", {})
        if timestep_s is not None and not _close(prov.get("timestep_s"), timestep_s):
            continue
        if timestep_s is None and path != tuned_path(engine, scenario):
            continue
        if all(params.get(k) == v for k, v in (variant or {}).items()):
            return path
    return tuned_path(engine, scenario)


def fitted_at(engine: str, scenario: str, timestep_s: float) -> bool:
    """Whether a packaged tuned file of ``engine`` and ``scenario`` was fitted at this step."""
    return any(_close((load_tuned_file(p) or {}).get("provenance", {}).get("timestep_s"),
                      timestep_s) for p in packaged_tuned_files(engine, scenario))


def load_tuned_settings(engine: str, scenario: str, timestep_s: float | None = None,
                        path: Path | str | None = None, variant: dict[str, Any] | None = None
                        ) -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
    """(parameters, provenance) of a tuned file (``path``, else the packaged one for this
    timestep and variant); (None, None) when no file exists."""
    path = Path(path) if path is not None else find_tuned(engine, scenario, timestep_s, variant)
    data = load_tuned_file(path)
    if data is None:
        if path is not None and not Path(path).exists() and path != tuned_path(engine, scenario):
            raise ValueError(f"tuned = {str(path)!r}: no such file")
        return None, None
    prov = data.get("provenance")
    shown = path.name if path.parent == TUNED_DIR else str(path)
    if not (isinstance(prov, dict) and (prov.get("engine", engine) != engine
                                        or prov.get("scenario", scenario) != scenario)):
        # (a file of another engine or scenario is reported by the binding check, naming it)
        check_tuned_keys(engine, data["parameters"], shown, scenario)
    return data["parameters"], (dict(prov, file=shown) if isinstance(prov, dict) else None)


def tuned_settings(engine: str, scenario: Any, timestep_s: float | None = None,
                   path: Path | str | None = None, variant: dict[str, Any] | None = None
                   ) -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
    """(parameters, provenance) of the tuned file a ``tuned`` run of ``scenario`` (an object)
    takes: its scenario's own (:meth:`~impactbench.scenarios.spec.ScenarioSpec.load_tuned`),
    else :func:`load_tuned_settings`."""
    own = spec_of(scenario).load_tuned(engine, scenario, timestep_s, path, variant)
    if own is not None:
        return own
    return load_tuned_settings(engine, spec_of(scenario).name, timestep_s, path, variant)


def tune_command(engine: str, scenario: Any, timestep_s: float) -> str:
    """The ``impactbench tune`` command line that fits ``engine`` to ``scenario`` at this step
    (``--scenario`` unless it is the ball's; the scenario's axes, which a fit sweeps, left
    out)."""
    from impactbench.scenarios import get

    spec = spec_of(scenario)
    if spec.tuned_from:  # its tuned files are another scenario's (the bounce's: the ball's)
        spec = get(spec.tuned_from)
    default = spec.cls()
    axes = {a.name for a in spec.axes}
    flags = [f"--{f.flag} {getattr(scenario, f.field):g}" for f in spec.flags
             if f.field not in axes and hasattr(scenario, f.field)
             and getattr(scenario, f.field) != getattr(default, f.field)]
    which = [] if "tuning" in spec.studies else [f"--scenario {spec.name}"]
    return " ".join(["impactbench tune", *which, f"--engine {engine}", *flags,
                     f"--timestep {timestep_s:g}", "--out tuned.toml"])


def binding_mismatch(provenance: dict[str, Any], engine: str, scenario: Any,
                     timestep_s: float) -> str:
    """Why a tuned file does not apply to this run ('' when it does).

    A tuned file is bound to the engine, scenario (every physical parameter except the impact
    velocity) and timestep it was fitted for; the message names the first differing field and
    the ``impactbench tune`` command that fits this case."""
    name = spec_of(scenario).name
    diffs: list[str] = []
    if provenance.get("engine", engine) != engine:
        diffs.append(f"engine = {provenance['engine']!r} (this run: {engine!r})")
    if provenance.get("scenario", name) != name:
        diffs.append(f"scenario = {provenance['scenario']!r} (this run: {name!r})")
    for field in scenario.field_names():
        key = f"scenario_{field}"
        if field == "velocity_m_s" or key not in provenance:
            continue
        if not _close(provenance[key], getattr(scenario, field)):
            diffs.append(f"{field} = {provenance[key]!r} (this run: {getattr(scenario, field)!r})")
    if "timestep_s" in provenance and not _close(provenance["timestep_s"], timestep_s):
        diffs.append(f"timestep_s = {provenance['timestep_s']!r} (this run: {timestep_s!r})")
    if not diffs:
        return ""
    where = provenance.get("file", "the tuned file")
    return (f"{where} was fitted for {'; '.join(diffs)}: its parameters do not apply here; "
            f"fit them with `{tune_command(engine, scenario, timestep_s)}`")


def _key(key: str) -> str:
    return key if _BARE_KEY.match(key) else json.dumps(key)


def _value(value: Any) -> str:
    """A TOML value: string, bool, int, float (inf/nan allowed) or a list of those."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # JSON escapes are valid TOML ones
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float) or hasattr(value, "item"):
        v = float(value)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    raise ValueError(f"tuned-file value {value!r}: must be a string, number, bool or list")


def dumps_tuned(tables: Mapping[str, Mapping[str, Any]], header: str = "") -> str:
    """TOML text of flat ``tables`` (``{table: {key: value}}``), in the given order."""
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    for name, table in tables.items():
        if lines:
            lines.append("")
        lines.append(f"[{_key(name)}]")
        lines.extend(f"{_key(k)} = {_value(v)}" for k, v in table.items())
    return "\n".join(lines) + "\n"


def write_tuned(path: Path | str, tables: Mapping[str, Mapping[str, Any]],
                header: str = "") -> Path:
    """Write a tuned file (``tables`` must include ``parameters``); checks it reads back."""
    if "parameters" not in tables:
        raise ValueError("tables: must include a [parameters] table")
    text = dumps_tuned(tables, header)
    tomllib.loads(text)  # never write a file the loader would reject
    from impactbench.publish import atomic_write

    return atomic_write(Path(path), text, "out")  # all or nothing; one-line I/O errors
