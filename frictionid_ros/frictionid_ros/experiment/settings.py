"""A ``~/run_experiment`` goal validated into :class:`Settings` (no ROS import).

Zeros and empty strings of the goal take the defaults below; the identification's fields go over the
node's parameters as ``~/identify``'s do (:func:`frictionid_ros.identification.node_request`). A bad
value is one FrictionIdError naming the goal field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from frictionid_core import FrictionIdError, InputError, PreprocessingOverrides
from frictionid_core.experiment import DEFAULT_MAX_FLOOR_RATIO, DEFAULT_VALIDATION_SHARE, Thresholds, check_share
from frictionid_ros.identification import node_request
from frictionid_ros.parameters import Config

INTERFACES = ("trajectory", "position")
DEFAULT_TOPICS = {"trajectory": "/joint_trajectory_controller/joint_trajectory",
                  "position": "/forward_position_controller/commands"}
DEFAULT_RATES = {"trajectory": 100.0, "position": 250.0}  # [Hz] points or streamed commands per second
MAX_RATE_HZ = 1000.0
DEFAULT_APPROACH_SPEED = 0.2
# The excitation designed when no file is given (frictionid excite's defaults).
DESIGN_DEFAULTS = {"duration_s": 20.0, "harmonics": 5, "period_s": 10.0, "evals": 1500, "margin": 0.05,
                   "clearance_m": 0.01}
MAX_DURATION_S = 600.0
MAX_EVALS = 100_000


@dataclass(frozen=True)
class Design:
    """The settings of an excitation designed by the node (``frictionid excite``'s)."""

    duration_s: float
    harmonics: int
    period_s: float
    evals: int
    seed: int
    margin: float
    max_acceleration: float | None
    collision: bool
    clearance_m: float
    floor_z: float | None


@dataclass(frozen=True)
class Settings:
    """A validated goal: the excitation (a file of the results folder, or a :class:`Design`), the
    command interface, its topic and rate, the approach speed (fraction of the limits), the abort
    thresholds, the identification request, the validation share and thresholds, dry run."""

    excitation_file: str
    design: Design
    interface: str
    topic: str
    rate_hz: float
    approach_speed: float
    thresholds: Thresholds
    request: object  # IdentifyRequest (its window is set by the experiment)
    validation_share: float
    max_floor_ratio: float
    max_relerr_pct: float
    dry_run: bool


def _or(value, default):
    return default if not value else value


def _number(goal, name: str, default: float, low: float = 0.0, high: float = math.inf) -> float:
    """Goal field ``name`` (0: ``default``), finite and in [low, high]."""
    raw = float(getattr(goal, name))
    if not math.isfinite(raw) or raw < 0:
        raise InputError(f"goal field '{name}' must be a finite number >= 0 (0: the default), got {raw:g}")
    value = raw or default
    if not low <= value <= high:
        raise InputError(f"goal field '{name}' = {value:g} must lie in [{low:g}, {high:g}]")
    return float(value)


def parse_goal(goal, cfg: Config, joints: list[str]) -> Settings:
    """The :class:`Settings` of a RunExperiment goal for a node of settings ``cfg`` buffering ``joints``."""
    interface = goal.command_interface or "trajectory"
    if interface not in INTERFACES:
        raise InputError(f"goal field 'command_interface' = {interface!r}: choose one of {', '.join(INTERFACES)}")
    topic = goal.command_topic or DEFAULT_TOPICS[interface]
    if not topic.replace("/", "").replace("_", "").isalnum() or len(topic) > 256:
        raise InputError(f"goal field 'command_topic' = {topic[:60]!r} is not a topic name")
    seed = int(goal.seed) if goal.seed >= 0 else int(np.random.SeedSequence().entropy % 2**31)
    floor = float(goal.floor_z) if goal.floor else None
    if floor is not None and not math.isfinite(floor):
        raise InputError(f"goal field 'floor_z' must be finite, got {floor:g}")
    d = DESIGN_DEFAULTS
    harmonics, evals = int(goal.harmonics) or d["harmonics"], int(goal.evals) or d["evals"]
    if not (1 <= harmonics <= 50 and 1 <= evals <= MAX_EVALS):
        raise InputError(f"goal fields 'harmonics' (1..50) and 'evals' (1..{MAX_EVALS}): got {harmonics}, {evals}")
    design = Design(_number(goal, "duration_s", d["duration_s"], 0.5, MAX_DURATION_S), harmonics,
                    _number(goal, "period_s", d["period_s"], 0.1, MAX_DURATION_S), evals, seed,
                    _number(goal, "margin", d["margin"], 0.0, 0.95), _number(goal, "max_acceleration", 0.0) or None,
                    bool(goal.collision or goal.floor), _number(goal, "clearance_m", d["clearance_m"], 0.0, 1.0), floor)
    thresholds = Thresholds(_number(goal, "max_tracking_error", Thresholds.tracking_rad),
                            _number(goal, "max_effort_ratio", Thresholds.effort_ratio),
                            _number(goal, "silence_s", Thresholds.silence_s, 0.0, 10.0))
    fields = {k: v for k, v in (("friction_model", goal.friction_model), ("solver", goal.solver)) if v}
    fields.update(asymmetric=bool(goal.asymmetric or cfg.solve.asymmetric), budget=int(goal.budget))
    if goal.budget > cfg.max_budget:
        raise FrictionIdError(f"goal field 'budget' = {goal.budget} is over the node's limit max_budget = "
                              f"{cfg.max_budget}")
    request = node_request(cfg, list(joints), "goal field", **fields)
    overrides = {k: v for k, v in (("cutoff_hz", _number(goal, "cutoff_hz", 0.0)),
                                   ("reversal_periods", _number(goal, "reversal_periods", 0.0, 0.0, 100.0)),
                                   ("min_speed", _number(goal, "min_speed", 0.0))) if v}
    if overrides:
        request = replace(request, preprocessing=PreprocessingOverrides(
            **{**request.preprocessing.changes(), **overrides}))
    share = float(goal.validation_share) or DEFAULT_VALIDATION_SHARE
    try:
        check_share(share)
    except InputError as exc:
        raise InputError(f"goal field 'validation_share': {exc}") from None
    return Settings(goal.excitation_file, design, interface, topic,
                    _number(goal, "command_rate_hz", DEFAULT_RATES[interface], 1.0, MAX_RATE_HZ),
                    _number(goal, "approach_speed", DEFAULT_APPROACH_SPEED, 0.0, 1.0), thresholds, request, share,
                    _number(goal, "max_floor_ratio", DEFAULT_MAX_FLOOR_RATIO), _number(goal, "max_relerr_pct", 0.0),
                    bool(goal.dry_run))
