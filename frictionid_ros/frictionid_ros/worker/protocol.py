"""The messages between the node and its identification worker's child, on the child's stdin and
stdout (no ROS import).

Both ways: the pickle's length and its number of out-of-band buffers (8-byte little-endian each),
the pickle (protocol 5), then each buffer as its length and bytes.
Node → child: ``("job", id, series, request, gate)`` (an IdentifyRequest or a task with a ``run``
method; a :class:`~frictionid_ros.worker.job.Gate` or None), ``("cancel", id)``.
Child → node: ``("ready", pid)`` once, then per job any number of
``("progress", generation, evaluations, best_cost)`` (at most every
:data:`~frictionid_ros.worker.child.PROGRESS_PERIOD_S`) and one reply:
``("ok", (IdentifyResult, the gate's Decision or None))``, ``("error", message)`` for a
FrictionIdError, ``("cancelled", message)`` or ``("crash", message)`` for anything else
(:func:`~frictionid_ros.worker.job.run_identification`).
"""

from __future__ import annotations

import pickle
import struct

_LENGTH = struct.Struct("<Q")  # an out-of-band buffer's length
_FRAME = struct.Struct("<QQ")  # a message's pickle length and number of out-of-band buffers


def send_message(stream, obj) -> None:
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


def receive_message(stream):
    """The next message of ``stream``; EOFError when the pipe is closed."""
    n, count = _FRAME.unpack(_read_exactly(stream, _FRAME.size))
    data = _read_exactly(stream, n)
    buffers = []
    for _ in range(count):  # writable, so that the arrays made on them are too
        buf = bytearray(_LENGTH.unpack(_read_exactly(stream, _LENGTH.size))[0])
        if stream.readinto(buf) < len(buf):
            raise EOFError("worker pipe closed")
        buffers.append(buf)
    return pickle.loads(data, buffers=buffers)
