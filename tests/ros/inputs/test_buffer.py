"""The input buffers: name mapping and the joint ring (order, chunked lock-free snapshots)."""

from __future__ import annotations

import array
import threading
import time

import numpy as np
import pytest

from frictionid_ros.inputs import buffer
from frictionid_ros.inputs.buffer import JointRing, NameMap, put


def test_name_map_reorders_and_caches():
    m = NameMap(["a", "b"])
    assert m.index(["a", "b"]) is None  # identity: copied as is
    idx = m.index(["x", "b", "a"])
    assert list(idx) == [2, 1]
    assert m.index(["x", "b", "a"]) is idx  # cached
    with pytest.raises(KeyError, match=r"lacks joint\(s\) \['b'\]"):
        m.index(["a"])
    with pytest.raises(KeyError, match=r"names joint\(s\) \['b'\] more than once \(it has \['b', 'a', 'b'\]\)"):
        m.index(["b", "a", "b"])
    row = np.empty(2)
    assert put(row, array.array("d", [9.0, 2.0, 1.0]), idx, 3) and list(row) == [1.0, 2.0]
    assert not put(row, array.array("d"), idx, 3) and np.isnan(row).all()  # empty field


def test_ring_keeps_the_newest_rows_in_order():
    r = JointRing(["a"], capacity=4)
    for k in range(6):
        i = r.begin()
        r.t_ns[i], r.position[i] = k, k
        r.commit()
    w = r.snapshot()
    assert list(w.t_ns) == [2, 3, 4, 5] and list(w.position[:, 0]) == [2, 3, 4, 5]
    assert r.total == 6 and r.count == 4
    r.clear()
    assert len(r.snapshot()) == 0


@pytest.mark.parametrize("head", [0, 1, 5, 9])
def test_ring_snapshot_copies_in_chunks_across_the_wrap(monkeypatch, head):
    monkeypatch.setattr(buffer, "SNAPSHOT_CHUNK_ROWS", 3)  # chunks that straddle the end of the ring
    r = JointRing(["a", "b"], capacity=10)
    for k in range(10 + head):
        i = r.begin()
        r.t_ns[i], r.rx_ns[i], r.position[i], r.velocity[i], r.effort[i], r.flags[i] = k, -k, k, 2 * k, 3 * k, k % 3
        r.commit()
    w = r.snapshot()
    expect = np.arange(head, 10 + head)
    assert list(w.t_ns) == list(expect) and list(w.rx_ns) == list(-expect) and list(w.flags) == list(expect % 3)
    assert (w.position == expect[:, None]).all() and (w.effort == 3 * expect[:, None]).all()


def test_ring_snapshot_never_blocks_the_writer_and_drops_overwritten_rows(monkeypatch):
    """A writer thread appends as fast as it can while snapshots are copied: every row of every
    snapshot is one whole sample, in order; rows the writer reached during a copy are left out,
    which can only happen because the writer got the lock while the copy ran (snapshots are taken
    until that is seen: when the writer thread runs meanwhile is up to the scheduler)."""
    monkeypatch.setattr(buffer, "SNAPSHOT_CHUNK_ROWS", 64)
    r = JointRing(["a", "b", "c"], capacity=5000)
    stop = threading.Event()

    def writer():
        k = 0
        while not stop.is_set():
            with r.lock:
                i = r.begin()
                r.t_ns[i], r.position[i], r.effort[i] = k, k, -k
                r.commit()
            k += 1

    thread = threading.Thread(target=writer, daemon=True)
    thread.start()
    try:
        while r.count < r.capacity:
            time.sleep(0.001)
        snapshots, short = 0, 0
        deadline = time.monotonic() + 60
        while snapshots < 200 or (short == 0 and time.monotonic() < deadline):
            w = r.snapshot()
            assert (w.position == w.t_ns[:, None]).all() and (w.effort == -w.t_ns[:, None]).all()
            assert (np.diff(w.t_ns) == 1).all()
            snapshots, short = snapshots + 1, short + (len(w) < r.capacity)
    finally:
        stop.set()
        thread.join()
    assert short > 0, f"the writer never wrote during a copy in {snapshots} snapshots"
