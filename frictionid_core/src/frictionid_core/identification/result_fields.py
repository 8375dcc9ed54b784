"""The key-by-key checks of a result file (:func:`result_fields`): each key's type, each
parameter a finite number within ±:data:`MAX_PARAMETER`, σ and metrics finite or NaN (not
determined), the nested blocks (drive, standard parameters, pre-processing) by their own keys."""

from __future__ import annotations

import math
from collections.abc import Mapping
from numbers import Real

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification.checks import (
    FieldError,
    bound_value,
    choice,
    flag,
    integer,
    mapping,
    number,
    window_value,
)

REQUIRED_KEYS = ("system", "friction", "asymmetric", "params")
MAX_PARAMETER = 1e15  # |value| beyond: not an identified parameter in SI units (an overflow, a typo)


def result_fields(data: Mapping, names: list[str]) -> dict:
    """The fields ``names`` (the result's dataclass fields) of a result's JSON ``data``, each
    checked (FieldError naming its key); keys it does not know are left out, a key missing or null
    takes its field's default."""
    from frictionid_core.friction import FRICTIONS

    given = {name: data[name] for name in names if data.get(name) is not None}
    defaults = {"solver": "", "source": "", "joints": [], "std": {}, "std_robust": {}, "at_bound": {}, "metrics": {},
                "wall_s": 0.0}
    checks = {
        "system": lambda k, v: _text(k, v),
        "friction": lambda k, v: choice(k, v, FRICTIONS, "friction model"),
        "asymmetric": flag, "varpro": flag, "warm_start": flag, "output_error": flag,
        "solver": lambda k, v: _text(k, v, empty=True),
        "layout": lambda k, v: _text(k, v, empty=True),
        "source": _source,
        "joints": _names,
        "params": _parameters, "fixed": _parameters, "idm_params": _parameters, "at_bound": _parameters,
        "std": _sigmas, "std_robust": _sigmas,
        "metrics": _metrics,
        "wall_s": lambda k, v: number(k, v),
        "joint_map": _joint_map,
        "warnings": _lines, "notes": _lines,
        "drive": _drive,
        "window": lambda k, v: window_value(mapping(k, v)),
        "bounds": lambda k, v: {n: bound_value(f"{k}.{n}", b) for n, b in mapping(k, v).items()},
        "optimizer": mapping, "consistency": mapping, "idm": mapping,
        "uncertainty": mapping, "holdout": mapping, "plausibility": mapping, "law_choice": mapping,
        "velocity_range": _velocity_range,
        "standard_parameters": _standard_parameters,
        "preprocessing": _preprocessing,
        "identifiability": mapping,
        "held_joints": _parameters,  # {model joint: position (rad or m)}, each finite
        "no_effort_joints": _names, "unexcited_joints": _names,
        "request": lambda k, v: v,  # IdentifyRequest.from_dict checks it
    }
    nulls = [k for k in REQUIRED_KEYS if data[k] is None]
    if nulls:
        raise FieldError(nulls[0], " must be given, got null")
    return {**defaults, **{k: checks[k](k, v) for k, v in given.items()}}


def _text(key: str, value, empty: bool = False) -> str:
    if not isinstance(value, str) or not (value or empty):
        raise FieldError(key, f" must be {'a' if empty else 'a non-empty'} string, got {value!r}")
    return value


def _source(key: str, value) -> str | list[str]:
    if isinstance(value, str) or (isinstance(value, list) and value and all(isinstance(v, str) for v in value)):
        return value
    raise FieldError(key, f" must be a source name or a list of them, got {value!r}")


def _names(key: str, value) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(j, str) and j for j in value):
        raise FieldError(key, f" must be a list of joint names, got {value!r}")
    repeated = sorted({j for j in value if value.count(j) > 1})
    if repeated:
        raise FieldError(key, f" repeats {repeated}")
    return value


def _lines(key: str, value) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(line, str) for line in value):
        raise FieldError(key, f" must be a list of strings, got {value!r}")
    return value


def _finite(key: str, value) -> float:
    """``value`` if it is a number, finite and within ±MAX_PARAMETER."""
    if isinstance(value, bool) or not isinstance(value, Real):
        raise FieldError(key, f" must be a number, got {'null' if value is None else repr(value)}")
    if not math.isfinite(value) or abs(value) > MAX_PARAMETER:
        raise FieldError(key, f" must be a finite number within ±{MAX_PARAMETER:g}, got {value!r}")
    return value


def _parameters(key: str, value) -> dict[str, float]:
    return {name: _finite(f"{key}.{name}", v) for name, v in mapping(key, value).items()}


