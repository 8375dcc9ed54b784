"""The ``ros`` fixture (a client node on the test's ROS domain) for every test of this folder."""

from support.ros_harness import ros  # noqa: F401 - a fixture, found by name
