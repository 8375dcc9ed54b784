"""No public function of frictionid_core silently swallows a keyword it does not know (in the
spirit of python-control's kwargs_test): every public function and method of ``frictionid_core``
and of its subpackages' ``__all__`` takes its keywords by name, or is listed in ALLOWED with the
reason and a call with a misspelt keyword that must fail."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import frictionid_core
from frictionid_core.errors import FrictionIdError


def _minimize_with_a_typo():
    from frictionid_core.optim import Problem, minimize

    problem = Problem(["a"], [0.0], [1.0], lambda p: (p[:, 0] - 0.5) ** 2)
    minimize(problem, "de", generations=2, popsize=5)  # de's option is pop


# "module.qualname" → (why it takes **keywords, a call with an unknown keyword that must raise)
ALLOWED = {
    "frictionid_core.optim.suite.minimize": (
        "the method's own options (e.g. F for de, topology for pso), checked against that method's "
        "solve signature before it runs", _minimize_with_a_typo),
}


def _public_packages():
    yield frictionid_core
    for info in pkgutil.iter_modules(frictionid_core.__path__):
        if info.ispkg:
            yield importlib.import_module(f"frictionid_core.{info.name}")


def _callables(obj, name: str):
    """(qualified name, function) of ``obj`` and, for a class, of its own public methods."""
    if inspect.isclass(obj):
        for attr, value in vars(obj).items():
            if attr == "__init__" or not attr.startswith("_"):
                func = value.__func__ if isinstance(value, (classmethod, staticmethod)) else value
                if inspect.isfunction(func):
                    yield f"{obj.__module__}.{obj.__qualname__}.{attr}", func
    elif inspect.isfunction(obj):
        yield f"{obj.__module__}.{obj.__qualname__}", inspect.unwrap(obj)


def public_functions() -> dict:
    found = {}
    for package in _public_packages():
        for name in getattr(package, "__all__", ()):
            obj = getattr(package, name)
            if getattr(obj, "__module__", "").startswith("frictionid_core"):
                found.update(_callables(obj, name))
    return found


def test_the_walk_sees_the_public_api():
    names = public_functions()
    for expected in ("frictionid_core.identification.orchestration.identify",
                     "frictionid_core.identification.validation.validate",
                     "frictionid_core.identification.request.IdentifyRequest.from_dict",
                     "frictionid_core.io.loader.load", "frictionid_core.optim.suite.minimize"):
        assert expected in names, expected
    assert len(names) > 40


def test_no_public_function_swallows_unknown_keywords():
    catch_all = sorted(name for name, func in public_functions().items()
                       if any(p.kind is p.VAR_KEYWORD for p in inspect.signature(func).parameters.values()))
    assert catch_all == sorted(ALLOWED), "**keywords not validated: list each in ALLOWED with why, or name them"


@pytest.mark.parametrize("name", sorted(ALLOWED))
def test_allowed_keywords_are_checked(name):
    _, call = ALLOWED[name]
    with pytest.raises((FrictionIdError, TypeError), match="popsize"):
        call()


def test_identify_refuses_the_keywords_of_its_former_signature(synthetic):
    from frictionid_core.identification import IdentifyRequest, identify

    with pytest.raises(TypeError, match="friction"):
        identify(synthetic(), friction="tustin")
    with pytest.raises(FrictionIdError, match="IdentifyRequest, got dict"):
        identify(synthetic(), {"friction": "tustin"})
    with pytest.raises(TypeError, match="popsize"):
        IdentifyRequest(popsize=5)
