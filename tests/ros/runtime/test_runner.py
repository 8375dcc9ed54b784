"""The nodes' runner: a signal while a node starts is a stop (exit 0, no traceback), whatever it interrupts."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.ros


@pytest.fixture
def ros_node_class():
    """rclpy initialised (shut down after the test) and a node class with the ``close`` serve calls."""
    import rclpy
    from rclpy.node import Node

    class Started(Node):
        closed = 0

        def close(self) -> None:
            type(self).closed += 1

    rclpy.init(args=[])
    yield Started
    rclpy.try_shutdown()


def test_a_signal_while_the_node_starts_is_a_stop(ros_node_class, capsys):
    # rclpy's handler shuts ROS down on SIGTERM; when that landed after the node's "configured:" line but
    # before its executors existed, building one raised RCLError ("the given context is not valid"): a
    # traceback and exit 1 (tests/ros/node/test_node_safety.py met it once in a fresh clone's suite)
    import rclpy

    from frictionid_ros.runtime.runner import serve

    def make_node():
        node = ros_node_class("frictionid_runner_test")
        rclpy.shutdown()  # what the signal handler does, at the end of the node's start-up
        return node

    built = []
    assert serve(make_node, lambda node: built.append(node) or (), "frictionid_node") == 0
    assert built == [] and ros_node_class.closed == 1 and not rclpy.ok()
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")  # rclpy's half-built executor
def test_a_signal_while_the_executors_are_built_is_a_stop(ros_node_class):
    import rclpy
    from rclpy.executors import MultiThreadedExecutor

    from frictionid_ros.runtime.runner import serve

    def executors(node):
        rclpy.shutdown()  # the signal, a moment later
        return MultiThreadedExecutor(), MultiThreadedExecutor()

    assert serve(lambda: ros_node_class("frictionid_runner_test"), executors, "frictionid_node") == 0
    assert ros_node_class.closed == 1


def test_an_error_while_ros_runs_is_not_taken_for_a_stop(ros_node_class):
    from frictionid_ros.runtime.runner import serve

    def executors(node):
        raise RuntimeError("a defect of the node's own")

    with pytest.raises(RuntimeError, match="a defect of the node's own"):
        serve(lambda: ros_node_class("frictionid_runner_test"), executors, "frictionid_node")
    assert ros_node_class.closed == 1
