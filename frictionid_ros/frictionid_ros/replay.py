"""``frictionid replay``: publish a bag's JointState (and effort) topic with rclpy, re-stamped to now.

    frictionid replay bags/emps_estimation --rate 1        # real time
    frictionid replay bags/emps_estimation --rate 0        # as fast as possible
    python -m frictionid_ros.replay BAG --duration 8 --loop

Reads rosbag2 (MCAP, sqlite3) and ROS 1 bags through rosbags. rosbag2 payloads are already
CDR: they are published as serialized bytes with only the header stamp patched in place (no
deserialisation). ROS 1 messages are converted once, before publishing. Header stamps become
``now + (stamp − first stamp)``: the recording's sample spacing is kept whatever the rate, so
an identification on the replayed data sees the recorded time base.

Registered with the core CLI through the entry point group ``frictionid.commands``
(``replay = frictionid_ros.replay:register``); importing this module imports neither rclpy nor
the bag readers (``frictionid replay --help`` stays fast).
"""

from __future__ import annotations

import argparse
import signal
import struct
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from frictionid_core import FrictionIdError, InputError
from frictionid_ros.runtime import check_domain_id

NS = 1_000_000_000
DESCRIPTION = ("Publish a bag's JointState (and effort) topic with rclpy, re-stamped to now "
               "(the recording's relative timing is kept).")


@dataclass
class Stream:
    """Messages of a bag ready to publish, in bag order.

    Attributes:
        topics: published topic names; ``types[i]`` is the ROS type of ``topics[i]``.
        bag_ns: receive time of each message in the bag [ns] (publish schedule).
        topic_index: index into ``topics`` of each message.
        payloads: CDR-serialized messages (bytes).
        stamp_ns: header stamp of each message [ns], 0 without header (Float64MultiArray).
        source: bag path.
    """

    topics: list[str]
    types: list[str]
    bag_ns: list[int] = field(default_factory=list)
    topic_index: list[int] = field(default_factory=list)
    payloads: list[bytes] = field(default_factory=list)
    stamp_ns: list[int] = field(default_factory=list)
    source: str = ""

    def __len__(self) -> int:
        return len(self.payloads)

    @property
    def duration(self) -> float:
        """Bag time from the first to the last message [s]."""
        return (self.bag_ns[-1] - self.bag_ns[0]) / NS if self.bag_ns else 0.0


def read_stamp(cdr: bytes) -> int:
    """Header stamp [ns] of a CDR message that starts with std_msgs/Header."""
    fmt = "<iI" if cdr[1] & 1 else ">iI"
    sec, nsec = struct.unpack_from(fmt, cdr, 4)
    return sec * NS + nsec


def restamp(cdr: bytes, stamp_ns: int) -> bytes:
    """Copy of ``cdr`` with its header stamp set to ``stamp_ns`` [ns]."""
    buf = bytearray(cdr)
    fmt = "<iI" if buf[1] & 1 else ">iI"
    sec, nsec = divmod(int(stamp_ns), NS)
    struct.pack_into(fmt, buf, 4, sec, nsec)
    return bytes(buf)


def _ros1_to_cdr(msg, msgtype: str) -> bytes:
    """A ROS 1 message (rosbags object) as ROS 2 CDR, through rclpy's own types."""
    from rclpy.serialization import serialize_message

    from frictionid_core.io import JOINT_STATE

    if msgtype == JOINT_STATE:
        from sensor_msgs.msg import JointState

        out = JointState()
        out.header.stamp.sec, out.header.stamp.nanosec = int(msg.header.stamp.sec), int(msg.header.stamp.nanosec)
        out.header.frame_id = msg.header.frame_id
        out.name = list(msg.name)
        out.position, out.velocity, out.effort = (msg.position.tolist(), msg.velocity.tolist(),
                                                  msg.effort.tolist())
    else:
        from std_msgs.msg import Float64MultiArray

        out = Float64MultiArray()
        out.data = msg.data.tolist()
    return serialize_message(out)


