"""The worker's watchdog: a child that stops responding (SIGSTOP) is killed at the wall-time limit and
replaced, and no call waits on its pipe."""

from __future__ import annotations

import os
import signal

import pytest

from frictionid_core.identification import IdentifyRequest
from frictionid_ros.worker import JobControl, WorkerProcess
from support.node_parts import ROOT
from support.waiting import wait_until


@pytest.fixture
def stopped_worker():
    """A worker whose child is stopped (SIGSTOP) as it starts, and the child's pid; stopped and resumed
    after the test."""
    worker = WorkerProcess()
    pid = None
    try:
        pid = wait_until(lambda: worker.pid, "the worker's child")
        os.kill(pid, signal.SIGSTOP)
        yield worker, pid
    finally:
        worker.stop()
        if pid is not None:
            try:
                os.kill(pid, signal.SIGCONT)
            except ProcessLookupError:
                pass


@pytest.fixture
def emps():
    from frictionid_core.io import load

    return load(ROOT / "bags" / "emps_estimation").slice(0, 4000)


@pytest.mark.slow
def test_a_worker_stopped_before_it_is_ready_is_killed_at_the_wall_time_limit(stopped_worker, emps):
    """Stopped while it starts (imports, warm-up), the child never says ready: the job is answered at
    its wall-time limit, the child killed, and the next job runs on a new one."""
    worker, pid = stopped_worker
    control = JobControl(wall_s=1.0)
    assert worker.run(emps, IdentifyRequest(system="emps"), control) == (
        "cancelled", "stopped: over the wall-time limit max_wall_s = 1 s")
    assert control.overrun and control.killed
    assert worker.run(emps, IdentifyRequest(system="emps"))[0] == "ok" and worker.pid not in (None, pid)


@pytest.mark.slow
def test_a_job_that_overruns_while_the_child_starts_leaves_a_child_that_is_only_slow(emps):
    """A wall-time limit shorter than the child's start (imports and warm-up take well over 50 ms) answers the
    job at once, but the child is not stuck: it is left to start and the next job runs on it."""
    worker = WorkerProcess()
    try:
        pid = wait_until(lambda: worker.pid, "the worker's child")
        control = JobControl(wall_s=0.05)
        assert worker.run(emps, IdentifyRequest(system="emps"), control) == (
            "cancelled", "stopped: over the wall-time limit max_wall_s = 0.05 s")
        assert control.overrun and not control.killed
        assert worker.run(emps, IdentifyRequest(system="emps"))[0] == "ok" and worker.pid == pid
    finally:
        worker.stop()


@pytest.mark.slow
def test_a_child_whose_node_stopped_reading_while_it_started_exits_quietly():
    """A node that stops (or replaces) its worker while the child starts closes the child's stdout: the
    child's "ready" finds a broken pipe and it exits 0 without a traceback."""
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, "-m", "frictionid_ros.worker.child"], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    child.stdout.close()  # before it is ready: imports and warm-up take a while
    child.stdin.close()
    assert child.wait(120) == 0
    assert "Traceback" not in child.stderr.read().decode(), "the child printed a traceback"


@pytest.mark.slow
def test_the_next_job_after_a_kill_runs_even_if_the_killed_child_takes_moments_to_exit(stopped_worker, emps,
                                                                                        monkeypatch):
    """A SIGKILLed child exits only once the kernel has torn it down (milliseconds for a large process,
    more on a loaded machine): the job that follows at once waits for it and runs on a new child,
    instead of reading the dying child's pipe as a crash. The teardown is stretched to 0.3 s here by
    sending the real SIGKILL late."""
    import subprocess
    import threading

    worker, pid = stopped_worker
    send_kill = subprocess.Popen.kill
    with monkeypatch.context() as late:
        late.setattr(subprocess.Popen, "kill", lambda proc: threading.Timer(0.3, send_kill, (proc,)).start())
        assert worker.run(emps, IdentifyRequest(system="emps"), JobControl(wall_s=1.0))[0] == "cancelled"
    assert worker.run(emps, IdentifyRequest(system="emps"))[0] == "ok" and worker.pid not in (None, pid)
