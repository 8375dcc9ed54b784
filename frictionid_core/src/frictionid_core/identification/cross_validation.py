"""Pre-processing chosen by what it predicts: blocked cross-validation of the torque.

Each source is cut into contiguous pieces in time, dealt to :data:`FOLDS` folds in turn
(:func:`folds_of`), each pre-processed alone (no filter runs across a seam: a fold never sees
another's samples), with the settings of a candidate resolved once on the whole source. The linear
model (the system's rigid body, viscous and Coulomb friction, offsets: the closed form, its sign
constraints kept) is fitted on all folds but one and predicts the recorded effort of the one left
out, at its analysis instants; the candidate's score is the relative error of those predictions
over every fold, per row joint and overall (:func:`cross_validated_error`), the lower of two
layouts of the pieces, long and short (:func:`layout_score`).

Candidates (:func:`cutoff_candidates`): the rule's per-joint cut-offs
(:func:`frictionid_core.preprocess.choose_preprocessing`), the same capped at each value of a
fixed logarithmic grid below its highest one, and the same raised to each value of the grid above
its lowest one, up to the rule's own ceiling (0.2 × the sample rate; not for a dynamic law, whose
fit raises its cut-offs itself: :mod:`.dynamic_rates`). The decimation, trims and min speed follow
each candidate's cut-offs as the rule sets them. The rule's noise bound can sit below the motion: a
UR5 at 56 Hz whose rule took 3.5–7.8 Hz validated at 3.5 % against 2.05 % for least squares at
10 Hz (raised to 10 Hz: 2.14 %); quantised Jaco2 logs at 65 and 451 Hz at 39 and 19 % (raised: 24 and
7.0 %, least squares 23 and 12 %). They are searched coarse to fine: the rule's and the caps at each
decade (1000, 100, 10, 1 Hz), the raised at each decade upwards while each predicts better than the
one below (a 5 kHz log's 1000 Hz is costly; only where the rule's error is below INFORMATIVE_PCT),
then the grid's neighbours of the best while they predict better (the raised ones only where a
decade's beat the rule's). The errors of the caps are not monotonic (a 12-bit encoder at 4.3 kHz,
read by the rule as 1.6 kHz of motion: 104, 73, 102, 109 % from its 859 Hz down to 100 Hz, where a
search stopping on rising errors stopped, while 10 Hz validates at 2.5 %), so no decade below the
rule is ruled out by the ones above it. (Scoring every candidate costs twice as many on a 5 kHz log;
a real 7-DOF arm's joint sweep, 84 % at the rule's 199 Hz, 86 % at 100, 40 % at 46.4, 38 % at 21.5,
151 % at 10 Hz, is found from 100 Hz only when 100 Hz beats the rule's.) Every joint takes the
candidate that predicts its own effort best (:func:`choose_by_cross_validation`), and that choice
stands only where, scored as one candidate, it predicts every row better than the candidate it was
made from: a joint's cut-off changes the columns of every row that sees its motion (a Z1 at 117 Hz
whose shoulder preferred 1 Hz alone: 32 % on a second log).

For a static law with a dip (Stribeck) the folds' model may have each joint's low-speed friction
curve too (:func:`dip_basis`): with Coulomb friction alone the misfit of the dip outweighs what a
cut-off changes, and the choice follows the misfit (that Z1: cross-validated 9.3 % against a 2.1 % floor,
1 Hz chosen for joints whose motion reaches 0.9 Hz; with the curve 3.1 % at 4.6 Hz, 2.3 % on the
second log).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model
from frictionid_core.identification.model_building import observe_plan, on_source, rule_series
from frictionid_core.identification.plan import FitPlan
from frictionid_core.identification.stick import without_rows
from frictionid_core.model import IdentificationModel, Observation
from frictionid_core.preprocess import (
    MAX_CUTOFF_SHARE,
    MIN_SPEED_SHARE,
    Preprocessing,
    TooFewSamples,
    choose_preprocessing,
)
from frictionid_core.timeseries import JointSeries, sample_period

FOLDS = 2  # folds of each source: each predicted from the others, as a later log is
# The two ways a source is cut into pieces (see folds_of), each (seconds a piece lasts at least, pieces
# per fold at most): long pieces, whose filters settle, and short ones, whose folds span every motion.
LAYOUTS = ((5.0, 2), (1.5, 15))
# Cut-offs tried beside the rule's: this many per decade (a ratio of 2.15), down to MIN_GRID_CUTOFF_HZ
# and up to the rule's own ceiling, MAX_CUTOFF_SHARE × the sample rate (its noise bound is a guess the
# folds judge).
GRID_PER_DECADE = 3
MIN_GRID_CUTOFF_HZ = 0.5
# A fold's fit leaves out the directions of its design (unit-scaled columns) whose singular value is
# below this share of the largest (what the identification holds as unresolved, roughly).
RESOLVED_SHARE = 1e-5
# A candidate replaces the rule's choice of a joint only when it predicts that joint's effort with
# less than this share of the rule's cross-validated error (nearby cut-offs differ by less).
BETTER_SHARE = 0.98
# Min speeds tried beside the rule's (MIN_SPEED_SIGMAS σ of the velocity noise): these shares of each
# joint's top speed (99th percentile of its filtered |q̇|).
MIN_SPEED_SHARES = (0.01, 0.02, 0.05)
# A joint's min speed changes only where the folds' fits predict its effort at all (error below this,
# %): a fold whose rigid body extrapolates (a 7-DOF arm's, condition 2e7: 1000 %) tells nothing of it.
INFORMATIVE_PCT = 100.0
# Speed scales of the folds' low-speed friction basis (shares of a joint's top speed) for a law
# with a dip: Stribeck dips of vs 0.5–20 % of the top speed fall within them.
DIP_SCALE_SHARES = (0.01, 0.03, 0.1)
DIP_SHAPES = (1.0, 2.0)  # … each as e^(−|q̇|/s) and e^(−(q̇/s)²)


@dataclass(frozen=True)
class CvScore:
    """The cross-validated relative error (%) of a candidate: overall and per row joint; ``curve``:
    the model that predicted it has each joint's low-speed friction curve (:func:`dip_basis`)."""

    relerr_pct: float
    per_joint: dict[str, float]
    curve: bool = False


