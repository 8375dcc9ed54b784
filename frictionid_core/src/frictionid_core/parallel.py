"""How many threads a compiled kernel may use right now, and the pool that runs its chunks.

A robot computer is never idle: the controller, the drivers and this node share the cores. A
fork/join kernel waits for its slowest thread, and a thread that the scheduler parks behind a
competing process stalls the whole call for a time slice (several ms), so a 2-thread kernel with
one CPU-bound competitor on 2 cores ran up to 90× slower than on one thread. Hence:

* threads = min(CPUs this process may use (affinity, cgroup quota) minus the other runnable
  tasks right now (``/proc/loadavg``), one per ``min_items`` of work), at least 1: one thread
  on a busy machine, and no fork/join for work too small to pay for it;
* the chunks are claimed by whichever thread is free first, the caller included: a worker the
  scheduler has not run yet leaves its chunk to the caller instead of stalling the call;
* a load that the snapshot missed shows in the call itself: when the caller waited for the other
  threads more than half as long as it worked, or did every chunk itself, the kernels stay on
  one thread for ``BACKOFF_S`` seconds.

``FRICTIONID_THREADS=n`` caps the threads (1: never a second thread); :func:`fixed_threads`
pins the count (tests, benchmarks). Kernels give each item to one thread, computed in a fixed
order, so results do not depend on the thread count.

The same stall hits the BLAS (OpenBLAS) and OpenMP pools of numpy, scipy and scikit-learn on
the small matrices of the surrogate and least-squares solvers: :func:`single_threaded_libraries`
keeps them at one thread for a block (bo's 100 calls: 4× less CPU on a busy machine).
"""

from __future__ import annotations

import itertools
import os
import queue
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import lru_cache

_CAP_VARIABLE = "FRICTIONID_THREADS"
BACKOFF_S = 2.0  # one thread for this long after a parallel call that did not pay
STALL_RATIO = 0.5  # ... i.e. whose caller waited for the others more than this × its own work
_fixed: int | None = None
_backoff_until = 0.0
_controller: tuple[int, object] | None = None  # (len(sys.modules) when built, ThreadpoolController)


