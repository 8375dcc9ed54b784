"""Many independent tasks on a local process pool (default) or a Dask cluster: each result handed over
as it arrives, a failed task recorded and retried once, never fatal.

    with open_backend(workers=2, setup=warm) as backend:      # or scheduler="tcp://host:port"
        backend.run(fn, [(key, payload), …], on_record)

``fn(payload)`` runs in a worker and returns a record (a dict of JSON values); ``on_record`` receives
``{**record, "key", "status": "ok", "attempt"}``, or ``{"key", "status": "failed", "error": one line,
"attempt"}`` when ``fn`` raised or its worker died. A failed attempt is retried once (``attempts=2``).
Each worker is set up once: :func:`frictionid_core.parallel.init_worker_process` (kernels on one
thread, glibc's malloc thresholds restored where Dask's nanny changed them), then ``setup()`` (e.g.
a numba warm-up) — by the pool's initialiser, or by a Dask worker's first task.

Local: a spawn-context ``ProcessPoolExecutor`` (fresh interpreters: no inherited threads or locks),
two tasks in flight per worker, each worker's address space capped at ``memory_mb`` (a log too large
for it fails with MemoryError instead of swapping the machine), each ending with its coordinator. A
worker that dies (killed, out of memory) breaks the pool: it is rebuilt and the tasks that were in
flight are rerun one at a time, so the one that kills its worker is found and recorded as failed
while the others complete.

Dask: a ``distributed.Client`` at ``scheduler`` (the scheduler reruns the tasks of a worker that dies).
Its workers should run one thread each (``dask worker --nthreads 1``) and bound their own memory
(``--memory-limit``).
"""

from __future__ import annotations

import os
import threading
from collections import deque
from collections.abc import Callable, Iterable

from frictionid_core.errors import FrictionIdError

IN_FLIGHT_PER_WORKER = 2
WORKER_WAIT_S = 60.0
DIED = ("its worker process died (killed, out of memory or crashed) while running it, also when run alone")

Task = tuple[str, object]  # (key, payload)
OnRecord = Callable[[dict], None]
Prepare = Callable[[object], object]

_setup_lock = threading.Lock()
_setup_done = False


def one_line(text: str) -> str:
    """``text`` on one line (whitespace runs made single spaces)."""
    return " ".join(str(text).split())


def failed(error: str) -> dict:
    """The outcome of a failed attempt."""
    return {"status": "failed", "error": one_line(error)}


def setup_worker(setup: Callable[[], None] | None = None, memory_mb: float | None = None,
                 coordinator_pid: int | None = None) -> None:
    """Set up this worker process once (module doc); ``memory_mb``: cap its address space (MB). A
    worker thread inside the coordinator's own process (``coordinator_pid``: a Dask cluster with
    ``processes=False``) only runs ``setup``: the process's environment and limits stay the caller's."""
    global _setup_done
    with _setup_lock:
        if _setup_done:
            return
        from frictionid_core.parallel import init_worker_process

        in_coordinator = coordinator_pid is not None and os.getpid() == coordinator_pid
        if not in_coordinator:
            init_worker_process()
        if memory_mb and not in_coordinator:
            import resource

            limit = int(memory_mb * 1024 * 1024)
            _, hard = resource.getrlimit(resource.RLIMIT_AS)
            if hard == resource.RLIM_INFINITY or limit < hard:
                resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
        if setup is not None:
            setup()
        _setup_done = True


def _init_pool_worker(setup: Callable[[], None] | None, memory_mb: float | None) -> None:
    """A local pool worker's initialiser: it ends with the coordinator, then :func:`setup_worker`."""
    from frictionid_core.parallel import exit_with_parent

    exit_with_parent()
    setup_worker(setup, memory_mb)