def folds_of(plan: FitPlan, folds: int = FOLDS, layout: tuple[float, int] = LAYOUTS[0]) -> list[FitPlan]:
    """``plan`` with each source cut into contiguous pieces of equal duration, dealt to ``folds``
    folds in turn (piece i to fold i mod folds; :func:`pieces_per_fold` of them each): one plan per
    fold, its sources the pieces it holds. Interleaved, every fold spans the log's excitations (a
    Fourier part before micro-motions, one joint's sweep after another's), so no fold's fit must
    predict motion it never saw (the finer ``layout``, the closer; :func:`layout_score`)."""
    out = []
    for k in range(folds):
        sources = []
        for sp in plan.sources:
            elapsed = _elapsed(sp.series)
            n = folds * pieces_per_fold(elapsed[-1], layout)
            edges = np.searchsorted(elapsed, np.arange(n + 1) * elapsed[-1] / n)  # on an edge: the later piece
            edges[-1] = elapsed.size
            sources += [replace(sp, series=sp.series.slice(edges[i], edges[i + 1])) for i in range(k, n, folds)]
        out.append(replace(plan, sources=sources))
    return out


def _elapsed(series: JointSeries) -> np.ndarray:
    """Seconds from the first stamp with each gap between the series' segments
    (:meth:`~frictionid_core.timeseries.JointSeries.segment_bounds`) counted as one sample period
    (a clock jump or a pause splits no piece into nothing)."""
    elapsed = series.t - series.t[0]
    for a, _ in series.segment_bounds()[1:]:
        elapsed[a:] -= series.t[a] - series.t[a - 1] - sample_period(series.t)
    return elapsed


