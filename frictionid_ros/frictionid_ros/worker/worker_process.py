"""The identification worker process, the node's side: :class:`WorkerProcess` (no ROS import).

The node runs ``frictionid_core.identification`` in a child process (:mod:`.child`) rather than a
thread: the pipeline is CPU-bound Python/numpy and, in a thread, would take the GIL from the 1 kHz
input callback (measured: end-to-end feed-forward latency p50 12 ms, p99 39 ms during an
identification instead of < 1 ms), and its temporary arrays would stay in the node's heap. The
child also isolates the node from a crashing solver, and it can be killed. It runs at a low
priority (``nice``) with one BLAS/numba thread, so the identification never takes every core from
the feed-forward path. Their messages: :mod:`.protocol`.

A cancelled job stops at the optimiser's next generation or cost call; a child that has not
answered CANCEL_GRACE_S after a cancel is killed and replaced (the watchdog: the wall-time limit
``max_wall_s`` cancels a job, :meth:`JobControl.check_wall`, so a child that overruns it or stops
responding — even stopped by SIGSTOP — is killed and replaced, and the job answered saying so; a
job that overruns while the child starts is answered, and the child killed only if it is stuck
starting: stopped, or not ready READY_TIMEOUT_S after its start).
No caller ever waits on the child's pipe: one writer thread writes to it, the owner thread reads
from it, and the lock guards state only. The child exits when its stdin closes, and at once if the
node dies (PR_SET_PDEATHSIG).
"""

from __future__ import annotations

import os
import pickle
import queue
import select
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING

from frictionid_ros.worker.job import Gate
from frictionid_ros.worker.job_control import JobControl
from frictionid_ros.worker.protocol import receive_message, send_message

if TYPE_CHECKING:
    from frictionid_core import IdentifyRequest

CANCEL_GRACE_S = 0.25  # a cancelled child still running after this long is killed [s]
# A child that has not said "ready" this long after its start (imports, warm-up: seconds) is stuck [s].
READY_TIMEOUT_S = 60.0
KILLED_NOTE = "the identification worker did not stop: killed and restarted"
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