def guarded(fn: Callable[[object], dict], payload, setup: Callable[[], None] | None = None,
            coordinator_pid: int | None = None) -> dict:
    """``fn(payload)`` in a worker with the BLAS on one thread, as ``{**record, "status": "ok"}``, or
    :func:`failed` with the error's one line (an input error's own words; another exception's type and
    message)."""
    from frictionid_core.parallel import single_threaded_libraries

    setup_worker(setup, coordinator_pid=coordinator_pid)
    try:
        with single_threaded_libraries():
            record = fn(payload)
    except FrictionIdError as exc:
        return failed(str(exc))
    except MemoryError:
        return failed("out of memory (MemoryError): the task needs more than the worker's memory limit")
    except Exception as exc:  # one task's bug must not stop the others: recorded, retried
        return failed(f"internal error: {type(exc).__name__}: {exc}")
    return {**record, "status": "ok"}


def _same(payload):
    return payload


class _Attempts:
    """The tasks still to run, and what becomes of an attempt's outcome (recorded; retried if failed)."""

    def __init__(self, tasks: Iterable[Task], attempts: int, on_record: OnRecord) -> None:
        self.queue: deque[tuple[str, object, int]] = deque((key, payload, 1) for key, payload in tasks)
        self.attempts = attempts
        self.on_record = on_record

    def take(self) -> tuple[str, object, int] | None:
        return self.queue.popleft() if self.queue else None

    def done(self, key: str, payload, attempt: int, outcome: dict) -> None:
        self.on_record({**outcome, "key": key, "attempt": attempt})
        if outcome.get("status") != "ok" and attempt < self.attempts:
            self.queue.append((key, payload, attempt + 1))


class LocalBackend:
    """A spawn-context process pool of ``workers`` processes (module doc)."""

    def __init__(self, workers: int, setup: Callable[[], None] | None = None, memory_mb: float | None = None):
        self.workers = max(1, int(workers))
        self.setup = setup
        self.memory_mb = memory_mb
        self.pool = None

    def __enter__(self) -> LocalBackend:
        self._start()
        return self

    def __exit__(self, *exc) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=exc[0] is None, cancel_futures=True)
            self.pool = None

    def _start(self) -> None:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        self.pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"),
                                        initializer=_init_pool_worker, initargs=(self.setup, self.memory_mb))

    def sees(self, path: str) -> bool:
        """True: the workers read this machine's files."""
        return True

    def run(self, fn: Callable[[object], dict], tasks: Iterable[Task], on_record: OnRecord, attempts: int = 2,
            prepare: Prepare | None = None) -> None:
        """Run every task (module doc), calling ``on_record`` with each attempt's record as it ends;
        ``prepare(payload)`` (e.g. attaching a file's bytes) is applied as each is submitted."""
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        todo = _Attempts(tasks, attempts, on_record)
        prepare = prepare or _same
        pending: dict = {}  # future -> (key, payload, attempt, run alone)
        suspects: deque = deque()  # in flight when a worker died: rerun one at a time
        while True:
            if suspects:
                if not pending:
                    key, payload, attempt = suspects.popleft()
                    pending[self.pool.submit(guarded, fn, prepare(payload), self.setup)] = (key, payload, attempt, True)
            else:
                while len(pending) < IN_FLIGHT_PER_WORKER * self.workers and (item := todo.take()) is not None:
                    pending[self.pool.submit(guarded, fn, prepare(item[1]), self.setup)] = (*item, False)
            if not pending:
                return
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            broken = False
            for future in done:
                key, payload, attempt, alone = pending.pop(future)
                try:
                    outcome = future.result()
                except BrokenProcessPool:
                    broken = True
                    if alone:
                        todo.done(key, payload, attempt, failed(DIED))
                    else:
                        suspects.append((key, payload, attempt))
                    continue
                except Exception as exc:  # e.g. a payload that cannot be pickled
                    outcome = failed(f"internal error: {type(exc).__name__}: {exc}")
                todo.done(key, payload, attempt, outcome)
            if broken:
                suspects.extend((key, payload, attempt) for key, payload, attempt, _ in pending.values())
                pending.clear()
                self.pool.shutdown(wait=False, cancel_futures=True)
                self._start()


