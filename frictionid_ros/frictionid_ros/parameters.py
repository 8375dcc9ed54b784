"""Every node parameter, declared once: the parameter table, the validated :class:`Config`, the
declaration on ROS and the docs (no ROS import when loaded: rclpy is imported by the functions that
declare the parameters on a node).

Every node parameter is a field of :class:`Config` whose metadata holds its :class:`Parameter`:
default (its type is the ROS type), unit, description, range or choices, read-only flag and parser;
:data:`PARAMETERS` is the table of them. From these declarations

* :func:`make_config` validates a set of values: a bad value is a
  :class:`~frictionid_core.FrictionIdError` with one line naming the parameter, reported at startup;
* :func:`declare_parameters` declares the ROS parameters, each with a descriptor (``ros2 param
  describe``): its description and unit, read-only flag, allowed values as text and, for a bounded
  number, an rclpy ``IntegerRange`` or ``FloatingPointRange``, so rclpy itself refuses a value
  outside. Runtime changes go through the same validation (:func:`changed_config`);
* :func:`defaults_yaml` and :func:`markdown_table` write the defaults file ``config/frictionid.yaml``
  and the parameter table of ``docs/node.md`` (tests check both agree with the declarations)::

    python -m frictionid_ros.parameters      # rewrite both after changing a declaration
"""

from __future__ import annotations

import json
import math
import os
import sys
import textwrap
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from frictionid_core import FRICTIONS, Drive, FrictionIdError, IdentifyRequest, budget_field, check_choice, load_drive
from frictionid_core.io import MIN_SAMPLES
from frictionid_core.optim import SOLVERS
from frictionid_ros.joint_names import name_problem, shown_names
from frictionid_ros.runtime import parse_priority

if TYPE_CHECKING:
    from rcl_interfaces.msg import ParameterDescriptor
    from rclpy.node import Node
    from rclpy.parameter import Parameter as RosParameter

NODE_NAME = "frictionid"

# ROS name → IdentifyRequest field (dotted: nested), for the parameters and the ~/identify request (other
# names agree; ``budget`` is solver.generations or solver.calls, by the solver).
CORE_NAMES = {"friction_model": "friction", "solver": "solver.method", "seed": "solver.seed",
              "population": "solver.pop"}

@dataclass(frozen=True)
class Parameter:
    """The declaration of one node parameter.

    ``default``'s type is the ROS type (bool, int, float, str; a list: a string array); ``unit``: the
    unit of a number ("s", "Hz", "%"), shown after the description. A number may have bounds
    ``low``/``high`` (inclusive; both exclusive with ``exclusive``), a string ``choices``.
    ``parse(value, where)`` turns a value into the :class:`Config` field, raising FrictionIdError that
    starts with ``where`` (by default :meth:`config_value`: the default's type, then the bounds or choices).
    ``dynamic_typing``: a value of any type (``parse`` decides); ``constraints``: the rule as text
    when it is not a range or choices.
    """

    default: bool | int | float | str | list
    description: str
    unit: str = ""
    low: int | float | None = None
    high: int | float | None = None
    exclusive: bool = False
    choices: tuple[str, ...] = ()
    read_only: bool = True
    parse: Callable[[Any, str], Any] | None = None
    dynamic_typing: bool = False
    constraints: str = ""

    @property
    def rule(self) -> str:
        """The allowed values as text ("> 0", "0..19", "(0, 1)", "one of a, b"); empty: any value of the type."""
        if self.choices:
            return f"one of {', '.join(self.choices)}"
        low, high = self.low, self.high
        if low is not None and high is not None:
            if self.exclusive:
                return f"({low:g}, {high:g})"
            return f"{low}..{high}" if isinstance(self.default, int) else f"[{low:g}, {high:g}]"
        if low is not None:
            return f"{'>' if self.exclusive else '>='} {low:g}"
        if high is not None:
            return f"{'<' if self.exclusive else '<='} {high:g}"
        return self.constraints

    def config_value(self, name: str, raw: Any) -> Any:
        """The :class:`Config` value of ``raw`` (a value of parameter ``name``), checked."""
        where = f"parameter '{name}'"
        if self.parse is not None:
            return self.parse(raw, where)
        kind = type(self.default)
        try:
            value = kind(raw)
        except (TypeError, ValueError, OverflowError):
            raise FrictionIdError(f"{where} must be a {kind.__name__}, got {raw!r}") from None
        if self.choices:
            return check_choice(where, value, self.choices, name.replace("_", " "))
        if not self._in_range(value):
            verb = "lie in" if self.low is not None and self.high is not None else "be"
            raise FrictionIdError(f"{where} must {verb} {self.rule}, got {raw}")
        if kind is float and not math.isfinite(value):
            raise FrictionIdError(f"{where} must be a finite number, got {raw}")
        return value

    def _in_range(self, value: float) -> bool:
        """``value`` within the bounds (NaN never is)."""
        if self.low is not None and not (value > self.low if self.exclusive else value >= self.low):
            return False
        return self.high is None or (value < self.high if self.exclusive else value <= self.high)


