"""The command line starts fast: ``--help`` anywhere imports no heavy library, and every help
page is complete (each flag explained, no heading twice). The timing target is a benchmark
(``python -m benchmarks cli_startup``), not a test."""

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
``importlib.metadata`` is allowed: scenario plug-ins are found through their entry points
when the parser lists the scenarios (measured 30 ms; ``impactbench --help`` 0.095 s in all,
against 0.12 s before plug-ins, on the 2-core CI machine)."""

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
