"""The identification worker: each identification runs in a child process rather than a thread of
the node (no ROS import).

:mod:`.worker_process` (the node's side, :class:`WorkerProcess`, and why a process), :mod:`.child`
(the child's loop, ``python -m frictionid_ros.worker.child``), :mod:`.protocol` (their messages),
:mod:`.job` (what a job carries and runs, its reply read back) and :mod:`.job_control` (cancel,
progress and wall-time limit of one identification)."""

from frictionid_ros.worker.job import Gate, checked_result, run_identification
from frictionid_ros.worker.job_control import Cancelled, JobControl
from frictionid_ros.worker.worker_process import KILLED_NOTE, WorkerProcess, rss_kb

__all__ = ["KILLED_NOTE", "Cancelled", "Gate", "JobControl", "WorkerProcess", "checked_result", "rss_kb",
           "run_identification"]
