"""Thread choice of the compiled kernels (frictionid_core.parallel): behaviour, not timing.

The pure rule is checked on given CPU counts and loads; the live reading with real CPU-bound
competitor processes; the pool on real work (a chunk error reaches the caller, every chunk runs
once); the EMPS simulator bit-identical for any thread count (the dip sums: test_identify_optim).
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from frictionid_core import parallel
from frictionid_core.parallel import choose_threads, fixed_threads, run_chunks, split, threads_for
from support.data import EMPS_ESTIMATION
from support.waiting import wait_until


@pytest.mark.parametrize("n_items, min_items, cpus, busy, expected", [
    (1000, 10, 2, 0, 2),     # idle 2-core machine, plenty of work: both cores
    (1000, 10, 2, 1, 1),     # one CPU-bound competitor: one thread, never a stalled fork/join
    (1000, 10, 2, 2, 1),     # two competitors: still one (never 0)
    (1000, 10, 8, 3, 5),     # the CPUs left by the busy tasks
    (15, 10, 8, 0, 1),       # too little work for a second thread
    (40, 10, 8, 0, 4),       # one thread per min_items
    (1000, 10, 1.5, 0, 1),   # a cgroup quota of 1.5 CPUs does not make 2 threads
    (1000, 10, 2, -3, 2),    # a negative reading (races in /proc) counts as idle, capped by the CPUs
    (0, 10, 2, 0, 1),
])
def test_thread_rule(n_items, min_items, cpus, busy, expected):
    assert choose_threads(n_items, min_items, cpus, busy) == expected


def test_split_covers_every_item_once_in_order():
    for n, parts in ((10, 3), (7, 7), (3, 5), (100, 1), (0, 2)):
        chunks = split(n, parts)
        assert [i for lo, hi in chunks for i in range(lo, hi)] == list(range(n))
        assert max((hi - lo for lo, hi in chunks), default=0) - min((hi - lo for lo, hi in chunks), default=0) <= 1


def test_small_work_and_the_cap_stay_on_one_thread(monkeypatch):
    assert threads_for(5, 8) == 1  # below two chunks: no load reading, no fork/join
    monkeypatch.setenv("FRICTIONID_THREADS", "1")
    assert threads_for(10**6, 1) == 1
    with fixed_threads(3):
        assert threads_for(10**6, 1) == 3 and threads_for(2, 1) == 2


def test_competing_processes_take_the_second_thread_away():
    """As many CPU-bound competitors as this process has CPUs: every kernel runs on one thread
    (other load on the machine can only lower the count further, so this cannot flake)."""
    n = int(parallel.usable_cpus())
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]
    try:
        wait_until(lambda: parallel.busy_cpus() >= n, f"{n} runnable competitors")  # started
        assert threads_for(10**6, 1) == 1
    finally:
        for p in spinners:
            p.kill()
            p.wait()


def test_this_process_own_runnable_threads_are_counted_as_its_own():
    """A thread of this process running without the GIL (as a BLAS pool spinning after its call)
    is in the run queue: it is one of this process's runnable threads, which busy_cpus takes off
    the machine's count (it counted as a competitor and kept large kernels on one thread)."""
    import hashlib

    stop, data = threading.Event(), bytes(1 << 22)

    def spin():
        while not stop.is_set():
            hashlib.sha256(data).digest()  # releases the GIL on large buffers

    thread = threading.Thread(target=spin)
    thread.start()
    try:
        # the caller and the spinning thread (while it hashes: between two hashes it waits for the GIL)
        wait_until(lambda: parallel._own_running() >= 2, "two runnable threads of this process", period=0.0)
    finally:
        stop.set()
        thread.join()


def test_a_parallel_call_that_did_not_pay_keeps_the_next_ones_on_one_thread(monkeypatch):
    """The load snapshot can miss a competitor; the call itself shows it: a helper thread that
    finished long after the caller (here: its chunk sleeps 0.2 s, the caller's takes nothing)
    makes the kernels use one thread for BACKOFF_S, then the snapshot decides again."""
    monkeypatch.setattr(parallel, "_backoff_until", 0.0)
    monkeypatch.setattr(parallel, "busy_cpus", lambda: 0)
    monkeypatch.setattr(parallel, "usable_cpus", lambda: 2.0)
    assert threads_for(10**6, 1) == 2
    caller = threading.get_ident()
    slow_helper = lambda lo, hi: None if threading.get_ident() == caller else time.sleep(0.2)
    with fixed_threads(2):
        run_chunks(slow_helper, 2)
    assert threads_for(10**6, 1) == 1
    monkeypatch.setattr(parallel, "_backoff_until", time.monotonic() - 1.0)  # BACKOFF_S later
    assert threads_for(10**6, 1) == 2


def chunks_run(n_items: int, threads: int) -> list[tuple[int, int]]:
    """The (lo, hi) chunks run_chunks gives out for ``n_items`` on ``threads`` threads, sorted."""
    seen: list[tuple[int, int]] = []
    lock = threading.Lock()

    def record(lo: int, hi: int) -> None:
        with lock:
            seen.append((lo, hi))

    with fixed_threads(threads):
        assert run_chunks(record, n_items) == threads
    return sorted(seen)


def test_pool_runs_every_chunk_once_and_reports_errors():
    assert chunks_run(10, 3) == [(0, 3), (3, 6), (6, 10)]

    def fail(lo: int, hi: int) -> None:
        if lo:
            raise ValueError(f"chunk {lo}")

    with fixed_threads(2), pytest.raises(ValueError, match="chunk 5"):
        run_chunks(fail, 10)
    assert chunks_run(4, 2) == [(0, 2), (2, 4)]  # the pool still works after a failed job


def test_simulated_population_does_not_depend_on_the_thread_count():
    from frictionid_core.emps import EmpsSimulator

    sim = EmpsSimulator(EMPS_ESTIMATION, "tustin", True)
    lo = np.array([90.0, 150.0, 15.0, 20.0, 0.01, 220.0, 15.0, 20.0, 0.01])
    pop = lo * (1.0 + 0.1 * np.random.default_rng(2).random((24, lo.size)))
    with fixed_threads(1):
        one = sim.position(pop)
    for n in (2, 3):
        with fixed_threads(n):
            np.testing.assert_array_equal(sim.position(pop), one)


def test_single_threaded_libraries_limits_blas_inside_the_block_only():
    from threadpoolctl import threadpool_info

    blas = lambda: [d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"]
    before = blas()
    with parallel.single_threaded_libraries():
        assert set(blas()) == {1}
    assert blas() == before


def test_a_forked_child_gets_a_pool_of_its_own():
    """Worker threads do not survive fork: the child starts its own (a study's process pool)."""
    import multiprocessing

    with fixed_threads(2):
        run_chunks(lambda lo, hi: None, 4)  # the parent's worker exists
        ctx = multiprocessing.get_context("fork")
        with ctx.Pool(1) as pool:
            assert pool.apply(chunks_run, (4, 2)) == [(0, 2), (2, 4)]
