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


def assert_same_record(ours, theirs, rtol: float, samples: int | None = None) -> None:
    """Same status and length, and the first ``samples`` (None: all) equal: each channel
    within ``rtol`` of its largest magnitude in C MuJoCo's record."""
    assert ours.status == theirs.status and len(ours) == len(theirs)
    for name in CHANNELS:
        got, ref = getattr(ours, name)[:samples], getattr(theirs, name)[:samples]
        assert np.max(np.abs(got - ref)) <= rtol * np.max(np.abs(ref)), name
    assert ours.meta["settled"] == theirs.meta["settled"]
    assert ours.meta["steps"] == theirs.meta["steps"]


@pytest.mark.parametrize("mode", ["default", "custom", "native", "tuned", "injected"])
def test_mjx_bounce_record_is_c_mujocos(adapters, mode) -> None:
    """Every mode of the ball builder, at the customary 2 ms, MJX against C MuJoCo. Measured
    (largest difference over the channel's largest magnitude): default 6.4e-15, custom
    3.3e-13, native and tuned 1.8e-13, injected 2.8e-13 — the default contact and the
    custom one settle (ok); the stiff ones (~0.1 ms contacts) gain energy at the first
    impact (diverged, stopped by the end rule one step after it)."""
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
    """A ball that bounces to the 15 s cap (a direct solref (−2e4, −1): 2000 N/m, ζ 0.004,
    44 contacts) takes 7500 steps, 15 of the ball's 512-step scans (the steps past the cap
    cut off), in well under a second once compiled: measured 0.37 s.

    Round-off grows from bounce to bounce (the step a contact starts at amplifies it):
    measured against C MuJoCo, the penetration's difference passes 1e-13 of its scale at
    1.49 s (4th contact), 1e-12 at 2.87 s, 1e-6 at 8.9 s, 1e-2 at 12.7 s. The first second
    (two contacts) is compared to 1e-12: measured 4.5e-14."""
    mjx, mujoco = adapters
    s, settings = Bounce(), RunSettings(params={"solref": [-2e4, -1.0]})
    mjx.run(Bounce(max_time_s=0.3), "custom", settings)  # compiled (or loaded) before
    ours = mjx.run(s, "custom", settings)
    assert ours.status is Status.MAX_TIME and len(ours) == 7501, ours.message
    assert ours.meta["steps"] == 7500 > 10 * ours.meta["chunk_steps"]
    assert ours.meta["wall_s"] < 5.0
    assert_same_record(ours, mujoco.run(s, "custom", settings), rtol=1e-12, samples=500)
