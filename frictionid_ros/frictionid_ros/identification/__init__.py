"""Identification on request, without ROS: a request validated into a job (:mod:`.request`), its
data window (:mod:`.window`), the ``~/identify`` service (:mod:`.identify_service`), the
``~/identify_payload`` service (:mod:`.payload_service`) and online re-identification behind the
safety gate (:mod:`.online`)."""

from frictionid_ros.identification.identify_service import Answer, IdentifyService
from frictionid_ros.identification.online import Online, split
from frictionid_ros.identification.payload_service import PayloadService, PayloadTask, base_result
from frictionid_ros.identification.request import (
    Job,
    consistency_text,
    node_request,
    parse_request,
    parse_window,
    summary,
)
from frictionid_ros.identification.window import Selection, window_series

__all__ = ["Answer", "IdentifyService", "Job", "Online", "PayloadService", "PayloadTask", "Selection", "base_result",
           "consistency_text", "node_request", "parse_request", "parse_window", "split", "summary", "window_series"]
