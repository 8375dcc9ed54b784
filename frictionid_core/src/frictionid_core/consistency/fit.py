"""Physically consistent parameters of a robot fit: a convex program (docs/reference.md#consistent-parameters).

The unknowns are the *standard* parameters π (per body ``m, mx, my, mz, Ixx, Ixy, Iyy, Ixz,
Iyz, Izz`` about the joint frame origin, as Pinocchio's dynamic parameters, then one rotor
inertia per joint or motor) and the linear friction parameters (Fv, Fc, Fs, offset). The rigid
columns of the fit are the base regressor W_b, and W_b·A·π is the standard prediction
(β = A·π, :meth:`~frictionid_core.robots.base.BaseParameters.combination_matrix`), so the
program reuses the unconstrained fit's observation rows exactly:

    minimise  ‖y − X(θ)·c‖² / (2σ̂²) + W·Σ_k d(J_k, J_k⁰)        c = (A·π, friction levels)
    subject to J_k(π) ⪰ ε·max(1, m_k)·1 (4×4 pseudo-inertia, Wensing et al. 2017), Ia ≥ 0, Fv ≥ 0, Fc ≥ 0
               [Fs ≥ 0, Fs ≥ Fc with ``stribeck_order``]

X(θ): the design at the nonlinear friction shapes θ (vs, δ, v0) of the unconstrained solution;
σ̂²: its residual variance per row. d(J, J⁰) = −log det(J⁰⁻¹J) + tr(J⁰⁻¹J) − 4 is the log-det
(Bregman) divergence to the prior's pseudo-inertia (Lee, Wensing & Park 2020), convex in J;
without a prior W = :data:`TIE_BREAK` (a tie-break in the base map's null space).
Solved by cvxpy with Clarabel (after a QR of X, so the program has L rows, not R).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from frictionid_core.consistency.check import PSEUDO_INERTIA_BASIS, body_report, pseudo_inertia
from frictionid_core.consistency.prior import HOLD_WEIGHT, undetermined_directions
from frictionid_core.errors import FrictionIdError

# Smallest eigenvalue of each pseudo-inertia (kg·m²): strictly inside the cone, so the witness
# passes the consistency check (λ_min > 1e-9·max(1, m)) after the solver's round-off.
MARGIN = 2e-6
# Without a prior the data leave the base map's null space free (a link may take tonnes and
# another a negative share): this weight of the log-det divergence to the model picks, among the
# (near-)optimal solutions, the one nearest the model; against the data term (‖e‖²/2σ̂² over
# thousands of rows) it moves the fit by a negligible amount.
TIE_BREAK = 1e-2
SOLVER = "CLARABEL"
FRICTION_NONNEGATIVE = ("Fv", "Fc", "Fs")


@dataclass
class ConsistentFit:
    """The consistent solution.

    Attributes:
        x: full model parameter vector (k,): base parameters A·π, friction levels, the
            unconstrained nonlinear shapes.
        standard: standard parameters π (P,) in ``names`` order.
        names: standard parameter names.
        record: the JSON ``consistency`` block (feasible, per-link λ_min, solver, SDP wall time, …).
    """

    x: np.ndarray
    standard: np.ndarray
    names: list[str]
    record: dict


def _friction_kind(name: str) -> str:
    """``joint_1/Fc_pos`` → ``Fc``."""
    return name.rsplit("/", 1)[-1].removesuffix("_pos").removesuffix("_neg")


def consistent_fit(model, x0: np.ndarray, robot, *, prior: np.ndarray | None = None, prior_weight: float = 0.0,
                   stribeck_order: bool = False, margin: float = MARGIN, released=frozenset(),
                   data_scale: float = 1.0, hold_weight: float = HOLD_WEIGHT) -> ConsistentFit:
    """Consistent standard + friction parameters on the rows of ``model`` (an IdentificationModel
    of a robot system) with the nonlinear shapes of ``x0`` (its unconstrained solution, (k,));
    ``robot``: the system's :class:`~frictionid_core.systems.system.RobotInfo`; ``prior``:
    standard parameters whose pseudo-inertias the log-det term pulls toward with ``prior_weight``
    (default: the model's own); ``stribeck_order``: also Fs ≥ Fc per branch. A fixed parameter
    of the model keeps its value, a base parameter as A·π; one whose index is in ``released``
    (held only because the data do not resolve it) is left free when it is a base parameter:
    the prior's divergence (or the tie-break) decides it. The directions of the links the data do
    not determine (:func:`~frictionid_core.consistency.prior.undetermined_directions`, with
    ``hold_weight``; 0: none) are held at the prior's values; ``data_scale`` (≥ 1): the variance of
    the calibrated σ over the white one, by which the data term's σ̂² grows (residuals that are
    coloured or carry model error inform less than white ones)."""
    import cvxpy as cp

    rows = robot.rows or robot.model
    names = rows.parameter_names()
    A = robot.base.combination_matrix()
    r, P = A.shape
    nb = robot.model.model.njoints - 1
    nrot = P - 10 * nb
    lin = [model.names[i] for i in model.linear_index]
    if list(lin[:r]) != list(model.obs.rigid_names) or r != len(model.obs.rigid_names):
        raise FrictionIdError("consistent fit: the model's rigid columns are not the robot's base parameters")
    if prior_weight < 0 or not np.isfinite(prior_weight):
        raise FrictionIdError(f"prior weight must be finite and ≥ 0, got {prior_weight}")
    X = model.design() if model.is_linear else model.design(np.asarray(x0, dtype=float)[None])[0]
    y = model.obs.y
    if model.friction.is_dynamic:  # its state-dependent friction held at the unconstrained fit's
        y = y - model.state_part(x0)
    L = X.shape[1]
    Q, R = np.linalg.qr(X)
    b = Q.T @ y
    x_unc = np.asarray(x0, dtype=float)
    rss_unc = float(np.sum((y - X @ x_unc[model.linear_index]) ** 2))
    dof = max(int(np.count_nonzero(model.obs.used)) - L, 1)
    if not (np.isfinite(data_scale) and data_scale >= 1.0):
        raise FrictionIdError(f"consistent fit: data scale must be ≥ 1, got {data_scale}")
    s2 = max(rss_unc / dof, np.finfo(float).tiny) * data_scale
    # z = [π (P), friction and offset levels (L − r)]; c = M·z.
    pi0 = rows_parameters(robot) if prior is None else np.asarray(prior, dtype=float)
    floor = np.concatenate([np.tile([1.0, 0.1, 0.1, 0.1] + [0.01] * 6, nb), np.full(nrot, 0.01)])
    col = np.linalg.norm(R[:, r:], axis=0)
    D = np.concatenate([np.maximum(np.abs(pi0), floor), 1.0 / np.where(col > 0, col, 1.0)])  # z = D·u
    G = np.hstack([R[:, :r] @ A, R[:, r:]]) * D
    u = cp.Variable(P + L - r)
    z = cp.multiply(D, u)
    objective = cp.sum_squares(G @ u - b) / (2.0 * s2)
    cons = []
    Js = []
    for k in range(nb):
        J = cp.Variable((4, 4), symmetric=True)
        # λ_min ≥ ε·max(1, m): the consistency check's own test (relative for heavy links)
        cons += [J == sum(z[10 * k + i] * PSEUDO_INERTIA_BASIS[i] for i in range(10)), J >> margin * np.eye(4),
                 J - margin * J[3, 3] * np.eye(4) >> 0]
        Js.append(J)
    if nrot:
        cons.append(z[10 * nb : P] >= 0)
    held_rows = []
    for pos in range(r):
        i = model.linear_index[pos]
        if i in model.fixed_values and i not in released:
            cons.append(A[pos] @ z[:P] == model.fixed_values[i])
            held_rows.append(A[pos] * D[:P])
    held = np.zeros((0, 10 * nb))
    if hold_weight > 0:  # the links' directions the data do not determine: at the prior's values
        information = G.T @ G / s2
        if held_rows:  # what a fixed value holds is determined (by the user or the model)
            rows_u = np.hstack([np.array(held_rows), np.zeros((len(held_rows), L - r))])
            information += (1e6 * max(float(np.max(np.diag(information))), 1.0)) * rows_u.T @ rows_u
        held, with_prior = undetermined_directions(information, pi0, D, nb, hold_weight)
        if held.size:
            index = np.array([10 * k + i for k in with_prior for i in range(10)], dtype=int)
            objective = objective + 0.5 * hold_weight * cp.sum_squares(held @ (u[index] - pi0[index] / D[index]))
    used_prior = []
    weight = prior_weight if prior_weight > 0 else TIE_BREAK
    if weight > 0:
        for k, J in enumerate(Js):
            J0 = pseudo_inertia(pi0[10 * k : 10 * k + 10])
            if np.linalg.eigvalsh(J0)[0] <= margin:
                continue  # no density-realisable prior body (a massless link): no pull
            objective = objective + weight * (-cp.log_det(J) + cp.trace(np.linalg.inv(J0) @ J))
            used_prior.append(k)
    by_kind: dict[tuple[str, str], int] = {}
    for pos in range(r, L):
        name = lin[pos]
        kind = _friction_kind(name)
        i = model.linear_index[pos]
        if i in model.fixed_values:
            cons.append(z[P + pos - r] == model.fixed_values[i])
            continue
        lo, hi = model.linear_box[0][pos], model.linear_box[1][pos]
        if np.isfinite(lo):
            cons.append(z[P + pos - r] >= lo)
        if np.isfinite(hi):
            cons.append(z[P + pos - r] <= hi)
        if kind in FRICTION_NONNEGATIVE:
            cons.append(z[P + pos - r] >= 0)
        by_kind[(name.replace(kind, "{}", 1), kind)] = P + pos - r
    if stribeck_order:
        for (stem, kind), idx in by_kind.items():
            if kind == "Fs" and (stem, "Fc") in by_kind:
                cons.append(z[idx] >= z[by_kind[(stem, "Fc")]])
    problem = cp.Problem(cp.Minimize(objective), cons)
    wall = solve_program(problem, u, "consistent fit")
    zv = D * u.value
    pi = zv[:P]
    c = np.concatenate([A @ pi, zv[P:]])
    x = x_unc.copy()
    x[model.linear_index] = c
    rss = float(np.sum((y - X @ c) ** 2))
    links = {}
    for k in range(nb):
        body = body_report(pi[10 * k : 10 * k + 10])  # the consistency check's own verdict
        links[robot.model.joints[k]] = {"pseudo_inertia_min_eig": body["pseudo_inertia_min_eig"],
                                        "consistent": body["consistent"]}
    rotor_ok = bool(np.all(pi[10 * nb :] >= -1e-12))
    record = {
        "feasible": bool(all(v["consistent"] for v in links.values()) and rotor_ok),
        "links": links,
        "solver": f"cvxpy {cp.__version__} + {SOLVER}",
        "status": problem.status,
        "sdp_wall_s": wall,
        "prior": "none" if prior_weight == 0 else ("model" if prior is None else "given"),
        "prior_weight": float(prior_weight),
        "tie_break_weight": 0.0 if prior_weight > 0 else TIE_BREAK,
        "prior_links": [robot.model.joints[k] for k in used_prior],
        "held_directions": int(held.shape[0]),
        "hold_weight": float(hold_weight),
        "data_scale": float(data_scale),
        "stribeck_order": bool(stribeck_order),
        "margin": margin,
        "sigma2": s2,
        "cost_increase_pct": 100.0 * (rss - rss_unc) / max(rss_unc, np.finfo(float).tiny),
        "constraints": ["pseudo-inertia J_k ⪰ ε·max(1, m_k)·1 per link (ε = margin)", "rotor inertia Ia ≥ 0",
                        "Fv ≥ 0, Fc ≥ 0, Fs ≥ 0" + (", Fs ≥ Fc" if stribeck_order else "")],
    }
    return ConsistentFit(x, pi, names, record)


def links_within_sigma(robot, beta: np.ndarray, sigma: np.ndarray, *, margin: float = MARGIN,
                       hold_weight: float = HOLD_WEIGHT) -> tuple[np.ndarray, float]:
    """(consistent standard parameters π (P,) of ``robot`` (a RobotInfo) whose base parameters A·π lie
    as near identified ones ``beta`` (r,) as their σ ``sigma`` (r,; NaN or inf: not determined, 0:
    held) say, the largest |A·π − β|/σ): minimise ½‖(A·π − β)/σ‖² with the links' directions these σ
    do not determine held at the model's (:func:`~frictionid_core.consistency.prior.undetermined_directions`),
    each link's pseudo-inertia ⪰ ε·max(1, m), rotor inertias ≥ 0. What ``export`` builds links from
    when a result without ``--consistent`` has no consistent or plausible exact witness."""
    import cvxpy as cp

    A = robot.base.combination_matrix()
    r, P = A.shape
    nb = robot.model.model.njoints - 1
    nrot = P - 10 * nb
    pi0 = rows_parameters(robot)
    floor = np.concatenate([np.tile([1.0, 0.1, 0.1, 0.1] + [0.01] * 6, nb), np.full(nrot, 0.01)])
    D = np.maximum(np.abs(pi0), floor)
    beta = np.asarray(beta, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    known = np.isfinite(sigma) & np.isfinite(beta)
    tiny = 1e-9 * np.maximum(np.abs(beta), 1.0)
    weight = np.where(known, 1.0 / np.maximum(np.where(known, sigma, 1.0), tiny), 0.0)
    G = (weight[:, None] * A) * D
    target = np.where(known, weight * beta, 0.0)
    u = cp.Variable(P)
    z = cp.multiply(D, u)
    objective = 0.5 * cp.sum_squares(G @ u - target)
    cons = []
    for k in range(nb):
        J = cp.Variable((4, 4), symmetric=True)
        cons += [J == sum(z[10 * k + i] * PSEUDO_INERTIA_BASIS[i] for i in range(10)), J >> margin * np.eye(4),
                 J - margin * J[3, 3] * np.eye(4) >> 0]
        J0 = pseudo_inertia(pi0[10 * k : 10 * k + 10])
        if np.linalg.eigvalsh(J0)[0] > margin:
            objective = objective + TIE_BREAK * (-cp.log_det(J) + cp.trace(np.linalg.inv(J0) @ J))
    if nrot:
        cons.append(z[10 * nb :] >= 0)
    held, with_prior = undetermined_directions(G.T @ G, pi0, D, nb, hold_weight)
    if held.size:
        index = np.array([10 * k + i for k in with_prior for i in range(10)], dtype=int)
        objective = objective + 0.5 * hold_weight * cp.sum_squares(held @ (u[index] - pi0[index] / D[index]))
    solve_program(cp.Problem(cp.Minimize(objective), cons), u, "links within the base parameters' σ")
    pi = D * u.value
    return pi, float(np.max(np.abs(weight * (A @ pi - np.where(known, beta, 0.0))), initial=0.0))


def solve_program(problem, variable, what: str) -> float:
    """Solve the cvxpy ``problem`` with :data:`SOLVER`; its wall time (s). FrictionIdError naming
    ``what`` when the solver fails or ends without an optimal ``variable``."""
    import cvxpy as cp

    t0 = time.perf_counter()
    try:
        problem.solve(solver=SOLVER)
    except cp.error.SolverError as exc:
        raise FrictionIdError(f"{what}: {SOLVER} failed ({exc})") from None
    if problem.status not in ("optimal", "optimal_inaccurate") or variable.value is None:
        raise FrictionIdError(f"{what}: {SOLVER} ended '{problem.status}'")
    return time.perf_counter() - t0


def rows_parameters(robot) -> np.ndarray:
    """The model's standard parameters in the order of the fit rows' regressor (robot info)."""
    return (robot.rows or robot.model).parameters()
