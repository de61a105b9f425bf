"""The built wheel installs one top-level package, ``impactbench``.

The folders ``reference/`` and ``engines/`` live at the top of the repository but must install
as ``impactbench.reference`` and ``impactbench.engines`` (generic top-level names would collide
with any other distribution's). The wheel is built offline from this checkout.
"""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    pytest.importorskip("setuptools", reason="run `pip install 'setuptools>=77'`")
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
         "--quiet", "-w", str(out), str(ROOT)],
        check=True, capture_output=True, text=True,
    )
    (whl,) = out.glob("impactbench-*.whl")
    return whl


def test_wheel_has_one_top_level_package(wheel: Path) -> None:
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"impactbench"}


def test_wheel_ships_every_source_package(wheel: Path) -> None:
    """Every folder with an ``__init__.py`` is in the wheel, under its installed name."""
    names = set(zipfile.ZipFile(wheel).namelist())
    installed = {"reference": "impactbench/reference", "engines": "impactbench/engines"}
    for init in [*ROOT.glob("impactbench/**/__init__.py"),
                 *ROOT.glob("reference/**/__init__.py"), *ROOT.glob("engines/**/__init__.py")]:
        rel = init.relative_to(ROOT).as_posix()
        top, _, rest = rel.partition("/")
        assert f"{installed.get(top, top)}/{rest}" in names, rel
    assert "impactbench/data/default.toml" in names
    assert "impactbench/reference/data/materials.toml" in names


def test_wheel_ships_the_report_templates(wheel: Path) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    templates = [p for p in (ROOT / "impactbench" / "templates").rglob("*") if p.is_file()]
    assert templates
    for path in templates:
        assert path.relative_to(ROOT).as_posix() in names, path
