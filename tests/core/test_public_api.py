"""The public API of frictionid_core: names, docstrings, and a light import."""

import inspect
import subprocess
import sys
import types

import frictionid_core

PUBLIC = {"load", "identify", "validate", "FrictionModel", "JointSeries", "FrictionIdError", "InputError",
          "OptimError", "load_drive", "Drive", "friction_rows", "FRICTIONS", "get_model", "check_choice",
          "read_json", "write_json", "YAML_SUFFIXES", "IdentifyRequest", "IdentifyResult", "SolverOptions",
          "PreprocessingOverrides", "read_request", "read_result", "budget_field"}
CONSTANTS = {"FRICTIONS", "YAML_SUFFIXES"}  # documented in the package docstring
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
    for name in CONSTANTS:
        assert f"``{name}``" in frictionid_core.__doc__, name
    for name in set(frictionid_core.__all__) - CONSTANTS:
        obj = getattr(frictionid_core, name)
        doc = inspect.getdoc(obj)
        assert doc and len(doc.split()) >= 3, f"frictionid_core.{name} has no docstring"
        assert obj.__module__.startswith("frictionid_core."), name


def test_public_names_are_the_library_objects():
    from frictionid_core.drive import Drive, friction_rows, load_drive
    from frictionid_core.errors import FrictionIdError, InputError, OptimError, check_choice
    from frictionid_core.files import YAML_SUFFIXES, read_json, write_json
    from frictionid_core.friction import FRICTIONS, FrictionModel, get_model
    from frictionid_core.identification import (
        IdentifyRequest,
        IdentifyResult,
        PreprocessingOverrides,
        SolverOptions,
        budget_field,
        identify,
        read_request,
        validate,
    )
    from frictionid_core.io import load
    from frictionid_core.timeseries import JointSeries

    expected = {"load": load, "identify": identify, "validate": validate, "FrictionModel": FrictionModel,
                "JointSeries": JointSeries, "FrictionIdError": FrictionIdError, "InputError": InputError,
                "OptimError": OptimError, "load_drive": load_drive, "Drive": Drive, "friction_rows": friction_rows,
                "FRICTIONS": FRICTIONS, "get_model": get_model, "check_choice": check_choice, "read_json": read_json,
                "write_json": write_json, "YAML_SUFFIXES": YAML_SUFFIXES, "IdentifyRequest": IdentifyRequest,
                "IdentifyResult": IdentifyResult, "SolverOptions": SolverOptions,
                "PreprocessingOverrides": PreprocessingOverrides, "read_request": read_request,
                "budget_field": budget_field}
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


def test_subpackage_faces_export_their_names():
    """Every name in a subpackage's ``__all__`` is there (the lazily loaded ones of ``loop`` too), and
    importing ``frictionid_core.loop`` loads none of its modules."""
    loaded = _fresh("import sys, frictionid_core.loop\n"
                    "print(sorted(m for m in sys.modules if m.startswith('frictionid_core.loop.') or m == 'numpy'))")
    assert loaded == "[]"
    import importlib

    for package in ("io", "loop", "optim", "robots", "systems", "cli"):
        module = importlib.import_module(f"frictionid_core.{package}")
        assert module.__all__, package
        for name in module.__all__:
            assert getattr(module, name) is not None, f"frictionid_core.{package}.{name}"
