"""Compiled sums of one friction dip over its active rows, for a whole population.

The cost and the variable projection of :class:`~frictionid_core.identification_model.IdentificationModel`
need, per candidate i, only three reductions of the signed dip column d_i (n,) over the rows
where its branch is active: d_iᵀd_i, d_iᵀy and d_iᵀF (L,). One numba kernel computes them
without materialising the (P, n) dip array, over chunks of candidates in the threads that
:mod:`frictionid_core.parallel` allows (one on a busy machine or a small population); each
candidate is computed by one thread, so the results do not depend on the thread count.

The dips are exponentials, and neither numpy (float64 ``exp`` is SIMD only with AVX-512) nor
numba (no SVML with the PyPI llvmlite) vectorises ``exp`` on AVX2 machines such as these,
where a scalar libm ``exp`` costs ~6 ns. :func:`_exp` is therefore written so that LLVM
vectorises it: Cody–Waite reduction x = k·ln2 + q, a degree-13 Taylor polynomial of e^q on
|q| ≤ ln2/2 (truncation < 1e-17) and 2^k assembled in the exponent bits. It is within 1 ulp
of ``math.exp`` for −708 ≤ x ≤ 709, returns 0 below (where e^x < 3.3e-308) and saturates
at e^709 above (the dips only need x ≤ 709 or a huge value that the outer exp maps to 0).
On the EMPS costs it makes the whole kernel 2.5-3× faster than with libm ``exp``.
The reductions may be reassociated (vectorised partial sums): their order is fixed by the
compiled code, so a result is still bit-reproducible on a given machine.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from frictionid_core.friction import LAWS, STRIBECK, THRELFALL, TUSTIN
from frictionid_core.parallel import run_chunks

_E3 = 1.0 - math.exp(-3.0)

_LOG2E = 1.4426950408889634
_LN2_HI = 6.93147180369123816490e-01  # high part of ln 2: k·_LN2_HI is exact for |k| < 2^20
_LN2_LO = 1.90821492927058770002e-10  # ln 2 − _LN2_HI
_SHIFTER = 6755399441055744.0  # 1.5·2^52: x + _SHIFTER rounds x to an integer held in the low bits
_SHIFTER_BITS = int(np.float64(_SHIFTER).view(np.int64))
_EXP_MIN, _EXP_MAX = -708.0, 709.0  # e^x is a normal float64 in between
_C = tuple(1.0 / math.factorial(n) for n in range(14))  # Taylor coefficients of e^q
_STRICT = {"contract"}  # FMA allowed; no reassociation (it would undo the Cody–Waite steps)
_SUMS = {"contract", "reassoc"}
# Dip rows per thread below which a second thread costs more than it saves (≈ 0.5 ms of work;
# the EMPS populations of 50 stay on one thread, see bench/contention.py).
MIN_CHUNK_ROWS = 150_000


@njit(cache=True, inline="always", fastmath=_STRICT)
def _exp_begin(x):  # pragma: no cover - compiled
    """(e^q, x/ln2 + _SHIFTER): the mantissa part of e^x and the integer k in float bits."""
    v = min(max(x, _EXP_MIN), _EXP_MAX)
    t = v * _LOG2E + _SHIFTER
    k = t - _SHIFTER
    q = (v - k * _LN2_HI) - k * _LN2_LO
    p = _C[13]
    p = p * q + _C[12]
    p = p * q + _C[11]
    p = p * q + _C[10]
    p = p * q + _C[9]
    p = p * q + _C[8]
    p = p * q + _C[7]
    p = p * q + _C[6]
    p = p * q + _C[5]
    p = p * q + _C[4]
    p = p * q + _C[3]
    p = p * q + _C[2]
    p = p * q + 1.0
    p = p * q + 1.0
    if x < _EXP_MIN:
        p = 0.0
    elif x != x:
        p = x  # NaN in, NaN out
    return p, t


@njit(cache=True, nogil=True, fastmath=_STRICT)
def _exp(x, out, work):  # pragma: no cover - compiled
    """out[r] = e^x[r] for arrays (n,); ``work`` (n,) is scratch. Three distinct arrays: an
    ``out`` that aliases ``x`` would make LLVM fall back to its scalar loop."""
    for r in range(x.size):
        out[r], work[r] = _exp_begin(x[r])
    bits = work.view(np.int64)
    for r in range(bits.size):
        bits[r] = (bits[r] - _SHIFTER_BITS + 1023) << 52  # the float 2^k
    for r in range(x.size):
        out[r] *= work[r]


@njit(cache=True, nogil=True, fastmath=_SUMS)
def _reduce(d, y, Ft, dF):  # pragma: no cover - compiled
    """(dᵀd, dᵀy) and dF[c] = dᵀFt[c] for d, y (n,), Ft (L, n)."""
    dd = 0.0
    dy = 0.0
    for r in range(d.size):
        dd += d[r] * d[r]
        dy += d[r] * y[r]
    for c in range(Ft.shape[0]):
        acc = 0.0
        for r in range(d.size):
            acc += d[r] * Ft[c, r]
        dF[c] = acc
    return dd, dy


@njit(cache=True, nogil=True, fastmath=_STRICT)
def _dip_sums_rows(law, theta, speed, log_speed, mask, Ft, y, lo, hi, s_dd, s_dy, s_dF):  # pragma: no cover
    """Candidates lo..hi−1 of dip_sums, written into s_dd, s_dy (P,) and s_dF (P, L)."""
    n_rows = speed.size
    arg = np.empty(n_rows)
    d = np.empty(n_rows)
    work = np.empty(n_rows)
    for i in range(lo, hi):
        a = theta[i, 0]
        if law == TUSTIN:  # exp(−|v|/vs)
            for r in range(n_rows):
                arg[r] = -speed[r] / a
            _exp(arg, d, work)
        elif law == STRIBECK:  # exp(−(|v|/vs)^δ) = exp(−exp(δ (log|v| − log vs)))
            b = theta[i, 1]
            log_vs = math.log(a)
            for r in range(n_rows):
                arg[r] = b * (log_speed[r] - log_vs)
            _exp(arg, d, work)
            for r in range(n_rows):
                arg[r] = -d[r]
            _exp(arg, d, work)
        elif law == THRELFALL:  # 1 − (1 − exp(−3|v|/v0))/(1 − e⁻³) for |v| ≤ v0, else 0
            for r in range(n_rows):
                arg[r] = -3.0 * speed[r] / a
            _exp(arg, d, work)
            for r in range(n_rows):
                if speed[r] <= a:
                    d[r] = 1.0 - (1.0 - d[r]) / _E3
                elif a == a:  # beyond v0; a NaN v0 keeps d = exp(NaN) = NaN
                    d[r] = 0.0
        for r in range(n_rows):
            d[r] *= mask[r]
        s_dd[i], s_dy[i] = _reduce(d, y, Ft, s_dF[i])


def dip_sums(friction: str, theta: np.ndarray, speed: np.ndarray, log_speed: np.ndarray, mask: np.ndarray,
             Ft: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(d·d, d·y, dᵀF) per candidate: (P,), (P,), (P, L).

    Args:
        friction: the law with a dip: ``tustin``, ``stribeck`` or ``threlfall``.
        theta: (P, m) the branch's nonlinear parameters (vs | vs, δ | v0).
        speed, log_speed, mask: (n,) |v| > 0, log|v| and the signed branch mask of the rows.
        Ft: (L, n) design rows, transposed; y: (n,) torque rows.
    """
    law = LAWS[friction].code
    theta = np.ascontiguousarray(theta, dtype=float)
    Ft = np.ascontiguousarray(Ft)
    n_pop = theta.shape[0]
    s_dd, s_dy, s_dF = np.zeros(n_pop), np.zeros(n_pop), np.zeros((n_pop, Ft.shape[0]))

    def rows(lo: int, hi: int) -> None:
        _dip_sums_rows(law, theta, speed, log_speed, mask, Ft, y, lo, hi, s_dd, s_dy, s_dF)

    run_chunks(rows, n_pop, min_items=-(-MIN_CHUNK_ROWS // max(speed.size, 1)))
    return s_dd, s_dy, s_dF


def exp(x: np.ndarray) -> np.ndarray:
    """e^x of a float64 array with the kernel's vectorised exponential (for tests/inspection)."""
    x = np.ascontiguousarray(x, dtype=float).ravel()
    out = np.empty_like(x)
    _exp(x, out, np.empty_like(x))
    return out