def pieces_per_fold(span_s: float, layout: tuple[float, int] = LAYOUTS[0]) -> int:
    """Pieces of a source of ``span_s`` seconds per fold under ``layout`` (seconds, count): as many as
    keep each at least that long, at most that many (at least 1)."""
    shortest, most = layout
    return int(min(most, max(1, span_s // (FOLDS * shortest))))


def fold_observations(plan: FitPlan, settings: Preprocessing, folds: int = FOLDS,
                      layout: tuple[float, int] = LAYOUTS[0]) -> list[Observation]:
    """The observation of each fold of ``plan`` (:func:`folds_of`; its sources stacked as an
    identification stacks them) under the resolved ``settings``, its trims at most a tenth of the
    shortest piece; TooFewSamples when a piece is too short."""
    pieces = folds_of(plan, folds, layout)
    span = min(sp.series.t[-1] - sp.series.t[0] for piece in pieces for sp in piece.sources)
    trims = {n: min(getattr(settings, n), 0.1 * span) for n in ("trim_start_s", "trim_end_s")}
    return [observe_plan(piece, replace(settings, **trims)) for piece in pieces]


def layout_score(plan: FitPlan, settings: Preprocessing, asymmetric: bool = False,
                 fixed: dict[str, float] | None = None, dips: bool = False
                 ) -> tuple[CvScore, dict[tuple[float, int], list[Observation]]]:
    """(the lower cross-validated error of ``plan`` under the resolved ``settings`` over LAYOUTS,
    {layout: its fold observations}); the layouts that cut the sources alike scored once.

    Each layout's error overstates what the settings predict, for a reason of its own: a fold of
    long pieces holds other motions than the other (constant-velocity plateaus at other speeds), its
    rigid body is extrapolated, and the errors rank cut-offs by chance (a UR5 on plateaus at 109 Hz,
    22 s: four pieces of 5.6 s predicted at 37–52 %, 48 % at 10 Hz where the whole log's fit errs by
    8.7 %, and chose 21.8 Hz: 23 % on a second log; 14 pieces of 1.6 s predict at 9.4 % at 10 Hz and
    choose it: 6.0 %, least squares 6.3 %); in short pieces a low cut-off's filter edges take a larger
    share (a joint swept at 0.25–0.7 Hz whose best cut-off is 2.2 Hz: the rule's 7.5 Hz kept). The lower is
    the nearer. TooFewSamples or FrictionIdError (the first layout's) when no layout can be scored."""
    best, failure, seen, observed = None, None, [], {}
    for layout in LAYOUTS:
        cuts = [pieces_per_fold(_elapsed(sp.series)[-1], layout) for sp in plan.sources]
        if cuts in seen:
            continue
        seen.append(cuts)
        try:
            observed[layout] = fold_observations(plan, settings, layout=layout)
            score = cross_validated_error(observed[layout], asymmetric, fixed, dips=dips)
        except (TooFewSamples, FrictionIdError) as exc:
            failure = failure or exc
            continue
        if best is None or score.relerr_pct < best.relerr_pct:
            best = score
    if best is None:
        raise failure
    return best, observed


def resolved_settings(plan: FitPlan, requested: Preprocessing, cutoffs: dict[str, float]) -> Preprocessing:
    """``requested`` with ``cutoffs`` and the settings that follow them resolved on the whole of
    each source (the first's decimation and trims), as an identification with those cut-offs
    resolves them — but for the min speed: every candidate keeps the same rows, those faster than
    MIN_SPEED_SHARE of each joint's top speed (the user's min speed where given), and its brief
    motions (the ringing of a low cut-off after a stop) scored, not left out. The rule's min
    speed rises with a cut-off's velocity noise: scored on the rows each keeps, a noisy cut-off
    would win by leaving out the rows it gets wrong."""
    settings, speeds = None, {}
    for sp in plan.sources:
        series = rule_series(sp.series, plan.system)
        own, report = choose_preprocessing(series, on_source(replace(requested, cutoff_hz=cutoffs), series))
        settings = settings or own
        floor = {j: MIN_SPEED_SHARE * v for j, v in report["top_speed"].items() if v is not None}
        for j, v in (own.min_speed if requested.min_speed is not None else floor).items():
            speeds.setdefault(j, v)
    # a cut-off's ringing after a stop is scored with it, not left out as brief motion
    brief = 0.0 if requested.brief_periods is None else requested.brief_periods
    return replace(settings, cutoff_hz=dict(cutoffs), min_speed=speeds, brief_periods=brief)


def cross_validated_error(observations: list[Observation], asymmetric: bool = False,
                          fixed: dict[str, float] | None = None,
                          scored: list[Observation] | None = None, dips: bool = False) -> CvScore:
    """Each observation predicted by the Coulomb model fitted on the others (least squares of least
    norm on their summed normal equations, ``fixed`` parameters held at their values): the relative
    error (%) of the predictions of the recorded effort at the analysis instants, over all of
    them, per row joint and overall. ``scored``: the same folds with the rows to predict (default:
    those each fits). ``dips``: the better predicting of that model and one with each joint's
    low-speed friction curve too (:func:`dip_basis`), as a law with a dip (Stribeck) fits it,
    fitted on the rows it predicts (the recorded effort at the analysis instants: the decimated
    rows' anti-alias filter smooths a dip crossed within a few samples, which a curve of the
    decimated velocity does not follow). Folds too short to pin the curve down (a 2.5 s log:
    seconds of one sweep each) extrapolate it (2200 %), and the Coulomb model stands in."""
    if dips:
        return min(cross_validated_error(observations, asymmetric, fixed, scored),
                   _cross_validated_error(observations, asymmetric, fixed, scored, dips=True),
                   key=lambda score: score.relerr_pct)
    return _cross_validated_error(observations, asymmetric, fixed, scored)


def _cross_validated_error(observations: list[Observation], asymmetric: bool = False,
                           fixed: dict[str, float] | None = None,
                           scored: list[Observation] | None = None, dips: bool = False) -> CvScore:
    """:func:`cross_validated_error` of one model: with the low-speed curve where ``dips``."""
    law = get_model("coulomb", asymmetric)
    joints = observations[0].joints
    if dips:  # fitted on the rows it predicts: a dip evaluated at the analysis instants, as the effort is sampled
        observations, scored = [o.metric for o in observations], [o.metric for o in scored or observations]
    scales = dip_scales(observations) if dips else None
    parts, held = [], None
    for obs, target in zip(observations, scored or observations):
        model = IdentificationModel(obs, law, fixed=dict(fixed or {}))
        metric = target.metric
        on = model if metric is obs else IdentificationModel(metric, law, fixed=dict(fixed or {}))
        G, b, Xm = *model.normal_equations, on.design()
        extra = 0
        if scales is not None:
            X, E = model.design(), dip_basis(obs, scales)
            G = np.block([[G, X.T @ E], [E.T @ X, E.T @ E]])
            b = np.concatenate([b, E.T @ obs.y])
            Xm = np.hstack([Xm, dip_basis(metric, scales)])
            extra = E.shape[1]
        parts.append((G, b, Xm, metric.y, metric.used))
        if held is None:
            held = np.array([i in model.fixed_values for i in model.linear_index] + [False] * extra)
            values = np.array([model.fixed_values.get(i, 0.0) for i in model.linear_index] + [0.0] * extra)
    free = ~held
    G, b = sum(p[0] for p in parts), sum(p[1] for p in parts)
    err, ref = np.zeros(len(joints)), np.zeros(len(joints))
    for Gk, bk, Xm, ym, used in parts:
        Gt, bt = G - Gk, b - bk
        x = values.copy()
        x[free] = _least_norm(Gt[np.ix_(free, free)], bt[free] - Gt[np.ix_(free, held)] @ values[held])
        residual = np.where(used, ym - Xm @ x, 0.0).reshape(len(joints), -1)
        err += (residual ** 2).sum(axis=1)
        ref += (np.where(used, ym, 0.0).reshape(len(joints), -1) ** 2).sum(axis=1)
    per_joint = {j: float(100 * np.sqrt(e / r)) if r > 0 else float("nan") for j, e, r in zip(joints, err, ref)}
    total = float(100 * np.sqrt(err.sum() / ref.sum())) if ref.sum() > 0 else float("nan")
    return CvScore(total, per_joint, dips)


def top_speeds(observations: list[Observation]) -> np.ndarray:
    """(J,) each row joint's top speed: the 99th percentile of |q̇| over the used rows of all
    ``observations`` (0 where it never moves)."""
    joints = observations[0].joints
    speeds = np.concatenate([np.abs(o.velocity) * o.used.reshape(len(joints), -1).T for o in observations])
    return np.array([np.percentile(s[s > 0], 99) if (s > 0).any() else 0.0 for s in speeds.T])


def dip_scales(observations: list[Observation]) -> np.ndarray:
    """(J, K) the speed scales of :func:`dip_basis`: DIP_SCALE_SHARES of each row joint's top speed
    (:func:`top_speeds`; 1 where it never moves)."""
    top = top_speeds(observations)
    return np.outer(np.where(top > 0, top, 1.0), DIP_SCALE_SHARES)


def dip_basis(obs: Observation, scales: np.ndarray) -> np.ndarray:
    """(J·Nd, J·K·S) columns sign(q̇_j)·exp(−(|q̇_j|/s_jk)^p) on joint j's rows (its used ones, times
    the row weights of a thinned observation), one per speed scale s_jk of ``scales`` (J, K) and
    shape p of DIP_SHAPES (S): a linear basis of the low-speed friction curve, for a fold's closed
    form."""
    nd, (n_joints, k) = obs.n_samples, scales.shape
    width = k * len(DIP_SHAPES)
    out = np.zeros((n_joints * nd, n_joints * width))
    used = obs.used.reshape(n_joints, nd)
    weight = np.ones(nd) if obs.weight is None else obs.weight
    for j in range(n_joints):
        ratio = np.abs(obs.velocity[:, j])[:, None] / scales[j][None, :]
        block = np.sign(obs.velocity[:, j])[:, None] * np.hstack([np.exp(-ratio**p) for p in DIP_SHAPES])
        out[j * nd:(j + 1) * nd, j * width:(j + 1) * width] = block * (used[j] * weight)[:, None]
    return out


def _least_norm(G: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The solution of the normal equations G·x = b of least norm in unit-scaled columns, the
    directions a fold does not resolve (normalised singular values of the design below
    RESOLVED_SHARE) left at 0: a half's fit of a poorly excited rigid body must not extrapolate."""
    scale = np.sqrt(np.diag(G))
    scale[scale == 0] = 1.0
    return np.linalg.lstsq(G / np.outer(scale, scale), b / scale, rcond=RESOLVED_SHARE**2)[0] / scale


def cutoff_candidates(rule_cutoffs: dict[str, float], ceiling_hz: float | None
                      ) -> tuple[list[dict[str, float]], int]:
    """(the candidates from the highest cut-offs to the lowest, the index of the rule's): the rule's
    cut-offs raised to each value of the grid above their lowest up to ``ceiling_hz`` (None: not
    raised), the rule's, then the rule's capped at each value of the grid below their highest."""
    high, low = max(rule_cutoffs.values()), min(rule_cutoffs.values())
    top = high if ceiling_hz is None else max(high, ceiling_hz)
    grid = 10.0 ** (np.arange(np.floor(np.log10(MIN_GRID_CUTOFF_HZ) * GRID_PER_DECADE),
                              np.floor(np.log10(top) * GRID_PER_DECADE + 1e-9) + 1) / GRID_PER_DECADE)
    raised: list[dict[str, float]] = []
    for floor in (float(g) for g in grid if low * (1 + 1e-9) < g <= top and ceiling_hz is not None):
        lifted = {j: max(c, floor) for j, c in rule_cutoffs.items()}
        if lifted not in raised:
            raised.insert(0, lifted)
    out = [*raised, dict(rule_cutoffs)]
    for cap in (float(g) for g in grid[::-1] if MIN_GRID_CUTOFF_HZ <= g < high):
        capped = {j: min(c, cap) for j, c in rule_cutoffs.items()}
        if capped not in out:
            out.append(capped)
    return out, len(raised)


def _at_decade(cap_hz: float) -> bool:
    """True when ``cap_hz`` is a grid value at a whole decade (1, 10, 100 Hz, …)."""
    exponent = np.log10(cap_hz)
    return bool(abs(exponent - round(exponent)) < 1e-9)


def rule_cutoffs_of(plan: FitPlan, requested: Preprocessing) -> dict[str, float]:
    """{data joint: the highest cut-off (Hz) the rule chooses for it on any source of ``plan``}."""
    out: dict[str, float] = {}
    for sp in plan.sources:
        rule = choose_preprocessing(rule_series(sp.series, plan.system), requested)[0]
        for j, c in rule.cutoff_hz.items():
            out[j] = max(c, out.get(j, 0.0))
    return out


def score_at(plan: FitPlan, requested: Preprocessing, cutoffs: dict[str, float], asymmetric: bool = False,
             fixed: dict[str, float] | None = None) -> CvScore | None:
    """The cross-validated error of ``plan`` at ``cutoffs``; None when the folds cannot be made."""
    try:
        return layout_score(plan, resolved_settings(plan, requested, cutoffs), asymmetric, fixed)[0]
    except (TooFewSamples, FrictionIdError):
        return None


def choose_by_cross_validation(plan: FitPlan, requested: Preprocessing, asymmetric: bool = False,
                               fixed: dict[str, float] | None = None, keep: dict | None = None,
                               dips: bool = False, raised: bool = True) -> tuple[dict[str, float] | None, dict]:
    """({data joint: cut-off} chosen by cross-validation, the record of the choice), or (None,
    record) when the data are too short for the folds. ``requested``: the pre-processing asked for
    (its cut-off None: chosen here).

    The candidate that predicts every row best is taken where it beats the rule's by BETTER_SHARE;
    then each joint whose own effort is a row takes the candidate that predicts that effort best
    (rows that are motors of a coupled drive take the overall choice), and those choices together
    are scored as one more candidate, kept only where it predicts every row better than the
    candidate they were made from (``record["composed"]``). ``keep["folds"]`` receives
    the long layout's fold observations of the chosen cut-offs where they are one candidate's
    (:func:`choose_min_speed` judges on those). ``dips``: each
    candidate is scored by the better of the Coulomb model and one with each joint's low-speed
    friction curve (:func:`cross_validated_error`; the law fitted has a dip). ``raised``: the rule's
    cut-offs raised are candidates too (a dynamic law's fit raises them itself, judged by the law:
    :mod:`.dynamic_rates`)."""
    try:
        rule_cutoffs = rule_cutoffs_of(plan, requested)
    except FrictionIdError as exc:  # the identification says why, in its own words
        return None, {"folds": FOLDS, "skipped": str(exc)}
    record = {"folds": FOLDS, "rule_cutoff_hz": rule_cutoffs, "candidates": [], "dips": dips}
    rate_hz = min((1.0 / dt for dt in (sample_period(sp.series.t) for sp in plan.sources) if dt > 0), default=0.0)
    candidates, rule_at = cutoff_candidates(rule_cutoffs, MAX_CUTOFF_SHARE * rate_hz if raised else None)
    scored: dict[int, CvScore | None] = {}  # by index in candidates; None: could not be scored
    folds: dict[int, list[Observation] | None] = {}  # the long layout's, for choose_min_speed

    def score(i: int) -> CvScore | None:
        if i not in scored:
            try:
                settings = resolved_settings(plan, requested, candidates[i])
                scored[i], observed = layout_score(plan, settings, asymmetric, fixed, dips)
                folds[i] = observed.get(LAYOUTS[0])
            except (TooFewSamples, FrictionIdError) as exc:
                scored[i] = None
                record.setdefault("failed", {})[f"{max(candidates[i].values()):.4g}"] = str(exc)
        return scored[i]

    if score(rule_at) is None:  # the rule's own cut-offs: the data are too short for the folds
        record["skipped"] = record.pop("failed", {}).popitem()[1]
        return None, record
    for i in range(rule_at + 1, len(candidates)):  # coarse: the caps at a whole decade
        if _at_decade(max(candidates[i].values())):
            score(i)
    # … and the floors at a whole decade, upwards while each predicts better than the one below — where the
    # folds predict at all at the rule's (2 s of a TX40, 164 % there: its 100 Hz's 52 % an extrapolation)
    below, informative = rule_at, scored[rule_at].relerr_pct < INFORMATIVE_PCT
    for i in (i for i in range(rule_at - 1, -1, -1) if informative and _at_decade(min(candidates[i].values()))):
        if score(i) is None or scored[i].relerr_pct >= scored[below].relerr_pct:
            break
        below = i
    top = min((i for i in scored if scored[i] is not None), key=lambda i: scored[i].relerr_pct)
    first = 0 if below < rule_at else rule_at  # the floors in between only where a decade's beat the rule's
    while True:  # fine: the grid's neighbours of the best, while one predicts better
        around = [i for i in (top - 1, top + 1) if first <= i < len(candidates) and score(i) is not None]
        step = min(around, key=lambda i: scored[i].relerr_pct, default=top)
        if scored[step].relerr_pct >= scored[top].relerr_pct:
            break
        top = step
    scores: list[tuple[dict[str, float], CvScore]] = [  # the rule's first
        (candidates[i], scored[i]) for i in sorted(scored, key=lambda i: (i != rule_at, i)) if scored[i] is not None]
    record["candidates"] = [{"cutoff_hz": c, "cv_relerr_pct": sc.relerr_pct, "per_joint": sc.per_joint,
                             "curve": sc.curve} for c, sc in scores]
    rule_score = scores[0][1]
    best_cutoffs, best = min(scores, key=lambda s: s[1].relerr_pct)
    whole = dict(best_cutoffs if best.relerr_pct < BETTER_SHARE * rule_score.relerr_pct else rule_cutoffs)
    chosen = dict(whole)
    for j in (j for j in rule_score.per_joint if j in chosen):  # a joint's own effort: its own choice
        own_cutoffs, own = min(scores, key=lambda s: s[1].per_joint[j])
        if own.per_joint[j] < BETTER_SHARE * rule_score.per_joint[j]:
            chosen[j] = own_cutoffs[j]
    if chosen not in candidates:  # the joints' own choices together: a candidate of its own, taken if it predicts
        candidates.append(chosen)  # better than the one they were made from (a joint's torque sees the others')
        composed = score(len(candidates) - 1)
        taken = composed is not None and composed.relerr_pct < scored[candidates.index(whole)].relerr_pct
        record["composed"] = {"cutoff_hz": chosen, "cv_relerr_pct": None if composed is None else composed.relerr_pct,
                              "per_joint": None if composed is None else composed.per_joint, "taken": taken}
        chosen = chosen if taken else whole
    record["cutoff_hz"] = chosen
    if keep is not None:
        keep["folds"] = next((folds[i] for i, c in enumerate(candidates) if c == chosen and i in folds), None)
    return chosen, record


def choose_min_speed(plan: FitPlan, requested: Preprocessing, cutoffs: dict[str, float],
                     asymmetric: bool = False, fixed: dict[str, float] | None = None,
                     observations: list[Observation] | None = None) -> tuple[dict[str, float] | None, dict]:
    """({data joint: min speed} chosen by cross-validation at the chosen ``cutoffs``, the record of
    the choice), or (None, record) when it cannot be made.

    Below a joint's min speed its rows are left out of the fit: near standstill friction leaves its
    law (a joint sticking through micro-motions, the sign of a noisy velocity). Candidates: the
    rule's (from the velocity noise) and MIN_SPEED_SHARES of the joint's top speed. Each fold's fit
    keeps the rows of its candidate; every candidate predicts the same rows (those faster than the
    highest candidate), so a candidate cannot win by leaving out the rows it gets wrong. A joint
    takes the candidate that predicts its effort best where it beats the rule's by BETTER_SHARE and
    the rule's error is below INFORMATIVE_PCT; the joints that are not rows keep the rule's. The folds
    are the long layout's (LAYOUTS[0]): short pieces of a slow sweep fall in step with its period
    (a 0.15 Hz sweep in pieces of 1.7 s: each fold holds the same quarter periods), and so do the
    rows a min speed leaves out (a Stribeck joint's Coulomb fit: its fit error 1.9 → 3.2 %, Fv 1.78
    → 1.66 with the min speed those folds chose). ``observations``: the folds at ``cutoffs`` where
    :func:`choose_by_cross_validation` kept them."""
    record: dict = {"shares_of_top_speed": list(MIN_SPEED_SHARES)}
    try:
        if observations is None:
            observations = fold_observations(plan, resolved_settings(plan, requested, cutoffs))
        rule: dict[str, float] = {}
        for sp in plan.sources:
            series = rule_series(sp.series, plan.system)
            own = choose_preprocessing(series, on_source(replace(requested, cutoff_hz=cutoffs), series))[0]
            for j, v in own.min_speed.items():
                rule[j] = max(v, rule.get(j, 0.0))
    except (TooFewSamples, FrictionIdError) as exc:
        record["skipped"] = str(exc)
        return None, record
    joints = observations[0].joints
    if not set(joints) <= set(rule):  # rows named otherwise than the rule's joints (a drive's motors)
        record["skipped"] = "rows named otherwise than the log's joints"
        return None, record
    top = dict(zip(joints, map(float, top_speeds(observations))))
    candidates = [{j: rule[j] for j in joints}] + [{j: share * top[j] for j in joints} for share in MIN_SPEED_SHARES]
    highest = {j: max(c[j] for c in candidates) for j in joints}
    scored = [_faster(o, highest) for o in observations]
    scores = []
    for speeds_j in candidates:
        try:
            scores.append(cross_validated_error([_faster(o, speeds_j) for o in observations], asymmetric, fixed,
                                                scored))
        except FrictionIdError as exc:
            record["skipped"] = str(exc)
            return None, record
    chosen = dict(rule)  # the joints that are not rows keep the rule's
    for j in joints:
        k = min(range(len(scores)), key=lambda i: scores[i].per_joint[j])
        informative = scores[0].per_joint[j] < INFORMATIVE_PCT
        better = informative and scores[k].per_joint[j] < BETTER_SHARE * scores[0].per_joint[j]
        chosen[j] = candidates[k if better else 0][j]
    record.update(candidates=[{"min_speed": c, "cv_relerr_pct": sc.relerr_pct, "per_joint": sc.per_joint}
                              for c, sc in zip(candidates, scores)], min_speed=chosen)
    return chosen, record


def _faster(obs: Observation, speeds: dict[str, float]) -> Observation:
    """A copy of ``obs`` (and of its sampled observation) with the rows slower than ``speeds`` left out."""
    copy = without_rows(obs, speeds)
    if obs.sampled is not None:
        copy.sampled = without_rows(obs.sampled, speeds)
    return copy


def record_choice(report: dict, choice: dict) -> None:
    """Note in an observation's ``report`` that its cut-offs came from the data by cross-validation
    (``choice``: the record of :func:`choose_by_cross_validation`)."""
    report["cross_validation"] = choice
    if choice.get("cutoff_hz") is not None:
        report["from_data"] = ["cutoff_hz", *[k for k in report.get("from_data", []) if k != "cutoff_hz"]]
        report["cutoff_from_data"] = list(choice["cutoff_hz"])
        report["chosen_from_data"] = True
    if (choice.get("min_speed") or {}).get("min_speed") is not None:
        report["from_data"] = [*[k for k in report.get("from_data", []) if k != "min_speed"], "min_speed"]
