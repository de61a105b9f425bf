"""The ``impactbench`` command line.

Every subcommand lives in its own module under :mod:`impactbench.commands` and exposes
``register(top, groups)``: ``top`` is the top-level subparsers object, ``groups`` maps the
scenario-keyed groups (``reference``, ``sweep``) to their subparsers. A handler is stored as
``func`` on its parser and returns the exit code.

Bad input anywhere (argparse, scenario validation, config files) and an I/O fault (a full
disk, a read-only folder) print one line ``impactbench: error: …`` to stderr and exit 2,
without a traceback (set ``IMPACTBENCH_DEBUG=1`` to see one).

Ctrl-C, SIGTERM and SIGHUP all stop a command the same way: what finished is kept (a report's
runs are stored), one line ``impactbench: interrupted; N of M runs stored; rerun to resume``
is printed and the exit code is 128 + the signal (130, 143, 129). Further SIGTERMs and SIGHUPs
while it stops are ignored, so the cleanup finishes.

The parser :func:`main` uses is lazy (:func:`lazy_parser`): the top level lists the commands
from the static table :data:`COMMANDS` (names and one-line helps), and a command's own parser
is built — its module imported and registered as in :func:`build_parser` — only when that
command is chosen, so ``impactbench --help`` (and a bare ``impactbench``) imports no command,
no scenario and no entry point. A command word the table lacks (a plug-in's own top-level
command, or a typo) is parsed again with the full tree (:func:`build_parser`), so it works, or
is refused, exactly as before. ``tests/impactbench/test_cli_lazy.py`` checks that every help
page of the lazy tree is the eager tree's, byte for byte.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
from collections.abc import Sequence

COMMAND_MODULES: tuple[str, ...] = (
    # one line per subcommand module; keep this list sorted. The packaged scenarios' own
    # subcommands (reference NAME, sweep NAME) are here too; a plug-in's come from its spec
    # (``register_commands``).
    "impactbench.commands.advise",
    "impactbench.commands.ball_on_plate",
    "impactbench.commands.bounce",
    "impactbench.commands.calibrate",
    "impactbench.commands.cube_toss",
    "impactbench.commands.figures",
    "impactbench.commands.gate",
    "impactbench.commands.history",
    "impactbench.commands.oblique",
    "impactbench.commands.report",
    "impactbench.commands.rigid_flexible",
    "impactbench.commands.run",
    "impactbench.commands.tune",
)

GROUPS: dict[str, str] = {
    "reference": "solve a scenario with the reference solver (the ground truth)",
    "sweep": "sweep one parameter of a scenario with the reference solver into a table",
}

GROUP_MODULES: tuple[str, ...] = (
    # the modules of COMMAND_MODULES that add the packaged scenarios' ``reference NAME`` and
    # ``sweep NAME`` (the groups' subcommands; a plug-in's come from its spec)
    "impactbench.commands.ball_on_plate",
    "impactbench.commands.bounce",
    "impactbench.commands.cube_toss",
    "impactbench.commands.oblique",
    "impactbench.commands.rigid_flexible",
)

COMMANDS: dict[str, tuple[str, str | None]] = {
    # every top-level command in the order the full tree lists it (the groups, then
    # COMMAND_MODULES' order): name → (its one-line help, as its module registers it; its
    # module, None for a group). The lazy parser's top level is built from this table alone
    # (tests/impactbench/test_cli_lazy.py checks it against the modules).
    **{name: (help_text, None) for name, help_text in GROUPS.items()},
    "advise": ("the best contact settings for an engine at your step, for your body",
               "impactbench.commands.advise"),
    "calibrate": ("fit a contact model's damping (and stiffness) to measured impacts, with "
                  "intervals", "impactbench.commands.calibrate"),
    "figures": ("write the reference papers' figures (PNG) into a directory",
                "impactbench.commands.figures"),
    "gate": ("check engines against the reference with the tolerances of a gate file (CI)",
             "impactbench.commands.gate"),
    "history": ("show each metric's error across engine and impactbench versions held in the "
                "store", "impactbench.commands.history"),
    "report": ("run the comparison matrix and write the report (tables, plots, CSV/Parquet)",
               "impactbench.commands.report"),
    "run": ("run one scenario in one engine and compare it with the reference",
            "impactbench.commands.run"),
    "tune": ("fit an engine's native contact parameters to the reference (Hunt–Crossley, or "
             "any --model)", "impactbench.commands.tune"),
}


class UsageError(ValueError):
    """Bad command-line input (exit code 2)."""


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and exit 2, and which reads ``-1e-3`` as a
    negative number (:data:`impactbench.cliutil.NEGATIVE_NUMBER`), so the validator names
    the field and its rule."""

    def __init__(self, *args, **kwargs) -> None:  # type: ignore[no-untyped-def]
        super().__init__(*args, **kwargs)
        from impactbench.cliutil import NEGATIVE_NUMBER

        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(f"{self.prog}: {message}")


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("impactbench")
    except metadata.PackageNotFoundError:
        return "unknown"


