"""The node's parameters on ROS, from their declarations in :mod:`.config`.

Each is declared with a descriptor (``ros2 param describe``): its description and unit, read-only
flag, allowed values as text and, for a bounded number, an rclpy ``IntegerRange`` or
``FloatingPointRange``, so rclpy itself refuses a value outside. Runtime changes go through the
same validation (:func:`changed_config`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
    from rclpy.exceptions import InvalidParameterValueException
    from rclpy.node import Node
    from rclpy.parameter import Parameter as RosParameter

from frictionid_core import FrictionIdError
from frictionid_ros.parameters import PARAMETERS, Config, Parameter, make_config

INT64 = (-(2**63), 2**63 - 1)  # the bounds of an integer parameter
# The parameters a client may change at runtime (the defaults of ~/identify and of the windows, smoothing_eps).
RUNTIME = tuple(name for name, p in PARAMETERS.items() if not p.read_only)


def descriptor(declaration: Parameter) -> ParameterDescriptor:
    """The ROS descriptor of a parameter's ``declaration``."""
    p = declaration
    d = ParameterDescriptor(description=p.description + (f" [{p.unit}]" if p.unit else ""), read_only=p.read_only,
                            dynamic_typing=p.dynamic_typing, additional_constraints=p.rule)
    if (p.low is None and p.high is None) or isinstance(p.default, bool):
        return d
    if isinstance(p.default, int):
        low, high = INT64
        d.integer_range = [IntegerRange(from_value=low if p.low is None else p.low,
                                        to_value=high if p.high is None else p.high, step=1)]
    else:
        d.floating_point_range = [FloatingPointRange(from_value=-math.inf if p.low is None else float(p.low),
                                                     to_value=math.inf if p.high is None else float(p.high))]
    return d


def declare_parameters(node: Node) -> Config:
    """Declare every node parameter on ``node``; their values validated. FrictionIdError: one line naming
    the parameter at fault."""
    values = {}
    for name, p in PARAMETERS.items():
        d = descriptor(p)
        default = RosParameter.Type.STRING_ARRAY if isinstance(p.default, list) else p.default  # [] has no type
        try:
            values[name] = node.declare_parameter(name, default, d).value
        except InvalidParameterValueException as exc:  # outside the range: the declaration's own message
            d.integer_range, d.floating_point_range = [], []
            p.config_value(name, node.declare_parameter(name, default, d).value)
            raise FrictionIdError(f"parameter '{name}': {exc}") from None
        except Exception as exc:  # e.g. InvalidParameterTypeException for "30" where 30.0 is expected
            raise FrictionIdError(f"parameter '{name}': {exc} (default {p.default!r}: "
                                  f"{type(p.default).__name__})") from None
    return make_config(values)


def changed_config(node: Node, cfg: Config, changes: list[RosParameter]) -> Config:
    """``cfg`` with the runtime parameters set to ``node``'s values updated by ``changes`` (an
    ``on_set_parameters`` callback's list), all checked together; FrictionIdError if refused."""
    values = {name: node.get_parameter_or(name).value for name in PARAMETERS}  # unset joints: None (the default)
    new = make_config({**values, **{p.name: p.value for p in changes}})
    return replace(cfg, **{name: getattr(new, name) for name in RUNTIME})
