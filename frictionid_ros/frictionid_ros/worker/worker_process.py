"""Identification worker process and the control of one identification (no ROS import).

The node runs ``frictionid_core.identification`` in a child process (``python -m frictionid_ros.worker``)
rather than a thread: the pipeline is CPU-bound Python/numpy and, in a thread, would take the
GIL from the 1 kHz input callback (measured: end-to-end feed-forward latency p50 12 ms, p99
39 ms during an identification instead of < 1 ms), and its temporary arrays would stay in the
node's heap. The child also isolates the node from a crashing solver, and it can be killed.
It runs at a low priority (``nice``) with one BLAS/numba thread, so the identification never
takes every core from the feed-forward path.

Protocol on the child's stdin/stdout, both ways: the pickle's length and its number of out-of-band
buffers (8-byte little-endian each), the pickle (protocol 5), then each buffer as its length and bytes.
Node → child: ``("job", id, series, request, gate)`` (an IdentifyRequest; a :class:`Gate` or None),
``("cancel", id)``. Child → node: ``("ready", pid)`` once, then per job any number of
``("progress", generation, evaluations, best_cost)`` (at most every PROGRESS_PERIOD_S) and one
reply: ``("ok", (IdentifyResult, the gate's Decision or None))``, ``("error", message)`` for a
FrictionIdError, ``("cancelled", message)`` or ``("crash", message)`` for anything else.
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

import math
import os
import pickle
import queue
import select
import signal
import struct
import subprocess
import sys
import threading
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from frictionid_core import IdentifyRequest, IdentifyResult
    from frictionid_core.loop import Decision

_LENGTH = struct.Struct("<Q")  # an out-of-band buffer's length
_FRAME = struct.Struct("<QQ")  # a message's pickle length and number of out-of-band buffers
PROGRESS_PERIOD_S = 0.1  # shortest interval between two progress messages of the child [s]
CANCEL_GRACE_S = 0.25  # a cancelled child still running after this long is killed [s]
# A child that has not said "ready" this long after its start (imports, warm-up: seconds) is stuck [s].
READY_TIMEOUT_S = 60.0
KILLED_NOTE = "the identification worker did not stop: killed and restarted"
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


class Cancelled(Exception):
    """Raised inside an identification (from its progress hook) to stop it."""


@dataclass(frozen=True)
class Gate:
    """A review by the safety gate (:func:`frictionid_core.loop.gate.review`) of an identification:
    ``candidate`` (None: the identification's own result) against ``current`` (None: no active
    set) on the held-back series ``holdout``; ``max_abs``: largest parameter magnitude accepted."""

    current: IdentifyResult | None
    holdout: object  # JointSeries
    max_abs: float
    candidate: IdentifyResult | None = None


class JobControl:
    """Cancellation and progress of one identification, shared by the threads that run and watch it.

    :meth:`cancel` records the first reason and interrupts the running identification (the worker
    registers how, :meth:`on_cancel`); :meth:`check_wall` cancels it once it has run longer than
    ``wall_s`` [s]. :attr:`progress` is the optimiser's last report (generation, evaluations, best
    cost); :attr:`stopped_at` is set when the identification ended [s, ``time.monotonic``];
    :attr:`overrun`: cancelled by the wall-time limit; :attr:`killed`: its worker child did not
    stop after the cancel (or, overrun, never became ready) and was killed.
    """

    def __init__(self, wall_s: float = math.inf):
        self.t_start = time.monotonic()
        self.wall_s = float(wall_s)
        self.reason = ""
        self.cancelled_at = 0.0
        self.stopped_at = 0.0
        self.overrun = False
        self.killed = False
        self.progress: tuple[int, int, float] = (0, 0, math.inf)
        self._interrupt = None
        self._lock = threading.Lock()

    @property
    def cancelled(self) -> bool:
        return bool(self.reason)

    def cancel(self, reason: str) -> bool:
        """Stop the identification, saying why; False if it was already cancelled."""
        with self._lock:
            if self.reason:
                return False
            self.reason, self.cancelled_at = reason, time.monotonic()
            interrupt = self._interrupt
        if interrupt is not None:
            interrupt()
        return True

    def check_wall(self) -> None:
        """Cancel the identification once it has run longer than :attr:`wall_s`."""
        if not self.reason and time.monotonic() - self.t_start > self.wall_s:
            self.overrun = self.cancel(f"stopped: over the wall-time limit max_wall_s = {self.wall_s:g} s")

    def on_cancel(self, interrupt) -> None:
        """Call ``interrupt()`` on :meth:`cancel` (at once if already cancelled)."""
        with self._lock:
            self._interrupt = interrupt
            now = bool(self.reason)
        if now:
            interrupt()

    def report(self, generation: int, evaluations: int, best_cost: float) -> None:
        """The optimiser's progress hook in this process: record, and stop if cancelled."""
        self.progress = (int(generation), int(evaluations), float(best_cost))
        self.check_wall()
        if self.reason:
            raise Cancelled(self.reason)


def _send(stream, obj) -> None:
    """Write ``obj``: its pickle and, out of band, the memory of its arrays as they are (no copy of
    a data window while holding the GIL: the node's feed-forward thread may be waiting for it)."""
    buffers: list[pickle.PickleBuffer] = []
    data = pickle.dumps(obj, protocol=5, buffer_callback=buffers.append)
    stream.write(_FRAME.pack(len(data), len(buffers)) + data)
    for buf in buffers:
        raw = buf.raw()
        stream.write(_LENGTH.pack(raw.nbytes))
        stream.write(raw)  # the write itself releases the GIL
    stream.flush()


