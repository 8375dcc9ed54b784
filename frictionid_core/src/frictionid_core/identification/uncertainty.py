"""σ of the estimates: the white-noise σ of the residual Jacobian (``std``) and a σ robust to
coloured and heteroscedastic residuals (``std_robust``, docs/cli.md#uncertainty).

Both linearise the estimating equations Jᵀe = 0 at the solution (J: the residual Jacobian over
the free parameters, H = JᵀJ; with several joints, of the rows each weighted by its joint's σ:
:mod:`.joint_weights`). The white-noise σ assumes independent residuals of one variance:
cov = s²·H⁻¹. The robust one is the heteroscedasticity-and-autocorrelation-consistent (HAC)
sandwich cov = H⁻¹·S·H⁻¹ of Newey and West: S sums the products of the scores g_t = Σ_j J_jt·e_jt
of each instant t (every joint's row at that instant, so joints may share a disturbance) with
those of the instants within L of it, Bartlett-weighted (1 − l/(L+1)); the bandwidth L comes from
the data (Newey and West 1994: L = 1.1447·(ŝ₁/ŝ₀)^(2/3)·T^(1/3) from the autocovariances of the
summed standardised scores). Joints of different noise levels, a residual coloured by the
filters or by friction the law does not follow are thus counted as they are; a bias that is the
same over the whole log (a filter's lag, a law that misses everywhere alike) is not.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.model import IdentificationModel

# Each half of a specification split is fitted with this share of the full data's information per
# parameter added toward the full estimate: a parameter the half does not determine stays put.
SPLIT_RIDGE = 0.02
SPLITS = ("time", "speed", "acceleration")  # the row splits of the specification term
# Newey–West (1994) bandwidth selection for the Bartlett kernel.
NW_PILOT_FACTOR = 4.0  # pilot lags n = 4·(T/100)^(2/9)
NW_GAMMA_FACTOR = 1.1447


def parameter_jacobian(model: IdentificationModel, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the Jacobian of the prediction w.r.t. the free parameters at x (R, m), the design matrix at
    x (R, L)).

    The prediction is linear in the linear parameters: their columns of J are the design
    matrix's; central differences for the free nonlinear ones (all perturbed predictions in one
    batched call).
    """
    free = model.free_index
    X = model.design(x[None])[0] if not model.is_linear else model.design()
    position = {int(i): k for k, i in enumerate(model.linear_index)}
    J = np.empty((X.shape[0], free.size))
    linear = np.array([k for k, i in enumerate(free) if int(i) in position], dtype=int)
    J[:, linear] = X[:, [position[int(free[k])] for k in linear]]
    nonlinear = np.setdiff1d(np.arange(free.size), linear)
    if nonlinear.size:
        index = free[nonlinear]
        h = 1e-6 * np.maximum(np.abs(x[index]), 1e-3)
        steps = np.zeros((index.size, model.k))
        steps[np.arange(index.size), index] = h
        pred = model.predict(np.vstack([x + steps, x - steps]))
        J[:, nonlinear] = (pred[: index.size] - pred[index.size :]).T / (2.0 * h)
    return J, X


def jacobian_std(model: IdentificationModel, x: np.ndarray, held: set[str] = frozenset()
                 ) -> tuple[dict[str, float], np.ndarray]:
    """σ of each estimate from the residual Jacobian at x: std(e)·sqrt(diag((JᵀJ)⁻¹)), and the
    design matrix at x (R, L). σ 0 for fixed parameters; NaN for those in ``held`` (held at a
    bound: known, like the fixed ones, to the others) and where J is rank-deficient (a parameter
    without influence, e.g. a dip that vanished)."""
    J, X = parameter_jacobian(model, x)
    names = [model.names[i] for i in model.free_index]
    keep = [k for k, n in enumerate(names) if n not in held]
    e = model.residuals(x)
    sd = np.full(len(names), np.nan)
    try:
        cov = np.linalg.inv(J[:, keep].T @ J[:, keep])
        sd[keep] = np.std(e, ddof=1) * np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        pass
    std = dict.fromkeys(model.names, 0.0)
    std.update(zip(names, map(float, sd)))
    return std, X


def sigma_with_held(model: IdentificationModel, x: np.ndarray, std: dict[str, float], held: set[str]
                    ) -> dict[str, float]:
    """``std`` with the parameters ``held`` (at a bound: not identified values) NaN and the others'
    σ taken again with those held, as known (``std`` itself when every one of them already has no σ)."""
    if all(not np.isfinite(std.get(n, np.nan)) for n in held):
        return {**std, **dict.fromkeys(held, float("nan"))}
    again, _ = jacobian_std(model, x, model.held_at_box(x) | set(held))
    return {**again, **dict.fromkeys(held, float("nan"))}


