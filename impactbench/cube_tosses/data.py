"""The cube tosses as a tidy table: loading, validation, per-toss arrays and the train/test split.

The packaged file (``impactbench/data/cube_tosses/tosses.csv.gz``, BSD-3, DAIR Lab's
ContactNets data; its README and LICENSE sit beside it) has one row per motion-capture sample::

    toss, sample, t_s, x_m, y_m, z_m, qw, qx, qy, qz,
    vx_m_s, vy_m_s, vz_m_s, wx_rad_s, wy_rad_s, wz_rad_s

SI units, the board's frame (z up, the board's normal), quaternion w first (body → board),
angular velocity in the **body** frame. :func:`load` reads that file or any CSV with the same
columns (a user's own tosses) and validates it; every problem is a one-line ``ValueError``
naming the column, toss, value and rule.

Split (:func:`split`): a toss is in the test set when the first 8 bytes of SHA-256 of its id
written in decimal (``"42"``), read as a big-endian integer, are ≡ 0 (mod 5); every other toss
is in the training set. It depends on the id alone, so it is the same for any subset of tosses
and on any machine (89 test and 367 training tosses of the packaged 456). Not "every fifth
id": the packaged file already lacks every id ≡ 3 (mod 5) of the original 570.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

DATA_DIR = Path(__file__).resolve().parents[1] / "data" / "cube_tosses"
DEFAULT_PATH = DATA_DIR / "tosses.csv.gz"

COLUMNS = ("toss", "sample", "t_s", "x_m", "y_m", "z_m", "qw", "qx", "qy", "qz",
           "vx_m_s", "vy_m_s", "vz_m_s", "wx_rad_s", "wy_rad_s", "wz_rad_s")
POSITION = ("x_m", "y_m", "z_m")
QUATERNION = ("qw", "qx", "qy", "qz")
VELOCITY = ("vx_m_s", "vy_m_s", "vz_m_s")
OMEGA_BODY = ("wx_rad_s", "wy_rad_s", "wz_rad_s")

QUATERNION_TOLERANCE = 1e-3
"""Largest allowed ||q| − 1| of a sample's quaternion."""
MIN_SAMPLES = 10
"""Fewest samples a toss may have (the replay starts up to 3 before the drop and needs a few
after; the packaged tosses have 80 to 442)."""

SPLITS = ("train", "test", "all")


@dataclass(frozen=True)
class Toss:
    """One toss as arrays (``n`` samples, SI, board frame).

    Attributes:
        toss: its id.
        t: sample times (s), shape (n,).
        p: centre positions (m), (n, 3).
        q: unit quaternions w, x, y, z (body → board), (n, 4).
        v: linear velocities (m/s), (n, 3).
        w_body: angular velocities in the body frame (rad/s), (n, 3).
    """

    toss: int
    t: np.ndarray
    p: np.ndarray
    q: np.ndarray
    v: np.ndarray
    w_body: np.ndarray

    def __len__(self) -> int:
        return len(self.t)


def load(path: str | Path | None = None, *, min_samples: int = MIN_SAMPLES) -> pd.DataFrame:
    """The tosses at ``path`` (default: the packaged ContactNets tosses) as a DataFrame with
    :data:`COLUMNS`, sorted by toss and sample; validated (ValueError, one line each):
    a missing column, a non-numeric or non-finite value, a quaternion with ||q| − 1| >
    :data:`QUATERNION_TOLERANCE`, time not strictly increasing within a toss, a toss with fewer
    than ``min_samples`` samples. Extra columns are kept."""
    source = Path(path) if path is not None else DEFAULT_PATH
    if not source.is_file():
        raise ValueError(f"path = {str(source)!r}: no such file")
    st = source.stat()
    key = (str(source.resolve()), st.st_ino, st.st_size, st.st_mtime_ns, min_samples)
    if key not in _LOADED:
        if len(_LOADED) >= LOADED_FILES:
            _LOADED.pop(next(iter(_LOADED)))
        _LOADED[key] = _read(source, min_samples)
    return _LOADED[key].copy()


LOADED_FILES = 4
"""How many validated files :func:`load` keeps in the process (a report's and a tuner's
every cube-toss run reads the same file: 0.07 s a read and validation, once now). A file is
read again when its size, modification time or inode changes; each call gets its own copy."""
_LOADED: dict[tuple[object, ...], pd.DataFrame] = {}


def _read(source: Path, min_samples: int) -> pd.DataFrame:
    """The file at ``source`` read and validated (see :func:`load`)."""
    import lzma
    import zlib

    try:
        df = pd.read_csv(source)
    except (EOFError, zlib.error, lzma.LZMAError) as exc:
        # a compressed file cut short (EOFError) or damaged: neither is an OSError
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"path = {str(source)!r}: truncated or corrupt compressed file "
                         f"({first}); must be a whole CSV or .csv.gz") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError,
            OSError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"path = {str(source)!r}: not a readable CSV ({first})") from None
    return validate(df, min_samples=min_samples, where=source.name)


