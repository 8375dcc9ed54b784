"""The friction models under numpy: each law of :data:`~frictionid_core.friction.laws.LAWS`,
symmetric or asymmetric (a Maxwell-slip law also with its number of elements).

The asymmetric variant has one parameter set for v > 0 (suffix ``_pos``) and one for v < 0
(suffix ``_neg``); the negative branch uses magnitudes: τ(v<0) = −[Fc_neg + …] − Fv_neg·|v|.

Parameter arrays are (P, k) for a population of P candidates (or (k,) for one); velocities
are (N,); :meth:`FrictionModel.torque` returns (P, N) (or (N,)) with no Python loop: it runs
the laws' own functions (:mod:`~frictionid_core.friction.laws`) on numpy arrays.
A smoothed sign tanh(v/ε) replaces sign(v) when ``eps > 0`` (feed-forward without chatter).

A dynamic law's friction depends on the motion's history: :meth:`FrictionModel.torque` then
needs the samples' times and integrates the states along them in the compiled kernel
(:mod:`~frictionid_core.friction.states`); :class:`~frictionid_core.friction.states.StateFriction`
steps them sample by sample under numpy (the node's feed-forward, the kernel's reference).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction.laws import (
    DEFAULT_BOUNDS,
    FRICTIONS,
    LAWS,
    LUGRE_DELTA,
    MAX_ELEMENTS,
    NUMPY_OPS,
    STATIC_FRICTIONS,
    UNITS,
    FrictionLaw,
    branch_force,
    dip_level,
    parameter_base,
)


def smooth_sign(v: np.ndarray, eps: float = 0.0) -> np.ndarray:
    """sign(v) (sign(0) = 0) or, when eps > 0, tanh(v/eps) with eps in velocity units."""
    if eps > 0.0:
        return np.tanh(v / eps)
    return np.sign(v)


@dataclass(frozen=True)
class FrictionModel:
    """A friction model: law ``name`` × {symmetric, asymmetric}; a dynamic law's ``elements``
    (None: the law's default; only a Maxwell-slip law takes another)."""

    name: str
    asymmetric: bool = False
    elements: int | None = None

    def __post_init__(self) -> None:
        if self.name not in LAWS:
            raise FrictionIdError(f"unknown friction model '{self.name}'; choose one of {', '.join(FRICTIONS)}")
        law = LAWS[self.name]
        if self.elements is None:
            object.__setattr__(self, "elements", law.elements or None)
        elif not law.per_element or isinstance(self.elements, bool) or not isinstance(self.elements, int) \
                or not 1 <= self.elements <= MAX_ELEMENTS:
            raise FrictionIdError(f"elements {self.elements!r}: only the gms law takes a number of elements, "
                                  f"1 to {MAX_ELEMENTS}" + ("" if law.per_element else f" ({self.name} has none)"))

    @property
    def is_dynamic(self) -> bool:
        """True for a law with internal states (its friction depends on the motion's history)."""
        return self.law.is_dynamic

    @property
    def law(self) -> FrictionLaw:
        return LAWS[self.name]

    @property
    def branch_names(self) -> tuple[str, ...]:
        """Parameter names of one velocity branch (no suffix)."""
        return self.law.branch_params(self.elements)

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names in vector order (``_pos`` block then ``_neg`` block if asymmetric)."""
        b = self.branch_names
        if not self.asymmetric:
            return b
        return tuple(f"{n}_pos" for n in b) + tuple(f"{n}_neg" for n in b)

    @property
    def label(self) -> str:
        n = f"-{self.elements}" if self.law.per_element else ""
        return f"{self.name}{n}{'-asym' if self.asymmetric else ''}"

    @property
    def is_linear(self) -> bool:
        """True when every parameter enters linearly (Coulomb + viscous)."""
        return not self.law.nonlinear and not self.is_dynamic

    def units(self) -> dict[str, str]:
        return {n: UNITS[_base(n)] for n in self.names}

    def default_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) default search bounds, each (k,)."""
        lo = np.array([DEFAULT_BOUNDS[_base(n)][0] for n in self.names])
        hi = np.array([DEFAULT_BOUNDS[_base(n)][1] for n in self.names])
        return lo, hi

    def torque(self, params: np.ndarray, v: np.ndarray, eps: float = 0.0, t: np.ndarray | None = None
               ) -> np.ndarray:
        """Friction force/torque for parameters (P, k) or (k,) at velocities v (N,).

        Returns (P, N), or (N,) when ``params`` is 1-D. ``eps`` > 0 smooths the sign of a static
        law. A dynamic law needs the samples' times ``t`` (N,) (s): its states start at their
        sliding values of the first sample and are reset so at a gap
        (:func:`~frictionid_core.friction.states.resets`).
        """
        if self.is_dynamic:
            from frictionid_core.friction.states import state_torque

            if t is None:
                raise FrictionIdError(f"{self.label} has internal states: its torque needs the samples' times")
            return state_torque(self, params, v, t)
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
        table = p.T[:, :, None]  # (k, P, 1): the laws' p[o + j] is parameter o + j of every candidate
        nb = len(self.branch_names)
        out = self._branch(table, 0, v, s, a)
        if self.asymmetric:
            out = np.where(v >= 0.0, out, self._branch(table, nb, v, s, a))
        return out[0] if single else out

    def static_equivalent(self, params: np.ndarray) -> tuple[FrictionModel, np.ndarray]:
        """(the static law of this law's sliding limit, its parameters (…, k′) from ``params``
        (…, k)): the law itself for a static law; for a dynamic one the Stribeck law with δ = 2
        (Fv, Fc, Fs, vs, 2 per branch): what it predicts at constant speed, without its states."""
        p = np.asarray(params, dtype=float)
        if not self.is_dynamic:
            return self, p
        nb = len(self.branch_names)
        branches = [np.concatenate([p[..., o : o + 4], np.full(p.shape[:-1] + (1,), LUGRE_DELTA)], axis=-1)
                    for o in ((0, nb) if self.asymmetric else (0,))]
        return FrictionModel("stribeck", self.asymmetric), np.concatenate(branches, axis=-1)

    def torque_each(self, params: np.ndarray, v: np.ndarray, eps: float = 0.0) -> np.ndarray:
        """Friction (J,) of J joints, each with its own parameters ``params`` (J, k) at its own
        velocity v (J,) (the diagonal of :meth:`torque`; for a handful of joints; a static law's)."""
        if self.is_dynamic:
            raise FrictionIdError(f"{self.label} has internal states: step them with StateFriction")
        return np.diagonal(self.torque(params, v, eps)).copy()

    def _branch(self, table: np.ndarray, o: int, v, s, a) -> np.ndarray:
        """The branch whose parameters start at row ``o`` of ``table`` (k, P, 1) → (P, N)."""
        law = self.law
        n_linear = len(law.linear)
        level = table[o + 1]
        if law.dip is not None:
            level = dip_level(table, o, n_linear, _numpy_dip(law, a, table, o + n_linear))
        return branch_force(v, s, table[o], level)

    def dip(self, theta_nl: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Shape of the non-Coulomb part of one branch at speeds a (N,) → (P, N).

        ``theta_nl`` holds the branch's nonlinear parameters (P, m): v0 for threlfall,
        vs for tustin, (vs, delta) for stribeck. The branch torque is
        Fv·v + Fc·sign(v) + c·dip·sign(v) with c = −Fc (threlfall) or Fs − Fc (tustin, stribeck).
        (The population cost uses the compiled :func:`frictionid_core.friction.kernels.dip_sums` instead.)
        """
        if self.law.dip is None:
            raise FrictionIdError(f"the {self.name} model has no nonlinear part")
        table = np.atleast_2d(theta_nl).T[:, :, None]
        return _numpy_dip(self.law, np.asarray(a, dtype=float)[None, :], table, 0)


def _numpy_dip(law: FrictionLaw, a: np.ndarray, table: np.ndarray, o: int) -> np.ndarray:
    """The law's dip at speeds ``a`` (1, N) for the nonlinear parameters from row ``o`` of
    ``table`` (k, P, 1) → (P, N), under numpy."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return law.dip(a, None, table, o, *NUMPY_OPS)


def _base(name: str) -> str:
    return parameter_base(name)


def get_model(friction: str, asymmetric: bool = False, elements: int | None = None) -> FrictionModel:
    """The model of friction law ``friction`` (one of FRICTIONS), symmetric or asymmetric; a
    Maxwell-slip law's ``elements`` (default 4)."""
    return FrictionModel(friction, asymmetric, elements)


def elements_of(friction: str, names) -> int | None:
    """The number of elements of a Maxwell-slip law's parameters ``names`` (their ``k1``, ``k2``, …,
    with or without a ``<joint>/`` prefix and a branch suffix); None for another law."""
    if friction not in LAWS or not LAWS[friction].per_element:
        return None
    stems = {n.rsplit("/", 1)[-1].removesuffix("_pos").removesuffix("_neg") for n in names}
    return max(1, sum(1 for stem in stems if parameter_base(stem) == "k"))


def all_models() -> list[FrictionModel]:
    """The 8 static models: each static law, symmetric then asymmetric."""
    return [FrictionModel(f, a) for f in STATIC_FRICTIONS for a in (False, True)]
