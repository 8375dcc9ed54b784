"""Identification results side by side, against the ground truth of synthetic data, and the noise floor.

:func:`compare_fits` puts two or more fits side by side: per parameter the values, σ, the
difference to the first fit and that difference in units of the combined σ
√(σ₁² + σ₂²) (the fits' errors are treated as independent; two fits of the same data are
correlated, so read it as a scale, not as a test), the metrics (overall and per joint) and the
settings (system, friction, pre-processing, drive, …) that differ.

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
that recording; at a given noise level σ shrinks only as 1/√(duration). The *coverage* is the share
of the identified parameters (those with a σ: not fixed, held or at a bound) whose 1.96 σ interval
holds the truth: about 95 % when σ means what it says. It is given for the calibrated σ
(``std_robust``, docs/reference.md#uncertainty: what to read σ as) and for the white-noise σ
(``std``, which assumes a right model and white residuals).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification import validate
from frictionid_core.preprocess import Preprocessing
from frictionid_core.robots import INERTIA_ENTRIES, QUANTITIES
from frictionid_core.synthetic import expected_parameters

DETERMINED_RSD = 0.01
RESOLVE_TOLERANCE_PCT = 5.0
Z95 = 1.96


# Result keys whose values are listed when they differ between fits (nested dicts key by key).
SETTING_KEYS = ("system", "joint_map", "joints", "friction", "asymmetric", "solver", "varpro", "source", "layout",
                "window", "fixed", "bounds", "preprocessing", "drive")
PER_JOINT_METRICS = ("relerr_pct", "rmse", "r2")


def fit_labels(count: int) -> list[str]:
    """Column labels of ``count`` fits: A, B, C, …"""
    return [chr(ord("A") + k) if k < 26 else f"F{k + 1}" for k in range(count)]


def check_result(result, name: str) -> None:
    """Raise FrictionIdError unless ``result`` (read from ``name``) is an identification result."""
    hint = "expected the JSON written by 'frictionid identify'"
    if not isinstance(result, dict) or not isinstance(result.get("params"), dict):
        if isinstance(result, dict) and ("base_parameters" in result or "bags" in result):
            raise FrictionIdError(f"{name}: a ground truth, not an identification result; pass it with --truth")
        raise FrictionIdError(f"{name}: not an identification result (no 'params' object); {hint}")
    for key in ("system", "friction"):
        if not isinstance(result.get(key), str):
            raise FrictionIdError(f"{name}: identification result without '{key}'; {hint}")
    bad = [n for n, v in result["params"].items() if not _is_number(v)]
    if bad:
        raise FrictionIdError(f"{name}: parameter(s) {bad} are not numbers; {hint}")
    for key in ("std", "metrics"):
        if not isinstance(result.get(key, {}), dict):
            raise FrictionIdError(f"{name}: '{key}' is not an object; {hint}")


def compare_fits(results: list[dict], files: list[str] | None = None) -> dict:
    """Two or more identification results (``IdentifyResult.to_dict()``) side by side.

    Fits are labelled A, B, …; differences are taken against A. Returns::

        fits:       [{label, file, system, friction, asymmetric, solver, source, joints, warnings}]
        parameters: {name: {values, sigma: {label: float | None},
                            difference, z: {label of B, C, …: float | None}}}
                    (z = difference / √(σ_A² + σ²); None where a value or σ is missing)
        only_in:    {name: [labels of the fits that have it]} for names not in every fit
        metrics:    {metric: {label: value | None}} (the scalar metrics)
        per_joint:  {joint: {relerr_pct | rmse | r2: {label: value | None}}} (``metrics.per_joint``)
        settings:   {key: {label: value | None}} for the SETTING_KEYS (dotted for nested keys) that differ

    Raises FrictionIdError for fewer than two fits, a malformed result, or fits sharing no parameter.
    """
    files = list(files) if files is not None else [f"fit {k + 1}" for k in range(len(results))]
    if len(results) < 2 or len(files) != len(results):
        raise FrictionIdError("comparing fits needs two or more results (and one name per result)")
    for result, name in zip(results, files):
        check_result(result, name)
    labels = fit_labels(len(results))
    names = _union(r["params"] for r in results)
    shared = [n for n in names if all(n in r["params"] for r in results)]
    if not shared:
        systems = ", ".join(f"'{r['system']}'" for r in results)
        raise FrictionIdError(f"{' and '.join(files)} share no parameter (systems {systems}): nothing to compare")
    ref, ref_sd = results[0]["params"], results[0].get("std", {})
    parameters = {}
    for n in names:
        values = {lab: _number(r["params"].get(n)) for lab, r in zip(labels, results)}
        sigma = {lab: _number(r.get("std", {}).get(n)) for lab, r in zip(labels, results)}
        diff, z = {}, {}
        for lab in labels[1:]:
            d = values[lab] - ref[n] if n in ref and values[lab] is not None else None
            comb = _combined_sigma(_number(ref_sd.get(n)), sigma[lab])
            diff[lab], z[lab] = d, (d / comb if d is not None and comb else None)
        parameters[n] = {"values": values, "sigma": sigma, "difference": diff, "z": z}
    metrics = {m: {lab: _number(r.get("metrics", {}).get(m)) for lab, r in zip(labels, results)}
               for m in _union(r.get("metrics", {}) for r in results)
               if any(_is_number(r.get("metrics", {}).get(m)) for r in results)}
    per_joint = {j: {m: {lab: _number(_per_joint(r).get(j, {}).get(m)) for lab, r in zip(labels, results)}
                     for m in PER_JOINT_METRICS}
                 for j in _union(_per_joint(r) for r in results)}
    flat = [flatten({k: _setting(k, r[k]) for k in SETTING_KEYS if k in r}) for r in results]
    settings = {k: {lab: f.get(k) for lab, f in zip(labels, flat)} for k in _union(flat)
                if any(f.get(k) != flat[0].get(k) for f in flat[1:])}
    fits = [{"label": lab, "file": str(f), **{k: r.get(k) for k in ("system", "friction", "asymmetric", "solver",
                                                                         "source", "joints")},
             "warnings": list(r.get("warnings") or [])} for lab, f, r in zip(labels, files, results)]
    only_in = {n: [lab for lab, r in zip(labels, results) if n in r["params"]] for n in names if n not in shared}
    return {"fits": fits, "parameters": parameters, "only_in": only_in, "metrics": metrics,
            "per_joint": per_joint, "settings": settings}


def compare_payloads(payloads: list, files: list[str]) -> dict:
    """Two or more payloads (:class:`~frictionid_core.robots.payload_model.Payload`) side by side, as
    :func:`compare_fits` puts fits: {payloads: [{label, file, link, feasible, resolved}],
    quantities: {quantity: {values, sigma, difference, z}}} (mass kg, centre of mass m, inertia
    about it kg·m²; differences against A, z in units of the combined σ; σ None where held)."""
    if len(payloads) < 2:
        raise FrictionIdError("comparing payloads needs two or more payload files")
    labels = fit_labels(len(payloads))
    links = sorted({p.link for p in payloads})
    if len(links) > 1:
        raise FrictionIdError(f"{' and '.join(files)} are payloads on different links ({', '.join(links)}): their "
                              "centres of mass and inertias are in different frames")

    def entries(p, sigma: bool) -> list:
        block = (p.sigma or {}) if sigma else {"mass": p.mass, "com": p.com, "inertia": p.inertia}
        com = block.get("com") or [None] * 3
        inertia = block.get("inertia") or [[None] * 3] * 3
        return [block.get("mass"), *com, *(inertia[a][b] for a, b in INERTIA_ENTRIES.values())]

    values = [entries(p, False) for p in payloads]
    sigmas = [entries(p, True) for p in payloads]
    quantities = {}
    for k, name in enumerate(QUANTITIES):
        row = {"values": {lab: _number(v[k]) for lab, v in zip(labels, values)},
               "sigma": {lab: _number(s[k]) for lab, s in zip(labels, sigmas)}, "difference": {}, "z": {}}
        for lab in labels[1:]:
            d = row["values"][lab] - row["values"][labels[0]]
            comb = _combined_sigma(row["sigma"][labels[0]], row["sigma"][lab])
            row["difference"][lab], row["z"][lab] = d, (d / comb if comb else None)
        quantities[name] = row
    listed = [{"label": lab, "file": str(f), "link": p.link, "feasible": p.feasible, "resolved": list(p.resolved)}
              for lab, f, p in zip(labels, files, payloads)]
    return {"payloads": listed, "quantities": quantities}


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _number(v) -> float | None:
    return float(v) if _is_number(v) else None


def _combined_sigma(a: float | None, b: float | None) -> float | None:
    if a is None or b is None or not (np.isfinite(a) and np.isfinite(b)):
        return None
    return float(np.hypot(a, b)) or None


def _union(keyed) -> list[str]:
    """The keys of several mappings, in first-seen order."""
    return list(dict.fromkeys(k for d in keyed for k in d))


def _per_joint(result: dict) -> dict:
    per_joint = result.get("metrics", {}).get("per_joint")
    return per_joint if isinstance(per_joint, dict) else {}


def _setting(key: str, value):
    """A result's setting as compared: of the ``preprocessing`` block only the settings (its other
    keys report what the data said, e.g. the noise floor, which differs with every fit)."""
    if key == "preprocessing" and isinstance(value, dict):
        from dataclasses import fields

        names = {f.name for f in fields(Preprocessing)}
        return {k: v for k, v in value.items() if k in names}
    return value


def flatten(d: dict, prefix: str = "") -> dict:
    """Settings for a table: nested dicts → {"a.b": value}; other values (lists too) as they are."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict) and v:
            out.update(flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def select_truth(truth: dict, bag: str | list | None = None) -> dict:
    """A single-recording truth from a synth truth file or a multi-bag one (``{"bags": {…}}``);
    ``bag``: a recording (a result's ``source``, a list of one)."""
    if "params" in truth and "system" in truth:
        raise FrictionIdError("the truth file is an identification result, not a ground truth: compare two fits "
                              "with 'frictionid compare A.json B.json'")
    if "bags" not in truth:
        return truth
    bags = truth["bags"]
    if isinstance(bag, list):
        if len(bag) != 1:
            raise FrictionIdError(f"the result was fitted on several recordings {bag}; pick the truth with --bag")
        bag = bag[0]
    if bag is None:
        if len(bags) != 1:
            raise FrictionIdError(f"the truth file holds several recordings {sorted(bags)}; pick one with --bag")
        return next(iter(bags.values()))
    name = Path(str(bag).split(":/", 1)[0].rstrip("/")).name
    if name not in bags:
        raise FrictionIdError(f"no truth for '{name}'; recordings: {sorted(bags)}")
    return bags[name]


def _covers(err: float, sd) -> bool | None:
    """Whether Z95·σ covers the error (None without a finite σ > 0: fixed or undetermined)."""
    sd = _number(sd)
    return None if sd is None or not np.isfinite(sd) or sd <= 0 else bool(abs(err) <= Z95 * sd)


def compare(result: dict, truth: dict) -> dict:
    """{parameter: {estimate, truth, error, relerr_pct, sigma, sigma_pct, z, determined, sigma_robust,
    covered, covered_robust}} + a summary (with the coverage of 1.96 σ and of 1.96 robust σ:
    [parameters whose interval holds the truth, parameters with that σ]; ``coverage_calibrated``:
    {sigma: "std_robust", covered, identified, share}, the coverage of the calibrated σ)."""
    exp = _expected(truth, result)
    robust = result.get("std_robust") or {}
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
                      "z": err / sd if sd and np.isfinite(sd) else float("nan"), "determined": determined,
                      "sigma_robust": _number(robust.get(name)), "covered": _covers(err, sd),
                      "covered_robust": _covers(err, robust.get(name))}
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
    for key, label in (("covered", "coverage"), ("covered_robust", "coverage_robust")):
        known = [r[key] for r in rows.values() if r[key] is not None]
        summary[label] = [sum(known), len(known)]
    hit, n = summary["coverage_robust"]
    summary["coverage_calibrated"] = {"sigma": "std_robust", "covered": hit, "identified": n,
                                      "share": hit / n if n else float("nan")}
    return {"parameters": rows, "summary": summary}


def noise_floor(series, result: dict, truth: dict) -> dict:
    """OSA relative error of ``result`` and of the true parameters on ``series``, and their ratio."""
    exp = _expected(truth, result)
    missing = [n for n in result["params"] if n not in exp]
    if missing:
        raise FrictionIdError(f"the truth has no value for {missing}")
    ident = validate(series, result)["relerr_pct"]
    floor = validate(series, dict(result, params={n: exp[n] for n in result["params"]}))["relerr_pct"]
    return {"relerr_pct": ident, "floor_relerr_pct": floor, "ratio": ident / floor if floor else float("nan")}


def _expected(truth: dict, result: dict) -> dict[str, float]:
    """The truth under the result's parameter names; FrictionIdError when the truth does not fit."""
    try:
        return expected_parameters(truth, result["system"], result.get("joints"))
    except (KeyError, TypeError, AttributeError) as exc:
        raise FrictionIdError(f"the truth does not describe this result (system '{result['system']}', joints "
                              f"{result.get('joints')}): no {exc}; expected 'frictionid synth --truth' output"
                              ) from None
