"""What the loop's processes share: rclpy start-up and spin until SIGINT/SIGTERM, QoS profiles.

A loop node keeps its 1 kHz topics on a hidden helper node (``input_node``, no parameter
services) spun by rclpy's EventsExecutor in a thread of its own, as the frictionid node does;
its parameter services are spun by a SingleThreadedExecutor in the main thread."""

from __future__ import annotations

import gc
import sys
import threading
import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from frictionid_core.errors import FrictionIdError

from frictionid_ros.runner import GIL_SWITCH_INTERVAL, make_input_executor, spin

SENSOR = qos_profile_sensor_data  # joint_states, reference, commands: best effort, newest only matters
RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE)


def input_node(node: Node) -> Node:
    """The hidden helper node of ``node`` for its 1 kHz topics (no parameter services)."""
    return Node(f"_{node.get_name()}_input", context=node.context, use_global_arguments=False,
                start_parameter_services=False)


def run_node(node_class, argv: list[str] | None = None) -> int:
    """Run ``node_class()`` (with its ``input_node``) until SIGINT/SIGTERM, then ``node.close()``;
    exit code 0, or 2 with one line for a bad parameter."""
    argv = list(sys.argv if argv is None else argv)
    rclpy.init(args=argv)
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    node, executors, thread = None, [], None
    try:
        node = node_class()
        gc.freeze()  # start-up objects are never scanned again: no 100 ms collections at 1 kHz
        fast = make_input_executor("events", node.get_logger())
        fast.add_node(node.input_node)
        main = SingleThreadedExecutor()
        main.add_node(node)
        executors = [fast, main]
        thread = threading.Thread(target=spin, args=(fast, node), name="loop-input", daemon=True)
        thread.start()
        spin(main, node)
    except FrictionIdError as exc:
        print(f"{node_class.__name__}: error: {exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.close()
        for ex in executors:
            ex.shutdown(timeout_sec=1.0)
        if thread is not None:
            thread.join(timeout=2.0)
        if node is not None:
            node.input_node.destroy_node()
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
