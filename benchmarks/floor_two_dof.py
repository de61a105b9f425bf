"""The floor of the 60,000-point 2-DOF sweep: a bare process doing the least such a sweep can.

``python -m benchmarks.floor_two_dof OUT.parquet [THREADS]`` imports numpy, pyarrow and the
compiled kernel (:mod:`impactbench.reference.two_dof_fast`, numba, from its on-disk cache),
writes the kernel's inputs for v1 = 0.1, 0.2, …, 1000 m/s × the 6 law combinations of the
paper's base parameters straight into arrays (no scenario, no validation, no store), solves
them in the sweep's chunks on THREADS threads (default: one per core, as the command does)
and writes the five metrics and the status as Parquet with pyarrow (pandas never imported).
A yardstick for ``impactbench sweep rigid-flexible … --fresh``
(:mod:`benchmarks.bench_two_dof` times both as fresh processes, alternately).
"""

from __future__ import annotations

import os
import sys

START, STEP, COUNT = 0.1, 0.1, 10_000
CHUNK = 250


def main(argv: list[str]) -> int:
    from concurrent.futures import ThreadPoolExecutor

    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq
    from impactbench.reference import two_dof_fast as fast
    from impactbench.reference.scenarios import RigidFlexible

    out = argv[0]
    threads = int(argv[1]) if len(argv) > 1 else len(os.sched_getaffinity(0))
    v = START + STEP * np.arange(COUNT, dtype=float)
    tasks = []
    for local in ("linear", "elastoplastic", "mutation"):
        for structure in ("linear", "softening"):
            code, row = fast.kernel_params(RigidFlexible(local=local, structure=structure))
            params = np.tile(np.asarray(row, dtype=float), (COUNT, 1))
            params[:, 0] = v
            tasks += [(code, params[i:i + CHUNK]) for i in range(0, COUNT, CHUNK)]
    with ThreadPoolExecutor(threads) as pool:
        results = np.concatenate(list(pool.map(lambda t: fast.run_many(*t), tasks)))
    names = fast.RESULTS

    def column(values: np.ndarray) -> pa.Array:  # no pa.array: it would import pandas
        values = np.ascontiguousarray(values)
        kind = pa.float64() if values.dtype == np.float64 else pa.int64()
        return pa.Array.from_buffers(kind, len(values), [None, pa.py_buffer(values)])

    labels = "".join(fast.STATUS_NAMES).encode()
    offsets = np.cumsum([0, *map(len, fast.STATUS_NAMES)]).astype(np.int32)
    status = pa.DictionaryArray.from_arrays(
        column(results[:, 0].astype(np.int64)),
        pa.Array.from_buffers(pa.string(), len(fast.STATUS_NAMES),
                              [None, pa.py_buffer(offsets), pa.py_buffer(labels)]))
    keys = ("peak_force_n", "pulse_width_s", "contact_time_s", "impulse_ns")
    table = pa.Table.from_arrays(
        [column(np.tile(v, 6)), *(column(results[:, names.index(k)]) for k in keys),
         column(results[:, names.index("impacts")].astype(np.int64)), status],
        names=["velocity_m_s", *keys, "impacts", "status"])
    pq.write_table(table, out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
