"""What a process of this package runs on: real-time scheduling (:mod:`.realtime`), a ROS domain of
its own (:mod:`.ros_domain`) and, for the nodes, rclpy's executors, signals and orderly shutdown
(:mod:`.runner`); an action client whose goal future completes (:mod:`.action_client`).

This face imports no ROS and so leaves out :mod:`.runner` and :mod:`.action_client` (rclpy): the
parameters and ``frictionid loop``'s command line import it without ROS; the nodes import
``frictionid_ros.runtime.runner``, a client of an action ``frictionid_ros.runtime.action_client``."""

from frictionid_ros.runtime.realtime import (
    AUTO_PRIORITY,
    fifo_this_thread,
    fifo_threads,
    parse_priority,
    realtime_priority,
    schedule_this_thread,
)
from frictionid_ros.runtime.ros_domain import DomainLease, check_domain_id, lock_file, reserve_domain

__all__ = ["AUTO_PRIORITY", "DomainLease", "check_domain_id", "fifo_threads", "fifo_this_thread", "lock_file",
           "parse_priority", "realtime_priority", "reserve_domain", "schedule_this_thread"]