def newey_west_bandwidth(scores: np.ndarray) -> int:
    """The Bartlett bandwidth L (instants) of Newey and West (1994) for the scores (T, m)."""
    T = scores.shape[0]
    scale = scores.std(axis=0)
    z = (scores[:, scale > 0] / scale[scale > 0]).sum(axis=1)
    z = z - z.mean()
    pilot = max(1, min(T - 1, int(NW_PILOT_FACTOR * (T / 100.0) ** (2.0 / 9.0))))
    gamma = np.array([z[lag:] @ z[: T - lag] / T for lag in range(pilot + 1)])
    s0 = gamma[0] + 2.0 * gamma[1:].sum()
    s1 = 2.0 * (np.arange(1, pilot + 1) * gamma[1:]).sum()
    if not s0 > 0.0:
        return pilot
    return int(min(T - 1, max(1, NW_GAMMA_FACTOR * abs(s1 / s0) ** (2.0 / 3.0) * T ** (1.0 / 3.0))))


def instant_scores(J: np.ndarray, e: np.ndarray, instants: int) -> np.ndarray:
    """The scores g_t = Σ_j J_jt·e_jt of each instant (instants, m): every joint's row at that
    instant summed (rows joint-major), so joints may share a disturbance."""
    m = J.shape[1]
    return np.einsum("jtm,jt->tm", J.reshape(-1, instants, m), e.reshape(-1, instants))


def bartlett_sum(scores: np.ndarray, bandwidth: int) -> np.ndarray:
    """Σ_t Σ_s (1 − |t − s|/(L+1))·g_t·g_sᵀ over |t − s| ≤ L (m, m), as the sums of L+1 consecutive
    scores (zero-padded at both ends): a pair l apart is weighed by exactly 1 − l/(L+1)."""
    L, m = bandwidth, scores.shape[1]
    padded = np.concatenate([np.zeros((L + 1, m)), scores, np.zeros((L, m))])
    cumulative = np.cumsum(padded, axis=0)
    window = cumulative[L + 1 :] - cumulative[: -(L + 1)]
    return window.T @ window / (L + 1)


def hac_covariance(J: np.ndarray, e: np.ndarray, instants: int) -> tuple[np.ndarray, int]:
    """(the HAC covariance H⁻¹·S·H⁻¹ (m, m) of least-squares estimates with residual Jacobian J
    (R, m) and residuals e (R,), rows joint-major over ``instants`` instants, the bandwidth L).
    LinAlgError when H is singular. S: :func:`bartlett_sum` of the :func:`instant_scores` at the
    bandwidth of :func:`newey_west_bandwidth`."""
    m = J.shape[1]
    scores = instant_scores(J, e, instants)
    L = newey_west_bandwidth(scores)
    S = bartlett_sum(scores, L)
    Hinv = np.linalg.inv(J.T @ J)
    dof = instants / max(instants - m, 1)
    return dof * Hinv @ S @ Hinv, L


def specification_variance(J: np.ndarray, e: np.ndarray, instants: int, splits: dict[str, np.ndarray],
                           bandwidth: int) -> dict[str, np.ndarray]:
    """{split: the variance (m,) that the disagreement of the split's two halves adds to each estimate}
    (the specification term of the calibrated σ, module doc). ``splits``: {name: rows (R,) of the
    first half} (the others the second); J, e, ``instants`` as :func:`hac_covariance`, whose
    ``bandwidth`` the halves' covariance takes.

    Each half's estimate is one Gauss–Newton step from the full fit on its rows,
    θ_h − θ̂ = (H_h + ε·D)⁻¹·J_hᵀe (D = diag(JᵀJ), ε = :data:`SPLIT_RIDGE`: a parameter the half
    does not determine stays at θ̂); d = θ_1 − θ_2 has the HAC covariance V_d of its per-instant
    shares under a right model; what d² exceeds it by, over 4 (the half-range of the two halves),
    is the variance the residuals alone do not show: max(0, d² − V_d)/4."""
    m = J.shape[1]
    H = J.T @ J
    ridge = SPLIT_RIDGE * np.diag(np.diag(H))
    dof = instants / max(instants - m, 1)
    out = {}
    for name, first in splits.items():
        H1 = masked_gram(J, first)
        inverses = [np.linalg.pinv(H1 + ridge), np.linalg.pinv(H - H1 + ridge)]
        scores = [instant_scores(J, e * half, instants) for half in (first, ~first)]
        shares = scores[0] @ inverses[0].T - scores[1] @ inverses[1].T  # each instant's share of d
        d = shares.sum(axis=0)
        var = dof * np.diag(bartlett_sum(shares, bandwidth))
        out[name] = np.maximum(d**2 - var, 0.0) / 4.0
    return out


def masked_gram(J: np.ndarray, rows: np.ndarray, chunk: int = 65536) -> np.ndarray:
    """J[rows]ᵀ·J[rows] (m, m), a chunk of rows at a time (no copy of J's selected rows at once)."""
    out = np.zeros((J.shape[1], J.shape[1]))
    for start in range(0, J.shape[0], chunk):
        part = J[start : start + chunk][rows[start : start + chunk]]
        out += part.T @ part
    return out