def parameter(default, description: str, **declaration) -> Any:
    """A :class:`Config` field that is the node parameter declared by these arguments (:class:`Parameter`)."""
    return field(metadata={"parameter": Parameter(default, description, **declaration)})


def solve_options(where: str, base: IdentifyRequest | None = None, **fields) -> IdentifyRequest:
    """``base`` (default: the core's defaults) with ROS-named ``fields`` (system, friction_model,
    asymmetric, solver, seed, budget, population, …) over it, validated by the core's request
    parser; an error names the ROS field (``{where} 'friction_model': …``)."""
    values = base.to_dict() if base is not None else {}
    names = {}
    for ros, value in fields.items():
        path = CORE_NAMES.get(ros, ros)
        if ros == "budget":
            path = "solver." + budget_field(fields.get("solver") or (values.get("solver") or {}).get("method", "ls"))
        names[path] = ros
        part, _, key = path.rpartition(".")
        if part:
            values[part] = {**(values.get(part) or {}), key: value}
        else:
            values[key] = value
    return IdentifyRequest.from_dict(values, where=where, names=names)


def check_system(name: str) -> str:
    """``name`` if it is an inverse dynamic model of the core (``emps``, ``friction-only``,
    ``tx40-j2``, ``tx40``, ``urdf:PATH`` — the URDF must load), else a clear error."""
    from frictionid_core.systems import get_system

    try:
        get_system(name)
    except FrictionIdError as exc:
        raise FrictionIdError(f"parameter 'system': {exc}") from None
    return name


def _robot_system(name: str) -> bool:
    """True when the (checked) system ``name`` has body parameters (tx40, urdf:PATH)."""
    from frictionid_core.systems import get_system

    return get_system(name).robot is not None


def _drive(path_or_name: str) -> Drive | None:
    """The drive of parameter ``drive_file`` (a YAML file or a bundled name), None when empty."""
    if not path_or_name:
        return None
    try:
        return load_drive(path_or_name)
    except FrictionIdError as exc:
        raise FrictionIdError(f"parameter 'drive_file': {exc}") from None


def _joint_names(value, where: str) -> tuple[str, ...]:

    joints = tuple(str(j) for j in value if str(j))
    if len(set(joints)) != len(joints):
        raise FrictionIdError(f"{where}: duplicated names in {shown_names(joints)}")
    problem = name_problem(joints) if joints else ""
    if problem:
        raise FrictionIdError(f"{where}: {problem}")
    return joints


def _absolute_path(value, where: str) -> Path | None:
    """The absolute path of ``value`` (``~`` expanded); None when empty."""
    return Path(os.path.expanduser(str(value))).absolute() if value else None


