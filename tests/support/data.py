"""Data the tests share: the bundled EMPS bags, noise-free EMPS-like series and ROS 2 bag writing.

The real EMPS data are the MCAP bags in ``bags/`` (never ``../shared``: CI has a clean clone).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from frictionid_core.timeseries import JointSeries

REPO = Path(__file__).resolve().parents[2]
BAGS = REPO / "bags"
EMPS_ESTIMATION = BAGS / "emps_estimation"
EMPS_VALIDATION = BAGS / "emps_validation"

JOINT_STATE = "sensor_msgs/msg/JointState"
FLOAT_ARRAY = "std_msgs/msg/Float64MultiArray"
T0_NS = 1_700_000_000_000_000_000


def emps_like(n: int = 3000, dt: float = 1e-3, M: float = 95.0, Fv: float = 200.0, Fc: float = 20.0,
              offset: float = -3.0, joint: str = "emps") -> JointSeries:
    """Noise-free 1-DOF data τ = M·q̈ + Fv·q̇ + Fc·sign(q̇) + offset on a two-sine trajectory
    (about 8 velocity reversals in 3 s at 1 kHz)."""
    t = np.arange(n) * dt
    w1, w2 = 2 * np.pi * 0.7, 2 * np.pi * 1.9
    q = 0.05 * np.sin(w1 * t) + 0.01 * np.sin(w2 * t + 0.3)
    qd = 0.05 * w1 * np.cos(w1 * t) + 0.01 * w2 * np.cos(w2 * t + 0.3)
    qdd = -0.05 * w1**2 * np.sin(w1 * t) - 0.01 * w2**2 * np.sin(w2 * t + 0.3)
    tau = M * qdd + Fv * qd + Fc * np.sign(qd) + offset
    return JointSeries(t, [joint], q, tau, source="synthetic")


def one_way_series() -> JointSeries:
    """A one-direction move (q̇ ≥ 0.05 m/s throughout): sign(q̇) is the constant column, so Fc and the
    offset are collinear. τ = 95·q̈ + 200·q̇ + 20 (offset 0), 10 s at 1 kHz."""
    t = np.arange(10001) * 1e-3
    w = 2 * np.pi * 2 / 3
    q = 0.1 * t + 0.05 / w * np.sin(w * t)
    qd = 0.1 + 0.05 * np.cos(w * t)
    qdd = -0.05 * w * np.sin(w * t)
    return JointSeries(t, ["emps"], q, 95.0 * qdd + 200.0 * qd + 20.0, source="one-way")


def reversal_motion(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, q̇, q̈) of 5 s segments: 4 s of whole sine cycles at one of six amplitudes (0.02 to 0.8
    rad/s) and rates, smoothly windowed, then 1 s at rest: fast and slow reversals and dwells."""
    seg, local = (t // 5.0).astype(int) % 6, t % 5.0
    amp = np.array([0.4, 0.05, 0.8, 0.02, 0.3, 0.1])[seg]
    w = 2 * np.pi * np.array([0.5, 0.25, 0.75, 0.5, 1.0, 0.25])[seg]
    moving = local < 4.0
    c = np.pi / 4.0
    window, dwindow = np.sin(c * local) ** 2, 2 * c * np.sin(c * local) * np.cos(c * local)
    qd = np.where(moving, amp * np.sin(w * local) * window, 0.0)
    qdd = np.where(moving, amp * (w * np.cos(w * local) * window + np.sin(w * local) * dwindow), 0.0)
    q = np.concatenate([[0.0], np.cumsum(0.5 * (qd[1:] + qd[:-1]) * np.diff(t))])
    return q, qd, qdd


def dynamic_friction_log(params: dict[str, float], friction: str = "lugre", *, seed: int = 0, seconds: float = 30.0,
                         rate: float = 1000.0, inertia: float = 0.05, torque_noise: float = 0.02,
                         position_noise: float = 1e-6, elements: int | None = None,
                         joint: str = "j") -> JointSeries:
    """One joint τ = J·q̈ + F(q̇ history) + noise of a dynamic law with ``params`` along
    :func:`reversal_motion` (the states integrated at the log's rate from rest), noisy position."""
    from frictionid_core.friction import get_model

    t = np.arange(0.0, seconds, 1.0 / rate)
    q, qd, qdd = reversal_motion(t)
    law = get_model(friction, False, elements)
    friction_torque = law.torque(np.array([params[n] for n in law.names]), qd, t=t)
    rng = np.random.default_rng(seed)
    tau = inertia * qdd + friction_torque + torque_noise * rng.standard_normal(t.size)
    return JointSeries(t, [joint], (q + position_noise * rng.standard_normal(t.size))[:, None], tau[:, None],
                       source=f"synthetic {friction} (seed {seed})")


# ------------------------------------------------------------------------ bag writing
def _ros2_typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_KILTED)


def write_ros2_bag(path: Path, topics: dict[str, tuple[str, list[tuple[int, dict]]]],
                   storage: str = "mcap") -> Path:
    """Write arbitrary messages into a new rosbag2 directory.

    ``topics`` maps a topic to (message type, [(bag time ns, fields), …]). For a JointState,
    ``fields`` holds ``name`` and optionally ``stamp_ns`` (header stamp, default: the bag time),
    ``position``, ``velocity``, ``effort`` (default: empty). For a Float64MultiArray, ``data``.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = _ros2_typestore()
    JointState = ts.types[JOINT_STATE]
    Header = ts.types["std_msgs/msg/Header"]
    Time = ts.types["builtin_interfaces/msg/Time"]
    F64A = ts.types[FLOAT_ARRAY]
    Layout = ts.types["std_msgs/msg/MultiArrayLayout"]
    plugin = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}[storage]
    arr = lambda x: np.ascontiguousarray(x if x is not None else [], dtype=np.float64)
    records = []
    with Writer(Path(path), version=9, storage_plugin=plugin) as writer:
        for topic, (msgtype, msgs) in topics.items():
            conn = writer.add_connection(topic, msgtype, typestore=ts)
            for bag_ns, f in msgs:
                if msgtype == JOINT_STATE:
                    st = int(f.get("stamp_ns", bag_ns))
                    msg = JointState(
                        header=Header(stamp=Time(sec=st // 1_000_000_000, nanosec=st % 1_000_000_000),
                                      frame_id=""),
                        name=list(f["name"]), position=arr(f.get("position")),
                        velocity=arr(f.get("velocity")), effort=arr(f.get("effort")))
                else:
                    msg = F64A(layout=Layout(dim=[], data_offset=0), data=arr(f["data"]))
                records.append((bag_ns, conn, ts.serialize_cdr(msg, msgtype)))
        for bag_ns, conn, raw in sorted(records, key=lambda r: r[0]):
            writer.write(conn, int(bag_ns), raw)
    return Path(path)


def joint_state_msgs(t: np.ndarray, names: list[str], position=None, effort=None, velocity=None,
                     t0_ns: int = T0_NS) -> list[tuple[int, dict]]:
    """JointState records for :func:`write_ros2_bag`: row k of each (N, J) array at t[k] s."""
    out = []
    for k, tk in enumerate(t):
        f = {"name": names}
        for key, a in (("position", position), ("effort", effort), ("velocity", velocity)):
            if a is not None:
                f[key] = np.atleast_1d(np.asarray(a[k], dtype=float))
        out.append((t0_ns + int(round(tk * 1e9)), f))
    return out
