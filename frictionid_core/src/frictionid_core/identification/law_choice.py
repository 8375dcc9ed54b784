"""The friction law chosen by what it predicts (``--friction auto``).

Each candidate law (Coulomb, Stribeck, LuGre; a one-joint system each with and without its gravity
terms) is fitted on each half of the data in time and predicts the other half; its score is the
relative error over both halves, on the same rows for every law (the moving rows of the Coulomb
fit's min speed, the rows near reversals left out: there the zero-phase filter's smear of a stick
or slip, not the law, sets the error). The simplest law is kept unless a richer one predicts clearly
better (:data:`BETTER_SHARE`) without a nonlinear parameter at its search bound (a law that needs a
bound to fit is not what the data show). All candidates are fitted with the cut-offs the Coulomb
fit of the whole data chose, so they are scored on the same signals.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import DEFAULT_BOUNDS, get_model
from frictionid_core.identification.model_building import Sources, as_sources
from frictionid_core.identification.request import IdentifyRequest
from frictionid_core.identification.result import IdentifyResult
from frictionid_core.identification.settings import PreprocessingOverrides
from frictionid_core.identification.validation import validate
from frictionid_core.preprocess import REVERSAL_PERIODS

AUTO = "auto"
CANDIDATE_LAWS = ("coulomb", "stribeck", "lugre")  # simplest first
ONE_JOINT_SYSTEMS = ("joint",)  # the systems whose gravity terms are a choice (``gravity``)
# A richer candidate replaces a simpler one only below this share of its cross-validated error.
BETTER_SHARE = 0.95
# A shape parameter within this share of its search box's width (of its log-width where the box
# spans decades) from a bound sits at it.
AT_BOUND_SHARE = 1e-3
SHAPE_PARAMETERS = ("vs", "v0", "delta", "sigma0", "sigma1", "k")  # what a richer law adds to Coulomb's


def candidates(request: IdentifyRequest) -> list[IdentifyRequest]:
    """The requests to compare, simplest first: each law (an optimiser where the closed form cannot
    fit it: ``lm``), and for a one-joint system each without and with gravity terms."""
    gravities = (False, True) if request.system in ONE_JOINT_SYSTEMS else (request.gravity,)
    out = []
    for gravity in gravities:
        for law in CANDIDATE_LAWS:
            solver = request.solver
            if solver.method == "ls" and (get_model(law).law.nonlinear or get_model(law).is_dynamic):
                solver = replace(solver, method="lm")
            out.append(replace(request, friction=law, gravity=gravity, solver=solver))
    return out


def halves(series: Sources, request: IdentifyRequest) -> tuple[list, list]:
    """Each source of ``series`` (in the request's window) cut in two halves of equal duration."""
    first, second = [], []
    for source in as_sources(series, request.window):
        mid = 0.5 * (source.t[-1] - source.t[0])
        first.append(source.window(None, mid))
        second.append(source.window(mid, None))
    return first, second


def nonlinear_at_bound(result: IdentifyResult, request: IdentifyRequest) -> list[str]:
    """The shape parameters of ``result``'s friction (:data:`SHAPE_PARAMETERS`) at their search
    bounds: those its fit found there (:meth:`IdentifyResult.nonlinear_at_bound`: every bound it
    searched in, the data's too, judged against σ), and those within :data:`AT_BOUND_SHARE` of the
    law's default bounds (the user's over them)."""
    out = list(result.nonlinear_at_bound())
    for name, value in result.params.items():
        if name in out:
            continue
        base = name.rsplit("/", 1)[-1]
        kind = base.removesuffix("_pos").removesuffix("_neg")
        if kind not in SHAPE_PARAMETERS or kind not in DEFAULT_BOUNDS:
            continue
        lo, hi = request.bounds.get(name, DEFAULT_BOUNDS[kind])
        if lo > 0 and hi / lo > 100:  # a box over decades: judged on the log scale
            value, lo, hi = np.log(max(value, 1e-300)), np.log(lo), np.log(hi)
        elif lo == 0 and hi > 0:  # a box from 0 over decades: at 0 only when 0 to within 1e-6 of the box
            if value <= 1e-6 * hi or hi - value <= AT_BOUND_SHARE * hi:
                out.append(name)
            continue
        if min(abs(value - lo), abs(hi - value)) <= AT_BOUND_SHARE * (hi - lo):
            out.append(name)
    return out


def cross_validated(fit: Callable[[Sources, IdentifyRequest], IdentifyResult], parts: tuple[list, list],
                    request: IdentifyRequest, rows: PreprocessingOverrides) -> dict:
    """The candidate ``request`` fitted on each half and scored on the other, on the rows that
    ``rows`` keep: the relative error (%) over both, and the parameters at a bound in either fit."""
    err2 = total = 0.0
    at_bound: list[str] = []
    for train, test in ((parts[0], parts[1]), (parts[1], parts[0])):
        result = fit(train, request)
        metrics = validate(test, result, preprocessing=rows)
        err2 += metrics["relerr_pct"] ** 2 * metrics["samples"]
        total += metrics["samples"]
        at_bound += [n for n in nonlinear_at_bound(result, request) if n not in at_bound]
    return {"cv_relerr_pct": float(np.sqrt(err2 / total)), "at_bound": at_bound}


def identify_auto(series: Sources, request: IdentifyRequest, fit: Callable[..., IdentifyResult],
                  keep: dict | None = None) -> tuple[IdentifyResult, IdentifyRequest]:
    """(the fit of the law that predicts best, the request of that law), the result's ``law_choice``
    recording every candidate's score and why the law was taken; ``fit(series, request[, keep])``
    fits one law (``keep`` passed to the fits of the whole data: it ends holding the chosen one's)."""
    options = candidates(request)
    coulomb = fit(series, options[0], keep)
    settings = coulomb.preprocessing or {}
    fixed = request.preprocessing
    if settings.get("cutoff_hz") is not None and fixed.cutoff_hz is None:
        fixed = replace(fixed, cutoff_hz=settings["cutoff_hz"])
    rows = replace(fixed, min_speed=fixed.min_speed if fixed.min_speed is not None else settings.get("min_speed"),
                   reversal_periods=REVERSAL_PERIODS)
    parts = halves(series, request)
    scored = []
    for option in options:
        try:
            score = cross_validated(fit, parts, replace(option, preprocessing=fixed, window=None), rows)
        except FrictionIdError as exc:  # a law the halves cannot fit: not a candidate
            score = {"cv_relerr_pct": float("inf"), "at_bound": [], "failed": str(exc)}
        scored.append((option, score))
    best, best_score = scored[0]
    for option, score in scored[1:]:
        if score["at_bound"]:
            continue
        if score["cv_relerr_pct"] < BETTER_SHARE * best_score["cv_relerr_pct"]:
            best, best_score = option, score
    why = ("the simplest law; no richer one predicts the other half more than "
           f"{100 * (1 - BETTER_SHARE):.3g} % better without a parameter at its bound"
           if best is options[0] else
           f"predicts the other half {100 * (1 - best_score['cv_relerr_pct'] / scored[0][1]['cv_relerr_pct']):.3g} % "
           "better than Coulomb, no nonlinear parameter at its bound")
    record = {"chosen": best.friction, "gravity": best.gravity, "why": why, "folds": 2,
              "candidates": [{"friction": o.friction, "gravity": o.gravity, **s} for o, s in scored]}
    result = coulomb if best is options[0] else fit(series, best, keep)
    return replace(result, law_choice=record), best
