"""Publisher process of tests/ros/node/test_node_options.py: stamped joint states and an unstamped
Float64MultiArray effort at 500 Hz, for two joints published in the order ``b, a``.

A process of its own so that nothing else (the test's client executor) runs between the two
publishes of one sample: the node pairs the unstamped effort with the joint states by receipt time.

    python publish_unstamped_effort.py NAMESPACE
"""

from __future__ import annotations

import sys
import time

import numpy as np

FV = np.array([2.0, 1.0])  # joints a, b [N·m·s/rad]
FC = np.array([0.5, 0.3])  # [N·m]
RATE = 500.0  # [Hz]
N = 1500


def signals() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample times [s], positions [rad] and efforts [N·m] of joints ``a, b`` (columns)."""
    t = np.arange(N) / RATE
    w = 2 * np.pi * np.array([0.8, 1.1])
    q = 0.3 * np.sin(np.outer(t, w))
    v = 0.3 * w * np.cos(np.outer(t, w))
    return t, q, FV * v + FC * np.sign(v)


def main(ns: str) -> int:
    import rclpy
    from builtin_interfaces.msg import Time
    from rclpy.duration import Duration
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    reliable = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=2000, reliability=ReliabilityPolicy.RELIABLE)
    rclpy.init()
    node = rclpy.create_node("unstamped_effort_publisher")
    js = node.create_publisher(JointState, f"{ns}/joint_states", reliable)
    eff = node.create_publisher(Float64MultiArray, f"{ns}/effort", reliable)
    deadline = time.monotonic() + 60
    while js.get_subscription_count() == 0 or eff.get_subscription_count() == 0:
        if time.monotonic() > deadline:
            print("no subscriber to joint_states and effort within 60 s", file=sys.stderr)
            return 1
        time.sleep(0.02)
    # a head start: the node's readers may accept our samples a moment after this side sees them, and
    # the effort is paired by receipt time (that every sample arrives, the acknowledgements check)
    time.sleep(0.3)
    t, q, tau = signals()
    m = JointState(name=["b", "a"])  # another order than the node's joints
    t0, base = time.monotonic(), time.time_ns()
    for k in range(len(t)):
        stamp = base + int(t[k] * 1e9)  # the sample time, however late this loop runs
        m.header.stamp = Time(sec=stamp // 1_000_000_000, nanosec=stamp % 1_000_000_000)
        m.position = [q[k, 1], q[k, 0]]
        js.publish(m)
        eff.publish(Float64MultiArray(data=tau[k].tolist()))
        delay = t0 + (k + 1) / RATE - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    for pub in (js, eff):  # a reliable writer destroyed before the acknowledgements drops the tail
        if not pub.wait_for_all_acked(Duration(seconds=60)):
            print(f"{pub.topic_name}: not everything acknowledged within 60 s", file=sys.stderr)
            return 1
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
