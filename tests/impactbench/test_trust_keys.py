"""The results store's run key (:func:`impactbench.store.run_key` of
:func:`~impactbench.store.run_inputs`) sees every input of a run.

A key that missed an input would serve one run's stored result for another, silently. So every
field of every registered scenario (:func:`impactbench.scenarios.specs`, their dataclass
fields) is changed on its own — text fields (a model, a law, a shape) to another allowed value,
floats by one ulp and by a relative 1e-12, integers by one, booleans flipped, optional values
to and from None — and each change must change the key; so must every field of the run
settings, the engine and the mode, and a data file's content. Each variant is checked to differ from
its base in that one field of ``to_dict()`` (so the key cannot differ through a derived field
instead). A field this test does not know fails it until a variant is added here.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from impactbench.engines.base import RunSettings

from impactbench import scenarios
from impactbench import store as store_mod

ENGINE = "pymunk"
"""Any engine name: run_inputs reads its version from package metadata, nothing runs. The mode
is ``custom`` unless a test says otherwise (every scenario takes it; the cube tosses' native
and injected keys also hash the fitted model file, which needs the model's module)."""

_LINEAR_BALL = {"model": "kelvin-voigt", "exponent": 1.0, "stiffness": 1e7,
                "nominal_restitution": 0.8}
"""A ball whose model sets the damping to 0 whatever e (both linear models do), so changing the
model or e changes no derived field (a hysteresis model's e derives b = α(e)/V0: another model
would change the key through b alone and hide a key that ignores the model)."""


def _packaged_tosses() -> str:
    from impactbench.cube_tosses.data import DEFAULT_PATH

    return str(DEFAULT_PATH)


CONTEXT: dict[tuple[str, str], list[tuple[dict[str, Any], Any]]] = {
    # (scenario, field) → [(fields of the base over its defaults, the field's other value)]
    ("ball-on-plate", "model"): [(_LINEAR_BALL, "kelvin-voigt-clipped")],
    ("ball-on-plate", "nominal_restitution"): [(_LINEAR_BALL, math.nextafter(0.8, 1.0)),
                                               (_LINEAR_BALL, 0.8 * (1 + 1e-12))],
    ("oblique", "model"): [({"nominal_restitution": 0.8}, "flores")],
    ("oblique", "nominal_restitution"): [({}, 0.8),
                                         ({"nominal_restitution": 0.8},
                                          math.nextafter(0.8, 1.0))],
    ("oblique", "tangential"): [({}, "mindlin"), ({}, "mindlin-deresiewicz")],
    ("oblique", "shape"): [({}, "disc")],
    ("rigid-flexible", "local"): [({}, "elastoplastic"), ({}, "mutation"),
                                  ({}, "mutation-continuous")],
    ("rigid-flexible", "structure"): [({}, "softening")],
    ("cube-toss", "data"): [({"tosses": "test"}, "<packaged>")],
    ("cube-toss", "tosses"): [({}, "train"), ({}, "all"), ({"tosses": "0,1"}, "0,2")],
    ("cube-toss", "start_rule"): [({}, "first")],
    ("cube-toss", "velocity_fit"): [({}, "lstsq")],
}
"""Variants a generic rule cannot make: text fields (another allowed value), fields whose base
is None, and fields whose change needs another base to stay valid and isolated."""


def key(scenario: Any, *, engine: str = ENGINE, mode: str = "custom",
        settings: RunSettings | None = None) -> str:
    return store_mod.run_key(store_mod.run_inputs(
        engine, type(scenario).name, scenario, mode, settings or RunSettings()))


def _allows_none(annotation: Any) -> bool:
    if isinstance(annotation, str):  # the scenario modules' postponed annotations
        return "None" in [p.strip() for p in annotation.split("|")]
    origin = typing.get_origin(annotation)
    return origin in (typing.Union, types.UnionType) and type(None) in typing.get_args(annotation)


def _generic(value: Any) -> list[Any]:
    """The other values a generic rule gives: floats one ulp up and ×(1 + 1e-12) (or 1e-12
    where 0), integers + 1, booleans flipped; [] for anything else (text, None)."""
    if isinstance(value, bool):
        return [not value]
    if isinstance(value, int):
        return [value + 1]
    if isinstance(value, float) and math.isfinite(value):
        return [math.nextafter(value, math.inf), value * (1 + 1e-12) if value else 1e-12]
    return []


def variants() -> Iterator[tuple[str, str, Callable[[], tuple[Any, Any]]]]:
    """(scenario, field, a maker of (base, variant)) for every field of every scenario."""
    for spec in scenarios.specs():
        default = spec.build()
        for f in dataclasses.fields(spec.cls):
            cases = CONTEXT.get((spec.name, f.name))
            if cases is None:
                cases = [({}, other) for other in _generic(getattr(default, f.name))]
                if _allows_none(f.type) and getattr(default, f.name) is not None:
                    cases.append(({}, None))
            if not cases:
                def missing(spec=spec, f=f) -> tuple[Any, Any]:
                    raise AssertionError(f"{spec.name}.{f.name}: no variant; add one to CONTEXT")
                yield spec.name, f.name, missing
                continue
            for i, (over, other) in enumerate(cases):
                def make(spec=spec, f=f, over=over, other=other) -> tuple[Any, Any]:
                    if other == "<packaged>":
                        other = _packaged_tosses()
                    base = spec.build(parameters=over)
                    return base, spec.build(parameters={**over, f.name: other})
                yield spec.name, f"{f.name}[{i}]", make


VARIANTS = list(variants())


def test_every_registered_scenario_and_field_is_covered() -> None:
    """The loop below reaches every scenario the registry has, each with all its fields."""
    names = {s for s, _, _ in VARIANTS}
    assert names == {spec.name for spec in scenarios.specs()} and len(names) >= 4
    for spec in scenarios.specs():
        covered = {f.partition("[")[0] for s, f, _ in VARIANTS if s == spec.name}
        assert covered == {f.name for f in dataclasses.fields(spec.cls)}, spec.name


@pytest.mark.parametrize(("scenario", "field", "make"), VARIANTS,
                         ids=[f"{s}-{f}" for s, f, _ in VARIANTS])
def test_changing_one_scenario_field_changes_the_key(scenario: str, field: str,
                                                     make: Callable[[], tuple[Any, Any]]) -> None:
    base, other = make()
    name = field.partition("[")[0]
    a, b = base.to_dict(), other.to_dict()
    changed = {k for k in a.keys() | b.keys() if a.get(k) != b.get(k) or type(a.get(k))
               is not type(b.get(k))}
    assert changed == {name}, f"the variant must differ in {name} alone, not {changed}"
    assert key(base) == key(spec_copy(base)), "the key is not deterministic"
    assert key(base) != key(other), (f"{scenario}.{name}: {a[name]!r} and {b[name]!r} share a "
                                     "run key")


def spec_copy(scenario: Any) -> Any:
    """An equal scenario built anew (not the same object)."""
    return type(scenario)(**scenario.to_dict())


NEAR = math.nextafter(1.0, 2.0)
SETTINGS_VARIANTS: dict[str, list[tuple[Any, Any]]] = {
    "timestep_s": [(1e-6, math.nextafter(1e-6, 1.0)), (1e-6, 1e-6 * (1 + 1e-12)), (None, 1e-6)],
    "max_time_s": [(None, 1.0), (1.0, NEAR)],
    "tuned": [(None, {"k": 1.0}), ({"k": 1.0}, {"k": NEAR}), ({"k": 1.0}, {"k2": 1.0}),
              ({"solref": (0.02, 1.0)}, {"solref": (0.02, NEAR)})],
    "params": [(None, {"k": 1.0}), ({"k": 1.0}, {"k": NEAR}), ({"cone": "pyramidal"},
                                                                {"cone": "elliptic"})],
    "tuned_for": [(None, {"timestep_s": 1e-6}),
                  ({"timestep_s": 1e-6}, {"timestep_s": math.nextafter(1e-6, 1.0)}),
                  ({"scenario": {"model": "flores"}}, {"scenario": {"model": "gonthier"}})],
    "options": [({}, {"injection": "secant"}), ({"injection": "secant"},
                                                {"injection": "explicit"}),
                ({"x": 1.0}, {"x": NEAR})],
    "phase": [(None, 0.0), (0.0, 0.125), (0.5, math.nextafter(0.5, 1.0))],
}
"""Per RunSettings field: (value, other value) pairs, text and nearly equal floats included."""


def test_every_run_setting_changes_the_key() -> None:
    assert set(SETTINGS_VARIANTS) == {f.name for f in dataclasses.fields(RunSettings)}, \
        "a RunSettings field without variants here"
    ball = scenarios.get("ball-on-plate").build()
    for name, pairs in SETTINGS_VARIANTS.items():
        for a, b in pairs:
            ka = key(ball, settings=RunSettings(**{name: a}))
            kb = key(ball, settings=RunSettings(**{name: b}))
            assert ka != kb, f"settings.{name}: {a!r} and {b!r} share a run key"


def test_engine_and_mode_change_the_key() -> None:
    ball = scenarios.get("ball-on-plate").build()
    base = key(ball)
    assert len({base, key(ball, engine="mujoco"), key(ball, mode="injected"),
                key(ball, mode="native")}) == 4


def test_a_data_files_content_changes_the_key(tmp_path) -> None:
    """The cube tosses' key holds the data file's content, not only its path: the same file
    edited in place (one digit) is another run."""
    import gzip
    import os

    from impactbench.cube_tosses.data import DEFAULT_PATH

    lines = gzip.decompress(DEFAULT_PATH.read_bytes()).decode().splitlines(keepends=True)
    path = tmp_path / "mine.csv"
    path.write_text("".join(lines[:200]))
    toss = scenarios.get("cube-toss").build(parameters={"data": str(path)})
    before = key(toss)
    assert key(toss) == before
    header, first, *rest = lines[:200]
    cells = first.split(",")
    cells[3] = cells[3][:-1] + ("1" if cells[3][-1] != "1" else "2")   # x_m, last digit
    path.write_text("".join([header, ",".join(cells), *rest]))
    stat = path.stat()
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000_000))  # an edit's mtime
    assert key(toss) != before


def test_the_key_does_not_depend_on_mapping_order() -> None:
    """Equal settings written in another order are the same run (no needless rerun)."""
    ball = scenarios.get("ball-on-plate").build()
    one = RunSettings(params={"a": 1.0, "b": "x"}, options={"p": 2.0, "q": (1.0, 2.0)})
    two = RunSettings(params={"b": "x", "a": 1.0}, options={"q": (1.0, 2.0), "p": 2.0})
    assert key(ball, settings=one) == key(ball, settings=two)
