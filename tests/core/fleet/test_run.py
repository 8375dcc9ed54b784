"""``frictionid fleet`` on a small synthetic fleet: its files, a drift alarmed, broken logs in failed.json,
resume by content hash, --refit, a damaged store recomputed, a killed worker or client losing nothing,
and the fleet file's errors in one line."""

from __future__ import annotations

import csv
import functools
import json
import operator
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from frictionid_core.cli import main
from frictionid_core.fleet import Broken, Drift, synthesize_fleet
from frictionid_core.fleet.backends import DIED, LocalBackend
from frictionid_core.fleet.run import FITS_HEADER, STORE_FILE
from support.waiting import wait_until

ROBOTS, LOGS, BASELINE = 2, 13, 10
DRIFT = Drift(robot=1, joint=0, start=11, size=0.3, ramp_logs=1)  # arm02 j1: Fc +30 % from its 12th log
BROKEN = (Broken(0, 2, "truncated"), Broken(1, 4, "garbage"))


@pytest.fixture(scope="module")
def fleet(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("fleet") / "data"
    return synthesize_fleet(folder, robots=ROBOTS, logs=LOGS, drifts=(DRIFT,), broken=BROKEN, duration_s=6.0,
                            rate_hz=100.0, seed=3, baseline_logs=BASELINE)


@pytest.fixture(scope="module")
def first_run(fleet, tmp_path_factory) -> tuple[Path, str]:
    out = tmp_path_factory.mktemp("run") / "out"
    assert main(["fleet", str(fleet), "--out", str(out), "--workers", "2"]) == 0
    return out, (out / "fits.csv").read_text()


def _cli(capsys, *argv) -> tuple[int, str, str]:
    code = main(["fleet", *map(str, argv)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.slow
def test_a_fleet_run_writes_its_files_alarms_the_drift_and_lists_the_broken_logs(fleet, first_run):
    out, fits = first_run
    rows = list(csv.reader(fits.splitlines()))
    assert tuple(rows[0]) == FITS_HEADER
    fitted = {(r[0], r[1]) for r in rows[1:]}
    assert len(fitted) == ROBOTS * LOGS - len(BROKEN)
    # joint system, Coulomb: J, Fv, Fc and offset of each of the 3 joints, each with a finite positive σ
    assert len(rows) - 1 == len(fitted) * 3 * 4
    assert all(float(r[6]) > 0 for r in rows[1:])
    assert rows[1][2].startswith("2026-01-01T") and rows[1][2].endswith("+00:00")
    failed = json.loads((out / "failed.json").read_text())
    assert {(f["robot"], f["log"]) for f in failed} == {("arm01", "arm01/day_003.mcap"),
                                                        ("arm02", "arm02/day_005.mcap")}
    assert all(f["attempts"] == 2 and "not a readable bag" in f["error"] for f in failed)
    # the identified Fc follows the truth (each fit resolves it to ~1 %)
    truth = json.loads((fleet.parent / "truth.json").read_text())["robots"]["arm02"]["logs"]
    fc = {r[1]: float(r[5]) for r in rows[1:] if r[0] == "arm02" and r[3] == "j1" and r[4] == "Fc"}
    for log in truth:
        if log["log"] in fc:
            assert fc[log["log"]] == pytest.approx(log["Fc"][0], rel=0.03)
    alarms = json.loads((out / "alarms.json").read_text())
    assert [(a["robot"], a["joint"], a["parameter"], a["first_log"]) for a in alarms] == [
        ("arm02", "j1", "Fc", "arm02/day_012.mcap")]
    assert set(alarms[0]) >= {"robot", "joint", "parameter", "first_log", "start_time", "baseline", "value", "z"}
    assert alarms[0]["value"] > 1.2 * alarms[0]["baseline"] and alarms[0]["z"] > 10
    page = (out / "index.html").read_text()
    assert "arm02" in page and "ALARM" in page and (out / "plots").is_dir()


@pytest.mark.slow
def test_a_rerun_skips_fitted_logs_and_recomputes_damaged_records(fleet, first_run, tmp_path, capsys):
    out, fits = first_run
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    code, stdout, _ = _cli(capsys, fleet, "--out", copy, "--workers", "1")
    assert code == 0 and "0 fitted now, 26 already done" in stdout
    assert (copy / "fits.csv").read_text() == fits
    # forge a value, delete a field, break a byte: each record is set aside, said so, and refitted
    store = copy / STORE_FILE
    lines = store.read_bytes().split(b"\n")
    ok = [k for k, line in enumerate(lines) if b'"status":"ok"' in line]
    forged = json.loads(lines[ok[0]])
    forged["rows"][0][2] *= 1.5
    lines[ok[0]] = json.dumps(forged).encode()
    deleted = json.loads(lines[ok[1]])
    del deleted["start_time"]
    lines[ok[1]] = json.dumps(deleted).encode()
    lines[ok[2]] = lines[ok[2]][:30] + b"\xc3" + lines[ok[2]][31:]
    store.write_bytes(b"\n".join(lines))
    code, stdout, stderr = _cli(capsys, fleet, "--out", copy, "--workers", "1")
    assert code == 0 and "3 fitted now, 23 already done" in stdout
    assert stderr.count("set aside in fits.set-aside.jsonl") == 3
    assert f"line {ok[0] + 1}: checksum mismatch" in stderr and f"line {ok[2] + 1}: not UTF-8" in stderr
    assert (copy / "fits.csv").read_text() == fits
    code, stdout, _ = _cli(capsys, fleet, "--out", copy, "--workers", "1", "--refit")
    assert code == 0 and "24 fitted now, 0 already done, 2 failed" in stdout
    assert (copy / "fits.csv").read_text() == fits


@pytest.mark.slow
def test_a_killed_client_loses_only_the_logs_in_flight(fleet, first_run, tmp_path):
    out = tmp_path / "out"
    cli = [str(Path(sys.executable).parent / "frictionid"), "fleet", str(fleet), "--out", str(out), "--workers", "1"]
    proc = subprocess.Popen(cli, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    store = out / STORE_FILE
    try:
        wait_until(lambda: store.exists() and store.read_bytes().count(b"\n") >= 3, timeout=120,
                   what="three records in the store")
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    kept = store.read_bytes().count(b"\n")
    done = subprocess.run(cli, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    already = int(done.stdout.split(" fitted now, ")[1].split(" already done")[0])
    assert already >= kept - 2  # failed attempts of a broken log count once it failed twice
    assert (out / "fits.csv").read_text() == first_run[1]


def test_a_task_that_kills_its_worker_is_recorded_and_the_others_complete():
    # a payload is a callable: functools.partial(os._exit, 3) kills the worker process running it
    tasks = [("a", functools.partial(dict, value=1.0)), ("dies", functools.partial(os._exit, 3)),
             ("b", functools.partial(dict, value=2.0)), ("c", functools.partial(dict, value=3.0))]
    records = []
    with LocalBackend(2) as backend:
        backend.run(operator.call, tasks, records.append)  # fn(payload) = payload(), in a fresh interpreter
    final = {r["key"]: r for r in records}
    assert {k: final[k].get("value") for k in "abc"} == {"a": 1.0, "b": 2.0, "c": 3.0}
    assert final["dies"]["status"] == "failed" and final["dies"]["error"] == DIED and final["dies"]["attempt"] == 2


@pytest.mark.parametrize("change, message", [
    ({"robots": [{"name": "arm01", "logs": "nothing/*.mcap"}]}, "robot 'arm01': logs 'nothing/*.mcap' match no file"),
    ({"defaults": {"friction": "nope"}}, "defaults.friction"),
    ({"defaults": {"colour": "red"}}, "key 'defaults.colour' is unknown"),
    ({"alarm": {"false_alarm_rate": 2}}, "key 'alarm.false_alarm_rate' must be a probability"),
    ({"baseline_logs": 1}, "key 'baseline_logs' must be an integer >= 3"),
])
def test_a_bad_fleet_file_is_one_line_naming_its_key(fleet, tmp_path, capsys, change, message):
    import yaml

    data = {**yaml.safe_load(fleet.read_text()), **change}
    bad = fleet.parent / f"bad_{len(list(fleet.parent.glob('bad_*')))}.yaml"
    bad.write_text(yaml.safe_dump(data))
    code, _, stderr = _cli(capsys, bad, "--out", tmp_path / "out")
    assert code == 2 and message in stderr and len(stderr.strip().splitlines()) == 1, stderr
    assert not (tmp_path / "out").exists()


def test_an_output_over_a_log_is_refused(fleet, capsys):
    code, _, stderr = _cli(capsys, fleet, "--out", fleet.parent / "arm01" / "day_001.mcap")
    assert code == 2 and "is a file" in stderr


def test_the_workers_read_files_even_after_the_cwd_changes(fleet, tmp_path, monkeypatch):
    # relative globs are resolved against the fleet file, once: the jobs carry absolute paths
    from frictionid_core.fleet import read_fleet

    monkeypatch.chdir(tmp_path)
    config = read_fleet(os.path.relpath(fleet, tmp_path))
    assert all(Path(source).is_absolute() and Path(source).exists() for r in config.robots for _, source in r.logs)
    assert [name for name, _ in config.robots[0].logs][:2] == ["arm01/day_001.mcap", "arm01/day_002.mcap"]



def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_a_dask_cluster_gives_the_same_fits_and_a_killed_worker_loses_nothing(fleet, first_run, tmp_path):
    # a scheduler and two one-thread workers (each under its nanny, as `dask worker` starts them); one
    # worker process is killed after the third record: its nanny restarts it, the scheduler reruns its task
    import psutil

    from frictionid_core.fleet import read_fleet, run_fleet

    dask = str(Path(sys.executable).parent / "dask")
    address = f"tcp://127.0.0.1:{_free_port()}"
    port = address.rsplit(":", 1)[1]
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", port, "--no-dashboard"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)]
    procs += [subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--no-dashboard"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
              for _ in range(2)]
    killed = []

    def kill_a_worker(done: int, total: int, record: dict) -> None:
        if done == 3 and not killed:
            children = psutil.Process(procs[1].pid).children(recursive=True)
            worker = next(c for c in children if "python" in c.name().lower())
            worker.kill()
            killed.append(worker.pid)

    try:
        result = run_fleet(read_fleet(fleet), tmp_path / "out", scheduler=address, progress=kill_a_worker)
    finally:
        for proc in procs:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert killed
    assert result.fitted_now == ROBOTS * LOGS - len(BROKEN) and len(result.failed) == len(BROKEN)
    assert (tmp_path / "out" / "fits.csv").read_text() == first_run[1]