def load_stream(bag: str | Path, *, topic: str | None = None, effort_topic: str | None = None,
                duration: float | None = None, publish_topic: str | None = None,
                publish_effort_topic: str | None = None) -> Stream:
    """Read the JointState ``topic`` (default /joint_states, else the only one) and ``effort_topic``.

    ``duration`` [s] keeps only the messages of the first seconds of the JointState topic.
    """
    from frictionid_core.io import FLOAT_ARRAY, JOINT_STATE, joint_state_topic, open_reader, topic_listing

    path = Path(bag)
    if not path.exists():
        raise InputError(f"{path}: no such file or directory")
    reader = open_reader(path)
    try:
        types = {name: info.msgtype for name, info in reader.topics.items()}
        listing = topic_listing(types)
        topic = joint_state_topic(path, types, topic)
        wanted = [topic] + ([effort_topic] if effort_topic else [])
        for name in wanted:
            if name not in types:
                raise InputError(f"{path}: topic '{name}' not in the bag. Topics: {listing}")
        if types[topic] != JOINT_STATE:
            raise InputError(f"{path}: topic '{topic}' is {types[topic]}, not {JOINT_STATE}")
        if effort_topic and types[effort_topic] not in (JOINT_STATE, FLOAT_ARRAY):
            raise InputError(f"{path}: effort topic '{effort_topic}' is {types[effort_topic]}; expected "
                             f"{JOINT_STATE} or {FLOAT_ARRAY}")
        out_names = [publish_topic or topic] + ([publish_effort_topic or effort_topic] if effort_topic else [])
        stream = Stream(out_names, [types[n] for n in wanted], source=str(path))
        conns = [c for c in reader.connections if c.topic in wanted]
        limit = None
        first = None
        for conn, bag_ns, raw in reader.messages(connections=conns):
            i = wanted.index(conn.topic)
            if reader.is2:
                cdr = bytes(raw)
            else:
                cdr = _ros1_to_cdr(reader.deserialize(raw, conn.msgtype), conn.msgtype)
            if first is None:
                first = bag_ns
                limit = None if duration is None else first + int(duration * NS)
            if limit is not None and bag_ns >= limit:
                if i == 0:
                    break
                continue
            stream.bag_ns.append(int(bag_ns))
            stream.topic_index.append(i)
            stream.payloads.append(cdr)
            stream.stamp_ns.append(read_stamp(cdr) if stream.types[i] == JOINT_STATE else 0)
    finally:
        reader.close()
    if not any(i == 0 for i in stream.topic_index):
        raise InputError(f"{path}: topic '{topic}' has no messages")
    return stream


def publish_stream(node, stream: Stream, *, rate: float = 1.0, loops: int = 1, qos=None,
                   wait_subscribers: float = 5.0, settle: float = 0.3, ack_timeout: float = 2.0,
                   stop=None, pause=None) -> dict:
    """Publish ``stream`` with ``node`` (rclpy), re-stamped to now; returns counts and timing.

    Args:
        rate: speed factor (1.0 real time, 2.0 twice as fast, 0 as fast as possible).
        loops: passes over the bag (0 = until ``stop()`` returns True or Ctrl-C). Stamps keep
            increasing from one pass to the next.
        qos: rclpy QoSProfile (default: reliable, keep last 1000 — matches best-effort and
            reliable subscribers).
        wait_subscribers: wait up to this long [s] for a subscriber of the JointState topic.
        settle: then wait this long [s] so that the first messages are not lost to discovery.
        ack_timeout: at the end, wait up to this long [s] for reliable subscribers to acknowledge
            everything (a writer destroyed earlier may drop the last messages).
        stop: optional callable; publishing ends when it returns True.
        pause: optional callable, given the count of messages sent so far every 64 messages; it may
            block (flow control: a subscriber that drains its history slower than the bag's rate
            loses what overflows a keep-last history, reliable or not).
    """
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    from frictionid_core.io import FLOAT_ARRAY, JOINT_STATE

    if rate < 0:
        raise FrictionIdError(f"--rate must be >= 0, got {rate}")
    qos = qos or QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    cls = {JOINT_STATE: JointState, FLOAT_ARRAY: Float64MultiArray}
    pubs = [node.create_publisher(cls[t], name, qos) for name, t in zip(stream.topics, stream.types)]
    deadline = time.monotonic() + wait_subscribers
    while pubs[0].get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    subscribers = pubs[0].get_subscription_count()
    if subscribers:
        time.sleep(settle)  # the writer sees the reader before the reader accepts the writer's samples
    stamps = [s for s, i in zip(stream.stamp_ns, stream.topic_index) if s]
    first_stamp = min(stamps) if stamps else 0
    b0 = stream.bag_ns[0]
    period = (stream.bag_ns[-1] - b0) / max(len(stream) - 1, 1)
    pass_ns = stream.bag_ns[-1] - b0 + int(period)  # stamps advance by this per pass
    sent = 0
    t_start = time.monotonic()
    now0 = time.time_ns()
    n_pass = 0
    try:
        while loops == 0 or n_pass < loops:
            shift = now0 + n_pass * pass_ns - first_stamp
            wall0 = t_start + n_pass * pass_ns / NS / rate if rate > 0 else None
            for bag_ns, i, cdr, st in zip(stream.bag_ns, stream.topic_index, stream.payloads, stream.stamp_ns):
                if wall0 is not None:
                    delay = wall0 + (bag_ns - b0) / NS / rate - time.monotonic()
                    if delay > 0:
                        time.sleep(delay)
                pubs[i].publish(restamp(cdr, st + shift) if st else cdr)
                sent += 1
                if (sent & 63) == 0:
                    if pause is not None:
                        pause(sent)
                    if stop is not None and stop():
                        raise KeyboardInterrupt
            n_pass += 1
    except KeyboardInterrupt:
        pass
    wall = time.monotonic() - t_start
    if qos.reliability == ReliabilityPolicy.RELIABLE and ack_timeout > 0:
        from rclpy.duration import Duration

        for p in pubs:  # a reliable writer destroyed too early drops what is not acknowledged yet
            try:
                p.wait_for_all_acked(Duration(seconds=ack_timeout))
            except KeyboardInterrupt:
                break
    for p in pubs:
        node.destroy_publisher(p)
    return {"sent": sent, "passes": n_pass, "wall_s": wall, "subscribers": subscribers,
            "rate_hz": sent / wall if wall > 0 else float("nan"), "first_stamp_ns": now0}


