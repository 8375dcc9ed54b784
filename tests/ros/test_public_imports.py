"""The ROS package uses the core through its public names only: ``from frictionid_core import NAME``
with NAME in ``frictionid_core.__all__``, or ``from frictionid_core.<package> import NAME`` with NAME
in that subpackage's ``__all__``; a core module that is not a package is private."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

ROS_PACKAGE = Path(__file__).resolve().parents[2] / "frictionid_ros" / "frictionid_ros"


def private_core_imports(source: str) -> list[str]:
    """The imports of ``source`` that reach into the core past its public names."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [alias.name for alias in node.names
                      if alias.name.startswith("frictionid_core.")]  # import frictionid_core.x: a module's inside
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("frictionid_core"):
            module = importlib.import_module(node.module)
            public = getattr(module, "__all__", []) if hasattr(module, "__path__") else []
            found += [f"from {node.module} import {alias.name}" for alias in node.names if alias.name not in public]
    return found


def test_the_ros_package_imports_only_public_core_names():
    modules = sorted(ROS_PACKAGE.rglob("*.py"))
    assert len(modules) >= 20
    private = {str(path.relative_to(ROS_PACKAGE)): names for path in modules
               if (names := private_core_imports(path.read_text()))}
    assert private == {}


def test_the_rule_refuses_private_modules_and_names():
    source = ("import frictionid_core\nfrom frictionid_core import FrictionIdError\n"
              "from frictionid_core.io import check_series\nfrom frictionid_core.io.checks import stamp_gaps\n"
              "from frictionid_core.files.writing import write_json\nfrom frictionid_core.systems import registry\n"
              "def f():\n    import frictionid_core.friction\n    from frictionid_core import _lazy\n")
    assert private_core_imports(source) == ["from frictionid_core.io.checks import stamp_gaps",
                                            "from frictionid_core.files.writing import write_json",
                                            "from frictionid_core.systems import registry", "frictionid_core.friction",
                                            "from frictionid_core import _lazy"]
