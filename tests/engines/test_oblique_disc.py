"""The disc (``Oblique.shape = "disc"``) in the 3D engines: ``unsupported`` with the reason,
decided centrally (:func:`impactbench.engines.oblique_common.finish`, which every oblique
builder calls; only the 2D engines mark their records planar). Real engines, each skipped
when it is not installed."""

from __future__ import annotations

import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.oblique_common import DISC_UNSUPPORTED
from impactbench.reference.oblique import Oblique
from impactbench.reference.record import Status

from impactbench.evaluate import compare


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
@pytest.mark.parametrize("mode", ["native", "injected"])
def test_a_3d_engine_returns_unsupported_for_a_disc(engine, mode):
    require_engine(engine)
    rec = get_adapter(engine).run(Oblique(angle_deg=30.0, shape="disc"), mode, RunSettings())
    assert rec.status is Status.UNSUPPORTED
    assert rec.message == DISC_UNSUPPORTED and "disc" in rec.message
    assert len(rec) == 0 and rec.meta["engine"] == engine
    out, _ = compare(engine, Oblique(angle_deg=30.0, shape="disc"), mode, RunSettings())
    assert out["status"] == "unsupported" and "2D engines" in out["message"]
    # the sphere still runs
    assert get_adapter(engine).run(Oblique(angle_deg=30.0), mode, RunSettings()).ok
