"""Identified parameters against the ground truth of synthetic data, and the noise floor.

The *noise floor* of a validation recording is the relative error that the true parameters
themselves reach on it through the same pre-processing (noise, differentiation and
slow-row exclusion included); an identification is as good as the data allow when its
one-step-ahead relative error on that recording is close to the floor.

A parameter is *determined* by the data when its standard deviation σ (from the fit's
Jacobian) is below 1 % of its true magnitude; relative-error thresholds only make sense
for those (a true product of inertia of 3e−6 kg·m² cannot be matched to 5 %). Every other
parameter is judged by its error in units of σ. A parameter is *resolvable* to a tolerance
when 1.96 σ (95 %) is below that fraction of its true magnitude. For least squares under
Gaussian noise σ is the Cramér–Rao bound, so a parameter whose σ is larger (or whose truth
is 0) cannot be placed within the tolerance with 95 % confidence by any unbiased estimator on
that recording; at a given noise level σ shrinks only as 1/√(duration).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from frictionid_core.errors import FrictionIdError

DETERMINED_RSD = 0.01
RESOLVE_TOLERANCE_PCT = 5.0
Z95 = 1.96


def select_truth(truth: dict, bag: str | None = None) -> dict:
    """A single-recording truth from a synth truth file or a multi-bag one (``{"bags": {…}}``)."""
    if "bags" not in truth:
        return truth
    bags = truth["bags"]
    if bag is None:
        if len(bags) != 1:
            raise FrictionIdError(f"the truth file holds several recordings {sorted(bags)}; pick one with --bag")
        return next(iter(bags.values()))
    name = Path(str(bag).split(":/", 1)[0].rstrip("/")).name
    if name not in bags:
        raise FrictionIdError(f"no truth for '{name}'; recordings: {sorted(bags)}")
    return bags[name]


def compare(result: dict, truth: dict) -> dict:
    """{parameter: {estimate, truth, error, relerr_pct, sigma, sigma_pct, z, determined}} + a summary."""
    from frictionid_core.robots.synth import expected_parameters

    exp = expected_parameters(truth, result["system"], result.get("joints"))
    rows = {}
    for name, est in result["params"].items():
        if name not in exp:
            continue
        tv = exp[name]
        err = est - tv
        sd = result.get("std", {}).get(name, float("nan"))
        rel = 100.0 * err / abs(tv) if tv != 0 else float("nan")
        determined = bool(tv != 0 and np.isfinite(sd) and sd < DETERMINED_RSD * abs(tv))
        rows[name] = {"estimate": est, "truth": tv, "error": err, "relerr_pct": rel, "sigma": sd,
                      "sigma_pct": 100.0 * sd / abs(tv) if tv != 0 else float("inf"),
                      "z": err / sd if sd and np.isfinite(sd) else float("nan"), "determined": determined}
    det = [r for r in rows.values() if r["determined"]]
    resolvable = [r for r in rows.values() if Z95 * r["sigma_pct"] < RESOLVE_TOLERANCE_PCT]
    summary = {
        "parameters": len(rows),
        "determined": len(det),
        "resolvable_5pct": len(resolvable),
        "max_abs_relerr_pct_resolvable_5pct": max((abs(r["relerr_pct"]) for r in resolvable), default=float("nan")),
        "max_abs_relerr_pct_determined": max((abs(r["relerr_pct"]) for r in det), default=float("nan")),
        "max_abs_z": max((abs(r["z"]) for r in rows.values() if np.isfinite(r["z"])), default=float("nan")),
    }
    return {"parameters": rows, "summary": summary}


def noise_floor(series, result: dict, truth: dict) -> dict:
    """OSA relative error of ``result`` and of the true parameters on ``series``, and their ratio."""
    from frictionid_core.identification import validate
    from frictionid_core.robots.synth import expected_parameters

    exp = expected_parameters(truth, result["system"], result.get("joints"))
    missing = [n for n in result["params"] if n not in exp]
    if missing:
        raise FrictionIdError(f"the truth has no value for {missing}")
    ident = validate(series, result)["relerr_pct"]
    floor = validate(series, dict(result, params={n: exp[n] for n in result["params"]}))["relerr_pct"]
    return {"relerr_pct": ident, "floor_relerr_pct": floor, "ratio": ident / floor}
