"""``impactbench figures`` in parallel and skipped when nothing changed: a figure drawn by the
pool's worker processes is byte for byte the one drawn here; the readings through the pool are
the serial ones; a folder whose manifest has the same key is left as it is (nothing
rewritten), and a changed file, another key, ``--force`` or ``--fresh`` draws again, the same
bytes."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import pytest

from impactbench.cli import main
from impactbench.figures import hunt_crossley, manifest, rf_readings, zoo
from impactbench.figures.pool import IN_PROCESS, figure_pool


def test_the_pool_draws_the_same_bytes_as_this_process(tmp_path: Path) -> None:
    """The seven Hunt–Crossley PNGs and the zoo's figure and tables, drawn on two worker
    processes and here: the same paths in the same order, the same bytes."""
    with figure_pool(2, preload=("impactbench.figures.hunt_crossley",)) as pool:
        got = hunt_crossley.draw(tmp_path / "pool", pool)() + zoo.draw(tmp_path / "pool",
                                                                      pool)()
    here = hunt_crossley.write(tmp_path / "here") + zoo.write(tmp_path / "here")
    assert [p.name for p in got] == [p.name for p in here]
    assert len(got) == 10
    for a, b in zip(got, here, strict=True):
        assert a.parent == tmp_path / "pool" and a.read_bytes() == b.read_bytes(), a.name


def test_the_readings_through_a_pool_are_the_serial_ones() -> None:
    """The readings as pool tasks: each the numbers :func:`rf_readings.numbers` gives in one
    process, a reading that leaves the v1 sweep taking the default's."""
    with figure_pool(2) as pool:
        got = rf_readings.draw_numbers(pool)()
    assert list(got) == list(rf_readings.READINGS)
    shared = next(r for r in rf_readings.READINGS if r not in rf_readings.V1_SWEEP_READINGS)
    assert got[shared] == rf_readings.numbers(shared, v1_from=got["default"])
    assert got["default"] == rf_readings.numbers("default")
    assert got[shared]["reg2"] == got["default"]["reg2"]


def test_ctrl_c_ends_the_workers_at_once() -> None:
    """An exception (Ctrl-C) while a task runs: the pool is left at once, its workers ended,
    not waited for."""
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt), figure_pool(2) as pool:
        running = pool.submit(time.sleep, 60)
        while not running.running():
            time.sleep(0.05)
        processes = list(pool._processes.values())
        raise KeyboardInterrupt
    for process in processes:
        process.join(10)
        assert not process.is_alive()
    assert time.perf_counter() - t0 < 30


def test_in_process_runs_each_task_at_once() -> None:
    calls = []
    done = IN_PROCESS.submit(calls.append, 1)
    assert calls == [1] and done.done() and done.result() is None
    with pytest.raises(ZeroDivisionError):
        IN_PROCESS.submit(divmod, 1, 0)


# ------------------------------------------------------------------ the manifest


@pytest.fixture
def zoo_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """The command with the zoo's figure alone (a second to draw)."""
    monkeypatch.setattr("impactbench.figures.FIGURE_MODULES", ("impactbench.figures.zoo",))


def figures(out: Path, capsys: pytest.CaptureFixture[str], *flags: str) -> tuple[list[str], str]:
    """``impactbench figures --out OUT --workers 0 FLAGS``: (printed paths, stderr)."""
    assert main(["figures", "--out", str(out), "--workers", "0",
                 "--store", str(out.parent / "store.duckdb"), *flags]) == 0
    captured = capsys.readouterr()
    return captured.out.split(), captured.err


def state(out: Path) -> dict[str, tuple[int, int, bytes]]:
    """Every file of ``out``: (inode, mtime in ns, bytes)."""
    return {p.name: (p.stat().st_ino, p.stat().st_mtime_ns, p.read_bytes())
            for p in sorted(out.iterdir())}


def test_an_unchanged_folder_is_left_as_it_is(tmp_path: Path, zoo_only, capsys) -> None:
    out = tmp_path / "figures"
    printed, err = figures(out, capsys)
    assert [Path(p).name for p in printed] == ["zoo_restitution.png", "zoo_restitution.csv",
                                               "zoo_restitution.md"]
    assert err == ""
    recorded = json.loads((out / manifest.MANIFEST).read_text())
    assert recorded["key"] == manifest.key(("impactbench.figures.zoo",))
    assert re.fullmatch(r".+\+[0-9a-f]{10}", recorded["key"]["impactbench"])  # release+source
    assert set(recorded["key"]["libraries"]) == set(manifest.LIBRARIES)
    assert recorded["printed"] == [Path(p).name for p in printed]
    assert set(recorded["files"]) == set(recorded["printed"])
    before = state(out)
    time.sleep(0.01)

    again, err = figures(out, capsys)
    assert again == printed
    assert err.count("\n") == 1 and "unchanged" in err and "--force" in err
    assert state(out) == before  # nothing rewritten, the manifest included


@pytest.mark.parametrize("how", ["changed file", "missing file", "other key", "--force",
                                 "--fresh", "bad manifest"])
def test_a_change_draws_again_the_same_bytes(tmp_path: Path, zoo_only, capsys,
                                             monkeypatch: pytest.MonkeyPatch, how: str) -> None:
    out = tmp_path / "figures"
    printed, _ = figures(out, capsys)
    before = state(out)
    png = out / "zoo_restitution.png"
    flags: tuple[str, ...] = ()
    if how == "changed file":
        png.write_bytes(png.read_bytes() + b"\0")
    elif how == "missing file":
        png.unlink()
    elif how == "other key":
        key = manifest.key
        monkeypatch.setattr(manifest, "key", lambda modules: {**key(modules), "python": "2.7"})
    elif how == "bad manifest":
        (out / manifest.MANIFEST).write_text("{not json")
    else:
        flags = (how,)
    time.sleep(0.01)
    again, err = figures(out, capsys, *flags)
    assert again == printed and err == ""
    after = state(out)
    assert after["zoo_restitution.png"][1] != before["zoo_restitution.png"][1]  # drawn again
    # the same bytes; the same manifest, but for the key that changed
    assert {n: v[2] for n, v in after.items() if n != manifest.MANIFEST} == {
        n: v[2] for n, v in before.items() if n != manifest.MANIFEST}
    recorded = json.loads(after[manifest.MANIFEST][2])
    assert recorded["files"] == json.loads(before[manifest.MANIFEST][2])["files"]
    if how == "other key":
        assert recorded["key"]["python"] == "2.7"
    else:
        assert after[manifest.MANIFEST][2] == before[manifest.MANIFEST][2]


def _fails(path: Path) -> Path:
    raise RuntimeError(f"cannot draw {path.name}")


def test_a_redraw_that_fails_leaves_no_manifest(tmp_path: Path, capsys,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """A figure that fails halfway: the error is raised, and the folder has no manifest any
    more (the next run draws again instead of keeping half-new figures)."""
    monkeypatch.setattr("impactbench.figures.FIGURE_MODULES",
                        ("impactbench.figures.hunt_crossley",))
    out = tmp_path / "figures"
    monkeypatch.setattr(hunt_crossley, "FIGURES", hunt_crossley.FIGURES[:1])
    figures(out, capsys)
    assert (out / manifest.MANIFEST).is_file()
    monkeypatch.setattr(hunt_crossley, "FIGURES", (*hunt_crossley.FIGURES,
                                                   ("hc_fig9_broken.png", _fails)))
    with pytest.raises(RuntimeError, match=r"cannot draw hc_fig9_broken\.png"):
        figures(out, capsys, "--force")
    assert not (out / manifest.MANIFEST).exists()
