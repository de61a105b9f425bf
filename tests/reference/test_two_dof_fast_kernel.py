"""The compiled 2-DOF kernel's fast paths give the numbers of the plain ones, bit for bit:
the written-out DOP853 tableau, the unrolled step, and a chunk solved in one call."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from impactbench.reference import two_dof, two_dof_fast
from impactbench.reference.scenarios import RigidFlexible
from scipy.integrate._ivp import dop853_coefficients as dc


def test_the_tableau_is_scipys_dop853() -> None:
    assert np.array_equal(two_dof_fast._A, dc.A[:12, :12])
    assert np.array_equal(two_dof_fast._B, dc.B)


_A_FULL = np.ascontiguousarray(dc.A[:12, :12])
_B_FULL = np.ascontiguousarray(dc.B)


def _step_loop(y, h, k, f0, m1, m2, k2, beta, K, tmp, out):
    """One step as the kernel took it before: a loop over every A[s, r], zeros included."""
    rhs = two_dof_fast._rhs
    rhs(y, k, f0, m1, m2, k2, beta, K[0])
    for s in range(1, 12):
        for j in range(4):
            acc = 0.0
            for r in range(s):
                acc += _A_FULL[s, r] * K[r, j]
            tmp[j] = y[j] + h * acc
        rhs(tmp, k, f0, m1, m2, k2, beta, K[s])
    for j in range(4):
        acc = 0.0
        for r in range(12):
            acc += _B_FULL[r] * K[r, j]
        out[j] = y[j] + h * acc


def test_the_unrolled_step_is_the_loop_over_the_whole_tableau() -> None:
    loop = two_dof_fast.njit(error_model="numpy")(_step_loop)  # compiled like the kernel
    rng = np.random.default_rng(7)
    K, tmp, out, want = np.zeros((12, 4)), np.zeros(4), np.zeros(4), np.zeros(4)
    for _ in range(200):
        y = rng.normal(size=4) * 10.0 ** rng.integers(-6, 2, size=4)
        h = 10.0 ** rng.uniform(-7, -2)
        k, f0 = float(rng.choice([0.0, 1e5, 2e4])), float(rng.choice([0.0, -350.0]))
        args = (h, k, f0, 10.0, 10.0, 1e5, float(rng.choice([0.0, 3e6])))
        two_dof_fast._step(y, *args, K, tmp, out)
        loop(y, *args, K, tmp, want)
        assert out.tolist() == want.tolist()


COMBOS = list(itertools.product(("linear", "elastoplastic", "mutation", "mutation-continuous"),
                                ("linear", "softening")))


@pytest.mark.parametrize(("local", "structure"), COMBOS)
def test_a_chunk_in_one_call_is_the_kernel_point_by_point(local: str, structure: str) -> None:
    scenarios = [RigidFlexible(local=local, structure=structure, velocity_m_s=v, m2_kg=m2)
                 for v in (0.3, 2.0, 17.0, 400.0) for m2 in (1.0, 10.0)]
    code = two_dof_fast.LOCAL_CODES[local]
    params = np.array([two_dof_fast.kernel_params(sc)[1] for sc in scenarios])
    many = two_dof_fast.run_many(code, params)
    one = np.array([two_dof_fast.run(sc) for sc in scenarios], dtype=float)
    assert many.shape == (len(scenarios), len(two_dof_fast.RESULTS))
    assert np.array_equal(many, one)


@pytest.mark.parametrize("over", ["velocity", "k1", "k2", "m2"])
@pytest.mark.parametrize(("local", "structure"), COMBOS)
def test_sweep_params_are_with_parameter_point_by_point(over: str, local: str,
                                                        structure: str) -> None:
    base = RigidFlexible(local=local, structure=structure, velocity_m_s=3.0)
    values = {"velocity": [0.1, 2.7, 999.9], "k1": [1e3, 3.3e4, 7.1e5],
              "k2": [1e3, 3.3e4, 7.1e6], "m2": [0.1, 3.3, 77.0]}[over]
    p = two_dof.sweep_params(base, over, values)
    want = [two_dof_fast.kernel_params(two_dof.with_parameter(base, over, v))[1] for v in values]
    assert p.tolist() == [list(row) for row in want]


def test_sweep_block_is_sweep_chunk_and_solve() -> None:
    task = two_dof.sweep_tasks(RigidFlexible(), "velocity", [0.5, 3.0, 40.0],
                               [("elastoplastic", "softening")])[0]
    block, rows = two_dof.sweep_block(task), two_dof.sweep_chunk(task)
    for i, v in enumerate(task[2]):
        r = two_dof.solve(task[0].replace(velocity_m_s=v))
        assert rows[i] == {"local": "elastoplastic", "structure": "softening",
                           "velocity_m_s": v, **{k: r[k] for k in two_dof.METRIC_KEYS},
                           "status": r["status"]}
        assert [block[k][i] for k in two_dof.METRIC_KEYS] == [r[k] for k in two_dof.METRIC_KEYS]
        assert block["status"][i] == r["status"]
    assert block["impacts"].dtype == np.int64


def _rounding_up_k1() -> float:
    """A k1 for which kt = k1·(k1/k1_base) of a base with kt = k1 rounds above k1."""
    for v in np.linspace(1.0, 2.0, 1000):
        if 3.0 * (float(v) / 3.0) > float(v):
            return float(v)
    raise AssertionError("no such value")  # pragma: no cover


def test_a_point_the_scenario_refuses_fails_the_sweep_up_front_with_its_message() -> None:
    base = RigidFlexible(local="elastoplastic", k1_n_per_m=3.0, kt_n_per_m=3.0,
                         k1_failed_n_per_m=1.0)
    bad = _rounding_up_k1()
    with pytest.raises(ValueError) as want:
        two_dof.with_parameter(base, "k1", bad)
    for call in (lambda: two_dof.sweep_tasks(base, "k1", [1.0, bad]),
                 lambda: two_dof.sweep(base, "k1", [1.0, bad],
                                       combos=[("elastoplastic", "linear")]),
                 lambda: two_dof.sweep_params(base, "k1", [bad])):
        with pytest.raises(ValueError) as got:
            call()
        assert str(got.value) == str(want.value)
    # the linear law has no such rule: the same values sweep
    assert len(two_dof.sweep(base, "k1", [1.0, bad], combos=[("linear", "linear")])) == 2


def test_bad_swept_values_name_the_field() -> None:
    with pytest.raises(ValueError, match=r"^velocity_m_s = -2.0: must be > 0"):
        two_dof.sweep_tasks(RigidFlexible(), "velocity", [1.0, -2.0, 0.0])
    with pytest.raises(ValueError, match=r"^k1_n_per_m = inf: must be > 0"):
        two_dof.sweep_params(RigidFlexible(), "k1", [np.inf])
