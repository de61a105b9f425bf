"""The lazy command line (:func:`impactbench.cli.lazy_parser`, what ``main`` parses with) is the
full tree (:func:`impactbench.cli.build_parser`) built on demand: every help page it prints,
every one-line error and every parse are the full tree's, byte for byte; the static table of
commands is what the command modules register."""

from __future__ import annotations

import argparse
import contextlib
import io

import pytest

from impactbench import cli


def parsers(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()):
    """(path, parser) of every parser of a tree, depth first (``()``: the top level)."""
    yield prefix, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from parsers(sub, (*prefix, name))


def commands_action(parser: argparse.ArgumentParser) -> argparse._SubParsersAction:
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return action


def through_main(argv: list[str]) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of ``impactbench ARGV`` in this process."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli.main(argv)
        except SystemExit as exc:
            code = exc.code
    return code, out.getvalue(), err.getvalue()


def full_tree(argv: list[str]) -> tuple[int, str, str]:
    """What the full tree gives for ``argv``: its parse's exit, help or one-line error (as
    ``main`` prints a UsageError)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            cli.build_parser().parse_args(argv)
            code = None
        except SystemExit as exc:
            code = exc.code
        except cli.UsageError as exc:
            print(f"impactbench: error: {exc}", file=err)
            code = 2
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(autouse=True)
def _fixed_width(monkeypatch: pytest.MonkeyPatch) -> None:
    """argparse wraps help to the terminal's width: the same for both trees."""
    monkeypatch.setenv("COLUMNS", "80")


PATHS = [path for path, _ in parsers(cli.build_parser())]


def test_the_table_is_what_the_modules_register() -> None:
    """:data:`impactbench.cli.COMMANDS`: the full tree's top-level names in its order, each
    with the one-line help its module registers."""
    top = commands_action(cli.build_parser())
    assert list(cli.COMMANDS) == list(top.choices)
    assert {a.dest: a.help for a in top._choices_actions} == {
        name: help_text for name, (help_text, _) in cli.COMMANDS.items()}
    # each command's module registers it (a group: built from the scenario modules)
    for name, (_, module) in cli.COMMANDS.items():
        assert (module is None) == (name in cli.GROUPS)
        assert module is None or module in cli.COMMAND_MODULES
    assert set(cli.GROUP_MODULES) <= set(cli.COMMAND_MODULES)


def test_the_lazy_top_level_help_is_the_full_trees() -> None:
    lazy, full = cli.lazy_parser(), cli.build_parser()
    assert lazy.format_help() == full.format_help()
    assert lazy.format_usage() == full.format_usage()
    assert len(PATHS) > 20  # every command and every scenario of run, reference and sweep


@pytest.mark.parametrize("path", PATHS, ids=lambda p: " ".join(p) or "impactbench")
def test_every_help_page_is_the_full_trees(path: tuple[str, ...]) -> None:
    """``impactbench PATH --help`` through ``main`` (the lazy tree) prints the full tree's page
    of that parser, and exits 0."""
    page = dict(parsers(cli.build_parser()))[path].format_help()
    assert through_main([*path, "--help"]) == (0, page, "")


@pytest.mark.parametrize("argv", [
    [], ["nope"], ["--bogus"], ["-1"], ["--", "nope"], ["run"], ["reference"], ["sweep"],
    ["reference", "nope"], ["run", "nope"], ["tune", "--bogus"], ["report", "--workers", "x"],
    ["figures", "--bogus"], ["gate", "--x"], ["history", "--store"],
    ["sweep", "rigid-flexible", "--bogus"], ["reference", "oblique", "--velocity", "fast"],
    ["run", "ball-on-plate", "--engine", "nope"], ["calibrate", "--bogus"],
    ["--version", "--help"], ["--help", "nope"], ["nope", "--help"],
], ids=lambda a: " ".join(a) or "bare")
def test_errors_and_exits_are_the_full_trees(argv: list[str]) -> None:
    """A refused command line: the same one line on stderr and exit 2 (or the same page and
    exit 0) through the lazy tree as through the full one."""
    expected = full_tree(argv)
    assert expected[0] in (0, 2)
    got = through_main(argv)
    assert got == expected
    if got[0] == 2:
        assert got[2].count("\n") == 1 and got[2].startswith("impactbench: error: ")


@pytest.mark.parametrize("argv", [
    ["history", "--store", "s.duckdb", "--engine", "mujoco"],
    ["figures", "--out", "f", "--workers", "1"],
    ["reference", "ball-on-plate", "--velocity", "2", "--json"],
    ["sweep", "oblique", "--over", "angle-deg", "--start", "0", "--stop", "10", "--step", "5",
     "--out", "t.csv"],
    ["run", "oblique", "--engine", "mujoco", "--velocity", "2", "--angle-deg", "30"],
    ["report", "--keep-unchanged", "--workers", "0"],
], ids=" ".join)
def test_a_parse_is_the_full_trees(argv: list[str]) -> None:
    """The namespace (every option and default, the handler) the full tree gives."""
    got, expected = vars(cli.parse(argv)), vars(cli.build_parser().parse_args(argv))
    assert got == expected and got["command"] == argv[0] and callable(got["func"])


def test_a_command_missing_from_the_table_goes_to_the_full_tree(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A command word the table lacks (a plug-in's own command) is parsed by the full tree:
    it runs as before instead of being refused."""
    page = dict(parsers(cli.build_parser()))[("history",)].format_help()
    monkeypatch.setattr(cli, "COMMANDS", {k: v for k, v in cli.COMMANDS.items()
                                          if k != "history"})
    lazy_page = cli.lazy_parser().format_help()
    assert "\n    history" not in lazy_page  # the lazy top level no longer lists it
    assert through_main(["history", "--help"]) == (0, page, "")
    assert vars(cli.parse(["history"])) == vars(cli.build_parser().parse_args(["history"]))
