"""The floor of a million-velocity ball sweep: a bare process doing the least such a sweep can.

``python -m benchmarks.floor_ball OUT.parquet [COUNT]`` imports numpy, scipy and pandas,
evaluates the Lambert W closed form of the restitution, k(α) = (1 + W₀(−(1+α)·e^(−(1+α))))/α,
on COUNT velocities (default 10⁶: 0.001, 0.002, …, 1000 m/s, α = 0.1 s/m · V0) and writes a
table of the same shape as the sweep's (velocity and five float64 columns, through pandas
and pyarrow) as Parquet. No validation, no refinement, no other metric: a yardstick for
``impactbench sweep ball-on-plate`` (:mod:`benchmarks.bench_reference_ball` times both as
fresh processes, alternately, and prints the ratio of their medians; target ≤ 2).
"""

from __future__ import annotations

import sys

COUNT = 1_000_000
START = STEP = 0.001
DAMPING_S_PER_M = 0.1


def main(argv: list[str]) -> int:
    import numpy as np
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq
    from scipy import special

    out = argv[0]
    count = int(argv[1]) if len(argv) > 1 else COUNT
    v = START + STEP * np.arange(count, dtype=float)
    a = DAMPING_S_PER_M * v
    w = special.lambertw(-(1.0 + a) * np.exp(-(1.0 + a)), 0).real
    k = (1.0 + w) / a
    frame = pd.DataFrame({"velocity_m_s": v, "restitution": k, "duration_s": k * v,
                          "peak_force_n": w * v, "max_penetration_m": w * a,
                          "energy_loss_fraction": (1.0 - k) * (1.0 + k)})
    pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
