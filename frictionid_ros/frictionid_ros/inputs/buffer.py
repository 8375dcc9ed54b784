"""Bounded, preallocated ring buffers of joint samples (no ROS import).

Stamps are ns since the epoch (int64). One writer (the subscription callback) appends rows in
place under a short lock; a reader copies the rows without holding it (:meth:`JointRing.snapshot`),
so the writer, which is the feed-forward's path, never waits for a copy however long the buffer
(the copy of 60 000 rows under the lock took 10 ms). Nothing is allocated per message except what
numpy needs for a fancy-index take into a preallocated row.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, fields

import numpy as np

from frictionid_ros.joint_names import repeated_names, shown_names

NS = 1_000_000_000  # ns per second

# Row flags: which fields of a message were missing (empty or shorter than ``name``).
NO_POSITION = 1
NO_VELOCITY = 2
NO_EFFORT = 4
SNAPSHOT_CHUNK_ROWS = 8192  # rows a snapshot copies per numpy call (~0.1 ms): the GIL can change hands between them


def stamp_ns(stamp) -> int:
    """A builtin_interfaces/Time (``sec``, ``nanosec``) as ns since the epoch."""
    return stamp.sec * NS + stamp.nanosec


class NameMap:
    """Column order of incoming messages → buffer columns, cached per name list.

    :meth:`index` returns None when the message's names are exactly ``joints`` (copy as is),
    an index array into the message otherwise, or raises KeyError naming missing or repeated joints.
    """

    def __init__(self, joints: list[str]):
        self.joints = list(joints)
        self._last_names: list[str] | None = None
        self._last_index: np.ndarray | None = None
        self._cache: dict[tuple[str, ...], np.ndarray | None] = {}

    def index(self, names: list[str]) -> np.ndarray | None:
        if names == self._last_names:  # fast path: same names as the previous message
            return self._last_index
        key = tuple(names)
        if key in self._cache:
            idx = self._cache[key]
        else:
            pos = {n: i for i, n in enumerate(key)}
            missing = [j for j in self.joints if j not in pos]
            if missing:
                raise KeyError(f"message lacks joint(s) {shown_names(missing)} (it has {shown_names(key)})")
            problem = repeated_names(key)
            if problem:
                raise KeyError(problem)
            idx = None if list(key) == self.joints else np.array([pos[j] for j in self.joints], dtype=np.intp)
            if len(self._cache) > 64:  # pathological publishers: keep the cache bounded
                self._cache.clear()
            self._cache[key] = idx
        self._last_names, self._last_index = list(names), idx
        return idx


def long_fields(msg, n_names: int, fields=("position", "velocity", "effort")) -> str:
    """Why a message whose ``fields`` hold more values than its ``n_names`` names is refused; ""
    when none does."""
    for field in fields:
        size = len(getattr(msg, field))
        if size > n_names:
            return f"field '{field}' has {size} values for {n_names} names"
    return ""


def put(row: np.ndarray, src, idx: np.ndarray | None, n_names: int) -> bool:
    """Copy ``src`` (a message's array.array field) into ``row`` through ``idx``.

    Returns False (row set to NaN) when the field is shorter than the names.
    """
    if len(src) < n_names:
        row.fill(np.nan)
        return False
    a = np.frombuffer(src, dtype=np.float64) if len(src) else np.empty(0)
    if idx is None:
        row[:] = a[: row.shape[0]]
    else:
        np.take(a, idx, out=row)
    return True


@dataclass
class Window:
    """Copies of buffered rows, oldest first: stamps and receipt times [ns] (N,), fields (N, J), flags (N,)."""

    t_ns: np.ndarray
    rx_ns: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray
    flags: np.ndarray

    def __len__(self) -> int:
        return len(self.t_ns)

    def take(self, keep: np.ndarray) -> Window:
        return Window(*(a[keep] for a in _columns(self)))


def _columns(rows: Window | JointRing) -> tuple[np.ndarray, ...]:
    """The arrays of a window or a ring, in the order of :class:`Window`'s fields."""
    return tuple(getattr(rows, f.name) for f in fields(Window))


class JointRing:
    """Ring buffer of ``capacity`` joint samples of J joints.

    Arrays: ``t_ns`` header stamps and ``rx_ns`` middleware receipt times [ns since the epoch]
    (int64), ``position`` [rad | m],
    ``velocity`` [rad/s | m/s], ``effort`` [N·m | N], each (capacity, J) float64, ``flags``
    (:data:`NO_POSITION` | :data:`NO_VELOCITY` | :data:`NO_EFFORT`).
    """

    def __init__(self, joints: list[str], capacity: int):
        if capacity < 2:
            raise ValueError("ring capacity must be >= 2")
        self.joints = list(joints)
        self.capacity = int(capacity)
        nj = len(self.joints)
        self.t_ns = np.zeros(self.capacity, dtype=np.int64)
        self.rx_ns = np.zeros(self.capacity, dtype=np.int64)
        self.position = np.full((self.capacity, nj), np.nan)
        self.velocity = np.full((self.capacity, nj), np.nan)
        self.effort = np.full((self.capacity, nj), np.nan)
        self.flags = np.zeros(self.capacity, dtype=np.uint8)
        self.lock = threading.Lock()
        self.head = 0        # next row to write
        self.count = 0       # valid rows
        self.total = 0       # rows ever written (since start, survives clear())
        self.clears = 0      # clear() calls so far

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in _columns(self))

    def begin(self) -> int:
        """Row index to fill next; call :meth:`commit` when it is written (under :attr:`lock`)."""
        return self.head

    def commit(self) -> None:
        self.head = (self.head + 1) % self.capacity
        if self.count < self.capacity:
            self.count += 1
        self.total += 1

    def last_row(self, back: int = 0) -> int | None:
        """Index of the newest row (``back`` = 1: the one before), or None."""
        if back >= self.count:
            return None
        return (self.head - 1 - back) % self.capacity

    def clear(self) -> None:
        with self.lock:
            self.head = 0
            self.count = 0
            self.clears += 1

    def snapshot(self) -> Window:
        """Copy of every valid row, oldest first, taken without holding :attr:`lock` while copying:
        the writer goes on meanwhile, and the oldest rows it overwrote during the copy are left out
        (a few rows of a long window; a :meth:`clear` during the copy gives an empty window)."""
        arrays = _columns(self)
        with self.lock:
            n, h, total, clears = self.count, self.head, self.total, self.clears
        out = [np.empty((n, *a.shape[1:]), a.dtype) for a in arrays]
        first = (h - n) % self.capacity  # the oldest valid row
        for lo in range(0, n, SNAPSHOT_CHUNK_ROWS):
            hi = min(n, lo + SNAPSHOT_CHUNK_ROWS)
            a = (first + lo) % self.capacity
            cut = lo + min(hi - lo, self.capacity - a)  # rows lo..cut-1 come before the ring's end, cut..hi-1 after
            for src, dst in zip(arrays, out):
                dst[lo:cut] = src[a:a + cut - lo]
                dst[cut:hi] = src[:hi - cut]
        with self.lock:
            written, cleared = self.total - total, self.clears != clears
        # The writer fills row h, h+1, ... (the oldest rows once the ring is full): rows of the copy
        # it reached meanwhile may mix two samples, so they are dropped.
        lost = n if cleared else min(n, max(0, n + written - self.capacity))
        return Window(*(a[lost:] for a in out))
