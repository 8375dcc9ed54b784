"""Shared driver for the scikit-optimize methods (bo: gp_minimize, dt: forest_minimize).

The surrogate is sequential: ``batch_cost`` is called once per point with a (1, k) array.
scikit-optimize needs finite values, so a NaN/inf cost is passed to it as the worst
finite cost seen so far (1e10 before any finite one) while the run's own records keep
+inf and count it in n_nan. The integer seed given to scikit-optimize is drawn from
``rng``, so the same seed reproduces the run.

The surrogates work on at most ``calls`` points: BLAS and OpenMP run single-threaded during
the run (see :mod:`frictionid_core.parallel`), and scikit-learn's per-call parameter
validation is off (the inputs are ours and finite).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable

import numpy as np

from frictionid_core.optim._engine import CallLog, all_nan_error, check_count, nan_note
from frictionid_core.optim.problem import OptimResult, Problem
from frictionid_core.parallel import single_threaded_libraries

PENALTY_BEFORE_FIRST_FINITE = 1e10


def run_skopt(
    problem: Problem,
    rng: np.random.Generator,
    method: str,
    minimizer: Callable,
    calls: int,
    n_initial_points: int,
    describe: str,
    **skopt_kwargs,
) -> OptimResult:
    """Run ``minimizer`` (gp_minimize or forest_minimize) and wrap the outcome."""
    t_start = time.perf_counter()
    calls = check_count(calls, "calls", method)
    n_initial_points = check_count(n_initial_points, "n_initial_points", method)
    note = ""
    if n_initial_points > calls:
        note = f" (n_initial_points {n_initial_points} reduced to the {calls} calls)"
        n_initial_points = calls
    log = CallLog(problem, method)

    def objective(point: list) -> float:
        x = np.clip(np.asarray(point, dtype=float), problem.lower, problem.upper)
        c = float(np.asarray(problem.batch_cost(x[None, :]), dtype=float).ravel()[0])
        c = log.add(x, c)
        if np.isfinite(c):
            return c
        return log.worst_finite if np.isfinite(log.worst_finite) else PENALTY_BEFORE_FIRST_FINITE

    dimensions = [(float(lo), float(hi)) for lo, hi in zip(problem.lower, problem.upper)]
    seed = int(rng.integers(0, 2**31 - 1))
    from sklearn import config_context

    with warnings.catch_warnings(), single_threaded_libraries(), config_context(assume_finite=True,
                                                                               skip_parameter_validation=True):
        warnings.filterwarnings("ignore", message="The objective has been evaluated at")
        minimizer(
            objective, dimensions, n_calls=calls, n_initial_points=n_initial_points,
            random_state=seed, x0=None if problem.x0 is None else [problem.x0.tolist()], **skopt_kwargs,
        )
    if log.best_x is None:
        raise all_nan_error(method, log.nfev)
    return OptimResult(
        method=method,
        x=np.clip(log.best_x, problem.lower, problem.upper),
        fun=log.best_f,
        nfev=log.nfev,
        wall_s=time.perf_counter() - t_start,
        history_fmin=np.asarray(log.fmin, dtype=float),
        history_dist_mean=np.asarray(log.spread, dtype=float),
        n_nan=log.n_nan,
        message=(
            f"{method}: {describe}, {n_initial_points} initial points{note}, {calls} calls; "
            f"{log.nfev} evaluations{nan_note(log.n_nan, log.nfev)}"
        ),
        names=list(problem.names),
    )
