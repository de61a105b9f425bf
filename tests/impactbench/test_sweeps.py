"""Reference sweeps through the results store and Dask: the solver's frame bit for bit, only
the missing points solved, and an interrupted sweep resumed."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from ctrl_c import interruptible_children
from impactbench.reference import two_dof
from impactbench.reference.scenarios import RigidFlexible

from impactbench import store as store_mod
from impactbench import sweeps
from impactbench.cliutil import write_table

BASE = RigidFlexible(velocity_m_s=5.0)
COMBOS = [("elastoplastic", "softening"), ("mutation", "linear")]


@pytest.fixture
def store(tmp_path: Path) -> store_mod.Store:
    return store_mod.Store(tmp_path / "r.duckdb")


def test_store_columns_are_the_solver_metrics() -> None:
    assert store_mod.POINT_KEYS == two_dof.METRIC_KEYS


def test_on_dask_the_frame_is_the_solvers(monkeypatch: pytest.MonkeyPatch,
                                          store: store_mod.Store) -> None:
    monkeypatch.setattr(sweeps, "DISPATCH_MIN_S", 0.0)  # dispatch however small
    values = np.linspace(1.0, 40.0, 2 * two_dof.SWEEP_CHUNK + 7)  # three chunks per combo
    out = sweeps.rigid_flexible(BASE, "m2", values, COMBOS, store=store, workers=2)
    assert out.where == "on 2 local workers" and (out.served, out.solved) == (0, 2 * 507)
    assert out.frame.equals(two_dof.sweep(BASE, "m2", values, combos=COMBOS))


def test_a_rerun_is_served_and_ranges_share_points(store: store_mod.Store) -> None:
    values = [1.0, 2.0, 3.0, 4.0]
    first = sweeps.rigid_flexible(BASE, "velocity", values, COMBOS, store=store, workers=0)
    again = sweeps.rigid_flexible(BASE, "velocity", values, COMBOS, store=store, workers=0)
    assert (first.served, first.solved) == (0, 8) and (again.served, again.solved) == (8, 0)
    assert again.frame.equals(first.frame)
    assert again.frame.equals(two_dof.sweep(BASE, "velocity", values, combos=COMBOS))
    wider = sweeps.rigid_flexible(BASE.replace(velocity_m_s=9.0), "velocity",
                                  [3.0, 4.0, 5.0], COMBOS, store=store, workers=0)
    assert (wider.served, wider.solved) == (4, 2)  # the base's own v1 is not a parameter
    assert wider.frame.equals(two_dof.sweep(BASE, "velocity", [3.0, 4.0, 5.0], combos=COMBOS))
    fresh = sweeps.rigid_flexible(BASE, "velocity", values, COMBOS, store=store, workers=0,
                                  fresh=True)
    assert (fresh.served, fresh.solved) == (0, 8) and fresh.frame.equals(first.frame)


def test_other_fixed_parameters_never_share_points(store: store_mod.Store) -> None:
    values = [5e4, 1e5]
    sweeps.rigid_flexible(BASE, "k1", values, COMBOS, store=store, workers=0)
    # the same k1 values, but kt scales from another fraction of k1: other points
    other = BASE.replace(kt_n_per_m=1e4)
    out = sweeps.rigid_flexible(other, "k1", values, COMBOS, store=store, workers=0)
    assert out.served == 0
    assert out.frame.equals(two_dof.sweep(other, "k1", values, combos=COMBOS))
    heavier = sweeps.rigid_flexible(BASE.replace(m2_kg=20.0), "k1", values, COMBOS,
                                    store=store, workers=0)
    assert heavier.served == 0


def stored_points(path: Path) -> int:
    import duckdb

    try:
        con = duckdb.connect(str(path), read_only=True)
    except duckdb.Error:  # absent, or the sweep holds it right now
        return 0
    try:
        return con.execute("SELECT count(*) FROM sweep_points").fetchone()[0]
    except duckdb.Error:
        return 0
    finally:
        con.close()


def test_ctrl_c_stores_what_finished_and_the_rerun_resumes(tmp_path: Path) -> None:
    """SIGINT a real `impactbench sweep rigid-flexible` (74,856 points, ~2 s on one thread
    here) at its first progress line, printed when the first chunk is solved: one line, exit
    130, no output file, what finished stored by the interrupt (not waiting for the first
    timed store write); the rerun solves only the rest and writes the uninterrupted sweep's
    file byte for byte."""
    path, out = tmp_path / "r.duckdb", tmp_path / "sweep.csv"
    argv = [sys.executable, "-m", "impactbench.cli", "sweep", "rigid-flexible", "--over",
            "velocity", "--start", "0.5", "--stop", "250", "--step", "0.02", "--workers", "0",
            "--store", str(path), "--out", str(out)]
    with interruptible_children():
        proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, start_new_session=True)
    first = proc.stderr.readline()  # at the first chunk done (250 points, milliseconds)
    assert re.fullmatch(r"impactbench: 250 of 74856 points done \(\d+ s\)\n", first), first
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    *progress, last = (first + err).splitlines()  # progress lines (not a terminal), one line
    assert all(re.fullmatch(r"impactbench: \d+ of 74856 points done( \(\d+ s\))?", p)
               for p in progress), err
    line = re.fullmatch(r"impactbench: interrupted; (\d+) of 74856 points stored; rerun to "
                        r"resume", last)
    assert line, err
    stored = int(line.group(1))
    assert 250 <= stored < 74856 and stored_points(path) == stored
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.duckdb"]  # no (partial) table
    again = subprocess.run(argv, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert f"{stored} from the store, {74856 - stored} solved" in again.stdout
    values = 0.5 + 0.02 * np.arange(12476)
    write_table(two_dof.sweep(RigidFlexible(), "velocity", values), tmp_path / "plain.csv")
    assert out.read_bytes() == (tmp_path / "plain.csv").read_bytes()
