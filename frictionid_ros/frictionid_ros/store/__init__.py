"""The node's active parameters (no ROS import): per joint and in the results file (:mod:`.results`),
screened before they become active (:mod:`.screen`, which also clamps the feed-forward), held,
saved and loaded (:mod:`.active_parameters`)."""

from frictionid_ros.store.active_parameters import ActiveParameters
from frictionid_ros.store.results import (
    FORMAT,
    JointParams,
    Results,
    check_replaceable,
    read_results,
    request_path,
    shared_parameters,
    split_identification,
    write_results,
)
from frictionid_ros.store.screen import Screen

__all__ = ["FORMAT", "ActiveParameters", "JointParams", "Results", "Screen", "check_replaceable", "read_results",
           "request_path", "shared_parameters", "split_identification", "write_results"]