class _VersionAction(argparse.Action):
    """``--version``: looks the version up only when asked (importlib.metadata costs ~30 ms,
    a tenth of the start-up budget of every other command)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=default,
                         help=help or "print the installed version and exit")

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        print(f"impactbench {_version()}")
        parser.exit()


DESCRIPTION = ("Cross-validate physics engines on impact: against Hunt–Crossley and "
               "rigid–flexible reference solutions, the oblique impact with friction and spin "
               "(rigid Coulomb theory, Mindlin, Kharaz et al.'s measurements) and 456 real "
               "cube tosses (DAIR's ContactNets data).")


def add_commands(parser: argparse.ArgumentParser
                 ) -> tuple[argparse._SubParsersAction, dict[str, argparse._SubParsersAction]]:
    """The top-level subcommands of ``parser`` and the scenario-keyed groups (``reference``,
    ``sweep``: one subcommand per scenario) under it: (top, groups)."""
    top = parser.add_subparsers(dest="command", required=True, parser_class=Parser,
                                metavar="COMMAND")
    groups = {}
    for name, help_text in GROUPS.items():
        group = top.add_parser(name, help=help_text, description=help_text)
        groups[name] = group.add_subparsers(dest="scenario", required=True, metavar="SCENARIO",
                                            parser_class=Parser)
    return top, groups


def _top_parser(parser_class: type[Parser] = Parser) -> Parser:
    """The bare top level: ``impactbench [-h] [--version]`` and its description."""
    parser = parser_class(prog="impactbench", description=DESCRIPTION)
    parser.add_argument("--version", action=_VersionAction)
    return parser


def _register(modules: Sequence[str], plugins: bool = True
              ) -> tuple[Parser, argparse._SubParsersAction]:
    """A full-tree top level with ``modules`` registered (and, with ``plugins``, first every
    scenario's own subcommands: plug-ins' ``reference NAME`` …): (parser, its COMMAND
    action)."""
    parser = _top_parser()
    top, groups = add_commands(parser)
    if plugins:
        from impactbench import scenarios

        for spec in scenarios.specs():  # each scenario's own subcommands (reference NAME, …)
            spec.register_commands(top, groups)
    for module in modules:
        importlib.import_module(module).register(top, groups)
    return parser, top


def build_parser() -> argparse.ArgumentParser:
    """The full parser tree: every command's parser built now (scenario plug-ins included).
    :func:`main` uses :func:`lazy_parser`, which gives the same help and parse."""
    return _register(COMMAND_MODULES)[0]


def command_parser(name: str) -> argparse.ArgumentParser:
    """The parser of the top-level command ``name`` of :data:`COMMANDS`, built as
    :func:`build_parser` builds it: a group (``reference``, ``sweep``) with every scenario's
    subcommands, else its module's. The plug-ins are looked up as the full tree does (the
    scenarios' and the engines' entry points), so a broken one is still named on stderr
    (one line) whichever command runs."""
    module = COMMANDS[name][1]
    top = _register(GROUP_MODULES if module is None else (module,))[1]
    from impactbench.engines.registry import engine_names

    engine_names()  # what `run`'s --engine choices load in the full tree
    return top.choices[name]


class _NotInTable(Exception):
    """A command word :data:`COMMANDS` lacks: parse again with the full tree."""


class _LazyCommands(argparse._SubParsersAction):
    """The top-level COMMAND: its names and helps from :data:`COMMANDS` (what the top-level
    help and a refused word's message list), the chosen command's parser built when argparse
    reaches it (:func:`command_parser`)."""

    def __init__(self, *args, **kwargs) -> None:  # type: ignore[no-untyped-def]
        super().__init__(*args, **kwargs)
        for name, (help_text, _module) in COMMANDS.items():
            self._name_parser_map[name] = None  # built when chosen
            self._choices_actions.append(self._ChoicesPseudoAction(name, (), help_text))

    def __call__(self, parser, namespace, values, option_string=None) -> None:  # type: ignore[no-untyped-def]
        name = values[0]
        if self._name_parser_map.get(name) is None:
            self._name_parser_map[name] = command_parser(name)
        super().__call__(parser, namespace, values, option_string)


class _LazyTop(Parser):
    """The lazy top level: a word not in :data:`COMMANDS` raises :class:`_NotInTable` (the
    full tree, plug-ins loaded, then parses it: their own command, or the refusal naming
    every choice)."""

    def _check_value(self, action, value) -> None:  # type: ignore[no-untyped-def]
        if isinstance(action, _LazyCommands) and value not in action.choices:
            raise _NotInTable(value)
        super()._check_value(action, value)


def lazy_parser() -> argparse.ArgumentParser:
    """The parser :func:`main` uses: the top level from :data:`COMMANDS` alone, each command's
    parser built only when chosen (``impactbench --help`` imports no command module)."""
    parser = _top_parser(_LazyTop)
    parser.add_subparsers(dest="command", required=True, parser_class=Parser,
                          metavar="COMMAND", action=_LazyCommands)
    return parser


def parse(argv: Sequence[str]) -> argparse.Namespace:
    """``argv`` parsed as the full tree would (:func:`build_parser`), through the lazy one."""
    try:
        return lazy_parser().parse_args(argv)
    except _NotInTable:
        return build_parser().parse_args(argv)


STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
"""Signals handled like Ctrl-C (a KeyboardInterrupt in the main thread)."""
_received: list[int] = []


def _stop(signum: int, _frame: object) -> None:
    """SIGTERM or SIGHUP: the first raises KeyboardInterrupt (the Ctrl-C path stores what
    finished and closes the workers); later ones only wait for that to finish."""
    _received.append(signum)
    if len(_received) == 1:
        raise KeyboardInterrupt


def _install_stop_handlers() -> dict[int, object]:
    """Route SIGTERM and SIGHUP into KeyboardInterrupt (main thread only); the previous
    handlers, to restore."""
    import threading

    _received.clear()
    if threading.current_thread() is not threading.main_thread():
        return {}
    return {sig: signal.signal(sig, _stop) for sig in STOP_SIGNALS}


def _forget_unhandled_interrupt() -> None:
    """A KeyboardInterrupt raised inside code an extension runs through ``PyRun_String``
    (e.g. while it imports) leaves CPython's "unhandled KeyboardInterrupt" flag set though
    it was handled here, and the interpreter would then exit by SIGINT (130) instead of our
    143 or 129. Running any code through ``PyRun_String`` clears it."""
    import contextlib

    with contextlib.suppress(Exception):
        import ctypes

        ctypes.pythonapi.PyRun_SimpleString(b"pass")


def _io_error(exc: OSError) -> str:
    """One line for an I/O fault: what, where and why (``No space left on device``)."""
    where = f" '{exc.filename}'" if getattr(exc, "filename", None) else ""
    return f"cannot write or read{where}: {exc.strerror or exc}"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the exit code."""
    previous = _install_stop_handlers()
    try:
        argv = list(sys.argv[1:] if argv is None else argv)
        if argv[:1] == ["run"]:
            from impactbench.commands.run import scenario_first

            argv = scenario_first(argv)
        args = parse(argv)
        if getattr(args, "store_reset", False):
            from impactbench import store

            store.RESET_CORRUPT = True  # reset again below (tests call main repeatedly)
        return int(args.func(args) or 0)
    except ValueError as exc:  # UsageError, scenario/config validation
        if os.environ.get("IMPACTBENCH_DEBUG"):
            raise
        print(f"impactbench: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a full disk, a read-only folder: one line, never a traceback
        if os.environ.get("IMPACTBENCH_DEBUG"):
            raise
        print(f"impactbench: error: {_io_error(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:  # matrix.Interrupted says how much was stored
        print(f"impactbench: {str(exc) or 'interrupted'}", file=sys.stderr)
        if _received:
            _forget_unhandled_interrupt()
        return 128 + (_received[0] if _received else signal.SIGINT)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if "impactbench.store" in sys.modules:
            sys.modules["impactbench.store"].RESET_CORRUPT = False


if __name__ == "__main__":
    sys.exit(main())
