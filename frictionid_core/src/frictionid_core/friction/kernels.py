"""The friction laws compiled by numba: the identification's dip sums and the simulator's friction.

Nothing here is specific to one law. Each kernel is built per law by a factory whose closure
holds that law's functions from :mod:`~frictionid_core.friction.laws` (registered with
numba's ``register_jitable``, so the plain Python that numpy runs is also compiled and
inlined); numba then compiles the kernel for that law alone, with no branch on the law. The
shared helpers are ``njit(inline="always")`` (inlined before typing, so a law without a dip
passes None and its branch is dropped; typed inlining would not drop it, and warns).

Caching: every kernel is ``cache=True``. numba keys a closure's cache entry by its cells
(functions by reference), and checks only the file that defines the kernel; a kernel therefore
also closes over :data:`SOURCE_DIGEST`, the digest of this package's sources, so that editing a
law recompiles every kernel that inlines it — here and in the EMPS simulator.

Dip sums. The cost and the variable projection of
:class:`~frictionid_core.model.identification_model.IdentificationModel` need, per candidate i, only
three reductions of the signed dip column d_i (n,) over the rows where its branch is active:
d_iᵀd_i, d_iᵀy and d_iᵀF (L,). :func:`dip_sums` computes them without materialising the (P, n)
dip array, over chunks of candidates in the threads that :mod:`frictionid_core.parallel` allows
(one on a busy machine or a small population); each candidate is computed by one thread, so the
results do not depend on the thread count.

The dips are exponentials, and neither numpy (float64 ``exp`` is SIMD only with AVX-512) nor
numba (no SVML with the PyPI llvmlite) vectorises ``exp`` on AVX2 machines,
where a scalar libm ``exp`` costs ~6 ns. The dip sums therefore run the laws with
:func:`fexp`, written so that LLVM vectorises a loop calling it: Cody–Waite reduction
x = k·ln2 + q, a degree-13 Taylor polynomial of e^q on |q| ≤ ln2/2 (truncation < 1e-17) and
2^k assembled in the exponent bits. It is within 1 ulp of ``math.exp`` for −708 ≤ x ≤ 709,
returns 0 below (where e^x < 3.3e-308) and saturates at e^709 above (the dips only need
x ≤ 709 or a huge value that the outer exp maps to 0). On the EMPS costs it makes the whole
kernel 2.5-3× faster than with libm ``exp``. The reductions may be reassociated (vectorised
partial sums): their order is fixed by the compiled code, so a result is still
bit-reproducible on a given machine.

Simulator friction. :func:`members_friction` is the friction of a population's members, each
at its own velocity (members innermost, so that the EMPS simulator vectorises across them),
with numba's ``math.exp`` (libm); beyond :func:`dip_ends` a member's dip is taken as
0 and not computed. :func:`friction_batch` evaluates it on a grid, for checks.

States of a dynamic law. :func:`state_rows` integrates a LuGre or Maxwell-slip law's element
states along sampled velocities (exact sub-steps of :func:`~frictionid_core.friction.laws.bristle_advance`)
and returns its friction at every sample, one item (a candidate, a joint) per thread chunk.
"""

from __future__ import annotations

import functools
import hashlib
import math
from pathlib import Path

import numpy as np
from numba import njit, types
from numba.extending import intrinsic, register_jitable
from numba.np.unsafe.ndarray import to_fixed_tuple

from frictionid_core.friction.laws import (
    LAWS,
    branch_force,
    bristle_advance,
    bristle_advance_pieces,
    bristle_force,
    dip_level,
    state_level,
    substeps,
    travel_substeps,
)
from frictionid_core.parallel import run_chunks

SOURCE_DIGEST = hashlib.sha256(b"".join(p.read_bytes() for p in sorted(Path(__file__).parent.glob("*.py")))).hexdigest()

for _fn in (dip_level, branch_force,
            *(f for law in LAWS.values() for f in (law.dip, law.dip_end, law.stiffness, law.damping) if f is not None)):
    register_jitable(inline="always")(_fn)
# compiled once each, called
for _fn in (state_level, substeps, travel_substeps, bristle_advance, bristle_advance_pieces, bristle_force):
    register_jitable(_fn)

# Dip rows per thread below which a second thread costs more than it saves (≈ 0.5 ms of work;
# the EMPS populations of 50 stay on one thread, see bench/contention.py).
MIN_CHUNK_ROWS = 150_000

