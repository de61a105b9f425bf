"""The CLI contract of ``reference rigid-flexible`` and ``sweep rigid-flexible``."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from impactbench.reference import two_dof
from impactbench.reference.scenarios import RigidFlexible

from impactbench.cli import main

JSON_KEYS = ["status", "peak_force_n", "pulse_width_s", "contact_time_s", "impulse_ns",
             "impacts"]


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_json_has_exactly_the_six_keys_and_the_solver_values(capsys):
    code, out, _ = run(capsys, "reference", "rigid-flexible", "--velocity", "10", "--local",
                       "elastoplastic", "--structure", "softening", "--m2", "12", "--json")
    assert code == 0
    obj = json.loads(out)
    assert list(obj) == JSON_KEYS
    want = two_dof.solve(RigidFlexible(velocity_m_s=10.0, local="elastoplastic",
                                       structure="softening", m2_kg=12.0))
    for key in JSON_KEYS:
        assert obj[key] == (want[key] if key in ("status", "impacts")
                            else pytest.approx(want[key], rel=1e-15))


def test_defaults_are_the_paper_base_parameters(capsys):
    _, out, _ = run(capsys, "reference", "rigid-flexible", "--json")
    assert json.loads(out)["peak_force_n"] == pytest.approx(
        two_dof.solve(RigidFlexible())["peak_force_n"], rel=1e-15)


def test_table_output_lists_the_energy_partition(capsys):
    code, out, _ = run(capsys, "reference", "rigid-flexible", "--velocity", "300",
                       "--structure", "softening")
    assert code == 0 and "structure_collapsed" in out and "dissipated_energy_j" in out


@pytest.mark.parametrize("argv", [
    ("reference", "rigid-flexible", "--velocity", "-2"),
    ("reference", "rigid-flexible", "--local", "plastic"),
    ("reference", "rigid-flexible", "--k1", "abc"),
    ("sweep", "rigid-flexible", "--over", "velocity", "--start", "1", "--stop", "0.5",
     "--step", "0.1", "--out", "x.csv"),
    ("sweep", "rigid-flexible", "--over", "velocity", "--start", "1", "--stop", "2",
     "--step", "0", "--out", "x.csv"),
    ("sweep", "rigid-flexible", "--over", "mass", "--start", "1", "--stop", "2",
     "--step", "1", "--out", "x.csv"),
    ("sweep", "rigid-flexible", "--over", "k2", "--start", "1", "--stop", "2",
     "--step", "1", "--out", "x.txt"),
    ("sweep", "rigid-flexible", "--over", "k2", "--start", "1", "--stop", "2",
     "--step", "1", "--out", "x.csv", "--workers", "-1"),
    ("figures", "--workers", "-2"),
])
def test_bad_input_exits_2_with_one_line(capsys, argv):
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == ""
    assert err.startswith("impactbench: error: ") and err.count("\n") == 1


def test_sweep_all_combinations_to_csv(capsys, tmp_path):
    out_file = tmp_path / "sweep.csv"
    argv = ("sweep", "rigid-flexible", "--over", "m2", "--start", "1", "--stop", "3",
            "--step", "1", "--velocity", "5", "--out", str(out_file))
    code, out, _ = run(capsys, *argv)
    assert code == 0 and "18 points (" in out and "0 from the store, 18 solved" in out
    first = out_file.read_bytes()
    code, out, _ = run(capsys, *argv)  # the results store serves every point
    assert code == 0 and "18 from the store, 0 solved" in out
    assert out_file.read_bytes() == first
    df = pd.read_csv(out_file)
    assert list(df.columns) == ["local", "structure", "m2_kg", *JSON_KEYS[1:], "status"]
    assert list(df["m2_kg"][:3]) == [1.0, 2.0, 3.0]
    assert len(df.groupby(["local", "structure"])) == 6
    row = df[(df.local == "mutation") & (df.structure == "softening") & (df.m2_kg == 2.0)]
    want = two_dof.solve(RigidFlexible(velocity_m_s=5.0, m2_kg=2.0, local="mutation",
                                       structure="softening"))
    assert row["peak_force_n"].item() == pytest.approx(want["peak_force_n"], rel=1e-12)


def test_sweep_one_law_to_parquet(capsys, tmp_path):
    out_file = tmp_path / "k1.parquet"
    code, _, _ = run(capsys, "sweep", "rigid-flexible", "--over", "k1", "--start", "1e4",
                     "--stop", "3e4", "--step", "1e4", "--local", "elastoplastic",
                     "--out", str(out_file))
    assert code == 0
    df = pd.read_parquet(out_file)
    assert set(zip(df.local, df.structure, strict=True)) == {("elastoplastic", "linear"),
                                                             ("elastoplastic", "softening")}
    assert sorted(set(df.k1_n_per_m)) == [1e4, 2e4, 3e4]
