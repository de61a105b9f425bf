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


@pytest.mark.parametrize(("engine", "argv", "noise"), [
    ("newton", ["ball-on-plate", "--velocity", "1"], "CUDA"),
    ("drake", ["ball-on-plate", "--velocity", "1", "--mode", "custom",
               "--timestep", "1e-3", "--param", "discrete_contact_approximation=tamsi"],
     "TAMSI"),
    ("drake", ["cube-toss", "--tosses", "0"], "half spaces"),
    ("pybullet", ["cube-toss", "--tosses", "0"], "build time"),
])
def test_a_cpu_run_says_nothing_that_means_nothing(engine: str, argv: list[str],
                                                   noise: str) -> None:
    """A run on a CPU-only machine carries no notes meant for someone else: warp's missing
    CUDA driver, Drake's TAMSI deprecation (TAMSI is compared on purpose) and its deformable
    half-space note, pybullet's build time. stderr is empty."""
    require_engine(engine)
    out = subprocess.run([sys.executable, "-m", "impactbench.cli", "run", "--engine", engine,
                          *argv, "--allow-status", "implausible"], capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert noise not in out.stderr and out.stderr == "", out.stderr
