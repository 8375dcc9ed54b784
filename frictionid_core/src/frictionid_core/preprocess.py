"""Signal preparation for inverse-dynamic identification (docs/reference.md#emps-idim-ls).

Zero-phase Butterworth on position, central differences for velocity and acceleration,
edge trimming, and parallel decimation (low-pass + keep 1 of n) of every observation column
and of the torque. Irregular stamps are first resampled onto a uniform grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from frictionid_core import iir
from frictionid_core.errors import InputError
from frictionid_core.timeseries import JointSeries

# Stamps whose spacing deviates from the mean period by more than this fraction are
# treated as jittered and resampled onto a uniform grid.
JITTER_TOLERANCE = 0.05


@dataclass(frozen=True)
class Preprocessing:
    """Settings of the identification pre-processing.

    Attributes:
        cutoff_hz: Butterworth cut-off on position, Hz (None: no filter).
        order: Butterworth order (applied forward and backward).
        decimate: keep 1 sample of n after the anti-alias low-pass (1: no decimation).
        trim_start: samples dropped at the start after differentiation (filter transients).
        trim_end: samples dropped at the end.
    """

    cutoff_hz: float | None = 100.0
    order: int = 4
    decimate: int = 10
    trim_start: int = 49
    trim_end: int = 0


@dataclass
class Prepared:
    """Filtered, differentiated, trimmed signals at full rate: each (N, J)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    dt: float


def resample_uniform(series: JointSeries) -> JointSeries:
    """Return ``series`` on a uniform grid if its stamps jitter (linear interpolation).

    The grid keeps the mean period and the first and last stamps; a note says so.
    """
    dt = series.dt
    if np.max(np.abs(np.diff(series.t) - dt)) <= JITTER_TOLERANCE * dt:
        return series
    t = series.t[0] + dt * np.arange(len(series))
    interp = lambda a: None if a is None else np.column_stack(  # noqa: E731
        [np.interp(t, series.t, a[:, j]) for j in range(a.shape[1])])
    out = JointSeries(t, list(series.joints), interp(series.position), interp(series.effort),
                      interp(series.velocity), series.source,
                      {k: np.interp(t, series.t, v) if v.ndim == 1 else interp(v) for k, v in series.extras.items()},
                      dict(series.meta), list(series.notes))
    out.notes.append(f"{series.source}: jittered stamps resampled onto a uniform {1 / dt:.6g} Hz grid")
    return out


def lowpass_position(q: np.ndarray, fs: float, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth (forward–backward) of each column of q (N, J)."""
    if not 0.0 < cutoff_hz < fs / 2:
        raise InputError(f"filter cut-off {cutoff_hz} Hz must lie in (0, {fs / 2:g}) Hz (the Nyquist frequency)")
    b, a = iir.butter(order, cutoff_hz / (fs / 2))
    return filtfilt(b, a, q, f"the order-{order} Butterworth filter")


def filtfilt(b: np.ndarray, a: np.ndarray, x: np.ndarray, what: str) -> np.ndarray:
    """Forward–backward IIR filter along axis 0, padded as MATLAB's filtfilt (3·(n−1) samples,
    odd reflection), which the benchmark's reference figures depend on."""
    pad = 3 * (max(len(a), len(b)) - 1)
    if x.shape[0] <= pad:
        raise InputError(f"{x.shape[0]} samples are too few for {what} (needs more than {pad})")
    return iir.filtfilt(b, a, x, pad)


def central_difference(y: np.ndarray, dt: float) -> np.ndarray:
    """(y[k+1] − y[k−1]) / 2dt inside, one-sided at the ends; along axis 0."""
    return np.gradient(y, dt, axis=0, edge_order=1)


def decimate(x: np.ndarray, n: int) -> np.ndarray:
    """MATLAB-style decimation of each column of x (N, …) by n.

    Chebyshev type I low-pass (order 8, 0.05 dB ripple, cut-off 0.8/n of Nyquist) applied
    forward–backward, then every n-th sample kept, aligned to the last sample.
    """
    if n == 1:
        return x
    b, a = iir.cheby1(8, 0.05, 0.8 / n)
    return filtfilt(b, a, x, f"the anti-alias filter of decimation by {n}")[decimation_indices(x.shape[0], n)]


def decimation_indices(length: int, n: int) -> np.ndarray:
    """Indices kept by decimating ``length`` samples by n: every n-th, aligned to the last."""
    start = n - (n * int(np.ceil(length / n)) - length)  # 1-based, as MATLAB's decimate
    return np.arange(start - 1, length, n)


def prepare(series: JointSeries, settings: Preprocessing, dt: float | None = None) -> Prepared:
    """Filter, differentiate and trim ``series`` (no decimation yet).

    Velocity and acceleration are central differences of the filtered position; the recorded
    velocity, if any, is not used (it is usually noisier or lagged). ``dt`` overrides the
    sample period (default: the mean stamp spacing).
    """
    series = resample_uniform(series)
    dt = series.dt if dt is None else dt
    q = series.position
    if settings.cutoff_hz is not None:
        q = lowpass_position(q, 1.0 / dt, settings.cutoff_hz, settings.order)
    qd = central_difference(q, dt)
    qdd = central_difference(qd, dt)
    n = len(series)
    stop = n - settings.trim_end
    if stop - settings.trim_start < 3:
        raise InputError(f"{series.source}: {n} samples leave nothing after trimming {settings.trim_start}+{settings.trim_end}")
    sl = slice(settings.trim_start, stop)
    return Prepared(series.t[sl], q[sl], qd[sl], qdd[sl], series.effort[sl], dt)
