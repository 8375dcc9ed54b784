"""The identification worker's child process: it reads jobs and cancels from its stdin, identifies
and answers on its stdout (:mod:`.protocol`), at a low priority with one BLAS/numba thread (no ROS
import). Started by :class:`~frictionid_ros.worker.worker_process.WorkerProcess`::

    python -m frictionid_ros.worker.child

It exits when its stdin closes, and at once if the node dies (PR_SET_PDEATHSIG).
"""

from __future__ import annotations

import os
import pickle
import queue
import signal
import sys
import threading
import time

from frictionid_ros.worker.job import run_identification
from frictionid_ros.worker.job_control import Cancelled
from frictionid_ros.worker.protocol import receive_message, send_message

PROGRESS_PERIOD_S = 0.1  # shortest interval between two progress messages of the child [s]


def _die_with_parent() -> None:
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except Exception:  # not Linux: stdin EOF still ends the worker
        pass


def _warm_up() -> None:
    """Import the pipeline and fit a tiny synthetic series once (first real call then ~ms)."""
    import numpy as np

    from frictionid_core import IdentifyRequest, JointSeries, identify

    t = np.arange(2000) * 1e-3
    q = 0.1 * np.sin(2 * np.pi * t)
    v = np.gradient(q, t)
    identify(JointSeries(t, ["w"], q, 2.0 * v + 0.5 * np.sign(v)), IdentifyRequest(system="friction-only"))


class _Child:
    """The child's loop: a reader thread takes jobs and cancels from stdin; the main thread identifies."""

    def __init__(self, inp, out):
        self.out = out
        self.jobs: queue.Queue = queue.Queue()
        self.cancelled: set = set()  # ids of cancelled jobs
        threading.Thread(target=self._read, args=(inp,), daemon=True).start()

    def _read(self, inp) -> None:
        while True:
            try:
                msg = receive_message(inp)
            except (EOFError, OSError, pickle.UnpicklingError):
                self.jobs.put(None)
                return
            if msg[0] == "cancel":
                self.cancelled.add(msg[1])
            else:
                self.jobs.put(msg[1:])

    def serve(self) -> int:
        while True:
            job = self.jobs.get()
            if job is None:
                return 0
            job_id, series, request, gate = job
            last = [0.0]

            def progress(generation, evaluations, best_cost, job_id=job_id, last=last):
                if job_id in self.cancelled:
                    raise Cancelled("cancelled")
                now = time.monotonic()
                if now - last[0] >= PROGRESS_PERIOD_S:
                    last[0] = now
                    send_message(self.out, ("progress", generation, evaluations, best_cost))

            reply = (("cancelled", "cancelled") if job_id in self.cancelled
                     else run_identification(series, request, progress, gate))
            self.cancelled.discard(job_id)
            try:
                send_message(self.out, reply)
            except BrokenPipeError:
                return 0


def _lower_priority() -> None:
    """Normal scheduling (a node run real-time passes its policy on) and the niceness of the
    environment (FRICTIONID_WORKER_NICE), set before any thread starts: every thread of the child
    inherits them."""
    try:
        if os.sched_getscheduler(0) != os.SCHED_OTHER:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except (OSError, AttributeError):
        pass
    try:
        os.nice(int(os.environ.get("FRICTIONID_WORKER_NICE", "0")))
    except (OSError, ValueError):
        pass


def main() -> int:
    _die_with_parent()
    _lower_priority()
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # library prints must not corrupt the protocol channel
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is for the node; it closes our stdin
    try:
        _warm_up()
    except Exception:  # a warm-up problem shows again on the first request
        pass
    try:
        send_message(out, ("ready", os.getpid()))
    except BrokenPipeError:  # the node stopped (or replaced) us while we started: it reads no more
        return 0
    return _Child(inp, out).serve()


if __name__ == "__main__":
    sys.exit(main())
