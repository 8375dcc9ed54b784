"""Global search followed by a local least-squares polish, reported as one result.

Stage 1 runs ``global_method`` (default ``de``); stage 2 runs ``lm`` from stage 1's best
point (least_squares trf on ``problem.residuals``, or L-BFGS-B on ``batch_cost`` without
residuals). The result holds the better of the two points (the polish cannot leave the
bounds and normally improves), nfev, n_nan and wall time summed over both stages, and
stage 1's histories (f_min / dist_mean per generation).
"""

from __future__ import annotations

import time

import numpy as np

from frictionid_core.errors import OptimError
from frictionid_core.optim import lm
from frictionid_core.optim.problem import OptimResult, Problem
from frictionid_core.optim.suite import METHODS, call_method


def solve(
    problem: Problem,
    rng: np.random.Generator,
    *,
    global_method: str = "de",
    pop: int | None = None,
    generations: int | None = None,
    calls: int | None = None,
    global_options: dict | None = None,
    polish_options: dict | None = None,
) -> OptimResult:
    """Minimise ``problem`` with ``global_method`` then polish with ``lm``.

    Args:
        global_method: any population or surrogate method id (not ``lm``/``hybrid``).
        pop, generations: budget of a population global stage (method defaults if None).
        calls: ``lm`` budget of the polish (scipy default if None).
        global_options: extra keyword options for the global method (e.g. {"F": 0.5}).
        polish_options: extra keyword options for ``lm`` (e.g. {"ftol": 1e-12}).
    """


    t_start = time.perf_counter()
    if global_method in ("lm", "hybrid") or global_method not in METHODS:
        allowed = sorted(m for m in METHODS if m not in ("lm", "hybrid"))
        raise OptimError(f"hybrid: global_method must be one of {allowed}, got {global_method!r}")
    first = call_method(
        problem, global_method, rng, pop=pop, generations=generations, calls=None, options=global_options or {}
    )
    polish_opts = dict(polish_options or {})
    if "x0" in polish_opts:
        raise OptimError("hybrid: polish_options cannot set x0 (the polish starts from the global best)")
    second = lm.solve(problem, rng, calls=calls, x0=first.x, **polish_opts)
    improved = second.fun <= first.fun
    best = second if improved else first
    nfev = first.nfev + second.nfev
    n_nan = first.n_nan + second.n_nan
    outcome = (
        f"polish improved {first.fun:.6g} -> {second.fun:.6g}"
        if improved
        else f"polish did not improve ({second.fun:.6g} > {first.fun:.6g}); kept the global point"
    )
    return OptimResult(
        method="hybrid",
        x=best.x.copy(),
        fun=float(best.fun),
        nfev=nfev,
        wall_s=time.perf_counter() - t_start,
        history_fmin=first.history_fmin,
        history_dist_mean=first.history_dist_mean,
        n_nan=n_nan,
        message=f"hybrid {global_method}+lm: stage 1 [{first.message}]; stage 2 [{second.message}]; {outcome}",
        names=list(problem.names),
    )
