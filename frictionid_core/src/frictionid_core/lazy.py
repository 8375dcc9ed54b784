"""The one lazy-import mechanism: a package's public names loaded from their modules on first use
(PEP 562), so that importing a package (and ``frictionid --help``) stays light."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable


def attribute(module: str, name: str) -> object:
    """``module.name``, importing ``module`` now if it is not yet."""
    return getattr(importlib.import_module(module), name)


def lazy_names(package: str, names: dict[str, str]) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package``, whose lazily loaded public names
    ``names`` map to the module defining each (a name mapped to ``package.name`` itself is that
    submodule); a loaded name is kept in the package's namespace."""

    def __getattr__(name: str) -> object:
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        if module == f"{package}.{name}":
            value = importlib.import_module(module)
        else:
            value = attribute(module, name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return __getattr__, __dir__
