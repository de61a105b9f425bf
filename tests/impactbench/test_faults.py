"""Faults while the suite works: signals, hung engines, failing writes, a damaged or locked
results store, oversized jobs and oversized worker counts. Slow and hanging engines are
plug-ins (``tests/engines/crashing_adapter.py``): they sleep instead of computing, so these
tests cost little CPU."""

from __future__ import annotations

import errno
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from impactbench.engines.base import ENGINES_ENV

from impactbench import cli, cluster, publish
from impactbench import store as store_mod
from impactbench.matrix import Job, run_jobs
from impactbench.store import Store

ENGINES_DIR = Path(__file__).resolve().parent.parent / "engines"
PLUGINS = ("sleeper=crashing_adapter:SleepingAdapter,"
           "hanger=crashing_adapter:HangingAdapter")


def only_ball(engine: str, velocities: list[float]) -> str:
    """A report config of ``engine``'s native ball runs only: every other part of the
    packaged default (other scenarios, the studies) emptied."""
    from impactbench import config, scenarios

    lines = [f'[report]\nengines = ["{engine}"]\nmodes = ["native"]',
             f"[ball_on_plate]\nvelocities_m_s = {velocities}"]
    default = config.load(None).raw
    for spec in scenarios.specs():
        keys = [a.config_key for a in spec.axes if not a.categorical
                and a.config_key in default.get(spec.table, {})]
        if spec.table != "ball_on_plate" and keys:  # an empty axis drops the section
            lines.append(f"[{spec.table}]\n{keys[0]} = []")
    lines += ["[practical]\nvelocities_m_s = []", "[work_precision]\ntimesteps_s = []",
              "[cube_toss]\nengines = []"]
    return "\n".join(lines) + "\n"


@pytest.fixture
def plugins(monkeypatch: pytest.MonkeyPatch) -> dict[str, str]:
    """The slow and hanging engines, here and in subprocesses (their environment)."""
    monkeypatch.setenv(ENGINES_ENV, PLUGINS)
    monkeypatch.syspath_prepend(str(ENGINES_DIR))
    path = os.pathsep.join([str(ENGINES_DIR), os.environ.get("PYTHONPATH", "")])
    return {**os.environ, ENGINES_ENV: PLUGINS, "PYTHONPATH": path}


def stored_runs(path: Path) -> int:
    try:
        frame = Store(path).frame()
    except ValueError:
        return 0
    return 0 if frame.empty else frame.run_key.nunique()


