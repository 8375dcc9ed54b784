"""frictionid_core: joint friction identification for robot manipulators.

Pure Python (numpy/scipy); no ROS import anywhere in this package.

The public API::

    import frictionid_core as fid

    series = fid.load("bags/emps_estimation")                    # MAT, CSV, rosbag2, ROS 1 bag
    result = fid.identify(series, fid.IdentifyRequest(system="emps", friction="coulomb", solver="ls"))
    # a motor-side log: fid.IdentifyRequest(system="tx40", drive="tx40"); a saved one: fid.read_request("r.yaml")
    metrics = fid.validate(fid.load("bags/emps_validation"), result)
    tau = fid.FrictionModel("coulomb").torque([result.params["Fv"], result.params["Fc"]], [0.1, -0.1])

Importing the package is light (the errors only): every other public name is loaded on first
use (PEP 562), so ``import frictionid_core`` pulls in neither scipy nor numba nor an optimiser.
"""

import importlib as _importlib

from frictionid_core.errors import FrictionIdError, InputError, OptimError

__version__ = "0.1.0"

# Lazily loaded public names -> the module that defines them.
_LAZY = {
    "load": "frictionid_core.io",
    "load_drive": "frictionid_core.drive",
    "identify": "frictionid_core.identification",
    "validate": "frictionid_core.identification",
    "IdentifyRequest": "frictionid_core.identification",
    "IdentifyResult": "frictionid_core.identification",
    "SolverOptions": "frictionid_core.identification",
    "PreprocessingOverrides": "frictionid_core.identification",
    "read_request": "frictionid_core.identification",
    "FrictionModel": "frictionid_core.friction",
    "JointSeries": "frictionid_core.timeseries",
}

__all__ = ["FrictionIdError", "FrictionModel", "IdentifyRequest", "IdentifyResult", "InputError", "JointSeries",
           "OptimError", "PreprocessingOverrides", "SolverOptions", "identify", "load", "load_drive", "read_request",
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