def _read_exactly(stream, n: int) -> bytes:
    data = stream.read(n)
    if len(data) < n:
        raise EOFError("worker pipe closed")
    return data


def _recv(stream):
    n, count = _FRAME.unpack(_read_exactly(stream, _FRAME.size))
    data = _read_exactly(stream, n)
    buffers = []
    for _ in range(count):  # writable, so that the arrays made on them are too
        buf = bytearray(_LENGTH.unpack(_read_exactly(stream, _LENGTH.size))[0])
        if stream.readinto(buf) < len(buf):
            raise EOFError("worker pipe closed")
        buffers.append(buf)
    return pickle.loads(data, buffers=buffers)


def run_identification(series, request: IdentifyRequest, progress=None, gate: Gate | None = None) -> tuple:
    """One identification → ("ok", (result, decision)) | ("error" | "cancelled" | "crash", message).

    ``gate``: the result (or ``gate.candidate``, judged instead of identifying) is also judged by
    the safety gate; the decision is None without one. ``progress``: the optimiser's hook (see
    :func:`frictionid_core.identification.identify`); it cancels the run by raising :class:`Cancelled`."""
    from frictionid_core import FrictionIdError, IdentifyRequest, identify

    try:
        if gate is not None and gate.candidate is not None:
            result = gate.candidate
        elif isinstance(request, IdentifyRequest):
            result = identify(series, request, progress=progress)
        else:  # a task of its own (~/identify_payload's: frictionid_ros.payload.PayloadTask)
            result = request.run(series)
        decision = None
        if gate is not None:  # judged here too: the prediction of the held-back slice is CPU work
            from frictionid_core.loop import review

            decision = review(gate.current, result, gate.holdout, gate.max_abs)
        return ("ok", (result, decision))
    except Cancelled as exc:
        return ("cancelled", str(exc))
    except FrictionIdError as exc:
        return ("error", str(exc))
    except ImportError as exc:
        what = f"solver '{request.solver.method}'" if isinstance(request, IdentifyRequest) else "a module"
        return ("error", f"{what} is unavailable ({type(exc).__name__}: {exc})")
    except Exception as exc:  # reported to the caller, never kills the worker
        return ("crash", f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}")


def checked_result(reply: tuple, log_crash) -> tuple[IdentifyResult, Decision | None]:
    """(the result, the gate's decision or None) of a :func:`run_identification` reply;
    FrictionIdError for an error, a crash (whose full text goes to ``log_crash``) or non-finite
    parameters; :class:`Cancelled` for a cancelled run."""
    from frictionid_core import FrictionIdError

    status, payload = reply
    if status == "cancelled":
        raise Cancelled(payload)
    if status == "error":
        raise FrictionIdError(payload)
    if status == "crash":
        log_crash(f"identification crashed: {payload}")
        raise FrictionIdError(f"identification failed: {payload.splitlines()[0]}")
    from frictionid_core import IdentifyResult

    result = payload[0]
    values = result.params if isinstance(result, IdentifyResult) else result.payload.parameters()
    bad = [k for k, v in values.items() if not math.isfinite(v)]
    if bad:
        raise FrictionIdError(f"identification failed: non-finite parameter(s) {bad}")
    return payload


def rss_kb(pid: int | str = "self") -> int:
    """Resident memory of a process [kB] (0 if unknown)."""
    try:
        with open(f"/proc/{pid}/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024
    except (OSError, ValueError, IndexError):
        return 0


# ----------------------------------------------------------------------------- child side


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
                msg = _recv(inp)
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
                    _send(self.out, ("progress", generation, evaluations, best_cost))

            reply = (("cancelled", "cancelled") if job_id in self.cancelled
                     else run_identification(series, request, progress, gate))
            self.cancelled.discard(job_id)
            try:
                _send(self.out, reply)
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
        _send(out, ("ready", os.getpid()))
    except BrokenPipeError:  # the node stopped (or replaced) us while we started: it reads no more
        return 0
    return _Child(inp, out).serve()


# ----------------------------------------------------------------------------- node side


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
        proc = subprocess.Popen([sys.executable, "-m", "frictionid_ros.worker.worker_process"], stdin=subprocess.PIPE,
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
                    _send(proc.stdin, msg)
            except (OSError, ValueError):  # the child died or was killed (broken pipe), or its stdin closed
                pass

    def _ready(self, proc: subprocess.Popen, job: _Job) -> bool:
        """Wait for the child's ("ready", pid); False (not ready yet) as soon as ``job`` is cancelled."""
        while not select.select([proc.stdout], [], [], 0.1)[0]:
            if job.control.cancelled:
                return False
        _recv(proc.stdout)
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
            try:
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
                    msg = _recv(proc.stdout)
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
            proc.kill()  # SIGKILL: a stopped child too; its pipes then break, freeing the owner and the writer

    def run(self, series, request: IdentifyRequest, control: JobControl | None = None, gate: Gate | None = None
            ) -> tuple:
        """Identify ``request`` on ``series`` in the child (with ``gate``: also judge the result by the
        safety gate, see :func:`run_identification`); returns its reply (see the module docstring).

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


if __name__ == "__main__":
    sys.exit(main())
