"""The internal states of a dynamic friction law (LuGre, generalized Maxwell-slip) along a motion.

Along a log the states are integrated by the compiled kernel
(:func:`~frictionid_core.friction.kernels.state_rows`): :func:`state_torque` for parameter sets on
one velocity series, :func:`joint_state_rows` for joints each with its own. Sample by sample
(the node's feed-forward, and the kernel's reference) :class:`StateFriction` steps the same
functions of :mod:`~frictionid_core.friction.laws` under numpy.

Initial states. A series starts — and restarts after a gap of its stamps (:func:`resets`) —
with each element at its sliding value for the velocity of that sample (sign(v)·g/(n·k_i), 0 at
rest): exact when the motion was steady before (burnt in), and forgotten after a travel of a
few break-away deflections (g/(n·k_i): micrometres to millimetres). Until each joint's first
reversal the start is a guess: an observation leaves those rows out of the fit and the metrics
while the states run through them (:func:`~frictionid_core.systems.system.burn_in_rows`).
"""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction.laws import NUMPY_OPS, bristle_advance, bristle_force, substeps

# A step longer than this many median sample periods (or not forward) restarts the states.
GAP_PERIODS = 10.0


def resets(t: np.ndarray) -> np.ndarray:
    """(N,) True where the states restart along sample times ``t`` (s): the first sample, and
    each sample after a step that is not forward or longer than GAP_PERIODS median steps (a
    gap, or the start of the next source in stacked rows)."""
    t = np.asarray(t, dtype=float)
    out = np.ones(t.size, dtype=bool)
    if t.size > 1:
        dt = np.diff(t)
        forward = dt[dt > 0.0]
        limit = GAP_PERIODS * float(np.median(forward)) if forward.size else 0.0
        out[1:] = ~((dt > 0.0) & (dt <= limit))
    return out


