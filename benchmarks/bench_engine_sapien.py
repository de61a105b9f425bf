"""PhysX (SAPIEN) adapter overhead: ``adapter.run`` against a bare ``scene.step()`` loop
(see :mod:`benchmarks.stepped`). Run: ``python -m benchmarks bench_engine_sapien``."""

from __future__ import annotations

from benchmarks import stepped


def main() -> None:
    from impactbench.engines import sapien_adapter

    stepped.main("sapien", sapien_adapter)


if __name__ == "__main__":
    main()
