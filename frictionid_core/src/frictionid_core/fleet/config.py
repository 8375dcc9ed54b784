"""The fleet file (YAML): which robots, which logs, how each is identified and what is watched.

::

    defaults: {system: joint, friction: coulomb, solver: ls}   # any identify option, any robot key
    robots:
      - name: arm01
        logs: "arm01/*.mcap"        # glob (or a list of globs), relative to this file; any source identify reads
        topic: /joint_states        # optional; also effort_topic, layout, strict_time, strict_rows
        joints: [j1, j2, j3]        # and any identify option: system, friction, drive, solver, window, …
        covariates:                 # optional: per-log means regressed out of the drift test
          temperature: {topic: /joint_temperatures, field: effort}   # bags: a JointState topic's field
          # payload: {column: payload_kg}                            # CSV logs: a column
    baseline_logs: 10               # the first N logs of each robot (by first stamp) set its baseline
    alarm: {parameters: [Fc, Fv], false_alarm_rate: 0.001, reference: 2.5}

A robot's keys are ``defaults`` with its own keys over them (``solver``, ``preprocessing``, ``window``,
``fixed``, ``bounds`` and ``covariates`` merged key by key). Every identify option goes through
:meth:`~frictionid_core.identification.IdentifyRequest.from_dict`, so a bad value is refused with the
YAML key that holds it. Paths (logs, layout, a drive file, ``urdf:PATH``) are relative to the fleet
file and are resolved here, once: workers receive absolute paths and a drive's keys.
"""

from __future__ import annotations

import glob
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path

from frictionid_core.errors import InputError

TOP_KEYS = ("defaults", "robots", "baseline_logs", "alarm")
ALARM_KEYS = ("parameters", "false_alarm_rate", "reference")
SOURCE_KEYS = ("topic", "effort_topic", "layout", "strict_time", "strict_rows")
ROBOT_ONLY_KEYS = ("name", "logs")
COVARIATE_KEYS = ("topic", "field", "column")
COVARIATE_FIELDS = ("position", "velocity", "effort")
MERGED_KEYS = ("solver", "preprocessing", "window", "fixed", "bounds", "covariates")
DEFAULT_BASELINE_LOGS = 10
DEFAULT_ALARM = {"parameters": ["Fc"], "false_alarm_rate": 0.001, "reference": 2.5}


@dataclass(frozen=True)
class AlarmSettings:
    """What the drift test watches (:mod:`frictionid_core.fleet.drift`).

    Attributes:
        parameters: base parameter names watched on every joint (``Fc``, ``Fv``, …).
        false_alarm_rate: in-control probability of a false alarm per robot, watched parameter and
            log (shared by the robot's joints).
        reference: the CUSUM's reference value k, in units of the baseline spread.
    """

    parameters: tuple[str, ...] = ("Fc",)
    false_alarm_rate: float = 0.001
    reference: float = 2.5


@dataclass(frozen=True)
class RobotConfig:
    """One robot of the fleet: its logs and how each is read and identified.

    Attributes:
        name: the robot's name (unique in the fleet).
        logs: (name in the outputs, absolute path) of each log matched, sorted by name.
        request: the identify request's fields (:meth:`IdentifyRequest.to_dict`, paths absolute).
        load: keyword arguments of :func:`frictionid_core.io.load` (topic, effort_topic, layout, …).
        covariates: {name: {"topic", "field"} or {"column"}} read from each log.
    """

    name: str
    logs: tuple[tuple[str, str], ...]
    request: dict
    load: dict = field(default_factory=dict)
    covariates: dict = field(default_factory=dict)


@dataclass(frozen=True)
class FleetConfig:
    """A validated fleet file (see the module doc)."""

    path: Path
    robots: tuple[RobotConfig, ...]
    baseline_logs: int = DEFAULT_BASELINE_LOGS
    alarm: AlarmSettings = field(default_factory=AlarmSettings)


def read_fleet(path: str | Path) -> FleetConfig:
    """The fleet file at ``path``, validated; InputError naming the file and key at fault."""
    from frictionid_core.files import check_keys, read_yaml

    path = Path(path).expanduser().absolute()
    data = read_yaml(path, "a fleet file (robots, logs, defaults)")
    check_keys(data, TOP_KEYS, str(path), required=("robots",))
    defaults = data.get("defaults") or {}
    if not isinstance(defaults, Mapping):
        raise InputError(f"{path}: key 'defaults' must be a mapping of identify options, got {defaults!r}")
    robots = data["robots"]
    if not isinstance(robots, list) or not robots:
        raise InputError(f"{path}: key 'robots' must be a non-empty list of robots ({{name, logs, …}})")
    built = [_robot(path, k, entry, defaults) for k, entry in enumerate(robots)]
    names = [r.name for r in built]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"{path}: robot name(s) {dup} used more than once")
    return FleetConfig(path, tuple(built), _baseline_logs(path, data.get("baseline_logs", DEFAULT_BASELINE_LOGS)),
                       _alarm(path, data.get("alarm")))


