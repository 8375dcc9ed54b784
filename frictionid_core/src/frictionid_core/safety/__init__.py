"""The safety screen of every parameter set that can reach a robot (no ROS import): the node's
identification results, ``~/load``, ``results_file`` and online candidates, and ``frictionid export
--yaml`` pass :func:`screen_parameters` (or :func:`result_refusals`) against each joint's
:class:`Limit` (:func:`robot_limits`, :func:`data_limits`); see :mod:`.screen`. Each name is loaded
from its module on first use (PEP 562)."""

from frictionid_core import _lazy

__all__ = ["DATA_MARGIN", "Limit", "data_limits", "effort_sign_refusals", "explicit_bounds", "result_refusals",
           "robot_limits", "screen_parameters"]
_LAZY = dict.fromkeys(__all__, "frictionid_core.safety.screen")

__getattr__, __dir__ = _lazy.lazy_names(__name__, _LAZY)
