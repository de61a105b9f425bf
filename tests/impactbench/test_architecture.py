"""The shape of the code: arrows run one way, no import circles, and scenario names live only
in the scenarios' own modules.

The import graph is read from the source with :mod:`ast`, function-level imports included
(``import x`` inside a function is still an arrow), over the three installed packages:
``impactbench.reference`` (``reference/``), ``impactbench.engines`` (``engines/``) and the suite
(``impactbench/``; its ``commands`` and ``cli`` on top).
"""

from __future__ import annotations

import ast
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


def import_graph() -> dict[str, set[str]]:
    """module → the project modules it imports anywhere in its source."""
    mods = modules()
    graph = {}
    for name, path in mods.items():
        base = name if path.name == "__init__.py" else name.rpartition(".")[0]
        found: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text())):
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
    imports included."""
    graph = import_graph()
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


def test_a_circle_would_be_found() -> None:
    """The walk sees function-level imports (what a hidden circle is made of)."""
    graph = import_graph()
    assert "impactbench.scenarios" in graph["impactbench.evaluate"]
    assert "impactbench.tuned" in graph["impactbench.evaluate"]  # imported inside a function


SCENARIO_NAMES = {"ball-on-plate", "rigid-flexible", "ball_on_plate", "rigid_flexible",
                  "oblique"}
ALLOWED = {
    # the scenarios' own modules: their specs, their subcommands, their physics and solvers
    "impactbench.scenarios.ball_on_plate", "impactbench.scenarios.rigid_flexible",
    "impactbench.scenarios",  # BUILTIN: the registry of the packaged specs
    "impactbench.commands.ball_on_plate", "impactbench.commands.rigid_flexible",
    "impactbench.reference.scenarios",
    "impactbench.scenarios.oblique", "impactbench.commands.oblique",
    "impactbench.reference.oblique_scenario", "impactbench.reference.oblique",
}


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
        tree = ast.parse(path.read_text())
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