def choose_threads(n_items: int, min_items: int, cpus: float, busy: int) -> int:
    """Threads for ``n_items`` items: one per ``min_items``, at most the ``cpus`` this process may
    use (possibly a fractional quota) less the ``busy`` ones, at least 1."""
    return max(1, min(int(cpus) - max(busy, 0), n_items // max(min_items, 1)))


@lru_cache(maxsize=1)
def _cpu_quota() -> float:
    """CPUs allowed by the cgroup v2 quota (``cpu.max``), inf when there is none."""
    try:
        with open("/sys/fs/cgroup/cpu.max") as fh:
            quota, period = fh.read().split()[:2]
        return float("inf") if quota == "max" else float(quota) / float(period)
    except (OSError, ValueError):
        return float("inf")


def usable_cpus() -> float:
    """CPUs this process may run on: its affinity set, capped by a cgroup CPU quota."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    return min(float(cpus), _cpu_quota())


def busy_cpus() -> int:
    """Runnable tasks of other processes: a snapshot of ``/proc/loadavg``, machine-wide (with an
    affinity narrower than the machine it may count tasks on other CPUs: one thread more often,
    never a stall), less this process's own runnable threads (this call, this pool's active
    workers, a BLAS pool still spinning after its last call); 0 where it does not exist."""
    try:
        with open("/proc/loadavg") as fh:
            running = int(fh.read().split()[3].split("/")[0])
    except (OSError, ValueError, IndexError):
        return 0
    busy = running - 1 - _POOL.active
    return busy if busy <= 0 else running - max(_own_running(), 1 + _POOL.active)


def _own_running() -> int:
    """Threads of this process in the run queue (state R), the caller included; 0 if unknown."""
    n = 0
    try:
        tasks = os.listdir("/proc/self/task")
    except OSError:
        return 0
    for task in tasks:
        try:
            with open(f"/proc/self/task/{task}/stat", "rb") as fh:
                n += fh.read().rsplit(b")", 1)[1].split()[0] == b"R"
        except (OSError, IndexError):
            continue
    return n


def _cap() -> int | None:
    value = os.environ.get(_CAP_VARIABLE)
    try:
        return max(1, int(value)) if value else None
    except ValueError:
        return None


def threads_for(n_items: int, min_items: int) -> int:
    """Threads a kernel over ``n_items`` items (at least ``min_items`` per thread) uses now."""
    if _fixed is not None:
        return max(1, min(_fixed, n_items))
    cap = _cap()
    if n_items < 2 * max(min_items, 1) or cap == 1 or time.monotonic() < _backoff_until:
        return 1
    n = choose_threads(n_items, min_items, usable_cpus(), busy_cpus())
    return n if cap is None else min(n, cap)


@contextmanager
def fixed_threads(n: int) -> Iterator[None]:
    """Use exactly ``n`` threads (at most one per item) whatever the load, inside the block."""
    global _fixed
    previous, _fixed = _fixed, max(1, int(n))
    try:
        yield
    finally:
        _fixed = previous


def split(n_items: int, parts: int) -> list[tuple[int, int]]:
    """``parts`` contiguous (lo, hi) ranges covering range(n_items), sizes differing by at most 1."""
    parts = max(1, min(parts, n_items))
    edges = [n_items * i // parts for i in range(parts + 1)]
    return list(zip(edges[:-1], edges[1:]))


def _back_off(seconds: float = BACKOFF_S) -> None:
    """Keep the kernels on one thread for ``seconds`` (a parallel call just did not pay)."""
    global _backoff_until
    _backoff_until = time.monotonic() + seconds


class _Job:
    """Chunks of one call; any thread claims the next one until none is left."""

    def __init__(self, fn: Callable[[int, int], None], chunks: list[tuple[int, int]]) -> None:
        self.fn, self.chunks = fn, chunks
        self.claims = itertools.count()
        self.left = len(chunks)
        self.lock = threading.Lock()
        self.done = threading.Event()
        self.error: BaseException | None = None

    def work(self) -> int:
        """Run chunks until none is left to claim; returns how many this thread ran."""
        ran = 0
        while (i := next(self.claims)) < len(self.chunks):
            ran += 1
            try:
                self.fn(*self.chunks[i])
            except BaseException as exc:  # re-raised in the calling thread
                self.error = self.error or exc
            with self.lock:
                self.left -= 1
                if not self.left:
                    self.done.set()
        return ran


class _Pool:
    """Daemon worker threads, started on first use, that help with the chunks of a job."""

    def __init__(self) -> None:
        self.jobs: queue.SimpleQueue[_Job] = queue.SimpleQueue()
        self.workers = 0
        self.active = 0  # workers busy with a job (they are runnable, but they are us)
        self.lock = threading.Lock()

    def _worker(self) -> None:
        while True:
            job = self.jobs.get()
            with self.lock:
                self.active += 1
            try:
                job.work()
            finally:
                with self.lock:
                    self.active -= 1

    def run(self, fn: Callable[[int, int], None], chunks: list[tuple[int, int]], threads: int) -> None:
        job = _Job(fn, chunks)
        helpers = min(threads, len(chunks)) - 1
        with self.lock:
            for _ in range(self.workers, helpers):
                threading.Thread(target=self._worker, name="frictionid-kernel", daemon=True).start()
                self.workers += 1
        for _ in range(helpers):
            self.jobs.put(job)
        t0 = time.perf_counter()
        ran = job.work()
        t1 = time.perf_counter()
        job.done.wait()
        if ran == len(chunks) or time.perf_counter() - t1 > STALL_RATIO * (t1 - t0):
            _back_off()
        if job.error is not None:
            raise job.error


_POOL = _Pool()


def _reset_after_fork() -> None:  # a forked child has none of the parent's worker threads
    global _POOL
    _POOL = _Pool()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_reset_after_fork)


def run_chunks(fn: Callable[[int, int], None], n_items: int, min_items: int = 1) -> int:
    """Call ``fn(lo, hi)`` over contiguous chunks covering range(n_items), in as many threads as
    :func:`threads_for` allows (``fn`` should release the GIL: a ``nogil`` numba kernel).
    Returns the number of threads used."""
    threads = threads_for(n_items, min_items)
    if threads == 1:
        if n_items:
            fn(0, n_items)
        return 1
    _POOL.run(fn, split(n_items, threads), threads)
    return threads


@contextmanager
def single_threaded_libraries() -> Iterator[None]:
    """BLAS and OpenMP thread pools of the loaded libraries at one thread inside the block."""
    global _controller
    from threadpoolctl import ThreadpoolController

    if _controller is None or _controller[0] != len(sys.modules):  # rescan (~10 ms) after new imports only
        _controller = (len(sys.modules), ThreadpoolController())
    with _controller[1].limit(limits=1):
        yield


# ------------------------------------------------------------------ worker processes
# glibc's mallopt parameters, and the thresholds its dynamic rule settles at on 64-bit Linux.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_MMAP_THRESHOLD_MAX = 32 * 1024 * 1024
MALLOC_TRIM_VARIABLE = "MALLOC_TRIM_THRESHOLD_"


def init_worker_process() -> None:
    """Set up a process that runs one task at a time beside others of its kind (a process pool's or a
    Dask worker): kernels on one thread (``FRICTIONID_THREADS=1`` unless set: the processes already
    use the cores) and glibc's malloc thresholds restored (:func:`restore_malloc_thresholds`)."""
    os.environ.setdefault(_CAP_VARIABLE, "1")
    restore_malloc_thresholds()


def restore_malloc_thresholds() -> bool:
    """Undo ``MALLOC_TRIM_THRESHOLD_`` in this process's environment: Dask's nanny starts its workers
    with 65536, which hands every freed block over 64 KiB back to the kernel and fixes the mmap
    threshold at 128 KiB, so each large array costs fresh page faults (a TX40 Stribeck fit took 2.5–6×
    longer, its system time 0.7 → 5.9 s). The thresholds are set to where glibc's dynamic rule
    settles (mmap 32 MiB, trim twice that). Returns True when it changed them (glibc only)."""
    if MALLOC_TRIM_VARIABLE not in os.environ or not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        libc = ctypes.CDLL("libc.so.6")
        done = (libc.mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD_MAX) == 1
                and libc.mallopt(_M_TRIM_THRESHOLD, 2 * _MMAP_THRESHOLD_MAX) == 1)
    except (OSError, AttributeError):  # not glibc
        return False
    if done:
        del os.environ[MALLOC_TRIM_VARIABLE]  # child processes start with glibc's own rule
    return done


def exit_with_parent() -> None:
    """End this process when its parent ends (Linux ``PR_SET_PDEATHSIG``): a pool worker must not outlive
    a coordinator that was killed (SIGKILL leaves it no time to stop its pool)."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    parent = os.getppid()
    try:
        ctypes.CDLL("libc.so.6").prctl(1, int(signal.SIGTERM))  # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not glibc
        return
    if os.getppid() != parent:  # the parent ended before the call
        os._exit(1)
