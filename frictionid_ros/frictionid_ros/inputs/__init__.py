"""The node's input path, without ROS: bounded ring buffers of joint samples and name maps
(:mod:`.buffer`), what the input callbacks do with a message (:mod:`.callbacks`) and the friction
feed-forward (:mod:`.feedforward`)."""

from frictionid_ros.inputs.buffer import (
    NO_EFFORT,
    NO_POSITION,
    NO_VELOCITY,
    NS,
    JointRing,
    NameMap,
    Window,
    stamp_ns,
)
from frictionid_ros.inputs.callbacks import Inputs
from frictionid_ros.inputs.feedforward import FeedForward

__all__ = ["NO_EFFORT", "NO_POSITION", "NO_VELOCITY", "NS", "FeedForward", "Inputs", "JointRing", "NameMap", "Window",
           "stamp_ns"]
