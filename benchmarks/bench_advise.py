"""The advisor's wall time per engine and step: ``impactbench advise`` as a user runs it.

For each installed engine at each of its customary steps (its spec's ``advice_timesteps_s``),
on the paper's steel ball over 0.5–5 m/s (six speeds, eight phases each), one
:func:`impactbench.advise.advise` call as the command runs it (its contact models searched on
one worker process per core, the default 60 s cap): its wall time, how many candidates it
evaluated, whether the cap cut it (``stop``), the chosen model and the worst restitution
error over speeds and phases. The target is ≤ 60 s per engine on the 2-core machine; the
search is a fixed number of evaluations, so the answer does not depend on the machine unless
the cap is reached.

Run: ``python -m benchmarks advise`` (or this file directly; names of engines as arguments
pick some: ``python benchmarks/bench_advise.py pybullet mujoco``).
"""

from __future__ import annotations

import sys
import time

from impactbench.engines.advice_models import ENGINE_STEPS_S
from impactbench.engines.base import available_engines

from impactbench.advise import advise


def main(engines: list[str] | None = None) -> None:
    """One row per engine and customary step (see the module)."""
    installed = set(available_engines())
    print(f"{'engine':<9} {'step (s)':>10} {'wall (s)':>9} {'cands':>6} {'worst err':>10}  "
          "plausible  model  [stop]")
    for engine, steps in ENGINE_STEPS_S.items():
        if (engines and engine not in engines) or engine not in installed:
            continue
        for dt in steps:
            t0 = time.perf_counter()
            a = advise(engine, dt, fallback=False, workers=None)
            wall = time.perf_counter() - t0
            print(f"{engine:<9} {dt:>10.4g} {wall:>9.1f} {len(a.tried):>6} "
                  f"{100 * a.worst_error:>9.1f}%  {a.plausible!s:<9}  {a.model}  "
                  f"[{a.stop}]", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or None)