_LOG2E = 1.4426950408889634
_LN2_HI = 6.93147180369123816490e-01  # high part of ln 2: k·_LN2_HI is exact for |k| < 2^20
_LN2_LO = 1.90821492927058770002e-10  # ln 2 − _LN2_HI
_SHIFTER = 6755399441055744.0  # 1.5·2^52: x + _SHIFTER rounds x to an integer held in the low bits
_SHIFTER_BITS = int(np.float64(_SHIFTER).view(np.int64))
_EXP_MIN, _EXP_MAX = -708.0, 709.0  # e^x is a normal float64 in between
_C = tuple(1.0 / math.factorial(n) for n in range(14))  # Taylor coefficients of e^q
_STRICT = {"contract"}  # FMA allowed; no reassociation (it would undo the Cody–Waite steps)
_SUMS = {"contract", "reassoc"}


# ---------------------------------------------------------------- the vectorised exp
@intrinsic
def _float_bits(typingctx, x):
    """The bits of a float64 as an int64."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.int64))

    return types.int64(types.float64), codegen


@intrinsic
def _bits_float(typingctx, n):
    """The float64 whose bits are the int64 ``n``."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.float64))

    return types.float64(types.int64), codegen


@njit(cache=True, inline="always", fastmath=_STRICT)
def fexp(x):  # pragma: no cover - compiled
    """e^x, vectorisable (module docstring)."""
    v = min(max(x, _EXP_MIN), _EXP_MAX)
    t = v * _LOG2E + _SHIFTER  # k = round(v/ln2), in the low bits of t
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
    return p * _bits_float((_float_bits(t) - _SHIFTER_BITS + 1023) << 52)  # e^q·2^k


@njit(cache=True, nogil=True)
def _exp_into(x, out):  # pragma: no cover - compiled
    for r in range(x.size):
        out[r] = fexp(x[r])


def exp(x: np.ndarray) -> np.ndarray:
    """e^x of a float64 array with the dip sums' vectorised exponential (for tests/inspection)."""
    x = np.ascontiguousarray(x, dtype=float).ravel()
    out = np.empty_like(x)
    _exp_into(x, out)
    return out


# ------------------------------------------------------- the laws' elementary functions
@register_jitable(inline="always")
def _select(condition, a, b):
    return a if condition else b


@register_jitable
def _pick(condition, a, b):
    """The select of the state functions (called, not inlined: inlining it there trips numba's IR checks)."""
    return a if condition else b


@register_jitable(inline="always")
def _fast_ratio_power(x, log_x, scale, exponent):
    """(x/scale)^exponent = e^(exponent·(log x − log scale)) with the vectorised exp."""
    return fexp(exponent * (log_x - math.log(scale)))


@register_jitable(inline="always")
def _exact_ratio_power(x, log_x, scale, exponent):
    """(x/scale)^exponent with libm's pow."""
    return (x / scale) ** exponent


def law_parts(friction: str) -> tuple:
    """(dip, dip_end, number of linear parameters) of the law ``friction`` (None, None without a
    dip): what a kernel built for it closes over (with :data:`SOURCE_DIGEST`)."""
    law = LAWS[friction]
    return law.dip, law.dip_end, len(law.linear)


# ------------------------------------------------------------------------- dip sums
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


@functools.cache
def _dip_sums_kernel(friction: str):
    dip, _, _ = law_parts(friction)
    n_nonlinear = len(LAWS[friction].nonlinear)
    digest = SOURCE_DIGEST

    @njit(cache=True, nogil=True, fastmath=_STRICT)
    def dip_sums_rows(theta, speed, log_speed, mask, Ft, y, lo, hi, s_dd, s_dy, s_dF):  # pragma: no cover
        """Candidates lo..hi−1 of dip_sums (nonlinear parameters theta (P, m)), written into
        s_dd, s_dy (P,) and s_dF (P, L)."""
        digest  # noqa: B018 - a cell of the closure: part of the cache key (module docstring)
        d = np.empty(speed.size)
        for i in range(lo, hi):
            p = to_fixed_tuple(theta[i], n_nonlinear)  # values, not memory: they stay out of the row loop
            for r in range(speed.size):
                d[r] = dip(speed[r], log_speed[r], p, 0, fexp, _fast_ratio_power, _select) * mask[r]
            s_dd[i], s_dy[i] = _reduce(d, y, Ft, s_dF[i])

    return dip_sums_rows


