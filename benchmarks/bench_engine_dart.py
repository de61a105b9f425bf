"""DART adapter overhead: ``adapter.run`` against a bare ``World.step()`` loop
(see :mod:`benchmarks.stepped`). Run: ``python -m benchmarks bench_engine_dart``."""

from __future__ import annotations

from benchmarks import stepped


def main() -> None:
    from impactbench.engines import dart_adapter

    stepped.main("dart", dart_adapter)


if __name__ == "__main__":
    main()
