"""An identification experiment on a robot, without ROS: the commanded motion as trajectory points and
the approach to its start pose (:mod:`.motion`), what stops it (:mod:`.monitor`), and its recording
judged before anything is applied (:mod:`.judgement`). The node's ``~/run_experiment`` runs it over
ROS 2 (frictionid_ros); the motion passes :func:`frictionid_core.safety.screen_motion` first.
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("check_share", "DEFAULT_MAX_FLOOR_RATIO", "DEFAULT_VALIDATION_SHARE", "fit_and_validate", "judge",
                     "Verdict"), "frictionid_core.experiment.judgement"),
    **dict.fromkeys(("Abort", "Monitor", "REASONS", "Thresholds"), "frictionid_core.experiment.monitor"),
    **dict.fromkeys(("approach", "approach_duration", "Motion", "POINT_RATE_HZ", "quintic", "sampled"),
                    "frictionid_core.experiment.motion"),
}

__all__ = ["DEFAULT_MAX_FLOOR_RATIO", "DEFAULT_VALIDATION_SHARE", "POINT_RATE_HZ", "REASONS", "Abort", "Monitor",
           "Motion", "Thresholds", "Verdict", "approach", "approach_duration", "check_share", "fit_and_validate",
           "judge", "quintic", "sampled"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
