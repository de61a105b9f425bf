"""The sweeps' fast paths give the plain paths' results: the ball sweep's columns without
pandas, the Chebyshev evaluation in blocks, the restitution iterated only where unconverged,
and the 2-DOF sweep solved on threads from arrays."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from impactbench.reference import hunt_crossley as hc
from impactbench.reference import two_dof, zoo
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

from impactbench import sweeps
from impactbench.cliutil import write_table


def test_the_ball_sweeps_columns_are_its_frame() -> None:
    v = np.geomspace(1e-3, 1e3, 3000)
    for scenario in (BallOnPlate(), BallOnPlate(model="flores", nominal_restitution=0.7),
                     BallOnPlate(model="kelvin-voigt", nominal_restitution=0.7,
                                 exponent=1.0, stiffness=1e7)):
        cols = zoo.sweep_columns(scenario, v)
        frame = zoo.sweep(scenario, v)
        assert list(cols) == list(frame.columns)
        pd.testing.assert_frame_equal(pd.DataFrame(cols), frame, check_exact=True)
        assert all(np.asarray(c).dtype == np.float64 for c in cols.values())


def test_restitution_of_a_point_does_not_depend_on_the_others() -> None:
    """Each point stops iterating when its own step is below 4 ulp: its value no longer
    depends on the slowest point of the array it came with."""
    a = np.concatenate([np.geomspace(1e-9, 0.049, 300), np.geomspace(0.05, 1e4, 300)])
    together = hc.restitution(a)
    alone = np.array([hc.restitution(x) for x in a])
    assert np.array_equal(together, alone)
    assert hc.restitution(0.0) == 1.0 and isinstance(hc.restitution(0.5), float)
    assert hc.restitution(a.reshape(20, 30)).shape == (20, 30)


def test_restitution_solves_its_equation() -> None:
    """k solves (1+k)·α − ln(1+α) + ln(1 − kα) = 0 to round-off (in the cancellation-free
    form of the module: ũ²·q(αũ) = G(α) at ũ_r)."""
    a = np.geomspace(1e-8, 1e4, 2000)
    ur = hc._u_restitution(a)
    resid = ur * ur * hc._q2(a * ur) - hc._g2(a)
    assert np.max(np.abs(resid) / hc._g2(a)) < 1e-14


@pytest.mark.parametrize("shuffle", [False, True])
def test_the_chebyshev_table_evaluates_as_chebval(shuffle: bool) -> None:
    a = np.geomspace(1e-4, 100.0, 50_000)
    if shuffle:
        a = np.random.default_rng(3).permutation(a)
    table = hc.ChebyshevTable.build(float(a.min()), float(a.max()), 1.5)
    tau, peak = table(a)
    s = np.log1p(a)
    piece = np.clip(np.searchsorted(table.breaks, s, side="right") - 1, 0,
                    len(table.coefs) - 1)
    for p in range(len(table.coefs)):
        at = piece == p
        lo, hi = table.breaks[p], table.breaks[p + 1]
        t = (2.0 * s[at] - lo - hi) / (hi - lo)
        assert np.array_equal(tau[at], np.polynomial.chebyshev.chebval(t, table.coefs[p, 0]))
        assert np.array_equal(peak[at], np.polynomial.chebyshev.chebval(t, table.coefs[p, 1]))


def test_a_mapping_and_a_frame_write_the_same_table(tmp_path) -> None:
    cols = zoo.sweep_columns(BallOnPlate(), np.linspace(0.1, 5.0, 50))
    for ext in ("csv", "parquet"):
        write_table(cols, tmp_path / f"a.{ext}")
        write_table(pd.DataFrame(cols), tmp_path / f"b.{ext}")
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "a.parquet"),
                                  pd.read_parquet(tmp_path / "b.parquet"), check_exact=True)


def test_the_ball_sweep_command_imports_no_pandas_scipy_integrate_or_optimize(tmp_path) -> None:
    code = ("import sys; from impactbench.cli import main; "
            f"main(['sweep', 'ball-on-plate', '--over', 'velocity', '--start', '0.1', "
            f"'--stop', '5', '--step', '0.1', '--out', {str(tmp_path / 'x.csv')!r}]); "
            "print(sorted(m for m in ('pandas', 'scipy.integrate', 'scipy.optimize') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
    assert len(pd.read_csv(tmp_path / "x.csv")) == 50


def test_on_threads_here_with_repeats_the_frame_is_the_solvers() -> None:
    """Default placement: the points solve here, a thread per core (more than two chunks);
    values unsorted and repeated, as the solver keeps them."""
    values = np.concatenate([np.linspace(40.0, 1.0, 3 * two_dof.SWEEP_CHUNK + 3), [2.0, 2.0]])
    combos = [("mutation", "softening"), ("linear", "linear")]
    base = RigidFlexible(velocity_m_s=5.0)
    out = sweeps.rigid_flexible(base, "velocity", values, combos)
    assert out.where == "in this process"
    assert (out.served, out.solved) == (0, 2 * (3 * two_dof.SWEEP_CHUNK + 4))
    want = two_dof.sweep(base, "velocity", values, combos=combos)
    assert out.frame.equals(want)
    pd.testing.assert_frame_equal(out.frame, want, check_exact=True)
    assert sweeps.rigid_flexible(base, "velocity", values, combos, workers=0).frame.equals(want)


@pytest.mark.parametrize("workers", [None, 0])
def test_interrupted_on_threads_stores_what_finished_and_resumes(
        tmp_path, monkeypatch: pytest.MonkeyPatch, workers: int | None) -> None:
    """Ctrl-C (here: raised by the progress callback after five chunks) stores every chunk
    that finished; the rerun solves only the others and gives the uninterrupted frame."""
    from impactbench import store as store_mod
    from impactbench.matrix import Interrupted

    monkeypatch.setattr(sweeps, "FLUSH_EVERY_S", 0.0)  # store every chunk as it finishes
    monkeypatch.setattr(store_mod, "impactbench_version", lambda: "0+test")  # fixed key
    store = store_mod.Store(tmp_path / "r.duckdb")
    values = np.linspace(0.5, 60.0, 8 * two_dof.SWEEP_CHUNK)
    combos = [("elastoplastic", "linear")]
    seen = []

    def progress(n: int) -> None:
        seen.append(n)
        if len(seen) == 5:
            raise KeyboardInterrupt

    base = RigidFlexible()
    with pytest.raises(Interrupted) as stop:
        sweeps.rigid_flexible(base, "velocity", values, combos, store=store,
                              workers=workers, progress=progress)
    assert stop.value.stored == 5 * two_dof.SWEEP_CHUNK
    again = sweeps.rigid_flexible(base, "velocity", values, combos, store=store,
                                  workers=workers)
    assert again.served == 5 * two_dof.SWEEP_CHUNK
    assert again.served + again.solved == len(values)
    assert again.frame.equals(two_dof.sweep(base, "velocity", values, combos=combos))
