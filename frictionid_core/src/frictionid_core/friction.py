"""The friction laws of docs/reference.md#friction-models (the registry :data:`LAWS`) and the 8 friction models.

Every law maps joint velocity v (m/s or rad/s) to a friction force/torque (N or N·m):

* ``coulomb``   Fv·v + Fc·sign(v)
* ``threlfall`` Fv·v + Fc·g(v)·sign(v),  g = (1−e^(−3|v|/v0))/(1−e^(−3)) for |v| ≤ v0, else 1
* ``tustin``    Fv·v + [Fc + (Fs−Fc)·e^(−|v|/vs)]·sign(v)
* ``stribeck``  Fv·v + [Fc + (Fs−Fc)·e^(−(|v|/vs)^δ)]·sign(v)

i.e. Fv·v + [Fc + c·dip(|v|)]·sign(v) with c = Fs − Fc when the law has Fs, else −Fc: the
*dip* is the only part that depends on nonlinear parameters. A new law is one
:class:`FrictionLaw` in :data:`LAWS` (name, parameters, integer code, numpy dip) plus its
branch in the compiled kernels (:mod:`frictionid_core.dipsums`, :mod:`frictionid_core.emps_simulation`),
which import the codes below as constants.

A friction *model* is a law, symmetric or asymmetric: the asymmetric variant has one parameter
set for v > 0 (suffix ``_pos``) and one for v < 0 (suffix ``_neg``); the negative branch uses
magnitudes: τ(v<0) = −[Fc_neg + …] − Fv_neg·|v|.

Parameter arrays are (P, k) for a population of P candidates (or (k,) for one); velocities
are (N,); :meth:`FrictionModel.torque` returns (P, N) (or (N,)) with no Python loop.
A smoothed sign tanh(v/ε) replaces sign(v) when ``eps > 0`` (feed-forward without chatter).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

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

# Integer codes of the laws in compiled kernels (numba freezes them as constants).
COULOMB, THRELFALL, TUSTIN, STRIBECK = 0, 1, 2, 3

_E3 = 1.0 - np.exp(-3.0)


def threlfall_dip(a: np.ndarray, v0) -> np.ndarray:
    """1 − g(|v|) of the Threlfall law: 1 at v = 0, 0 for |v| ≥ v0."""
    with np.errstate(over="ignore", invalid="ignore"):
        g = (1.0 - np.exp(-3.0 * a / v0)) / _E3
    return np.where(a <= v0, 1.0 - g, 0.0)


def stribeck_shape(a: np.ndarray, vs, delta) -> np.ndarray:
    """e^(−(|v|/vs)^δ): 1 at v = 0, decaying with speed."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        r = a / vs
        return np.exp(-(r if np.isscalar(delta) and delta == 1.0 else r**delta))


def _tustin_dip(a: np.ndarray, theta: np.ndarray) -> np.ndarray:
    return np.exp(a * (-1.0 / theta[:, 0:1]))


def _threlfall_dip(a: np.ndarray, theta: np.ndarray) -> np.ndarray:
    return threlfall_dip(a, theta[:, 0:1])


def _stribeck_dip(a: np.ndarray, theta: np.ndarray) -> np.ndarray:
    return stribeck_shape(a, theta[:, 0:1], theta[:, 1:2])


@dataclass(frozen=True)
class FrictionLaw:
    """One friction law.

    Attributes:
        name: the law's name (``coulomb``, …).
        linear: parameters of one velocity branch that enter the torque linearly.
        nonlinear: the dip's shape parameters (velocities, exponents).
        code: the law's integer code in compiled kernels.
        dip: (speeds |v| (1, N), nonlinear parameters (P, m)) → dip (P, N); None for a law
            without one (Coulomb).
    """

    name: str
    linear: tuple[str, ...]
    nonlinear: tuple[str, ...]
    code: int
    dip: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None

    @property
    def params(self) -> tuple[str, ...]:
        """Parameters of one velocity branch, linear ones first."""
        return self.linear + self.nonlinear


LAWS: dict[str, FrictionLaw] = {law.name: law for law in (
    FrictionLaw("coulomb", ("Fv", "Fc"), (), COULOMB),
    FrictionLaw("threlfall", ("Fv", "Fc"), ("v0",), THRELFALL, _threlfall_dip),
    FrictionLaw("tustin", ("Fv", "Fc", "Fs"), ("vs",), TUSTIN, _tustin_dip),
    FrictionLaw("stribeck", ("Fv", "Fc", "Fs"), ("vs", "delta"), STRIBECK, _stribeck_dip),
)}
# The law names (choices of every --friction option and parameter).
FRICTIONS = tuple(LAWS)