class DaskBackend:
    """A Dask ``distributed`` client at ``scheduler`` (module doc)."""

    def __init__(self, scheduler: str, setup: Callable[[], None] | None = None) -> None:
        self.scheduler = scheduler
        self.setup = setup
        self.client = None

    def __enter__(self) -> DaskBackend:
        try:
            from distributed import Client
        except ImportError:
            raise FrictionIdError("--scheduler needs dask.distributed (pip install distributed)") from None
        try:
            self.client = Client(self.scheduler, timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise FrictionIdError(f"cannot reach the Dask scheduler at {self.scheduler} ({exc})") from None
        try:
            self.client.wait_for_workers(1, timeout=WORKER_WAIT_S)
        except (OSError, TimeoutError):
            self.client.close()
            raise FrictionIdError(f"no Dask worker joined the scheduler at {self.scheduler} within "
                                  f"{WORKER_WAIT_S:g} s") from None
        return self

    def __exit__(self, *exc) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None

    @property
    def workers(self) -> int:
        """Worker threads of the cluster now."""
        return max(1, sum(w.get("nthreads", 1) for w in self.client.scheduler_info()["workers"].values()))

    def sees(self, path: str) -> bool:
        """True when every worker can read ``path``."""
        return all(self.client.run(os.path.exists, path).values())

    def run(self, fn: Callable[[object], dict], tasks: Iterable[Task], on_record: OnRecord, attempts: int = 2,
            prepare: Prepare | None = None) -> None:
        """Run every task (module doc), calling ``on_record`` with each attempt's record as it ends;
        ``prepare(payload)`` (e.g. attaching a file's bytes) is applied as each is submitted."""
        from distributed import as_completed

        todo = _Attempts(tasks, attempts, on_record)
        prepare = prepare or _same
        running = as_completed()
        items: dict = {}

        def fill() -> None:
            while running.count() < IN_FLIGHT_PER_WORKER * self.workers and (item := todo.take()) is not None:
                future = self.client.submit(guarded, fn, prepare(item[1]), self.setup, os.getpid(), pure=False)
                items[future.key] = item
                running.add(future)

        try:
            fill()
            for future in running:
                key, payload, attempt = items.pop(future.key)
                try:
                    outcome = future.result()
                except Exception as exc:  # KilledWorker (its workers kept dying), a lost task
                    outcome = failed(f"the Dask cluster could not run it: {type(exc).__name__}: {exc}")
                future.release()
                todo.done(key, payload, attempt, outcome)
                fill()
        except (OSError, TimeoutError) as exc:
            raise FrictionIdError(f"lost the Dask scheduler at {self.scheduler} ({type(exc).__name__}: {exc}); "
                                  "run the same command again to resume") from None


def open_backend(workers: int | None = None, scheduler: str | None = None, setup: Callable[[], None] | None = None,
                 memory_mb: float | None = None) -> LocalBackend | DaskBackend:
    """A Dask backend at ``scheduler``, else a local pool of ``workers`` processes (default: the usable
    CPUs), each capped at ``memory_mb`` (default: 80 % of the memory available now, shared out)."""
    if scheduler:
        return DaskBackend(scheduler, setup)
    from frictionid_core.parallel import usable_cpus

    if workers is not None and workers < 1:
        raise FrictionIdError(f"--workers must be at least 1, got {workers}")
    workers = workers or max(1, int(usable_cpus()))
    return LocalBackend(workers, setup, memory_mb if memory_mb is not None else default_memory_mb(workers))


def default_memory_mb(workers: int) -> float | None:
    """80 % of the memory available now, shared by ``workers`` (at least 1 GB each); None if unknown."""
    try:
        with open("/proc/meminfo") as fh:
            info = dict(line.split(":", 1) for line in fh)
        available_kb = float(info["MemAvailable"].split()[0])
    except (OSError, KeyError, ValueError):
        return None
    return max(1024.0, 0.8 * available_kb / 1024.0 / workers)
