"""Where the JIT engines keep their compiles, found without importing them
(:mod:`impactbench.engines.compile_caches`), read back from the engines themselves, and
whether a cache is warm (the time-left estimate's cold or warm prior, #32)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import require_engine
from impactbench.engines import compile_caches
from impactbench.engines.registry import SPECS


def _engine_says(code: str, env: dict[str, str]) -> str:
    """The last line ``code`` prints in a fresh interpreter with ``env`` (an engine resolves
    its cache folder once per process)."""
    out = subprocess.run([sys.executable, "-c", code], env={**os.environ, **env},
                         capture_output=True, text=True, timeout=300, check=True)
    return out.stdout.strip().splitlines()[-1]


FOLDERS = {
    # engine: (the engine's own variable for the folder, code printing the folder the engine
    # resolved, the function that finds it without the engine)
    "newton": ("WARP_CACHE_PATH",
               "import warp; warp.config.quiet = True; warp.init(); "
               "print(warp.config.kernel_cache_dir)", compile_caches.warp_cache_dir),
    "mjx": ("JAX_COMPILATION_CACHE_DIR",
            "from impactbench.engines.mjx_adapter import _mjx\n_, jax, _ = _mjx()\n"
            "print(jax.config.jax_compilation_cache_dir)", compile_caches.jax_cache_dir),
}


@pytest.mark.parametrize("own_path", [False, True], ids=["default", "own-variable"])
@pytest.mark.parametrize("engine", sorted(FOLDERS))
def test_the_cache_folder_is_the_one_the_engine_resolves(tmp_path: Path, monkeypatch,
                                                         engine: str, own_path: bool) -> None:
    require_engine(engine)
    variable, code, found = FOLDERS[engine]
    monkeypatch.delenv(variable, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    if own_path:
        monkeypatch.setenv(variable, str(tmp_path / "own"))
    said = _engine_says(code, {})
    assert Path(said) == found()
    assert str(tmp_path) in said  # the environment was heeded, not a fixed path


def test_an_engine_is_warm_once_its_cache_folder_holds_something(tmp_path: Path,
                                                                 monkeypatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    for name in ("WARP_CACHE_PATH", "JAX_COMPILATION_CACHE_DIR"):
        monkeypatch.delenv(name, raising=False)
    # only the JIT engines keep a compile cache; the others have no say
    assert {n for n, s in SPECS.items() if s.compile_cache} == {"mjx", "newton"}
    assert SPECS["mujoco"].compile_cache_warm() is None
    assert SPECS["mjx"].compile_cache_warm() is False      # no folder at all
    folder = compile_caches.jax_cache_dir()
    folder.mkdir(parents=True)
    assert SPECS["mjx"].compile_cache_warm() is False      # an empty folder
    (folder / "jit_call-0-cache").write_bytes(b"x")
    assert SPECS["mjx"].compile_cache_warm() is True
    assert SPECS["newton"].compile_cache_warm() is False   # its own folder, still empty
    compile_caches.warp_cache_dir().mkdir(parents=True)
    (compile_caches.warp_cache_dir() / "wp_module").mkdir()
    assert SPECS["newton"].compile_cache_warm() is True


def test_the_registry_finds_the_folders_without_importing_an_engine() -> None:
    """The report's main process asks before any engine is loaded (and never loads one)."""
    code = ("import sys\nfrom impactbench.engines.registry import SPECS\n"
            "[s.compile_cache_warm() for s in SPECS.values()]\n"
            "import json; print(json.dumps(sorted(m for m in ('jax', 'warp', 'mujoco', 'numpy')"
            " if m in sys.modules)))")
    assert json.loads(_engine_says(code, {})) == []
