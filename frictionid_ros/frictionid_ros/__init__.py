"""ROS 2 wrapper of frictionid_core."""
