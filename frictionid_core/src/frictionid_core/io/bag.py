"""sensor_msgs/JointState from rosbag2 (MCAP, sqlite3) and ROS 1 bags, via rosbags."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.io.align import align_effort
from frictionid_core.timeseries import JointSeries

JOINT_STATE = "sensor_msgs/msg/JointState"
FLOAT_ARRAY = "std_msgs/msg/Float64MultiArray"
META_PREFIX = "frictionid."
DEFAULT_TOPIC = "/joint_states"


def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_KILTED)


class _BuiltinTypes:
    """The ROS 2 Kilted message types, as AnyReader's default typestore: loaded only for a bag
    that stores no type definitions of its own (MCAP and ROS 1 bags do; loading costs ~0.1 s)."""

    @functools.cached_property
    def fielddefs(self):
        return _typestore().fielddefs


def open_reader(path: Path):
    """An opened rosbags AnyReader (rosbag2 MCAP/sqlite3 or ROS 1), or InputError naming the file."""
    from rosbags.highlevel import AnyReader

    try:
        reader = AnyReader([path], default_typestore=_BuiltinTypes())
        reader.open()
    except Exception as exc:  # rosbags raises reader-specific errors for corrupt files
        raise InputError(f"{path}: not a readable bag ({type(exc).__name__}: {exc})") from None
    return reader


def joint_state_topic(path: Path, topics: dict[str, str], topic: str | None = None) -> str:
    """``topic`` if given, else /joint_states or the bag's only JointState topic; InputError
    listing the topics otherwise. ``topics``: {name: message type} of the bag."""
    if topic is not None:
        return topic
    js = [n for n, t in topics.items() if t == JOINT_STATE]
    if DEFAULT_TOPIC in js:
        return DEFAULT_TOPIC
    if len(js) != 1:
        raise InputError(f"{path}: {'no' if not js else 'several'} {JOINT_STATE} topics; pick one with --topic. "
                         f"Topics: {topic_listing(topics)}")
    return js[0]


def topic_listing(topics: dict[str, str]) -> str:
    """'name [type], …' for error messages."""
    return ", ".join(f"{n} [{t}]" for n, t in sorted(topics.items())) or "none"


def list_topics(path: Path) -> dict[str, str]:
    """{topic: message type} of a bag."""
    reader = open_reader(Path(path))
    try:
        return {name: info.msgtype for name, info in reader.topics.items()}
    finally:
        reader.close()


def load_bag(path: Path, *, topic: str | None = None, effort_topic: str | None = None,
             extras: dict[str, tuple[str, str]] | None = None) -> JointSeries:
    """Read a JointState topic (and an optional separate effort topic) into a JointSeries.

    Time is the message header stamp, or the bag's receive time when the stamp is zero.
    ``extras`` = {name: (topic, field)} adds side JointState signals (e.g. a set-point) as
    ``series.extras[name]`` (N, J), interpolated at the joint-state times when not simultaneous.
    """
    reader = open_reader(path)
    try:
        topics = {name: info.msgtype for name, info in reader.topics.items()}
        listing = topic_listing(topics)
        topic = joint_state_topic(path, topics, topic)
        side = [(t, JOINT_STATE) for t, _ in (extras or {}).values()]
        for name, want in [(topic, JOINT_STATE), (effort_topic, None)] + side:
            if name is None:
                continue
            if name not in topics:
                raise InputError(f"{path}: topic '{name}' not in the bag. Topics: {listing}")
            if want and topics[name] != want:
                raise InputError(f"{path}: topic '{name}' is {topics[name]}, not {want}")
        series, t0_ns = _read_joint_states(reader, path, topic,
                                           need=("position", "effort") if effort_topic is None else ("position",))
        if effort_topic is not None:
            t_eff, eff = _read_effort(reader, path, effort_topic, topics[effort_topic], series.joints)
            series = align_effort(series, (t_eff - t0_ns) * 1e-9, eff, f"effort topic '{effort_topic}'")
        for name, (side_topic, field) in (extras or {}).items():
            side_series, side_t0 = _read_joint_states(reader, path, side_topic, need=(field,))
            t_side = side_series.t + (side_t0 - t0_ns) * 1e-9
            values = getattr(side_series, field)
            if t_side.size != series.t.size or np.max(np.abs(t_side - series.t)) > 1e-9:
                values = np.column_stack([np.interp(series.t, t_side, c) for c in values.T])
            series.extras[name] = values
        for key, value in _custom_data(reader).items():
            if key.startswith(META_PREFIX):
                series.meta[key.removeprefix(META_PREFIX)] = float(value)
        return series
    finally:
        reader.close()


def _custom_data(reader) -> dict[str, str]:
    """rosbag2 metadata custom_data (empty for ROS 1 bags and bare storage files)."""
    if not reader.is2:
        return {}
    metadata = getattr(getattr(reader.readers[0], "storage", None), "metadata", None)
    return dict(getattr(metadata, "custom", None) or {})


def _stamp(msg, bag_ns: int) -> int:
    st = msg.header.stamp
    ns = int(st.sec) * 1_000_000_000 + int(st.nanosec)
    return ns if ns else bag_ns


def _read_joint_states(reader, path: Path, topic: str, *, need: tuple[str, ...]) -> tuple[JointSeries, int]:
    """The topic's samples (time relative to the first stamp) and that first stamp, ns.

    rosbag2 messages sharing one layout are decoded at once (:mod:`frictionid_core.io.cdr`);
    others (and ROS 1 bags) one by one."""
    conns = [c for c in reader.connections if c.topic == topic]
    n_msgs = sum(c.msgcount for c in conns)
    if n_msgs == 0:
        raise InputError(f"{path}: topic '{topic}' has no messages")
    bag_ns = np.empty(n_msgs, dtype=np.int64)
    raws: list[bytes] = []
    msgtypes: list[str] = []
    for k, (conn, ns, raw) in enumerate(_messages(reader, path, topic, conns)):
        bag_ns[k] = ns
        raws.append(raw)
        msgtypes.append(conn.msgtype)
    bag_ns = bag_ns[: len(raws)]
    decoded = None
    if reader.is2 and set(msgtypes) == {JOINT_STATE}:
        from frictionid_core.io.cdr import decode_joint_states

        decoded = decode_joint_states(raws)
        if decoded is not None and not all(
                _agrees(decoded, k, _deserialize(reader, path, topic, raws[k], JOINT_STATE, k, bag_ns[k] - bag_ns[0]))
                for k in (0, len(raws) - 1)):
            decoded = None  # a layout rosbags reads otherwise: its reading is the reference
    if decoded is None:
        stamps, joints, arrays, short = _deserialize_joint_states(reader, path, topic, raws, msgtypes, bag_ns)
    else:
        stamps, joints, arrays, short = _decoded_joint_states(path, topic, decoded, bag_ns)
    pos, vel, eff = arrays
    for field in need:
        if short[field]:
            hint = ("; record effort in the JointState or give a separate effort topic (--effort-topic)"
                    if field == "effort" else "")
            raise InputError(
                f"{path}: topic '{topic}': field '{field}' is empty or shorter than 'name' in "
                f"{short[field]} of {n_msgs} messages{hint}"
            )
    velocity = vel if short["velocity"] == 0 else None
    series = JointSeries(t=(stamps - stamps[0]) * 1e-9, joints=joints, position=pos, effort=eff,
                         velocity=velocity, source=f"{path}:{topic}")
    return series, int(stamps[0])


def _messages(reader, path: Path, topic: str, conns):
    """(connection, bag time ns, raw bytes) of the messages of ``conns``; InputError naming the
    topic and the message a storage error stops at (a corrupt chunk or record)."""
    k = 0
    try:
        for item in reader.messages(connections=conns):
            yield item
            k += 1
    except Exception as exc:  # rosbags raises reader- and storage-specific errors
        raise InputError(f"{path}: topic '{topic}': message {k} cannot be read: the bag is corrupt there "
                         f"({type(exc).__name__}: {exc})") from None


def _deserialize(reader, path: Path, topic: str, raw: bytes, msgtype: str, k: int, after_ns: int):
    """Message ``k`` of ``topic``, received ``after_ns`` after its first, deserialised; InputError
    naming it when it is corrupt."""
    try:
        return reader.deserialize(raw, msgtype)
    except Exception as exc:  # rosbags raises AnyReaderError and deserialiser-specific errors
        raise InputError(f"{path}: topic '{topic}': message {k} (bag time {after_ns * 1e-9:.6g} s after the first) "
                         f"is not a readable {msgtype} ({type(exc).__name__}: {exc})") from None


def _check_names(path: Path, topic: str, names, k: int) -> None:
    """InputError when message ``k`` names a joint more than once."""
    if len(set(names)) != len(names):
        repeated = [n for n in dict.fromkeys(names) if list(names).count(n) > 1]
        raise InputError(f"{path}: topic '{topic}': message {k} names joint(s) {repeated} more than once "
                         f"({list(names)}): which values belong to them is ambiguous")


def _long_field(path: Path, topic: str, field: str, size: int, names, k: int) -> InputError:
    return InputError(f"{path}: topic '{topic}': message {k}: field '{field}' has {size} values for "
                      f"{len(names)} names {list(names)}: which values belong to which joint is ambiguous")


def _agrees(decoded: dict, k: int, msg) -> bool:
    """True when row ``k`` of ``decoded`` is the deserialised message ``msg``, bit for bit."""
    st = msg.header.stamp
    return (decoded["sec"][k] == st.sec and decoded["nanosec"][k] == st.nanosec
            and decoded["frame_id"] == msg.header.frame_id and decoded["names"] == list(msg.name)
            and all(np.array_equal(decoded[f][k].view(np.int64), np.asarray(getattr(msg, f), np.float64).view(np.int64))
                    for f in ("position", "velocity", "effort")))


def _no_names(path: Path, topic: str) -> InputError:
    return InputError(f"{path}: topic '{topic}': first JointState has no joint names")


def _decoded_joint_states(path: Path, topic: str, decoded: dict, bag_ns: np.ndarray):
    """(stamps ns, joints, (position, velocity, effort) (N, J), {field: short messages}) of the
    messages decoded at once: every message has the same names and array lengths."""
    joints = list(decoded["names"])
    if not joints:
        raise _no_names(path, topic)
    _check_names(path, topic, joints, 0)
    n_msgs, nj = bag_ns.size, len(joints)
    stamps = decoded["sec"] * 1_000_000_000 + decoded["nanosec"]
    stamps = np.where(stamps != 0, stamps, bag_ns)
    arrays, short = [], {}
    for field in ("position", "velocity", "effort"):
        values = decoded[field]
        if values.shape[1] > nj:
            raise _long_field(path, topic, field, values.shape[1], joints, 0)
        if values.shape[1] == nj:
            arrays.append(np.ascontiguousarray(values[:, :nj]))
            short[field] = 0
        else:
            arrays.append(np.full((n_msgs, nj), np.nan))
            short[field] = n_msgs
    return stamps, joints, arrays, short


def _deserialize_joint_states(reader, path: Path, topic: str, raws: list[bytes], msgtypes: list[str],
                              bag_ns: np.ndarray):
    """As :func:`_decoded_joint_states`, deserialising message by message (any layout, ROS 1)."""
    n_msgs = len(raws)
    stamps = np.empty(n_msgs, dtype=np.int64)
    joints: list[str] | None = None
    pos = vel = eff = None
    order_cache: dict[tuple, np.ndarray] = {}
    short = {"position": 0, "velocity": 0, "effort": 0}
    for k, raw in enumerate(raws):
        msg = _deserialize(reader, path, topic, raw, msgtypes[k], k, bag_ns[k] - bag_ns[0])
        names = tuple(msg.name)
        if joints is None:
            if not names:
                raise _no_names(path, topic)
            _check_names(path, topic, names, k)
            joints = list(names)
            nj = len(joints)
            pos, vel, eff = (np.full((n_msgs, nj), np.nan) for _ in range(3))
        idx = order_cache.get(names)
        if idx is None:
            missing = [j for j in joints if j not in names]
            if missing:
                raise InputError(
                    f"{path}: topic '{topic}': message {k} lacks joint(s) {missing} (it has {list(names)})"
                )
            _check_names(path, topic, names, k)
            idx = order_cache[names] = np.array([names.index(j) for j in joints])
        stamps[k] = _stamp(msg, int(bag_ns[k]))
        for field, out in (("position", pos), ("velocity", vel), ("effort", eff)):
            arr = np.asarray(getattr(msg, field), dtype=float)
            if arr.size > len(names):
                raise _long_field(path, topic, field, arr.size, names, k)
            if arr.size == len(names):
                out[k] = arr[idx]
            else:
                short[field] += 1
    return stamps, joints, (pos, vel, eff), short


def _read_effort(reader, path: Path, topic: str, msgtype: str, joints: list[str]):
    conns = [c for c in reader.connections if c.topic == topic]
    t, rows = [], []
    first_ns = None
    for conn, bag_ns, raw in _messages(reader, path, topic, conns):
        first_ns = bag_ns if first_ns is None else first_ns
        msg = _deserialize(reader, path, topic, raw, conn.msgtype, len(t), bag_ns - first_ns)
        if msgtype == JOINT_STATE:
            names = list(msg.name)
            missing = [j for j in joints if j not in names]
            if missing:
                raise InputError(f"{path}: effort topic '{topic}' lacks joint(s) {missing} (it has {names})")
            _check_names(path, topic, names, len(t))
            e = np.asarray(msg.effort, dtype=float)
            if e.size > len(names):
                raise _long_field(path, topic, "effort", e.size, names, len(t))
            if e.size < len(names):
                raise InputError(f"{path}: effort topic '{topic}': field 'effort' is empty or short in message "
                                 f"{len(t)}")
            rows.append(e[[names.index(j) for j in joints]])
            t.append(_stamp(msg, bag_ns))
        elif msgtype == FLOAT_ARRAY:
            e = np.asarray(msg.data, dtype=float)
            if e.size != len(joints):
                raise InputError(f"{path}: effort topic '{topic}': message {len(t)} has {e.size} values for "
                                 f"{len(joints)} joints {joints}")
            rows.append(e)
            t.append(bag_ns)
        else:
            raise InputError(f"{path}: effort topic '{topic}' is {msgtype}; expected {JOINT_STATE} or {FLOAT_ARRAY}")
    if not rows:
        raise InputError(f"{path}: effort topic '{topic}' has no messages")
    return np.asarray(t, dtype=np.int64), np.vstack(rows)


def write_joint_state_bag(
    path: Path,
    series: JointSeries,
    *,
    topic: str = DEFAULT_TOPIC,
    storage: str = "mcap",
    extra_topics: dict[str, tuple[str, np.ndarray]] | None = None,
    t0_ns: int = 1_700_000_000_000_000_000,
) -> Path:
    """Write ``series`` as sensor_msgs/JointState messages to a new rosbag2 directory.

    Args:
        path: bag directory to create (must not exist).
        topic: JointState topic.
        storage: "mcap" (zstd-compressed chunks) or "sqlite3".
        extra_topics: {topic: (field, array (N,) or (N, J))}: further JointState topics on the
            same stamps carrying ``array`` in ``field`` ("position", "velocity" or "effort").
        t0_ns: stamp of the first sample, ns since the epoch.
    Series ``meta`` goes into the bag's custom data (``frictionid.<key>``).
    """
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

    ts = _typestore()
    JointState = ts.types[JOINT_STATE]
    Header = ts.types["std_msgs/msg/Header"]
    Time = ts.types["builtin_interfaces/msg/Time"]
    path = Path(path)
    if path.exists():
        raise InputError(f"{path}: already exists; refusing to overwrite a bag")
    plugin = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}[storage]
    stamps = t0_ns + np.round(series.t * 1e9).astype(np.int64)
    empty = np.empty(0)
    names = list(series.joints)
    streams = [(topic, {"position": series.position, "effort": series.effort,
                        "velocity": series.velocity})]
    for extra, (field, arr) in (extra_topics or {}).items():
        streams.append((extra, {field: np.asarray(arr, dtype=float).reshape(len(series), -1)}))
    writer = Writer(path, version=9, storage_plugin=plugin)
    if storage == "mcap":
        writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    for key, value in series.meta.items():
        writer.set_custom_data(META_PREFIX + key, repr(float(value)))
    with writer:
        conns = [(writer.add_connection(name, JOINT_STATE, typestore=ts), fields) for name, fields in streams]
        for k, ns in enumerate(stamps):
            ns = int(ns)
            header = Header(stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id="")
            for conn, fields in conns:
                row = {f: (empty if a is None else np.ascontiguousarray(a[k], dtype=np.float64))
                       for f, a in fields.items()}
                msg = JointState(header=header, name=names, position=row.get("position", empty),
                                 velocity=row.get("velocity", empty), effort=row.get("effort", empty))
                writer.write(conn, ns, ts.serialize_cdr(msg, JOINT_STATE))
    return path


def first_bag_stamp(path: Path, topic: str | None) -> int:
    """The stamp (ns) of the first message of a bag's JointState topic (the bag time where the
    stamp is zero), as :func:`frictionid_core.io.load` counts its time from."""
    reader = open_reader(path)
    try:
        topics = {name: info.msgtype for name, info in reader.topics.items()}
        name = joint_state_topic(path, topics, topic)
        conns = [c for c in reader.connections if c.topic == name]
        for conn, bag_ns, raw in reader.messages(connections=conns):
            return _stamp(reader.deserialize(raw, conn.msgtype), int(bag_ns))
    finally:
        reader.close()
    raise InputError(f"{path}: topic '{name}' has no messages")
