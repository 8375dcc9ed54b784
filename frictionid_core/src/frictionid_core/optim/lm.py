"""Bounded nonlinear least squares (the thesis used MATLAB ``lsqnonlin``).

With ``problem.residuals``: ``scipy.optimize.least_squares`` (trust-region reflective,
'trf', which handles bounds; Jacobian by 2-point finite differences, all k perturbed points
in one ``problem.batch_residuals`` call when the problem has it) minimising sum(r^2), each
variable scaled by its Jacobian column norm (``x_scale="jac"``: vs of ~0.01 rad/s and δ of ~2
take steps of their own size; it cuts the Stribeck variable-projection steps by ~40 %).
Without residuals: ``scipy.optimize.minimize`` L-BFGS-B on ``batch_cost``
evaluated one (1, k) row at a time.

Start: the ``x0`` option, else ``problem.x0``, else the middle of the box.
``history_fmin`` has one entry per residual/cost evaluation (finite-difference Jacobian
evaluations included): best sum(r^2) so far (residual mode) or best cost so far
(fallback). ``history_dist_mean`` is empty (no population). ``fun`` is ``batch_cost`` at
the solution (one extra evaluation, counted in nfev), so it compares with other methods.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.optimize import least_squares, minimize

from frictionid_core.errors import OptimError
from frictionid_core.optim._engine import CallLog, all_nan_error, check_count, nan_note
from frictionid_core.optim.problem import OptimResult, Problem
from frictionid_core.parallel import single_threaded_libraries


def _unusable(D: np.ndarray) -> np.ndarray:
    """(k,) True for the rows of slopes ``D`` (k, n) that trf cannot use: not finite, or so large that their
    squares overflow (its scaling and SVD square them; call it with overflow warnings off)."""
    return ~np.isfinite(np.einsum("ij,ij->i", D, D))


def solve(
    problem: Problem,
    rng: np.random.Generator,
    *,
    calls: int | None = None,
    x0: np.ndarray | None = None,
    ftol: float = 1e-10,
    xtol: float = 1e-10,
    gtol: float = 1e-10,
) -> OptimResult:
    """Minimise ``problem`` locally from ``x0``.

    Args:
        rng: unused (deterministic method); accepted for the common interface.
        calls: evaluation budget: scipy's ``max_nfev`` (trf; finite-difference Jacobian
            evaluations not counted, scipy default 100 k) or ``maxfun`` (L-BFGS-B; default 15000).
        x0: start point (k,); overrides ``problem.x0``.
        ftol, xtol, gtol: scipy termination tolerances.
    """
    t_start = time.perf_counter()
    if calls is not None:
        calls = check_count(calls, "calls", "lm")
    lower, upper = problem.lower, problem.upper
    if x0 is None:
        x0 = problem.x0 if problem.x0 is not None else 0.5 * (lower + upper)
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (problem.k,) or not np.all(np.isfinite(x0)):
        raise OptimError(f"lm: start point x0 must be {problem.k} finite values, got {x0!r}")
    x0 = np.clip(x0, lower, upper)
    log = CallLog(problem, "lm", track_spread=False)

    if problem.residuals is not None:
        n_resid: list[int] = []

        last: dict = {}

        def residuals(x: np.ndarray) -> np.ndarray:
            r = np.asarray(problem.residuals(x), dtype=float).ravel()
            last["x"], last["r"] = x.copy(), r
            n_resid.append(r.size)
            with np.errstate(over="ignore", invalid="ignore"):  # a diverging model: an infinite cost
                log.add(x, float(r @ r) if r.size else 0.0)
            return r

        first = residuals(x0)
        if not np.all(np.isfinite(first)):
            raise OptimError(
                f"lm: residuals are NaN/inf at the start point x0 = {x0.tolist()} "
                f"({int(np.count_nonzero(~np.isfinite(first)))} of {first.size} values)"
            )
        jac = "2-point"
        if problem.batch_residuals is not None:

            def counted(X: np.ndarray) -> np.ndarray:
                R = np.asarray(problem.batch_residuals(X), dtype=float)
                with np.errstate(over="ignore", invalid="ignore"):
                    for xi, ri in zip(X, R):  # every evaluation is counted, as in the 2-point mode
                        log.add(xi, float(ri @ ri))
                return R

            def jac(x: np.ndarray) -> np.ndarray:
                # scipy's 2-point step, turned inwards at an upper bound
                h = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(x))
                h = np.where(x + h > upper, -h, h)
                same = "x" in last and np.array_equal(last["x"], x)  # trf evaluates fun(x) before jac(x)
                r0 = last["r"] if same else np.asarray(problem.residuals(x), dtype=float).ravel()
                with np.errstate(over="ignore", invalid="ignore"):
                    D = (counted(x[None, :] + np.diag(h)) - r0[None, :]) / h[:, None]
                    broken = _unusable(D)
                    if broken.any():  # a step into a region the model cannot be evaluated in (a state that diverges)
                        D[broken] = (r0[None, :] - counted(x[None, :] - np.diag(h)[broken])) / h[broken, None]
                        D[_unusable(D)] = 0.0  # the other side neither: no slope there
                return D.T

        with single_threaded_libraries():  # SVDs of an (n, k) Jacobian: threads stall on a busy machine
            sol = least_squares(
                residuals, x0, bounds=(lower, upper), method="trf", max_nfev=calls,
                ftol=ftol, xtol=xtol, gtol=gtol, jac=jac, x_scale="jac",
            )
        x = np.clip(sol.x, lower, upper)
        stage = f"least_squares trf ({sol.nfev} steps, {sol.njev} Jacobians): {sol.message}"
    else:

        def cost(x: np.ndarray) -> float:
            c = float(np.asarray(problem.batch_cost(np.asarray(x, dtype=float)[None, :]), dtype=float).ravel()[0])
            return log.add(x, c)

        sol = minimize(
            cost, x0, method="L-BFGS-B", bounds=list(zip(lower, upper)),
            options={"maxfun": calls if calls is not None else 15000, "ftol": ftol, "gtol": gtol},
        )
        x = np.clip(sol.x, lower, upper)
        stage = f"no residuals, L-BFGS-B on batch_cost ({sol.nit} iterations): {sol.message}"

    if log.best_x is None:
        raise all_nan_error("lm", log.nfev)
    fun = float(np.asarray(problem.batch_cost(x[None, :]), dtype=float).ravel()[0])
    nfev = log.nfev + 1
    n_nan = log.n_nan + (0 if np.isfinite(fun) else 1)
    if not np.isfinite(fun):
        fun = np.inf
    return OptimResult(
        method="lm",
        x=x,
        fun=fun,
        nfev=nfev,
        wall_s=time.perf_counter() - t_start,
        history_fmin=np.asarray(log.fmin, dtype=float),
        history_dist_mean=np.empty(0),
        n_nan=n_nan,
        message=f"lm: {stage}; {nfev} evaluations{nan_note(n_nan, nfev)}",
        names=list(problem.names),
    )
