"""The tuner at a step longer than the contact scores each velocity at its worst phase of the
step (8 phases), and says so in the tuned file's provenance; at a step that resolves the
contact it runs the one phase, as before (real engine: pymunk, whose rigid contact is
milliseconds a run)."""

from __future__ import annotations

import pytest
from conftest import require_engine

import impactbench
from impactbench.phases import PHASES


def test_a_coarse_step_is_tuned_on_every_phase(tmp_path) -> None:
    require_engine("pymunk")
    fit = impactbench.tune(engine="pymunk", timestep_s=1 / 60, velocities_m_s=(1.0, 3.0),
                           targets=("restitution",), max_evals=3, store=False)
    assert fit.data["phases"] == PHASES
    path = tmp_path / "pymunk_60.toml"
    impactbench.tune(engine="pymunk", timestep_s=1 / 60, velocities_m_s=(1.0, 3.0),
                     targets=("restitution",), max_evals=3, store=False, out=path)
    import tomllib

    prov = tomllib.loads(path.read_text())["provenance"]
    assert prov["phases"] == PHASES
    assert prov["runs_per_evaluation"] == 2 * PHASES
    fine = impactbench.tune(engine="pymunk", timestep_s=1e-5, velocities_m_s=(1.0,),
                            targets=("restitution",), max_evals=2, store=False)
    assert fine.data["phases"] == 1


def test_phases_is_checked() -> None:
    require_engine("pymunk")
    with pytest.raises(ValueError, match="phases = 0"):
        impactbench.tune(engine="pymunk", timestep_s=1 / 60, velocities_m_s=(1.0,),
                         targets=("restitution",), max_evals=1, store=False, phases=0)