# The identification limits and every parameter naming a file or folder (system urdf:PATH,
# results_file, results_dir) are read-only: set at start-up, never by a client at runtime.
@dataclass(frozen=True)
class Config:
    """Validated node settings: one field per node parameter (its declaration in the field's metadata,
    see :data:`PARAMETERS`), then ``drive``, loaded from ``drive_file``."""

    joints: tuple[str, ...] = parameter(
        [], "joint names to buffer, identify and feed forward, in this order (empty: the names of the first "
        "joint_states message)", parse=_joint_names)
    system: str = parameter(
        "emps", "inverse dynamic model: emps | joint | friction-only | tx40-j2 | tx40 | urdf:PATH (a URDF file)",
        parse=lambda value, where: check_system(str(value)))
    friction_model: str = parameter("coulomb", "default friction model", choices=FRICTIONS, read_only=False)
    asymmetric: bool = parameter(False, "default: separate parameters for v > 0 and v < 0", read_only=False)
    solver: str = parameter("ls", "default solver", choices=SOLVERS, read_only=False)
    seed: int = parameter(0, "default RNG seed of stochastic solvers", read_only=False)
    consistent: bool = parameter(
        False, "robot systems (tx40, urdf:PATH): every identification estimates physically consistent parameters "
        "(frictionid identify --consistent)", read_only=False)
    prior_weight: float = parameter(
        0.0, "with consistent: weight of the log-det pull of every link toward the URDF inertials (identify "
        "--prior urdf --prior-weight); 0 = none (what the data do not determine is held at the URDF's either way)",
        low=0.0, read_only=False)
    input_executor: str = parameter(
        "events", "executor of the input callbacks: events (rclpy EventsExecutor, lighter) | single_threaded "
        "(SingleThreadedExecutor: latency measured from middleware receipt)", choices=("events", "single_threaded"))
    identification_worker: str = parameter(
        "process", "where identifications run: process (a child process: the input callbacks keep the GIL) | "
        "thread", choices=("process", "thread"))
    buffer_seconds: float = parameter(30.0, "length of the joint-state ring buffer", unit="s", low=0.0,
                                      exclusive=True)
    max_rate_hz: float = parameter(
        1000.0, "highest expected joint_states rate; sizes the ring buffer (capacity = buffer_seconds * "
        "max_rate_hz samples)", unit="Hz", low=0.0, exclusive=True)
    window_seconds: float = parameter(0.0, "default identification window; 0 = the whole buffer", unit="s",
                                      low=0.0, read_only=False)
    min_samples: int = parameter(200, "fewest joint-state samples an identification accepts", low=MIN_SAMPLES,
                                 read_only=False)
    max_missing_pct: float = parameter(5.0, "refuse a window whose stamps show more than this share of lost "
                                       "samples", unit="%", low=0.0, read_only=False)
    filter_cutoff_hz: float = parameter(0.0, "Butterworth cut-off on position; 0 = the system's default",
                                        unit="Hz", low=0.0)
    decimation: int = parameter(0, "keep 1 sample of n after the anti-alias filter; 0 = the system's default",
                                low=0)
    drive_file: str = parameter(
        "", "drive model between joint_states and the model's joints (gear ratios, coupling, effort units, "
        "friction on joints or motors): a YAML file or a bundled name (tx40); read at start; empty = none "
        "(joint-side data in N·m)")
    joint_states_topic: str = parameter("joint_states", "sensor_msgs/JointState input topic")
    qos: str = parameter("sensor_data", "QoS of the input topics: sensor_data (best effort) | reliable",
                         choices=("sensor_data", "reliable"))
    qos_depth: int = parameter(100, "history depth of the input subscriptions", unit="messages", low=1,
                               high=100_000)
    effort_topic: str = parameter("", "separate effort topic; empty = the JointState effort field")
    effort_topic_type: str = parameter("joint_state", "type of effort_topic",
                                       choices=("joint_state", "float64_multi_array"))
    velocity_source: str = parameter(
        "measured", "feed-forward velocity: measured (joint_states velocity, else finite difference of "
        "positions) | reference (reference_topic)", choices=("measured", "reference"))
    reference_topic: str = parameter("reference_joint_states", "desired/reference sensor_msgs/JointState topic "
                                     "(velocity_source = reference)")
    feedforward_rate_hz: float = parameter(0.0, "feed-forward publish rate; 0 = on every velocity-source message",
                                           unit="Hz", low=0.0, high=10_000.0)
    smoothing_eps: float = parameter(0.01, "sign smoothing tanh(v/eps) of the feed-forward; 0 = sign(v)",
                                     unit="rad/s | m/s", low=0.0, high=1.0, read_only=False)
    results_file: Path = parameter(
        "~/.ros/frictionid/parameters.json", "JSON file of the active parameters: written after each "
        "identification, read at start", parse=_absolute_path)
    results_dir: Path = parameter("", "the only folder ~/save and ~/load may use; empty = the folder of "
                                  "results_file", parse=_absolute_path)
    max_budget: int = parameter(1000, "largest budget a request may ask for", unit="generations | cost calls",
                                low=1)
    max_population: int = parameter(200, "largest population a request may ask for", low=1)
    max_window_seconds: float = parameter(60.0, "longest data window of an identification", unit="s", low=0.0,
                                          exclusive=True)
    max_wall_s: float = parameter(120.0, "wall time after which an identification is stopped", unit="s",
                                  low=0.0, exclusive=True)
    worker_nice: int = parameter(19, "niceness of the identification worker process (19: the feed-forward path "
                                 "gets the CPU first)", low=0, high=19)
    realtime_priority: int | str = parameter(
        "auto", "scheduling of the input/feed-forward thread, as ros2_control runs its loop: auto (SCHED_FIFO 10 "
        "if the OS allows, else normal) | off | a SCHED_FIFO priority 1..99 (refused by the OS: normal "
        "scheduling and a warning); a string or an integer", dynamic_typing=True, constraints="auto, off or 0..99",
        parse=parse_priority)
    diagnostics_period_s: float = parameter(1.0, "period of /diagnostics", unit="s", low=0.0, exclusive=True)
    known_rigid_body: bool = parameter(
        False, "robot systems (tx40, urdf:PATH): keep the model's links (the controller's rigid-body model) and "
        "identify the rotor inertias (armature, ≥ 0), friction and offsets (the request field known_rigid_body)")
    online_period_s: float = parameter(
        0.0, "online re-identification: every this long, identify the last online_window_s and activate the "
        "result only if the safety gate accepts it; 0 = off (~/load is then not gated either)", unit="s", low=0.0)
    online_window_s: float = parameter(10.0, "data window of an online re-identification", unit="s", low=0.0,
                                       exclusive=True)
    online_holdout: float = parameter(0.25, "share of the online window held back (its newest samples) for the "
                                      "safety gate", low=0.0, high=1.0, exclusive=True)
    gate_max_abs: float = parameter(
        1000.0, "the safety screen refuses every parameter set (identification, ~/load, results_file, online "
        "candidate) with a parameter larger than this in magnitude", unit="SI units", low=0.0, high=1e9,
        exclusive=True)
    feedforward_max: float = parameter(
        100.0, "clamp of the feed-forward: each joint's torque stays within ±min(feedforward_max, the joint's effort "
        "limit: the URDF's, else that of the data its parameters were identified on); also the effort limit of the "
        "safety screen for parameters without either", unit="N·m | N", low=0.0, high=1e6, exclusive=True)
    feedforward_ramp_s: float = parameter(0.0, "new parameters blend in over this long (feed-forward rate "
                                          "limit); 0 = at once", unit="s", low=0.0, high=600.0)
    unique_name: bool = parameter(
        True, "refuse to start when another node of this name and namespace is on the ROS graph (looked for "
        "during the first seconds, as discovery takes a moment); false: allow several")
    drive: Drive | None  # loaded from drive_file at start

    @property
    def solve(self) -> IdentifyRequest:
        """The defaults of ~/identify: system, friction_model, asymmetric, solver, seed."""
        return solve_options("parameter", system=self.system, friction_model=self.friction_model,
                             asymmetric=self.asymmetric, solver=self.solver, seed=self.seed)

    @property
    def capacity(self) -> int:
        """Ring-buffer capacity [samples]."""
        return int(math.ceil(self.buffer_seconds * self.max_rate_hz)) + 1


