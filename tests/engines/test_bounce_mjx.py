"""MJX's bounce to rest (``run_bounce``) on the real engine: MuJoCo's bounce stepped by MJX
itself in compiled scans, checked against C MuJoCo's record for the same settings.

MJX computes in 64-bit floats: the records agree to round-off (XLA orders some sums
differently). The ball's scan kinds compile once per process (their first run here takes
the trace and compile, seconds; jax's persistent cache keeps the compiled code across
processes). Tolerances are about 3× the differences measured on this machine (mujoco 4.0.0,
mujoco-mjx 3.17.0, jax 0.10.2 CPU), written beside them."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.record import Status

CUSTOMARY_S = 0.002
"""MuJoCo's default ``<option timestep>`` (s), the bounce builder's step."""

CHANNELS = ("time_s", "penetration_m", "penetration_rate_m_s", "normal_force_n",
            "velocity_1_m_s")


@pytest.fixture(scope="module")
def adapters():
    """(MJX's adapter, C MuJoCo's), skipping with the pip command of a missing one."""
    require_engine("mujoco")
    require_engine("mjx")
    return get_adapter("mjx"), get_adapter("mujoco")


def settings_for(mode: str, mujoco) -> RunSettings:
    """Each mode's settings: custom a solref that bounces (0.01, 0.5), tuned native's
    solref and solimp as a tuned file."""
    if mode == "custom":
        return RunSettings(params={"solref": [0.01, 0.5]})
    if mode == "tuned":
        native = mujoco.run(Bounce(max_time_s=0.6), "native")
        return RunSettings(tuned={"solref": native.meta["solref"],
                                  "solimp": native.meta["solimp"]})
    return RunSettings()


def assert_same_record(ours, theirs, rtol: float) -> None:
    """Same status, length and samples: each channel within ``rtol`` of its largest
    magnitude in C MuJoCo's record."""
    assert (ours.status, ours.message) == (theirs.status, theirs.message)
    assert len(ours) == len(theirs)
    for name in CHANNELS:
        got, ref = getattr(ours, name), getattr(theirs, name)
        assert np.max(np.abs(got - ref)) <= rtol * np.max(np.abs(ref)), name
    assert ours.meta["settled"] == theirs.meta["settled"]
    assert ours.meta["steps"] == theirs.meta["steps"]


@pytest.mark.parametrize("mode", ["default", "custom", "native", "tuned", "injected"])
def test_mjx_bounce_record_is_c_mujocos(adapters, mode) -> None:
    """Every mode of the ball builder, at the customary 2 ms, MJX against C MuJoCo. Measured
    (largest difference over the channel's largest magnitude): default 6.4e-15, custom
    3.3e-13, native and tuned 1.8e-13, injected 2.8e-13 — the default contact and the
    custom one settle (ok), the stiff ones gain energy at the first impact (diverged)."""
    mjx, mujoco = adapters
    s = Bounce(max_time_s=0.6)
    settings = settings_for(mode, mujoco)
    ours = mjx.run(s, mode, settings)
    theirs = mujoco.run(s, mode, settings)
    want = Status.OK if mode in ("default", "custom") else Status.DIVERGED
    assert ours.status is want, ours.message
    assert ours.meta["stepping"] == "lax.scan" and ours.meta["timestep_s"] == CUSTOMARY_S
    assert ours.meta["efc_diagA"] == theirs.meta["efc_diagA"]
    assert ours.meta.get("solref") == theirs.meta.get("solref")
    assert "bounce_threshold_m_s" not in ours.meta  # soft contact: no threshold
    assert_same_record(ours, theirs, rtol=1e-12)


def test_mjx_bounce_to_the_cap_spans_many_scans(adapters) -> None:
    """The whole 15 s cap at 2 ms (7500 steps, 15 of the ball's 512-step scans, the steps
    past the cap cut off) in well under a second once compiled: measured 0.28 s (0.6–0.9 s
    with the two CPUs shared). Native gains energy at each impact; the record still follows
    C MuJoCo's (measured 1.9e-13)."""
    mjx, mujoco = adapters
    s = Bounce()
    mjx.run(Bounce(max_time_s=0.3), "native")  # compiled (or loaded) before the clock
    ours = mjx.run(s, "native")
    assert ours.status is Status.DIVERGED and len(ours) == 7501
    assert ours.meta["steps"] == 7500 > 10 * ours.meta["chunk_steps"]
    assert ours.meta["wall_s"] < 5.0
    assert_same_record(ours, mujoco.run(s, "native"), rtol=1e-12)
