"""The IIR low-pass filters of the pre-processing, without importing ``scipy.signal``.

``import scipy.signal`` costs 0.5–1 s of CPU (it imports scipy.stats and rewrites hundreds of
docstrings): more than the whole least-squares identification it serves. Here are scipy's
``butter`` and ``cheby1`` low-pass designs (analog prototype, pre-warped bilinear transform)
and its ``filtfilt`` (odd extension, steady-state initial conditions, forward then backward
pass) in numpy, operation for operation, with scipy's own compiled direct-form-II-transposed
recursion (``scipy/signal/_sigtools``, loaded on its own in ~1 ms; ``scipy.signal.lfilter`` if
that ever fails). The results are scipy's bit for bit (tests/test_preprocess.py).
"""

from __future__ import annotations

import importlib.util
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np


def butter(order: int, wn: float) -> tuple[np.ndarray, np.ndarray]:
    """Digital Butterworth low-pass (b, a); ``wn``: cut-off as a fraction of Nyquist."""
    m = np.arange(-order + 1, order, 2)
    return _bilinear(-np.exp(1j * np.pi * m / (2 * order)), 1.0, wn)


def cheby1(order: int, ripple_db: float, wn: float) -> tuple[np.ndarray, np.ndarray]:
    """Digital Chebyshev type I low-pass (b, a): pass-band ripple ``ripple_db`` dB, cut-off ``wn``
    as a fraction of Nyquist."""
    eps = np.sqrt(10 ** (0.1 * ripple_db) - 1.0)
    mu = np.arcsinh(1.0 / eps) / order
    poles = -np.sinh(mu + 1j * np.pi * np.arange(-order + 1, order, 2) / (2 * order))
    gain = np.prod(-poles).real
    if order % 2 == 0:
        gain = gain / np.sqrt(1.0 + eps * eps)
    return _bilinear(poles, gain, wn)


def _bilinear(analog_poles: np.ndarray, gain: float, wn: float) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) of an all-pole analog prototype moved to the pre-warped cut-off, bilinear transform."""
    fs2 = 4.0  # 2·fs with fs = 2: frequencies as fractions of Nyquist
    warped = 4.0 * np.tan(np.pi * wn / 2.0)
    p = warped * analog_poles
    k = gain * warped ** len(p)
    z_poles = (fs2 + p) / (fs2 - p)
    k_z = k * np.real(1.0 / np.prod(fs2 - p))
    return k_z * np.poly(-np.ones(len(p))), np.poly(z_poles).real


@lru_cache(maxsize=1)
def _linear_filter():
    """scipy's compiled lfilter(b, a, x, axis, zi) -> (y, zf), without scipy.signal's package import."""
    loaded = sys.modules.get("scipy.signal._sigtools")  # scipy.signal already imported: its own
    if loaded is not None:
        return loaded._linear_filter
    spec = importlib.util.find_spec("scipy")
    try:
        so = next(Path(spec.submodule_search_locations[0], "signal").glob("_sigtools.*"))
        module_spec = importlib.util.spec_from_file_location("scipy.signal._sigtools", so)
        module = importlib.util.module_from_spec(module_spec)
        module_spec.loader.exec_module(module)
        return module._linear_filter
    except (StopIteration, ImportError, AttributeError, TypeError, OSError):
        from scipy.signal import lfilter

        return lambda b, a, x, axis, zi: lfilter(b, a, x, axis=axis, zi=zi)


def filtfilt(b: np.ndarray, a: np.ndarray, x: np.ndarray, padlen: int) -> np.ndarray:
    """Zero-phase filter of x along axis 0 (b and a of equal length ≥ 2): scipy's
    ``filtfilt(b, a, x, axis=0, padlen=padlen)`` (needs x.shape[0] > padlen)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a[0] != 1.0:
        b, a = b / a[0], a / a[0]
    x = np.asarray(x, dtype=float)
    ext = np.concatenate((2 * x[:1] - x[padlen:0:-1], x, 2 * x[-1:] - x[-2 : -(padlen + 2) : -1]), axis=0)
    n = len(a) - 1
    companion_t = np.zeros((n, n))  # scipy.linalg.companion(a).T
    companion_t[:, 0] = -a[1:]
    companion_t[np.arange(n - 1), np.arange(1, n)] = 1.0
    zi = np.linalg.solve(np.eye(n) - companion_t, b[1:] - a[1:] * b[0])  # steady state of a unit step
    zi = zi.reshape((n,) + (1,) * (x.ndim - 1))
    lfilter = _linear_filter()
    y = lfilter(b, a, ext, 0, zi * ext[:1])[0]
    y = lfilter(b, a, y[::-1], 0, zi * y[-1:])[0][::-1]
    return y[padlen : ext.shape[0] - padlen]
