"""Active parameters per joint and the results file (no ROS import).

The results file is JSON: the last identification exactly as ``Identification.to_dict()``
(system, friction, asymmetric, solver, source, joints, params, std, metrics, wall_s), plus

* ``per_joint``: {joint: {system, friction, asymmetric, solver, params, std, metrics, samples,
  stamp_ns}} — the *active* parameters of every joint, names without the ``<joint>/`` prefix;
* ``window_start_ns``, ``window_end_ns``, ``window_samples``, ``stamp_ns``: the data window
  of the last identification and when it ran [ns since the epoch].

A plain ``frictionid identify --json`` file (no ``per_joint``) is accepted by :func:`read_results`.
Files are written atomically (temporary file + ``os.replace``). :class:`ActiveParameters` holds
the node's active parameters and saves them.
"""

from __future__ import annotations

import json
import math
import os
import threading
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

from frictionid_core.drive import friction_rows
from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model

FORMAT = "frictionid_ros/1"


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

    def friction_vector(self):
        """(model, parameter vector in the model's order) for the feed-forward."""
        model = get_model(self.friction, self.asymmetric)
        missing = [n for n in model.names if n not in self.params]
        if missing:
            raise FrictionIdError(f"joint '{self.joint}': {model.label} parameter(s) {missing} missing")
        return model, [float(self.params[n]) for n in model.names]

    def to_dict(self) -> dict:
        d = asdict(self)
        d.pop("joint")
        return d


def split_identification(result: dict, stamp_ns: int = 0) -> dict[str, JointParams]:
    """Per-joint parameters of an ``Identification.to_dict()``.

    With several joints, names ``<joint>/<name>`` go to their joint; unprefixed (shared, e.g.
    rigid-body) parameters stay only in the top-level ``params``. With one joint every
    parameter belongs to it. Metrics are those of the whole fit; ``samples`` is per joint.
    Under a drive with friction on the motors the parameters are per motor (``motor_<k>``).
    """
    try:
        joints = friction_rows(result)
        params, std = dict(result["params"]), dict(result.get("std") or {})
        system, friction = str(result["system"]), str(result["friction"])
        asym, solver = bool(result["asymmetric"]), str(result.get("solver", ""))
    except (KeyError, TypeError) as exc:
        raise FrictionIdError(f"identification result lacks {exc}") from None
    metrics = {k: float(v) for k, v in (result.get("metrics") or {}).items() if isinstance(v, (int, float))}
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
                             int(stamp_ns))
    return out



def shared_parameters(result: dict | None) -> tuple[list[str], list[float], list[float]]:
    """(names, values, std) of the parameters of an ``Identification.to_dict()`` that belong to
    no single joint (unprefixed names of a several-joint result: the robot's base parameters)."""
    if not result or len(result.get("joints") or []) < 2:
        return [], [], []
    std = result.get("std") or {}
    names = [k for k in result.get("params", {}) if "/" not in k]
    return names, [float(result["params"][k]) for k in names], [float(std.get(k, float("nan"))) for k in names]

@dataclass
class Results:
    """What the results file holds: the active parameters and the last identification."""

    per_joint: dict[str, JointParams] = field(default_factory=dict)
    last: dict | None = None
    window_start_ns: int = 0
    window_end_ns: int = 0
    window_samples: int = 0
    stamp_ns: int = 0

    def to_dict(self) -> dict:
        d = dict(self.last or {})
        d.update(format=FORMAT, window_start_ns=int(self.window_start_ns), window_end_ns=int(self.window_end_ns),
                 window_samples=int(self.window_samples), stamp_ns=int(self.stamp_ns),
                 per_joint={j: p.to_dict() for j, p in self.per_joint.items()})
        return d


