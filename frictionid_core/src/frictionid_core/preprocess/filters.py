"""The filters: zero-phase Butterworth on position (second-order sections), central differences,
parallel decimation (anti-alias low-pass + keep 1 of n)."""

from __future__ import annotations

import numpy as np
from scipy import signal

from frictionid_core.errors import InputError
from frictionid_core.preprocess.settings import (
    _FILTER_COLUMNS,
    TooFewSamples,
)


def lowpass_position(q: np.ndarray, fs: float, cutoff_hz: float | np.ndarray, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth (forward–backward) of each column of q (N, J) at ``cutoff_hz``: one
    value, or one per column (J,)."""
    cutoffs = np.broadcast_to(np.asarray(cutoff_hz, dtype=float), (q.shape[1],))
    bad = [c for c in np.unique(cutoffs) if not 0.0 < c < fs / 2]
    if bad:
        raise InputError(f"filter cut-off {bad[0]:g} Hz must lie in (0, {fs / 2:g}) Hz (the Nyquist frequency)")
    out = np.empty(q.shape)
    for fc in np.unique(cutoffs):
        cols = cutoffs == fc
        out[:, cols] = filtfilt(signal.butter(order, fc / (fs / 2), output="sos"), order, q[:, cols],
                                f"the order-{order} Butterworth filter")
    return out


def filtfilt(sos: np.ndarray, order: int, x: np.ndarray, what: str) -> np.ndarray:
    """Forward–backward IIR filter (second-order sections ``sos`` of a filter of ``order``) along
    axis 0, padded as MATLAB's filtfilt (3·order samples, odd reflection), which the benchmark's
    reference figures depend on."""
    pad = 3 * order
    if x.shape[0] <= pad:
        raise TooFewSamples(f"{x.shape[0]} samples are too few for {what} (needs more than {pad})")
    return signal.sosfiltfilt(sos, x, axis=0, padlen=pad)


def central_difference(y: np.ndarray, dt: float) -> np.ndarray:
    """(y[k+1] − y[k−1]) / 2dt inside, one-sided at the ends; along axis 0."""
    return np.gradient(y, dt, axis=0, edge_order=1)


def decimate(x: np.ndarray, n: int, stride: int = 1, rows: np.ndarray | None = None) -> np.ndarray:
    """MATLAB-style decimation of each column of x (N, …) by n.

    Chebyshev type I low-pass (order 8, 0.05 dB ripple, cut-off 0.8/n of Nyquist) applied
    forward–backward, then every n-th sample kept, aligned to the last sample.

    ``stride`` (a divisor of n): x holds every ``stride``-th sample only (aligned to the last,
    :func:`decimation_indices`); the filter keeps the same band in Hz (cut-off 0.8·stride/n of
    x's Nyquist) and the rows are the same instants. ``rows``: only these of the decimated rows.
    """
    if n == 1:
        return x if rows is None else x[rows]
    kept = decimation_indices(x.shape[0], n // stride)
    if rows is not None:
        kept = kept[rows]
    sos = signal.cheby1(8, 0.05, 0.8 * stride / n, output="sos")
    what = f"the anti-alias filter of decimation by {n}"
    if x.ndim == 1:
        return filtfilt(sos, 8, x, what)[kept]
    # column by column (each is filtered alone), in blocks to bound the filter's work arrays;
    # all-zero columns (a robot regressor's block of a joint a body does not load) stay zero
    flat = x.reshape(x.shape[0], -1)
    out = np.zeros((kept.size, flat.shape[1]))
    live = np.flatnonzero(np.any(flat, axis=0))
    if live.size == 0:
        live = np.arange(min(1, flat.shape[1]))
    for c0 in range(0, live.size, _FILTER_COLUMNS):
        cols = live[c0 : c0 + _FILTER_COLUMNS]
        out[:, cols] = filtfilt(sos, 8, flat[:, cols], what)[kept]
    return out.reshape((kept.size,) + x.shape[1:])


def window_means(x: np.ndarray, n: int, stride: int = 1, rows: np.ndarray | None = None) -> np.ndarray:
    """The rows of decimating each column of x (N, …) by n as :func:`decimate` keeps them, each the
    mean of the n samples around it (centred) instead of an anti-alias filter's output: the short
    filter of thinned rows (:func:`~frictionid_core.preprocess.thinned_rows`), which averages the
    noise of the rows a kept one stands for without reaching further (an anti-alias filter of
    decimation n rings for tens of its periods: it carries a friction dip's rows into rows the
    model evaluates outside it). ``stride`` and ``rows`` as for :func:`decimate`."""
    if n == 1:
        return x if rows is None else x[rows]
    kept = decimation_indices(x.shape[0], n // stride)
    if rows is not None:
        kept = kept[rows]
    width = n // stride
    flat = x.reshape(x.shape[0], -1)
    lo = np.clip(kept - (width - 1) // 2, 0, x.shape[0])
    hi = np.clip(kept + width // 2 + 1, 0, x.shape[0])
    out = np.empty((kept.size, flat.shape[1]))
    for c0 in range(0, flat.shape[1], _FILTER_COLUMNS):  # in blocks: bounded work arrays
        block = flat[:, c0 : c0 + _FILTER_COLUMNS]
        cum = np.vstack([np.zeros((1, block.shape[1])), np.cumsum(block, axis=0)])
        out[:, c0 : c0 + _FILTER_COLUMNS] = (cum[hi] - cum[lo]) / (hi - lo)[:, None]
    return out.reshape((kept.size,) + x.shape[1:])


def brief_runs(velocity: np.ndarray, t: np.ndarray, cutoff_hz: np.ndarray, periods: float) -> np.ndarray:
    """(N, J) True where a row of ``velocity`` (N, J), at the instants ``t`` (N,) s, belongs to a run of
    one sign of motion (0 for a row left out or at rest) shorter than ``periods`` / ``cutoff_hz`` (J,)
    seconds: no motion within the filter's band crosses the min speed that briefly (the filter's ringing
    after a stop, or noise), so its sign of motion says nothing. A run lasts from halfway to the row
    before its first to halfway to the row after its last (its rows × the period on a uniform grid; the
    rows of a thinned observation are not evenly spaced)."""
    n, joints = velocity.shape
    out = np.zeros((n, joints), dtype=bool)
    if periods <= 0.0 or n == 0:
        return out
    edges = _row_edges(t)
    for j in range(joints):
        sign = np.sign(velocity[:, j])
        run = np.concatenate([[0], np.cumsum(sign[1:] != sign[:-1])])  # each row's run
        first = np.flatnonzero(np.concatenate([[True], run[1:] != run[:-1]]))
        last = np.concatenate([first[1:] - 1, [n - 1]])
        duration = edges[last + 1] - edges[first]
        out[:, j] = (sign != 0) & (duration[run] < (1.0 - 1e-9) * periods / cutoff_hz[j])  # n rows ≥ n periods
    return out


def _row_edges(t: np.ndarray) -> np.ndarray:
    """(N + 1,) the instants halfway between consecutive rows at ``t`` (N,), the first and last half a
    step outside (a single row: half a second either side of it)."""
    if t.size < 2:
        return np.array([t[0] - 0.5, t[0] + 0.5]) if t.size else np.zeros(1)
    mid = 0.5 * (t[1:] + t[:-1])
    return np.concatenate([[t[0] - (mid[0] - t[0])], mid, [t[-1] + (t[-1] - mid[-1])]])


def decimation_indices(length: int, n: int) -> np.ndarray:
    """Indices kept by decimating ``length`` samples by n: every n-th, aligned to the last."""
    start = n - (n * int(np.ceil(length / n)) - length)  # 1-based, as MATLAB's decimate
    return np.arange(start - 1, length, n)


def near_reversals(velocity: np.ndarray, t: np.ndarray, cutoff_hz: np.ndarray, periods: float) -> np.ndarray:
    """(N, J) True where a row of ``velocity`` (N, J), at the instants ``t`` (N,) s, lies within
    ``periods`` / ``cutoff_hz`` (J,) seconds of a change of its joint's sign of motion (−, 0 for a row
    left out or at rest, +): a reversal, a stop or a start, taken halfway between the two rows."""
    n, joints = velocity.shape
    out = np.zeros((n, joints), dtype=bool)
    if periods <= 0.0 or n < 2:
        return out
    for j in range(joints):
        sign = np.sign(velocity[:, j])
        flips = np.flatnonzero(sign[1:] != sign[:-1])
        if flips.size:
            at = 0.5 * (t[flips] + t[flips + 1])
            k = np.searchsorted(at, t)
            gap = np.minimum(np.abs(t - at[np.maximum(k - 1, 0)]), np.abs(at[np.minimum(k, at.size - 1)] - t))
            out[:, j] = gap <= periods / cutoff_hz[j]
    return out
