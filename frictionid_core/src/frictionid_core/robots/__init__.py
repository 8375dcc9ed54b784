"""Manipulators on Pinocchio: models, base parameters, excitation, synthetic data, checks.

* :mod:`~frictionid_core.robots.robot_model` — :class:`RobotModel` (any fixed-base URDF via
  :func:`load_urdf`), inverse dynamics, the standard-parameter regressor (+ rotor inertias).
* :mod:`~frictionid_core.robots.tx40` — the Stäubli TX40 of docs/reference.md#tx40 (:func:`build_tx40`) and
  the thesis joint-2 model equivalents.
* :mod:`~frictionid_core.robots.base` — base parameters by QR with column pivoting, the
  excitation (rank) test naming unidentifiable parameters. The identification systems
  ``tx40`` and ``urdf:PATH`` built on them are in :mod:`frictionid_core.systems.robot`.
* :mod:`~frictionid_core.robots.excitation` — Fourier excitation optimised for the condition
  number (``frictionid excite``).
* :mod:`~frictionid_core.robots.synth` — synthetic JointState data (``frictionid synth``).
* :mod:`~frictionid_core.robots.consistency_check` — physical consistency of identified base
  parameters (``frictionid consistency``).
* :mod:`~frictionid_core.robots.compare` — results vs ground truth and the noise floor
  (``frictionid compare``).
* :mod:`~frictionid_core.robots.payload` — a payload fixed to a link (:class:`Payload`, the model
  with it: :func:`robot_with_payload`); its identification is ``frictionid payload``.

Pinocchio is imported only when a robot model is built.
"""

from frictionid_core.robots.payload import Payload, default_link, robot_with_payload
from frictionid_core.robots.robot_model import RobotModel, example_robot_data_dir, load_urdf

__all__ = ["Payload", "RobotModel", "default_link", "example_robot_data_dir", "load_urdf", "robot_with_payload"]
