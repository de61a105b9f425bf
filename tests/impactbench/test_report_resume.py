"""A report is all or nothing: Ctrl-C keeps the previous report and resumes from the store;
a second writer is refused. Real engines, a real `impactbench report` subprocess."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import require_engine
from ctrl_c import interruptible_children

from impactbench import publish
from impactbench.store import Store

BASE = """
[report]
engines = ["mujoco"]
modes = ["injected"]
[ball_on_plate]
velocities_m_s = [1.0]
[rigid_flexible]                # the file is layered over the default: drop its other parts
velocities_m_s = []
[oblique]
velocities_m_s = []
[bounce]
heights_m = []
[practical]
velocities_m_s = []
[cube_toss]
engines = []
"""
SMALL = BASE + """
[work_precision]
timesteps_s = []
"""
ENGINES_DIR = Path(__file__).resolve().parent.parent / "engines"


def sleeper_env(tmp_path: Path, sleep_s: float) -> dict[str, str]:
    """A slow plug-in engine (tests/engines/crashing_adapter.py: each run sleeps): the
    interrupt lands mid-matrix however quickly the test polls, at no CPU cost."""
    return {**os.environ, "IMPACTBENCH_STORE": str(tmp_path / "store.duckdb"),
            "IMPACTBENCH_ENGINES": "sleeper=crashing_adapter:SleepingAdapter",
            "IMPACTBENCH_TEST_SLEEP_S": str(sleep_s),
            "PYTHONPATH": os.pathsep.join([str(ENGINES_DIR), os.environ.get("PYTHONPATH",
                                                                             "")])}


def sleeper_config(velocities: list[float]) -> str:
    from test_faults import only_ball

    return only_ball("sleeper", velocities)


def report(config: Path, out: Path, env: dict[str, str], workers: int = 2,
           **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "impactbench.cli", "report", "--config",
                             str(config), "--out", str(out), "--workers", str(workers)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            **kw)


def stored_runs(path: Path) -> int:
    try:
        frame = Store(path).frame()
    except ValueError:  # the writer holds the file right now
        return 0
    return 0 if frame.empty else frame.run_key.nunique()


def test_ctrl_c_keeps_the_previous_report_and_the_rerun_resumes(tmp_path: Path) -> None:
    small, slow, out = tmp_path / "small.toml", tmp_path / "slow.toml", tmp_path / "rep"
    small.write_text(sleeper_config([1.0]))
    slow.write_text(sleeper_config([1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5]))
    first = report(small, out, sleeper_env(tmp_path, 0), workers=0)
    assert first.wait(300) == 0, first.communicate()[1]
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert Path("README.md") in before and stored_runs(tmp_path / "store.duckdb") == 1

    # 8 runs of 1.5 s on 2 workers (6 s in all), stored as they finish (at least every 2 s):
    # at 0.5 s a run, the whole matrix (2 s) could finish between the flush that showed 3
    # stored and the interrupt's flush on a loaded machine (seen: "8 of 8 stored")
    with interruptible_children():
        second = report(slow, out, sleeper_env(tmp_path, 1.5), start_new_session=True)
    deadline = time.monotonic() + 120
    while stored_runs(tmp_path / "store.duckdb") < 3 and time.monotonic() < deadline:
        assert second.poll() is None, second.communicate()[1]
        time.sleep(0.1)
    os.killpg(second.pid, signal.SIGINT)  # what Ctrl-C does: the whole process group
    _, err = second.communicate(timeout=120)
    assert second.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    line = re.search(r"interrupted; (\d+) of (\d+) runs stored; rerun to resume", err)
    assert line, err
    stored, total = map(int, line.groups())
    assert 3 <= stored < total == 8
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before  # the previous report, byte for byte
    assert sorted(p.name for p in tmp_path.iterdir()) == [".rep.lock", "rep", "slow.toml",
                                                          "small.toml", "store.duckdb"]

    third = report(slow, out, sleeper_env(tmp_path, 0), workers=0)
    assert third.wait(600) == 0, third.communicate()[1]
    meta = json.loads((out / "metadata.json").read_text())
    assert sum(r["stored"] for r in meta["runs"]) >= stored
    assert len(meta["runs"]) == total


def test_a_second_writer_is_refused(tmp_path: Path) -> None:
    config = tmp_path / "small.toml"
    config.write_text(SMALL)
    out = tmp_path / "rep"
    env = {**os.environ, "IMPACTBENCH_STORE": str(tmp_path / "store.duckdb")}
    with publish.writer_lock(out):
        done = report(config, out, env)
        _, err = done.communicate(timeout=120)
    assert done.returncode == 2
    assert err.count("\n") == 1 and "another impactbench is writing it" in err
    assert not out.exists()


def test_a_failed_write_leaves_the_folder_untouched(tmp_path: Path) -> None:
    out = tmp_path / "rep"
    (out / "figures").mkdir(parents=True)
    (out / "README.md").write_text("old")
    (out / "figures" / "hc_paper.png").write_text("kept")
    with pytest.raises(RuntimeError), publish.staged(out) as stage:
        (stage / "README.md").write_text("new")
        raise RuntimeError("renderer failed")
    assert (out / "README.md").read_text() == "old"
    with publish.staged(out, lambda rel: rel.name == "README.md") as stage:
        (stage / "README.md").write_text("new")
    assert (out / "README.md").read_text() == "new"
    assert (out / "figures" / "hc_paper.png").read_text() == "kept"  # not the writer's: kept
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]  # no staging folder left


def test_an_unchanged_rerun_keeps_the_rendered_files(tmp_path: Path) -> None:
    require_engine("pymunk")
    from impactbench import config, report

    cfg = config.parse({"report": {"engines": ["pymunk"], "modes": ["injected"]},
                        "ball_on_plate": {"velocities_m_s": [1.0]}})
    st, out = Store(tmp_path / "s.duckdb"), tmp_path / "rep"
    report.build(cfg, out, show_progress=False, store=st, workers=0)
    readme = out / "README.md"
    first = (readme.stat().st_ino, readme.read_bytes(), json.loads(
        (out / "metadata.json").read_text())["render_key"])
    again = report.build(cfg, out, show_progress=False, store=st, workers=0)
    meta = json.loads((out / "metadata.json").read_text())
    assert all(r["stored"] for r in meta["runs"]) and meta["render_key"] == first[2]
    assert (readme.stat().st_ino, readme.read_bytes()) == first[:2]  # the same file, kept
    assert {p.name for p in again.files} >= {"README.md", "index.html", "results.csv"}
    other = config.parse({**cfg.raw, "report": {**cfg.raw["report"], "title": "another"}})
    report.build(other, out, show_progress=False, store=st, workers=0)
    assert "another" in readme.read_text()
