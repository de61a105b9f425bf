"""The Python API names a mistyped budget in one line (ValueError), before any run."""

from __future__ import annotations

import pytest

import impactbench


@pytest.mark.parametrize("value", ["5", 2.5, True, 0, -3, float("nan")])
def test_tune_max_evals_must_be_a_positive_integer(value) -> None:
    # before: max_evals="5" passed int("5") >= 1 and failed deep in the search with
    # "TypeError: unsupported operand type(s) for -: 'str' and 'int'"
    with pytest.raises(ValueError, match=r"^max_evals = .*: must be an integer >= 1"):
        impactbench.tune(engine="pymunk", timestep_s=1e-3, velocities_m_s=(1.0,),
                         targets=("restitution",), max_evals=value, store=False)
