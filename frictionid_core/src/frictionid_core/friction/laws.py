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
}

# Default search bounds (SI units; wide enough for the EMPS and the TX40).
DEFAULT_BOUNDS = {
    "Fv": (0.0, 500.0),
    "Fc": (0.0, 100.0),
    "Fs": (0.0, 100.0),
    "vs": (1e-6, 0.5),
    "v0": (1e-6, 0.5),
    "delta": (0.3, 5.0),
}

DIP_NEGLIGIBLE = 40.0  # the dip is treated as 0 where its exponent passes −40 (e^−40 ≈ 4e−18)
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
        linear: parameters of one velocity branch that enter the torque linearly: (Fv, Fc) or
            (Fv, Fc, Fs), in that order.
        nonlinear: the dip's shape parameters (velocities, exponents), in ``dip``'s order.
        dip: the law's dip (module docstring), or None for a law without one (Coulomb).
        dip_end: speed from which ``dip`` counts as 0 (with ``dip``).
        states: names of internal states integrated along the motion. None of these laws has
            any, and a law declaring some is refused until the kernels carry them (the package
            docstring says how).
    """

    name: str
    linear: tuple[str, ...]
    nonlinear: tuple[str, ...] = ()
    dip: Callable | None = None
    dip_end: Callable | None = None
    states: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.states:
            raise FrictionIdError(f"friction law {self.name}: internal states {list(self.states)} are not supported "
                                  "yet (frictionid_core.friction says how they plug in)")
        if self.linear not in (("Fv", "Fc"), ("Fv", "Fc", "Fs")):
            raise FrictionIdError(f"friction law {self.name}: linear parameters must be (Fv, Fc) or (Fv, Fc, Fs)")
        if (self.dip is None) != (not self.nonlinear) or (self.dip is None) != (self.dip_end is None):
            raise FrictionIdError(f"friction law {self.name}: a dip and its end go with nonlinear parameters")

    @property
    def params(self) -> tuple[str, ...]:
        """Parameters of one velocity branch, linear ones first."""
        return self.linear + self.nonlinear


LAWS: dict[str, FrictionLaw] = {law.name: law for law in (
    FrictionLaw("coulomb", ("Fv", "Fc")),
    FrictionLaw("threlfall", ("Fv", "Fc"), ("v0",), threlfall_dip, threlfall_dip_end),
    FrictionLaw("tustin", ("Fv", "Fc", "Fs"), ("vs",), tustin_dip, tustin_dip_end),
    FrictionLaw("stribeck", ("Fv", "Fc", "Fs"), ("vs", "delta"), stribeck_dip, stribeck_dip_end),
)}
# The law names (choices of every --friction option and parameter).
FRICTIONS = tuple(LAWS)
