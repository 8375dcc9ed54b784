"""Vectorised CDR decode of many sensor_msgs/JointState messages that share one byte layout.

A ROS 2 JointState in CDR (XCDR1, as rosbags writes and reads it) is: a 4-byte encapsulation
header (byte 1: 1 little-endian, 0 big-endian); header.stamp sec (int32) and nanosec (uint32);
frame_id (uint32 length incl. NUL, bytes); name (uint32 count, then per name: align 4, uint32
length, bytes); then position, velocity and effort (align 4, uint32 count, then
when not empty align 8 and float64s).
Alignment counts from the end of the encapsulation header.

When every message has the same length and the same bytes everywhere but the stamp and the
float64 payloads (same frame_id, names, array lengths and padding), the stamps and arrays are
strided views of the joined bytes: one numpy pass instead of one deserialisation per message.
"""

from __future__ import annotations

import numpy as np

_HEADER = 4  # encapsulation header bytes; alignment is relative to its end
_FIELDS = ("position", "velocity", "effort")


def _align(pos: int, n: int) -> int:
    return _HEADER + ((pos - _HEADER + n - 1) // n) * n


def _layout(raw: bytes) -> tuple[str, str, list[str], dict[str, tuple[int, int]], int] | None:
    """(byte order, frame_id, names, {field: (data offset, count)}, end) of one message, or
    None when ``raw`` is not a JointState this parser understands."""
    if len(raw) < 16 or raw[0] != 0 or raw[1] not in (0, 1):
        return None
    bo = "<" if raw[1] == 1 else ">"
    u32 = np.dtype(bo + "u4")

    def count(pos: int) -> int:
        if pos + 4 > len(raw):
            raise ValueError
        return int(np.frombuffer(raw, u32, 1, pos)[0])

    try:
        pos = 12
        n = count(pos)
        if pos + 4 + n > len(raw):
            return None
        frame_id = raw[pos + 4: pos + 3 + n].decode() if n else ""
        pos += 4 + n
        names = []
        pos = _align(pos, 4)
        n_names = count(pos)
        pos += 4
        if 5 * n_names > len(raw) - pos:
            return None
        for _ in range(n_names):
            pos = _align(pos, 4)
            n = count(pos)
            if n == 0 or pos + 4 + n > len(raw):
                return None
            names.append(raw[pos + 4: pos + 3 + n].decode())
            pos += 4 + n
        arrays = {}
        for field in _FIELDS:
            pos = _align(pos, 4)
            n = count(pos)
            pos = _align(pos + 4, 8) if n else pos + 4
            arrays[field] = (pos, n)
            pos += 8 * n
    except (ValueError, UnicodeDecodeError):
        return None
    if pos > len(raw):
        return None
    return bo, frame_id, names, arrays, pos


def decode_joint_states(raws: list[bytes]) -> dict | None:
    """Stamps and arrays of the CDR JointState messages ``raws`` when they share one layout.

    Returns {"sec": (N,) int64, "nanosec": (N,) int64, "frame_id": str, "names": [str],
    "position"/"velocity"/"effort": (N, n) float64} (n the field's length, 0 when empty), or
    None when the messages differ in layout (frame_id, names, array lengths or padding) or are
    not JointStates this decoder understands: the caller then deserialises one by one.
    """
    if not raws:
        return None
    first = raws[0]
    layout = _layout(first)
    if layout is None:
        return None
    bo, frame_id, names, arrays, end = layout
    size = len(first)
    if end != size or any(len(r) != size for r in raws):
        return None
    buf = np.frombuffer(b"".join(raws), dtype=np.uint8).reshape(len(raws), size)
    # every byte outside the stamp and the float64 payloads must equal the first message's
    fixed = np.ones(size, dtype=bool)
    fixed[4:12] = False
    for offset, n in arrays.values():
        fixed[offset: offset + 8 * n] = False
    cols = np.flatnonzero(fixed)
    if not np.array_equal(buf[:, cols], np.broadcast_to(buf[0, cols], (len(raws), cols.size))):
        return None
    out = {"frame_id": frame_id, "names": names,
           "sec": buf[:, 4:8].copy().view(bo + "i4")[:, 0].astype(np.int64),
           "nanosec": buf[:, 8:12].copy().view(bo + "u4")[:, 0].astype(np.int64)}
    for field, (offset, n) in arrays.items():
        out[field] = buf[:, offset: offset + 8 * n].copy().view(bo + "f8").astype(np.float64, copy=False)
    return out
