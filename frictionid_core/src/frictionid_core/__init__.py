"""frictionid_core: joint friction identification for robot manipulators.

Pure Python (numpy/scipy); no ROS import anywhere in this package.

The public API::

    import frictionid_core as fid

    series = fid.load("bags/emps_estimation")                    # MAT, CSV, rosbag2, ROS 1 bag
    result = fid.identify(series, system="emps", friction="coulomb", solver="ls")
    metrics = fid.validate(fid.load("bags/emps_validation"), result.to_dict())
    tau = fid.FrictionModel("coulomb").torque([result.params["Fv"], result.params["Fc"]], [0.1, -0.1])

Importing the package is light (the errors only): every other public name is loaded on first
use (PEP 562), so ``import frictionid_core`` pulls in neither scipy nor numba nor an optimiser.
"""

import importlib as _importlib
import sys as _sys
import types as _types

from frictionid_core.errors import FrictionIdError, InputError, OptimError

__version__ = "0.1.0"

# Lazily loaded public names -> the module that defines them.
_LAZY = {
    "load": "frictionid_core.io",
    "identify": "frictionid_core.identify",
    "validate": "frictionid_core.identify",
    "FrictionModel": "frictionid_core.friction",
    "JointSeries": "frictionid_core.timeseries",
}

__all__ = ["FrictionIdError", "FrictionModel", "InputError", "JointSeries", "OptimError", "identify", "load",
           "validate"]


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(_importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _Package(_types.ModuleType):
    """The package's module type: importing the submodule ``frictionid_core.identify`` must not
    replace the public function ``frictionid_core.identify`` of the same name (the import system
    sets every loaded submodule as an attribute of its package)."""

    def __setattr__(self, name: str, value) -> None:
        if isinstance(value, _types.ModuleType) and name in _LAZY:
            return
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package
