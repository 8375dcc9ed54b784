"""Output-error identification of the EMPS: minimise the simulated-position error directly.

The dissertation fits the inverse dynamic model (OSA torque) and only then simulates. Here the
closed-loop simulator (:mod:`frictionid_core.emps.simulation`) is inside the optimiser: the cost is
Σ (q_measured − q_simulated)², m², starting from (and bounded around) the IDM result.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from frictionid_core.emps.simulation import EmpsSimulator, load_emps
from frictionid_core.errors import FrictionIdError
from frictionid_core.identification import IdentifyRequest, IdentifyResult, SolverOptions, identify

# Search box around the IDM start: ±50 % of each value (shape parameters included).
SPAN = 0.5


def identify_output_error(source, request: IdentifyRequest, *, clock: str = "true", substeps: int = 4,
                          span: float = SPAN) -> IdentifyResult:
    """Output-error identification of the EMPS from ``source`` (bag or MAT file) by ``request``:
    its friction model, its solver (any method of :mod:`frictionid_core.optim`: ``lm`` refines
    the IDM start, population methods search the box around it; ``ls`` stands for ``lm``) and
    its bounds (of the IDM start). System ``emps`` only, without joints, joint map, drive,
    window, fixed values, pre-processing or consistency.

    ``clock``: simulation clock (``true`` or ``benchmark``); ``substeps``: RK4 steps per
    controller period inside the optimiser (4 agrees with 10 to ~1e-6); ``span``: half-width of
    the search box around the IDM start, as a fraction of each value.
    The result's metrics hold the simulated position relative error on ``source``
    (``position_relerr_pct``) and the IDM (OSA) metrics of the start under ``idm``.
    """
    from frictionid_core.io import load
    from frictionid_core.optim import Problem, minimize

    _check(request)
    t0 = time.perf_counter()
    solver = request.solver if request.solver.method != "ls" else replace(request.solver, method="lm")
    friction, asymmetric = request.friction, request.asymmetric
    series = load(source)
    nonlinear = friction != "coulomb"
    start = identify(series, IdentifyRequest(friction=friction, asymmetric=asymmetric, bounds=request.bounds,
                                             solver=SolverOptions("lm" if nonlinear else "ls", varpro=nonlinear)))
    sim = EmpsSimulator(load_emps(source), friction, asymmetric, clock=clock, substeps=substeps)
    x0 = sim.as_array(start.params).ravel()
    half = np.maximum(span * np.abs(x0), 1e-6)
    lo, hi = x0 - half, x0 + half
    for i, name in enumerate(sim.names):  # positive-only quantities stay positive
        if name != "offset":
            lo[i] = max(lo[i], 1e-9)
    problem = Problem(list(sim.names), lo, hi, sim.position_cost, residuals=sim.position_residuals, x0=x0)
    res = minimize(problem, solver.method, seed=solver.seed, pop=solver.pop, generations=solver.generations,
                   calls=solver.calls, **solver.options)
    best = res.x if res.fun <= sim.position_cost(x0[None])[0] else x0
    metrics = {"position_relerr_pct": float(sim.position_relerr(best[None])[0]), "clock": clock}
    return IdentifyResult("emps", friction, asymmetric, solver.method, series.source, list(series.joints),
                          dict(zip(sim.names, map(float, best))), {}, metrics, time.perf_counter() - t0,
                          bounds=dict(request.bounds), optimizer=res.to_dict(), output_error=True, idm=start.metrics,
                          idm_params=start.params, request=request)


def _check(request: IdentifyRequest) -> None:
    """FrictionIdError naming what an output-error identification cannot take."""
    if request.system != "emps":
        raise FrictionIdError(f"--output-error needs the EMPS closed-loop model; got system '{request.system}'")
    default = IdentifyRequest()
    unsupported = [name for name in ("joints", "joint_map", "drive", "window", "fixed", "preprocessing", "consistent")
                   if getattr(request, name) != getattr(default, name)]
    if unsupported:
        raise FrictionIdError(f"--output-error takes one EMPS source without {', '.join(unsupported)}")