def _sigmas(key: str, value) -> dict[str, float]:
    for name, v in mapping(key, value).items():
        if isinstance(v, bool) or not isinstance(v, Real):
            raise FieldError(f"{key}.{name}", f" must be a number (NaN: not determined), got {v!r}")
    return value


def _velocity_range(key: str, value) -> dict[str, list[float]]:
    """{row: [slowest, fastest]} speeds, each a number ≥ 0."""
    out = {}
    for row, speeds in mapping(key, value).items():
        if (not isinstance(speeds, list) or len(speeds) != 2
                or not all(isinstance(v, Real) and not isinstance(v, bool) and v >= 0 for v in speeds)):
            raise FieldError(f"{key}.{row}", f" must be [slowest, fastest] speeds ≥ 0, got {speeds!r}")
        out[row] = [float(v) for v in speeds]
    return out


def _metrics(key: str, value) -> dict:
    metrics = mapping(key, value)
    for name, v in metrics.items():
        if name == "per_joint":
            for joint, row in mapping(f"{key}.per_joint", v).items():
                if not isinstance(row, Mapping):
                    raise FieldError(f"{key}.per_joint.{joint}", f" must be a mapping of metrics, got {row!r}")
                for metric, x in row.items():
                    if x is not None and (isinstance(x, bool) or not isinstance(x, Real)):
                        raise FieldError(f"{key}.per_joint.{joint}.{metric}", f" must be a number, got {x!r}")
        elif not (v is None or isinstance(v, (Real, str, Mapping))):
            raise FieldError(f"{key}.{name}", f" must be a number, got {v!r}")
    return value


def _joint_map(key: str, value) -> dict[str, str]:
    joint_map = mapping(key, value)
    if not all(isinstance(v, str) and v for v in joint_map.values()):
        raise FieldError(key, f" must map data joint names to model joint names, got {value!r}")
    return value


def _drive(key: str, value) -> dict:
    from frictionid_core.drive import drive_from_dict

    drive = mapping(key, value)
    if drive:
        try:
            drive_from_dict(drive, "the drive")
        except FrictionIdError as exc:
            raise FieldError(key, f": {exc}") from None
    return value


LINK_KEYS = ("mass", "com", "inertia", "rotor", "rotor_inertia")
INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def _standard_parameters(key: str, value) -> dict:
    """Per link {mass, com [x, y, z], inertia {ixx … izz}, rotor, rotor_inertia}
    (:func:`frictionid_core.consistency.check.standard_record`), every number finite."""
    for link, record in mapping(key, value).items():
        where = f"{key}.{link}"
        record = mapping(where, record)
        missing = [k for k in LINK_KEYS if k not in record]
        if missing:
            raise FieldError(where, f" lacks {missing}")
        _finite(f"{where}.mass", record["mass"])
        _finite(f"{where}.rotor_inertia", record["rotor_inertia"])
        com = record["com"]
        if not isinstance(com, list) or len(com) != 3:
            raise FieldError(f"{where}.com", f" must be [x, y, z], got {com!r}")
        for axis, x in zip("xyz", com):
            _finite(f"{where}.com.{axis}", x)
        inertia = mapping(f"{where}.inertia", record["inertia"])
        for name in INERTIA_KEYS:
            if name not in inertia:
                raise FieldError(f"{where}.inertia", f" lacks '{name}'")
            _finite(f"{where}.inertia.{name}", inertia[name])
        if record["rotor"] is not None:
            _text(f"{where}.rotor", record["rotor"])
    return value


def _preprocessing(key: str, value) -> dict:
    """The settings of a ``preprocessing`` block (its other keys are a report): types, finite
    numbers, then :class:`~frictionid_core.preprocess.Preprocessing`'s own checks."""
    from frictionid_core.preprocess import Preprocessing

    block = mapping(key, value)
    for name in ("trim_start_s", "trim_end_s", "trim_start", "trim_end"):
        if block.get(name) is not None:
            _finite(f"{key}.{name}", block[name])
    for name in ("order", "decimate", "thin"):
        if name in block:
            integer(f"{key}.{name}", block[name], low=1, optional=name == "decimate")
    for name in ("cutoff_hz", "min_speed", "stick_speed", "dip_scale"):  # a number or {joint: number}
        speeds = block.get(name)
        if isinstance(speeds, Mapping):
            _parameters(f"{key}.{name}", speeds)
        elif speeds is not None:
            _finite(f"{key}.{name}", speeds)
    for name in ("velocity", "filter", "metric"):
        if name in block:
            _text(f"{key}.{name}", block[name])
    try:
        Preprocessing.from_dict(block, 1.0)
    except FrictionIdError as exc:
        raise FieldError(key, f": {exc}") from None
    return value
