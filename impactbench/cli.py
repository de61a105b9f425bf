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


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="impactbench", description=DESCRIPTION)
    parser.add_argument("--version", action=_VersionAction)
    top, groups = add_commands(parser)
    from impactbench import scenarios

    for spec in scenarios.specs():  # each scenario's own subcommands (reference NAME, …)
        spec.register_commands(top, groups)
    for module in COMMAND_MODULES:
        importlib.import_module(module).register(top, groups)
    return parser


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
        from impactbench.commands.run import scenario_first

        argv = scenario_first(sys.argv[1:] if argv is None else argv)
        args = build_parser().parse_args(argv)
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
