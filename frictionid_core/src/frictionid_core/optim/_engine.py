"""Book-keeping shared by all optimisers: budgets, evaluation, NaN handling, histories.

Population methods search in bound-normalised coordinates u in [0, 1]^k
(x = lower + u * (upper - lower)); the mapped x is clipped to the bounds so float rounding
can never leave the box and the bounds themselves are reachable exactly.
"""

from __future__ import annotations

import math
import numbers
import time

import numpy as np
from scipy.spatial.distance import pdist

from frictionid_core.errors import OptimError
from frictionid_core.optim.problem import OptimResult, Problem


def check_count(value, name: str, method: str, minimum: int = 1) -> int:
    """Return ``value`` as an int >= ``minimum`` or raise :class:`OptimError` naming it."""
    if (
        isinstance(value, bool)
        or not isinstance(value, numbers.Real)
        or not math.isfinite(value)
        or int(value) != value
    ):
        raise OptimError(f"{method}: {name} must be a whole number, got {value!r}")
    value = int(value)
    if value < minimum:
        if value <= 0:
            raise OptimError(f"{method}: {name} must be positive, got {value}")
        raise OptimError(f"{method}: {name} must be at least {minimum}, got {value}")
    return value


def check_fraction(value, name: str, method: str, low: float = 0.0, high: float = 1.0) -> float:
    """Return ``value`` as a float in [low, high] or raise :class:`OptimError` naming it."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (low <= value <= high):
        raise OptimError(f"{method}: {name} must be a number in [{low:g}, {high:g}], got {value!r}")
    return float(value)


def dist_mean(u: np.ndarray) -> float:
    """Thesis eq. 2-18: mean Euclidean distance over all unique pairs of rows of ``u``."""
    return float(pdist(u).mean()) if len(u) > 1 else float("nan")


def nan_note(n_nan: int, nfev: int) -> str:
    return f"; {n_nan} of {nfev} evaluations returned NaN/inf (treated as worst)" if n_nan else ""


def all_nan_error(method: str, nfev: int) -> OptimError:
    return OptimError(
        f"{method}: every one of the {nfev} cost evaluations returned NaN/inf; "
        "check the cost function and the parameter bounds"
    )


class PopulationRun:
    """Evaluates populations with one ``batch_cost`` call each and records f_min/dist_mean.

    Args:
        problem: the validated problem.
        method: optimiser id (for messages).
        generations: number of history entries to record (one per generation).
    """

    def __init__(self, problem: Problem, method: str, generations: int) -> None:
        self.problem = problem
        self.method = method
        self.lower = problem.lower
        self.upper = problem.upper
        self.span = problem.upper - problem.lower
        self.nfev = 0
        self.n_nan = 0
        self.best_f = np.inf
        self.best_u: np.ndarray | None = None
        self.history_fmin = np.full(generations, np.inf)
        self.history_dist_mean = np.full(generations, np.nan)
        self.generation = 0
        self.t_start = time.perf_counter()

    def initial(self, rng: np.random.Generator, pop: int) -> np.ndarray:
        """The normalised initial population (pop, k): uniform in the box; with ``problem.x0``
        its first member is x0 (e.g. the nested linear optimum), so the result is never worse
        than x0. The random draws are the same with or without x0."""
        u = rng.random((pop, self.problem.k))
        if self.problem.x0 is not None:
            u[0] = (self.problem.x0 - self.lower) / self.span
        return u

    def to_x(self, u: np.ndarray) -> np.ndarray:
        """Normalised (P, k) -> parameters (P, k), clipped to the bounds."""
        return np.clip(self.lower + u * self.span, self.lower, self.upper)

    def evaluate(self, u: np.ndarray) -> np.ndarray:
        """Costs (P,) of the normalised population ``u`` (P, k); NaN/inf -> +inf."""
        n = len(u)
        costs = np.array(self.problem.batch_cost(self.to_x(u)), dtype=float)  # own copy
        if costs.shape != (n,):
            if costs.size != n:
                raise OptimError(
                    f"{self.method}: batch_cost returned shape {costs.shape} for a population of {n}; "
                    f"expected ({n},)"
                )
            costs = costs.reshape(n)
        self.nfev += n
        finite = np.isfinite(costs)
        if not finite.all():
            self.n_nan += int(n - np.count_nonzero(finite))
            costs = np.where(finite, costs, np.inf)
        i = int(np.argmin(costs))
        if costs[i] < self.best_f:
            self.best_f = float(costs[i])
            self.best_u = u[i].copy()
        return costs

    def record(self, population_u: np.ndarray) -> None:
        """Store f_min and dist_mean of the current generation."""
        g = self.generation
        self.history_fmin[g] = self.best_f
        self.history_dist_mean[g] = dist_mean(population_u)
        self.generation = g + 1
        if self.problem.progress is not None:
            self.problem.progress(self.generation, self.nfev, self.best_f)

    def result(self, details: str) -> OptimResult:
        """Build the result; raise :class:`OptimError` if no evaluation was finite."""
        if self.best_u is None:
            raise all_nan_error(self.method, self.nfev)
        x = self.to_x(self.best_u[None, :])[0]
        return OptimResult(
            method=self.method,
            x=x,
            fun=self.best_f,
            nfev=self.nfev,
            wall_s=time.perf_counter() - self.t_start,
            history_fmin=self.history_fmin[: self.generation].copy(),
            history_dist_mean=self.history_dist_mean[: self.generation].copy(),
            n_nan=self.n_nan,
            message=f"{self.method}: {details}; {self.nfev} evaluations{nan_note(self.n_nan, self.nfev)}",
            names=list(self.problem.names),
        )


class CallLog:
    """Per-call records for sequential methods (bo, dt, lm): cost, best-so-far, spread.

    ``dist_mean`` after call n is the mean pairwise distance (bound-normalised, eq. 2-18) of
    the n points evaluated so far, updated incrementally (O(n) per call).
    """

    def __init__(self, problem: Problem, method: str, track_spread: bool = True) -> None:
        self.problem = problem
        self.method = method
        self.span = problem.upper - problem.lower
        self.track_spread = track_spread
        self.points_u: list[np.ndarray] = []
        self.fmin: list[float] = []
        self.spread: list[float] = []
        self._pair_sum = 0.0
        self.nfev = 0
        self.n_nan = 0
        self.best_f = np.inf
        self.best_x: np.ndarray | None = None
        self.worst_finite = -np.inf

    def add(self, x: np.ndarray, cost: float) -> float:
        """Log one evaluation at ``x`` (k,); returns the cost with NaN/inf -> +inf."""
        self.nfev += 1
        if not np.isfinite(cost):
            self.n_nan += 1
            cost = np.inf
        else:
            self.worst_finite = max(self.worst_finite, cost)
        if cost < self.best_f:
            self.best_f = float(cost)
            self.best_x = np.array(x, dtype=float)
        self.fmin.append(self.best_f)
        if self.track_spread:
            u = (np.asarray(x, dtype=float) - self.problem.lower) / self.span
            if self.points_u:
                self._pair_sum += float(np.sqrt(((np.asarray(self.points_u) - u) ** 2).sum(axis=1)).sum())
            self.points_u.append(u)
            n = len(self.points_u)
            self.spread.append(self._pair_sum / (n * (n - 1) / 2) if n > 1 else float("nan"))
        if self.problem.progress is not None:
            self.problem.progress(0, self.nfev, self.best_f)
        return cost
