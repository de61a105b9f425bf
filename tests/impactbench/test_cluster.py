"""Dask execution: a run that kills its worker costs only itself, also inside a batch."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import require_engine
from impactbench.engines.base import ENGINES_ENV

from impactbench.matrix import Job, run_jobs


def test_a_dying_run_in_a_batch_costs_only_itself(monkeypatch: pytest.MonkeyPatch) -> None:
    require_engine("pymunk")
    monkeypatch.setenv(ENGINES_ENV, "crasher=crashing_adapter:CrashingAdapter")
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parent.parent / "engines"))
    jobs = [Job("matrix", "pymunk", "ball-on-plate", "injected", v, 1e-5)
            for v in (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5)]
    jobs.append(Job("matrix", "crasher", "ball-on-plate", "native", 1.0, None))
    results = run_jobs(jobs, workers=1)  # 8 runs, one worker: batches of two
    status = {r.job.id: r.run["status"] for r in results}
    assert [s for i, s in status.items() if "crasher" in i] == ["crashed"]
    assert all(s == "ok" for i, s in status.items() if "pymunk" in i), status