def state_torque(model, params: np.ndarray, v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The friction of the dynamic :class:`~frictionid_core.friction.FrictionModel` ``model`` for
    parameters (P, k) or (k,) along velocities v (N,) at times t (N,) → (P, N) or (N,)."""
    from frictionid_core.friction.kernels import state_rows

    p = np.asarray(params, dtype=float)
    single = p.ndim == 1
    p = np.atleast_2d(p)
    if p.shape[1] != len(model.names):
        raise FrictionIdError(f"{model.label} takes {len(model.names)} parameters {list(model.names)}, "
                              f"got {p.shape[1]}")
    v = np.asarray(v, dtype=float).ravel()
    t = np.asarray(t, dtype=float).ravel()
    if t.shape != v.shape:
        raise FrictionIdError(f"{model.label}: {t.size} times for {v.size} velocities")
    out = state_rows(model.name, model.asymmetric, model.elements, p, v[None, :], np.zeros(p.shape[0], dtype=int), t,
                     resets(t))
    return out[0] if single else out


def joint_state_rows(model, params: np.ndarray, velocity: np.ndarray, t: np.ndarray,
                     travel: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """The friction (P, J, N) of J joints for P parameter sets: ``params`` (P, J, k) (joint j's
    parameters of set p), ``velocity`` (N, J) (an observation's), sampled at ``t`` (N,). A joint's
    states are integrated once per distinct parameter set of it: a finite-difference Jacobian's sets
    differ from their centre in one joint each. ``travel``: None, or each joint's measured travel
    (path (N, J), shift (N, J), rest speed (J,)): see :func:`~frictionid_core.friction.kernels.state_rows`."""
    from frictionid_core.friction.kernels import state_rows

    p = np.asarray(params, dtype=float)
    n_pop, nj, k = p.shape
    items = p.reshape(n_pop * nj, k)
    keyed = np.hstack([np.tile(np.arange(nj, dtype=float), n_pop)[:, None], items])
    distinct, where = np.unique(keyed, axis=0, return_inverse=True)
    if travel is not None:
        path, shift, rest = travel
        travel = (np.asarray(path, dtype=float).T, np.asarray(shift, dtype=float).T, np.asarray(rest, dtype=float))
    out = state_rows(model.name, model.asymmetric, model.elements, distinct[:, 1:],
                     np.asarray(velocity, dtype=float).T, distinct[:, 0].astype(np.int64), t, resets(t), travel)
    return out[where.ravel()].reshape(n_pop, nj, -1)


class StateFriction:
    """The states of a dynamic law for J joints, each with its own parameters, stepped one sample
    at a time under numpy (the functions of :mod:`~frictionid_core.friction.laws`).

    Args:
        model: a dynamic :class:`~frictionid_core.friction.FrictionModel`.
        params: (J, k) each joint's parameters in ``model.names`` order.
    """

    def __init__(self, model, params: np.ndarray):
        if not model.is_dynamic:
            raise FrictionIdError(f"{model.label} has no internal states")
        self.model = model
        self.table = np.asarray(params, dtype=float).T.copy()  # (k, J): the laws' p[o + j] is a joint row
        if self.table.shape[0] != len(model.names):
            raise FrictionIdError(f"{model.label} takes {len(model.names)} parameters per joint, got "
                                  f"{self.table.shape[0]}")
        self.n = model.elements
        self.nb = len(model.branch_names) if model.asymmetric else 0
        self.z: np.ndarray | None = None
        self.v: np.ndarray | None = None
        self.t_s: float | None = None  # the time of the last sample of advance()

    @property
    def started(self) -> bool:
        """True once :meth:`reset` or :meth:`step` has set the states."""
        return self.z is not None

    def reset(self, v: np.ndarray) -> np.ndarray:
        """Set the states to their sliding values at velocities v (J,) (0 at rest); the friction there."""
        v = np.asarray(v, dtype=float)
        direction = np.sign(v)
        self.z = self._advance(np.zeros((self.n, v.size)), np.full(v.size, np.inf), direction, np.abs(v), np.abs(v))
        self.v = v.copy()
        return self.force(v)

    def step(self, v: np.ndarray, h: float) -> np.ndarray:
        """Advance the states by ``h`` s to velocities v (J,) (linear from the previous ones); the
        friction (J,) there. The first call (or after :meth:`clear`) is a :meth:`reset`."""
        v = np.asarray(v, dtype=float)
        if self.z is None:
            return self.reset(v)
        with np.errstate(invalid="ignore", divide="ignore"):
            d1, s1, a1, e1, d2, s2, a2, e2 = substeps(self.v, v, h, np.where)
        z = self._advance(self.z, d1, s1, a1, e1)
        self.z = self._advance(z, d2, s2, a2, e2)
        self.v = v.copy()
        return self.force(v)

    def advance(self, v: np.ndarray, t_s: float, max_gap_s: float) -> np.ndarray:
        """Step to velocities v (J,) sampled at ``t_s`` [s] and return the friction there; the
        states restart at the sliding values of v (0 at rest) on the first sample, after a gap over
        ``max_gap_s``, a time that does not move forward or a non-finite velocity (taken as 0)."""
        v = np.asarray(v, dtype=float)
        h = t_s - self.t_s if self.t_s is not None and self.z is not None else 0.0
        finite = np.isfinite(v)
        out = self.step(v, h) if finite.all() and 0.0 < h <= max_gap_s else self.reset(np.where(finite, v, 0.0))
        self.t_s = float(t_s)
        return out

    def clear(self) -> None:
        """Forget the states: the next :meth:`step` starts from the sliding values."""
        self.z = self.v = self.t_s = None

    def force(self, v: np.ndarray) -> np.ndarray:
        """The friction (J,) of the current states at velocities v (J,)."""
        out = bristle_force(v, self.z, self.n, self.table, 0, *self._parts(), *NUMPY_OPS)
        if self.nb:
            out = np.where(v >= 0.0, out, bristle_force(v, self.z, self.n, self.table, self.nb, *self._parts(),
                                                        *NUMPY_OPS))
        return np.asarray(out, dtype=float)

    def _parts(self) -> tuple:
        law = self.model.law
        return law.dip, law.stiffness, law.damping

    def _advance(self, z: np.ndarray, distance, direction, speed0, speed1) -> np.ndarray:
        """New states (n, J) after a sub-step (each joint on its own branch)."""
        law = self.model.law
        branches = {}
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            for o in {0, self.nb}:
                branches[o] = z.copy()
                bristle_advance(branches[o], self.n, distance, direction, speed0, speed1, self.table, o, law.dip,
                                law.stiffness, *NUMPY_OPS)
        return np.where(direction < 0.0, branches[self.nb], branches[0])
