"""frictionid_core: joint friction identification for robot manipulators.

Pure Python (numpy/scipy); no ROS import anywhere in this package.
"""

from frictionid_core.errors import FrictionIdError, InputError, OptimError
from frictionid_core.timeseries import JointSeries

__all__ = ["FrictionIdError", "InputError", "JointSeries", "OptimError"]
__version__ = "0.1.0"