# name → declaration, in the order of Config (and of the YAML file and the docs).
PARAMETERS: dict[str, Parameter] = {f.name: f.metadata["parameter"] for f in fields(Config) if f.metadata}


def make_config(values: dict) -> Config:
    """Validate raw parameter values (name → value; missing or None: the default) into a :class:`Config`."""
    settings = {name: p.config_value(name, p.default if values.get(name) is None else values[name])
                for name, p in PARAMETERS.items()}
    # The checks across parameters; each parameter's own are in its declaration.
    if settings["window_seconds"] > settings["max_window_seconds"]:
        raise FrictionIdError(f"parameter 'window_seconds' = {settings['window_seconds']} s is over the limit "
                              f"max_window_seconds = {settings['max_window_seconds']} s")
    samples = settings["buffer_seconds"] * settings["max_rate_hz"]
    if samples > 50_000_000:
        raise FrictionIdError(f"buffer_seconds * max_rate_hz = {samples:.0f} samples is too large (max 5e7)")
    if settings["velocity_source"] == "reference" and not settings["reference_topic"]:
        raise FrictionIdError("velocity_source 'reference' needs a reference_topic")
    if settings["consistent"] and not _robot_system(settings["system"]):
        raise FrictionIdError(f"parameter 'consistent' needs a robot system (tx40, urdf:PATH); system is "
                              f"'{settings['system']}'")
    settings["results_dir"] = settings["results_dir"] or settings["results_file"].parent
    config = Config(**settings, drive=_drive(settings["drive_file"]))
    config.solve  # noqa: B018 - the core's validation of the identification defaults, as for a request
    return config


# ----------------------------------------------------------------------------- on ROS
INT64 = (-(2**63), 2**63 - 1)  # the bounds of an integer parameter
# The parameters a client may change at runtime (the defaults of ~/identify and of the windows, smoothing_eps).
RUNTIME = tuple(name for name, p in PARAMETERS.items() if not p.read_only)


def descriptor(declaration: Parameter) -> ParameterDescriptor:
    """The ROS descriptor of a parameter's ``declaration``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
        from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

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
    from rclpy.exceptions import InvalidParameterValueException
    from rclpy.parameter import Parameter as RosParameter

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


# ----------------------------------------------------------------------------- written out
PACKAGE = Path(__file__).resolve().parents[1]  # the frictionid_ros source folder
YAML_FILE = PACKAGE / "config" / "frictionid.yaml"
PAGE = PACKAGE.parent / "docs" / "node.md"  # the node's page of the repository's docs
TABLE_START = "<!-- parameter table: written by python -m frictionid_ros.parameters -->"
TABLE_END = "<!-- end of the parameter table -->"

YAML_HEAD = """\
# Parameters of the frictionid node at their defaults (copy this file to set others), written from
# their declarations in frictionid_ros/parameters.py by `python -m frictionid_ros.parameters`.
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
