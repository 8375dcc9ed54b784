"""The nodes' runner: a signal while a node starts is a stop (exit 0, no traceback), whatever it interrupts.

Each scenario runs in a process of its own (real rclpy on the test run's private domain): rclpy's
default context and its signal handlers stay out of the test process."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from support.ros_harness import DOMAIN, node_env

pytestmark = pytest.mark.ros

PRELUDE = """
import rclpy
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from frictionid_ros.runtime.runner import serve

class Started(Node):
    closed = 0
    def close(self):
        type(self).closed += 1

rclpy.init(args=[])
"""


def scenario(body: str) -> subprocess.CompletedProcess:
    """``body`` after :data:`PRELUDE`, in a Python process of its own; it prints what it found."""
    code = PRELUDE + textwrap.dedent(body)
    return subprocess.run([sys.executable, "-c", code], env=node_env(DOMAIN), capture_output=True, text=True,
                          timeout=120)


def test_a_signal_while_the_node_starts_is_a_stop():
    # rclpy's handler shuts ROS down on SIGTERM; when that landed after the node's "configured:" line but
    # before its executors existed, building one raised RCLError ("the given context is not valid"): a
    # traceback and exit 1 (tests/ros/node/test_node_safety.py met it once in a fresh clone's suite)
    proc = scenario("""
        def make_node():
            node = Started("frictionid_runner_test")
            rclpy.shutdown()  # what the signal handler does, at the end of the node's start-up
            return node
        built = []
        print(serve(make_node, lambda node: built.append(node) or (), "frictionid_node"), built, Started.closed,
              rclpy.ok())
    """)
    assert proc.returncode == 0 and proc.stdout.split() == ["0", "[]", "1", "False"], proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_signal_while_the_executors_are_built_is_a_stop():
    proc = scenario("""
        def executors(node):
            rclpy.shutdown()  # the signal, a moment later
            return MultiThreadedExecutor(), MultiThreadedExecutor()
        print(serve(lambda: Started("frictionid_runner_test"), executors, "frictionid_node"), Started.closed)
    """)
    # rclpy's half-built executor may still complain in its __del__ ("Exception ignored in"): not ours
    assert proc.returncode == 0 and proc.stdout.split() == ["0", "1"], proc.stderr
    assert "RCLError" not in proc.stderr.split("Exception ignored in")[0]


def test_an_error_while_ros_runs_is_not_taken_for_a_stop():
    proc = scenario("""
        def executors(node):
            raise RuntimeError("a defect of the node's own")
        try:
            serve(lambda: Started("frictionid_runner_test"), executors, "frictionid_node")
        except RuntimeError as exc:
            print("raised", exc, Started.closed)
    """)
    assert proc.returncode == 0 and proc.stdout.strip() == "raised a defect of the node's own 1", proc.stderr
