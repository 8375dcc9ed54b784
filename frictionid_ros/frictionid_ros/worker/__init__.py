"""The identification worker process and the control of one identification (no ROS import)."""

from frictionid_ros.worker.worker_process import (
    KILLED_NOTE,
    Cancelled,
    Gate,
    JobControl,
    WorkerProcess,
    checked_result,
    rss_kb,
    run_identification,
)

__all__ = ["KILLED_NOTE", "Cancelled", "Gate", "JobControl", "WorkerProcess", "checked_result", "rss_kb",
           "run_identification"]
