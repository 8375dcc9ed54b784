"""An identification of the simulated arm against its hidden truth (no ROS import).

The arm's friction is the core's Stribeck law per joint (:func:`frictionid_core.loop.sim.hidden_friction`:
Fv, Fc, Fs, vs, δ) and its rotor inertias are the robot model's armature. :func:`truth_errors` gives,
per joint, the identified viscous and Coulomb levels (``<joint>/Fv``, ``<joint>/Fc``) and rotor inertia
(``<joint>.Ia``, where the identification resolves it apart from the links: a joint whose rotor inertia
only enters a base parameter together with link inertias has none) beside the truth, with the error in
% of the truth (None where the truth is 0: the error is then given in the parameter's unit).
"""

from __future__ import annotations

import numpy as np


def _entry(value: float | None, truth: float) -> dict:
    if value is None:
        return {"value": None, "truth": float(truth), "error_pct": None}
    err = 100.0 * (value - truth) / abs(truth) if truth != 0 else None
    out = {"value": float(value), "truth": float(truth), "error_pct": err}
    if truth == 0:
        out["error"] = float(value)
    return out


def truth_errors(params: dict[str, float], joints: list[str], hidden: np.ndarray, armature: np.ndarray) -> dict:
    """{joint: {Fv, Fc, Ia: {value, truth, error_pct}}} of identified ``params`` (a result's) against the
    hidden Stribeck table ``hidden`` (J, 5) and the rotor inertias ``armature`` (J,); ``max_abs_pct``
    per quantity over the joints."""
    out: dict = {"per_joint": {}}
    prefix = (lambda j: f"{j}/") if len(joints) > 1 else (lambda j: "")
    for k, j in enumerate(joints):
        row = {name: _entry(params.get(prefix(j) + name), hidden[k, col]) for col, name in ((0, "Fv"), (1, "Fc"))}
        row["Ia"] = _entry(params.get(f"{j}.Ia"), float(armature[k]))
        out["per_joint"][j] = row
    for name in ("Fv", "Fc", "Ia"):
        errs = [abs(r[name]["error_pct"]) for r in out["per_joint"].values() if r[name]["error_pct"] is not None]
        out[f"max_abs_{name}_pct"] = max(errs) if errs else None
    return out
