"""``python -m benchmarks [NAME…] [--OPTION …]``: run every ``bench_*`` module's ``main()``, or
the named ones.

A NAME is a module name with or without its ``bench_`` prefix (``reference_ball`` or
``bench_reference_ball``). Exit 2 on an unknown name. Everything from the first ``--``
argument on is the benchmark's own options, in its ``sys.argv[1:]`` (``python -m benchmarks
report --rounds 3``).
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path


def available() -> list[str]:
    return sorted(p.stem for p in Path(__file__).parent.glob("bench_*.py"))


def main(argv: list[str]) -> int:
    names = available()
    if any(a in ("-h", "--help") for a in argv):
        print(__doc__.strip())
        print("\nbenchmarks: " + ", ".join(n.removeprefix("bench_") for n in names))
        return 0
    cut = next((i for i, a in enumerate(argv) if a.startswith("--")), len(argv))
    argv, options = argv[:cut], argv[cut:]
    chosen = []
    for arg in argv:
        name = arg if arg.startswith("bench_") else f"bench_{arg}"
        name = name.removesuffix(".py")
        if name not in names:
            print(f"benchmarks: error: {arg!r} is not one of {', '.join(names)}", file=sys.stderr)
            return 2
        chosen.append(name)
    for name in chosen or names:
        print(f"== {name} ==", flush=True)
        sys.argv = [name, *options]
        importlib.import_module(f"benchmarks.{name}").main()
        print(flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
