"""Waiting for an event with a deadline, instead of sleeping a fixed time (no ROS import)."""

from __future__ import annotations

import time


def wait_until(condition, what: str, timeout: float = 60.0, period: float = 0.02, proc=None):
    """Poll ``condition()`` until it returns a true value, and return that value; AssertionError naming
    ``what`` after ``timeout`` s, or at once if the node ``proc`` (a ``support.ros_harness.NodeProcess``)
    exits meanwhile. The deadline is generous: a loaded machine only makes the wait longer."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if proc is not None:
            assert proc.alive(), f"node exited with {proc.proc.returncode} while waiting for {what}:\n{proc.stderr()}"
        assert time.monotonic() < deadline, f"no {what} within {timeout:g} s"
        time.sleep(period)
