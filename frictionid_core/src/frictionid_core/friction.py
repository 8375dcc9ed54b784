"""The 8 friction models of SPEC §2.1, vectorised over a population.

Every model maps joint velocity v (m/s or rad/s) to a friction force/torque (N or N·m):

* ``coulomb``   Fv·v + Fc·sign(v)
* ``threlfall`` Fv·v + Fc·g(v)·sign(v),  g = (1−e^(−3|v|/v0))/(1−e^(−3)) for |v| ≤ v0, else 1
* ``tustin``    Fv·v + [Fc + (Fs−Fc)·e^(−|v|/vs)]·sign(v)
* ``stribeck``  Fv·v + [Fc + (Fs−Fc)·e^(−(|v|/vs)^δ)]·sign(v)

The asymmetric variant has one parameter set for v > 0 (suffix ``_pos``) and one for v < 0
(suffix ``_neg``); the negative branch uses magnitudes: τ(v<0) = −[Fc_neg + …] − Fv_neg·|v|.

Parameter arrays are (P, k) for a population of P candidates (or (k,) for one); velocities
are (N,); :meth:`FrictionModel.torque` returns (P, N) (or (N,)) with no Python loop.
A smoothed sign tanh(v/ε) replaces sign(v) when ``eps > 0`` (feed-forward without chatter).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import FrictionIdError

KINDS = ("coulomb", "threlfall", "tustin", "stribeck")

# Per kind: the parameters of one branch, in order. Linear ones first.
_BRANCH_PARAMS = {
    "coulomb": ("Fv", "Fc"),
    "threlfall": ("Fv", "Fc", "v0"),
    "tustin": ("Fv", "Fc", "Fs", "vs"),
    "stribeck": ("Fv", "Fc", "Fs", "vs", "delta"),
}
LINEAR_PARAMS = frozenset({"Fv", "Fc", "Fs"})

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

_E3 = 1.0 - np.exp(-3.0)


def smooth_sign(v: np.ndarray, eps: float = 0.0) -> np.ndarray:
    """sign(v) (sign(0) = 0) or, when eps > 0, tanh(v/eps) with eps in velocity units."""
    if eps > 0.0:
        return np.tanh(v / eps)
    return np.sign(v)


@dataclass(frozen=True)
class FrictionModel:
    """One of the 8 friction models: kind × {symmetric, asymmetric}."""

    kind: str
    asymmetric: bool = False

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise FrictionIdError(f"unknown friction model '{self.kind}'; choose one of {', '.join(KINDS)}")

    @property
    def branch_names(self) -> tuple[str, ...]:
        """Parameter names of one velocity branch (no suffix)."""
        return _BRANCH_PARAMS[self.kind]

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names in vector order (``_pos`` block then ``_neg`` block if asymmetric)."""
        b = self.branch_names
        if not self.asymmetric:
            return b
        return tuple(f"{n}_pos" for n in b) + tuple(f"{n}_neg" for n in b)

    @property
    def label(self) -> str:
        return f"{self.kind}{'-asym' if self.asymmetric else ''}"

    @property
    def is_linear(self) -> bool:
        """True when every parameter enters linearly (Coulomb + viscous)."""
        return all(_base(n) in LINEAR_PARAMS for n in self.names)

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

    def _branch(self, p: np.ndarray, v, s, a) -> np.ndarray:
        col = {n: p[:, i : i + 1] for i, n in enumerate(self.branch_names)}
        fv, fc = col["Fv"], col["Fc"]
        if self.kind == "coulomb":
            level = fc
        elif self.kind == "threlfall":
            level = fc * (1.0 - threlfall_dip(a, col["v0"]))
        else:
            delta = col.get("delta", 1.0)
            level = fc + (col["Fs"] - fc) * stribeck_shape(a, col["vs"], delta)
        return fv * v + level * s

    def dip(self, theta_nl: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Shape of the non-Coulomb part of one branch at speeds a (N,) → (P, N).

        ``theta_nl`` holds the branch's nonlinear parameters (P, m): v0 for threlfall,
        vs for tustin, (vs, delta) for stribeck. The branch torque is
        Fv·v + Fc·sign(v) + c·dip·sign(v) with c = −Fc (threlfall) or Fs − Fc (tustin, stribeck).
        (The population cost uses the compiled :mod:`frictionid_core.dipsums` instead.)
        """
        a = np.asarray(a, dtype=float)[None, :]
        t = np.atleast_2d(theta_nl)
        if self.kind == "threlfall":
            return threlfall_dip(a, t[:, 0:1])
        if self.kind == "tustin":
            return np.exp(a * (-1.0 / t[:, 0:1]))
        if self.kind == "stribeck":
            return stribeck_shape(a, t[:, 0:1], t[:, 1:2])
        raise FrictionIdError("the Coulomb model has no nonlinear part")


def threlfall_dip(a: np.ndarray, v0) -> np.ndarray:
    """1 − g(|v|) of the Threlfall model: 1 at v = 0, 0 for |v| ≥ v0."""
    with np.errstate(over="ignore", invalid="ignore"):
        g = (1.0 - np.exp(-3.0 * a / v0)) / _E3
    return np.where(a <= v0, 1.0 - g, 0.0)


def stribeck_shape(a: np.ndarray, vs, delta) -> np.ndarray:
    """e^(−(|v|/vs)^δ): 1 at v = 0, decaying with speed."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        r = a / vs
        return np.exp(-(r if np.isscalar(delta) and delta == 1.0 else r**delta))


def _base(name: str) -> str:
    return name.removesuffix("_pos").removesuffix("_neg")


def get_model(kind: str, asymmetric: bool = False) -> FrictionModel:
    """The friction model ``kind`` (one of KINDS), symmetric or asymmetric."""
    return FrictionModel(kind, asymmetric)


def all_models() -> list[FrictionModel]:
    """The 8 models: each kind, symmetric then asymmetric."""
    return [FrictionModel(k, a) for k in KINDS for a in (False, True)]
