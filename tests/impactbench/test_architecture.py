"""The shape of the code: arrows run one way, no import circles, and scenario names live only
in the scenarios' own modules.

The import graph is read from the source with :mod:`ast`, function-level imports included
(``import x`` inside a function is still an arrow), and so are ``"module:attr"`` strings (a
registry entry imported by name is an arrow too), over the three installed packages:
``impactbench.reference`` (``reference/``), ``impactbench.engines`` (``engines/``) and the suite
(``impactbench/``; its ``commands`` and ``cli`` on top).
"""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = {"impactbench": ROOT / "impactbench", "impactbench.reference": ROOT / "reference",
            "impactbench.engines": ROOT / "engines"}


def modules() -> dict[str, Path]:
    out = {}
    for package, folder in PACKAGES.items():
        for path in folder.rglob("*.py"):
            parts = list(path.relative_to(folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join([package, *parts])] = path
    return out


@functools.cache
def parsed(source: str) -> ast.Module:
    """``source``'s syntax tree, parsed once per process (the checks here walk every module's
    tree several times and never change one)."""
    return ast.parse(source)


STRING_ARROW = re.compile(r"^(impactbench(?:\.\w+)*):\w+(?:\.\w+)*$")
"""A ``"module:attr"`` string naming a project object (what a registry loads by name)."""
UNKNOWN = "X"
"""What an f-string's replacement field that is no module-level string constant reads as: a
word, so ``f"{MODULE}:{name}"`` is still ``"module:attr"`` and ``f"impactbench.a.b_{x}:f"``
names ``impactbench.a.b_X`` (not a module: the arrow goes to its package, ``impactbench.a``)."""


def module_constants(tree: ast.AST) -> dict[str, str]:
    """The module-level string constants of ``tree`` (``NAME = "text"``), by name."""
    out: dict[str, str] = {}
    for node in getattr(tree, "body", []):
        if isinstance(node, ast.Assign | ast.AnnAssign) and isinstance(node.value, ast.Constant) \
                and isinstance(node.value.value, str):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            out.update((t.id, node.value.value) for t in targets if isinstance(t, ast.Name))
    return out


def f_string_text(node: ast.JoinedStr, constants: dict[str, str]) -> str:
    """The text of an f-string with each ``{NAME}`` of a module-level string constant filled
    in (no conversion or format) and any other field :data:`UNKNOWN`."""
    parts = []
    for value in node.values:
        if isinstance(value, ast.Constant):
            parts.append(str(value.value))
        elif isinstance(value, ast.FormattedValue) and isinstance(value.value, ast.Name) \
                and value.value.id in constants and value.conversion == -1 \
                and value.format_spec is None:
            parts.append(constants[value.value.id])
        else:
            parts.append(UNKNOWN)
    return "".join(parts)


def string_arrows(tree: ast.AST) -> set[str]:
    """The modules ``"module:attr"`` strings in ``tree`` name: string constants, and f-strings
    read through the module's string constants (``f"{_SPACES}:mujoco_space"`` with
    ``_SPACES = "impactbench.x"`` names ``impactbench.x``; :func:`f_string_text`)."""
    constants = module_constants(tree)
    texts = [node.value if isinstance(node, ast.Constant) else f_string_text(node, constants)
             for node in ast.walk(tree)
             if (isinstance(node, ast.Constant) and isinstance(node.value, str))
             or isinstance(node, ast.JoinedStr)]
    return {m.group(1) for text in texts if (m := STRING_ARROW.match(text))}


def import_graph(strings: bool = True) -> dict[str, set[str]]:
    """module → the project modules it imports anywhere in its source or (``strings``) names
    in a ``"module:attr"`` string."""
    mods = modules()
    graph = {}
    for name, path in mods.items():
        base = name if path.name == "__init__.py" else name.rpartition(".")[0]
        tree = parsed(path.read_text())
        found: set[str] = string_arrows(tree) if strings else set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                found.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                module = node.module or ""
                if node.level:
                    b = base
                    for _ in range(node.level - 1):
                        b = b.rpartition(".")[0]
                    module = f"{b}.{module}".rstrip(".")
                found.add(module)
                found.update(f"{module}.{a.name}" for a in node.names)
        edges = set()
        for m in found:
            while m and m not in mods:
                m = m.rpartition(".")[0]
            if m and m != name and m != "impactbench":
                edges.add(m)
        graph[name] = edges
    return graph


def layer(module: str) -> int:
    if module.startswith("impactbench.reference"):
        return 0
    if module.startswith("impactbench.engines"):
        return 1
    if module.startswith("impactbench.commands") or module == "impactbench.cli":
        return 3
    return 2


def test_arrows_run_one_way() -> None:
    """reference ← engines ← suite ← commands: no module imports a higher layer."""
    graph = import_graph()
    assert len(graph) > 60  # the walk found the packages
    wrong = sorted((a, b) for a, bs in graph.items() for b in bs if layer(b) > layer(a))
    assert wrong == []


def test_no_import_circles() -> None:
    """No strongly connected component of more than one module (Tarjan), function-level
    imports included. A registry's own ``"module:attr"`` strings are left out here (its
    entries import the base class that lives beside the registry's loader: that loop is the
    plug-in mechanism itself); :func:`test_one_string_per_registry_entry` keeps them to the
    registries and :func:`test_arrows_run_one_way` checks their direction."""
    graph = import_graph(strings=False)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    assert circles == []


def test_a_string_arrow_the_wrong_way_would_be_found() -> None:
    """A ``"module:attr"`` string is an arrow: one in the reference naming a suite module
    is a wrong-way arrow, and the registries' strings are in the graph."""
    tree = ast.parse('TARGET = "impactbench.report:build"\nNOT = "a:b"\n')
    assert string_arrows(tree) == {"impactbench.report"}
    assert layer("impactbench.report") > layer("impactbench.reference.hunt_crossley")
    graph = import_graph()
    assert "impactbench.scenarios.ball_on_plate" in graph["impactbench.scenarios"]
    assert "impactbench.engines.mujoco_adapter" in graph["impactbench.engines.registry"]


def test_an_f_string_arrow_the_wrong_way_would_be_found() -> None:
    """An f-string is read through the module's string constants: the registry's tuning spaces
    as they were (``f"{_TUNE}:mujoco_space"``, ``f"{_TOSSES}:{const}"``, pointing into the
    suite) are wrong-way arrows from the engine layer; a field that is no constant still leaves
    the module's package."""
    tree = ast.parse(
        '_TUNE = "impactbench.tuning.spaces"\n'
        '_TOSSES: str = "impactbench.cube_tosses.spaces"\n'
        'A = (("solref", f"{_TUNE}:mujoco_space"),)\n'
        'def _spaces(const):\n    return (("tosses", f"{_TOSSES}:{const}"),)\n'
        'B = f"impactbench.commands.tune_{scenario}:main"\n'
        'NOT = (f"{_TUNE}.{x}", f"{_TUNE!r}:a", f"{other}:b", f"impactbench.report {x}:y")\n')
    found = string_arrows(tree)
    assert found == {"impactbench.tuning.spaces", "impactbench.cube_tosses.spaces",
                     "impactbench.commands.tune_X"}
    engine = "impactbench.engines.registry"
    assert all(layer(m) > layer(engine) for m in found)
    # the registry itself: every tuning space it names is an engine-layer module
    graph = import_graph()
    named = string_arrows(parsed(modules()[engine].read_text()))
    assert {"impactbench.engines.tuning_spaces", "impactbench.engines.tuning_spaces_extras",
            "impactbench.engines.oblique_tuned", "impactbench.engines.cube_toss_spaces"} <= named
    assert all(layer(m) == 1 for m in named) and named - {"impactbench.engines.plugins"} \
        <= graph[engine]


def test_one_string_per_registry_entry() -> None:
    """The registries are the only places that name project objects by ``"module:attr"``
    strings (the scenarios', the engines' and their tuning spaces), and a scenario's spec
    holds none: its behaviour is methods."""
    holders = {name for name, path in modules().items()
               if string_arrows(parsed(path.read_text()))}
    assert holders <= {"impactbench.scenarios", "impactbench.engines.registry"}, holders


def test_a_circle_would_be_found() -> None:
    """The walk sees function-level imports (what a hidden circle is made of)."""
    graph = import_graph()
    assert "impactbench.scenarios" in graph["impactbench.evaluate"]
    assert "impactbench.tuned" in graph["impactbench.evaluate"]  # imported inside a function


SCENARIO_NAMES = {"ball-on-plate", "rigid-flexible", "ball_on_plate", "rigid_flexible",
                  "oblique", "cube-toss", "cube_toss", "bounce"}
"""Every built-in scenario's name (registry and table spelling); tested equal to the registry."""
ALLOWED = {
    # the scenarios' own modules: their specs, their subcommands, their physics and solvers
    "impactbench.scenarios.ball_on_plate", "impactbench.scenarios.rigid_flexible",
    "impactbench.scenarios",  # BUILTIN: the registry of the packaged specs
    "impactbench.commands.ball_on_plate", "impactbench.commands.rigid_flexible",
    "impactbench.reference.scenarios",
    "impactbench.scenarios.oblique", "impactbench.commands.oblique",
    "impactbench.reference.oblique_scenario", "impactbench.reference.oblique",
    "impactbench.scenarios.cube_toss", "impactbench.commands.cube_toss",
    "impactbench.cube_tosses.scenario", "impactbench.cube_tosses.tune",
    "impactbench.cube_tosses.reference_model", "impactbench.commands.tune_tosses",
    "impactbench.cube_tosses.model_modes",
    "impactbench.scenarios.bounce", "impactbench.commands.bounce",
    "impactbench.reference.bounce_scenario", "impactbench.reference.bounce",
}


def test_every_builtin_scenario_name_is_known() -> None:
    """The name check covers every packaged scenario (a new one must be added above)."""
    from impactbench import scenarios

    for name, target in scenarios.BUILTIN.items():
        assert name in SCENARIO_NAMES
        assert scenarios.get(name).table in SCENARIO_NAMES, target


def _builder_tables(tree: ast.AST) -> set[int]:
    """ids of the string keys of ``builders = {...}`` / ``model_builders = {...}`` tables."""
    keys = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign | ast.AnnAssign) and isinstance(node.value, ast.Dict):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id.endswith("builders") for t in targets):
                keys.update(id(k) for k in node.value.keys)
    return keys


def test_scenario_names_only_in_scenario_modules_and_builders() -> None:
    """A scenario name as a string constant (what code keys or branches on) appears in the
    scenarios' own modules and as a key of the adapters' ``builders`` tables only (and in the
    packaged config and the tests): every other module reaches a scenario through its spec."""
    found = {}
    for name, path in modules().items():
        if name in ALLOWED:
            continue
        tree = parsed(path.read_text())
        allowed = _builder_tables(tree)
        hits = [node.lineno for node in ast.walk(tree)
                if isinstance(node, ast.Constant) and node.value in SCENARIO_NAMES
                and id(node) not in allowed]
        if hits:
            found[name] = hits
    assert found == {}


def test_the_name_check_would_fire() -> None:
    """The check above sees a scenario name used as a value (not only as a key)."""
    tree = ast.parse('builders = {"ball-on-plate": 1}\nif s == "rigid-flexible": pass\n')
    hits = [n.value for n in ast.walk(tree) if isinstance(n, ast.Constant)
            and n.value in SCENARIO_NAMES and id(n) not in _builder_tables(tree)]
    assert hits == ["rigid-flexible"]
