"""Sequential optimisation with decision trees (thesis §3.3.2; scikit-optimize ``forest_minimize``).

Thesis settings (§6.4.2): extra-trees regressor ("ET"), 10 initial points, 100 cost
calls, acquisition PI (probability of improvement; xi = 0.01 by default). One (1, k)
``batch_cost`` call per point. Histories as for ``bo``: one entry per call.
The acquisition is maximised over ``n_points`` = 2 000 random candidates per call
(scikit-optimize's default, 10 000; the thesis does not give this setting).
The ``ET`` surrogate is scikit-optimize's (100 extremely randomised trees, min_samples_leaf 3,
std(y|x) = E[Var(y|tree)] + Var(E[y|tree])) built without scikit-learn's per-tree overhead
(a clone, parameter validation and input checks per tree and per prediction, ~4 ms a tree on
a 2-core machine): :class:`ExtraTreesSurrogate` fits scikit-learn's own trees with the checks off,
which takes 100 calls on the EMPS cost from 9–17 s to a few seconds.
(scikit-optimize's ``gbrt_minimize`` is broken with current scikit-learn and not used.)
"""

from __future__ import annotations

import functools

import numpy as np

from frictionid_core.errors import OptimError
from frictionid_core.optim._engine import check_count, check_fraction
from frictionid_core.optim._skopt import run_skopt
from frictionid_core.optim.problem import OptimResult, Problem

ESTIMATORS = ("ET", "RF")
ACQUISITIONS = ("PI", "EI", "LCB")


def solve(
    problem: Problem,
    rng: np.random.Generator,
    *,
    calls: int = 100,
    n_initial_points: int = 10,
    base_estimator: str = "ET",
    acq_func: str = "PI",
    xi: float = 0.01,
    n_points: int = 2000,
) -> OptimResult:
    """Minimise ``problem`` with ``skopt.forest_minimize``.

    Args:
        calls: total cost evaluations (initial points included).
        n_initial_points: random points evaluated before the trees guide the search.
        base_estimator: "ET" (extra trees, thesis) or "RF" (random forest).
        acq_func: scikit-optimize acquisition ("PI", "EI", "LCB").
        xi: minimum improvement for PI/EI.
        n_points: random candidates on which the acquisition is evaluated per call.
    """
    from skopt import forest_minimize  # heavy import (scikit-learn): only when used

    if base_estimator not in ESTIMATORS:
        raise OptimError(f"dt: base_estimator must be one of {ESTIMATORS}, got {base_estimator!r}")
    if acq_func not in ACQUISITIONS:
        raise OptimError(f"dt: acq_func must be one of {ACQUISITIONS}, got {acq_func!r}")
    xi = check_fraction(xi, "xi", "dt", 0.0, 1e6)
    n_points = check_count(n_points, "n_points", "dt")
    estimator = (ExtraTreesSurrogate(random_state=int(rng.integers(0, 2**31 - 1))) if base_estimator == "ET"
                 else base_estimator)
    return run_skopt(
        problem, rng, "dt", forest_minimize, calls, n_initial_points,
        f"forest_minimize {base_estimator}, acquisition {acq_func}",
        base_estimator=estimator, acq_func=acq_func, xi=xi, n_points=n_points,
    )


def ExtraTreesSurrogate(**params):
    """scikit-optimize's ``ET`` regressor (fit, predict(X, return_std)) without the per-tree overhead."""
    return _surrogate_class()(**params)


@functools.cache
def _surrogate_class():
    from sklearn.base import BaseEstimator, RegressorMixin
    from sklearn.tree import ExtraTreeRegressor

    class _ExtraTrees(RegressorMixin, BaseEstimator):
        """Extremely randomised trees as scikit-optimize's ``ET`` (n_estimators 100, min_samples_leaf 3,
        every feature a split candidate, no bootstrap), each tree fitted and applied with
        ``check_input=False`` on float32 input as a scikit-learn forest does internally."""

        def __init__(self, n_estimators: int = 100, min_samples_leaf: int = 3, random_state: int | None = None):
            self.n_estimators = n_estimators
            self.min_samples_leaf = min_samples_leaf
            self.random_state = random_state

        def fit(self, X, y):
            X = np.ascontiguousarray(X, dtype=np.float32)
            y = np.ascontiguousarray(y, dtype=float)
            draws = np.random.RandomState(self.random_state)  # one stream for every tree (no reseeding per tree)
            self.trees_ = [ExtraTreeRegressor(min_samples_leaf=self.min_samples_leaf, max_features=1.0,
                                              random_state=draws).fit(X, y, check_input=False)
                           for _ in range(self.n_estimators)]
            return self

        def predict(self, X, return_std: bool = False):
            X = np.ascontiguousarray(X, dtype=np.float32)
            leaves = [t.apply(X, check_input=False) for t in self.trees_]
            means = np.array([t.tree_.value[leaf, 0, 0] for t, leaf in zip(self.trees_, leaves)])
            mean = means.mean(axis=0)
            if not return_std:
                return mean
            within = np.array([t.tree_.impurity[leaf] for t, leaf in zip(self.trees_, leaves)])
            var = np.mean(within + means**2, axis=0) - mean**2
            return mean, np.sqrt(np.maximum(var, 0.0))

    return _ExtraTrees
