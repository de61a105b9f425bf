"""CLI start-up: ``impactbench --help`` (and some subcommand ``--help``) against ``python -c pass``.

Every command is started as a fresh process once per round, the rounds alternated (pass,
--help, …, pass, --help, …) so all see the same machine load
(:func:`benchmarks.alternate.alternate`); the minimum and the median wall times are printed,
with the ratio of each minimum to the bare interpreter's (the same venv interpreter, its
``site`` start-up included). Target: ``impactbench --help`` and a bare ``impactbench`` (no
command: the one-line error, exit 2) within :data:`TARGET_RATIO` × ``python -c pass``
(minima). The top level is lazy: it lists the commands from :data:`impactbench.cli.COMMANDS`
and builds a command's parser only when it is chosen, so ``--help`` imports no command, no
scenario and no entry point (``tests/impactbench/test_cli_startup.py`` checks that; a
subcommand's help imports no heavy library). Run: ``python -m benchmarks cli_startup``.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

from benchmarks.alternate import alternate

ROUNDS = 15
TARGET_RATIO = 4.0
"""``impactbench --help`` (minimum) at most this many times ``python -c pass`` (minimum)."""
TARGETED = ("impactbench --help", "impactbench")


def commands() -> dict[str, list[str]]:
    script = Path(sys.executable).with_name("impactbench")
    cli = [str(script)] if script.is_file() else [sys.executable, "-m", "impactbench.cli"]
    return {
        "python -c pass": [sys.executable, "-c", "pass"],
        "impactbench --help": [*cli, "--help"],
        "impactbench": cli,
        "impactbench run --help": [*cli, "run", "--help"],
        "impactbench tune --help": [*cli, "tune", "--help"],
        "impactbench figures --help": [*cli, "figures", "--help"],
        "impactbench sweep rigid-flexible --help": [*cli, "sweep", "rigid-flexible", "--help"],
    }


def _started(cmd: list[str], expect: int) -> Callable[[], None]:
    """A contender: ``cmd`` as a fresh process, its output discarded; an exit code other than
    ``expect`` (0, or 2 for a bare ``impactbench``'s one-line error) raises."""

    def run() -> None:
        done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        if done.returncode != expect:
            raise RuntimeError(f"{' '.join(cmd)}: exit {done.returncode}: {done.stderr!r}")

    return run


def main() -> None:
    cmds = commands()
    times = alternate({name: _started(cmd, 2 if name == "impactbench" else 0)
                       for name, cmd in cmds.items()}, ROUNDS)
    base = min(times["python -c pass"])
    print(f"{'command':42s} {'min (s)':>8s} {'median (s)':>10s} {'min / pass':>10s}")
    for name, t in times.items():
        print(f"{name:42s} {min(t):8.3f} {statistics.median(t):10.3f} {min(t) / base:10.1f}")
    for name in TARGETED:
        best = min(times[name])
        verdict = "meets" if best <= TARGET_RATIO * base else "MISSES"
        print(f"{name}: {best:.3f} s = {best / base:.1f}× python -c pass ({base:.3f} s), "
              f"{verdict} the target of {TARGET_RATIO:g}×")


if __name__ == "__main__":
    main()