def _baseline_logs(path: Path, value) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 3:
        raise InputError(f"{path}: key 'baseline_logs' must be an integer >= 3, got {value!r}")
    return value


def _alarm(path: Path, data) -> AlarmSettings:
    from frictionid_core.files import check_keys

    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise InputError(f"{path}: key 'alarm' must be a mapping {{parameters, false_alarm_rate}}, got {data!r}")
    check_keys(data, ALARM_KEYS, f"{path}: key 'alarm'")
    values = {**DEFAULT_ALARM, **data}
    params = values["parameters"]
    if isinstance(params, str):
        params = [params]
    if (not isinstance(params, list) or not params or not all(isinstance(p, str) and p for p in params)
            or len(set(params)) != len(params)):
        raise InputError(f"{path}: key 'alarm.parameters' must be a list of distinct parameter names (Fc, Fv, "
                         f"…), got {values['parameters']!r}")
    rate = values["false_alarm_rate"]
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not 1e-6 <= rate <= 0.1:
        raise InputError(f"{path}: key 'alarm.false_alarm_rate' must be a probability per log in [1e-6, 0.1], "
                         f"got {rate!r}")
    reference = values["reference"]
    if isinstance(reference, bool) or not isinstance(reference, (int, float)) or not 0 <= reference <= 10:
        raise InputError(f"{path}: key 'alarm.reference' must be a number in [0, 10] (spreads), got {reference!r}")
    return AlarmSettings(tuple(params), float(rate), float(reference))


def _robot(path: Path, index: int, entry, defaults: Mapping) -> RobotConfig:
    from frictionid_core.identification import IdentifyRequest

    where = f"{path}: robots[{index}]"
    if not isinstance(entry, Mapping):
        raise InputError(f"{where} must be a mapping {{name, logs, …}}, got {entry!r}")
    name = entry.get("name")
    if not isinstance(name, str) or not name.strip() or name != name.strip():
        raise InputError(f"{where}: key 'name' must be a non-empty name without surrounding spaces, got {name!r}")
    where = f"{path}: robot '{name}'"
    for key in ROBOT_ONLY_KEYS:
        if key in defaults:
            raise InputError(f"{path}: key 'defaults.{key}' belongs to each robot, not to the defaults")
    if "logs" not in entry:
        raise InputError(f"{where}: key 'logs' missing (a glob of its log files, relative to the fleet file)")
    request_fields = {f.name for f in fields(IdentifyRequest)}
    known = set(request_fields) | set(SOURCE_KEYS) | set(ROBOT_ONLY_KEYS) | {"covariates"}
    origin: dict[str, str] = {}
    merged: dict = {}
    for label, part in (("defaults", defaults), (f"robots[{index}]", entry)):
        for key, value in part.items():
            if key not in known:
                raise InputError(f"{path}: key '{label}.{key}' is unknown; known keys: "
                                 f"{', '.join(sorted(known - {'name', 'logs'}))}, and per robot name, logs")
            if key == "solver" and isinstance(value, str):
                value = {"method": value}
            if key in MERGED_KEYS and isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
                merged[key] = {**merged[key], **value}
                origin.update({f"{key}.{k}": f"{label}.{key}.{k}" for k in value})
            else:
                merged[key] = value
                origin[key] = f"{label}.{key}"
                if isinstance(value, Mapping):
                    origin.update({f"{key}.{k}": f"{label}.{key}.{k}" for k in value})
    folder = path.parent
    request = {k: v for k, v in merged.items() if k in request_fields}
    request = _resolve_request_paths(request, folder, origin, path)
    checked = IdentifyRequest.from_dict(request, where=f"{path}: key", names=origin)
    load = _load_options(merged, folder, origin, path)
    if checked.joints is not None:
        load["joints"] = list(checked.joints)
    covariates = _covariates(merged.get("covariates"), origin.get("covariates", "covariates"), path)
    return RobotConfig(name, _logs(entry["logs"], folder, where), checked.to_dict(), load, covariates)


