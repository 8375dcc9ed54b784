"""Checks of a request's fields: each value's type and range, a bad one a :class:`FieldError` naming it."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import fields
from numbers import Integral, Real

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
