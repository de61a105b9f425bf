"""The cases every engine-overhead benchmark times (adapter against a bare stepping loop):
the ball in native mode at the default and the finest timestep and in injected mode, and the
rigid–flexible model native (linear and softening structure) and injected (elastoplastic);
and the pieces the benchmarks that print their own table share."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.record import ImpactRecord
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

CASES: tuple[tuple[str, BallOnPlate | RigidFlexible, str, float], ...] = (
    ("ball V0=1 native dt=1e-6", BallOnPlate(velocity_m_s=1.0), "native", 1e-6),
    ("ball V0=1 native dt=1e-7", BallOnPlate(velocity_m_s=1.0), "native", 1e-7),
    ("ball V0=5 injected dt=1e-7", BallOnPlate(velocity_m_s=5.0), "injected", 1e-7),
    ("rf lin/lin v1=3.3 native dt=1e-5", RigidFlexible(velocity_m_s=3.3), "native", 1e-5),
    ("rf lin/soft v1=3.3 native dt=1e-5",
     RigidFlexible(velocity_m_s=3.3, structure="softening"), "native", 1e-5),
    ("rf ep/lin v1=3.3 injected dt=1e-5",
     RigidFlexible(velocity_m_s=3.3, local="elastoplastic"), "injected", 1e-5),
)


def table_head(engine: str, title: str, bare: str, repeats: int, header: str) -> Any:
    """``engine``'s adapter, once the head of its overhead table is printed: the line "TITLE
    VERSION: adapter vs BARE (alternated, median of REPEATS)", then the column ``header``,
    underlined."""
    adapter = get_adapter(engine)
    print(f"{title} {adapter.version()}: adapter vs {bare} (alternated, median of {repeats})")
    print(header)
    print("-" * len(header))
    return adapter


def warmed_up(adapter: Any) -> Iterator[tuple[str, Any, str, float, RunSettings,
                                              ImpactRecord]]:
    """Each of :data:`CASES` as (label, scenario, mode, dt, settings at dt, record): the
    adapter's first run of the case, a warm-up (imports, compilation, caches) whose record
    gives the step count and the meta."""
    for label, scenario, mode, dt in CASES:
        settings = RunSettings(timestep_s=dt)
        yield label, scenario, mode, dt, settings, adapter.run(scenario, mode, settings)


def rerun(adapter: Any, scenario: Any, mode: str, settings: RunSettings
          ) -> Callable[[], ImpactRecord]:
    """The adapter side of a timed pair: a call that runs the case again."""
    return lambda: adapter.run(scenario, mode, settings)