def dip_sums(friction: str, theta: np.ndarray, speed: np.ndarray, log_speed: np.ndarray, mask: np.ndarray,
             Ft: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(d·d, d·y, dᵀF) per candidate: (P,), (P,), (P, L).

    Args:
        friction: a law with a dip (``tustin``, ``stribeck``, ``threlfall``).
        theta: (P, m) the branch's nonlinear parameters (vs | vs, δ | v0).
        speed, log_speed, mask: (n,) |v| > 0, log|v| and the signed branch mask of the rows.
        Ft: (L, n) design rows, transposed; y: (n,) torque rows.
    """
    rows = _dip_sums_kernel(friction)
    theta = np.ascontiguousarray(theta, dtype=float)
    Ft = np.ascontiguousarray(Ft)
    n_pop = theta.shape[0]
    s_dd, s_dy, s_dF = np.zeros(n_pop), np.zeros(n_pop), np.zeros((n_pop, Ft.shape[0]))

    def chunk(lo: int, hi: int) -> None:
        rows(theta, speed, log_speed, mask, Ft, y, lo, hi, s_dd, s_dy, s_dF)

    run_chunks(chunk, n_pop, min_items=-(-MIN_CHUNK_ROWS // max(speed.size, 1)))
    return s_dd, s_dy, s_dF


# ----------------------------------------------------------------- simulator friction
@njit(inline="always")
def dip_ends(dip_end, n_linear, asym, th):  # pragma: no cover - compiled
    """(2, m) speeds (v > 0, v < 0) from which each member's dip counts as 0 (inf without a dip);
    ``th`` (kf, m) as in :func:`members_friction`."""
    m = th.shape[1]
    cut = np.full((2, m), np.inf)
    if dip_end is not None:
        nb = th.shape[0] // 2 if asym else 0
        for b in range(2):
            for i in range(m):
                cut[b, i] = dip_end(th[:, i], nb * b + n_linear)
    return cut


@njit(inline="always")
def members_friction(dip, n_linear, asym, eps, th, off, cut, v, out):  # pragma: no cover - compiled
    """out[i] = τ_f(v[i]; th[:, i]) + off[i] for the members i of a population: parameters
    ``th`` (kf, m) in the model's order (the ``_neg`` block in the lower half if ``asym``),
    sign(v) or tanh(v/eps) when eps > 0, the dip taken as 0 from the speeds ``cut`` (2, m) of
    :func:`dip_ends` on."""
    if eps > 0.0:  # two loops: the hard sign's vectorises
        for i in range(v.shape[0]):
            out[i] = _member_friction(dip, n_linear, asym, th, off, cut, v[i], math.tanh(v[i] / eps), i)
    else:
        for i in range(v.shape[0]):
            vi = v[i]
            sign = (1.0 if vi > 0.0 else 0.0) - (1.0 if vi < 0.0 else 0.0)
            out[i] = _member_friction(dip, n_linear, asym, th, off, cut, vi, sign, i)


@njit(inline="always")
def _member_friction(dip, n_linear, asym, th, off, cut, v, sign, i):  # pragma: no cover - compiled
    """Member i's friction at velocity v with sign(v) (or its smoothed form) ``sign``."""
    neg = v < 0.0
    if dip is None:  # loads from both branches, then a select: the loop vectorises
        nb = th.shape[0] // 2 if asym else 0
        return branch_force(v, sign, th[nb, i] if neg else th[0, i], th[nb + 1, i] if neg else th[1, i]) + off[i]
    o = th.shape[0] // 2 if asym and neg else 0  # one branch's loads, its exponentials only below the cut
    level = th[o + 1, i]
    a = abs(v)
    if a < cut[1 if neg else 0, i]:
        p = th[:, i]
        level = dip_level(p, o, n_linear, dip(a, math.log(a), p, o + n_linear, math.exp, _exact_ratio_power, _select))
    return branch_force(v, sign, th[o, i], level) + off[i]


@functools.cache
def _friction_batch_kernel(friction: str):
    dip, dip_end, n_linear = law_parts(friction)
    digest = SOURCE_DIGEST

    @njit(cache=True)
    def batch(asym, eps, theta, v):  # pragma: no cover - compiled
        digest  # noqa: B018 - a cell of the closure: part of the cache key (module docstring)
        P = theta.shape[0]
        out = np.empty((P, v.shape[0]))
        th = np.ascontiguousarray(theta.T)
        zero = np.zeros(P)
        col = np.empty(P)
        vv = np.empty(P)
        cut = dip_ends(dip_end, n_linear, asym, th)
        for j in range(v.shape[0]):
            vv[:] = v[j]
            members_friction(dip, n_linear, asym, eps, th, zero, cut, vv, col)
            out[:, j] = col
        return out

    return batch


def friction_batch(friction: str, asymmetric: bool, eps: float, theta: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The simulator's friction (:func:`members_friction`) of parameters (P, kf) at velocities
    (N,) → (P, N), for checks against :meth:`~frictionid_core.friction.FrictionModel.torque`."""
    return _friction_batch_kernel(friction)(bool(asymmetric), float(eps), np.asarray(theta, dtype=float),
                                            np.asarray(v, dtype=float))


# ------------------------------------------------------------- dynamic laws' states
@functools.cache
def _state_rows_kernel(friction: str):
    law = LAWS[friction]
    dip, stiffness, damping = law.dip, law.stiffness, law.damping
    digest = SOURCE_DIGEST

    @njit(cache=True, nogil=True)
    def rows(asym, n, theta, v, which, t, reset, path, shift, rest, lo, hi, out):  # pragma: no cover - compiled
        """Items lo..hi−1 of :func:`state_rows`, written into out (M, N)."""
        digest  # noqa: B018 - a cell of the closure: part of the cache key (module docstring)
        nb = theta.shape[1] // 2 if asym else 0
        travelled = path.shape[0] > 0
        z = np.zeros(n)
        for m in range(lo, hi):
            p = theta[m]
            w = which[m]
            vel = v[w]
            for r in range(vel.size):
                vr = vel[r]
                if reset[r]:  # the sliding states of this velocity (0 at rest)
                    z[:] = 0.0
                    moving = abs(vr) > rest[w]
                    direction = ((1.0 if vr > 0.0 else 0.0) - (1.0 if vr < 0.0 else 0.0)) if moving else 0.0
                    bristle_advance(z, n, math.inf if moving else 0.0, direction, abs(vr), abs(vr), p,
                                    nb if vr < 0.0 else 0, dip, stiffness, math.exp, _exact_ratio_power, _pick)
                else:
                    if travelled:  # the measured travel, each sub-step followed along the level
                        d1, s1, a1, e1, d2, s2, a2, e2 = travel_substeps(vel[r - 1], vr, path[w, r], shift[w, r],
                                                                         _pick)
                        bristle_advance_pieces(z, n, d1, s1, a1, e1, p, nb if s1 < 0.0 else 0, dip, stiffness,
                                               math.exp, _exact_ratio_power, _pick)
                        if d2 > 0.0:
                            bristle_advance_pieces(z, n, d2, s2, a2, e2, p, nb if s2 < 0.0 else 0, dip, stiffness,
                                                   math.exp, _exact_ratio_power, _pick)
                    else:  # the travel of the velocities, taken linear (StateFriction's steps)
                        d1, s1, a1, e1, d2, s2, a2, e2 = substeps(vel[r - 1], vr, t[r] - t[r - 1], _pick)
                        bristle_advance(z, n, d1, s1, a1, e1, p, nb if s1 < 0.0 else 0, dip, stiffness, math.exp,
                                        _exact_ratio_power, _pick)
                        if d2 > 0.0:
                            bristle_advance(z, n, d2, s2, a2, e2, p, nb if s2 < 0.0 else 0, dip, stiffness, math.exp,
                                            _exact_ratio_power, _pick)
                out[m, r] = bristle_force(vr, z, n, p, nb if vr < 0.0 else 0, dip, stiffness, damping, math.exp,
                                          _exact_ratio_power, _pick)

    return rows


def state_rows(friction: str, asymmetric: bool, elements: int, theta: np.ndarray, v: np.ndarray,
               which: np.ndarray, t: np.ndarray, reset: np.ndarray, travel: tuple | None = None) -> np.ndarray:
    """The friction (M, N) of M items of a dynamic law, item m with parameters ``theta[m]`` (M, k)
    at the velocities ``v[which[m]]`` ((V, N), rad/s or m/s) sampled at ``t`` (N,) (s), its
    states reset where ``reset`` (N,) (the first sample, gaps) to their sliding values.

    ``travel``: None (each step's distance from its velocities, taken linear), or (path, shift,
    rest): each step's path length and net displacement ((V, N) each, the measured travel from
    the previous sample: :func:`~frictionid_core.friction.laws.travel_substeps`) and the speed
    (V,) at or below which a reset starts at rest (states 0) rather than sliding."""
    kernel = _state_rows_kernel(friction)
    theta = np.ascontiguousarray(theta, dtype=float)
    v = np.ascontiguousarray(v, dtype=float)
    which = np.ascontiguousarray(which, dtype=np.int64)
    t = np.ascontiguousarray(t, dtype=float)
    reset = np.ascontiguousarray(reset, dtype=np.bool_)
    if travel is None:
        path = shift = np.zeros((0, v.shape[1]))
        rest = np.zeros(v.shape[0])
    else:
        path, shift, rest = (np.ascontiguousarray(a, dtype=float) for a in travel)
        if path.shape != v.shape or shift.shape != v.shape or rest.shape != (v.shape[0],):
            raise ValueError(f"travel {path.shape}, {shift.shape}, {rest.shape} for velocities {v.shape}")
    out = np.empty((theta.shape[0], v.shape[1]))

    def chunk(lo: int, hi: int) -> None:
        kernel(bool(asymmetric), int(elements), theta, v, which, t, reset, path, shift, rest, lo, hi, out)

    run_chunks(chunk, theta.shape[0], min_items=max(1, -(-MIN_CHUNK_ROWS // max(v.shape[1], 1))))
    return out
