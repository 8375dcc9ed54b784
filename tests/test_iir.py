"""frictionid_core.iir: the pre-processing's filters are scipy.signal's, bit for bit, without
importing scipy.signal (whose import alone costs more than a least-squares identification)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy import signal

from frictionid_core import iir

DESIGNS = [("butter", (4, 0.2)), ("butter", (4, 0.002)), ("butter", (3, 0.3)),
           ("cheby1", (8, 0.05, 0.08)), ("cheby1", (8, 0.05, 0.04)), ("cheby1", (8, 0.05, 0.8 / 3))]


@pytest.mark.parametrize("kind, args", DESIGNS)
def test_designs_and_zero_phase_filter_equal_scipy_bit_for_bit(kind, args):
    b, a = getattr(iir, kind)(*args)
    rb, ra = getattr(signal, kind)(*args)
    np.testing.assert_array_equal(b, rb)
    np.testing.assert_array_equal(a, ra)
    rng = np.random.default_rng(1)
    t = np.arange(5000) * 1e-3
    x = np.column_stack([np.sin(2 * np.pi * 0.7 * t) + 0.01 * rng.standard_normal(t.size),
                         np.cumsum(rng.standard_normal(t.size)), np.full(t.size, 3.0)])
    pad = 3 * (len(a) - 1)
    for data in (x, x[:, 0], np.asfortranarray(x), x[:, :, None]):
        got = iir.filtfilt(b, a, data, pad)
        np.testing.assert_array_equal(got, signal.filtfilt(rb, ra, data, axis=0, padlen=pad))


def test_the_least_squares_identification_imports_neither_scipy_nor_numba():
    """Only scipy's compiled recursion (``scipy.signal._sigtools``, loaded on its own) is loaded."""
    from conftest import REPO

    code = ("import sys; from frictionid_core.cli import main; "
            "main(['identify', 'bags/emps_estimation', '--system', 'emps', '--friction', 'coulomb', '--solver', 'ls']); "
            "print('LOADED', sorted(m for m in sys.modules if m.split('.')[0] in ('scipy', 'numba')))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True).stdout
    assert "M                      95.1089" in out  # the demo table, unchanged
    assert out.strip().splitlines()[-1] == "LOADED ['scipy.signal._sigtools']", out
