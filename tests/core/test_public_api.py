"""The public API of frictionid_core: names, docstrings, and a light import."""

import inspect
import subprocess
import sys
import types

import frictionid_core

PUBLIC = {"load", "identify", "validate", "FrictionModel", "JointSeries", "FrictionIdError", "InputError",
          "OptimError", "load_drive", "IdentifyRequest", "IdentifyResult", "SolverOptions", "PreprocessingOverrides",
          "read_request"}
# Modules a bare ``import frictionid_core`` must not load (the CLI's --help must stay fast).
HEAVY = ("numpy", "scipy", "numba", "sklearn", "skopt", "matplotlib", "rosbags", "pinocchio",
         "frictionid_core.optim", "frictionid_core.identification")


def test_all_lists_exactly_the_public_names():
    assert set(frictionid_core.__all__) == PUBLIC
    assert len(frictionid_core.__all__) == len(PUBLIC)
    exported = {n for n in dir(frictionid_core)
                if not n.startswith("_") and not isinstance(getattr(frictionid_core, n), types.ModuleType)}
    assert exported == PUBLIC


def test_every_public_name_has_a_docstring():
    for name in frictionid_core.__all__:
        obj = getattr(frictionid_core, name)
        doc = inspect.getdoc(obj)
        assert doc and len(doc.split()) >= 3, f"frictionid_core.{name} has no docstring"
        assert obj.__module__.startswith("frictionid_core."), name


def test_public_names_are_the_library_objects():
    from frictionid_core.drive import load_drive
    from frictionid_core.errors import FrictionIdError, InputError, OptimError
    from frictionid_core.friction import FrictionModel
    from frictionid_core.identification import (
        IdentifyRequest,
        IdentifyResult,
        PreprocessingOverrides,
        SolverOptions,
        identify,
        read_request,
        validate,
    )
    from frictionid_core.io import load
    from frictionid_core.timeseries import JointSeries

    expected = {"load": load, "identify": identify, "validate": validate, "FrictionModel": FrictionModel,
                "JointSeries": JointSeries, "FrictionIdError": FrictionIdError, "InputError": InputError,
                "OptimError": OptimError, "load_drive": load_drive, "IdentifyRequest": IdentifyRequest,
                "IdentifyResult": IdentifyResult, "SolverOptions": SolverOptions,
                "PreprocessingOverrides": PreprocessingOverrides, "read_request": read_request}
    for name, obj in expected.items():
        assert getattr(frictionid_core, name) is obj, name
    # The function lives in the submodule frictionid_core.identification: no name clash.
    assert frictionid_core.identify.__name__ == "identify"


def test_unknown_attribute_is_an_attribute_error():
    try:
        frictionid_core.no_such_name  # noqa: B018
    except AttributeError as exc:
        assert "no_such_name" in str(exc)
    else:
        raise AssertionError("no AttributeError")


def _fresh(code: str) -> str:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_import_is_light():
    loaded = _fresh("import sys, frictionid_core\n"
                    f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    assert loaded == "[]"


def test_identify_is_the_function_after_its_module_is_imported_first():
    # Any other module (the CLI, the node) may import frictionid_core.identification before a user
    # reads frictionid_core.identify: the package attribute is still the function.
    out = _fresh("import frictionid_core.identification, frictionid_core.cli\n"
                 "from frictionid_core import identify, validate\n"
                 "import frictionid_core as f\n"
                 "print(type(identify).__name__, type(f.identify).__name__, type(validate).__name__)")
    assert out == "function function function"
