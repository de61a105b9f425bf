"""A JIT engine's first-use compile does not count against a run's timeout: MJX and Newton
timed out (60 s) in a small oblique report on a busy 2-core machine while compiling for the
first time, and again on the rerun. The allowance is an engine fact (``EngineSpec``), added
to the default and to a given timeout alike, and a timeout says how to raise it."""

from __future__ import annotations

import math

from impactbench.engines.registry import SPECS
from impactbench.reference.scenarios import BallOnPlate

from impactbench import cluster
from impactbench.evaluate import timed_out


def test_the_compiling_engines_have_an_allowance_and_the_others_none() -> None:
    assert {e for e, s in SPECS.items() if s.first_use_s > 0} == {"mjx", "newton"}
    assert cluster.first_use_s("mjx") == 120.0 and cluster.first_use_s("mujoco") == 0.0
    assert cluster.first_use_s("no-such-engine") == 0.0


def test_a_run_timeout_adds_the_allowance_to_the_default_and_to_a_given_one() -> None:
    from impactbench import api
    from impactbench.scenarios import get

    spec = get("ball-on-plate")
    base = cluster.default_timeout(cluster.run_estimate_s(1e6))
    assert math.isclose(api._timeout(None, 1e6, spec, "newton"), base + 120.0)
    assert math.isclose(api._timeout(None, 1e6, spec, "pybullet"), base)
    assert math.isclose(api._timeout(30.0, 1e6, spec, "mjx"), 150.0)


def test_a_timeout_says_how_to_raise_it_and_what_the_compile_took() -> None:
    out = timed_out("mjx", BallOnPlate(), "native", None, {}, 180.0)
    assert out["status"] == "timeout"
    assert "120 s of it for mjx's first-use compile" in out["message"]
    assert "--timeout S, or [execution] timeout_s in a config, allows longer" in out["message"]
