"""Friction compensation in the loop, without ROS: a MuJoCo-simulated arm with hidden friction
(:mod:`.sim`), a tracking controller (:mod:`.control`), the arm's position servo that follows
trajectories and streamed positions (:mod:`.follower`), the figures of a run (:mod:`.evaluate`) and an
experiment's identification against the arm's hidden truth (:mod:`.truth`).
MuJoCo and Pinocchio are imported when an arm is built.
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("Controller", "default_trajectory"), "frictionid_core.loop.control"),
    **dict.fromkeys(("median_ratio", "payload_figures", "plot", "summarize"), "frictionid_core.loop.evaluate"),
    **dict.fromkeys(("SERVO_BANDWIDTH_HZ", "TrajectoryFollower"), "frictionid_core.loop.follower"),
    **dict.fromkeys(("truth_errors",), "frictionid_core.loop.truth"),
    **dict.fromkeys(("hidden_friction", "load_robot", "loop_payload", "SimArm"), "frictionid_core.loop.sim"),
}

__all__ = ["SERVO_BANDWIDTH_HZ", "Controller", "SimArm", "TrajectoryFollower", "default_trajectory", "hidden_friction",
           "load_robot", "loop_payload", "median_ratio", "payload_figures", "plot", "summarize", "truth_errors"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