def validate(df: pd.DataFrame, *, min_samples: int = MIN_SAMPLES, where: str = "data"
             ) -> pd.DataFrame:
    """``df`` checked and tidied (see :func:`load`); ``where`` prefixes the messages."""
    missing = [c for c in COLUMNS if c not in df.columns]
    if missing:
        raise ValueError(f"{where}: column {missing[0]!r} missing; needs columns "
                         f"{', '.join(COLUMNS)}")
    if df.empty:
        raise ValueError(f"{where}: no rows; needs at least one toss of {min_samples} samples")
    df = df.copy()
    for col in COLUMNS:
        values = pd.to_numeric(df[col], errors="coerce")
        bad = ~np.isfinite(values.to_numpy(dtype=float))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{where}: column {col!r}, toss {df['toss'].iloc[i]}, line {i + 2}:"
                             f" value {df[col].iloc[i]!r} must be a finite number")
        df[col] = values
    for col in ("toss", "sample"):
        if (df[col] != df[col].round()).any():
            i = int(np.flatnonzero((df[col] != df[col].round()).to_numpy())[0])
            raise ValueError(f"{where}: column {col!r}, toss {df['toss'].iloc[i]}, line {i + 2}:"
                             f" value {df[col].iloc[i]!r} must be an integer")
        df[col] = df[col].astype(np.int64)
    df = df.sort_values(["toss", "sample"], kind="stable").reset_index(drop=True)

    norm = np.linalg.norm(df[list(QUATERNION)].to_numpy(), axis=1)
    bad = np.abs(norm - 1.0) > QUATERNION_TOLERANCE
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{where}: columns qw, qx, qy, qz, toss {int(df['toss'].iloc[i])}, "
                         f"sample {int(df['sample'].iloc[i])}: |q| = {norm[i]:.6g} must be 1 "
                         f"within {QUATERNION_TOLERANCE:g}")

    toss = df["toss"].to_numpy()
    same = toss[1:] == toss[:-1]
    dup = same & (np.diff(df["sample"].to_numpy()) == 0)
    if dup.any():
        i = int(np.flatnonzero(dup)[0]) + 1
        raise ValueError(f"{where}: column 'sample', toss {int(toss[i])}: sample "
                         f"{int(df['sample'].iloc[i])} appears twice")
    dt = np.diff(df["t_s"].to_numpy())
    bad = same & ~(dt > 0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0]) + 1
        raise ValueError(f"{where}: column 't_s', toss {int(toss[i])}, sample "
                         f"{int(df['sample'].iloc[i])}: t = {df['t_s'].iloc[i]!r} s after "
                         f"{df['t_s'].iloc[i - 1]!r} s; time must increase with sample")
    sizes = df.groupby("toss").size()
    short = sizes[sizes < min_samples]
    if len(short):
        raise ValueError(f"{where}: toss {int(short.index[0])}: {int(short.iloc[0])} samples; "
                         f"needs at least {min_samples}")
    return df


def toss_ids(df: pd.DataFrame) -> list[int]:
    """The toss ids of ``df``, ascending."""
    return sorted(int(i) for i in df["toss"].unique())


def in_test_set(toss_id: int) -> bool:
    """Whether toss ``toss_id`` is in the test split (see the module doc)."""
    digest = hashlib.sha256(str(int(toss_id)).encode("ascii")).digest()
    return int.from_bytes(digest[:8], "big") % 5 == 0


def split(ids: Iterable[int], which: str = "all") -> list[int]:
    """The ids of ``ids`` in split ``which`` ("train", "test" or "all"), ascending: a
    deterministic 80/20 split by a hash of the id (module doc)."""
    if which not in SPLITS:
        raise ValueError(f"split = {which!r}: must be one of {', '.join(SPLITS)}")
    out = sorted({int(i) for i in ids})
    if which == "all":
        return out
    test = which == "test"
    return [i for i in out if in_test_set(i) == test]


def toss(df: pd.DataFrame, toss_id: int) -> Toss:
    """The arrays of toss ``toss_id`` (ValueError if ``df`` has no such toss)."""
    return next(tosses(df, [toss_id]))


def tosses(df: pd.DataFrame, ids: Iterable[int] | None = None) -> Iterator[Toss]:
    """The tosses of ``df`` (all, or ``ids`` in that order) as :class:`Toss` arrays: each
    toss's rows in their order in ``df``. The columns become arrays once, each toss takes its
    rows from them (456 tosses: 0.68 s through a DataFrame per toss, measured)."""
    toss_col = df["toss"].to_numpy()
    order = np.argsort(toss_col, kind="stable")
    keys, starts = np.unique(toss_col[order], return_index=True)
    ends = np.append(starts[1:], len(order))
    where = {k.item(): order[a:b] for k, a, b in zip(keys, starts, ends, strict=True)}
    columns = {cols: np.ascontiguousarray(df[list(cols)].to_numpy(dtype=float))
               for cols in (QUATERNION, POSITION, VELOCITY, OMEGA_BODY)}
    t_s = df["t_s"].to_numpy(dtype=float)
    for i in ([k.item() for k in keys] if ids is None else ids):
        rows = where.get(int(i))
        if rows is None:
            raise ValueError(f"toss = {i!r}: not in the data (ids {_id_range(df)})")
        q = columns[QUATERNION][rows]
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        yield Toss(int(i), t_s[rows], columns[POSITION][rows], q, columns[VELOCITY][rows],
                   columns[OMEGA_BODY][rows])


def _id_range(df: pd.DataFrame) -> str:
    ids = toss_ids(df)
    return f"{ids[0]}–{ids[-1]}, {len(ids)} tosses" if ids else "none"