def _resolve_request_paths(request: dict, folder: Path, origin: dict, path: Path) -> dict:
    """The request with its files made absolute: ``urdf:PATH`` and a drive file (as its keys)."""
    from frictionid_core.drive import bundled_drives
    from frictionid_core.systems import URDF_PREFIX

    out = dict(request)
    system = out.get("system")
    if isinstance(system, str) and system.startswith(URDF_PREFIX):
        urdf = (folder / Path(system[len(URDF_PREFIX):]).expanduser()).absolute()
        out["system"] = URDF_PREFIX + str(urdf)
    drive = out.get("drive")
    if isinstance(drive, str) and drive not in bundled_drives():
        from frictionid_core.files import read_yaml

        drive_path = (folder / Path(drive).expanduser()).absolute()
        keys = read_yaml(drive_path, f"a drive model (key '{origin.get('drive', 'drive')}' of {path})")
        out["drive"] = {**keys, "name": keys.get("name") or drive_path.stem}
    return out


def _load_options(merged: dict, folder: Path, origin: dict, path: Path) -> dict:
    """The keyword arguments of :func:`frictionid_core.io.load` a robot's keys give."""
    out = {}
    for key in ("topic", "effort_topic"):
        value = merged.get(key)
        if value is not None:
            if not isinstance(value, str) or not value:
                raise InputError(f"{path}: key '{origin[key]}' must be a topic name, got {value!r}")
            out[key] = value
    for key in ("strict_time", "strict_rows"):
        value = merged.get(key)
        if value is not None:
            if not isinstance(value, bool):
                raise InputError(f"{path}: key '{origin[key]}' must be true or false, got {value!r}")
            out[key] = value
    layout = merged.get("layout")
    if layout is not None:
        from frictionid_core.io import load_layout

        if not isinstance(layout, str) or not layout:
            raise InputError(f"{path}: key '{origin['layout']}' must be a layout file, got {layout!r}")
        out["layout"] = load_layout((folder / Path(layout).expanduser()).absolute())
    return out


def _covariates(data, label: str, path: Path) -> dict:
    """{name: {"topic", "field"} | {"column"}} of a robot's ``covariates`` key."""
    from frictionid_core.files import check_keys

    if data is None:
        return {}
    if not isinstance(data, Mapping):
        raise InputError(f"{path}: key '{label}' must map covariate names to {{topic, field}} or {{column}}, "
                         f"got {data!r}")
    out = {}
    for name, spec in data.items():
        where = f"{path}: key '{label}.{name}'"
        if not isinstance(spec, Mapping):
            raise InputError(f"{where} must be {{topic: T, field: effort}} or {{column: C}}, got {spec!r}")
        check_keys(spec, COVARIATE_KEYS, where)
        if ("column" in spec) == ("topic" in spec):
            raise InputError(f"{where}: give either 'topic' (and 'field') of a bag or 'column' of a CSV log")
        if "column" in spec:
            if not isinstance(spec["column"], str) or not spec["column"]:
                raise InputError(f"{where}: key 'column' must be a column name, got {spec['column']!r}")
            out[str(name)] = {"column": spec["column"]}
            continue
        field_ = spec.get("field", "position")
        if field_ not in COVARIATE_FIELDS:
            raise InputError(f"{where}: key 'field' must be one of {', '.join(COVARIATE_FIELDS)}, got {field_!r}")
        if not isinstance(spec["topic"], str) or not spec["topic"]:
            raise InputError(f"{where}: key 'topic' must be a topic name, got {spec['topic']!r}")
        out[str(name)] = {"topic": spec["topic"], "field": field_}
    return out


def _logs(patterns, folder: Path, where: str) -> tuple[tuple[str, str], ...]:
    """(name, absolute path) of every file or rosbag2 directory the glob(s) match, sorted by name."""
    if isinstance(patterns, str):
        patterns = [patterns]
    if not isinstance(patterns, list) or not patterns or not all(isinstance(p, str) and p for p in patterns):
        raise InputError(f"{where}: key 'logs' must be a glob or a list of globs, got {patterns!r}")
    found: dict[str, str] = {}
    for pattern in patterns:
        full = Path(pattern).expanduser()
        absolute = full if full.is_absolute() else folder / full
        matches = sorted(glob.glob(str(absolute), recursive=True))
        if not matches:
            raise InputError(f"{where}: logs '{pattern}' match no file (relative to {folder})")
        for match in matches:
            match_path = Path(match.rstrip("/"))
            try:
                name = match_path.relative_to(folder).as_posix()
            except ValueError:
                name = match_path.as_posix()
            found[name] = str(match_path.absolute())
    return tuple(sorted(found.items()))
