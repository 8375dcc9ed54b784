"""The ``~/run_experiment`` action without ROS (docs/experiment.md): a goal validated into settings
(:mod:`.settings`), the worker's tasks — the screened plan of the motion, the fit of the recording
(:mod:`.tasks`) —, the recording into an MCAP bag (:mod:`.recording`) and the experiment itself, from
the approach to the judgement (:mod:`.service`)."""

from frictionid_ros.experiment.recording import BagRecorder
from frictionid_ros.experiment.service import ExperimentAnswer, ExperimentService, Status
from frictionid_ros.experiment.settings import DEFAULT_RATES, DEFAULT_TOPICS, INTERFACES, Settings, parse_goal
from frictionid_ros.experiment.tasks import Fit, FitTask, Plan, PlanTask

__all__ = ["DEFAULT_RATES", "DEFAULT_TOPICS", "INTERFACES", "BagRecorder", "ExperimentAnswer", "ExperimentService",
           "Fit", "FitTask", "Plan", "PlanTask", "Settings", "Status", "parse_goal"]
