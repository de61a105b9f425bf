"""Loading an engine prints nothing: pybullet's C banner ("pybullet build time: …") is
silenced at import in the adapter, so neither stdout (``--json``) nor stderr carries it."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from conftest import require_engine

LOAD = ("from impactbench.engines.pybullet_adapter import _import_engine; "
        "p = _import_engine(); print('loaded', p.connect(p.DIRECT) >= 0)")


def test_pybullet_import_prints_no_banner() -> None:
    require_engine("pybullet")
    out = subprocess.run([sys.executable, "-c", LOAD], capture_output=True, text=True,
                         check=True, timeout=60)
    assert out.stdout == "loaded True\n"
    assert "build time" not in out.stderr and out.stderr == ""


def test_a_silenced_import_still_raises_and_restores_output(capfd) -> None:
    from impactbench.engines.common import silenced_fds

    with pytest.raises(ImportError, match="impactbench_no_such_module"), silenced_fds():
        os.write(1, b"hidden\n")  # what a C printf does: the descriptor itself
        import impactbench_no_such_module  # noqa: F401
    os.write(1, b"after\n")
    assert capfd.readouterr().out == "after\n"
