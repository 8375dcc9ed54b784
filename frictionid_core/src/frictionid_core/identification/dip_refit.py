"""The dip-refit policy: a friction dip (Stribeck, Threlfall) that the pre-processing rates chosen
from the data cannot follow makes the identification refit at the rates its estimate needs
(:func:`fit_at_dip_rates`; a cut-off no higher than the position noise allows: :func:`noise_caps`,
with a warning), or warns when the user set those rates, naming rates that, passed back,
hold (:func:`dip_advice`, :func:`settled_dip_advice`). A dynamic law refits at the cut-off at which
it predicts the effort best instead (:mod:`.dynamic_rates`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification.dynamic_rates import presliding_changes
from frictionid_core.identification.solve import Fit
from frictionid_core.model import IdentificationModel
from frictionid_core.preprocess import Preprocessing, cutoff_range, dip_needs, rule_decimation

# At most this many refits when a friction dip needs finer rates than those chosen.
DIP_ROUNDS = 4
ADVICE_MARGIN = 0.02  # a cut-off advised for a dip: this much above its need
NOISE_CAP_ROUNDS = 3  # a dip's cut-off lowered to what the position noise allows at most this many times


def fit_at_dip_rates(model: IdentificationModel, settings: Preprocessing,
                     rebuild: Callable[[Preprocessing], IdentificationModel],
                     fit: Callable[..., Fit]) -> tuple[IdentificationModel, Fit]:
    """``fit(model)``, then while the dip of the estimate needs finer rates than those chosen from
    the data, ``fit(rebuild(settings with those rates), previous)`` (too coarse a rate
    overestimates vs, so this may take a few rounds); a dynamic law's, while it predicts the effort
    better at higher cut-offs (:func:`~.dynamic_rates.presliding_changes`). Returns the last model
    and its fit. Rates at which the model cannot be built (a joint's rows all left out there) are
    not followed: the report's ``dip_not_followed`` says why.
    ``fit(model, previous=None)``: see :func:`frictionid_core.identification.solve.fit_static`."""
    result = fit(model)
    dynamic = model.friction.is_dynamic
    for _ in range(DIP_ROUNDS):
        changes, why = (presliding_changes(model, result.x, settings, rebuild) if dynamic
                        else dip_changes(model, result.x))
        if not changes:
            break
        from_data = model.obs.report["from_data"]
        limited = model.obs.report.get("dip_noise_limited")
        try:
            rebuilt = rebuild(replace(settings, **changes))
            caps: dict[str, float] = {}
            for _ in range(NOISE_CAP_ROUNDS):  # the noise at the capped rates may allow a little less
                lower = noise_caps(rebuilt, changes.get("cutoff_hz"), model.obs.preprocessing.cutoff_hz)
                if not lower:
                    break
                caps = {**caps, **lower}
                limited = (f"{why}, but the position noise dominates q̈ above "
                           + ", ".join(f"{hz:.3g} Hz ({j})" for j, hz in caps.items()))
                changes, _ = dip_changes(model, result.x, caps)
                if not changes:
                    break
                rebuilt = rebuild(replace(settings, **changes))
        except FrictionIdError as exc:
            model.obs.report["dip_not_followed"] = f"{why}, but at those rates {exc}"
            break
        if not changes:
            model.obs.report["dip_noise_limited"] = limited
            break
        model = rebuilt
        model.obs.report["from_data"] = sorted(set(from_data) | set(model.obs.report["from_data"]))
        model.obs.report["presliding_rates" if dynamic else "dip"] = why
        if limited:
            model.obs.report["dip_noise_limited"] = limited
        result = fit(model, result)
    return model, result


def model_dip_needs(model: IdentificationModel, x: np.ndarray
                    ) -> tuple[int, dict[str, float], str, dict[str, float]]:
    """(largest decimation, {row joint: smallest cut-off}, why, {row joint: speed scale}) the
    friction dip of the fit ``x`` needs: see :func:`frictionid_core.preprocess.dip_needs`, for its
    speed scale (vs or v0) of each joint and branch at the joint's reversal acceleration (the
    smaller of a joint's two branches); a scale at its lower bound (a dip that vanished) is skipped."""
    obs = model.obs
    n_max, needs, why, scales = np.iinfo(np.int32).max, {}, "", {}
    if model.is_linear:
        return n_max, needs, why, scales
    lo, _ = model.bounds()
    fs = obs.report["sample_rate_hz"]
    scale = model.friction.law.nonlinear[0]
    for i in model.nonlinear_index:
        name = model.names[i]
        vanished = x[i] <= lo[i] and i not in model.fixed_values  # a searched dip at its lower bound
        if name.rsplit("/", 1)[-1].removesuffix("_pos").removesuffix("_neg") != scale or vanished:
            continue
        joint = name.split("/", 1)[0] if "/" in name else obs.joints[0]
        a = obs.report.get("reversal_acceleration", {}).get(joint) or 0.0
        n, fc = dip_needs(fs, a, x[i])
        scales[joint] = min(float(x[i]), scales.get(joint, np.inf))
        if n < n_max or fc > max(needs.values(), default=0.0):
            why = (f"{joint}: its friction dip ({name} {x[i]:.3g}) is crossed at reversals at up to {a:.3g}/s²; "
                   f"it needs an analysis rate ≥ {fs / n:.4g} Hz and a cut-off ≥ {fc:.3g} Hz")
        n_max, needs[joint] = min(n, n_max), max(fc, needs.get(joint, 0.0))
    return n_max, needs, why, scales


def raised_cutoffs(cutoff_hz: float | dict[str, float], needs: dict[str, float]) -> dict[str, float]:
    """The cut-offs (one value or {data joint: Hz}) raised to what the dips of ``needs`` ({row
    joint: Hz}) need; a row joint that is no data joint (a motor) raises every joint below its need."""
    cutoffs = dict(cutoff_hz) if isinstance(cutoff_hz, dict) else {}
    for joint, fc in needs.items():
        for name in ([joint] if joint in cutoffs else list(cutoffs)):
            cutoffs[name] = max(cutoffs[name], fc)
    return cutoffs


def cutoff_shortfall(cutoff_hz: float | dict[str, float], needs: dict[str, float]) -> bool:
    """True when a cut-off of ``cutoff_hz`` is below what the dips of ``needs`` need."""
    if not isinstance(cutoff_hz, dict):
        return any(fc > cutoff_hz * (1 + 1e-9) for fc in needs.values())
    raised = raised_cutoffs(cutoff_hz, needs)
    return any(raised[j] > cutoff_hz[j] * (1 + 1e-9) for j in raised)


def noise_caps(rebuilt: IdentificationModel, raised: dict[str, float] | None,
               before: float | dict[str, float] | None) -> dict[str, float]:
    """{joint: the highest cut-off [Hz] its position noise allows} for the joints whose cut-off a dip
    raised (``raised`` over ``before``) into a noise-dominated q̈ in ``rebuilt`` (the model at the
    raised rates; its report's ``qdd_clean_cutoff_hz``), at least the cut-off ``before``. A dip
    followed there trades the dip's bias for the inertia's: a UR10 shoulder on a quantised encoder,
    its dip fitted at 4.6 Hz needing 88 Hz, fitted at 74 % where 4.3 % at 10 Hz."""
    if not isinstance(raised, dict):
        return {}
    clean = rebuilt.obs.report.get("qdd_clean_cutoff_hz") or {}
    old = before if isinstance(before, dict) else dict.fromkeys(raised, before)
    return {j: max(float(clean[j]), float(old.get(j) or 0.0)) for j, hz in raised.items()
            if clean.get(j) and hz > (old.get(j) or 0.0) * (1 + 1e-9) and clean[j] < hz}


def dip_changes(model: IdentificationModel, x: np.ndarray, caps: dict[str, float] | None = None
                ) -> tuple[dict, str]:
    """The pre-processing changes (among the settings chosen from the data) the dip of ``x``
    needs, and why; {} when none. ``caps``: {joint: Hz} no raised cut-off passes
    (:func:`noise_caps`).

    A decimation chosen from the data goes down to what the dip needs; the rows are then thinned
    (``thin``, ``dip_scale``: see :func:`frictionid_core.preprocess.thinned_rows`) back to the
    rule's rate for the cut-off wherever the dip is not crossed fast: the fine rate there only
    adds rows (and seconds and GBs on long logs). A cut-off the folds chose with each joint's
    low-speed friction curve among their models (``cross_validation.dips``) is not raised: they judged
    it by what it predicts of the dips (a Panda at 4.1 kHz with 12-bit encoders, cut-offs raised from 10 to
    21.5–31.6 Hz for two joints' dips: 4.1 % on a second log; kept: 1.8 %, a 1.3 % floor, the
    least-squares baseline 2.3 %). A dynamic law keeps the rule's rates: its states
    travel with the filtered position, which a raised cut-off fills with noise (and q̈ with it)."""
    if model.friction.is_dynamic:
        return {}, ""
    n, needs, why, scales = model_dip_needs(model, x)
    pre, chosen = model.obs.preprocessing, model.obs.report["from_data"]
    changes = {}
    cutoff = pre.cutoff_hz
    if cutoff_shortfall(cutoff, needs) and "cutoff_hz" in chosen and not judged_cutoffs(model):
        raised = raised_cutoffs(cutoff, needs)
        raised = {j: min(hz, (caps or {}).get(j, hz)) for j, hz in raised.items()}
        if raised != (cutoff if isinstance(cutoff, dict) else dict.fromkeys(raised, cutoff)):
            cutoff = changes["cutoff_hz"] = raised
    if "decimate" in chosen:
        rule = rule_decimation(model.obs.report["sample_rate_hz"], cutoff)
        n = min(n, rule)
        if n < pre.decimate or changes:
            changes["decimate"] = n
            changes["thin"] = max(1, rule // n)
            changes["dip_scale"] = scales if changes["thin"] > 1 else None
    return changes, why


def judged_cutoffs(model: IdentificationModel) -> bool:
    """True when the folds chose the cut-offs of ``model`` with a model that has each joint's
    low-speed friction curve among theirs (``cross_validation.dips``): judged by what they predict
    of the dips, neither raised nor advised higher. (Where the Coulomb model predicted best, the dip did
    not show at those rates: a 1 mrad encoder's joint with vs 0.004 rad/s, 2 Hz chosen, raised to
    the 18 Hz the position noise allows: Fs −42 %; kept: Fs +2 %, vs −2.5 %.)"""
    return bool((model.obs.report.get("cross_validation") or {}).get("dips"))


@dataclass(frozen=True)
class DipAdvice:
    """The rates a fit's friction dip needs where the user set coarser ones (:func:`dip_advice`)."""

    why: str  # which dip needs what
    here: str  # the rates used
    decimate: int  # the decimation to use
    cutoff_hz: float  # the cut-off to use (every joint)

    def warning(self) -> str:
        return (f"{self.why} (here {self.here}): vs and δ come out biased; use --decimate {self.decimate} --cutoff "
                f"{self.cutoff_hz:.3g}")


def dip_advice(model: IdentificationModel, x: np.ndarray) -> DipAdvice | None:
    """The rates the dip of ``x`` (a static law's) needs when the settings the user gave are too
    coarse for it; None when they are fine. A fit at too coarse rates overestimates vs, so a fit at
    these rates may need finer ones still: :func:`settled_dip_advice` follows the advice until it
    holds."""
    if model.friction.is_dynamic or "dip_not_followed" in model.obs.report:
        return None
    n, needs, why, _ = model_dip_needs(model, x)
    if judged_cutoffs(model):  # the cut-offs the folds chose stand; a decimation the user set may still be too coarse
        needs = {}
    pre = model.obs.preprocessing
    if n >= pre.decimate and not cutoff_shortfall(pre.cutoff_hz, needs):
        return None
    low, high = cutoff_range(pre.cutoff_hz)
    here = f"{model.obs.report['analysis_rate_hz']:.4g} Hz and " + (f"{low:.3g} Hz" if low == high
                                                                    else f"{low:.3g}…{high:.3g} Hz")
    return DipAdvice(why, here, min(n, pre.decimate), _advised_cutoff(max([*needs.values(), high])))


def _advised_cutoff(need: float) -> float:
    """``need`` with ADVICE_MARGIN, rounded up to the 3 digits a warning prints (what a user passes
    back is what was tried, and a refit's need a hair above its estimate's holds)."""
    x = need * (1.0 + ADVICE_MARGIN)
    digits = 2 - int(np.floor(np.log10(x)))
    return float(np.ceil(x * 10.0**digits) / 10.0**digits)


def settled_dip_advice(advice: DipAdvice, refit: Callable[[int, float], DipAdvice | None]) -> DipAdvice:
    """``advice`` followed until it holds: ``refit(decimate, cutoff_hz)`` fits again at those rates
    (as a user passing them would) and gives its own advice (None: they suffice). The advice of the
    warning, followed, does not bring the warning back (DIP_ROUNDS rounds at most; the last advice
    otherwise)."""
    first = advice.why
    for _ in range(DIP_ROUNDS):
        finer = refit(advice.decimate, advice.cutoff_hz)
        if finer is None:
            break
        advice = replace(advice, why=f"{first}; fitted again at the rates it needs, {finer.why}",
                         decimate=min(finer.decimate, advice.decimate),
                         cutoff_hz=max(finer.cutoff_hz, advice.cutoff_hz))
    return advice
