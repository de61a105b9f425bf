"""Building the wheel is quiet (every data folder is a declared package, so setuptools has
nothing to warn about) and the wheel still carries every data file; the test extra pulls
only plugins the tests use."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA_DIRS = {  # source folder → its folder in the wheel
    "impactbench/data": "impactbench/data",
    "impactbench/templates": "impactbench/templates",
    "reference/data": "impactbench/reference/data",
}


@pytest.fixture(scope="module")
def build(tmp_path_factory) -> tuple[Path, str]:
    pytest.importorskip("setuptools", reason="run `pip install 'setuptools>=77'`")
    out = tmp_path_factory.mktemp("wheel")
    done = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
         "-w", str(out), str(ROOT)], check=True, capture_output=True, text=True)
    (whl,) = out.glob("impactbench-*.whl")
    return whl, done.stdout + done.stderr


def test_wheel_build_has_no_package_would_be_ignored_warning(build) -> None:
    # before: 9 data folders ("impactbench.data", "impactbench.templates.sections", …) were
    # importable but undeclared: ~370 lines of "Package would be ignored" per build
    _, log = build
    ignored = re.findall(r"Package '([\w.]+)' is absent from the `packages`", log)
    assert not ignored, ignored
    assert "Package would be ignored" not in log


def test_wheel_carries_every_data_file(build) -> None:
    whl, _ = build
    names = set(zipfile.ZipFile(whl).namelist())
    files = [p for src in DATA_DIRS for p in (ROOT / src).rglob("*")
             if p.is_file() and "__pycache__" not in p.parts]
    assert len(files) >= 60  # 65 at the time of writing: tuned files, tosses, templates, …
    for path in files:
        rel = path.relative_to(ROOT).as_posix()
        for src, dst in DATA_DIRS.items():
            if rel.startswith(src + "/"):
                assert dst + rel[len(src):] in names, rel


def test_test_extra_has_no_unused_pytest_plugin() -> None:
    extra = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["test"]
    uses_benchmark = any(re.search(r"def test\w*\([^)]*\bbenchmark\b", p.read_text())
                         for p in (ROOT / "tests").rglob("test_*.py"))
    assert uses_benchmark or not any(d.startswith("pytest-benchmark") for d in extra), extra
