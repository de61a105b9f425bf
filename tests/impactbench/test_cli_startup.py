"""The command line starts fast: ``impactbench --help`` and a bare ``impactbench`` import no
command, scenario, solver, adapter or entry point (the lazy top level,
:func:`impactbench.cli.lazy_parser`), ``--help`` anywhere imports no heavy library, and every
help page is complete (each flag explained, no heading twice). The timing target (4× ``python
-c pass``) is a benchmark (``python -m benchmarks cli_startup``), not a test."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

import pytest

from impactbench import cli

HEAVY = ("numpy", "scipy", "pandas", "matplotlib", "numba", "pyarrow", "duckdb", "dask",
         "distributed", "tqdm", "tabulate",
         "jinja2", "mujoco", "pybullet", "pymunk", "pydrake")
"""Libraries a help page must not import (numpy alone costs more than the target allows).
``importlib.metadata`` is allowed below the top level: scenario plug-ins are found through
their entry points when a parser lists the scenarios (``run``, ``reference``, ``sweep``)."""

TOP_LEVEL_FORBIDDEN = ("impactbench.commands", "impactbench.scenarios", "impactbench.reference",
                       "impactbench.engines", "impactbench.flags", "impactbench.store",
                       "importlib.metadata", "email", "inspect", "tomllib", "dataclasses")
"""What the top-level help and a bare ``impactbench`` must not import: every command's
parser, the scenario registry (and its entry-point lookup), the solvers and the adapters are
built or loaded only once a command is chosen (measured: ``impactbench --help`` 2.6× ``python
-c pass``, against 7.5× when it built the whole tree)."""

TOP_LEVEL_PROBE = """
import contextlib, io, json, sys
from impactbench import cli

out, err = io.StringIO(), io.StringIO()
with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
    try:
        code = cli.main(sys.argv[2:])
    except SystemExit as exc:
        code = exc.code
print(json.dumps({"code": code, "out": out.getvalue(), "err": err.getvalue(),
                  "modules": sorted(m for m in sys.modules
                                    if m.startswith(tuple(sys.argv[1].split(","))))}))
"""

PROBE = """
import contextlib, io, json, sys
from impactbench import cli
import argparse

def paths(parser, prefix=()):
    yield prefix
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            for name, sub in a.choices.items():
                yield from paths(sub, prefix + (name,))

done = []
for path in list(paths(cli.build_parser())):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            cli.main([*path, "--help"])
        except SystemExit as exc:
            assert exc.code == 0, (path, exc.code)
    assert "usage: impactbench" in out.getvalue(), path
    done.append(" ".join(path))
heavy = sorted({m.split(".")[0] for m in sys.modules} & set(sys.argv[1].split(",")))
engines = sorted(m for m in sys.modules if m.startswith("impactbench.engines.")
                 and m.endswith("_adapter"))
print(json.dumps({"helps": done, "heavy": heavy, "adapters": engines}))
"""


@pytest.mark.parametrize("argv", [["--help"], [], ["-h"]], ids=["--help", "bare", "-h"])
def test_top_level_imports_no_command_scenario_or_entry_point(argv: list[str]) -> None:
    """In a fresh interpreter: the top-level help (or the bare command's one-line error, exit
    2), then none of :data:`TOP_LEVEL_FORBIDDEN` is loaded."""
    done = subprocess.run([sys.executable, "-c", TOP_LEVEL_PROBE, ",".join(TOP_LEVEL_FORBIDDEN),
                           *argv], capture_output=True, text=True, check=True, timeout=120)
    seen = json.loads(done.stdout)
    if argv:
        assert seen["code"] == 0 and seen["out"].startswith("usage: impactbench [-h]")
        assert all(f"\n    {name}" in seen["out"] for name in cli.COMMANDS)
    else:
        assert seen["code"] == 2
        assert seen["err"] == ("impactbench: error: impactbench: the following arguments are "
                               "required: COMMAND\n")
    assert seen["modules"] == []


def test_a_chosen_command_builds_only_its_parser() -> None:
    """The lazy top level builds the parser of the command given, and no other."""
    parser = cli.lazy_parser()
    args = parser.parse_args(["history", "--store", "x.duckdb"])
    assert args.command == "history" and callable(args.func)
    (top,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    assert list(top.choices) == list(cli.COMMANDS)
    assert [n for n, p in top.choices.items() if p is not None] == ["history"]


def parsers(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()):
    yield prefix, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from parsers(sub, (*prefix, name))


def test_help_pages_import_no_heavy_library() -> None:
    """In a fresh interpreter: every help page of the tree, then what got imported."""
    out = subprocess.run([sys.executable, "-c", PROBE, ",".join(HEAVY)], capture_output=True,
                         text=True, check=True, timeout=120).stdout
    seen = json.loads(out)
    assert {"", "run", "tune", "report", "gate", "sweep rigid-flexible"} <= set(seen["helps"])
    assert seen["heavy"] == []
    assert seen["adapters"] == []


@pytest.mark.parametrize("path", [p for p, _ in parsers(cli.build_parser())],
                         ids=lambda p: " ".join(p) or "impactbench")
def test_every_flag_is_explained_and_no_heading_repeats(path: tuple[str, ...]) -> None:
    parser = dict(parsers(cli.build_parser()))[path]
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
            continue
        assert action.help, f"impactbench {' '.join(path)} {action.option_strings}: no help"
        assert "None" not in action.help, action.help
    headings = [line for line in parser.format_help().splitlines()
                if line and not line.startswith(" ") and line.endswith(":")]
    assert len(headings) == len(set(headings)), headings


def test_version_is_looked_up_only_when_asked(capsys: pytest.CaptureFixture[str]) -> None:
    from importlib import metadata

    with pytest.raises(SystemExit) as exc:
        cli.main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out == f"impactbench {metadata.version('impactbench')}\n"
