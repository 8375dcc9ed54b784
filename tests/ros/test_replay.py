"""``frictionid replay``: bag reading (MCAP, sqlite3, ROS 1), re-stamping, and the CLI plugin.

Publishing with real rclpy across processes is covered in node/test_node.py (the node is fed by
:func:`frictionid_ros.replay.publish_stream`) and here by the CLI round trip.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

from frictionid_core.io import load, write_joint_state_bag
from frictionid_ros import replay
from support.ros_harness import close_spinning, private_domain
from support.waiting import wait_until

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

ROOT = Path(__file__).resolve().parents[2]
BAG = ROOT / "bags" / "emps_estimation"
NS = 1_000_000_000


def _decode(stream, i):
    return deserialize_message(stream.payloads[i], JointState if stream.types[stream.topic_index[i]].endswith(
        "JointState") else Float64MultiArray)


def test_mcap_stream_matches_the_core_loader():
    s = replay.load_stream(BAG, duration=0.5)
    ref = load(BAG)
    assert len(s) == 500 and s.topics == ["/joint_states"]
    for i in (0, 1, 499):
        m = _decode(s, i)
        assert list(m.name) == ref.joints
        assert m.position[0] == ref.position[i, 0] and m.effort[0] == ref.effort[i, 0]
    assert (s.stamp_ns[499] - s.stamp_ns[0]) * 1e-9 == pytest.approx(ref.t[499])


def test_restamp_keeps_everything_but_the_stamp():
    s = replay.load_stream(BAG, duration=0.01)
    raw = s.payloads[3]
    new = replay.restamp(raw, 1_800_000_000 * NS + 123)
    a, b = deserialize_message(raw, JointState), deserialize_message(new, JointState)
    assert (b.header.stamp.sec, b.header.stamp.nanosec) == (1_800_000_000, 123)
    assert replay.read_stamp(new) == 1_800_000_000 * NS + 123
    assert list(a.position) == list(b.position) and list(a.effort) == list(b.effort) and a.name == b.name


@pytest.fixture(scope="module")
def small_series():
    return load(BAG).slice(0, 200)


def test_sqlite3_and_effort_topic(tmp_path, small_series):
    path = write_joint_state_bag(tmp_path / "b", small_series, storage="sqlite3",
                                 extra_topics={"/effort": ("effort", small_series.effort * 2.0)})
    s = replay.load_stream(path, effort_topic="/effort", publish_topic="/js", publish_effort_topic="/eff")
    assert s.topics == ["/js", "/eff"] and len(s) == 400
    eff = [_decode(s, i) for i in range(len(s)) if s.topic_index[i] == 1]
    assert eff[7].effort[0] == pytest.approx(small_series.effort[7, 0] * 2.0)
    js = [_decode(s, i) for i in range(len(s)) if s.topic_index[i] == 0]
    assert js[7].position[0] == small_series.position[7, 0]


def test_ros1_bag(tmp_path, small_series):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC)
    JS, Header, Time = (ts.types[n] for n in ("sensor_msgs/msg/JointState", "std_msgs/msg/Header",
                                              "builtin_interfaces/msg/Time"))
    path = tmp_path / "b.bag"
    t0 = 1_700_000_000 * NS
    with Writer(path) as w:
        conn = w.add_connection("/joint_states", JS.__msgtype__, typestore=ts)
        for k in range(len(small_series)):
            ns = t0 + int(round(small_series.t[k] * 1e9))
            msg = JS(header=Header(seq=k, stamp=Time(sec=ns // NS, nanosec=ns % NS), frame_id=""),
                     name=["emps"], position=small_series.position[k], velocity=np.empty(0),
                     effort=small_series.effort[k])
            w.write(conn, ns, ts.serialize_ros1(msg, JS.__msgtype__))
    s = replay.load_stream(path)
    assert len(s) == len(small_series)
    m = _decode(s, 42)
    assert m.position[0] == small_series.position[42, 0] and m.effort[0] == small_series.effort[42, 0]
    assert s.stamp_ns[42] - s.stamp_ns[0] == int(round(small_series.t[42] * 1e9))


def test_bad_bag_and_topic_are_clear_errors(tmp_path):
    from frictionid_core.errors import InputError

    with pytest.raises(InputError, match="no such file"):
        replay.load_stream(tmp_path / "none.mcap")
    with pytest.raises(InputError, match="'/nope' not in the bag"):
        replay.load_stream(BAG, topic="/nope")


def test_register_adds_the_replay_parser():
    parser = argparse.ArgumentParser()
    handler = replay.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["replay", "B", "--rate", "0", "--loop"])
    assert callable(handler) and args.bag == "B" and args.rate == 0.0 and args.loop == 0
    assert parser.parse_args(["replay", "B"]).loop == 1


@pytest.mark.ros
@pytest.mark.slow
def test_cli_replay_publishes_to_another_process():
    """`frictionid replay` (core CLI, plugin from the entry point) → a subscriber in this process."""
    from importlib.metadata import entry_points

    assert any(ep.name == "replay" for ep in entry_points(group="frictionid.commands")), \
        "frictionid_ros is not installed (pip install -e frictionid_ros registers the replay command)"
    domain = private_domain()
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = rclpy.create_node("replay_sink", context=ctx)
    got = []
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=2000, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(JointState, "/replayed", got.append, qos)
    stop = threading.Event()
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)

    def spin():
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)

    th = threading.Thread(target=spin, daemon=True)
    th.start()
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "frictionid_core" / "src"), str(ROOT / "frictionid_ros"),
                                         env.get("PYTHONPATH", "")])
    env.pop("_ROS_WHEELS_BOOTSTRAP_COMPLETE", None)
    try:
        t0 = time.time_ns()
        out = subprocess.run(
            [sys.executable, "-c", "import sys; from frictionid_core.cli import main; sys.exit(main())",
             "replay", str(BAG), "--duration", "1", "--rate", "4", "--publish-topic", "/replayed", "--wait", "60"],
            env=env, capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr
        assert "published 1000 messages" in out.stdout
        try:  # acknowledged by this process's reader: the executor thread takes them in
            wait_until(lambda: len(got) >= 1000, "1000 replayed messages")
        except AssertionError as exc:
            raise AssertionError(f"{exc}: {len(got)}; {out.stdout} {out.stderr}") from None
        assert len(got) == 1000
        stamps = np.array([m.header.stamp.sec * NS + m.header.stamp.nanosec for m in got])
        assert stamps[0] >= t0  # re-stamped to now
        recorded = np.array(replay.load_stream(BAG, duration=1).stamp_ns)
        assert np.array_equal(np.diff(stamps), np.diff(recorded))  # the recording's spacing is kept
    finally:
        stop.set()
        close_spinning(ctx, executor, th, [node])
