"""Fit metrics (docs/reference.md#metrics): relative error, R², RMSE, error std, improvement."""

from __future__ import annotations

import math

import numpy as np

from frictionid_core.errors import FrictionIdError

NAN = float("nan")
# The metrics a fit or a cross-test must give as finite numbers to be an answer (R² and the noise
# floor may be NaN: not defined on a constant effort or on a few rows).
FINITE_METRICS = ("relerr_pct", "rmse")


def relerr_pct(y: np.ndarray, y_hat: np.ndarray) -> float:
    """100·‖y − ŷ‖₂ / ‖y‖₂, %."""
    return float(100.0 * np.linalg.norm(y - y_hat) / np.linalg.norm(y))


def fit_metrics(y: np.ndarray, y_hat: np.ndarray) -> dict[str, float]:
    """relerr_pct (%), r2, rmse and error_std (units of y), error_norm (‖y − ŷ‖₂)."""
    y = np.ravel(y)
    e = y - np.ravel(y_hat)
    ss_res = float(e @ e)
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    return {
        "relerr_pct": relerr_pct(y, y_hat),
        "r2": 1.0 - ss_res / ss_tot if ss_tot > 0 else float("nan"),
        "rmse": float(np.sqrt(ss_res / y.size)),
        "error_std": float(np.std(e, ddof=1)),
        "error_norm": float(np.sqrt(ss_res)),
    }


def noise_sigma(residual: np.ndarray, used: np.ndarray) -> float:
    """σ of the white noise in a residual series (one joint's rows in time order), robust to the
    slow model error and to sparse steps: 1.4826·median|Δ²e| / √6 over the second differences
    of three consecutive used rows (nan with fewer than 10)."""
    ok = used[2:] & used[1:-1] & used[:-2]
    d2 = np.diff(residual, 2)[ok]
    return float(1.4826 * np.median(np.abs(d2)) / np.sqrt(6.0)) if d2.size >= 10 else NAN


def metric_rows(obs, y_hat: np.ndarray, rows: np.ndarray | None = None) -> tuple[list[str], np.ndarray, np.ndarray,
                                                                                 np.ndarray]:
    """The rows :func:`observation_metrics` compares: (joints, effort, prediction, used), the last
    three (J·Nd,) joint-major — the joint torques τ = Cᵀ·u of motor rows (a joint's row used when
    every motor turning with it is), else the observation's own rows; ``rows`` (J·Nd,): only those
    of the used rows (default all)."""
    y, used = obs.y, obs.used if rows is None else obs.used & rows
    y_hat = np.ravel(y_hat)
    if obs.coupling is None:
        return list(obs.joints), y, y_hat, used
    motors_used = used.reshape(len(obs.joints), obs.n_samples)
    turns = obs.coupling != 0.0  # (motor, joint): the motor turns with the joint
    used = np.all(~turns[:, :, None] | motors_used[:, None, :], axis=0).reshape(-1)
    return obs.torque_joints, obs.joint_torques(y), obs.joint_torques(y_hat), used


def observation_metrics(obs, y_hat: np.ndarray, rows: np.ndarray | None = None) -> dict:
    """Metrics of the prediction ``y_hat`` (J·Nd,) on the used rows of the observation ``obs``
    (its ``metric`` observation: the recorded effort at the analysis instants, or the filtered
    one under the EMPS protocol; motor rows are mapped to joint torques first, a joint's row
    used when every motor turning with it is): :func:`fit_metrics`, ``samples``, ``noise_floor_pct`` (the
    relative error the effort's noise alone would leave, its σ from the residual by
    :func:`noise_sigma`), ``against`` (which effort) and ``per_joint`` {joint: {relerr_pct,
    rmse, r2, noise_floor_pct}}. ``rows`` (J·Nd,): only those of the used rows (default all)."""
    joints, y, y_hat, used = metric_rows(obs, y_hat, rows)
    nd = obs.n_samples
    out = fit_metrics(y[used], y_hat[used])
    out["samples"] = int(used.sum())
    per_joint, noise_sum, power_sum = {}, 0.0, 0.0
    for j, joint in enumerate(joints):
        rows = slice(j * nd, (j + 1) * nd)
        keep = used[rows]
        yj, pj = y[rows][keep], y_hat[rows][keep]
        power = float(yj @ yj)
        m = fit_metrics(yj, pj) if yj.size > 1 and power > 0 else dict.fromkeys(("relerr_pct", "r2", "rmse"), NAN)
        row = {k: m[k] for k in ("relerr_pct", "rmse", "r2")}
        noise = float(np.square(noise_sigma(y[rows] - y_hat[rows], keep))) * yj.size  # inf, not OverflowError
        row["noise_floor_pct"] = 100.0 * float(np.sqrt(noise / power)) if power > 0 else NAN
        if np.isfinite(noise):
            noise_sum += noise
            power_sum += power
        per_joint[joint] = row
    out["noise_floor_pct"] = 100.0 * float(np.sqrt(noise_sum / power_sum)) if power_sum > 0 else NAN
    out["against"] = ("effort low-passed by the decimation filter (the EMPS benchmark's metric)"
                      if obs.preprocessing.metric == "filtered" else "recorded effort at the analysis instants")
    out["per_joint"] = per_joint
    return out


ALL_ROWS_KEYS = ("relerr_pct", "rmse", "r2", "samples")


def all_rows_metrics(obs, y_hat: np.ndarray) -> dict:
    """The ``all_rows`` metrics of a prediction on every row of a full observation (standstill
    and reversals included): relerr_pct, rmse, r2, samples and per joint relerr_pct, rmse, r2."""
    m = observation_metrics(obs, y_hat)
    out = {k: m[k] for k in ALL_ROWS_KEYS}
    out["per_joint"] = {j: {k: v[k] for k in ("relerr_pct", "rmse", "r2")} for j, v in m["per_joint"].items()}
    return out


def improvement_pct(err_new: float, err_ref: float) -> float:
    """Δ = 100·(1 − ε_new/ε_ref), %."""
    return 100.0 * (1.0 - err_new / err_ref)


def check_finite(metrics: dict, what: str, keys: tuple[str, ...] = FINITE_METRICS) -> dict:
    """``metrics`` unless one of ``keys`` is missing, NaN or inf: FrictionIdError naming ``what``
    (such numbers are no answer; the caller writes nothing)."""
    bad = {k: metrics.get(k) for k in keys
           if isinstance(metrics.get(k), bool) or not isinstance(metrics.get(k), (int, float))
           or not math.isfinite(metrics[k])}
    if bad:
        shown = ", ".join(f"{k} {v}" for k, v in bad.items())
        raise FrictionIdError(f"{what} gives non-finite metrics ({shown}): the effort is zero or the model "
                              "overflows on these data")
    return metrics
