"""What the loop's processes share: rclpy start-up and spin until SIGINT/SIGTERM, QoS profiles.

A loop node keeps its 1 kHz topics on a hidden helper node (``input_node``, no parameter
services) spun by rclpy's EventsExecutor in a thread of its own, as the frictionid node does;
its parameter services are spun by a SingleThreadedExecutor in the main thread."""

from __future__ import annotations

import sys
import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import qos_profile_sensor_data

from frictionid_ros.runtime.runner import GIL_SWITCH_INTERVAL, make_input_executor, serve

SENSOR = qos_profile_sensor_data  # joint_states, reference, commands: best effort, newest only matters


class LoopNode(Node):
    """A node of the loop with a hidden helper node :attr:`input_node` (no parameter services)
    for its 1 kHz topics; :meth:`close` runs before the executors stop."""

    def __init__(self, name: str):
        super().__init__(name)
        self.input_node = Node(f"_{name}_input", context=self.context, use_global_arguments=False,
                               start_parameter_services=False)

    def close(self) -> None:
        """Stop what the node runs by itself (subclasses)."""

    def destroy_node(self) -> None:
        self.input_node.destroy_node()
        super().destroy_node()


def run_node(node_class, argv: list[str] | None = None) -> int:
    """Run the :class:`LoopNode` ``node_class()`` until SIGINT/SIGTERM (:func:`frictionid_ros.runtime.runner.serve`):
    its input node in rclpy's EventsExecutor, itself in a SingleThreadedExecutor."""
    rclpy.init(args=list(sys.argv if argv is None else argv))
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)

    def executors(node):
        fast = make_input_executor("events", node.get_logger())
        fast.add_node(node.input_node)
        main = SingleThreadedExecutor()
        main.add_node(node)
        return fast, main

    return serve(node_class, executors, node_class.__name__)