def smooth_sign(v: np.ndarray, eps: float = 0.0) -> np.ndarray:
    """sign(v) (sign(0) = 0) or, when eps > 0, tanh(v/eps) with eps in velocity units."""
    if eps > 0.0:
        return np.tanh(v / eps)
    return np.sign(v)


@dataclass(frozen=True)
class FrictionModel:
    """One of the 8 friction models: law ``name`` × {symmetric, asymmetric}."""

    name: str
    asymmetric: bool = False

    def __post_init__(self) -> None:
        if self.name not in LAWS:
            raise FrictionIdError(f"unknown friction model '{self.name}'; choose one of {', '.join(FRICTIONS)}")

    @property
    def law(self) -> FrictionLaw:
        return LAWS[self.name]

    @property
    def branch_names(self) -> tuple[str, ...]:
        """Parameter names of one velocity branch (no suffix)."""
        return self.law.params

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names in vector order (``_pos`` block then ``_neg`` block if asymmetric)."""
        b = self.branch_names
        if not self.asymmetric:
            return b
        return tuple(f"{n}_pos" for n in b) + tuple(f"{n}_neg" for n in b)

    @property
    def label(self) -> str:
        return f"{self.name}{'-asym' if self.asymmetric else ''}"

    @property
    def is_linear(self) -> bool:
        """True when every parameter enters linearly (Coulomb + viscous)."""
        return not self.law.nonlinear

    def units(self) -> dict[str, str]:
        return {n: UNITS[_base(n)] for n in self.names}

    def default_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) default search bounds, each (k,)."""
        lo = np.array([DEFAULT_BOUNDS[_base(n)][0] for n in self.names])
        hi = np.array([DEFAULT_BOUNDS[_base(n)][1] for n in self.names])
        return lo, hi

    def torque(self, params: np.ndarray, v: np.ndarray, eps: float = 0.0) -> np.ndarray:
        """Friction force/torque for parameters (P, k) or (k,) at velocities v (N,).

        Returns (P, N), or (N,) when ``params`` is 1-D. ``eps`` > 0 smooths the sign.
        """
        p = np.asarray(params, dtype=float)
        single = p.ndim == 1
        p = np.atleast_2d(p)
        if p.shape[1] != len(self.names):
            raise FrictionIdError(
                f"{self.label} takes {len(self.names)} parameters {list(self.names)}, got {p.shape[1]}"
            )
        v = np.asarray(v, dtype=float).ravel()[None, :]
        s = smooth_sign(v, eps)
        a = np.abs(v)
        nb = len(self.branch_names)
        out = self._branch(p[:, :nb], v, s, a)
        if self.asymmetric:
            out = np.where(v >= 0.0, out, self._branch(p[:, nb:], v, s, a))
        return out[0] if single else out

    def torque_each(self, params: np.ndarray, v: np.ndarray, eps: float = 0.0) -> np.ndarray:
        """Friction (J,) of J joints, each with its own parameters ``params`` (J, k) at its own
        velocity v (J,) (the diagonal of :meth:`torque`; for a handful of joints)."""
        return np.diagonal(self.torque(params, v, eps)).copy()

    def _branch(self, p: np.ndarray, v, s, a) -> np.ndarray:
        law = self.law
        col = {n: p[:, i : i + 1] for i, n in enumerate(law.params)}
        fv, fc = col["Fv"], col["Fc"]
        level = fc
        if law.dip is not None:  # the dip takes the level from Fc to Fs, or to 0 without Fs
            d = law.dip(a, p[:, len(law.linear) :])
            level = fc + (col["Fs"] - fc) * d if "Fs" in col else fc * (1.0 - d)
        return fv * v + level * s

    def dip(self, theta_nl: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Shape of the non-Coulomb part of one branch at speeds a (N,) → (P, N).

        ``theta_nl`` holds the branch's nonlinear parameters (P, m): v0 for threlfall,
        vs for tustin, (vs, delta) for stribeck. The branch torque is
        Fv·v + Fc·sign(v) + c·dip·sign(v) with c = −Fc (threlfall) or Fs − Fc (tustin, stribeck).
        (The population cost uses the compiled :mod:`frictionid_core.dipsums` instead.)
        """
        if self.law.dip is None:
            raise FrictionIdError(f"the {self.name} model has no nonlinear part")
        return self.law.dip(np.asarray(a, dtype=float)[None, :], np.atleast_2d(theta_nl))


def _base(name: str) -> str:
    return name.removesuffix("_pos").removesuffix("_neg")


def get_model(friction: str, asymmetric: bool = False) -> FrictionModel:
    """The model of friction law ``friction`` (one of FRICTIONS), symmetric or asymmetric."""
    return FrictionModel(friction, asymmetric)


def all_models() -> list[FrictionModel]:
    """The 8 models: each law, symmetric then asymmetric."""
    return [FrictionModel(f, a) for f in FRICTIONS for a in (False, True)]