def specification_splits(model: IdentificationModel) -> dict[str, np.ndarray]:
    """The row splits of the specification term (rows joint-major): ``time`` (the instants before
    the middle of the used ones), ``speed`` and ``acceleration`` (each joint's rows at or below
    the median |q̇|, |q̈| of its used rows). A drift, friction that leaves the law at low or high
    speed, an inertia the filters misstate at high acceleration: each makes its halves disagree."""
    obs = model.obs
    T, nj = obs.n_samples, len(obs.joints)
    used = obs.used.reshape(nj, T)
    speed = np.abs(obs.velocity).T  # (nj, T)
    with np.errstate(divide="ignore", invalid="ignore"):  # sources joined end to end: a step of 0 s
        acc = np.nan_to_num(np.abs(np.gradient(obs.velocity, obs.t, axis=0)), nan=0.0, posinf=0.0).T if T > 2 else speed
    instants = np.flatnonzero(used.any(axis=0))
    splits = {"time": np.tile(np.arange(T) < (np.median(instants) if instants.size else T / 2), nj)}
    for name, value in zip(SPLITS[1:], (speed, acc)):
        below = np.zeros((nj, T), dtype=bool)
        for j in range(nj):
            if used[j].any():
                below[j] = value[j] <= np.median(value[j][used[j]])
        splits[name] = below.ravel()
    return splits


def robust_std(model: IdentificationModel, x: np.ndarray, held: set[str] = frozenset()
               ) -> tuple[dict[str, float], np.ndarray | None, list[str], int | None]:
    """(σ robust to coloured and heteroscedastic residuals by name (0 for a fixed parameter,
    NaN for one in ``held`` (at a bound in a closed form) or undetermined), the HAC covariance
    of the others (or None), their names, the bandwidth in instants (or None))."""
    J, _ = parameter_jacobian(model, x)
    names = [model.names[i] for i in model.free_index]
    keep = [k for k, n in enumerate(names) if n not in held]
    std = dict.fromkeys(model.names, 0.0)
    std.update(dict.fromkeys(names, float("nan")))
    kept = [names[k] for k in keep]
    if not keep:
        return std, None, kept, None
    used = model.obs.used
    Ju, e = J[:, keep] * used[:, None], model.residuals(x) * used
    try:
        cov, bandwidth = hac_covariance(Ju, e, model.obs.n_samples)
    except np.linalg.LinAlgError:
        return std, None, kept, None
    extra = specification_variance(Ju, e, model.obs.n_samples, specification_splits(model), bandwidth)
    cov = cov + np.diag(sum(extra.values(), np.zeros(len(kept))))
    std.update(zip(kept, map(float, np.sqrt(np.clip(np.diag(cov), 0.0, None)))))
    return std, cov, kept, bandwidth


def calibration_scale(std: dict[str, float], std_robust: dict[str, float], names: list[str]) -> float:
    """The median over ``names`` (those with both σ finite and > 0) of (calibrated σ / white σ)²,
    at least 1: how much less the rows inform than white residuals of their variance would (1
    without such a name)."""
    ratios = [(std_robust[n] / std[n]) ** 2 for n in names
              if n in std and n in std_robust and np.isfinite(std[n]) and np.isfinite(std_robust[n]) and std[n] > 0
              and std_robust[n] > 0]
    return max(1.0, float(np.median(ratios))) if ratios else 1.0


def white_covariance(model: IdentificationModel, x: np.ndarray, names: list[str]) -> np.ndarray | None:
    """s²·(JᵀJ)⁻¹ over the free parameters ``names`` (the others held), s² the residual variance
    as :func:`jacobian_std` takes it; None without names or when JᵀJ is singular."""
    J, _ = parameter_jacobian(model, x)
    free = [model.names[i] for i in model.free_index]
    cols = [free.index(n) for n in names]
    if not cols:
        return None
    try:
        return np.var(model.residuals(x), ddof=1) * np.linalg.inv(J[:, cols].T @ J[:, cols])
    except np.linalg.LinAlgError:
        return None


def uncertainty_record(bandwidth: int | None, model: IdentificationModel) -> dict:
    """The ``uncertainty`` block: how ``std`` and ``std_robust`` were obtained."""
    rate = model.obs.report.get("analysis_rate_hz")
    return {"std": "white residuals: std(e)·sqrt(diag((JᵀJ)⁻¹))",
            "std_robust": "calibrated: HAC sandwich (Newey–West, Bartlett kernel, bandwidth chosen from the data) "
                          "+ the specification term (halves of the rows split by time, speed and acceleration "
                          "that disagree beyond their own σ)",
            "calibrated": "std_robust",
            "splits": list(SPLITS),
            "bandwidth_instants": bandwidth,
            "bandwidth_s": None if bandwidth is None or not rate else bandwidth / float(rate)}
