"""Manipulators on Pinocchio: models and base parameters.

* :mod:`.robot_model` — :class:`RobotModel` (any fixed-base URDF via :func:`load_urdf`), inverse
  dynamics, the standard-parameter regressor (+ rotor inertias).
* :mod:`.tx40` — the Stäubli TX40 of docs/reference.md#tx40 (:func:`build_tx40`) and the thesis
  joint-2 model equivalents (the module itself is public: ``robots.tx40``).
* :mod:`.base` — base parameters by QR with column pivoting, the excitation (rank) test.
* :mod:`.motor_side` — motor-side columns of a coupled drive.
* :mod:`.payload_model` — a payload fixed to a link (:class:`Payload`, the model with it).

Pinocchio is imported only when a robot model is built.
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "base_parameter_names", "random_samples", "restricted_base_parameters", "robot_base_parameters",
    ), "frictionid_core.robots.base"),
    **dict.fromkeys(("MotorSide",), "frictionid_core.robots.motor_side"),
    **dict.fromkeys((
        "body_quantities", "default_link", "frame_map", "INERTIA_ENTRIES", "link_frame", "link_name", "PAYLOAD",
        "Payload", "payload_link", "PAYLOAD_NAMES", "point_inertia", "QUANTITIES", "robot_with_payload",
        "with_payload",
    ), "frictionid_core.robots.payload_model"),
    **dict.fromkeys((
        "BODY_PARAMS", "example_robot_data_dir", "load_urdf", "RobotModel", "ROTOR_PARAM",
    ), "frictionid_core.robots.robot_model"),
    **dict.fromkeys(("build_tx40", "tx40"), "frictionid_core.robots.tx40"),
}

__all__ = ["BODY_PARAMS", "INERTIA_ENTRIES", "MotorSide", "PAYLOAD", "PAYLOAD_NAMES", "Payload", "QUANTITIES",
           "ROTOR_PARAM", "RobotModel", "base_parameter_names", "body_quantities", "build_tx40", "default_link",
           "example_robot_data_dir", "frame_map", "link_frame", "link_name", "load_urdf", "payload_link",
           "point_inertia", "random_samples", "restricted_base_parameters", "robot_base_parameters",
           "robot_with_payload", "tx40", "with_payload"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
