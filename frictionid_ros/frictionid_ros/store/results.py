"""The active parameters per joint and the results file that holds them (no ROS import).

The results file is JSON: the last identification exactly as ``IdentifyResult.to_dict()``
(system, friction, asymmetric, solver, source, joints, params, std, metrics, wall_s), plus

* ``per_joint``: {joint: {system, friction, asymmetric, solver, params, std, metrics, samples,
  stamp_ns[, limit]}} — the *active* parameters of every joint, names without the ``<joint>/``
  prefix; ``limit``: {effort, speed, source} of the data they were identified on
  (:func:`frictionid_core.safety.data_limits`), the limits of the safety screen and the clamp when the
  robot model gives none;
* ``window_start_ns``, ``window_end_ns``, ``window_samples``, ``stamp_ns``: the data window
  of the last identification and when it ran [ns since the epoch].

A plain ``frictionid identify --json`` file (no ``per_joint``), or its YAML from ``frictionid export --yaml``,
is accepted by :func:`read_results`.
Files are written atomically (temporary file + ``os.replace``), never over a file the node did
not write; requests name files inside the node's results folder only (:func:`request_path`).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

from frictionid_core import YAML_SUFFIXES, FrictionIdError, IdentifyResult, get_model, read_json, write_json
from frictionid_core.friction import elements_of
from frictionid_core.robots import Payload
from frictionid_core.safety import Limit

FORMAT = "frictionid_ros/1"
# Keys of the results file around the last identification's.
_FILE_KEYS = ("format", "per_joint", "window_start_ns", "window_end_ns", "window_samples", "stamp_ns", "payload")


@dataclass
class JointParams:
    """Identified parameters of one joint (SI units, see JointFriction.msg)."""

    joint: str
    system: str
    friction: str
    asymmetric: bool
    solver: str
    params: dict[str, float]
    std: dict[str, float] = field(default_factory=dict)
    metrics: dict[str, float] = field(default_factory=dict)
    samples: int = 0
    stamp_ns: int = 0
    limit: Limit | None = None

    def friction_vector(self):
        """(model, parameter vector in the model's order) for the feed-forward."""
        model = get_model(self.friction, self.asymmetric, elements_of(self.friction, self.params))
        missing = [n for n in model.names if n not in self.params]
        if missing:
            raise FrictionIdError(f"joint '{self.joint}': {model.label} parameter(s) {missing} missing")
        return model, [float(self.params[n]) for n in model.names]

    def to_dict(self) -> dict:
        d = asdict(self)
        d.pop("joint")
        if self.limit is None:
            d.pop("limit")
        else:
            d["limit"] = self.limit.to_dict()
        return d


def split_identification(result: IdentifyResult, stamp_ns: int = 0, limits: dict[str, Limit] | None = None
                         ) -> dict[str, JointParams]:
    """Per-joint parameters of an identification (``limits``: {owner: Limit} of its data, kept
    with each joint's parameters).

    With several joints, names ``<joint>/<name>`` go to their joint; unprefixed (shared, e.g.
    rigid-body) parameters stay only in the top-level ``params``. With one joint every
    parameter belongs to it. Metrics are those of the whole fit; ``samples`` is per joint.
    Under a drive with friction on the motors the parameters are per motor (``motor_<k>``).
    """
    joints = result.friction_rows()
    params, std = dict(result.params), dict(result.std)
    system, friction, asym, solver = result.system, result.friction, bool(result.asymmetric), result.solver
    metrics = {k: float(v) for k, v in result.metrics.items() if isinstance(v, (int, float))}
    total = int(metrics.get("samples", 0))
    out = {}
    for j in joints:
        if len(joints) == 1:
            p, s = params, std
        else:
            pre = j + "/"
            p = {k[len(pre):]: v for k, v in params.items() if k.startswith(pre)}
            s = {k[len(pre):]: v for k, v in std.items() if k.startswith(pre)}
        out[j] = JointParams(j, system, friction, asym, solver, {k: float(v) for k, v in p.items()},
                             {k: float(v) for k, v in s.items()}, dict(metrics), total // max(len(joints), 1),
                             int(stamp_ns), (limits or {}).get(j))
    return out



def shared_parameters(result: IdentifyResult | None) -> tuple[list[str], list[float], list[float]]:
    """(names, values, std) of the parameters of an identification that belong to no single joint
    (unprefixed names of a several-joint result: the robot's base parameters)."""
    if result is None or len(result.joints) < 2:
        return [], [], []
    names = [k for k in result.params if "/" not in k]
    return (names, [float(result.params[k]) for k in names],
            [float(result.std.get(k, float("nan"))) for k in names])

@dataclass
class Results:
    """What the results file holds: the active parameters and the last identification."""

    per_joint: dict[str, JointParams] = field(default_factory=dict)
    last: IdentifyResult | None = None
    window_start_ns: int = 0
    window_end_ns: int = 0
    window_samples: int = 0
    stamp_ns: int = 0
    payload: Payload | None = None

    def to_dict(self) -> dict:
        d = self.last.to_dict() if self.last is not None else {}
        d.update(format=FORMAT, window_start_ns=int(self.window_start_ns), window_end_ns=int(self.window_end_ns),
                 window_samples=int(self.window_samples), stamp_ns=int(self.stamp_ns),
                 per_joint={j: p.to_dict() for j, p in self.per_joint.items()})
        if self.payload is not None:
            d["payload"] = self.payload.to_dict()
        return d


def write_results(path: Path, results: Results) -> Path:
    """Write ``results`` atomically and durably to ``path`` (folders created); returns the absolute
    path. Refuses to replace an existing file that is not a parameters file of the node
    (:func:`check_replaceable`)."""
    check_replaceable(Path(path))
    return write_json(path, results.to_dict(), durable=True)


def check_replaceable(path: Path) -> None:
    """FrictionIdError unless ``path`` is free or a parameters file written by the node (its
    ``format`` is FORMAT): the node never overwrites another file."""
    if not os.path.lexists(path):
        return
    fmt = None
    if path.is_file() and not path.is_symlink():
        try:
            data = json.loads(path.read_text())
            fmt = data.get("format") if isinstance(data, dict) else None
        except (OSError, UnicodeDecodeError, ValueError, RecursionError):
            pass
    if fmt != FORMAT:
        raise FrictionIdError(f"{path}: refused: the file exists and is not a parameters file written by this node "
                              f"(no \"format\": \"{FORMAT}\"); the node overwrites no other file")


def request_path(folder: Path, name: str) -> Path:
    """The file ``name`` of a ``~/save`` or ``~/load`` request: a path relative to ``folder`` (the
    node's results folder) or an absolute path inside it, with symbolic links resolved.

    Refused with a FrictionIdError naming the rule: a ``..`` component, an absolute path outside
    ``folder``, a path whose real location is outside ``folder`` (a symbolic link leading out),
    a sub-folder that does not exist. Nothing outside ``folder`` is looked at."""
    rule = f"~/save and ~/load use only files inside the results folder {folder}"
    if "\0" in name:
        raise FrictionIdError(f"{name!r}: refused: a NUL character in the name; {rule}")
    path = Path(name)
    real_folder = Path(os.path.realpath(folder))
    if ".." in path.parts:
        raise FrictionIdError(f"'{name}': refused: '..' in the path; {rule}")
    if path.is_absolute():
        if not any(path.is_relative_to(f) for f in (folder, real_folder)):
            raise FrictionIdError(f"'{name}': refused: outside the results folder; {rule}")
    else:
        path = folder / path
    real = Path(os.path.realpath(path))
    if real == real_folder or not real.is_relative_to(real_folder):
        raise FrictionIdError(f"'{name}': refused: leads out of the results folder (symbolic link); {rule}")
    if not real.parent.is_dir():
        raise FrictionIdError(f"'{name}': refused: no such folder inside the results folder; {rule}")
    return real


def read_results(path: Path) -> Results:
    """Read a results file (this module's format, ``frictionid identify --json`` output, or the
    YAML of ``frictionid export --yaml``)."""
    path = Path(path).expanduser().absolute()
    try:
        if path.suffix.lower() in YAML_SUFFIXES:  # 'frictionid export --yaml'
            data = read_json(path, "parameters")
        else:
            data = json.loads(path.read_text())
    except FileNotFoundError:
        raise FrictionIdError(f"{path}: no such parameters file") from None
    except RecursionError:  # the readers recurse once per nesting level
        raise FrictionIdError(f"{path}: cannot read parameters (its values are nested too deeply)") from None
    except (OSError, ValueError) as exc:
        raise FrictionIdError(f"{path}: cannot read parameters ({exc})") from None
    if not isinstance(data, dict):
        raise FrictionIdError(f"{path}: not a parameters file (expected a JSON object)")
    try:
        if "per_joint" in data:
            per_joint = {}
            for j, d in data["per_joint"].items():
                per_joint[j] = JointParams(
                    j, str(d["system"]), str(d["friction"]), bool(d["asymmetric"]), str(d.get("solver", "")),
                    {k: float(v) for k, v in d["params"].items()},
                    {k: float(v) for k, v in (d.get("std") or {}).items()},
                    {k: float(v) for k, v in (d.get("metrics") or {}).items()},
                    int(d.get("samples", 0)), int(d.get("stamp_ns", 0)),
                    Limit.from_dict(d["limit"], f"{path}: per_joint '{j}' limit") if d.get("limit") else None)
        rest = {k: v for k, v in data.items() if k not in _FILE_KEYS}
        last = IdentifyResult.from_dict(rest, str(path)) if rest or "per_joint" not in data else None
        if "per_joint" not in data:
            per_joint = split_identification(last, int(data.get("stamp_ns", 0)))
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise FrictionIdError(f"{path}: malformed parameters ({type(exc).__name__}: {exc})") from None
    for p in per_joint.values():
        try:
            _, vec = p.friction_vector()
        except FrictionIdError as exc:
            raise FrictionIdError(f"{path}: {exc}") from None
        if not all(math.isfinite(x) for x in vec):
            raise FrictionIdError(f"{path}: joint '{p.joint}' has non-finite friction parameters")
    payload = None if data.get("payload") is None else Payload.from_dict(data["payload"], f"{path}: key 'payload'")
    return Results(per_joint, last, int(data.get("window_start_ns", 0)), int(data.get("window_end_ns", 0)),
                   int(data.get("window_samples", 0)), int(data.get("stamp_ns", 0)), payload)
