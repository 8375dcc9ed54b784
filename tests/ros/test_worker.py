"""The identification worker process: cancel, kill and priority."""

from __future__ import annotations

import os
import threading
import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl

from frictionid_ros.worker import JobControl, WorkerProcess
from support.node_parts import ROOT


@pytest.mark.slow
def test_worker_process_cancel_kill_and_priority():
    """A job cancelled before the child is ready never runs; the child stops at the optimiser's
    next report; one busy elsewhere (building a TX40 model, no report for seconds) is killed and
    replaced; it runs at the requested niceness."""
    from frictionid_core.identification import IdentifyRequest, SolverOptions
    from frictionid_core.io import load

    emps = load(ROOT / "bags" / "emps_estimation").slice(0, 4000)
    worker = WorkerProcess(nice=7)
    try:
        control = JobControl()  # cancelled while the child still starts (imports, warm-up: seconds)
        threading.Timer(0.05, control.cancel, ("early",)).start()
        assert worker.run(emps, IdentifyRequest(system="emps"), control) == ("cancelled", "early")
        assert worker.run(emps, IdentifyRequest(system="emps"))[0] == "ok"
        pid = worker.pid
        assert os.getpriority(os.PRIO_PROCESS, pid) == 7
        control = JobControl()
        threading.Timer(1.0, control.cancel, ("stop",)).start()
        endless = SolverOptions("de", pop=200, generations=100_000)
        reply = worker.run(emps, IdentifyRequest(system="emps", friction="tustin", solver=endless), control)
        assert reply == ("cancelled", "cancelled") and control.progress[0] >= 1 and worker.pid == pid
        tx40 = load(ROOT / "bags" / "tx40_excitation")
        control = JobControl()  # cancelled while the child loads the bag and builds the TX40 model
        threading.Timer(0.2, control.cancel, ("stop",)).start()
        assert worker.run(tx40, IdentifyRequest(system="tx40"), control) == ("cancelled", "stop")
        assert worker.run(emps, IdentifyRequest(system="emps"))[0] == "ok" and worker.pid != pid  # a new child
    finally:
        worker.stop()
