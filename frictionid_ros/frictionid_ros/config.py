"""Node parameters: names, defaults, descriptions and validation (no ROS import).

The defaults here are the values of ``config/frictionid.yaml`` (a test checks that they agree).
The node declares every parameter with a descriptor built from :data:`PARAMETERS` and turns the
values into a validated :class:`Config`; a bad value is a :class:`~frictionid_core.errors.FrictionIdError`
with one clear line, reported at startup.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

from frictionid_core.drive import Drive, load_drive
from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import FRICTIONS
from frictionid_core.identification import IdentifyRequest, budget_field
from frictionid_core.optim import SOLVERS
from frictionid_core.options import check_choice

from frictionid_ros.realtime import parse_priority

NODE_NAME = "frictionid"

# ROS name → IdentifyRequest field (dotted: nested), for the parameters and the ~/identify request (other
# names agree; ``budget`` is solver.generations or solver.calls, by the solver).
CORE_NAMES = {"friction_model": "friction", "solver": "solver.method", "seed": "solver.seed",
              "population": "solver.pop"}

QOS_CHOICES = ("sensor_data", "reliable")
VELOCITY_SOURCES = ("measured", "reference")
EFFORT_TYPES = ("joint_state", "float64_multi_array")
WORKERS = ("process", "thread")
EXECUTORS = ("events", "single_threaded")

# name: (default, description, read_only). Empty string-array defaults are declared typed.
# Every parameter naming a file or folder (system urdf:PATH, results_file, results_dir) and every
# limit is read-only: set at start-up, never by a client at runtime (PATH_PARAMETERS, LIMITS).
PARAMETERS: dict[str, tuple[object, str, bool]] = {
    "joints": ([], "joint names to buffer, identify and feed forward, in this order "
                   "(empty: the names of the first joint_states message)", True),
    "system": ("emps", "inverse dynamic model: emps | joint | friction-only | tx40-j2 | tx40 | urdf:PATH (a URDF file)", True),
    "friction_model": ("coulomb", f"default friction model: {' | '.join(FRICTIONS)}", False),
    "asymmetric": (False, "default: separate parameters for v > 0 and v < 0", False),
    "solver": ("ls", f"default solver: {' | '.join(SOLVERS)}", False),
    "seed": (0, "default RNG seed of stochastic solvers", False),
    "consistent": (False, "robot systems (tx40, urdf:PATH): every identification estimates physically consistent "
                          "parameters (frictionid identify --consistent)", False),
    "prior_weight": (0.0, "with consistent: weight of the log-det pull toward the URDF inertials "
                          "(identify --prior urdf --prior-weight); 0 = no prior", False),
    "input_executor": ("events", "executor of the input callbacks: events (rclpy EventsExecutor, lighter) | "
                                 "single_threaded (SingleThreadedExecutor: latency measured from middleware receipt)",
                       True),
    "identification_worker": ("process", "where identifications run: process (a child process: the input "
                                         "callbacks keep the GIL) | thread", True),
    "buffer_seconds": (30.0, "length of the joint-state ring buffer [s]", True),
    "max_rate_hz": (1000.0, "highest expected joint_states rate [Hz]; sizes the ring buffer "
                            "(capacity = buffer_seconds * max_rate_hz samples)", True),
    "window_seconds": (0.0, "default identification window [s]; 0 = the whole buffer", False),
    "min_samples": (200, "fewest joint-state samples an identification accepts", False),
    "max_missing_pct": (5.0, "refuse a window whose stamps show more than this share of lost samples [%]", False),
    "filter_cutoff_hz": (0.0, "Butterworth cut-off on position [Hz]; 0 = the system's default", True),
    "decimation": (0, "keep 1 sample of n after the anti-alias filter; 0 = the system's default", True),
    "drive_file": ("", "drive model between joint_states and the model's joints (gear ratios, coupling, effort "
                       "units, friction on joints or motors): a YAML file or a bundled name (tx40); read at start; "
                       "empty = none (joint-side data in N·m)", True),
    "joint_states_topic": ("joint_states", "sensor_msgs/JointState input topic", True),
    "qos": ("sensor_data", "QoS of the input topics: sensor_data (best effort) | reliable", True),
    "qos_depth": (100, "history depth of the input subscriptions [messages]", True),
    "effort_topic": ("", "separate effort topic; empty = the JointState effort field", True),
    "effort_topic_type": ("joint_state", f"type of effort_topic: {' | '.join(EFFORT_TYPES)}", True),
    "velocity_source": ("measured", "feed-forward velocity: measured (joint_states velocity, else finite "
                                    "difference of positions) | reference (reference_topic)", True),
    "reference_topic": ("reference_joint_states", "desired/reference sensor_msgs/JointState topic "
                                                  "(velocity_source = reference)", True),
    "feedforward_rate_hz": (0.0, "feed-forward publish rate [Hz]; 0 = on every velocity-source message", True),
    "smoothing_eps": (0.01, "sign smoothing tanh(v/eps) of the feed-forward [rad/s | m/s]; 0 = sign(v)", False),
    "results_file": ("~/.ros/frictionid/parameters.json", "JSON file of the active parameters: written "
                                                           "after each identification, read at start", True),
    "results_dir": ("", "the only folder ~/save and ~/load may use; empty = the folder of results_file", True),
    "max_budget": (1000, "largest budget a request may ask for [generations | cost calls]", True),
    "max_population": (200, "largest population a request may ask for", True),
    "max_window_seconds": (60.0, "longest data window of an identification [s]", True),
    "max_wall_s": (120.0, "wall time after which an identification is stopped [s]", True),
    "worker_nice": (19, "niceness of the identification worker process, 0..19 (19: the feed-forward "
                        "path gets the CPU first)", True),
    "realtime_priority": ("auto", "scheduling of the input/feed-forward thread, as ros2_control runs its loop: auto "
                                  "(SCHED_FIFO 10 if the OS allows, else normal) | off | a SCHED_FIFO priority "
                                  "1..99 (refused by the OS: normal scheduling and a warning); a string or an "
                                  "integer", True),
    "diagnostics_period_s": (1.0, "period of /diagnostics [s]", True),
    "known_rigid_body": (False, "robot systems (tx40, urdf:PATH): keep the base parameters at the model's values "
                                "(the controller's rigid-body model) and identify friction and offsets only", True),
    "online_period_s": (0.0, "online re-identification: every this long, identify the last online_window_s and "
                             "activate the result only if the safety gate accepts it [s]; 0 = off (~/load is then "
                             "not gated either)", True),
    "online_window_s": (10.0, "data window of an online re-identification [s]", True),
    "online_holdout": (0.25, "share of the online window held back (its newest samples) for the safety gate", True),
    "gate_max_abs": (1000.0, "the safety gate refuses a parameter larger than this in magnitude [SI units]", True),
    "feedforward_max": (0.0, "clamp of the feed-forward per joint [N·m | N]; 0 = none", True),
    "feedforward_ramp_s": (0.0, "new parameters blend in over this long (feed-forward rate limit) [s]; 0 = at once",
                           True),
}


DYNAMIC_PARAMETERS = ("realtime_priority",)  # a string or an integer (auto | off | 0..99)
PATH_PARAMETERS = ("system", "results_file", "results_dir")
LIMITS = ("max_budget", "max_population", "max_window_seconds", "max_wall_s", "worker_nice")


@dataclass(frozen=True)
class Config:
    """Validated node settings (units in :data:`PARAMETERS`)."""

    joints: tuple[str, ...]
    system: str
    solve: IdentifyRequest  # the defaults of ~/identify: system, friction_model, asymmetric, solver, seed
    consistent: bool  # physically consistent parameters (robot systems)
    prior_weight: float  # with consistent: weight of the URDF prior; 0 = none
    input_executor: str
    identification_worker: str
    buffer_seconds: float
    max_rate_hz: float
    window_seconds: float
    min_samples: int
    max_missing_pct: float
    filter_cutoff_hz: float
    decimation: int
    drive: Drive | None  # from drive_file
    joint_states_topic: str
    qos: str
    qos_depth: int
    effort_topic: str
    effort_topic_type: str
    velocity_source: str
    reference_topic: str
    feedforward_rate_hz: float
    smoothing_eps: float
    results_file: Path
    results_dir: Path
    max_budget: int
    max_population: int
    max_window_seconds: float
    max_wall_s: float
    worker_nice: int
    diagnostics_period_s: float
    known_rigid_body: bool = False
    realtime_priority: int | str = "auto"  # "auto" or 0..99 (realtime.parse_priority)
    online_period_s: float = 0.0
    online_window_s: float = 10.0
    online_holdout: float = 0.25
    gate_max_abs: float = 1000.0
    feedforward_max: float = 0.0
    feedforward_ramp_s: float = 0.0

    @property
    def capacity(self) -> int:
        """Ring-buffer capacity [samples]."""
        return int(math.ceil(self.buffer_seconds * self.max_rate_hz)) + 1


def _choice(name: str, value: str, choices, what: str = "") -> str:
    return check_choice(f"parameter '{name}'", value, choices, what or name)


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


def make_config(values: dict) -> Config:
    """Validate raw parameter values (name → value) into a :class:`Config`."""
    v = {name: (default if values.get(name) is None else values[name])
         for name, (default, _, _) in PARAMETERS.items()}
    joints = tuple(str(j) for j in v["joints"] if str(j))
    if len(set(joints)) != len(joints):
        raise FrictionIdError(f"parameter 'joints': duplicated names in {list(joints)}")
    for name in ("buffer_seconds", "max_rate_hz", "diagnostics_period_s", "max_window_seconds", "max_wall_s"):
        if not float(v[name]) > 0.0:
            raise FrictionIdError(f"parameter '{name}' must be > 0, got {v[name]}")
    for name in ("window_seconds", "max_missing_pct", "filter_cutoff_hz", "feedforward_rate_hz", "smoothing_eps",
                 "online_period_s", "feedforward_max", "feedforward_ramp_s"):
        if not float(v[name]) >= 0.0:
            raise FrictionIdError(f"parameter '{name}' must be >= 0, got {v[name]}")
    for name in ("decimation", "min_samples"):
        if int(v[name]) < 0:
            raise FrictionIdError(f"parameter '{name}' must be >= 0, got {v[name]}")
    for name in ("max_budget", "max_population"):
        if int(v[name]) < 1:
            raise FrictionIdError(f"parameter '{name}' must be >= 1, got {v[name]}")
    if not 0 <= int(v["worker_nice"]) <= 19:
        raise FrictionIdError(f"parameter 'worker_nice' must lie in 0..19, got {v['worker_nice']}")
    if float(v["window_seconds"]) > float(v["max_window_seconds"]):
        raise FrictionIdError(f"parameter 'window_seconds' = {v['window_seconds']} s is over the limit "
                              f"max_window_seconds = {v['max_window_seconds']} s")
    if not 1 <= int(v["qos_depth"]) <= 100_000:
        raise FrictionIdError(f"parameter 'qos_depth' must lie in 1..100000, got {v['qos_depth']}")
    cap = float(v["buffer_seconds"]) * float(v["max_rate_hz"])
    if cap > 50_000_000:
        raise FrictionIdError(f"buffer_seconds * max_rate_hz = {cap:.0f} samples is too large (max 5e7)")
    if not 0.0 < float(v["online_holdout"]) < 1.0:
        raise FrictionIdError(f"parameter 'online_holdout' must lie in (0, 1), got {v['online_holdout']}")
    if not float(v["online_window_s"]) > 0.0 or not float(v["gate_max_abs"]) > 0.0:
        raise FrictionIdError(f"parameters 'online_window_s' and 'gate_max_abs' must be > 0, got "
                              f"{v['online_window_s']} and {v['gate_max_abs']}")
    if v["velocity_source"] == "reference" and not v["reference_topic"]:
        raise FrictionIdError("velocity_source 'reference' needs a reference_topic")
    if not float(v["prior_weight"]) >= 0.0:
        raise FrictionIdError(f"parameter 'prior_weight' must be >= 0, got {v['prior_weight']}")
    system = check_system(str(v["system"]))
    if bool(v["consistent"]) and not _robot_system(system):
        raise FrictionIdError(f"parameter 'consistent' needs a robot system (tx40, urdf:PATH); system is '{system}'")
    results_file = Path(os.path.expanduser(str(v["results_file"]))).absolute()
    return Config(
        joints=joints,
        system=system,
        solve=solve_options("parameter", system=system, friction_model=str(v["friction_model"]),
                            asymmetric=bool(v["asymmetric"]), solver=str(v["solver"]), seed=int(v["seed"])),
        consistent=bool(v["consistent"]),
        prior_weight=float(v["prior_weight"]),
        input_executor=_choice("input_executor", v["input_executor"], EXECUTORS, "executor"),
        identification_worker=_choice("identification_worker", v["identification_worker"], WORKERS, "worker"),
        buffer_seconds=float(v["buffer_seconds"]),
        max_rate_hz=float(v["max_rate_hz"]),
        window_seconds=float(v["window_seconds"]),
        min_samples=int(v["min_samples"]),
        max_missing_pct=float(v["max_missing_pct"]),
        filter_cutoff_hz=float(v["filter_cutoff_hz"]),
        decimation=int(v["decimation"]),
        drive=_drive(str(v["drive_file"])),
        joint_states_topic=str(v["joint_states_topic"]),
        qos=_choice("qos", v["qos"], QOS_CHOICES, "QoS profile"),
        qos_depth=int(v["qos_depth"]),
        effort_topic=str(v["effort_topic"]),
        effort_topic_type=_choice("effort_topic_type", v["effort_topic_type"], EFFORT_TYPES, "effort topic type"),
        velocity_source=_choice("velocity_source", v["velocity_source"], VELOCITY_SOURCES, "velocity source"),
        reference_topic=str(v["reference_topic"]),
        feedforward_rate_hz=float(v["feedforward_rate_hz"]),
        smoothing_eps=float(v["smoothing_eps"]),
        results_file=results_file,
        results_dir=Path(os.path.expanduser(str(v["results_dir"]))).absolute() if v["results_dir"] else results_file.parent,
        max_budget=int(v["max_budget"]),
        max_population=int(v["max_population"]),
        max_window_seconds=float(v["max_window_seconds"]),
        max_wall_s=float(v["max_wall_s"]),
        worker_nice=int(v["worker_nice"]),
        diagnostics_period_s=float(v["diagnostics_period_s"]),
        known_rigid_body=bool(v["known_rigid_body"]),
        realtime_priority=parse_priority(v["realtime_priority"], "parameter 'realtime_priority'"),
        online_period_s=float(v["online_period_s"]),
        online_window_s=float(v["online_window_s"]),
        online_holdout=float(v["online_holdout"]),
        gate_max_abs=float(v["gate_max_abs"]),
        feedforward_max=float(v["feedforward_max"]),
        feedforward_ramp_s=float(v["feedforward_ramp_s"]),
    )


def default_config_file() -> Path | None:
    """``config/frictionid.yaml`` of the installed package (ament index) or of the source tree."""
    try:
        from ament_index_python.packages import get_package_share_directory

        p = Path(get_package_share_directory("frictionid_ros")) / "config" / "frictionid.yaml"
        if p.is_file():
            return p
    except Exception:  # not installed through colcon/ament: fall back to the source tree
        pass
    p = Path(__file__).resolve().parent.parent / "config" / "frictionid.yaml"
    return p if p.is_file() else None
