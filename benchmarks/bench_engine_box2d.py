"""Box2D adapter overhead: ``adapter.run`` against a bare ``World.Step`` loop
(see :mod:`benchmarks.stepped`). Run: ``python -m benchmarks bench_engine_box2d``."""

from __future__ import annotations

from benchmarks import stepped


def main() -> None:
    from impactbench.engines import box2d_adapter

    stepped.main("box2d", box2d_adapter)


if __name__ == "__main__":
    main()
