"""An excitation within every limit of the robot (``frictionid excite``).

:func:`design_excitation` optimises a Fourier excitation (:class:`~.excitation.FourierTrajectory`,
ramped: it starts and ends at rest at its start pose) for the criterion of :mod:`.excitation` (the
condition number of the base-parameter and friction columns), under hard constraints on a sampled
trajectory, with ``margin`` m:

* position |q − centre| ≤ (1 − m)·half-range (a joint without limits: ±π), velocity |q̇|,
  acceleration |q̈| and effort |τ| ≤ (1 − m)·limit, τ = the model's inverse dynamics (rigid bodies
  and rotor inertias, Pinocchio) + the joint friction of a :class:`~.excitation_limits.JointFriction`;
* with a :class:`~.collision.CollisionModel`: every checked pair of bodies (and the floor) at least
  ``clearance`` apart.

Position, velocity and acceleration are linear in the variables (the coefficients and the start pose),
the effort and the distances are not: their gradients come from Pinocchio's RNEA derivatives and the
distances' witness points. SLSQP (scipy) minimises the criterion (tanh(q̇/0.05) for sign(q̇) so that it
is smooth; finite-difference gradient) over random feasible starts, on a grid of ``samples`` points per
period, with slightly tighter targets (:data:`SLACK`, :data:`CLEARANCE_SLACK`) for what falls between
samples. The result is then verified on a fine grid (``verify_rate``, 1 kHz); a violation adds its
times to the grid and the optimisation goes on, and what still violates after that is scaled toward
the start pose (all deviations by one factor) until the verification holds: a trajectory leaving a
limit is never returned.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.excitation.design import FourierTrajectory, criterion, observation_columns
from frictionid_core.excitation.limits import Limits, motion_ratios, robot_limits, verify, violation_text

SIGN_SPEED = 0.05  # rad/s (m/s): tanh(q̇/this) for sign(q̇) in the optimised criterion
SLACK = 0.01  # optimisation targets: ratios ≤ 1 − margin − SLACK
CLEARANCE_SLACK = 0.002  # m: the optimisation keeps pairs clearance + this apart
ACCEPT = SLACK / 2  # an iterate whose rows are all ≥ −ACCEPT is kept (then verified on the fine grid)
DISTANCE_SCALE = 0.05  # m: a distance constraint's unit (like a ratio of 1)
RAMP_MAX = 2.0  # s: default ramp min(RAMP_MAX, duration/4)
REPORT_SAMPLES = 200  # per period: the grid of the reported cond (that of the criterion before limits)
SCALE_STEPS = (0.97, 0.93, 0.87, 0.8, 0.7, 0.55, 0.4, 0.25, 0.1, 0.0)  # last resort: deviations × these


@dataclass
class Design:
    """A designed excitation: the trajectory, its criterion (initial and final: cond of the unit-norm
    columns over the whole trajectory), evaluations, and the verification report of :func:`verify`."""

    trajectory: FourierTrajectory
    cond: float
    cond_initial: float
    evaluations: int
    report: dict
    limits: Limits
    scaled: float = 1.0
    rounds: int = 0
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        traj = self.trajectory
        out = {"cond": self.cond, "cond_initial": self.cond_initial, "evaluations": self.evaluations,
               "joints": traj.joints, "harmonics": traj.harmonics, "wf": traj.wf, "period": traj.period,
               "duration": traj.duration, "ramp_s": traj.ramp, "margin": self.limits.margin,
               "max_ratio": self.report["max_ratio"], "worst": self.report["worst"],
               "start_pose": dict(zip(traj.joints, map(float, traj.start_pose))),
               "limits": self.limits.to_dict(traj.joints), "friction": self.limits.friction.to_dict(),
               "verified_at_hz": self.report["rate_hz"], "scaled": self.scaled}
        if "min_clearance_m" in self.report:
            out["min_clearance_m"] = self.report["min_clearance_m"]
            out["closest"] = self.report["closest"]
        return out


class _Problem:
    """The variables x = (coefficients (nm, 2L) row-major, start pose (nm,)) and the trajectory,
    criterion and constraint rows (≥ 0) they give on the grids."""

    def __init__(self, system, robot, limits, moving, q_hold, L, wf, duration, ramp, t_crit, collision):
        self.system, self.robot, self.limits, self.collision = system, robot, limits, collision
        self.moving = moving
        self.mi = np.array([robot.joints.index(j) for j in moving])
        self.nm, self.L, self.wf, self.duration, self.ramp = len(moving), L, wf, duration, ramp
        self.q_hold = q_hold
        self.n = self.nm * (2 * L + 1)
        self.t_crit = t_crit
        self.basis_crit = self.basis(t_crit)
        self.set_grid(t_crit)
        self.target = 1.0 - limits.margin - SLACK
        self.evals = 0
        self._costs = {}

    def basis(self, t: np.ndarray):
        from frictionid_core.excitation.design import ramp_window

        wl = self.wf * np.arange(1, self.L + 1)
        s, c = np.sin(wl * t[:, None]), np.cos(wl * t[:, None])
        P = np.hstack([s / wl, -c / wl]) - np.concatenate([np.zeros(self.L), -1.0 / wl])
        Pd = np.hstack([c, s])
        Pdd = np.hstack([-wl * s, wl * c])
        w, w1, w2 = ramp_window(t, self.duration, self.ramp)
        return w * P, w1 * P + w * Pd, w2 * P + 2 * w1 * Pd + w * Pdd

    def set_grid(self, t: np.ndarray) -> None:
        self.t_con = np.unique(t)
        self.basis_con = self.basis(self.t_con)
        self._cache = {}

    def split(self, x):
        return x[: self.nm * 2 * self.L].reshape(self.nm, 2 * self.L), x[self.nm * 2 * self.L :]

    def motion(self, x, basis):
        C, qs = self.split(x)
        Mq, Mv, Ma = basis
        n = Mq.shape[0]
        q = np.tile(self.q_hold, (n, 1))
        qd, qdd = np.zeros_like(q), np.zeros_like(q)
        q[:, self.mi] = qs + Mq @ C.T
        qd[:, self.mi] = Mv @ C.T
        qdd[:, self.mi] = Ma @ C.T
        return q, qd, qdd

    def trajectory(self, x) -> FourierTrajectory:
        C, qs = self.split(x)
        nv = self.robot.nv
        a, b = np.zeros((nv, self.L)), np.zeros((nv, self.L))
        a[self.mi], b[self.mi] = C[:, : self.L], C[:, self.L :]
        q0 = self.q_hold.copy()
        q0[self.mi] = qs + np.sum(C[:, self.L :] / (self.wf * np.arange(1, self.L + 1)), axis=1)
        return FourierTrajectory(list(self.robot.joints), q0, a, b, self.wf, self.duration, self.ramp)

    def cost(self, x, sign_speed: float = SIGN_SPEED) -> float:
        key = x.tobytes()
        if key in self._costs:
            return self._costs[key]
        self.evals += 1
        q, qd, qdd = self.motion(x, self.basis_crit)
        f = criterion(observation_columns(self.system, self.robot, self.t_crit, q, qd, qdd, self.moving, sign_speed))
        if len(self._costs) > 8:
            self._costs.clear()
        self._costs[key] = f
        return f

    def cost_gradient(self, x, h: float = 1e-4) -> np.ndarray:
        f0 = self.cost(x)
        g = np.empty_like(x)
        for i in range(x.size):
            xi = x.copy()
            xi[i] += h
            g[i] = (self.cost(xi) - f0) / h
        return g

    # ---- constraints: rows ≥ 0
    def _rows(self, x, gradient: bool):
        key = x.tobytes()
        hit = self._cache.get(key)
        if hit is not None and (hit[1] is not None or not gradient):
            return hit
        lim, mi = self.limits, self.mi
        q, qd, qdd = self.motion(x, self.basis_con)
        Mq, Mv, Ma = self.basis_con
        n, nm, L2 = q.shape[0], self.nm, 2 * self.L
        values, jacs = [], []

        def add(val, dval_dC, dval_dqs):  # val (n, k), dval_dC (n, k, nm, L2), dval_dqs (n, k, nm)
            for sign in (1.0, -1.0):
                values.append((self.target - sign * val).ravel())
                if gradient:
                    jacs.append(-sign * np.concatenate([dval_dC.reshape(n, -1, nm * L2), dval_dqs], axis=2)
                                .reshape(-1, self.n))

        eye = np.eye(nm)
        lin = [("position", (q[:, mi] - lim.centre[mi]) / lim.half[mi], Mq, 1.0 / lim.half[mi], True),
               ("velocity", qd[:, mi] / lim.velocity[mi], Mv, 1.0 / lim.velocity[mi], False),
               ("acceleration", qdd[:, mi] / lim.acceleration[mi], Ma, 1.0 / lim.acceleration[mi], False)]
        for _, val, M, scale, with_qs in lin:
            keep = scale > 0
            if not keep.any():
                continue
            dC = (scale[:, None, None] * eye[:, :, None])[None] * M[:, None, None, :] if gradient else None
            dqs = np.broadcast_to(scale[:, None] * eye * with_qs, (n, nm, nm)) if gradient else None
            add(val[:, keep], dC[:, keep] if gradient else None, dqs[:, keep] if gradient else None)
        limited = np.flatnonzero(np.isfinite(lim.effort))
        if limited.size:
            tau, dq, dv, da = self._effort(q, qd, qdd, gradient)
            val = tau[:, limited] / lim.effort[limited]
            dC = dqs = None
            if gradient:
                sel = lambda D: D[:, limited][:, :, mi] / lim.effort[limited][None, :, None]
                dC = (sel(dq)[..., None] * Mq[:, None, None, :] + sel(dv)[..., None] * Mv[:, None, None, :]
                      + sel(da)[..., None] * Ma[:, None, None, :])
                dqs = sel(dq)
            add(val, dC, dqs)
        if self.collision is not None:
            col = self.collision
            res = col.distances(q, gradient)
            d, G = res if gradient else (res, None)
            values.append(((d - col.clearance - CLEARANCE_SLACK) / DISTANCE_SCALE).ravel())
            if gradient:
                Gm = G[:, :, mi] / DISTANCE_SCALE
                jacs.append(np.concatenate([(Gm[..., None] * Mq[:, None, None, :]).reshape(n, -1, nm * L2), Gm],
                                           axis=2).reshape(-1, self.n))
        out = (np.concatenate(values), np.vstack(jacs) if gradient else None)
        if len(self._cache) > 8:
            self._cache.clear()
        self._cache[key] = out
        return out

    def _effort(self, q, qd, qdd, gradient):
        import pinocchio as pin

        robot, lim = self.robot, self.limits
        model, data = robot.model, robot.model.createData()
        n, nv = qd.shape
        tau = np.empty((n, nv))
        dq = dv = da = None
        if gradient:
            dq, dv, da = (np.empty((n, nv, nv)) for _ in range(3))
        for k in range(n):
            cfg = robot.configuration(q[k])
            if gradient:
                pin.computeRNEADerivatives(model, data, cfg, qd[k], qdd[k])
                tau[k] = data.tau
                dq[k], dv[k] = data.dtau_dq, data.dtau_dv
                da[k] = np.triu(data.M) + np.triu(data.M, 1).T
            else:
                tau[k] = pin.rnea(model, data, cfg, qd[k], qdd[k])
        tau += lim.friction.torque(qd)
        if gradient:
            dv += lim.friction.slope(qd)[:, :, None] * np.eye(nv)[None]
        return tau, dq, dv, da

    def constraints(self, x):
        return self._rows(x, False)[0]

    def constraints_jac(self, x):
        return self._rows(x, True)[1]

    def feasible(self, x, tol: float = 0.0) -> bool:
        return bool(np.all(self.constraints(x) >= -tol))


def design_excitation(system, robot, *, limits: Limits | None = None, moving: list[str] | None = None,
                      hold: dict[str, float] | None = None, harmonics: int = 5, period: float = 10.0,
                      duration: float = 20.0, ramp: float | None = None, evals: int = 1500, starts: int = 20,
                      seed: int = 0, samples: int = 200, collision=None, verify_rate: float = 1000.0,
                      rounds: int = 3) -> Design:
    """Optimise a ramped Fourier excitation for ``system`` within ``limits`` (default
    :func:`robot_limits`) and, with ``collision``, its clearance: see the module doc. ``samples``
    per period of the optimisation grid; ``evals`` criterion evaluations (random starts, then
    SLSQP's finite-difference gradients and steps); ``rounds`` of re-optimisation after a failed
    verification before scaling."""
    from frictionid_core.parallel import single_threaded_libraries

    with single_threaded_libraries():  # small matrices: BLAS threads only contend
        return _design(system, robot, limits or robot_limits(robot), moving, hold, harmonics, period, duration, ramp,
                       evals, starts, seed, samples, collision, verify_rate, rounds)


def _design(system, robot, limits, moving, hold, harmonics, period, duration, ramp, evals, starts, seed, samples,
            collision, verify_rate, rounds) -> Design:
    moving = list(robot.joints) if moving is None else list(moving)
    unknown = [j for j in moving + list(hold or {}) if j not in robot.joints]
    if unknown:
        raise InputError(f"joint(s) {unknown} not in {robot.name}; joints: {robot.joints}")
    if not moving:
        raise InputError("no joint to move")
    if harmonics < 1 or not period > 0 or not duration > 0:
        raise InputError("harmonics must be ≥ 1, period and duration > 0")
    ramp = min(RAMP_MAX, duration / 4.0) if ramp is None else float(ramp)
    if not 0 < ramp <= duration / 2:
        raise InputError(f"--ramp must be > 0 and at most half the duration ({duration / 2:g} s), got {ramp:g}")
    centre = np.clip(0.0, robot.lower, robot.upper)
    centre = np.where(np.isfinite(centre), centre, limits.centre)
    q_hold = np.array([(hold or {}).get(j, centre[k]) for k, j in enumerate(robot.joints)], dtype=float)
    bad = [j for k, j in enumerate(robot.joints) if not robot.lower[k] <= q_hold[k] <= robot.upper[k]]
    if bad:
        raise InputError(f"hold position of {bad} outside the position limits")
    band = 1.0 - limits.margin
    bad = [j for k, j in enumerate(robot.joints) if j not in moving
           and abs(q_hold[k] - limits.centre[k]) > band * limits.half[k]]
    if bad:
        raise InputError(f"hold position of {bad} within the --margin of its position limits (|q − centre| must "
                         f"be ≤ {band:g} of the half-range)")
    wf = 2.0 * np.pi / period
    n_crit = max(samples, int(round(samples * duration / period)))
    t_crit = np.linspace(0.0, duration, n_crit)
    prob = _Problem(system, robot, limits, moving, q_hold, harmonics, wf, duration, ramp, t_crit, collision)
    rng = np.random.default_rng(seed)
    qs = _start_pose(prob, q_hold[prob.mi].copy())
    lo_s = limits.centre[prob.mi] - prob.target * limits.half[prob.mi]
    hi_s = limits.centre[prob.mi] + prob.target * limits.half[prob.mi]
    # random shapes, each scaled into the constraints (per joint to the linear limits, then as a whole)
    best = None
    ls = np.tile(np.arange(1, harmonics + 1), 2)
    for k in range(max(1, starts)):
        C = rng.uniform(-1, 1, (prob.nm, 2 * harmonics))
        if k == 0:
            C = C / ls
        x = _scaled_start(prob, C.ravel(), qs)
        f = prob.cost(x)
        if best is None or f < best[0]:
            best = (f, x)
    x = x_start = best[1]
    t_rep = np.linspace(0.0, duration, max(REPORT_SAMPLES, int(round(REPORT_SAMPLES * duration / period))))

    def cond(x) -> float:  # over the whole trajectory, sign(q̇) as such
        return float(10 ** criterion(observation_columns(system, robot, t_rep, *prob.trajectory(x).evaluate(t_rep),
                                                         moving)))
    # a trust region on the coefficients: a harmonic alone at the velocity and acceleration limits, twice
    wl = wf * np.arange(1, harmonics + 1)
    reach = 2.0 * np.minimum(limits.velocity[prob.mi][:, None], limits.acceleration[prob.mi][:, None] / wl)
    bounds = [(-r, r) for r in np.tile(reach, 2).ravel()] + list(zip(lo_s, hi_s))
    report, scaled, done_rounds = None, 1.0, 0
    for done_rounds in range(rounds + 1):
        budget = evals - prob.evals if done_rounds == 0 else max(evals - prob.evals, 3 * (prob.n + 2))
        if budget >= prob.n + 2:  # at least one SLSQP step (a gradient); a refinement round gets three
            x = _slsqp(prob, x, bounds, budget)
        report = verify(robot, limits, prob.trajectory(x), verify_rate, collision)
        if report["ok"] or done_rounds == rounds:
            break
        times = np.concatenate([v[3] for v in report["violations"]])
        prob.set_grid(np.concatenate([prob.t_con, _spread(times, 40)]))
    notes = []
    if not report["ok"]:
        x, scaled, report = _scale_into_limits(prob, [x, x_start], verify_rate)
        notes.append(f"scaled by {scaled:.3g} toward its start pose to hold every limit on the fine grid")
    return Design(prob.trajectory(x), cond(x), cond(x_start), prob.evals, report, limits, float(scaled),
                  done_rounds, notes)


def _scale_into_limits(prob: _Problem, designs: list[np.ndarray], rate: float):
    """(x, factor, report) of the first of ``designs`` whose deviations from its start pose, scaled by
    the first of a falling series of factors (down to 0: at rest at the start pose), verify on the
    fine grid. The last design is the feasible start, whose start pose at rest holds every limit."""
    for x in designs:
        C, qs = prob.split(x)
        for factor in SCALE_STEPS:
            xs = np.concatenate([C.ravel() * factor, qs])
            report = verify(prob.robot, prob.limits, prob.trajectory(xs), rate, prob.collision)
            if report["ok"]:
                return xs, float(factor), report
    raise InputError("no excitation within the limits found: "  # pragma: no cover - see the docstring
                     + violation_text(report, prob.limits.margin))


def _slsqp(prob: _Problem, x: np.ndarray, bounds, budget: int) -> np.ndarray:
    """SLSQP from ``x`` for about ``budget`` criterion evaluations (restarted from the best point
    when it stops early): the best iterate (criterion) whose rows all hold within ACCEPT (inside the
    slack of the targets), else the last one."""
    from scipy.optimize import minimize

    best = [np.inf, None]

    def consider(xk):
        f, worst = prob.cost(xk), prob.constraints(xk).min()
        if worst >= -ACCEPT and f < best[0]:
            best[:] = [f, np.array(xk, copy=True)]

    consider(x)
    end = prob.evals + budget
    last = x
    while prob.evals <= end - (prob.n + 2):
        before = best[0]
        res = minimize(prob.cost, x, jac=prob.cost_gradient, method="SLSQP", bounds=bounds,
                       constraints=[{"type": "ineq", "fun": prob.constraints, "jac": prob.constraints_jac}],
                       options={"maxiter": max(1, (end - prob.evals) // (prob.n + 2)), "ftol": 1e-7},
                       callback=consider)
        consider(res.x)
        last = res.x
        if res.status == 9 or not best[0] < before - 1e-4 or best[1] is None:  # 9: iteration limit
            break
        x = best[1]
    return best[1] if best[1] is not None else last


def _spread(times: np.ndarray, most: int) -> np.ndarray:
    """At most ``most`` of the sorted ``times``, evenly chosen."""
    times = np.unique(times)
    return times if times.size <= most else times[np.linspace(0, times.size - 1, most).astype(int)]


def _start_pose(prob: _Problem, qs0: np.ndarray) -> np.ndarray:
    """The start pose nearest ``qs0`` (moving joints) where the robot at rest holds every limit: as
    given when it does, else by SLSQP; InputError when none is found."""
    from scipy.optimize import minimize

    zero = np.zeros(prob.nm * 2 * prob.L)
    rest = lambda qs: np.concatenate([zero, qs])
    saved = prob.t_con
    prob.set_grid(np.array([0.0]))
    try:
        if prob.feasible(rest(qs0)):
            return qs0
        lo = prob.limits.centre[prob.mi] - prob.target * prob.limits.half[prob.mi]
        hi = prob.limits.centre[prob.mi] + prob.target * prob.limits.half[prob.mi]
        scale = prob.limits.half[prob.mi]
        res = minimize(lambda qs: float(np.sum(((qs - qs0) / scale) ** 2)), np.clip(qs0, lo, hi),
                       jac=lambda qs: 2 * (qs - qs0) / scale**2, method="SLSQP", bounds=list(zip(lo, hi)),
                       constraints=[{"type": "ineq", "fun": lambda qs: prob.constraints(rest(qs)),
                                     "jac": lambda qs: prob.constraints_jac(rest(qs))[:, -prob.nm :]}],
                       options={"maxiter": 200})
        if not prob.feasible(rest(res.x)):
            near = ", ".join(f"{j} {v:.4g}" for j, v in zip(prob.moving, qs0))
            raise InputError(f"no start pose at rest within the limits and clearances found near {near} rad; at the "
                             f"closest, {_shortfalls(prob, res.x)}; try --hold, a lower --clearance or --floor")
        return res.x
    finally:
        prob.set_grid(saved)


def _shortfalls(prob: _Problem, qs: np.ndarray) -> str:
    """What the robot at rest with its moving joints at ``qs`` breaks (the optimisation's targets)."""
    q = prob.q_hold.copy()
    q[prob.mi] = qs
    still = np.zeros((1, q.size))
    out = []
    for kind, r in motion_ratios(prob.robot, prob.limits, q[None], still, still).items():
        out += [f"joint '{prob.robot.joints[k]}' {kind} at {r[0, k]:.3g} of its limit"
                for k in np.flatnonzero(r[0] > prob.target)]
    if prob.collision is not None:
        col = prob.collision
        d = col.distances(q[None])[0]
        short = [p for p in np.argsort(d) if d[p] < col.clearance]
        out += [f"pair {col.pairs[p]} at {d[p] * 1000:.3g} mm (clearance {col.clearance * 1000:.3g} mm)"
                for p in short[:3]] + ([f"{len(short) - 3} more pairs"] if len(short) > 3 else [])
    return "; ".join(out) or "every limit within a hair"


def _scaled_start(prob: _Problem, c: np.ndarray, qs: np.ndarray) -> np.ndarray:
    """Coefficients ``c`` scaled per joint to the linear limits, then as a whole (bisection) until
    the effort and collision rows hold on the grid (the start pose holds them)."""
    lim, mi = prob.limits, prob.mi
    zero_qs = np.concatenate([c, np.zeros_like(qs)])
    p, v, a = (np.abs(m) for m in prob.motion(zero_qs, prob.basis_con))
    with np.errstate(divide="ignore", invalid="ignore"):
        room = prob.target * lim.half[mi] - np.abs(qs - lim.centre[mi])
        s = np.minimum.reduce([room / p[:, mi].max(axis=0), prob.target * lim.velocity[mi] / v[:, mi].max(axis=0),
                               prob.target * lim.acceleration[mi] / a[:, mi].max(axis=0)])
    s = np.where(np.isfinite(s), np.maximum(s, 0.0), 1.0)
    C = c.reshape(prob.nm, -1) * s[:, None]
    x = np.concatenate([C.ravel(), qs])
    if prob.feasible(x):
        return x
    lo, hi = 0.0, 1.0
    for _ in range(8):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if prob.feasible(np.concatenate([C.ravel() * mid, qs])) else (lo, mid)
    return np.concatenate([C.ravel() * lo, qs])