def rss_kb(pid: int | str = "self") -> int:
    """Resident memory of a process [kB] (0 if unknown)."""
    try:
        with open(f"/proc/{pid}/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024
    except (OSError, ValueError, IndexError):
        return 0


def _stopped(pid: int) -> bool:
    """Whether process ``pid`` is stopped (SIGSTOP, a debugger: state T or t in ``/proc/<pid>/stat``;
    False where there is no /proc)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read()
    except OSError:
        return False
    return stat[stat.rfind(b")") + 2:][:1] in (b"T", b"t")


class _Job:
    def __init__(self, job_id: int, series, request: IdentifyRequest, gate: Gate | None, control: JobControl):
        self.id, self.series, self.request, self.gate, self.control = job_id, series, request, gate, control
        self.reply: tuple | None = None
        self.done = threading.Event()
        self.sent = False  # handed to the writer for the child (under WorkerProcess._lock)


class WorkerProcess:
    """Parent side: one child, one identification at a time, replaced if it dies or is killed.

    ``nice``: niceness added to the child's [0..19]; the child runs one BLAS/numba thread. A
    long-lived owner thread starts the child and reads from it (Linux's PR_SET_PDEATHSIG is tied
    to the thread that created the child, so that thread must live as long as the node); a writer
    thread alone writes to the child's stdin (jobs and cancels, queued: a child that no longer
    reads blocks only that thread, until the child is killed). :attr:`_lock` guards the state only
    and is never held during I/O: a cancel, a kill and :meth:`stop` never wait on the child.
    """

    def __init__(self, nice: int = 0):
        self._nice = int(nice)
        self._proc: subprocess.Popen | None = None
        self._started_at = 0.0  # when the child was started [s, time.monotonic]
        self._jobs: queue.Queue = queue.Queue()
        self._outbox: queue.Queue = queue.Queue()  # (child, message or None: close its stdin) | None: end
        self._lock = threading.Lock()  # the child, the job in hand and job.sent
        self._current: _Job | None = None  # the job the owner thread handles (waiting for the child, or sent)
        self._killed: subprocess.Popen | None = None  # the last child killed (it may take moments to exit)
        self._ids = 0
        self._closed = False
        self._writer = threading.Thread(target=self._write, name="frictionid-worker-writer", daemon=True)
        self._writer.start()
        self._thread = threading.Thread(target=self._serve, name="frictionid-worker-io", daemon=True)
        self._thread.start()

    @property
    def pid(self) -> int | None:
        proc = self._proc
        return proc.pid if proc is not None and proc.poll() is None else None

    def _start(self) -> subprocess.Popen:
        import frictionid_core
        import frictionid_ros

        paths = [str(Path(m.__file__).resolve().parents[1]) for m in (frictionid_ros, frictionid_core)]
        env = dict(os.environ, FRICTIONID_WORKER_NICE=str(self._nice))
        env["PYTHONPATH"] = os.pathsep.join(paths + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
        env.update(dict.fromkeys(THREAD_VARIABLES, "1"))
        proc = subprocess.Popen([sys.executable, "-m", "frictionid_ros.worker.child"], stdin=subprocess.PIPE,
                                stdout=subprocess.PIPE, env=env, close_fds=True)
        with self._lock:
            self._proc, self._started_at = proc, time.monotonic()
        return proc

    def _retire(self, proc: subprocess.Popen | None) -> None:
        """Close the pipes of a child that is gone (its stdin by the writer, after what it has queued)."""
        if proc is not None:
            self._outbox.put((proc, None))
            try:
                proc.stdout.close()
            except OSError:
                pass

    def _write(self) -> None:
        """The writer thread: the queued messages to their child, in order."""
        while True:
            item = self._outbox.get()
            if item is None:
                return
            proc, msg = item
            try:
                if msg is None:
                    proc.stdin.close()
                else:
                    send_message(proc.stdin, msg)
            except (OSError, ValueError):  # the child died or was killed (broken pipe), or its stdin closed
                pass

    def _ready(self, proc: subprocess.Popen, job: _Job) -> bool:
        """Wait for the child's ("ready", pid); False (not ready yet) as soon as ``job`` is cancelled."""
        while not select.select([proc.stdout], [], [], 0.1)[0]:
            if job.control.cancelled:
                return False
        receive_message(proc.stdout)
        return True

    def _serve(self) -> None:
        proc = self._start()
        ready = False
        while True:
            job = self._jobs.get()
            if job is None:
                self._retire(proc)
                return
            with self._lock:
                self._current = job
                killed = proc is not None and proc is self._killed
            try:
                if killed:  # a SIGKILLed child is gone in moments; its pipe's EOF is no crash of this job
                    proc.wait()
                if proc is None or proc.poll() is not None:
                    self._retire(proc)
                    proc, ready = self._start(), False
                ready = ready or self._ready(proc, job)
                with self._lock:
                    if job.control.cancelled:
                        job.reply = ("cancelled", job.control.reason)
                        continue
                    job.sent = True
                self._outbox.put((proc, ("job", job.id, job.series, job.request, job.gate)))
                while True:
                    msg = receive_message(proc.stdout)
                    if msg[0] != "progress":
                        break
                    job.control.progress = tuple(msg[1:])
                job.reply = msg
            except (EOFError, OSError, ValueError, pickle.UnpicklingError) as exc:
                rc = proc.poll() if proc is not None else None
                if rc is None and proc is not None:
                    proc.kill()
                    rc = proc.wait()
                job.reply = (("cancelled", job.control.reason) if job.control.cancelled else
                             ("crash", f"identification worker died ({f'exit code {rc}' if rc is not None else exc})"))
                self._retire(proc)
                proc, ready = (None, False) if self._closed else (self._start(), False)  # the next job finds it warm
            finally:
                with self._lock:
                    self._current = None
                job.control.stopped_at = time.monotonic()
                job.done.set()

    def _interrupt(self, job: _Job) -> None:
        """Ask the child to stop ``job`` (it stops at the optimiser's next report); queued, never waits."""
        with self._lock:
            proc = self._proc if job.sent and self._current is job else None
        if proc is not None:
            self._outbox.put((proc, ("cancel", job.id)))

    def _kill(self, job: _Job) -> None:
        """Kill the child if it still runs ``job``, or if ``job`` overran its wall-time limit waiting
        for a child that is stuck starting — stopped (SIGSTOP), or not ready READY_TIMEOUT_S after
        its start; a child that is only slow to start is left to start (the owner thread starts a
        new one after a kill)."""
        with self._lock:
            proc = self._proc if self._current is job else None
            stuck = job.sent or (job.control.overrun and proc is not None and (
                _stopped(proc.pid) or time.monotonic() - self._started_at > READY_TIMEOUT_S))
        if proc is not None and stuck and proc.poll() is None:
            job.control.killed = True
            with self._lock:
                self._killed = proc
            proc.kill()  # SIGKILL: a stopped child too; its pipes then break, freeing the owner and the writer

    def run(self, series, request: IdentifyRequest, control: JobControl | None = None, gate: Gate | None = None
            ) -> tuple:
        """Identify ``request`` on ``series`` in the child (with ``gate``: also judge the result by the
        safety gate, see :func:`.job.run_identification`); returns its reply (see :mod:`.protocol`).

        ``control``: receives the progress and enforces its wall-time limit; its
        :meth:`~JobControl.cancel` stops the job, killing the child if it has not stopped within
        CANCEL_GRACE_S. A job still waiting for the child is answered at once when cancelled.
        """
        control = control or JobControl()
        if self._closed:
            return ("error", "node shutting down")
        with self._lock:
            self._ids += 1
            job = _Job(self._ids, series, request, gate, control)
        self._jobs.put(job)
        control.on_cancel(lambda: self._interrupt(job))
        while not job.done.wait(0.05):
            control.check_wall()
            if control.cancelled:
                with self._lock:
                    sent = job.sent
                if not sent:  # still waiting for the child: the owner thread will skip it
                    self._kill(job)  # only a child that did not start within the wall-time limit
                    control.stopped_at = time.monotonic()
                    return ("cancelled", control.reason)
                if time.monotonic() - control.cancelled_at > CANCEL_GRACE_S:
                    self._kill(job)
            if self._closed and not self._thread.is_alive():  # stopped meanwhile: no one will answer
                return ("error", "node shutting down")
        return job.reply

    def stop(self, timeout: float = 2.0) -> None:
        """End the child (stdin closed, killed after ``timeout`` s) and the threads; never waits on
        the child's pipe."""
        self._closed = True
        self._jobs.put(None)
        with self._lock:
            proc = self._proc
        if proc is not None:
            self._outbox.put((proc, None))  # after what is queued: the child ends on EOF
            try:
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout)
        self._outbox.put(None)

