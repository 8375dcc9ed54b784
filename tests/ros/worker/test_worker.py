"""The identification worker process: cancel, kill and priority."""

from __future__ import annotations

import os
import signal
import threading
import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl

from frictionid_core.identification import IdentifyRequest, SolverOptions
from frictionid_ros.worker import JobControl, WorkerProcess
from frictionid_ros.worker import worker_process as worker_module
from support.node_parts import ROOT
from support.waiting import wait_until

# Runs until cancelled: the optimiser reports every generation (~1 ms each).
ENDLESS_DE = IdentifyRequest(system="emps", friction="tustin",
                             solver=SolverOptions("de", pop=200, generations=100_000))


def run_in_thread(worker: WorkerProcess, series, request: IdentifyRequest,
                  control: JobControl) -> tuple[threading.Thread, dict]:
    """``worker.run`` in a thread of its own; its reply lands in the returned dict under "reply"."""
    box: dict = {}
    thread = threading.Thread(target=lambda: box.setdefault("reply", worker.run(series, request, control)),
                              daemon=True)
    thread.start()
    return thread, box


def reported(control: JobControl):
    """Wait for the optimiser's first progress report: the job runs in the child, past any compile
    of its kernels (numba, at first use on a fresh checkout: seconds without a report)."""
    wait_until(lambda: control.progress[0] >= 1, "progress report of the worker's job", timeout=120)


@pytest.mark.slow
def test_worker_process_cancel_kill_and_priority(monkeypatch):
    """A job cancelled before the child is ready never runs; a running child stops at the optimiser's
    next report and is kept; one that does not answer a cancel (stopped, as a child busy in a step
    without reports) is killed after CANCEL_GRACE_S and replaced; the child runs at the requested
    niceness."""
    from frictionid_core.io import load

    emps = load(ROOT / "bags" / "emps_estimation").slice(0, 4000)
    worker = WorkerProcess(nice=7)
    try:
        control = JobControl()
        control.cancel("early")  # while the child still starts (imports, warm-up: seconds)
        assert worker.run(emps, IdentifyRequest(system="emps"), control) == ("cancelled", "early")
        assert worker.run(emps, IdentifyRequest(system="emps"))[0] == "ok"
        pid = worker.pid
        assert os.getpriority(os.PRIO_PROCESS, pid) == 7

        with monkeypatch.context() as patch:
            # the child's own stop is under test, not how soon it comes on a loaded machine (at nice 7)
            patch.setattr(worker_module, "CANCEL_GRACE_S", 60.0)
            control = JobControl()
            thread, box = run_in_thread(worker, emps, ENDLESS_DE, control)
            reported(control)
            control.cancel("stop")
            thread.join(120)
        assert box.get("reply") == ("cancelled", "cancelled") and worker.pid == pid

        control = JobControl()
        thread, box = run_in_thread(worker, emps, ENDLESS_DE, control)
        reported(control)
        os.kill(pid, signal.SIGSTOP)  # no answer to the cancel will come
        control.cancel("stop")
        thread.join(120)
        assert box.get("reply") == ("cancelled", "stop")
        # a new child
        assert worker.run(emps, IdentifyRequest(system="emps"))[0] == "ok" and worker.pid not in (None, pid)
    finally:
        worker.stop()
