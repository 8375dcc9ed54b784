"""An experiment's recording judged before anything is applied (no ROS import): identified on its
first part, validated on the rest (:func:`fit_and_validate`), accepted only when the validation is
close enough to its noise floor (:func:`judge`).

The split is a time from the recording's first sample: the identification's request keeps its window
(``window = (None, split_s)``), so ``frictionid identify BAG --request RESULT.json`` fits the same
samples again and gives the same parameters; the validation takes the rest (``window = (split_s,
None)``) with the identification's pre-processing (:func:`frictionid_core.identification.validate`).

:func:`judge` accepts when the validation's relative error is at most ``max_floor_ratio`` × its noise
floor (the error the effort's own noise leaves: an identification as good as the data allow is close
to 1) and, when ``max_relerr_pct`` > 0, at most that. The safety screen of the parameters is the
applier's, after this (:mod:`frictionid_core.safety`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from frictionid_core.errors import InputError

DEFAULT_VALIDATION_SHARE = 0.3
DEFAULT_MAX_FLOOR_RATIO = 1.5


@dataclass(frozen=True)
class Verdict:
    """Whether the validation passes, and one line saying why (not)."""

    accepted: bool
    reason: str


def check_share(share: float) -> float:
    """A validation share in (0, 1); InputError otherwise."""
    if not (math.isfinite(share) and 0.0 < share < 1.0):
        raise InputError(f"the validation share must be a fraction in (0, 1), got {share:g}")
    return float(share)


def fit_and_validate(series, request, split_s: float):
    """(result, validation metrics) of ``request`` identified on ``series`` before ``split_s`` [s from
    its first sample] and validated after it."""
    from frictionid_core.identification import identify, validate

    asked = replace(request, window=(None, float(split_s)))
    result = identify(series, asked)
    return result, validate(series, result, window=(float(split_s), None))


def judge(validation: dict, max_floor_ratio: float = DEFAULT_MAX_FLOOR_RATIO, max_relerr_pct: float = 0.0) -> Verdict:
    """The verdict on a validation (its ``relerr_pct`` and ``noise_floor_pct``), see the module docstring."""
    if not (math.isfinite(max_floor_ratio) and max_floor_ratio > 0):
        raise InputError(f"the validation threshold (× the noise floor) must be > 0, got {max_floor_ratio:g}")
    err, floor = float(validation.get("relerr_pct", math.nan)), float(validation.get("noise_floor_pct", math.nan))
    if not math.isfinite(err):
        return Verdict(False, "the validation has no relative error")
    if not (math.isfinite(floor) and floor > 0):
        return Verdict(False, f"the validation's noise floor is unknown ({floor:g} %): nothing to judge "
                              f"{err:.4g} % against")
    ratio = err / floor
    text = f"validation {err:.4g} % = {ratio:.3g} × its noise floor {floor:.4g} %"
    if ratio > max_floor_ratio:
        return Verdict(False, f"{text} > {max_floor_ratio:g} ×")
    if max_relerr_pct > 0 and err > max_relerr_pct:
        return Verdict(False, f"{text}, over {max_relerr_pct:g} %")
    return Verdict(True, f"{text} ≤ {max_floor_ratio:g} ×" + (f", ≤ {max_relerr_pct:g} %" if max_relerr_pct > 0
                                                               else ""))
