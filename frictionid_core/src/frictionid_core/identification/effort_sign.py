"""Efforts logged with the opposite sign to the model's joint axis (:func:`checked_effort_sign`).

A driver may report a joint's effort with the sign opposite to its URDF axis (the real TIAGo's
``arm_3_joint`` and ``arm_4_joint``). Fitted as logged, that joint's friction comes out negative
(the sign constraint holds it at 0) and its torque is badly predicted; no bound or prior mends it.
The check: a joint-side fit whose viscous and Coulomb levels of one joint all end at or below 0
is fitted again with those joints' efforts negated (a joint-side drive with ``effort_scale`` −1
there). The negation is the answer when it leaves each such joint at most :data:`CLEARLY_BETTER`
of its relative error and the whole fit a smaller one — a joint whose effort does follow the axis
fits far worse negated, so a sign flip is never taken on a close call. ``effort_sign: auto`` then
returns the negated fit (its drive holds the signs: ``validate`` and the node's screen read them);
``as-logged`` keeps the log's signs and says what negating would give.
"""

from __future__ import annotations

from dataclasses import replace

from frictionid_core.drive import drive_from_dict, load_drive
from frictionid_core.identification.request import IdentifyRequest
from frictionid_core.identification.result import IdentifyResult

# A negated effort is taken when it leaves each such joint at most this share of its relative error.
CLEARLY_BETTER = 0.7
_LEVELS = ("Fv", "Fc")  # the friction levels whose signs say the effort runs against the motion


def negative_friction_rows(result: IdentifyResult) -> list[str]:
    """The fitted joints whose viscous and Coulomb levels (each branch) are all ≤ 0: held at the
    sign constraint's 0, or negative where the user's bounds allow it."""
    rows = []
    for row in result.joints:
        levels = [v for name, v in result.params.items()
                  if name.startswith(f"{row}/") and name[len(row) + 1:].split("_")[0] in _LEVELS]
        if levels and all(v <= 0.0 for v in levels):
            rows.append(row)
    return rows


def negated_drive(request: IdentifyRequest, joints: list[str], negate: list[str]) -> dict | None:
    """The drive keys of ``request``'s drive (none: a joint-side drive of ``joints``, the log's
    joints as the model names them) with the efforts of ``negate`` negated; None for a drive whose
    friction or efforts are on the motors (a motor's effort is not one joint's)."""
    drive = request.drive
    if drive is None:
        keys = {"name": "effort signs", "joints": list(joints), "side": "joint"}
    else:
        loaded = load_drive(drive) if isinstance(drive, str) else drive_from_dict(drive, "the request's drive")
        if loaded.side != "joint" or loaded.friction_on != "joint":
            return None
        keys = loaded.to_dict()
    scale = list(keys.get("effort_scale") or [1.0] * len(keys["joints"]))
    model = [request.joint_map.get(j, j) for j in negate]
    if not set(model) <= set(keys["joints"]):
        return None
    keys["effort_scale"] = [-s if j in model else s for j, s in zip(keys["joints"], scale)]
    return keys


def checked_effort_sign(fit, series, request: IdentifyRequest, result: IdentifyResult,
                        joints: list[str]) -> IdentifyResult:
    """``result`` (the fit of ``request`` on ``series`` as logged), or, when some joints' friction
    ends ≤ 0 and negating their efforts fits them clearly better, the negated fit (``auto``) or
    ``result`` with a warning saying so (``as-logged``). ``fit(series, request)`` fits;
    ``joints``: the logged joints (model names)."""
    negate = negative_friction_rows(result)
    keys = negated_drive(request, joints, negate) if negate else None
    if keys is None:
        return result
    trial = fit(series, replace(request, drive=keys, effort_sign="as-logged"))
    before = {j: result.metrics["per_joint"][j]["relerr_pct"] for j in negate}
    after = {j: trial.metrics["per_joint"][j]["relerr_pct"] for j in negate}
    better = (all(after[j] <= CLEARLY_BETTER * before[j] for j in negate)
              and trial.metrics["relerr_pct"] < result.metrics["relerr_pct"]
              and not negative_friction_rows(trial))
    errors = ", ".join(f"{j} {before[j]:.3g} → {after[j]:.3g} %" for j in negate)
    if not better:
        return replace(result, warnings=[*result.warnings, (
            f"friction of {', '.join(negate)} at or below 0: their efforts do not oppose their motion as the model "
            f"expects, and negating them does not clearly help (relerr {errors}); check the driver's effort units "
            "and the model")])
    scales = ", ".join(f"{v:g}" for v in keys["effort_scale"])
    yaml = f"joints: [{', '.join(keys['joints'])}], effort_scale: [{scales}]"
    if request.effort_sign == "auto":
        return replace(trial, request=request, warnings=[(
            f"{_efforts(negate, 'is', 'are')} logged with the sign opposite to the model's joint axes: "
            f"as logged their friction came out ≤ 0; negated they fit with positive friction (relerr {errors}), "
            f"so this fit negates them (the result's drive: {yaml}; validate reads it from there, a node needs it "
            "in its drive_file); --effort-sign as-logged keeps the log's signs"), *trial.warnings])
    return replace(result, warnings=[*result.warnings, (
        f"{_efforts(negate, 'seems', 'seem')} logged with the sign opposite to the model's joint axes: "
        f"negated they fit with positive friction (relerr {errors}); a drive with {yaml} (or --effort-sign auto) "
        "fits them so")])


def _efforts(joints: list[str], one: str, several: str) -> str:
    """"the effort of a is" / "the efforts of a, b are" (the verbs given)."""
    return f"the effort of {joints[0]} {one}" if len(joints) == 1 else f"the efforts of {', '.join(joints)} {several}"
