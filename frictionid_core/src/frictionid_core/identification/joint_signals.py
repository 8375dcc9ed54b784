"""What each joint's logged signals give a fit: a motion that excites its columns
(:func:`unexcited_joints`) and an effort that carries information (:func:`no_effort_joints`).

* **Motion.** A joint excites its columns in a source when its motion there is neither noise nor
  a tremble. Noise: its range stays within MOVING_FACTOR × its position noise (the pre-processing's
  rule of a moving joint). Tremble: its range stays below :data:`TREMBLE_SHARE` of the fit's motion
  scale — the largest range that any joint of its kind (revolute or prismatic) covers in any source
  of the fit, the joint itself included where it is swept. The scale comes from the data: the
  columns of a joint sweep what its motion makes them sweep, so a joint whose range is a few
  hundredths of the fit's adds rows measured at one configuration and a friction that never slides (a few
  mrad are the pre-sliding range of a gear, where friction is a spring, not a Coulomb level): on
  the real Kinova Gen3 sweeps (one joint swept per log, 2.1–2.6 rad) the other joints tremble over
  1e-6–2.6e-4 rad (≤ 1.3e-4 of the sweeps) and fitting them made every link implausible and the
  fit's own every-row prediction 21498 %; among the real logs' whole-arm excitations (TX40,
  UR10e, Kinova, TIAGo) the least-moving joint still covers 28 % of its arm's largest range
  (TX40 joint 2: 1.99 of 6.98 rad). A fit holds such a joint in that source at its logged
  (median) position, as ``--hold`` would (a robot model keeps that position in the other joints'
  columns), instead of fitting its columns there.
* **Effort.** A joint's effort carries no information when one value makes up :data:`STUCK_SHARE`
  of its samples in motion (a channel reporting 0) or when its own signal-to-noise ratio is below
  :data:`NO_EFFORT_SNR`: the variance of its effort in motion less its noise variance, over that
  noise variance (the noise's σ from the second differences of its samples, robust to the slow
  signal and to sparse steps, as the fit's noise floor takes it). The joint's effort is judged by
  itself alone, never against another joint's: a light wrist's effort is small beside a shoulder's
  but as clean.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.preprocess import MOVING_FACTOR, noise_density
from frictionid_core.timeseries import JointSeries

# A joint trembles in a source when its range there is below this share of the fit's motion scale
# (the largest range a joint of its kind covers in any source of the fit): two decades above the
# trembles of the real Kinova sweeps (≤ 1.3e-4), a decade below the least-moving joint of the real
# whole-arm logs (0.28). At 1 % the trembles of a few mrad beside 1–2 rad sweeps (1–2.7 %) were fitted
# about half the time: on 24 simulated arms with a trembling joint (bench/accuracy.py --cases 24
# --seed 9191 --set excitation=trembling) 0.63 of them validated within 1.2 × the noise floor, 0.71 at 3 %.
TREMBLE_SHARE = 0.03
# An effort carries no information when its signal variance is below this many times its noise
# variance: white noise alone reads 0 (± its sampling spread, ~0.03 over a thousand samples); the
# live joints of the real logs read 3.2 and more (the noisiest: the Kinova joint 1 and 3 sweeps'
# current-based torques at 1 kHz, 3.2 and 4.0; TIAGo ≥ 43, UR10e ≥ 136, TX40 ≥ 277); a perfect model
# of an effort at this ratio would still leave a relative error of 71 % (1/√(1 + SNR)). (The TIAGo
# channels that report nothing read one value 85–88 % of the time: STUCK_SHARE.)
NO_EFFORT_SNR = 1.0
# … or when one and the same value makes up at least this share of its samples in motion (a channel
# reporting 0, or a constant).
STUCK_SHARE = 0.5
# A sample moves when |q̇| (central difference) exceeds this share of the joint's top speed (99th percentile).
MOVING_SPEED_SHARE = 0.05
_MAD_TO_SIGMA = 1.4826  # σ of a normal variable per median absolute value


def moving_joints(series: JointSeries) -> np.ndarray:
    """(J,) True for the joints of ``series`` whose range exceeds MOVING_FACTOR × their position
    noise (the pre-processing's rule of a moving joint)."""
    return np.ptp(series.position, axis=0) > MOVING_FACTOR * position_noise(series)


def position_noise(series: JointSeries) -> np.ndarray:
    """(J,) σ of the white noise of each joint's position (from its periodogram's high band)."""
    t, q = series.t, series.position
    if len(t) < 3:
        return np.zeros(q.shape[1])
    fs = (len(t) - 1) / (t[-1] - t[0])
    return np.sqrt(noise_density(q, fs) * fs / 2)


def unexcited_joints(series: JointSeries, joints: list[str], ranges: np.ndarray, scale: dict[str, float],
                     kinds: dict[str, str]) -> dict[str, str]:
    """{joint: why} of ``joints`` whose motion in ``series`` does not excite their columns (see the
    module doc): ``ranges`` (J,) the range of every joint of ``series`` on the joint side (model
    units: rad or m), ``scale`` {kind: the fit's largest range of that kind}, ``kinds`` {data
    joint: ``revolute`` or ``prismatic``} (a joint it lacks: revolute)."""
    moves = moving_joints(series)
    sigma = position_noise(series)
    out = {}
    for j in joints:
        k = series.joints.index(j)
        kind = kinds.get(j, "revolute")
        unit = "m" if kind == "prismatic" else "rad"
        if not moves[k]:
            out[j] = (f"motion is noise: range {np.ptp(series.position[:, k]):.2g} ≤ {MOVING_FACTOR:g} σ_q "
                      f"(σ_q {sigma[k]:.2g})")
        elif ranges[k] < TREMBLE_SHARE * scale.get(kind, 0.0):
            out[j] = (f"trembles: range {ranges[k]:.2g} {unit}, {100 * ranges[k] / scale[kind]:.2g} % of the fit's "
                      f"largest {kind} range {scale[kind]:.3g} {unit} (< {100 * TREMBLE_SHARE:g} %)")
    return out


def effort_noise(effort: np.ndarray) -> np.ndarray:
    """(J,) σ of the white noise of each column of ``effort`` (N, J): 1.4826·median|Δ²e|/√6, robust
    to the slow signal and to sparse steps (the fit's noise floor takes it so from its residual)."""
    if len(effort) < 3:
        return np.zeros(effort.shape[1])
    return _MAD_TO_SIGMA * np.median(np.abs(np.diff(effort, 2, axis=0)), axis=0) / np.sqrt(6.0)


def no_effort_joints(series: JointSeries, candidates: list[str]) -> dict[str, str]:
    """{joint: why} of the ``candidates`` that move (range above MOVING_FACTOR × their position
    noise) while their effort carries no information by its own signal-to-noise ratio: over the
    samples where the joint moves, one value makes up STUCK_SHARE of them, or its signal variance
    is below NO_EFFORT_SNR × its noise variance (see the module doc)."""
    t, q, e = series.t, series.position, series.effort
    if len(t) < 3:
        return {}
    moves = moving_joints(series)
    speed = np.abs(np.gradient(q, t, axis=0))
    noise = effort_noise(e)
    out = {}
    for j in candidates:
        k = series.joints.index(j)
        top = np.percentile(speed[:, k], 99)
        moving = speed[:, k] > MOVING_SPEED_SHARE * top
        if not moves[k] or top <= 0 or moving.sum() < 10:
            continue  # a joint that does not move is not judged here
        x = e[moving, k]
        stuck = float(np.max(np.unique(x, return_counts=True)[1]) / x.size)
        variance = float(np.var(x))
        snr = (variance - noise[k] ** 2) / noise[k] ** 2 if noise[k] > 0 else (np.inf if variance > 0 else 0.0)
        if stuck >= STUCK_SHARE:
            reason = f"{100 * stuck:.0f} % of its samples in motion read {_mode(x):.3g}"
        elif snr < NO_EFFORT_SNR:
            reason = (f"its signal-to-noise ratio is {max(snr, 0.0):.2g} (spread σ {np.sqrt(variance):.3g}, noise σ "
                      f"{noise[k]:.3g}): no more signal than noise")
        else:
            continue
        out[j] = f"effort within {x.min():.3g} … {x.max():.3g} while it moves, {reason}"
    return out


def _mode(x: np.ndarray) -> float:
    values, counts = np.unique(x, return_counts=True)
    return float(values[np.argmax(counts)])
