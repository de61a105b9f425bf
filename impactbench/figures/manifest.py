"""The manifest of ``impactbench figures``: what the figures in a folder were drawn from.

``figures_manifest.json`` beside the figures records a key of everything the drawn bytes
depend on — impactbench's source (:func:`impactbench.store.impactbench_version`: the release
and a hash of every Python file of the suite, the reference solvers and the adapters), the
Python and the libraries that compute and draw (NumPy, SciPy, pandas, matplotlib, Pillow,
which writes the PNGs), the platform and the figure modules — and the SHA-256 of every file
written. A rerun whose key is the same, with every file still as written, rewrites nothing
(``impactbench figures`` prints the paths and says so); ``--force`` or ``--fresh`` draws
again. No flag of the command enters the key: ``--store``, ``--workers`` and ``--scheduler``
change where the numbers come from and how fast, not the numbers (the store serves a point
only to the source version that computed it). The manifest holds no time or machine name,
so a redraw from the same key writes the same manifest, byte for byte.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

MANIFEST = "figures_manifest.json"
LIBRARIES = ("numpy", "scipy", "pandas", "matplotlib", "pillow")
"""The distributions whose versions enter the key (what computes the curves and draws and
encodes them)."""


def key(modules: Sequence[str]) -> dict[str, Any]:
    """What the figures of ``modules`` depend on, as JSON-able data (see the module's
    docstring)."""
    from importlib import metadata

    from impactbench.store import impactbench_version

    libraries = {}
    for dist in LIBRARIES:
        try:
            libraries[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            libraries[dist] = "not installed"
    return {"impactbench": impactbench_version(),
            "python": f"{sys.version_info.major}.{sys.version_info.minor}",
            "platform": f"{platform.system()}-{platform.machine()}",
            "libraries": libraries, "modules": list(modules)}


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _name(path: Path, out_dir: Path) -> str:
    """``path`` relative to ``out_dir`` (POSIX; ``../rigid_flexible.md`` for the report)."""
    return Path(os.path.relpath(path, out_dir)).as_posix()


def unchanged(out_dir: Path, wanted: dict[str, Any]) -> list[Path] | None:
    """The paths the command printed when it drew ``out_dir``'s figures, when its manifest's
    key is ``wanted`` and every file it lists is there with the bytes it recorded; else None
    (no manifest, another key, a file missing or changed: draw again)."""
    try:
        old = json.loads((out_dir / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(old, dict) or old.get("key") != wanted:
        return None
    files = old.get("files")
    printed = old.get("printed")
    if not isinstance(files, dict) or not isinstance(printed, list) or not files:
        return None
    for name, digest in files.items():
        path = out_dir / name
        try:
            if _digest(path) != digest:
                return None
        except OSError:
            return None
    return [out_dir / name for name in printed]


def forget(out_dir: Path) -> None:
    """Remove ``out_dir``'s manifest (before drawing: a redraw that stops halfway leaves
    none, so the next run draws again)."""
    (out_dir / MANIFEST).unlink(missing_ok=True)


def record(out_dir: Path, wanted: dict[str, Any], printed: Sequence[Path],
           side_files: Sequence[Path] = ()) -> Path:
    """Write ``out_dir``'s manifest: the key ``wanted``, the files ``printed`` (in order) and
    the ``side_files`` written beside them, each with its SHA-256. Atomic (written beside
    and renamed)."""
    files = {_name(p, out_dir): _digest(p) for p in [*printed, *side_files]}
    text = json.dumps({"key": wanted, "printed": [_name(p, out_dir) for p in printed],
                       "files": files}, indent=2) + "\n"
    path = out_dir / MANIFEST
    part = path.with_name(f".{path.name}.part")
    try:
        part.write_text(text, encoding="utf-8")
        os.replace(part, path)
    finally:
        part.unlink(missing_ok=True)
    return path
