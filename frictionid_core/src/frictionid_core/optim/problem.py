"""What every optimiser receives (:class:`Problem`) and returns (:class:`OptimResult`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import OptimError


@dataclass
class Problem:
    """A bounded minimisation problem over k named parameters.

    Attributes:
        names: parameter names, length k, unique (they key :meth:`OptimResult.to_dict`).
        lower: lower bounds, shape (k,), finite, in the parameters' own units.
        upper: upper bounds, shape (k,), finite, each strictly above its lower bound.
        batch_cost: cost of a whole population in one call: (P, k) parameters -> (P,) costs.
            NaN/inf costs are allowed; optimisers treat them as the worst possible cost.
        residuals: optional (k,) -> (N,) residual vector whose sum of squares is the cost;
            used by ``lm`` (and the ``hybrid`` polish). Without it ``lm`` falls back to
            L-BFGS-B on ``batch_cost``.
        x0: optional start point, shape (k,), inside the bounds: the ``lm`` start, the first
            member of the population methods' initial population, the first bo/dt call.
        batch_residuals: optional (P, k) -> (P, N) residuals of a population in one call; with
            it ``lm`` evaluates each finite-difference Jacobian in one call instead of k.
        progress: optional ``progress(generation, evaluations, best_cost)``, called after each
            generation of a population method and each cost call of lm/bo/dt (generation 0);
            an exception it raises ends the run (how a caller cancels one).
    """

    names: list[str]
    lower: np.ndarray
    upper: np.ndarray
    batch_cost: Callable[[np.ndarray], np.ndarray]
    residuals: Callable[[np.ndarray], np.ndarray] | None = None
    x0: np.ndarray | None = None
    batch_residuals: Callable[[np.ndarray], np.ndarray] | None = None
    progress: Callable[[int, int, float], None] | None = None

    def __post_init__(self) -> None:
        self.check()

    @property
    def k(self) -> int:
        """Number of parameters."""
        return len(self.names)

    def check(self) -> None:
        """Validate (and normalise to float arrays) every field; raise :class:`OptimError`."""
        if isinstance(self.names, str) or not all(isinstance(n, str) for n in self.names):
            raise OptimError(f"problem names must be a list of strings, got {self.names!r}")
        self.names = list(self.names)
        self.lower = _bound_array(self.lower, "lower")
        self.upper = _bound_array(self.upper, "upper")
        k = len(self.names)
        if k == 0 and self.lower.size == 0 and self.upper.size == 0:
            raise OptimError("problem has no parameters: names and bounds are empty")
        if self.lower.shape != (k,) or self.upper.shape != (k,):
            raise OptimError(
                f"bounds shape mismatch: {k} parameter names {self.names} but lower has "
                f"{self.lower.size} and upper has {self.upper.size} values"
            )
        if len(set(self.names)) != k:
            dup = sorted({n for n in self.names if self.names.count(n) > 1})
            raise OptimError(f"duplicate parameter names: {dup}")
        for side, arr in (("lower", self.lower), ("upper", self.upper)):
            bad = np.flatnonzero(~np.isfinite(arr))
            if bad.size:
                i = int(bad[0])
                raise OptimError(
                    f"parameter '{self.names[i]}': {side} bound {arr[i]} is not finite "
                    "(every parameter needs a finite search interval)"
                )
        bad = np.flatnonzero(self.lower >= self.upper)
        if bad.size:
            i = int(bad[0])
            raise OptimError(
                f"parameter '{self.names[i]}': lower bound {self.lower[i]:g} is not below "
                f"upper bound {self.upper[i]:g}"
            )
        if not callable(self.batch_cost):
            raise OptimError(f"batch_cost must be callable, got {type(self.batch_cost).__name__}")
        if self.residuals is not None and not callable(self.residuals):
            raise OptimError(f"residuals must be callable or None, got {type(self.residuals).__name__}")
        if self.batch_residuals is not None and (self.residuals is None or not callable(self.batch_residuals)):
            raise OptimError("batch_residuals must be callable and come with residuals")
        if self.x0 is not None:
            x0 = np.asarray(self.x0, dtype=float)
            if x0.shape != (k,):
                raise OptimError(f"x0 has shape {x0.shape}, expected ({k},) for parameters {self.names}")
            outside = np.flatnonzero(~((x0 >= self.lower) & (x0 <= self.upper)))
            if outside.size:
                i = int(outside[0])
                raise OptimError(
                    f"parameter '{self.names[i]}': start value x0 = {x0[i]:g} is outside its bounds "
                    f"[{self.lower[i]:g}, {self.upper[i]:g}]"
                )
            self.x0 = x0


def _bound_array(value, side: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise OptimError(f"{side} bounds are not numbers: {value!r}") from exc
    if arr.ndim != 1:
        raise OptimError(f"{side} bounds must be a 1-D array, got shape {arr.shape}")
    return arr


@dataclass
class OptimResult:
    """Outcome of one optimiser run.

    Attributes:
        method: optimiser id (``de``, ``pso``, ...).
        x: best parameters found, shape (k,), always inside the bounds.
        fun: ``batch_cost`` at ``x`` (same units for every method).
        nfev: number of cost evaluations (population rows / residual calls).
        wall_s: wall-clock time of the run, s (cost evaluations included).
        history_fmin: f_min(G) (thesis eq. 2-17): best cost found so far after each
            generation (population methods, length = generations) or each call
            (bo/dt: length = calls; lm: one entry per residual evaluation, sum of squares).
        history_dist_mean: dist_mean(G) (thesis eq. 2-18): mean pairwise Euclidean distance of
            the population after each generation, measured in bound-normalised coordinates
            u = (x - lower)/(upper - lower) in [0, 1]^k (so 0 <= dist <= sqrt(k)).
            bo/dt: the same measure over all points evaluated so far, one entry per call
            (NaN for the first call). lm: empty (no population).
        n_nan: number of evaluations that returned NaN/inf (treated as +inf, the worst).
        message: what happened, in one line (budget, NaN count, stop reason).
        names: parameter names, in the order of ``x``.
    """

    method: str
    x: np.ndarray
    fun: float
    nfev: int
    wall_s: float
    history_fmin: np.ndarray
    history_dist_mean: np.ndarray
    n_nan: int
    message: str
    names: list[str]

    def refined(self, polish: OptimResult, how: str) -> OptimResult:
        """This run continued by a local ``polish`` from its point (on the same or a refined
        problem): the polish's point and cost, evaluations and wall time summed, this run's
        histories, both messages."""
        return OptimResult(self.method, polish.x.copy(), float(polish.fun), self.nfev + polish.nfev,
                           self.wall_s + polish.wall_s, self.history_fmin, self.history_dist_mean,
                           self.n_nan + polish.n_nan, f"{self.message}; {how} [{polish.message}]", list(polish.names))

    def to_dict(self) -> dict:
        """JSON-ready dict (plain lists/floats; non-finite history entries become None)."""
        return {
            "method": self.method,
            "params": {n: float(v) for n, v in zip(self.names, np.asarray(self.x, dtype=float))},
            "fun": _json_float(self.fun),
            "nfev": int(self.nfev),
            "wall_s": float(self.wall_s),
            "history_fmin": [_json_float(v) for v in np.asarray(self.history_fmin, dtype=float)],
            "history_dist_mean": [_json_float(v) for v in np.asarray(self.history_dist_mean, dtype=float)],
            "n_nan": int(self.n_nan),
            "message": self.message,
        }


def _json_float(v) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None
