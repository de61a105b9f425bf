"""The registry and the safe runner: unknown names, absent engines, crashes as statuses."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from impactbench.engines.base import (
    ENGINES,
    PIP,
    EngineUnavailable,
    RunSettings,
    get_adapter,
    run_safely,
)
from impactbench.engines.registry import spec
from impactbench.reference.scenarios import BallOnPlate


def test_unknown_engine_gets_a_hint() -> None:
    with pytest.raises(ValueError, match="did you mean 'mujoco'"):
        get_adapter("mujocco")
    with pytest.raises(ValueError, match="engine = 'nope'"):
        run_safely("nope", BallOnPlate())


def test_unknown_mode_is_bad_input() -> None:
    with pytest.raises(ValueError, match="mode = 'fast'"):
        run_safely("mujoco", BallOnPlate(), mode="fast")


def test_bad_settings_name_the_field() -> None:
    with pytest.raises(ValueError, match="timestep_s = -1"):
        RunSettings(timestep_s=-1)


def test_engine_unavailable_names_the_pip_command() -> None:
    exc = EngineUnavailable("drake")
    assert "pip install drake" in str(exc)


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_absent_engine_becomes_status_unavailable(engine: str) -> None:
    """In a fresh interpreter where the engine's package cannot be imported."""
    module = spec(engine).module or engine  # its spec's import name (pydrake, Box2D, …)
    code = (
        "import sys, json\n"
        f"sys.modules[{module!r}] = None  # makes `import {module}` raise ImportError\n"
        "from impactbench.engines.base import run_safely\n"
        "from impactbench.reference.scenarios import BallOnPlate\n"
        f"rec = run_safely({engine!r}, BallOnPlate())\n"
        "print(json.dumps({'status': str(rec.status), 'message': rec.message}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["status"] == "unavailable"
    assert PIP[engine] in got["message"]


def test_run_many_without_a_batch_is_run_one_by_one() -> None:
    """An engine whose builders do not batch (pymunk): run_many gives run's records, a
    refused run (tuned without parameters) included; bad input still raises, one line."""
    pytest.importorskip("pymunk", reason=f"pymunk not installed: run `{spec('pymunk').pip}`")
    from impactbench.engines.base import run_many_safely

    adapter = get_adapter("pymunk")
    items = [(BallOnPlate(velocity_m_s=v), mode, RunSettings(timestep_s=1e-5))
             for v in (0.5, 2.0) for mode in ("native", "tuned")]
    many = adapter.run_many(items)
    alone = [adapter.run(*item) for item in items]
    assert [str(r.status) for r in many] == [str(r.status) for r in alone]
    assert "unsupported" in {str(r.status) for r in many}
    for a, b in zip(alone, many, strict=True):
        assert list(a.penetration_m) == list(b.penetration_m) and a.message == b.message
    with pytest.raises(ValueError, match="param = 'nope'"):
        run_many_safely("pymunk", [(BallOnPlate(), "custom",
                                    RunSettings(params={"nope": 1.0}))])