def children(pid: int) -> list:
    import psutil

    try:
        return psutil.Process(pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []


# ----------------------------------------------------------------------------- signals


def test_sigterm_mid_report_keeps_finished_runs(tmp_path: Path,
                                                plugins: dict[str, str]) -> None:
    """A report of 12 half-second runs on 2 workers: runs are counted and stored as they
    finish, so SIGTERM (to the main process only, as a service manager stops it) finds some
    stored; one line, exit 143, no worker left behind, no report written; the rerun
    resumes."""
    import psutil

    config, out, db = tmp_path / "slow.toml", tmp_path / "rep", tmp_path / "s.duckdb"
    config.write_text(only_ball("sleeper", [0.5 + 0.25 * i for i in range(12)]))
    env = {**plugins, "IMPACTBENCH_STORE": str(db), "IMPACTBENCH_TEST_SLEEP_S": "0.5"}
    argv = [sys.executable, "-m", "impactbench.cli", "report", "--config", str(config),
            "--out", str(out), "--workers", "2"]
    t0 = time.monotonic()
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    first = proc.stderr.readline()  # the first progress line: at the first finished run
    assert re.match(r"impactbench: \d+ of 12 runs done", first), first
    assert time.monotonic() - t0 < 60
    deadline = time.monotonic() + 60
    while stored_runs(db) < 2 and time.monotonic() < deadline:
        assert proc.poll() is None
        time.sleep(0.1)
    workers = children(proc.pid)
    assert workers  # a local cluster
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    line = re.search(r"^impactbench: interrupted; (\d+) of 12 runs stored; rerun to resume$",
                     err, re.M)
    assert line, err
    stored = int(line.group(1))
    assert 2 <= stored < 12 and stored_runs(db) == stored
    gone = psutil.wait_procs(workers, timeout=10)[1]
    assert not gone, f"workers left behind: {gone}"
    assert not out.exists()
    env["IMPACTBENCH_TEST_SLEEP_S"] = "0"
    again = subprocess.run([*argv[:-2], "--workers", "0"], env=env, capture_output=True,
                           text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    meta = json.loads((out / "metadata.json").read_text())
    assert sum(r["stored"] for r in meta["runs"]) >= stored and len(meta["runs"]) == 12


def test_sighup_is_like_ctrl_c(tmp_path: Path, plugins: dict[str, str]) -> None:
    """A closed terminal (SIGHUP, here to a report running in its own process: --workers 0):
    what finished is stored, one line, exit 129."""
    config, db = tmp_path / "slow.toml", tmp_path / "s.duckdb"
    config.write_text(only_ball("sleeper", [0.5 + 0.25 * i for i in range(8)]))
    env = {**plugins, "IMPACTBENCH_STORE": str(db), "IMPACTBENCH_TEST_SLEEP_S": "0.4"}
    proc = subprocess.Popen([sys.executable, "-m", "impactbench.cli", "report", "--config",
                             str(config), "--out", str(tmp_path / "rep"), "--workers", "0"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = proc.stderr.readline()
    assert re.match(r"impactbench: 1 of 8 runs done", first), first
    time.sleep(0.5)
    proc.send_signal(signal.SIGHUP)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 129, err
    line = re.search(r"^impactbench: interrupted; (\d+) of 8 runs stored; rerun to resume$",
                     err, re.M)
    assert line and 1 <= int(line.group(1)) < 8, err
    assert stored_runs(db) == int(line.group(1))


# ----------------------------------------------------------------------------- timeouts


def test_a_hanging_engine_becomes_timeout_and_the_others_complete(
        tmp_path: Path, plugins: dict[str, str]) -> None:
    """On Dask: a run hanging in Python (2 m/s) and one hanging in C with the GIL held
    (3 m/s) time out, their workers are restarted, every other run completes; timeout rows
    are not stored (they rerun next time)."""
    jobs = [Job("hanger", "ball-on-plate", (("velocity_m_s", v),), "native", None)
            for v in (1.0, 2.0, 3.0, 3.5)]
    db = Store(tmp_path / "s.duckdb")
    # 6 s: the clock of a run on a restarted worker includes its cold imports (engines,
    # numpy, the plug-in registry), seen above 3 s while another test process ran beside it
    with cluster.run_timeout(6.0):
        results = run_jobs(jobs, workers=2, store=db)
    status = {r.job.velocity_m_s: r.run["status"] for r in results}
    assert status == {1.0: "no_contact", 2.0: "timeout", 3.0: "timeout", 3.5: "no_contact"}
    late = next(r for r in results if r.job.velocity_m_s == 3.0)
    assert late.run["message"] == "timed out after 6 s (cancelled; its worker was restarted)"
    assert stored_runs(tmp_path / "s.duckdb") == 2


def test_in_process_a_python_hang_is_interrupted_by_the_alarm(plugins: dict[str, str]) -> None:
    jobs = [Job("hanger", "ball-on-plate", (("velocity_m_s", v),), "native", None)
            for v in (1.0, 2.0)]
    results = run_jobs(jobs, workers=0, timeout_s=1.0)
    assert [r.run["status"] for r in results] == ["no_contact", "timeout"]
    assert results[1].run["message"] == "timed out after 1 s (in this process)"
    assert signal.getsignal(signal.SIGALRM) in (signal.SIG_DFL, None)  # put back


def test_the_default_timeout_follows_the_estimate() -> None:
    assert cluster.default_timeout(0.01) == 60.0
    assert cluster.default_timeout(10.0) == 200.0
    with cluster.run_timeout(5.0):
        assert cluster.configured_timeout() == 5.0
    assert cluster.configured_timeout() is None


def test_report_timeout_flag_and_config(tmp_path: Path, plugins: dict[str, str],
                                        capsys: pytest.CaptureFixture[str]) -> None:
    """`report --timeout S` (and [execution] timeout_s) reach the runs; --workers 0 runs in
    this process (the README's promise; config workers = 0 too)."""
    config = tmp_path / "hang.toml"
    config.write_text(only_ball("hanger", [1.0, 2.0])
                      + "[execution]\nworkers = 0\ntimeout_s = 1\n")
    db = tmp_path / "s.duckdb"
    assert cli.main(["report", "--config", str(config), "--out", str(tmp_path / "r"),
                     "--store", str(db)]) == 0
    assert "1 no_contact, 1 timeout" in capsys.readouterr().out
    assert cli.main(["report", "--config", str(config), "--out", str(tmp_path / "r"),
                     "--store", str(db), "--timeout", "0.5", "--workers", "0"]) == 0
    assert "1 no_contact, 1 timeout" in capsys.readouterr().out  # the timeout: not stored


def test_run_timeout_turns_a_python_hang_into_a_timeout_status(
        plugins: dict[str, str], capsys: pytest.CaptureFixture[str]) -> None:
    """`run --timeout S`: a run hanging in Python is stopped by the alarm: one line, status
    timeout, exit 1 (0 with --allow-status timeout); the alarm's handler is put back."""
    argv = ["run", "--engine", "hanger", "--scenario", "ball-on-plate", "--velocity", "2",
            "--timeout", "0.3"]
    t0 = time.monotonic()
    assert cli.main(argv) == 1
    assert time.monotonic() - t0 < 5.0
    err = capsys.readouterr().err
    assert "run status timeout (no result after 0.3 s" in err
    assert cli.main([*argv, "--json", "--allow-status", "timeout"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["status"], out["restitution"]) == ("timeout", None)
    assert signal.getsignal(signal.SIGALRM) in (signal.SIG_DFL, None)
    assert cli.main(["run", "--engine", "hanger", "--scenario", "ball-on-plate", "--velocity",
                     "1", "--timeout", "0.3", "--allow-status", "no_contact"]) == 0


def test_api_run_timeout(plugins: dict[str, str]) -> None:
    """`impactbench.run(..., timeout_s=S)`: a Python hang is a `timeout` result, no record."""
    import impactbench

    r = impactbench.run(engine="hanger", scenario="ball-on-plate", velocity_m_s=2.0,
                        timeout_s=0.3)
    assert (r.status, r.record, r.ok) == ("timeout", None, False)
    assert "no result after 0.3 s" in r.message


def test_run_timeout_ends_a_hang_in_c_holding_the_gil(plugins: dict[str, str]) -> None:
    """A run stuck in C with the GIL held and SIGALRM blocked (no alarm can reach it; a sleep
    in C alone is cut short by the alarm's EINTR, then reported as a timeout as above) is
    ended by the backstop
    max(5 s, S) after its timeout S: exit 1 and a dump of where it hung, no hang."""
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "impactbench.cli", "run", "--engine", "hanger",
                           "--scenario", "ball-on-plate", "--velocity", "4", "--timeout",
                           "0.5"], env=plugins, capture_output=True, text=True, timeout=120)
    took = time.monotonic() - t0
    assert proc.returncode == 1
    assert "Timeout (0:00:05.500000)!" in proc.stderr  # faulthandler's header: 0.5 + 5 s
    assert "run_ball" in proc.stderr  # where it hung
    assert 5.5 <= took < 60.0


# ----------------------------------------------------------------------------- cost refusal


def test_a_gate_too_fine_to_run_is_refused_with_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gate = tmp_path / "g.toml"
    gate.write_text('[[gate]]\nengine = "pymunk"\nmode = "injected"\nscenario = '
                    '"ball-on-plate"\nvelocities_m_s = [1.0]\ntimesteps_s = [1e-12]\n'
                    "[gate.tolerance]\nrestitution = 0.1\n")
    code = cli.main(["gate", "--config", str(gate), "--store", str(tmp_path / "s.duckdb")])
    err = capsys.readouterr().err
    assert code == 2
    assert re.fullmatch(r"impactbench: error: 1 runs: about \S+ \(integration steps\), more "
                        r"than 1e\+07; pass --yes to run it anyway\n", err), err
    assert not (tmp_path / "s.duckdb").exists()


# ----------------------------------------------------------------------------- writes


def full_disk(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every atomic write fails as on a full disk (after its data is written)."""
    def fsync(_fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(publish.os, "fsync", fsync)


def read_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """No file can be created (a read-only file system; chmod does not stop root)."""
    def mkstemp(*_a, **_k):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(publish.tempfile, "mkstemp", mkstemp)


@pytest.mark.parametrize("fault", [full_disk, read_only])
def test_a_failed_baseline_write_leaves_the_old_baseline(fault, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    from impactbench import gates

    path = tmp_path / "gates_baseline.json"
    gates.save_baseline(path, {"a": {"rel_error": 0.1}})
    before = path.read_bytes()
    fault(monkeypatch)
    with pytest.raises(ValueError, match=r"^baseline = '.*gates_baseline.json': cannot write "
                       r"\((No space left on device|Read-only file system)\)$"):
        gates.save_baseline(path, {"a": {"rel_error": 0.2}})
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gates_baseline.json"]


@pytest.mark.parametrize("fault", [full_disk, read_only])
def test_calibrate_out_on_a_failing_disk_is_one_line_and_keeps_the_old_file(
        fault, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    data = Path(__file__).resolve().parents[2] / "impactbench/data/examples/" \
        "synthetic_steel_ball.csv"
    out = tmp_path / "steel.toml"
    out.write_text("# the previous calibration\n")
    fault(monkeypatch)
    code = cli.main(["calibrate", "--data", str(data), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith(f"impactbench: error: out = '{out}': cannot write (")
    assert out.read_text() == "# the previous calibration\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["steel.toml"]


def test_a_failed_tuned_file_write_leaves_the_old_file(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    from impactbench.tuned import write_tuned

    path = tmp_path / "mj.toml"
    write_tuned(path, {"parameters": {"solref": [0.02, 1.0]}})
    before = path.read_bytes()
    full_disk(monkeypatch)
    with pytest.raises(ValueError, match=r"cannot write \(No space left on device\)"):
        write_tuned(path, {"parameters": {"solref": [0.03, 1.0]}})
    assert path.read_bytes() == before and len(list(tmp_path.iterdir())) == 1


def test_an_atomic_write_keeps_the_files_mode(tmp_path: Path) -> None:
    path = tmp_path / "f.json"
    path.write_text("{}")
    path.chmod(0o640)
    publish.atomic_write(path, "[]")
    assert path.read_text() == "[]" and path.stat().st_mode & 0o777 == 0o640


# ----------------------------------------------------------------------------- the store


def sleeper_jobs(velocities) -> list[Job]:
    return [Job("sleeper", "ball-on-plate", (("velocity_m_s", v),), "native", None)
            for v in velocities]


def test_a_truncated_store_is_named_in_one_line_and_moved_aside_on_request(
        tmp_path: Path, plugins: dict[str, str], monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("IMPACTBENCH_TEST_SLEEP_S", "0")
    db = tmp_path / "s.duckdb"
    run_jobs(sleeper_jobs([0.5 + 0.1 * i for i in range(40)]), workers=0, store=Store(db))
    size = db.stat().st_size
    assert size > 300_000  # more than one block
    os.truncate(db, size // 2)  # a copy cut short, a full disk during a checkpoint
    config = tmp_path / "c.toml"
    config.write_text(only_ball("sleeper", [1.0]))
    argv = ["report", "--config", str(config), "--out", str(tmp_path / "r"), "--store",
            str(db), "--workers", "0"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert re.fullmatch(rf"impactbench: error: store = '{re.escape(str(db))}': damaged, not "
                        r"a readable results store \(truncated to \d+ bytes, .*\); "
                        r"--store-reset moves it aside and starts a new one\n", err), err
    assert cli.main([*argv, "--store-reset"]) == 0
    err = capsys.readouterr().err
    assert "was damaged" in err and "moved aside to" in err
    aside = [p for p in tmp_path.iterdir() if p.name.startswith("s.duckdb.corrupt-")]
    assert len(aside) == 1 and aside[0].stat().st_size == size // 2  # kept, for inspection
    assert stored_runs(db) == 1
    assert not store_mod.RESET_CORRUPT  # per command


HOLD = """
import duckdb, sys, time
con = duckdb.connect(sys.argv[1])
print("holding", flush=True)
sys.stdin.readline()
"""


def test_a_locked_store_loses_nothing(tmp_path: Path, plugins: dict[str, str],
                                      monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    """Another process holds the store (a DuckDB client left open): the writes wait (and
    say so), then go to a side file beside the store, merged at its next open."""
    monkeypatch.setenv("IMPACTBENCH_TEST_SLEEP_S", "0")
    monkeypatch.setattr(store_mod, "LOCK_WAIT_S", 1.5)
    monkeypatch.setattr(store_mod, "SAY_WAIT_AFTER_S", 0.2)
    db = tmp_path / "s.duckdb"
    Store(db).put([])  # nothing: no file yet
    run_jobs(sleeper_jobs([0.5]), workers=0, store=Store(db))  # the store exists
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(db)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "holding\n"
        jobs = sleeper_jobs([1.0, 1.5, 2.0])
        results = run_jobs(jobs, workers=0, store=Store(db), fresh=True)
        assert len(results) == 3
        err = capsys.readouterr().err
        assert "is locked by another process (pid " in err and "waiting up to 1.5 s" in err
        assert re.search(r"3 runs kept in '.*s\.duckdb\.staged-\d+-\w+\.duckdb' \(merged "
                         r"into the store when it is next opened\)", err), err
        assert len([p for p in tmp_path.iterdir() if ".staged-" in p.name]) == 1
    finally:
        holder.communicate("\n", timeout=30)
    assert stored_runs(db) == 4  # the next open merged the side file ...
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.duckdb"]  # ... and removed it


def test_a_store_locked_through_a_report_keeps_every_run(
        tmp_path: Path, plugins: dict[str, str], monkeypatch: pytest.MonkeyPatch) -> None:
    """`report --fresh` while a DuckDB client holds the store: exit 0, every run kept."""
    monkeypatch.setattr(store_mod, "LOCK_WAIT_S", 1.0)
    db, config = tmp_path / "s.duckdb", tmp_path / "c.toml"
    config.write_text(only_ball("sleeper", [1.0, 2.0]))
    env = {"IMPACTBENCH_TEST_SLEEP_S": "0"}
    monkeypatch.setenv("IMPACTBENCH_TEST_SLEEP_S", env["IMPACTBENCH_TEST_SLEEP_S"])
    run_jobs(sleeper_jobs([3.0]), workers=0, store=Store(db))
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(db)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "holding\n"
        assert cli.main(["report", "--config", str(config), "--out", str(tmp_path / "r"),
                         "--store", str(db), "--workers", "0", "--fresh"]) == 0
    finally:
        holder.communicate("\n", timeout=30)
    assert stored_runs(db) == 3


# ----------------------------------------------------------------------------- workers


def test_workers_are_capped_at_the_cores(capsys: pytest.CaptureFixture[str]) -> None:
    from impactbench.cliutil import check_workers

    cores = cluster.available_cores()
    assert check_workers(1000) == cores
    assert capsys.readouterr().err == (f"impactbench: workers = 1000: capped at {cores}, the "
                                       "cores available\n")
    assert check_workers(0) == 0 and check_workers(None) is None
    assert check_workers(1000, "tcp://10.0.0.5:8786") == 1000  # not ours to cap
    assert cluster.Runner(1000).size == cores
    with pytest.raises(ValueError, match=r"^workers = -1: must be an integer >= 0"):
        check_workers(-1)


def test_execution_workers_zero_is_accepted() -> None:
    from impactbench import config

    cfg = config.parse({"report": {"engines": ["pymunk"]},
                        "ball_on_plate": {"velocities_m_s": [1.0]},
                        "execution": {"workers": 0, "timeout_s": 30}})
    assert cfg.execution == {"workers": 0, "timeout_s": 30}
    with pytest.raises(ValueError, match=r"execution.timeout_s = 0: must be a number"):
        config.parse({**cfg.raw, "execution": {"timeout_s": 0}})
