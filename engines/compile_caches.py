"""Where the JIT engines keep what they compile, found without importing them (standard
library only: the report's main process asks, before any engine is loaded).

An engine that compiles on first use (MJX through jax and XLA, Newton through Warp) spends
most of its first report compiling — the default report's MJX cube tosses 74 s with empty
caches against 39 s warm, Newton's 34 s against 7 s (engine time on 2 cores, measured in
fresh default reports) — and later processes load what it kept. The time-left estimate
(:class:`impactbench.matrix.TimeLeft`) takes an engine's cold or warm prior by whether its
folder holds anything (:meth:`impactbench.engines.registry.EngineSpec.compile_cache_warm`).
"""

from __future__ import annotations

import os
import sys
from importlib import metadata
from pathlib import Path


def cache_home() -> Path:
    """``$XDG_CACHE_HOME``, else ``~/.cache``."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


def impactbench_jax_dir() -> Path:
    """``<cache home>/impactbench/jax``: the folder MJX's adapter gives jax's persistent
    compilation cache where ``$JAX_COMPILATION_CACHE_DIR`` (jax's own variable) sets none, and
    where it keeps its traced loops (``mjx-loops``)."""
    return cache_home() / "impactbench" / "jax"


def jax_cache_dir() -> Path:
    """jax's persistent compilation cache as MJX's adapter sets it:
    ``$JAX_COMPILATION_CACHE_DIR`` where set, else :func:`impactbench_jax_dir`."""
    return Path(os.environ.get("JAX_COMPILATION_CACHE_DIR") or impactbench_jax_dir())


def warp_cache_dir() -> Path:
    """Warp's kernel cache as ``warp.init`` resolves it (warp/_src/build.py,
    ``init_kernel_cache``): ``$WARP_CACHE_PATH/<warp version>`` where set, else the user cache
    folder's ``warp/<warp version>`` (``appdirs.user_cache_dir``: ``<cache home>/warp/<version>``
    on Linux, ``~/Library/Caches/warp/<version>`` on macOS,
    ``%LOCALAPPDATA%\\NVIDIA\\warp\\Cache\\<version>`` on Windows)."""
    try:
        version = metadata.version("warp-lang")
    except metadata.PackageNotFoundError:
        version = "none"
    if os.environ.get("WARP_CACHE_PATH"):
        return Path(os.path.realpath(os.environ["WARP_CACHE_PATH"])) / version
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches" / "warp" / version
    if sys.platform == "win32":
        local = os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local"
        return Path(local) / "NVIDIA" / "warp" / "Cache" / version
    return cache_home() / "warp" / version


def holds_anything(folder: Path) -> bool:
    """True when ``folder`` exists and has an entry (a compile kept there)."""
    try:
        with os.scandir(folder) as entries:
            return any(True for _ in entries)
    except OSError:
        return False
