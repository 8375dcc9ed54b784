"""The ``frictionid`` node on ROS 2: :mod:`.frictionid_node` (the lifecycle node, ``frictionid_node``
or ``python -m frictionid_ros.node``), :mod:`.action` (its actions) and :mod:`.messages` (its
output messages built from plain values).

This face exports the message builders only: the node module is a program, imported by its
console script and ``__main__``, not here, so that a user of the messages (``frictionid loop``)
does not load the whole node."""

from frictionid_ros.node.messages import (
    diagnostic_array,
    fill_payload,
    inertia_msg,
    joint_friction,
    parameters_msg,
    to_time,
)

__all__ = ["diagnostic_array", "fill_payload", "inertia_msg", "joint_friction", "parameters_msg", "to_time"]
