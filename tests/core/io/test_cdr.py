"""Vectorised JointState decode (io/cdr.py) equals rosbags' message-by-message reading bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.io import bag as bagio
from frictionid_core.io import load
from frictionid_core.io.cdr import decode_joint_states
from support.data import BAGS, JOINT_STATE, T0_NS

BUNDLED = sorted(p for p in BAGS.iterdir() if p.is_dir())


def _both_ways(path, topic):
    """(vectorised, message-by-message) readings of one topic: (stamps, joints, arrays, short)."""
    reader = bagio.open_reader(path)
    try:
        conns = [c for c in reader.connections if c.topic == topic]
        items = [(c.msgtype, ns, raw) for c, ns, raw in reader.messages(connections=conns)]
        raws, bag_ns = [r for _, _, r in items], np.array([ns for _, ns, _ in items], dtype=np.int64)
        decoded = decode_joint_states(raws)
        slow = bagio._deserialize_joint_states(reader, path, topic, raws, [m for m, _, _ in items], bag_ns)
    finally:
        reader.close()
    return (None if decoded is None else bagio._decoded_joint_states(path, topic, decoded, bag_ns)), slow


def _assert_identical(fast, slow):
    np.testing.assert_array_equal(fast[0], slow[0])
    assert fast[1] == slow[1] and fast[3] == slow[3]
    for a, b in zip(fast[2], slow[2]):
        assert a.shape == b.shape
        # bit for bit (NaN rows of empty fields included)
        np.testing.assert_array_equal(a.view(np.int64), b.view(np.int64))


@pytest.mark.parametrize("path", BUNDLED, ids=[p.name for p in BUNDLED])
def test_bundled_bags_decode_at_once_and_exactly(path):
    topics = [t for t, m in bagio.list_topics(path).items() if m == JOINT_STATE]
    assert topics
    for topic in topics:
        fast, slow = _both_ways(path, topic)
        assert fast is not None, f"{path.name}:{topic} should share one layout"
        _assert_identical(fast, slow)


def _write(path, msgs, storage="mcap"):
    """A rosbag2 of JointStates given as (frame_id, names, position, velocity, effort)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = bagio._typestore()
    names = (JOINT_STATE, "std_msgs/msg/Header", "builtin_interfaces/msg/Time")
    JointState, Header, Time = (ts.types[n] for n in names)
    plugin = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}[storage]
    with Writer(path, version=9, storage_plugin=plugin) as w:
        conn = w.add_connection("/joint_states", JOINT_STATE, typestore=ts)
        for k, (frame, names, p, v, e) in enumerate(msgs):
            ns = T0_NS + k * 1_000_000
            arr = [np.asarray(a, dtype=np.float64) for a in (p, v, e)]
            msg = JointState(header=Header(stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=frame),
                             name=names, position=arr[0], velocity=arr[1], effort=arr[2])
            w.write(conn, ns, ts.serialize_cdr(msg, JOINT_STATE))
    return path


def test_varying_layouts_fall_back_and_read_the_same(tmp_path):
    rng = np.random.default_rng(3)
    rows = rng.standard_normal((8, 3, 2))
    ab, ba = ["a", "b"], ["b", "a"]
    msgs = [("base", ab, *rows[0]), ("base", ab, *rows[1]),
            ("world", ab, *rows[2]),  # another frame_id length
            ("base", ba, *rows[3]),  # names reordered
            ("base", ab, rows[4, 0], [], rows[4, 2]),  # velocity empty
            ("base", ab, *rows[5]), ("base", ab, *rows[6]), ("base", ab, *rows[7])]
    path = _write(tmp_path / "mixed", msgs)
    fast, slow = _both_ways(path, "/joint_states")
    assert fast is None  # not one layout: message by message
    series = load(path)
    pos = rows[:, 0].copy()
    pos[3] = pos[3, ::-1]  # message 3 lists b first
    np.testing.assert_array_equal(series.position, pos)
    assert series.velocity is None  # one message without velocity
    # the same messages, one layout each, decode at once and exactly
    for storage in ("mcap", "sqlite3"):
        same = [("base", ab, *rows[k]) for k in range(8)]
        fast, slow = _both_ways(_write(tmp_path / f"same_{storage}", same, storage), "/joint_states")
        assert fast is not None
        _assert_identical(fast, slow)
        np.testing.assert_array_equal(fast[2][1], rows[:, 1])


def test_decode_refuses_what_it_does_not_understand():
    assert decode_joint_states([]) is None
    assert decode_joint_states([b"\x00\x01\x00\x00" + b"\xff" * 20]) is None  # counts past the end
    assert decode_joint_states([b"\x00\x03\x00\x00" + b"\x00" * 40]) is None  # not CDR


def test_bag_without_type_definitions_reads_with_the_builtin_types(tmp_path):
    """A rosbag2 that stores no message definitions (as Humble and older write) is read with the
    built-in ROS 2 types, loaded for it only; the same samples as with its definitions."""
    import sqlite3

    rng = np.random.default_rng(5)
    rows = rng.standard_normal((20, 3, 2))
    path = _write(tmp_path / "old", [("base", ["a", "b"], *r) for r in rows], storage="sqlite3")
    with_definitions = load(path)
    (db,) = path.glob("*.db3")
    with sqlite3.connect(db) as con:
        assert con.execute("DELETE FROM message_definitions").rowcount == 1
    from rosbags.highlevel import AnyReader, AnyReaderError

    with pytest.raises(AnyReaderError, match="no type definitions"), AnyReader([path]):
        pass  # the bag really has none
    without = load(path)
    np.testing.assert_array_equal(without.position, rows[:, 0])
    for field in ("t", "position", "velocity", "effort"):
        np.testing.assert_array_equal(getattr(without, field), getattr(with_definitions, field))
