"""The engine registry: entry-point plug-ins (working and broken), the facts on the specs
(colours), and no table keyed by engine name outside the registry.

Plug-ins are installed as pip would leave them, without pip: a ``*.dist-info`` folder
(METADATA, entry_points.txt) and the plug-in's modules in a folder on ``sys.path`` (this
process) or ``PYTHONPATH`` (subprocesses).
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from impactbench.engines import registry
from impactbench.engines.base import EngineUnavailable, get_adapter, parameter_keys, run_safely
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate

ROOT = Path(__file__).resolve().parents[2]
GROUP = registry.ENTRY_POINT_GROUP


def install(site: Path, package: str, entries: dict[str, str],
            modules: dict[str, str] | None = None, group: str = GROUP,
            version: str = "0.2.0") -> Path:
    """A distribution ``package`` ``version`` with ``entries`` (name → "module:attr") in the
    entry-point ``group`` (the engines' by default) and ``modules`` (name → source) beside
    it, in ``site``."""
    info = site / f"{package.replace('-', '_')}-{version}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {package}\n"
                                   f"Version: {version}\n")
    (info / "entry_points.txt").write_text(
        f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items()))
    for name, source in (modules or {}).items():
        (site / f"{name}.py").write_text(textwrap.dedent(source))
    return site


@pytest.fixture
def site(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """A folder on ``sys.path`` for plug-ins; the registry forgets them afterwards."""
    folder = tmp_path / "site"
    folder.mkdir()
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.delenv(registry.WARNED_ENV, raising=False)
    registry.forget_plugins()
    before = set(sys.modules)
    yield folder
    registry.forget_plugins()
    for name in set(sys.modules) - before:
        if name.startswith("ib_test_"):
            del sys.modules[name]


SPEC_SOURCE = """
from impactbench.engines.registry import EngineSpec
SPEC = EngineSpec("{name}", "{adapter}", "pip install ib-test")
"""


# ------------------------------------------------------------------ broken plug-ins


def test_a_plugin_whose_module_is_missing_is_unavailable(site: Path, capfd) -> None:
    """Listed, ``unavailable`` with the entry point, its package and the error; one line on
    stderr, once; every other engine untouched."""
    install(site, "ib-test-missing", {"ghost": "ib_test_no_such_module:SPEC"})
    names = registry.engine_names()
    assert names[-1] == "ghost" and "mujoco" in names and registry.is_builtin("mujoco")
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 1, err
    assert "ghost = ib_test_no_such_module:SPEC" in err[0] and "ib-test-missing 0.2.0" in err[0]
    assert "ModuleNotFoundError" in err[0] and "unavailable" in err[0]
    rec = run_safely("ghost", BallOnPlate())
    assert rec.status == Status.UNAVAILABLE
    assert "No module named 'ib_test_no_such_module'" in rec.message
    assert "ib-test-missing 0.2.0" in rec.message and "pip install ib-test-missing" in rec.message
    assert "\n" not in rec.message
    assert parameter_keys("ghost") == ()
    registry.engine_names()
    assert capfd.readouterr().err == ""  # read once, reported once


def test_the_cli_still_works_beside_a_broken_plugin(tmp_path: Path) -> None:
    """``impactbench reference`` (no engine involved) and ``run`` of a packaged engine: exit
    0, the broken plug-in named in one stderr line; ``run`` of the broken one: its status."""
    folder = install(tmp_path / "site", "ib-test-missing",
                     {"ghost": "ib_test_no_such_module:SPEC"})
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(folder), *filter(None, [os.environ.get("PYTHONPATH")])]),
        "IMPACTBENCH_STORE": str(tmp_path / "store.duckdb")}
    env.pop(registry.WARNED_ENV, None)

    def cli(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "impactbench.cli", *args],
                              capture_output=True, text=True, env=env, timeout=300)

    ref = cli("reference", "ball-on-plate", "--velocity", "1", "--json")
    assert ref.returncode == 0, ref.stderr
    assert json.loads(ref.stdout)["restitution"] > 0.9
    lines = ref.stderr.splitlines()
    assert len(lines) == 1 and "ib-test-missing" in lines[0], lines
    assert "No module named 'ib_test_no_such_module'" in lines[0]

    ghost = cli("run", "--engine", "ghost", "--scenario", "ball-on-plate", "--velocity", "1",
                "--json")
    assert ghost.returncode != 0
    assert json.loads(ghost.stdout)["status"] == "unavailable"


def test_a_plugin_that_raises_on_import_or_is_no_spec(site: Path, capfd) -> None:
    install(site, "ib-test-bad", {"raiser": "ib_test_raiser:SPEC", "thing": "ib_test_thing:SPEC",
                                  "misnamed": "ib_test_misnamed:SPEC"},
            {"ib_test_raiser": "raise RuntimeError('no licence server')\n",
             "ib_test_thing": "SPEC = 42\n",
             "ib_test_misnamed": SPEC_SOURCE.format(name="other", adapter="x:Y")})
    assert registry.engine_names()[-3:] == ("misnamed", "raiser", "thing")
    assert len(capfd.readouterr().err.splitlines()) == 3
    assert "RuntimeError: no licence server" in registry.plugin_error("raiser")
    assert "must be an impactbench.engines.registry.EngineSpec named 'thing'" \
        in registry.plugin_error("thing")
    assert "named 'misnamed'" in registry.plugin_error("misnamed")
    for name in ("raiser", "thing", "misnamed"):
        with pytest.raises(EngineUnavailable, match=f"engine '{name}'"):
            get_adapter(name)


def test_a_plugin_whose_adapter_is_missing_is_unavailable(site: Path) -> None:
    """The spec loads (the engine is listed with its facts); its adapter module does not:
    ``unavailable`` when it runs, naming the adapter."""
    install(site, "ib-test-half", {"half": "ib_test_half:SPEC"},
            {"ib_test_half": SPEC_SOURCE.format(name="half", adapter="ib_test_gone:Adapter")})
    assert registry.plugin_error("half") == ""
    assert registry.spec("half").pip == "pip install ib-test"
    rec = run_safely("half", BallOnPlate())
    assert rec.status == Status.UNAVAILABLE
    assert "ib_test_gone:Adapter" in rec.message and "ModuleNotFoundError" in rec.message


def test_a_plugin_cannot_replace_a_packaged_engine(site: Path, capfd) -> None:
    install(site, "ib-test-usurper", {"mujoco": "ib_test_usurper:SPEC"})
    assert registry.engine_names() == tuple(s.name for s in registry.BUILTIN)
    assert registry.is_builtin("mujoco")
    err = capfd.readouterr().err
    assert "ignored engine plug-in" in err and "'mujoco' is a packaged engine" in err


def test_workers_stay_quiet_after_the_parent_reported(site: Path, capfd) -> None:
    """The parent's report is inherited (``WARNED_ENV``): a worker process does not repeat
    it, a fresh process does."""
    install(site, "ib-test-missing", {"ghost": "ib_test_no_such_module:SPEC"})
    registry.engine_names()
    assert "ghost" in capfd.readouterr().err
    code = "from impactbench.engines import registry; print(registry.engine_names()[-1])"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(site), *filter(None, [os.environ.get("PYTHONPATH")])])}
    child = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=env, check=True, timeout=60)
    assert child.stdout.strip() == "ghost" and child.stderr == ""
    env.pop(registry.WARNED_ENV)
    fresh = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=env, check=True, timeout=60)
    assert "ghost" in fresh.stderr


def test_the_registry_stays_standard_library_only_with_a_plugin(tmp_path: Path) -> None:
    """Listing engines (what every command's parser does) with the example plug-in installed
    imports neither numpy nor an adapter: the entry point names the light spec module."""
    folder = install(tmp_path / "site", "impactbench-euler",
                     {"euler": "impactbench_euler:SPEC"})
    example = ROOT / "examples" / "plugin-engine-euler"
    code = ("import sys; from impactbench.engines import registry\n"
            "print(registry.engine_names()[-1], registry.spec('euler').color)\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('numpy', 'scipy', 'impactbench_euler') or m.endswith('adapter')))\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(folder), str(example), *filter(None, [os.environ.get("PYTHONPATH")])])}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True, timeout=60).stdout.splitlines()
    assert out == ["euler teal", "['impactbench_euler']"]


# ------------------------------------------------------------------ facts on the specs


def test_every_packaged_engine_has_its_own_colour() -> None:
    colours = [s.color for s in registry.BUILTIN]
    assert all(colours) and len(set(colours)) == len(colours)
    assert not set(registry.FALLBACK_COLORS) & set(colours)


def test_an_engine_without_a_colour_gets_a_deterministic_fallback() -> None:
    plain = registry.EngineSpec("my-engine", "m:C", "pip install m")
    assert plain.plot_color == registry.fallback_color("my-engine") in registry.FALLBACK_COLORS
    # CRC-32, not Python's salted hash(): the same colour in another process
    code = "from impactbench.engines import registry; print(registry.fallback_color('my-engine'))"
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           check=True, timeout=60, env={**os.environ, "PYTHONHASHSEED": "7"})
    assert other.stdout.strip() == plain.plot_color
    names = [f"engine-{i}" for i in range(40)]
    assert len({registry.fallback_color(n) for n in names}) > 5  # spread, not one colour


ENGINE_NAMES = {s.name for s in registry.BUILTIN}
TABLES_ALLOWED = {
    # the registry itself: one spec per engine
    "engines/registry.py",
    # the adapters (their own name), and their own per-engine helpers
    "engines/mujoco_adapter.py", "engines/pybullet_adapter.py", "engines/pymunk_adapter.py",
    "engines/drake_adapter.py", "engines/sapien_adapter.py", "engines/dart_adapter.py",
    "engines/box2d_adapter.py", "engines/mjx_adapter.py", "engines/newton_adapter.py",
    "engines/cube_toss.py", "engines/cube_toss_more.py",
    # not moved yet (listed in the report of this change): the oblique friction knobs, the
    # cube tosses' tuning spaces, the cube tosses' batched engines, the scenarios' per-engine
    # descriptions of native mode
    "engines/oblique_tuned.py", "engines/base.py",
    "impactbench/scenarios/ball_on_plate.py", "impactbench/scenarios/rigid_flexible.py",
}


def _engine_tables(tree: ast.AST) -> list[int]:
    """Lines of dict displays with two or more packaged engine names as keys."""
    return [node.lineno for node in ast.walk(tree) if isinstance(node, ast.Dict)
            and sum(isinstance(k, ast.Constant) and k.value in ENGINE_NAMES
                    for k in node.keys) >= 2]


def test_no_table_keyed_by_engine_name_outside_the_registry() -> None:
    """An engine's facts live on its spec: no dict keyed by two or more engine names in the
    suite (docstrings' examples are strings, not dicts)."""
    found = {}
    for folder in ("engines", "impactbench"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if rel in TABLES_ALLOWED or rel.startswith("impactbench/cube_tosses/"):
                continue
            lines = _engine_tables(ast.parse(path.read_text()))
            if lines:
                found[rel] = lines
    assert found == {}


def test_the_table_check_would_fire() -> None:
    tree = ast.parse('COLORS = {"mujoco": "tab:blue", "drake": "tab:red"}\n'
                     'ONE = {"mujoco": 1}\n')
    assert _engine_tables(tree) == [1]