def write_results(path: Path, results: Results) -> Path:
    """Write ``results`` atomically to ``path`` (directories created); returns the absolute path."""
    path = Path(path).expanduser().absolute()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        with open(tmp, "w") as f:
            json.dump(results.to_dict(), f, indent=2, allow_nan=True)
            f.write("\n")
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
        try:  # make the rename itself durable
            fd = os.open(path.parent, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        except OSError:
            pass
    except OSError as exc:
        raise FrictionIdError(f"{path}: cannot write parameters ({exc.strerror or exc})") from None
    return path


def read_results(path: Path) -> Results:
    """Read a results file (this module's format, or ``frictionid identify --json`` output)."""
    path = Path(path).expanduser().absolute()
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise FrictionIdError(f"{path}: no such parameters file") from None
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
                    int(d.get("samples", 0)), int(d.get("stamp_ns", 0)))
        else:
            per_joint = split_identification(data, int(data.get("stamp_ns", 0)))
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise FrictionIdError(f"{path}: malformed parameters ({type(exc).__name__}: {exc})") from None
    for p in per_joint.values():
        try:
            _, vec = p.friction_vector()
        except FrictionIdError as exc:
            raise FrictionIdError(f"{path}: {exc}") from None
        if not all(math.isfinite(x) for x in vec):
            raise FrictionIdError(f"{path}: joint '{p.joint}' has non-finite friction parameters")
    last = {k: v for k, v in data.items()
            if k not in ("format", "per_joint", "window_start_ns", "window_end_ns", "window_samples", "stamp_ns")}
    return Results(per_joint, last or None, int(data.get("window_start_ns", 0)), int(data.get("window_end_ns", 0)),
                   int(data.get("window_samples", 0)), int(data.get("stamp_ns", 0)))


class ActiveParameters:
    """The node's active parameters, merged per joint over identifications and loads.

    Every change goes to ``on_change(results)`` (feed-forward, publication) under :attr:`lock`
    and is saved to ``path`` (the ``results_file``); ``log`` reports a failed save (``.error``).
    """

    def __init__(self, path: Path, on_change, log):
        self.path = Path(path)
        self._on_change = on_change
        self._log = log
        self.lock = threading.Lock()
        self.results = Results()

    def file(self, path: str) -> Path:
        """A service request's file: ``path`` (``~`` expanded) made absolute; empty: :attr:`path`."""
        return Path(os.path.expanduser(path)).absolute() if path else self.path

    def restore(self) -> None:
        """Read ``path`` if it exists (at start; ``on_change`` is not called)."""
        if self.path.exists():
            try:
                self.results = read_results(self.path)
            except FrictionIdError as exc:
                self._log.error(f"parameters not restored: {exc}")

    def activate(self, results: Results, save: bool = True) -> str:
        """Merge ``results`` into the active parameters and save them; returns a note for the reply."""
        with self.lock:
            self.results = replace(results, per_joint={**self.results.per_joint, **results.per_joint})
            self._on_change(self.results)
            if not save:
                return ""
            try:
                return f"; saved to {write_results(self.path, self.results)}"
            except FrictionIdError as exc:
                self._log.error(str(exc))
                return f"; NOT saved: {exc}"

    def save(self, path: Path) -> tuple[bool, str]:
        """Write the active parameters to ``path``: (success, message)."""
        with self.lock:
            results = self.results
        if not results.per_joint:
            return False, "no active parameters to save (identify or load first)"
        try:
            write_results(path, results)
        except FrictionIdError as exc:
            return False, str(exc)
        return True, f"saved parameters of {sorted(results.per_joint)} to {path}"

    def load(self, path: Path) -> tuple[bool, str]:
        """Activate the parameters of ``path`` (saved to :attr:`path` unless it is that file): (success, message)."""
        try:
            loaded = read_results(path)
        except FrictionIdError as exc:
            return False, str(exc)
        if not loaded.per_joint:
            return False, f"{path}: no parameters in the file"
        note = self.activate(replace(loaded, stamp_ns=loaded.stamp_ns or time.time_ns()), save=Path(path) != self.path)
        return True, f"loaded parameters of {sorted(loaded.per_joint)} from {path}{note}"
