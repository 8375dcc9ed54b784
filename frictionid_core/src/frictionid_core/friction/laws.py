"""Every friction law's single definition (docs/reference.md#friction-models): the registry :data:`LAWS`.

A law maps joint velocity v (m/s or rad/s) to a friction force/torque (N or N·m). The four laws
here are *dip laws*: one velocity branch is

    Fv·v + level(|v|)·sign(v),   level = Fc + (Fs − Fc)·dip(|v|)  (with Fs)  or  Fc·(1 − dip(|v|))  (without)

* ``coulomb``   no dip: level = Fc
* ``threlfall`` dip = 1 − (1 − e^(−3|v|/v0))/(1 − e^(−3)) for |v| ≤ v0, else 0
* ``tustin``    dip = e^(−|v|/vs)
* ``stribeck``  dip = e^(−(|v|/vs)^δ)

The dip is the only part that depends on nonlinear parameters (what the identification's
variable projection searches); Fv, Fc, Fs enter linearly.

Two *dynamic* laws carry internal states (bristle deflections z_i, one per element), driven
by the motion: each element i of n, of stiffness k_i, holds at most the share g/n of the
level g(|v|) = Fc + (Fs − Fc)·e^(−(|v|/vs)²) (the Stribeck level with δ = 2, called from
``stribeck_dip``), ż_i = v − |v|·z_i·n·k_i/g, and the friction is

    F = Fv·v + Σ k_i·z_i + σ1·Σ ż_i

* ``lugre``  one element, k_1 = σ0 (``sigma0``), bristle damping σ1 (``sigma1``);
* ``gms``    generalized Maxwell-slip: n elements (``--elements``, default 4) of stiffness
  ``k1`` … ``kn``, no damping; with one element and Fs = Fc it is Dahl's law.

In the sliding regime z_i settles at sign(v)·g/(n·k_i) and F = Fv·v + g·sign(v): the static
Stribeck law (δ = 2). Over a step of the log the velocity is taken linear between its samples
(split at a reversal): in the travelled distance s, dz_i/ds = sign(v) − z_i·n·k_i/g is linear,
and :func:`bristle_advance` solves it exactly for a constant level, with the level's change
as a linear forcing otherwise (second order; stable at any rate and any stiffness).

A law is written once, as plain scalar Python that numpy and numba both run:

* ``dip(speed, log_speed, p, o, exp, ratio_power, where)``: the dip at speed |v| ≥ 0, whose
  j-th nonlinear parameter is ``p[o + j]``. In compiled code ``p`` holds one candidate's
  parameters (a tuple or a column of the simulator's table) and ``speed`` is a float; under
  numpy ``p`` is (k, P, 1), so ``p[o + j]`` is (P, 1) and a dip at speeds (1, N) is (P, N).
  ``exp``, ``ratio_power`` and ``where`` are the only functions a law calls; each caller passes
  its own, with the same meaning: :data:`NUMPY_OPS` here, numba's ``math.exp`` (libm) in the
  EMPS simulator, a vectorised exponential in the identification's dip sums
  (:mod:`frictionid_core.friction.kernels`). ``ratio_power(x, log_x, scale, exponent)`` is
  (x/scale)^exponent: ``log_x`` = log x lets the vectorised flavour compute it as
  exp(exponent·(log x − log scale)); the others ignore it (numpy passes None).
  ``where(condition, a, b)`` is a select (both sides evaluated).
* ``dip_end(p, o)``: a speed from which the dip is below e^(−40) (or exactly 0): the
  simulator takes it as 0 there and skips the exponentials.

:mod:`~frictionid_core.friction.model` derives the numpy ``FrictionModel.torque`` from these
functions and :mod:`~frictionid_core.friction.kernels` compiles them into the dip sums and the
simulator's friction; ``tests/core/friction/test_law_agreement.py`` checks that the three agree.
A new law is one :class:`FrictionLaw` in :data:`LAWS` with its functions here, plus the units
and default bounds of any new parameter name (below); the kernels need no change. See the
package docstring (:mod:`frictionid_core.friction`) for a law with internal state.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import FrictionIdError

UNITS = {
    "Fv": "N·s/m | N·m·s/rad",
    "Fc": "N | N·m",
    "Fs": "N | N·m",
    "vs": "m/s | rad/s",
    "v0": "m/s | rad/s",
    "delta": "1",
    "sigma0": "N/m | N·m/rad",
    "sigma1": "N·s/m | N·m·s/rad",
    "k": "N/m | N·m/rad",
}

# Default search bounds (SI units; wide enough for the EMPS and the TX40).
DEFAULT_BOUNDS = {
    "Fv": (0.0, 500.0),
    "Fc": (0.0, 100.0),
    "Fs": (0.0, 100.0),
    "vs": (1e-6, 0.5),
    "v0": (1e-6, 0.5),
    "delta": (0.3, 5.0),
    "sigma0": (1e-6, 1e10),
    "sigma1": (0.0, 1e6),
    "k": (1e-6, 1e10),
}

LUGRE_DELTA = 2.0  # the Stribeck exponent of the dynamic laws' level
LEVEL_FLOOR = 1e-300  # a dynamic law's level is at least this (a zero level: every element stays at 0)
DIP_NEGLIGIBLE = 40.0  # the dip is treated as 0 where its exponent passes −40 (e^−40 ≈ 4e−18)
LEVEL_STEP = 0.02  # a step along a measured travel is cut where its level changes by more than this share …
MAX_PIECES = 16  # … into at most this many pieces
_E3 = 1.0 - math.exp(-3.0)


# ------------------------------------------------------------------------------ laws
def threlfall_dip(speed, log_speed, p, o, exp, ratio_power, where):
    """1 − (1 − e^(−3|v|/v0))/(1 − e^(−3)): 1 at v = 0, 0 from v0 on (NaN for a NaN v0)."""
    v0 = p[o]
    return where(speed > v0, 0.0, 1.0 - (1.0 - exp(-3.0 * speed / v0)) / _E3)


def threlfall_dip_end(p, o):
    """v0: the dip is 0 from there on."""
    return p[o]


def tustin_dip(speed, log_speed, p, o, exp, ratio_power, where):
    """e^(−|v|/vs)."""
    return exp(-speed / p[o])


def tustin_dip_end(p, o):
    """40·vs."""
    return p[o] * DIP_NEGLIGIBLE


def stribeck_dip(speed, log_speed, p, o, exp, ratio_power, where):
    """e^(−(|v|/vs)^δ)."""
    return exp(-ratio_power(speed, log_speed, p[o], p[o + 1]))


def stribeck_dip_end(p, o):
    """vs·40^(1/δ)."""
    return p[o] * DIP_NEGLIGIBLE ** (1.0 / p[o + 1])


def lugre_dip(speed, log_speed, p, o, exp, ratio_power, where):
    """e^(−(|v|/vs)²): the Stribeck dip with δ = 2."""
    return stribeck_dip(speed, log_speed, (p[o], LUGRE_DELTA), 0, exp, ratio_power, where)


def lugre_dip_end(p, o):
    """vs·40^(1/2)."""
    return stribeck_dip_end((p[o], LUGRE_DELTA), 0)


def lugre_stiffness(p, o, i):
    """σ0 (the one element's stiffness) of the branch from ``p[o]`` (Fv, Fc, Fs, vs, σ0, σ1)."""
    return p[o + 4]


def lugre_damping(p, o):
    """σ1."""
    return p[o + 5]


def gms_stiffness(p, o, i):
    """k_(i+1) of the branch from ``p[o]`` (Fv, Fc, Fs, vs, k1, …, kn)."""
    return p[o + 4 + i]


def gms_damping(p, o):
    """No damping."""
    return 0.0


# ------------------------------------------------------- the branch of a dip law
def dip_level(p, o, n_linear, dip):
    """Coulomb level of a dip law's branch whose parameters start at ``p[o]`` (Fv, Fc[, Fs]):
    Fc + (Fs − Fc)·dip with Fs (``n_linear`` 3), Fc·(1 − dip) without."""
    fc = p[o + 1]
    if n_linear == 3:
        return fc + (p[o + 2] - fc) * dip
    return fc * (1.0 - dip)


def branch_force(v, sign, fv, level):
    """Fv·v + level·sign: the friction of one branch, with sign = sign(v) or its smoothed form."""
    return fv * v + level * sign


# ------------------------------------------------------ the states of a dynamic law
def state_level(speed, p, o, dip, exp, ratio_power, where):
    """g(|v|) ≥ LEVEL_FLOOR: the level of a dynamic law's branch from ``p[o]`` (Fv, Fc, Fs, vs, …)."""
    level = dip_level(p, o, 3, dip(speed, 0.0, p, o + 3, exp, ratio_power, where))
    return where(level > LEVEL_FLOOR, level, LEVEL_FLOOR)


def substeps(v0, v1, h, where):
    """The two sub-steps of a step of ``h`` s from velocity v0 to v1 (taken linear): (distance,
    direction ±1 or 0, speed at its start, speed at its end) of each; the second is empty (0, 0,
    0, 0) unless the step reverses (the first then ends at rest and the second starts there)."""
    a0, a1 = abs(v0), abs(v1)
    reverses = v0 * v1 < 0.0
    total = a0 + a1
    first = where(reverses, h * a0 / where(total > 0.0, total, 1.0), h)  # time to the reversal
    s0 = where(v0 > 0.0, 1.0, 0.0) - where(v0 < 0.0, 1.0, 0.0)
    s1 = where(v1 > 0.0, 1.0, 0.0) - where(v1 < 0.0, 1.0, 0.0)
    s_mean = where(v0 + v1 > 0.0, 1.0, 0.0) - where(v0 + v1 < 0.0, 1.0, 0.0)
    d1 = where(reverses, 0.5 * a0 * first, 0.5 * total * h)
    d2 = where(reverses, 0.5 * a1 * (h - first), 0.0)
    return (d1, where(reverses, s0, s_mean), a0, where(reverses, 0.0, a1),
            d2, where(reverses, s1, 0.0), 0.0 * a1, where(reverses, a1, 0.0))


def travel_substeps(v0, v1, path, shift, where):
    """The two sub-steps of a step along a measured travel instead of the velocities: ``path`` ≥ 0
    the distance travelled over the step, ``shift`` the net displacement (|shift| ≤ path). A path
    longer than the shift (by more than 1e-6 of it) reverses once: first d1 = (path + s·shift)/2 in
    the direction s of v0 (else −sign(v1), else that of the shift), then the rest back, the speed
    passing 0 at the reversal; otherwise one sub-step in the shift's direction, the speed going
    from |v0| to |v1|. Returns what :func:`substeps` does."""
    a0, a1 = abs(v0), abs(v1)
    s_shift = where(shift > 0.0, 1.0, 0.0) - where(shift < 0.0, 1.0, 0.0)
    s_v0 = where(v0 > 0.0, 1.0, 0.0) - where(v0 < 0.0, 1.0, 0.0)
    s_v1 = where(v1 > 0.0, 1.0, 0.0) - where(v1 < 0.0, 1.0, 0.0)
    first = where(s_v0 != 0.0, s_v0, where(s_v1 != 0.0, -s_v1, s_shift))
    back = path - abs(shift)
    reverses = back > 1e-6 * path  # a path longer than the shift beyond rounding
    d1 = where(reverses, 0.5 * (path + first * shift), path)
    d2 = where(reverses, 0.5 * (path - first * shift), 0.0)
    return (d1, where(reverses, first, s_shift), a0, where(reverses, 0.0, a1),
            d2, where(reverses, -first, 0.0), 0.0 * a1, where(reverses, a1, 0.0))


def bristle_advance(z, n, distance, direction, speed0, speed1, p, o, dip, stiffness, exp, ratio_power, where):
    """Move the ``n`` element states ``z`` in place along ``distance`` ≥ 0 travelled in
    ``direction`` (±1; 0 with distance 0 leaves them) while the speed goes from ``speed0`` to
    ``speed1``. In the travelled distance s, element i's deflection c = g/(n·k_i) (its sliding
    state) moves linearly from c0 to c1 and w = z_i − direction·c obeys dw/ds = −w/c − direction·c′:
    with c at its mean in the decay, w1 = w0·e^(−x) − direction·(c1 − c0)·(1 − e^(−x))/x, x =
    distance/c̄ (an exponential integrator: exact for a constant level, stable at any step and
    stiffness, second order). An infinite distance sets the states to their sliding values."""
    g0 = state_level(speed0, p, o, dip, exp, ratio_power, where)
    g1 = state_level(speed1, p, o, dip, exp, ratio_power, where)
    for i in range(n):
        nk = n * stiffness(p, o, i)
        c0, c1 = g0 / nk, g1 / nk
        x = distance / (0.5 * (c0 + c1))
        decay = exp(-x)
        small = x < 1e-8
        share = where(small, 1.0 - 0.5 * x, (1.0 - decay) / where(small, 1.0, x))  # (1 − e^(−x))/x
        z[i] = direction * c1 + (z[i] - direction * c0) * decay - direction * (c1 - c0) * share


def bristle_advance_pieces(z, n, distance, direction, speed0, speed1, p, o, dip, stiffness, exp, ratio_power,
                           where):
    """:func:`bristle_advance` cut into pieces of equal time over which the speed, linear in time
    from ``speed0`` to ``speed1``, changes the level by about LEVEL_STEP of it at most (MAX_PIECES
    at most): a step that crosses the dip (a stop or a start at a low rate) follows its level
    there rather than a line from one end to the other. Scalars only (the compiled kernel)."""
    g0 = state_level(speed0, p, o, dip, exp, ratio_power, where)
    g1 = state_level(speed1, p, o, dip, exp, ratio_power, where)
    pieces = min(MAX_PIECES, 1 + int(abs(g1 - g0) / (LEVEL_STEP * min(g0, g1))))
    total = speed0 + speed1
    for k in range(pieces):
        a = speed0 + (speed1 - speed0) * k / pieces
        b = speed0 + (speed1 - speed0) * (k + 1) / pieces
        share = (a + b) / (pieces * total) if total > 0.0 else 1.0 / pieces
        bristle_advance(z, n, distance * share, direction, a, b, p, o, dip, stiffness, exp, ratio_power, where)


def bristle_force(v, z, n, p, o, dip, stiffness, damping, exp, ratio_power, where):
    """F = Fv·v + Σ k_i·z_i + σ1·Σ ż_i of the branch from ``p[o]`` with the states ``z`` at velocity v."""
    speed = abs(v)
    level = state_level(speed, p, o, dip, exp, ratio_power, where)
    spring = 0.0 * v
    rate = 0.0 * v
    for i in range(n):
        k = stiffness(p, o, i)
        spring = spring + k * z[i]
        rate = rate + (v - speed * z[i] * (n * k) / level)
    return p[o] * v + spring + damping(p, o) * rate


def _numpy_ratio_power(x, log_x, scale, exponent):
    """(x/scale)^exponent."""
    return (x / scale) ** exponent


NUMPY_OPS = (np.exp, _numpy_ratio_power, np.where)


# -------------------------------------------------------------------------- registry
@dataclass(frozen=True)
class FrictionLaw:
    """One friction law.

    Attributes:
        name: the law's name (``coulomb``, …).
        linear: parameters of one velocity branch that enter the torque linearly in a static law:
            (Fv, Fc) or (Fv, Fc, Fs), in that order (a dynamic law's level uses them too).
        nonlinear: the dip's shape parameters (velocities, exponents), in ``dip``'s order.
        dip: the law's dip (module docstring), or None for a law without one (Coulomb).
        dip_end: speed from which ``dip`` counts as 0 (with ``dip``).
        presliding: a dynamic law's parameters after the dip's: (σ0, σ1), or the stem of one
            per element (``k`` → k1 … kn) with ``per_element``.
        per_element: ``presliding`` names one parameter per element.
        elements: a dynamic law's default number of elements (0: a static law).
        stiffness, damping: a dynamic law's ``stiffness(p, o, i)`` of element i and
            ``damping(p, o)`` of the branch from ``p[o]`` (:func:`bristle_force`).
    """

    name: str
    linear: tuple[str, ...]
    nonlinear: tuple[str, ...] = ()
    dip: Callable | None = None
    dip_end: Callable | None = None
    presliding: tuple[str, ...] = ()
    per_element: bool = False
    elements: int = 0
    stiffness: Callable | None = None
    damping: Callable | None = None

    def __post_init__(self) -> None:
        if self.linear not in (("Fv", "Fc"), ("Fv", "Fc", "Fs")):
            raise FrictionIdError(f"friction law {self.name}: linear parameters must be (Fv, Fc) or (Fv, Fc, Fs)")
        if (self.dip is None) != (not self.nonlinear) or (self.dip is None) != (self.dip_end is None):
            raise FrictionIdError(f"friction law {self.name}: a dip and its end go with nonlinear parameters")
        dynamic = (bool(self.presliding), self.elements > 0, self.stiffness is not None, self.damping is not None)
        if any(dynamic) and not (all(dynamic) and self.linear == ("Fv", "Fc", "Fs") and len(self.nonlinear) == 1):
            raise FrictionIdError(f"friction law {self.name}: a dynamic law has (Fv, Fc, Fs), one dip speed, "
                                  "pre-sliding parameters, elements, a stiffness and a damping")

    @property
    def is_dynamic(self) -> bool:
        """True for a law with internal states (LuGre, Maxwell-slip)."""
        return self.elements > 0

    def branch_params(self, elements: int | None = None) -> tuple[str, ...]:
        """Parameters of one velocity branch, linear ones first (a dynamic law's with ``elements``,
        default its own)."""
        n = elements or self.elements
        extra = tuple(f"{stem}{i + 1}" for stem in self.presliding for i in range(n)) if self.per_element \
            else self.presliding
        return self.linear + self.nonlinear + extra

    @property
    def params(self) -> tuple[str, ...]:
        """Parameters of one velocity branch, linear ones first (default elements)."""
        return self.branch_params()


LAWS: dict[str, FrictionLaw] = {law.name: law for law in (
    FrictionLaw("coulomb", ("Fv", "Fc")),
    FrictionLaw("threlfall", ("Fv", "Fc"), ("v0",), threlfall_dip, threlfall_dip_end),
    FrictionLaw("tustin", ("Fv", "Fc", "Fs"), ("vs",), tustin_dip, tustin_dip_end),
    FrictionLaw("stribeck", ("Fv", "Fc", "Fs"), ("vs", "delta"), stribeck_dip, stribeck_dip_end),
    FrictionLaw("lugre", ("Fv", "Fc", "Fs"), ("vs",), lugre_dip, lugre_dip_end, ("sigma0", "sigma1"),
                elements=1, stiffness=lugre_stiffness, damping=lugre_damping),
    FrictionLaw("gms", ("Fv", "Fc", "Fs"), ("vs",), lugre_dip, lugre_dip_end, ("k",), per_element=True,
                elements=4, stiffness=gms_stiffness, damping=gms_damping),
)}
# The law names (choices of every --friction option and parameter).
FRICTIONS = tuple(LAWS)
# The static laws (no internal state): those the EMPS simulator and the dip sums compile.
STATIC_FRICTIONS = tuple(name for name, law in LAWS.items() if not law.is_dynamic)
# Most elements of a Maxwell-slip law.
MAX_ELEMENTS = 16


def parameter_base(name: str) -> str:
    """The registry's name of a friction parameter: ``Fc_pos`` → ``Fc``, ``k3`` → ``k``."""
    base = name.removesuffix("_pos").removesuffix("_neg")
    stem = base.rstrip("0123456789")
    return stem if stem != base and stem in UNITS else base
