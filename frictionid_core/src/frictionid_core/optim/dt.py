"""Sequential optimisation with decision trees (thesis §3.3.2; scikit-optimize ``forest_minimize``).

Thesis settings (§6.4.2): extra-trees regressor ("ET"), 10 initial points, 100 cost
calls, acquisition PI (probability of improvement; xi = 0.01 by default). One (1, k)
``batch_cost`` call per point. Histories as for ``bo``: one entry per call. The 100 trees
are fitted and queried on every core (``n_jobs=-1``); each tree has its own seed, so the
result does not depend on the number of cores.
(scikit-optimize's ``gbrt_minimize`` is broken with current scikit-learn and not used.)
"""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import OptimError
from frictionid_core.optim._engine import check_fraction
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
    n_jobs: int = -1,
) -> OptimResult:
    """Minimise ``problem`` with ``skopt.forest_minimize``.

    Args:
        calls: total cost evaluations (initial points included).
        n_initial_points: random points evaluated before the trees guide the search.
        base_estimator: "ET" (extra trees, thesis) or "RF" (random forest).
        acq_func: scikit-optimize acquisition ("PI", "EI", "LCB").
        xi: minimum improvement for PI/EI.
        n_jobs: threads for fitting and querying the trees (-1: all cores).
    """
    from skopt import forest_minimize  # heavy import (scikit-learn): only when used

    if base_estimator not in ESTIMATORS:
        raise OptimError(f"dt: base_estimator must be one of {ESTIMATORS}, got {base_estimator!r}")
    if acq_func not in ACQUISITIONS:
        raise OptimError(f"dt: acq_func must be one of {ACQUISITIONS}, got {acq_func!r}")
    xi = check_fraction(xi, "xi", "dt", 0.0, 1e6)
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, int) or n_jobs == 0 or n_jobs < -1:
        raise OptimError(f"dt: n_jobs must be a positive whole number or -1 (all cores), got {n_jobs!r}")
    return run_skopt(
        problem, rng, "dt", forest_minimize, calls, n_initial_points,
        f"forest_minimize {base_estimator}, acquisition {acq_func}",
        base_estimator=base_estimator, acq_func=acq_func, xi=xi, n_jobs=n_jobs,
    )
