"""Friction compensation in the loop over ROS 2 (``frictionid loop``): a simulated arm
(:mod:`.sim_node`, ``frictionid_sim``), a joint-group effort controller (:mod:`.controller_node`,
``frictionid_loop_controller``), what their processes share (:mod:`.loop_node`) and the command
that runs them with the frictionid node and computes the figures (:mod:`.loop_command`,
``frictionid_loop`` or ``python -m frictionid_ros.loop``).

This face imports no ROS (the core CLI loads the ``loop`` command through it); the nodes are
programs, run by their module path."""

from frictionid_ros.loop.loop_command import main, register

__all__ = ["main", "register"]
