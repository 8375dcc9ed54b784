"""Identification worker process (no ROS import).

The node runs ``frictionid_core.identification`` in a child process (``python -m frictionid_ros.worker``)
rather than a thread: the pipeline is CPU-bound Python/numpy and, in a thread, would take the
GIL from the 1 kHz input callback (measured: end-to-end feed-forward latency p50 12 ms, p99
39 ms during an identification instead of < 1 ms), and its temporary arrays would stay in the
node's heap. The child also isolates the node from a crashing solver.

Protocol on the child's stdin/stdout: 8-byte little-endian length + pickle, both ways.
Request ``(series: JointSeries, kwargs: dict)``; reply ``("ok", Identification.to_dict())``,
``("error", message)`` for a FrictionIdError or ``("crash", message)`` for anything else.
The child exits when its stdin closes, and at once if the node dies (PR_SET_PDEATHSIG).
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
import traceback
from pathlib import Path

_HEADER = struct.Struct("<Q")


def _send(stream, obj) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(_HEADER.pack(len(data)))
    stream.write(data)
    stream.flush()


def _recv(stream):
    head = stream.read(_HEADER.size)
    if len(head) < _HEADER.size:
        raise EOFError("worker pipe closed")
    (n,) = _HEADER.unpack(head)
    data = stream.read(n)
    if len(data) < n:
        raise EOFError("worker pipe closed")
    return pickle.loads(data)


def run_identification(series, kwargs: dict) -> tuple:
    """One identification → ("ok", result dict) | ("error", message) | ("crash", message)."""
    from frictionid_core.errors import FrictionIdError
    from frictionid_core.identification import identify

    try:
        return ("ok", identify(series, **kwargs).to_dict())
    except FrictionIdError as exc:
        return ("error", str(exc))
    except ImportError as exc:
        return ("error", f"solver '{kwargs.get('solver')}' is unavailable ({type(exc).__name__}: {exc})")
    except Exception as exc:  # noqa: BLE001 - reported to the caller, never kills the worker
        return ("crash", f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}")


def checked_result(reply: tuple, log_crash) -> dict:
    """The result dict of a :func:`run_identification` reply; FrictionIdError for an error, a crash
    (whose full text goes to ``log_crash``) or non-finite parameters."""
    from frictionid_core.errors import FrictionIdError

    status, payload = reply
    if status == "error":
        raise FrictionIdError(payload)
    if status == "crash":
        log_crash(f"identification crashed: {payload}")
        raise FrictionIdError(f"identification failed: {payload.splitlines()[0]}")
    bad = [k for k, v in payload["params"].items() if not math.isfinite(v)]
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


def _die_with_parent() -> None:
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except Exception:  # not Linux: stdin EOF still ends the worker
        pass


def _warm_up() -> None:
    """Import the pipeline and fit a tiny synthetic series once (first real call then ~ms)."""
    import numpy as np

    from frictionid_core.identification import identify
    from frictionid_core.timeseries import JointSeries

    t = np.arange(2000) * 1e-3
    q = 0.1 * np.sin(2 * np.pi * t)
    v = np.gradient(q, t)
    identify(JointSeries(t, ["w"], q, 2.0 * v + 0.5 * np.sign(v)), system="friction-only")


def main() -> int:
    _die_with_parent()
    try:
        os.nice(5)  # the node's 1 kHz input thread wins the CPU over a long identification
    except OSError:
        pass
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # library prints must not corrupt the protocol channel
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is for the node; it closes our stdin
    try:
        _warm_up()
    except Exception:  # noqa: BLE001 - a warm-up problem shows again on the first request
        pass
    _send(out, ("ready", os.getpid()))
    while True:
        try:
            series, kwargs = _recv(inp)
        except EOFError:
            return 0
        try:
            _send(out, run_identification(series, kwargs))
        except BrokenPipeError:
            return 0


class WorkerProcess:
    """Parent side: one child, one request at a time, restarted if it dies.

    A long-lived owner thread starts the child and talks to it: Linux's PR_SET_PDEATHSIG is
    tied to the thread that created the child, so that thread must live as long as the node.
    """

    def __init__(self):
        self._proc: subprocess.Popen | None = None
        self._jobs: queue.Queue = queue.Queue()
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
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(paths + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
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
            (series, kwargs), box, done = job
            try:
                if proc is None or proc.poll() is not None:
                    proc, ready = self._start(), False
                if not ready:
                    _recv(proc.stdout)  # ("ready", pid)
                    ready = True
                _send(proc.stdin, (series, kwargs))
                box.append(_recv(proc.stdout))
            except (EOFError, OSError, pickle.UnpicklingError) as exc:
                rc = proc.poll() if proc is not None else None
                if rc is None and proc is not None:
                    proc.kill()
                    rc = proc.wait()
                proc = None
                box.append(("crash", f"identification worker died ({f'exit code {rc}' if rc is not None else exc})"))
            finally:
                done.set()

    def run(self, series, kwargs: dict, stopping: threading.Event | None = None) -> tuple:
        """Identify in the child; returns its reply (see the module docstring).

        Returns ("error", "node shutting down") if ``stopping`` is set while waiting.
        """
        box: list = []
        done = threading.Event()
        self._jobs.put(((series, kwargs), box, done))
        while not done.wait(0.1):
            if stopping is not None and stopping.is_set():
                return ("error", "node shutting down")
        return box[0]

    def stop(self, timeout: float = 2.0) -> None:
        """End the child (stdin closed, killed after ``timeout`` s) and the owner thread."""
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
