"""The node's parameters written out from their declarations (:data:`.config.PARAMETERS`): the
defaults file ``config/frictionid.yaml`` and the parameter table of ``docs/node.md`` (no ROS import).

    python -m frictionid_ros.parameter_docs      # rewrite both after changing a declaration

Tests check that both files agree with the declarations.
"""

from __future__ import annotations

import json
import sys
import textwrap
from pathlib import Path

from frictionid_ros.parameters import PARAMETERS, Parameter

PACKAGE = Path(__file__).resolve().parents[1]  # the frictionid_ros source folder
YAML_FILE = PACKAGE / "config" / "frictionid.yaml"
PAGE = PACKAGE.parent / "docs" / "node.md"  # the node's page of the repository's docs
TABLE_START = "<!-- parameter table: written by python -m frictionid_ros.parameter_docs -->"
TABLE_END = "<!-- end of the parameter table -->"

YAML_HEAD = """\
# Parameters of the frictionid node at their defaults (copy this file to set others), written from
# their declarations in frictionid_ros/config.py by `python -m frictionid_ros.parameter_docs`.
#   python -m frictionid_ros.node --params-file config/frictionid.yaml
#   frictionid_node --ros-args --params-file config/frictionid.yaml
/**/frictionid:    # the node in any namespace (a bare "frictionid:" matches only "/frictionid")
  ros__parameters:
"""


def yaml_value(value) -> str:
    """``value`` as a YAML literal of its ROS type (``30.0`` stays a double, ``"0"`` a string)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (str, list)):
        return json.dumps(value, ensure_ascii=False)
    return repr(value)


def ros_type(p: Parameter) -> str:
    """The parameter's type as ``ros2 param`` shows it."""
    if p.dynamic_typing:
        return "string or integer"
    return {bool: "bool", int: "integer", float: "double", str: "string", list: "string array"}[type(p.default)]


def summary(p: Parameter) -> str:
    """One line: the description, the unit, the allowed values and whether a client may change it."""
    text = p.description + (f" [{p.unit}]" if p.unit else "")
    text += f"; allowed: {p.rule}" if p.rule else ""
    return text + ("" if p.read_only else "; may be changed at runtime")


def defaults_yaml() -> str:
    """The text of ``config/frictionid.yaml``: every parameter at its default, each after its summary."""
    lines = []
    for name, p in PARAMETERS.items():
        lines.append(textwrap.fill(summary(p), width=110, initial_indent="    # ", subsequent_indent="    # ",
                                   break_on_hyphens=False))
        if isinstance(p.default, list):  # rcl ignores an empty list: leave it unset or name the values
            lines.append(f'    # {name}: ["name_1", "name_2"]    (unset by default)')
        else:
            lines.append(f"    {name}: {yaml_value(p.default)}")
    return YAML_HEAD + "\n".join(lines) + "\n"


def markdown_table() -> str:
    """The markdown table of every parameter (between the markers of ``docs/node.md``)."""

    def cell(text: str) -> str:
        return text.replace("|", "\\|")

    rows = ["| parameter | type | default | unit | allowed | runtime | description |", "|---|---|---|---|---|---|---|"]
    for name, p in PARAMETERS.items():
        rows.append(f"| `{name}` | {ros_type(p)} | `{cell(yaml_value(p.default))}` | {cell(p.unit)} | "
                    f"{cell(p.rule)} | {'' if p.read_only else 'yes'} | {cell(p.description)} |")
    return "\n".join(rows) + "\n"


def page_with_table(page: str) -> str:
    """``page`` with the text between its table markers replaced by :func:`markdown_table`."""
    head, found, rest = page.partition(TABLE_START + "\n")
    _, found_end, tail = rest.partition(TABLE_END)
    if not found or not found_end:
        raise ValueError(f"{PAGE.name} has no '{TABLE_START}' ... '{TABLE_END}' section")
    return head + TABLE_START + "\n" + markdown_table() + TABLE_END + tail


def main() -> int:
    YAML_FILE.write_text(defaults_yaml(), encoding="utf-8")
    PAGE.write_text(page_with_table(PAGE.read_text(encoding="utf-8")), encoding="utf-8")
    print(f"wrote {YAML_FILE} and the parameter table of {PAGE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
