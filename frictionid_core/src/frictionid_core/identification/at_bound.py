"""A parameter at a bound is not an identified value (docs/cli.md#at-bound).

A fit that ends with a parameter at a bound of its search (a nonlinear law's ``vs``, ``δ``, ``v0`` at
the edge of its search box, the data's bounds or ``--bounds``; a linear parameter held at a bound of
the closed form, e.g. a friction level held at 0 by the sign constraint) has found where the
optimum would lie *beyond* the bound, not the parameter's value: the result lists it in ``at_bound``
({name: the bound}), gives it no σ (NaN: the others' σ are taken with it held, as known) and the
table prints ``at bound B`` instead of a value ± σ.

A parameter is at a bound when it lies within :data:`AT_BOUND_SIGMAS` of its own σ of it (judged
against its σ, not the width of the search range: an estimate a tenth of its σ from a bound cannot
be told from it), or, without a finite σ, at the bound to round-off (:data:`AT_BOUND_RTOL`); a
linear parameter the closed form holds at its box is at a bound whatever its σ.

:func:`nonlinear_at_bound` names a result's nonlinear friction parameters at a bound: a law that
needs a bound to fit is no better supported than the simpler law it nests (``--friction auto``
prefers the simpler one).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from frictionid_core.friction import elements_of, get_model
from frictionid_core.model import IdentificationModel, parameter_kind

# Within this many σ of a bound a parameter is at it; without a finite σ, to this relative round-off.
AT_BOUND_SIGMAS = 0.1
AT_BOUND_RTOL = 1e-9


def near(x: float, b: float, sd: float) -> bool:
    """Whether ``x`` is at the bound ``b`` (see the module doc), σ ``sd`` (NaN: unknown)."""
    if not np.isfinite(b):
        return False
    if np.isfinite(sd) and sd > 0.0:
        return abs(x - b) <= AT_BOUND_SIGMAS * sd
    return abs(x - b) <= AT_BOUND_RTOL * max(abs(b), 1.0)


def bounds_reached(names: list[str], values: np.ndarray, std: Mapping[str, float], lower: np.ndarray,
                   upper: np.ndarray, held: set[str] = frozenset()) -> dict[str, float]:
    """{name: the bound it is at} of parameters ``names`` with ``values`` and bounds ``lower``,
    ``upper`` (each (m,)); ``held``: names a closed form holds at a bound (at it whatever their
    σ). Fixed parameters (lower == upper) are not at a bound: their value is given."""
    out = {}
    for name, x, lo, hi in zip(names, np.asarray(values, dtype=float), lower, upper):
        if lo == hi:
            continue
        sd = float(std.get(name, np.nan))
        if name in held:
            sd = float("nan")
        for b in (lo, hi):
            if near(float(x), float(b), sd) or (name in held and abs(x - b) <= AT_BOUND_RTOL * max(abs(b), 1.0)):
                out[name] = float(b)
                break
    return out


def fit_at_bound(model: IdentificationModel, x: np.ndarray, std: Mapping[str, float],
                 closed_form: bool = True) -> dict[str, float]:
    """{name: bound} of the free parameters of ``model`` at ``x`` (k,) that end at a bound, judged
    against their σ in ``std``: the nonlinear ones at their search bounds
    (:meth:`~frictionid_core.model.IdentificationModel.bounds`); the linear ones at the box the
    closed form enforces (``closed_form``: ``ls`` or variable projection; held there whatever
    their σ), else at their search bounds too."""
    lower, upper = (b.copy() for b in model.bounds())
    free = model.free_index
    held = model.held_at_box(x) if closed_form else set()
    if closed_form:
        lower[model.linear_index], upper[model.linear_index] = model.linear_box
    return bounds_reached([model.names[i] for i in free], np.asarray(x)[free], std, lower[free], upper[free], held)


def nonlinear_at_bound(result) -> list[str]:
    """The nonlinear friction parameters (``vs``, ``delta``, ``v0``, a dynamic law's stiffness …) of
    ``result`` (an :class:`~frictionid_core.identification.IdentifyResult` or its JSON) that end at
    a bound of their search: non-empty when the law needed a bound to fit."""
    get = result.get if isinstance(result, Mapping) else lambda key, default=None: getattr(result, key, default)
    at = get("at_bound") or {}
    if not at:
        return []
    params = get("params") or {}
    law = get_model(get("friction"), bool(get("asymmetric")), elements_of(get("friction"), params))
    nonlinear = {parameter_kind(n) for n in law.names} - set(law.law.linear)
    return [n for n in at if parameter_kind(n) in nonlinear]
