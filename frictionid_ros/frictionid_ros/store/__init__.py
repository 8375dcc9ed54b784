"""The node's active parameters per joint, the results file and the safety screen (no ROS import)."""

from frictionid_ros.store.results import (
    FORMAT,
    ActiveParameters,
    JointParams,
    Results,
    Screen,
    check_replaceable,
    read_results,
    request_path,
    shared_parameters,
    split_identification,
    write_results,
)

__all__ = ["FORMAT", "ActiveParameters", "JointParams", "Results", "Screen", "check_replaceable", "read_results",
           "request_path", "shared_parameters", "split_identification", "write_results"]
