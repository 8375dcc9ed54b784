"""Checks of a request's fields: each value's type and range, a bad one a :class:`FieldError` naming it."""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import fields
from numbers import Integral, Real
from pathlib import Path

from frictionid_core.errors import FrictionIdError


class FieldError(FrictionIdError):
    """A bad value of the request field ``path`` (dotted: ``solver.pop``); ``problem`` follows the
    field's name in the message (``": unknown …"``, ``" must be …"``)."""

    def __init__(self, path: str, problem: str):
        super().__init__(f"request field '{path}'{problem}")
        self.path, self.problem = path, problem


def integer(path: str, value, low: int = 0, optional: bool = True) -> int | None:
    """``value`` as an int ≥ ``low`` (None passes when ``optional``)."""
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, Integral) or value < low:
        raise FieldError(path, f" must be an integer >= {low}, got {value!r}")
    return int(value)


def flag(path: str, value, optional: bool = False) -> bool | None:
    """``value`` if it is a bool (None passes when ``optional``)."""
    if value is None and optional:
        return None
    if not isinstance(value, bool):
        raise FieldError(path, f" must be true or false, got {value!r}")
    return value


def number(path: str, value, optional: bool = False) -> float | None:
    """``value`` as a float, not NaN (None passes when ``optional``)."""
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, Real) or math.isnan(value):
        raise FieldError(path, f" must be a number, got {value!r}")
    return float(value)


def choice(path: str, value, choices, what: str) -> str:
    """``value`` if it is one of ``choices`` (``what`` names them in the message)."""
    if value not in choices:
        raise FieldError(path, f": unknown {what} '{value}'; choose one of {', '.join(choices)}")
    return value


def mapping(path: str, value) -> dict:
    """``value`` as a dict keyed by non-empty names (None: {})."""
    if value is None:
        return {}
    if not isinstance(value, Mapping) or not all(isinstance(k, str) and k for k in value):
        raise FieldError(path, f" must be a mapping of names, got {value!r}")
    return dict(value)


def known_keys(path: str, data: Mapping, cls) -> None:
    """FieldError for the first key of ``data`` that is not a field of the dataclass ``cls``."""
    known = [f.name for f in fields(cls)]
    unknown = [str(k) for k in data if k not in known]
    if unknown:
        raise FieldError(f"{path}.{unknown[0]}" if path else unknown[0], f": unknown; known: {', '.join(known)}")


def window_value(window) -> tuple[float | None, float | None] | None:
    """A time window (start_s, end_s) [s] from a pair or {start_s, end_s} (None: open); None: no window."""
    if window is None:
        return None
    if isinstance(window, Mapping):
        unknown = [str(k) for k in window if k not in ("start_s", "end_s")]
        if unknown:
            raise FieldError(f"window.{unknown[0]}", ": unknown; known: start_s, end_s")
        window = (window.get("start_s"), window.get("end_s"))
    if isinstance(window, str) or not hasattr(window, "__len__") or len(window) != 2:
        raise FieldError("window", f" must be (start_s, end_s) or {{start_s, end_s}}, got {window!r}")
    start, end = (number(f"window.{k}", v, optional=True) for k, v in zip(("start_s", "end_s"), window))
    if start is not None and end is not None and end <= start:
        raise FieldError("window", f": end_s {end} is not after start_s {start}")
    return start, end


def bound_value(path: str, value) -> tuple[float, float]:
    """A bound [lo, hi] as two numbers (FieldError at ``path`` otherwise)."""
    if isinstance(value, str) or not hasattr(value, "__len__") or len(value) != 2:
        raise FieldError(path, f" must be [lo, hi], got {value!r}")
    return number(path, value[0]), number(path, value[1])


def system_name(name) -> str:
    from frictionid_core.systems import FIXED_SYSTEMS, SYSTEM_NAMES, URDF_PREFIX

    if not isinstance(name, str) or not (name in FIXED_SYSTEMS or name == "tx40"
                                         or (name.startswith(URDF_PREFIX) and len(name) > len(URDF_PREFIX))):
        raise FieldError("system", f": unknown system {name!r}; choose one of {', '.join(SYSTEM_NAMES)}")
    return name


def joint_names(joints) -> tuple[str, ...] | None:
    if joints is None:
        return None
    if not isinstance(joints, (list, tuple)) or not joints or not all(isinstance(j, str) and j for j in joints):
        raise FieldError("joints", f" must be a non-empty list of joint names, got {joints!r}")
    dup = sorted({j for j in joints if list(joints).count(j) > 1})
    if dup:
        raise FieldError("joints", f": duplicated name(s) {dup}")
    return tuple(joints)


def drive_value(drive) -> str | dict | None:
    if drive is None or (isinstance(drive, str) and drive):
        return drive
    if isinstance(drive, Path):
        return str(drive)
    if isinstance(drive, Mapping):
        from frictionid_core.drive import drive_from_dict

        try:
            drive_from_dict(dict(drive))
        except FrictionIdError as exc:
            raise FieldError("drive", f": {exc}") from None
        return copy.deepcopy(dict(drive))
    raise FieldError("drive", f" must be a drive file, a bundled drive name or the drive's keys, got {drive!r}")