def register(subparsers) -> Callable[[argparse.Namespace], int]:
    """Add the ``replay`` sub-command to the core CLI; returns its handler."""
    p = subparsers.add_parser(
        "replay", help="publish a bag's JointState (and effort) topic with ROS 2, re-stamped to now",
        description=DESCRIPTION)
    add_arguments(p)
    return handler


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("bag", help="rosbag2 directory / .mcap / .db3, or ROS 1 .bag")
    p.add_argument("--rate", type=float, default=1.0, help="speed factor: 1.0 real time, 0 as fast as possible")
    p.add_argument("--topic", help="JointState topic of the bag (default /joint_states, else the only one)")
    p.add_argument("--effort-topic", help="separate effort topic of the bag (JointState or Float64MultiArray)")
    p.add_argument("--publish-topic", help="publish the joint states on this topic (default: the bag's name)")
    p.add_argument("--publish-effort-topic", help="publish the effort topic on this topic")
    p.add_argument("--duration", type=float, help="replay only the first DURATION seconds [s]")
    p.add_argument("--loop", type=int, nargs="?", const=0, default=1, metavar="N",
                   help="replay N times (no N: forever, until Ctrl-C)")
    p.add_argument("--qos", choices=("reliable", "sensor_data"), default="reliable",
                   help="publisher QoS (default reliable: matches both reliable and best-effort subscribers)")
    p.add_argument("--depth", type=int, default=1000, help="publisher history depth [messages]")
    p.add_argument("--wait", type=float, default=5.0, help="wait up to WAIT s for a subscriber before publishing")


def handler(args) -> int:
    """Run ``replay``; FrictionIdError propagates to the CLI (one line, exit code 2)."""
    if args.rate < 0:
        raise FrictionIdError(f"--rate must be >= 0, got {args.rate}")
    stream = load_stream(args.bag, topic=args.topic, effort_topic=args.effort_topic, duration=args.duration,
                         publish_topic=args.publish_topic, publish_effort_topic=args.publish_effort_topic)
    check_domain_id()
    import rclpy
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    reliability = ReliabilityPolicy.RELIABLE if args.qos == "reliable" else ReliabilityPolicy.BEST_EFFORT
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=max(1, args.depth), reliability=reliability)
    from rclpy.signals import SignalHandlerOptions

    # Our own signal handling: Ctrl-C / SIGTERM end the loop between two messages, cleanly
    # (rclpy's handler would invalidate the context under a publish call).
    rclpy.init(args=None, signal_handler_options=SignalHandlerOptions.NO)
    previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    node = rclpy.create_node("frictionid_replay")
    try:
        print(f"replaying {len(stream)} messages ({stream.duration:.3f} s) of {stream.source} on "
              f"{', '.join(stream.topics)} at {'max speed' if args.rate == 0 else f'{args.rate:g}x'}"
              f"{', looping' if args.loop == 0 else ''}", flush=True)
        stats = publish_stream(node, stream, rate=args.rate, loops=args.loop, qos=qos, wait_subscribers=args.wait)
        if stats["subscribers"] == 0:
            print(f"frictionid: warning: no subscriber on {stream.topics[0]} after {args.wait:g} s", file=sys.stderr)
        print(f"published {stats['sent']} messages in {stats['wall_s']:.3f} s ({stats['rate_hz']:.0f} msg/s, "
              f"{stats['passes']} pass(es))", flush=True)
    except KeyboardInterrupt:  # during the final wait
        pass
    finally:
        signal.signal(signal.SIGTERM, previous)
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """Standalone entry point (``python -m frictionid_ros.replay``), same arguments as ``frictionid replay``."""
    from frictionid_core.cli import run_handler

    parser = argparse.ArgumentParser(prog="frictionid-replay", description=DESCRIPTION)
    add_arguments(parser)
    return run_handler(handler, parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
