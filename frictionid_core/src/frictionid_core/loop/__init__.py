"""Friction compensation in the loop, without ROS: a MuJoCo-simulated arm with hidden friction
(:mod:`.sim`), a tracking controller (:mod:`.control`), the safety gate of online
re-identification (:mod:`.gate`) and the figures of a run (:mod:`.evaluate`). Each name is loaded
from its module on first use (PEP 562); MuJoCo and Pinocchio are imported when an arm is built."""

from frictionid_core import _lazy

_LAZY = {
    "SimArm": "frictionid_core.loop.sim",
    "hidden_friction": "frictionid_core.loop.sim",
    "load_robot": "frictionid_core.loop.sim",
    "loop_payload": "frictionid_core.loop.sim",
    "Controller": "frictionid_core.loop.control",
    "default_trajectory": "frictionid_core.loop.control",
    "Decision": "frictionid_core.loop.gate",
    "review": "frictionid_core.loop.gate",
    "screen": "frictionid_core.loop.gate",
    "median_ratio": "frictionid_core.loop.evaluate",
    "payload_figures": "frictionid_core.loop.evaluate",
    "plot": "frictionid_core.loop.evaluate",
    "summarize": "frictionid_core.loop.evaluate",
}

__all__ = ["Controller", "Decision", "SimArm", "default_trajectory", "hidden_friction", "load_robot", "loop_payload",
           "median_ratio", "payload_figures", "plot", "review", "screen", "summarize"]

__getattr__, __dir__ = _lazy.lazy_names(__name__, _LAZY)
