"""The joint states of an experiment written to a rosbag2 folder in MCAP, as they arrive (no ROS import).

:class:`BagRecorder` takes each message already serialized (the CDR bytes rclpy gives, which rosbag2
stores as they are): :meth:`put` only appends to a queue, from the node's input thread (its
feed-forward path must not wait for a disk), and :meth:`flush`, called by the experiment's own thread,
writes what is queued (rosbags' MCAP writer, zstd chunks). The bag reads back with
``frictionid identify BAG`` like any other.
"""

from __future__ import annotations

import collections
import threading
from pathlib import Path

from frictionid_core import FrictionIdError

JOINT_STATE = "sensor_msgs/msg/JointState"


class BagRecorder:
    """A new rosbag2 folder ``path`` (MCAP) with one JointState topic ``topic``."""

    def __init__(self, path: Path, topic: str):
        from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        self.path = Path(path)
        if self.path.exists():
            raise FrictionIdError(f"{self.path}: already exists; refusing to overwrite a bag")
        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        self._writer.open()
        self._conn = self._writer.add_connection(topic, JOINT_STATE, typestore=get_typestore(Stores.LATEST))
        self._queue: collections.deque = collections.deque()
        self._lock = threading.Lock()  # flush and close
        self.count = 0
        self.closed = False

    def put(self, stamp_ns: int, data: bytes) -> None:
        """Queue one serialized message stamped ``stamp_ns`` (any thread; never blocks on I/O)."""
        if not self.closed:
            self._queue.append((int(stamp_ns), data))

    def flush(self) -> int:
        """Write what is queued; returns the messages written so far."""
        with self._lock:
            if self.closed:
                return self.count
            q = self._queue
            while q:
                stamp, data = q.popleft()
                self._writer.write(self._conn, stamp, data)
                self.count += 1
            return self.count

    def close(self) -> Path:
        """Write what is queued and close the bag; returns its folder."""
        self.flush()
        with self._lock:
            if not self.closed:
                self.closed = True
                self._writer.close()
        return self.path
