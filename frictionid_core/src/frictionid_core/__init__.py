"""frictionid_core: joint friction identification for robot manipulators.

Pure Python (numpy/scipy); no ROS import anywhere in this package.

The public API::

    import frictionid_core as fid

    series = fid.load("bags/emps_estimation")                    # MAT, CSV, rosbag2, ROS 1 bag
    result = fid.identify(series, fid.IdentifyRequest(system="emps", friction="coulomb", solver="ls"))
    # a motor-side log: fid.IdentifyRequest(system="tx40", drive="tx40"); a saved one: fid.read_request("r.yaml")
    metrics = fid.validate(fid.load("bags/emps_validation"), result)
    tau = fid.FrictionModel("coulomb").torque([result.params["Fv"], result.params["Fc"]], [0.1, -0.1])

Also public: the parts of a request (``SolverOptions``, ``PreprocessingOverrides``, ``budget_field``,
``check_choice``), the
friction laws (``FRICTIONS``, ``get_model``), a drive (``Drive``, ``friction_rows``: who owns a result's
friction parameters) and result files (``read_result``: an identification result, every key checked;
``read_json``, ``write_json``, ``YAML_SUFFIXES``). Subpackages
export their own names (``frictionid_core.io``, ``.systems``, ``.loop``, ``.optim``, ``.robots``, ``.cli``):
a module that is not a package is private.

Importing the package is light (the errors only): every other public name is loaded on first
use (PEP 562), so ``import frictionid_core`` pulls in neither scipy nor numba nor an optimiser.
"""

from frictionid_core import lazy
from frictionid_core.errors import FrictionIdError, InputError, OptimError

__version__ = "0.1.0"

# Lazily loaded public names -> the module that defines them.
_LAZY = {
    "load": "frictionid_core.io",
    "load_drive": "frictionid_core.drive",
    "Drive": "frictionid_core.drive",
    "friction_rows": "frictionid_core.drive",
    "identify": "frictionid_core.identification",
    "validate": "frictionid_core.identification",
    "IdentifyRequest": "frictionid_core.identification",
    "IdentifyResult": "frictionid_core.identification",
    "SolverOptions": "frictionid_core.identification",
    "PreprocessingOverrides": "frictionid_core.identification",
    "read_request": "frictionid_core.identification",
    "read_result": "frictionid_core.identification",
    "FrictionModel": "frictionid_core.friction",
    "FRICTIONS": "frictionid_core.friction",
    "get_model": "frictionid_core.friction",
    "JointSeries": "frictionid_core.timeseries",
    "budget_field": "frictionid_core.identification",
    "check_choice": "frictionid_core.errors",
    "read_json": "frictionid_core.files",
    "write_json": "frictionid_core.files",
    "YAML_SUFFIXES": "frictionid_core.files",
}

__all__ = ["FRICTIONS", "YAML_SUFFIXES", "Drive", "FrictionIdError", "FrictionModel", "IdentifyRequest",
           "IdentifyResult", "InputError", "JointSeries", "OptimError", "PreprocessingOverrides", "SolverOptions",
           "budget_field", "check_choice", "friction_rows", "get_model", "identify", "load", "load_drive",
           "read_json", "read_request", "read_result", "validate", "write_json"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
