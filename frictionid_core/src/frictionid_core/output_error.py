"""Output-error identification of the EMPS: minimise the simulated-position error directly.

The dissertation fits the inverse dynamic model (OSA torque) and only then simulates. Here the
closed-loop simulator (:mod:`frictionid_core.emps_simulation`) is inside the optimiser: the cost is
Σ (q_measured − q_simulated)², m², starting from (and bounded around) the IDM result.
"""

from __future__ import annotations

import time

import numpy as np

from frictionid_core.identification import Identification, identify
from frictionid_core.emps_simulation import EmpsSimulator, load_emps

# Search box around the IDM start: ±50 % of each value (shape parameters included).
SPAN = 0.5


def identify_output_error(source, *, friction: str = "coulomb", asymmetric: bool = False, solver: str = "lm",
                          seed: int = 0, clock: str = "true", substeps: int = 4, span: float = SPAN,
                          bounds: dict[str, tuple[float, float]] | None = None,
                          **solver_options) -> Identification:
    """Output-error identification of the EMPS from ``source`` (bag or MAT file).

    Args:
        friction, asymmetric: the friction model.
        solver: any method of :mod:`frictionid_core.optim` (``lm`` refines the IDM start;
            population methods search the box around it).
        clock: simulation clock (``true`` or ``benchmark``).
        substeps: RK4 steps per controller period inside the optimiser (4 agrees with 10 to ~1e-6).
        span: half-width of the search box around the IDM start, as a fraction of each value.
        bounds: IDM search-bound overrides (for the start).
    The result's metrics hold the simulated position relative error on ``source``
    (``position_relerr_pct``) and the IDM (OSA) metrics of the start under ``idm``.
    """
    from frictionid_core.io import load
    from frictionid_core.optim import minimize
    from frictionid_core.optim.problem import Problem

    t0 = time.perf_counter()
    series = load(source)
    nonlinear = friction != "coulomb"
    start = identify(series, system="emps", friction=friction, asymmetric=asymmetric,
                     solver="lm" if nonlinear else "ls", varpro=nonlinear, bounds=bounds)
    sim = EmpsSimulator(load_emps(source), friction, asymmetric, clock=clock, substeps=substeps)
    x0 = sim.as_array(start.params).ravel()
    half = np.maximum(span * np.abs(x0), 1e-6)
    lo, hi = x0 - half, x0 + half
    for i, name in enumerate(sim.names):  # positive-only quantities stay positive
        if name != "offset":
            lo[i] = max(lo[i], 1e-9)
    problem = Problem(list(sim.names), lo, hi, sim.position_cost, residuals=sim.position_residuals, x0=x0)
    res = minimize(problem, solver, seed=seed, **solver_options)
    best = res.x if res.fun <= sim.position_cost(x0[None])[0] else x0
    metrics = {"position_relerr_pct": float(sim.position_relerr(best[None])[0]), "clock": clock}
    extra = {"optimizer": res.to_dict(), "output_error": True, "idm": start.metrics,
             "idm_params": start.params}
    return Identification("emps", friction, asymmetric, solver, series.source, list(series.joints),
                          dict(zip(sim.names, map(float, best))), {}, metrics, time.perf_counter() - t0, extra)

