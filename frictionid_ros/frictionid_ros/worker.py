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
answered CANCEL_GRACE_S after a cancel is killed and replaced. The child exits when its stdin
closes, and at once if the node dies (PR_SET_PDEATHSIG).
"""

from __future__ import annotations

import math
import os
import pickle
import queue
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
    registers how, :meth:`on_cancel`). :attr:`progress` is the optimiser's last report
    (generation, evaluations, best cost); :attr:`stopped_at` is set when the identification ended
    [s, ``time.monotonic``].
    """

    def __init__(self):
        self.t_start = time.monotonic()
        self.reason = ""
        self.cancelled_at = 0.0
        self.stopped_at = 0.0
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
    from frictionid_core import FrictionIdError, identify

    try:
        if gate is not None and gate.candidate is not None:
            result = gate.candidate
        else:
            result = identify(series, request, progress=progress)
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
        return ("error", f"solver '{request.solver.method}' is unavailable ({type(exc).__name__}: {exc})")
    except Exception as exc:  # noqa: BLE001 - reported to the caller, never kills the worker
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
    bad = [k for k, v in payload[0].params.items() if not math.isfinite(v)]
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

            def progress(generation, evaluations, best_cost):
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
    except Exception:  # noqa: BLE001 - a warm-up problem shows again on the first request
        pass
    _send(out, ("ready", os.getpid()))
    return _Child(inp, out).serve()


# ----------------------------------------------------------------------------- node side


class _Job:
    def __init__(self, job_id: int, series, request: IdentifyRequest, gate: Gate | None, control: JobControl):
        self.id, self.series, self.request, self.gate, self.control = job_id, series, request, gate, control
        self.reply: tuple | None = None
        self.done = threading.Event()
        self.sent = False  # written to the child (under WorkerProcess._lock)


class WorkerProcess:
    """Parent side: one child, one identification at a time, replaced if it dies or is killed.

    ``nice``: niceness added to the child's [0..19]; the child runs one BLAS/numba thread. A
    long-lived owner thread starts the child and reads from it: Linux's PR_SET_PDEATHSIG is tied to the thread that created the child, so that
    thread must live as long as the node.
    """

    def __init__(self, nice: int = 0):
        self._nice = int(nice)
        self._proc: subprocess.Popen | None = None
        self._jobs: queue.Queue = queue.Queue()
        self._lock = threading.Lock()  # stdin writes, job.sent, the running job
        self._running: _Job | None = None
        self._ids = 0
        self._closed = False
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
        env.update({name: "1" for name in THREAD_VARIABLES})
        self._proc = subprocess.Popen([sys.executable, "-m", "frictionid_ros.worker"], stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE, env=env, close_fds=True)
        return self._proc

    def _serve(self) -> None:
        proc = self._start()
        ready = False
        while True:
            job = self._jobs.get()
            if job is None:
                return
            try:
                if proc is None or proc.poll() is not None:
                    proc, ready = self._start(), False
                if not ready:
                    _recv(proc.stdout)  # ("ready", pid)
                    ready = True
                with self._lock:
                    if job.control.cancelled:
                        job.reply = ("cancelled", job.control.reason)
                        continue
                    _send(proc.stdin, ("job", job.id, job.series, job.request, job.gate))
                    job.sent, self._running = True, job
                while True:
                    msg = _recv(proc.stdout)
                    if msg[0] != "progress":
                        break
                    job.control.progress = tuple(msg[1:])
                job.reply = msg
            except (EOFError, OSError, pickle.UnpicklingError) as exc:
                rc = proc.poll() if proc is not None else None
                if rc is None and proc is not None:
                    proc.kill()
                    rc = proc.wait()
                job.reply = (("cancelled", job.control.reason) if job.control.cancelled else
                             ("crash", f"identification worker died ({f'exit code {rc}' if rc is not None else exc})"))
                proc, ready = (None, False) if self._closed else (self._start(), False)  # the next job finds it warm
            finally:
                with self._lock:
                    self._running = None
                job.control.stopped_at = time.monotonic()
                job.done.set()

    def _interrupt(self, job: _Job) -> None:
        """Ask the child to stop ``job`` (it stops at the optimiser's next report)."""
        with self._lock:
            if job.sent and self._running is job and self._proc is not None:
                try:
                    _send(self._proc.stdin, ("cancel", job.id))
                except OSError:
                    pass

    def _kill(self, job: _Job) -> None:
        """Kill the child if it still runs ``job`` (the owner thread then starts a new one)."""
        with self._lock:
            proc = self._proc if self._running is job else None
        if proc is not None and proc.poll() is None:
            proc.kill()

    def run(self, series, request: IdentifyRequest, control: JobControl | None = None, gate: Gate | None = None
            ) -> tuple:
        """Identify ``request`` on ``series`` in the child (with ``gate``: also judge the result by the
        safety gate, see :func:`run_identification`); returns its reply (see the module docstring).

        ``control``: receives the progress; its :meth:`~JobControl.cancel` stops the job, killing
        the child if it has not stopped within CANCEL_GRACE_S.
        """
        control = control or JobControl()
        if self._closed:
            return ("error", "node shutting down")
        self._ids += 1
        job = _Job(self._ids, series, request, gate, control)
        self._jobs.put(job)
        control.on_cancel(lambda: self._interrupt(job))
        while not job.done.wait(0.05):
            if control.cancelled:
                with self._lock:
                    sent = job.sent
                if not sent:  # still waiting for the child (starting): the owner thread will skip it
                    control.stopped_at = time.monotonic()
                    return ("cancelled", control.reason)
                if time.monotonic() - control.cancelled_at > CANCEL_GRACE_S:
                    self._kill(job)
            if self._closed and not self._thread.is_alive():  # stopped meanwhile: no one will answer
                return ("error", "node shutting down")
        return job.reply

    def stop(self, timeout: float = 2.0) -> None:
        """End the child (stdin closed, killed after ``timeout`` s) and the owner thread."""
        self._closed = True
        self._jobs.put(None)
        proc = self._proc
        if proc is None:
            return
        try:
            proc.stdin.close()
        except OSError:
            pass
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout)


if __name__ == "__main__":
    sys.exit(main())
