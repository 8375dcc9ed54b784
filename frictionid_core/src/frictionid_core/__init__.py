"""frictionid_core: joint friction identification for robot manipulators.

Pure Python (numpy/scipy); no ROS import anywhere in this package.
"""

from frictionid_core.errors import FrictionIdError, InputError, OptimError

__all__ = ["FrictionIdError", "InputError", "JointSeries", "OptimError"]
__version__ = "0.1.0"


def __getattr__(name: str):
    """``JointSeries`` on first use: importing the package (and the CLI) stays free of numpy."""
    if name == "JointSeries":
        from frictionid_core.timeseries import JointSeries

        return JointSeries
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
