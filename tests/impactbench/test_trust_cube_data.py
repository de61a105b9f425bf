"""A damaged tosses file given as --data is one line naming the file, exit 2."""

from __future__ import annotations

import gzip
import subprocess
import sys
from pathlib import Path

import pytest

from impactbench.cube_tosses import data

CSV = ",".join(data.COLUMNS) + "\n" + "\n".join(
    f"1,{i},{0.01 * i},0,0,0.1,1,0,0,0,0,0,0,0,0,0" for i in range(20)) + "\n"


@pytest.fixture
def truncated(tmp_path: Path) -> Path:
    # the first half of a valid gzip stream: gzip raises EOFError (not an OSError) at its end
    whole = gzip.compress(CSV.encode() * 50)
    path = tmp_path / "tosses.csv.gz"
    path.write_bytes(whole[: len(whole) // 2])
    return path


def test_load_names_the_truncated_file(truncated: Path) -> None:
    with pytest.raises(ValueError, match=r"^path = '.*tosses\.csv\.gz': .*truncated"):
        data.load(truncated)


def test_corrupt_deflate_data_names_the_file(tmp_path: Path) -> None:
    whole = bytearray(gzip.compress(CSV.encode() * 50))
    whole[40:60] = b"\xff" * 20  # inside the deflate stream: zlib.error, not an OSError
    path = tmp_path / "bad.csv.gz"
    path.write_bytes(bytes(whole))
    with pytest.raises(ValueError, match=r"^path = '.*bad\.csv\.gz': "):
        data.load(path)


def test_cli_truncated_data_is_one_line_exit_2(truncated: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "impactbench.cli", "reference", "cube-toss",
                           "--data", str(truncated)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith("impactbench: error: path = ")
    assert str(truncated) in done.stderr
