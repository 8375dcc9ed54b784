"""The safety gate of online re-identification (no ROS import).

A candidate parameter set (an :class:`~frictionid_core.identification.IdentifyResult`) replaces the
current one only if it predicts a held-back slice of recent data — samples it was not fitted on —
better: a lower effort RMSE under :func:`frictionid_core.identification.validate` than the current set. A
candidate the safety screen refuses (:func:`frictionid_core.safety.result_refusals`: a non-finite
parameter, a negative friction or inertia, one over its robot's limits or larger than ``max_abs`` in
magnitude) is rejected before any prediction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification import validate
from frictionid_core.safety.screen import result_refusals

if TYPE_CHECKING:
    from frictionid_core.identification import IdentifyResult


@dataclass(frozen=True)
class Decision:
    """What the gate decided: ``accepted``, ``reason`` (one line), and the effort RMSE on the
    held-back slice of the current and candidate sets [N·m | N] (nan when not computed)."""

    accepted: bool
    reason: str
    current_rmse: float = math.nan
    candidate_rmse: float = math.nan


def _rmse(result: IdentifyResult, holdout) -> float:
    try:
        return float(validate(holdout, result)["rmse"])
    except (FrictionIdError, KeyError, ValueError, FloatingPointError) as exc:
        raise FrictionIdError(f"cannot predict the held-back slice: {exc}") from None


def screen_candidate(candidate: IdentifyResult, max_abs: float = 1e3) -> Decision | None:
    """The rejection of a candidate the safety screen refuses (:func:`frictionid_core.safety.result_refusals`
    with ``max_abs``; no prediction needed), else None."""
    refusals = result_refusals(candidate, max_abs=max_abs)
    if refusals:
        return Decision(False, "rejected: " + "; ".join(refusals))
    return None


def review(current: IdentifyResult | None, candidate: IdentifyResult, holdout, max_abs: float = 1e3) -> Decision:
    """Accept ``candidate`` over ``current`` (None: no active set) on the held-back JointSeries
    ``holdout``? ``max_abs``: largest parameter magnitude accepted (SI units)."""
    refused = screen_candidate(candidate, max_abs)
    if refused is not None:
        return refused
    try:
        cand = _rmse(candidate, holdout)
    except FrictionIdError as exc:
        return Decision(False, f"rejected: candidate: {exc}")
    if not math.isfinite(cand):
        return Decision(False, "rejected: the candidate's prediction of the held-back slice is not finite")
    if current is None:
        return Decision(True, f"accepted: no active parameters (held-back RMSE {cand:.4g})", math.nan, cand)
    try:
        cur = _rmse(current, holdout)
    except FrictionIdError as exc:
        return Decision(True, f"accepted: the active set cannot predict the held-back slice ({exc})", math.nan, cand)
    if cand < cur or not math.isfinite(cur):
        return Decision(True, f"accepted: held-back RMSE {cand:.4g} < {cur:.4g} of the active set", cur, cand)
    return Decision(False, f"rejected: held-back RMSE {cand:.4g} >= {cur:.4g} of the active set", cur, cand)
