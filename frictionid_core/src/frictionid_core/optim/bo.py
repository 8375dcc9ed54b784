"""Bayesian optimisation with a Gaussian process (thesis §3.3.1; scikit-optimize ``gp_minimize``).

Thesis settings (§6.4.2): 10 initial points, 100 cost calls, acquisition LCB (lower
confidence bound, mu - kappa * sigma, kappa = 1.96 by default). One (1, k) ``batch_cost``
call per point. Histories have one entry per call: best cost so far, and the mean pairwise
bound-normalised distance of all points evaluated so far (NaN after the first call).
Each call's GP hyper-parameter fit starts from the previous call's optimum (:class:`WarmStartFit`).
"""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import OptimError
from frictionid_core.optim._engine import check_fraction
from frictionid_core.optim._skopt import run_skopt
from frictionid_core.optim.problem import OptimResult, Problem

ACQUISITIONS = ("LCB", "EI", "PI", "gp_hedge")


def solve(
    problem: Problem,
    rng: np.random.Generator,
    *,
    calls: int = 100,
    n_initial_points: int = 10,
    acq_func: str = "LCB",
    kappa: float = 1.96,
    acq_optimizer: str = "sampling",
    n_points: int = 2000,
    gp_restarts: int = 0,
) -> OptimResult:
    """Minimise ``problem`` with ``skopt.gp_minimize``.

    Args:
        calls: total cost evaluations (initial points included).
        n_initial_points: random points evaluated before the GP guides the search.
        acq_func: scikit-optimize acquisition ("LCB", "EI", "PI", "gp_hedge").
        kappa: LCB exploration weight.
        acq_optimizer: how the acquisition is minimised: "sampling" (best of ``n_points``
            random points; default, ~10× faster) or "lbfgs" (scikit-optimize's default, with
            restarts; ~1 s per call on 9 parameters here).
        n_points: acquisition samples per call with "sampling".
        gp_restarts: extra random restarts of the GP hyper-parameter fit per call
            (scikit-optimize's default 2 triples the dominant cost: the marginal-likelihood fit).
    """
    from skopt import gp_minimize  # heavy import (scikit-learn): only when used
    from skopt.learning import GaussianProcessRegressor
    from skopt.learning.gaussian_process.kernels import ConstantKernel, Matern

    if acq_func not in ACQUISITIONS:
        raise OptimError(f"bo: acq_func must be one of {ACQUISITIONS}, got {acq_func!r}")
    kappa = check_fraction(kappa, "kappa", "bo", 0.0, 1e6)
    return run_skopt(
        problem, rng, "bo", gp_minimize, calls, n_initial_points,
        f"gp_minimize, acquisition {acq_func}, {acq_optimizer}", acq_func=acq_func, kappa=kappa,
        acq_optimizer=acq_optimizer, n_points=n_points,
        base_estimator=GaussianProcessRegressor(
            kernel=ConstantKernel(1.0, (0.01, 1000.0)) * Matern(length_scale=np.ones(problem.k),
                                                               length_scale_bounds=[(0.01, 100)] * problem.k, nu=2.5),
            normalize_y=True, noise="gaussian", n_restarts_optimizer=gp_restarts, optimizer=WarmStartFit(),
            random_state=int(rng.integers(0, 2**31 - 1))),
    )


class WarmStartFit:
    """The GP hyper-parameter fit (L-BFGS-B on the log marginal likelihood, scikit-learn's own
    call) started from the previous call's optimum instead of the kernel's initial values: one
    more point moves the optimum little, so a fit takes a few evaluations instead of ~23 (the
    fits dominate bo's time). scikit-optimize clones the surrogate before every fit; the clones
    share this object (``__deepcopy__``), so it remembers across the calls of one run."""

    def __init__(self) -> None:
        self.theta: np.ndarray | None = None

    def __deepcopy__(self, memo) -> WarmStartFit:
        return self

    def __call__(self, objective, initial_theta: np.ndarray, bounds: np.ndarray) -> tuple[np.ndarray, float]:
        from scipy.optimize import minimize

        start = initial_theta if self.theta is None or self.theta.shape != initial_theta.shape else self.theta
        res = minimize(objective, start, method="L-BFGS-B", jac=True, bounds=bounds)
        self.theta = res.x
        return res.x, float(res.fun)
