"""The effort's own lag the loader found, judged by what it predicts.

The loader's scan (:mod:`frictionid_core.preprocess.lag`) regresses each effort on a generic model
of the motion at every shift and keeps the best shift the whole log and a half of it agree on (or
both halves, where the whole does not) as a candidate
(:func:`~frictionid_core.preprocess.effort_lag_candidate`); it moves no effort itself: where that
model misses (a Stribeck dip, an arm's inertial coupling) a true lag still leaves most of the
residual (0.96–0.99 on simulated logs lagged 2–8 ms), and a dynamic friction law fakes one (a LuGre
joint's friction, late at each reversal, left 0.49 of the residual shifted by 9.6 ms, in both halves:
its fits then validated at 1.2–2.7 × the noise floor on six corpus cases).
Here the system's own linear model decides (:func:`confirmed_effort_lags`): the blocked
cross-validation of :mod:`.cross_validation` at the rule's cut-offs (those the folds then choose
from the lagged effort are lower: a low-pass stands in for part of a lag), the candidates' efforts
as logged and shifted by SHARES of their lags; the best shift is taken when it predicts the effort
better by the choices' margin (BETTER_SHARE), the model predicts it at all (INFORMATIVE_PCT) and
the best is not the largest shift. A candidate the motion confirms (EFFORT_SCAN_RATIO, both halves)
is taken as found (:func:`motion_confirmed_lags`); only a lag is judged by the folds, not a lead: a
logging driver stamps the effort late; a lead found this weakly was a misfit the shift offsets (a
one-joint Stribeck log with coloured noise and no lag: −14 ms "predicted" 68 → 30 % by the folds'
Coulomb model, and validated at 34 % against 19 % as logged). A dynamic law's friction follows each
reversal late as a lagged effort does: its own fit judges a confirmed candidate, as logged against
shifted (:func:`law_judged_effort_lags`: a LuGre joint's false 9.6 ms left, a 5.5 ms lag of a Jaco2
taken), and an unconfirmed one is said and left (:func:`unjudged_effort_lags`). ``validate`` reads
a result's effort lag again where its log's loader removed none (:func:`with_result_effort_lag`): a
lag of the logging, as a drive's signs, belongs to the robot.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification.cross_validation import (
    BETTER_SHARE,
    INFORMATIVE_PCT,
    rule_cutoffs_of,
    score_at,
)
from frictionid_core.identification.model_building import all_rows_relerr_pct
from frictionid_core.identification.plan import FitPlan
from frictionid_core.identification.result import IdentifyResult
from frictionid_core.preprocess import Preprocessing, effort_lag_candidate, lag_record, shift_effort
from frictionid_core.timeseries import JointSeries

# The shifts scored: the loader's lag times these (its regression, short of the system's model, can
# misjudge it: a 6 ms lag of an arm on constant-velocity plateaus read as 3.2 ms in each half). A best
# shift at the last share is none: the error falling ever further with the shift is a misfit it offsets.
SHARES = (0.5, 1.0, 1.5, 2.0, 3.0)


def confirmed_effort_lags(sources: list[JointSeries], logged_plan: FitPlan,
                          plan_of: Callable[[list[JointSeries]], FitPlan], requested: Preprocessing,
                          asymmetric: bool = False, fixed: dict[str, float] | None = None) -> list[JointSeries]:
    """``sources`` (a static law's fit), each whose candidate the motion confirms shifted by it, and
    those with a candidate lag it does not confirm shifted by it when the system's model predicts their
    effort better so (module doc; the note saying so appended to each one's notes). ``logged_plan``:
    the fit's plan of ``sources``; ``plan_of(other sources)``: theirs."""
    given, sources = sources, motion_confirmed_lags(sources)
    found = {i: c[:2] for i, c in enumerate(map(effort_lag_candidate, sources)) if c is not None and c[0] > 0}
    if not found:
        return sources
    if any(s is not o for s, o in zip(sources, given)):
        logged_plan = plan_of(sources)
    try:
        cutoffs = rule_cutoffs_of(logged_plan, requested)
        as_logged = score_at(logged_plan, requested, cutoffs, asymmetric, fixed)
        if as_logged is None or not as_logged.relerr_pct < INFORMATIVE_PCT:
            return sources  # a model that does not predict the effort tells nothing of its timing
        scores = {}
        for share in SHARES:  # the candidates' lags × each share, scored alike
            moved = [shift_effort(s, found[i][0] * share, "")[0] if i in found else s for i, s in enumerate(sources)]
            scores[share] = score_at(plan_of(moved), requested, cutoffs, asymmetric, fixed)
    except FrictionIdError:  # the fit says why, in its own words
        return sources
    scored = {share: sc.relerr_pct for share, sc in scores.items() if sc is not None}
    share = min(scored, key=scored.get, default=None)
    if share is None or share == SHARES[-1] or not scored[share] < BETTER_SHARE * as_logged.relerr_pct:
        return sources  # none better, or better ever further: a shift that stands in for a misfit
    out = list(sources)
    for i, (lag, ratio) in found.items():
        why = (f"the log or each half of it finds {lag * 1e3:.3g} ms (a fit of the effort to the motion alone leaves "
               f"{ratio:.2g} × its residual once shifted), and the system's model predicts the effort best shifted by "
               f"{share:g} × that (blocked cross-validation: {as_logged.relerr_pct:.3g} % as logged, "
               + ", ".join(f"{s:g} × {v:.3g} %" for s, v in scored.items()) + ")")
        out[i], note = shift_effort(sources[i], lag * share, why)
        out[i].notes.append(note)
    return out


def motion_confirmed_lags(sources: list[JointSeries]) -> list[JointSeries]:
    """``sources``, each whose effort lag candidate the motion confirms shifted by it (the note appended)."""
    out = []
    for series in sources:
        candidate = effort_lag_candidate(series)
        if candidate is not None and candidate[2]:
            series, note = shift_effort(series, candidate[0], _motion_evidence(*candidate[:2]))
            series.notes.append(note)
        out.append(series)
    return out


def _motion_evidence(lag: float, ratio: float) -> str:
    return (f"a fit of it to the motion leaves {ratio:.2g} × the residual once shifted by {lag * 1e3:.3g} ms, the "
            "least of every shift, in each half of the log alike")


def law_judged_effort_lags(sources: list[JointSeries], fit: Callable[[list[JointSeries]], IdentifyResult]
                           ) -> tuple[IdentifyResult, list[JointSeries]]:
    """(A dynamic law's fit (``fit(sources)``) of ``sources`` as logged, or with the effort lags the
    motion confirms removed where the law predicts the effort better so (its error on every row; the
    same parameters either way), the warning saying which and why; the sources of the fit taken). Its
    friction follows each reversal late as a lagged effort does, so the motion's regression also
    confirms a lag that is the law's own (a LuGre joint without one: 9.6 ms, 0.49 of the residual)."""
    shifted = motion_confirmed_lags(sources)
    if all(s is o for s, o in zip(shifted, sources)):
        return fit(sources), sources
    as_logged, moved = fit(sources), fit(shifted)
    logged_pct, moved_pct = (all_rows_relerr_pct(r.metrics) for r in (as_logged, moved))
    figures = f"{logged_pct:.3g} % as logged, {moved_pct:.3g} % shifted"
    if moved_pct < logged_pct:
        notes = {s.notes[-1] for s, o in zip(shifted, sources) if s is not o}
        judged = f"the law's fit predicts every row better so ({figures})"
        return replace(moved, warnings=[f"{w}; {judged}" if w in notes else w for w in moved.warnings]), shifted
    said = [f"{s.source}: channel lag? the effort lags the position by {c[0] * 1e3:.3g} ms to the motion alone "
            f"({_motion_evidence(*c[:2])}), but the law's fit predicts every row better as logged ({figures}): left "
            "as logged (the law's own lateness at each reversal)"
            for s in sources if (c := effort_lag_candidate(s)) is not None and c[2]]
    return replace(as_logged, warnings=[*as_logged.warnings, *said]), sources


def unjudged_effort_lags(sources: list[JointSeries]) -> list[str]:
    """The warnings of the effort lag candidates of ``sources`` a dynamic law's fit leaves as logged
    (those the motion does not confirm: :func:`law_judged_effort_lags` judges the others)."""
    out = []
    for series in sources:
        candidate = effort_lag_candidate(series)
        if candidate is not None and not candidate[2]:
            lag, ratio, _ = candidate
            out.append(f"{series.source}: channel lag? the effort may {'lag' if lag > 0 else 'run ahead of'} the "
                       f"position by {abs(lag) * 1e3:.3g} ms (a fit of it to the motion alone leaves {ratio:.2g} × its "
                       "residual once shifted): left as logged, a dynamic law's friction follows each reversal late "
                       "alike; a static law's fit (--friction coulomb) judges it by what it predicts")
    return out


def with_result_effort_lag(sources: list[JointSeries], record: Mapping | None) -> list[JointSeries]:
    """``sources``, each whose loader removed no effort lag shifted by the lags a result removed
    (``record``: its ``preprocessing`` block, ``lag_s.effort``: {joint: s}), the note saying so."""
    lags = {j: float(v) for j, v in (((record or {}).get("lag_s") or {}).get("effort") or {}).items() if v}
    if not lags:
        return sources
    out = []
    for series in sources:
        own = (lag_record(series) or {}).get("effort") or {}
        if any(own.values()) or not set(lags) & set(series.joints):
            out.append(series)
            continue
        shifted, note = shift_effort(series, lags, "the identification's result removed it "
                                                   "(preprocessing.lag_s), and this log's loader found none of its own")
        shifted.notes.append(note)
        out.append(shifted)
    return out
