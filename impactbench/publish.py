"""Writing an output folder safely: one writer at a time, and all of it or nothing.

:func:`writer_lock` takes an exclusive ``flock`` on ``.<name>.lock`` beside the folder (the
kernel releases it when the process dies, so a killed run leaves no stale lock); a second
writer gets a one-line ValueError (the lock file stays; unlocked, it means nothing).
:func:`staged` hands out a temporary folder beside the target,
pre-filled (hard links) with the target's files that the writer does not own — e.g. the papers'
figures and tuning plots that share ``reports/figures/`` with the report — and swaps it in when
the block finishes: with ``renameat2(RENAME_EXCHANGE)`` on Linux (one atomic step), else two
renames. An exception or Ctrl-C inside the block removes the temporary folder and leaves the
previous folder untouched.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path


def check_writable(path: Path, what: str = "out") -> None:
    """Raise a one-line ValueError unless a file or folder can be created at ``path``."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{what} = '{path}': cannot create its folder "
                         f"({exc.strerror or exc})") from None
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"{what} = '{path}': folder '{parent}' is not writable")
    if path.exists() and not os.access(path, os.W_OK):
        raise ValueError(f"{what} = '{path}': not writable")


def atomic_write(path: Path, data: str | bytes | Callable[[Path], None],
                 what: str = "out") -> Path:
    """Write a file all or nothing: into a temporary file in the same folder (``data``: the
    text or bytes, or a function that writes the temporary path), flushed to disk, then
    renamed over ``path`` (``os.replace``: atomic). A full disk, a read-only folder or any
    other I/O fault is a one-line ValueError (``{what} = 'path': cannot write (…)``) and
    leaves the previous file as it was; nothing is left behind. The file keeps the previous
    file's permissions (a new one gets the umask's)."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    part: Path | None = None
    try:
        parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=parent)
        part = Path(name)
        with os.fdopen(fd, "wb") as fh:
            if callable(data):
                fh.close()
                data(part)
            else:
                fh.write(data.encode() if isinstance(data, str) else data)
                fh.flush()
                os.fsync(fh.fileno())
        try:
            mode = path.stat().st_mode & 0o7777
        except FileNotFoundError:
            mode = 0o666 & ~_umask()
        os.chmod(part, mode)
        os.replace(part, path)
        part = None
    except OSError as exc:
        raise ValueError(f"{what} = '{path}': cannot write ({exc.strerror or exc})") from None
    finally:
        if part is not None:
            part.unlink(missing_ok=True)
    return path


def check_file_target(path: Path, what: str) -> None:
    """A file output: its folder must be creatable and writable, and it must not be a folder."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{what} = '{path}': is a folder, must be a file path")
    check_writable(path, what)


def check_dir_target(path: Path, what: str) -> None:
    """A folder output: must not be a file; its parent must be creatable and writable."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ValueError(f"{what} = '{path}': is a file, must be a folder")
    check_writable(path, what)
    if path.is_dir() and not os.access(path, os.W_OK | os.X_OK):
        raise ValueError(f"{what} = '{path}': folder is not writable")


def lock_path(out_dir: Path) -> Path:
    out_dir = Path(out_dir).resolve()
    return out_dir.parent / f".{out_dir.name}.lock"


@contextlib.contextmanager
def writer_lock(out_dir: Path, what: str = "out") -> Iterator[None]:
    """Hold the exclusive writer lock of ``out_dir`` for the duration."""
    import fcntl

    check_dir_target(out_dir, what)
    path = lock_path(out_dir)
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise ValueError(f"{what} = '{out_dir}': cannot create the lock {path.name} "
                         f"({exc.strerror})") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "another process"
            raise ValueError(f"{what} = '{out_dir}': another impactbench is writing it "
                             f"(pid {holder}); wait for it or choose another folder") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield  # the file stays (unlinking it would let a waiter lock a dead inode)
    finally:
        os.close(fd)


def _exchange(a: Path, b: Path) -> bool:
    """Atomically swap two paths with renameat2(RENAME_EXCHANGE); False if unavailable."""
    libc_name = ctypes.util.find_library("c")
    if not libc_name:
        return False
    libc = ctypes.CDLL(libc_name, use_errno=True)
    fn = getattr(libc, "renameat2", None)
    if fn is None:
        return False
    at_fdcwd, rename_exchange = -100, 2
    rc = fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange)
    return rc == 0


def link_tree(src: Path, dst: Path, owned: Callable[[Path], bool]) -> None:
    """Hard-link (else copy) every file of ``src`` not ``owned`` by the writer into ``dst``."""
    for path in src.rglob("*"):
        rel = path.relative_to(src)
        if path.is_dir() or owned(rel):
            continue
        target = dst / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        try:
            os.link(path, target)
        except OSError:
            shutil.copy2(path, target)


@contextlib.contextmanager
def staged(out_dir: Path, owned: Callable[[Path], bool] = lambda rel: True) -> Iterator[Path]:
    """A temporary folder to write ``out_dir`` into; swapped in when the block succeeds.

    ``owned(relative_path)`` says which existing files the writer replaces; the others are
    carried over into the new folder.
    """
    out_dir = Path(out_dir)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.new-", dir=out_dir.parent))
    try:
        if out_dir.is_dir():
            link_tree(out_dir, stage, owned)
        yield stage
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    os.chmod(stage, 0o755 & ~_umask())
    if not out_dir.exists():
        os.rename(stage, out_dir)
        return
    if _exchange(stage, out_dir):
        shutil.rmtree(stage, ignore_errors=True)  # now holds the previous folder
        return
    old = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.old-", dir=out_dir.parent))
    os.rmdir(old)
    os.rename(out_dir, old)
    os.rename(stage, out_dir)
    shutil.rmtree(old, ignore_errors=True)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
