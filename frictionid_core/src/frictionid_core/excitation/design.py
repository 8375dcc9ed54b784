"""Excitation trajectories: finite Fourier series optimised for the observation matrix.

Joint j follows (Swevers et al.)

    q_j(t) = q0_j + Σ_l  a_jl/(ω_f·l)·sin(ω_f·l·t) − b_jl/(ω_f·l)·cos(ω_f·l·t),   l = 1…L

so q̇ and q̈ are finite Fourier series too and the motion is periodic with period 2π/ω_f.
Limits are met by construction: q − q0, q̇ and q̈ are linear in (a, b), so each joint's
coefficients are scaled by the largest factor that keeps its position (with a margin),
velocity and acceleration inside the limits on a dense grid of one period. The optimiser
then only chooses the *shape* (and q0): it minimises log10 of the condition number of the
observation matrix — the system's rigid (base) columns plus the viscous and Coulomb
columns q̇_j, sign(q̇_j) of every moving joint, each column scaled to unit norm (the
criterion is then independent of parameter units) — sampled over one period.

That criterion cannot see the Stribeck shapes (vs, δ): with unit-norm columns a 0.14 N·m hump
weighs as much as a 50 N·m gravity term, and a Fourier motion crosses the Stribeck speeds only
briefly at each reversal. A :class:`DwellTrajectory` therefore appends constant-velocity
plateaus to the Fourier part, at the speeds and time shares of the c-optimal design for δ
(``bench/tx40_stribeck_information.py``).

A trajectory with ``ramp`` > 0 starts and ends at rest at its start pose p(0): the series' deviation
from p(0) is windowed, q(t) = p(0) + w(t)·(p(t) − p(0)), w rising from 0 to 1 over the first
``ramp`` seconds and back over the last as a quintic smoothstep (w′ = w″ = 0 at both ends), so q̇ and
q̈ are zero at both ends. ``frictionid excite`` designs such a trajectory within every limit of the
robot (position, velocity, acceleration, effort, collisions): :mod:`.excitation_design`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.preprocess import Prepared
from frictionid_core.robots import build_tx40

_GRID_PER_PERIOD = 2000  # limit-check grid (per period, at least 40 points per top harmonic)


@dataclass
class FourierTrajectory:
    """A finite Fourier series per joint (see the module doc). Arrays: q0 (J,), a, b (J, L)."""

    joints: list[str]
    q0: np.ndarray
    a: np.ndarray
    b: np.ndarray
    wf: float
    duration: float
    ramp: float = 0.0

    @property
    def harmonics(self) -> int:
        return self.a.shape[1]

    @property
    def period(self) -> float:
        return 2.0 * np.pi / self.wf

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q̇, q̈ at times t (N,), each (N, J)."""
        t = np.asarray(t, dtype=float)[:, None, None]
        wl = self.wf * np.arange(1, self.harmonics + 1)  # (L,)
        s, c = np.sin(wl * t), np.cos(wl * t)  # (N, 1, L)
        a, b = self.a[None], self.b[None]  # (1, J, L)
        q = self.q0 + np.sum(a / wl * s - b / wl * c, axis=-1)
        qd = np.sum(a * c + b * s, axis=-1)
        qdd = np.sum(wl * (b * c - a * s), axis=-1)
        if self.ramp > 0:
            w, w1, w2 = ramp_window(t[:, 0, 0], self.duration, self.ramp)
            dev = q - self.start_pose
            q, qd, qdd = self.start_pose + w * dev, w1 * dev + w * qd, w2 * dev + 2 * w1 * qd + w * qdd
        return q, qd, qdd

    @property
    def start_pose(self) -> np.ndarray:
        """q(0) of the series (J,): with a ramp, where the trajectory starts and ends at rest."""
        return self.q0 - np.sum(self.b / (self.wf * np.arange(1, self.harmonics + 1)), axis=-1)

    def sample(self, rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        t = np.arange(int(round(self.duration * rate)) + 1) / rate
        return (t, *self.evaluate(t))

    def moves(self) -> np.ndarray:
        """(J,) True for the joints that move (non-zero coefficients)."""
        return np.any(self.a != 0, axis=1) | np.any(self.b != 0, axis=1)

    def to_dict(self) -> dict:
        out = {"kind": "fourier", "joints": list(self.joints), "q0": self.q0.tolist(), "a": self.a.tolist(),
               "b": self.b.tolist(), "wf": self.wf, "duration": self.duration}
        return dict(out, ramp_s=self.ramp) if self.ramp > 0 else out

    # ------------------------------------------------------------------ files
    def save(self, path: Path, rate: float = 1000.0) -> Path:
        """``.npz``: the coefficients; ``.csv``: t and q/qd/qdd per joint sampled at ``rate``."""
        return _save(self, Path(path), rate)


def ramp_window(t: np.ndarray, duration: float, ramp: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """w, w′, w″ (N, 1) at times t (N,) of the window of a trajectory of ``duration`` s with ramps of
    ``ramp`` s: the quintic smoothstep S(s) = 10s³ − 15s⁴ + 6s⁵ of t/ramp, 1 in the middle, S of
    (duration − t)/ramp at the end (0 outside [0, duration])."""
    t = np.asarray(t, dtype=float)
    ramp = min(ramp, duration / 2.0)
    up, down = t / ramp, (duration - t) / ramp
    s = np.clip(np.minimum(up, down), 0.0, 1.0)
    sign = np.where(up <= down, 1.0, -1.0)
    w = s**3 * (10.0 - 15.0 * s + 6.0 * s**2)
    w1 = sign * 30.0 * s**2 * (1.0 - s) ** 2 / ramp
    w2 = 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / ramp**2
    return w[:, None], w1[:, None], w2[:, None]


def _save(traj, path: Path, rate: float) -> Path:
    """``.npz``: ``traj.to_dict()`` (read back by :func:`trajectory_from_dict`); ``.csv``: t and
    q/qd/qdd per joint sampled at ``rate``."""
    if path.suffix.lower() == ".npz":
        np.savez(path, **traj.to_dict())
        return path
    if path.suffix.lower() != ".csv":
        raise FrictionIdError(f"{path}: trajectory files are .npz (coefficients) or .csv (samples)")
    t, q, qd, qdd = traj.sample(rate)
    head = ["t"] + [f"{p}:{j}" for p in ("q", "qd", "qdd") for j in traj.joints]
    np.savetxt(path, np.column_stack([t, q, qd, qdd]), delimiter=",", header=",".join(head), comments="",
               fmt="%.12g")
    return path


@dataclass
class SampledTrajectory:
    """A trajectory given by samples (from CSV): t (N,), q, q̇, q̈ (N, J)."""

    joints: list[str]
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray

    def sample(self, rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        t = self.t[0] + np.arange(int(np.floor((self.t[-1] - self.t[0]) * rate + 1e-9)) + 1) / rate
        if t.size == self.t.size and np.allclose(t, self.t, atol=1e-9):
            return self.t - self.t[0], self.q, self.qd, self.qdd
        interp = lambda a: np.column_stack([np.interp(t, self.t, c) for c in a.T])
        return t - t[0], interp(self.q), interp(self.qd), interp(self.qdd)

    def moves(self) -> np.ndarray:
        """(J,) True for the joints whose position changes."""
        return np.ptp(self.q, axis=0) > 0


# Plateau speeds (multiples of the nominal vs) and their shares of the plateau time: the
# c-optimal design for δ at the published TX40 joint-2 friction (docs/reference.md#tx40-friction)
# (bench/tx40_stribeck_information.py puts 0.22, 0.36, 0.27, 0.14 of the time at ≈ 0, 0.64, 1.25,
# 2.4 vs; "≈ 0" becomes 0.2 vs, well above the velocity noise and the slow-row threshold of the
# robot systems).
DWELL_SPEEDS = (0.2, 0.6, 1.25, 2.5)
DWELL_SHARES = (0.22, 0.36, 0.27, 0.15)
DWELL_RAMP_S = 0.25  # between plateaus (cubic velocity ramp, q̈ continuous)


def _cubic_ramp(s, length, v0, a0, v1):
    """Velocity going from (v0, a0) to (v1, 0) in ``length`` s as a cubic Hermite curve at
    s ∈ [0, 1] (arrays broadcast): returns (Δq since s = 0, q̇, q̈)."""
    h00, h10, h01 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, 3 * s**2 - 2 * s**3
    d00, d10, d01 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, 6 * s - 6 * s**2
    i00, i10, i01 = s**4 / 2 - s**3 + s, s**4 / 4 - 2 * s**3 / 3 + s**2 / 2, s**3 - s**4 / 2
    tangent = length * a0
    dq = length * (i00 * v0 + i10 * tangent + i01 * v1)
    return dq, h00 * v0 + h10 * tangent + h01 * v1, (d00 * v0 + d10 * tangent + d01 * v1) / length


@dataclass
class DwellTrajectory:
    """A Fourier excitation followed by constant-velocity plateaus for the Stribeck curve.

    After ``fourier`` every moving joint ramps to +v₁ (in ``entry_s``), holds it ``plateau_s[0]``
    s, ramps to −v₁ (``ramp_s``), holds it, then ±v₂, … through ``speeds`` (rad/s), and ramps to
    rest. Ramps are cubic in velocity, so q̈ is continuous; q, q̇, q̈ are exact. Joints that do
    not move in the Fourier part stay still.
    """

    fourier: FourierTrajectory
    speeds: np.ndarray
    plateau_s: np.ndarray
    entry_s: float
    ramp_s: float = DWELL_RAMP_S

    @property
    def joints(self) -> list[str]:
        return self.fourier.joints

    @property
    def duration(self) -> float:
        ramps = self.entry_s + 2 * len(self.speeds) * self.ramp_s
        return self.fourier.duration + ramps + 2.0 * float(np.sum(self.plateau_s))

    def moves(self) -> np.ndarray:
        return self.fourier.moves()

    def _segments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Start times (S,), lengths (S,), and per joint v0, a0, v1, q at the start (S, J)."""
        q_end, v_end, a_end = (x[0] for x in self.fourier.evaluate(np.array([self.fourier.duration])))
        mask = self.moves().astype(float)
        levels = [sign * v * mask for v in self.speeds for sign in (1.0, -1.0)] + [np.zeros_like(mask)]
        lengths, v0, a0, v1 = [self.entry_s], [v_end], [a_end], [levels[0]]
        for k, hold in enumerate(np.repeat(self.plateau_s, 2)):
            lengths += [hold, self.ramp_s]
            v0 += [levels[k], levels[k]]
            a0 += [np.zeros_like(mask)] * 2
            v1 += [levels[k], levels[k + 1]]
        lengths, v0, a0, v1 = map(np.array, (lengths, v0, a0, v1))
        dq, _, _ = _cubic_ramp(1.0, lengths[:, None], v0, a0, v1)
        q0 = q_end + np.vstack([np.zeros_like(q_end), np.cumsum(dq, axis=0)[:-1]])
        starts = self.fourier.duration + np.concatenate(([0.0], np.cumsum(lengths)[:-1]))
        return starts, lengths, v0, a0, v1, q0

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q̇, q̈ at times t (N,), each (N, J); at rest after the end."""
        t = np.asarray(t, dtype=float)
        q, qd, qdd = self.fourier.evaluate(np.minimum(t, self.fourier.duration))
        late = t > self.fourier.duration
        if late.any():
            starts, lengths, v0, a0, v1, q0 = self._segments()
            seg = np.clip(np.searchsorted(starts, t[late], side="right") - 1, 0, len(starts) - 1)
            s = np.clip((t[late] - starts[seg]) / lengths[seg], 0.0, 1.0)[:, None]
            dq, qd[late], qdd[late] = _cubic_ramp(s, lengths[seg][:, None], v0[seg], a0[seg], v1[seg])
            q[late] = q0[seg] + dq
        return q, qd, qdd

    def sample(self, rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        t = np.arange(int(round(self.duration * rate)) + 1) / rate
        return (t, *self.evaluate(t))

    def to_dict(self) -> dict:
        return dict(self.fourier.to_dict(), kind="fourier+dwell", duration=self.duration,
                    fourier_duration=self.fourier.duration, dwell_speeds=self.speeds.tolist(),
                    dwell_plateau_s=self.plateau_s.tolist(), dwell_entry_s=self.entry_s, dwell_ramp_s=self.ramp_s)

    def save(self, path: Path, rate: float = 1000.0) -> Path:
        """``.npz``: the Fourier coefficients and the plateaus; ``.csv``: samples at ``rate``."""
        return _save(self, Path(path), rate)


def add_dwell(robot, fourier: FourierTrajectory, dwell_s: float, vs: float = 0.05,
              margin: float = 0.05) -> DwellTrajectory:
    """``fourier`` followed by ``dwell_s`` s of plateaus at ±DWELL_SPEEDS·``vs`` rad/s.

    The entry ramp takes the shortest time (0.1 s steps) that keeps q̈ within (1 − margin) of
    the acceleration limits; the plateaus share the rest as DWELL_SHARES. Raises InputError
    if ``dwell_s`` is too short for the ramps or the motion leaves the robot's limits.
    """
    if not (np.isfinite(vs) and vs > 0):
        raise InputError(f"dwell: the nominal Stribeck speed vs must be > 0 rad/s, got {vs}")
    speeds = vs * np.array(DWELL_SPEEDS)
    _, v_end, a_end = (x[0] for x in fourier.evaluate(np.array([fourier.duration])))
    v1 = speeds[0] * fourier.moves()
    s = np.linspace(0.0, 1.0, 201)[:, None]
    limit = (1.0 - margin) * np.asarray(robot.acceleration_limit, dtype=float)
    for entry in np.arange(0.2, 5.0001, 0.1):
        if np.all(np.abs(_cubic_ramp(s, entry, v_end, a_end, v1)[2]) <= limit):
            break
    else:
        raise InputError("dwell: no entry ramp up to 5 s keeps the acceleration within the limits")
    entry = float(round(entry, 1))
    plateaus = dwell_s - entry - 2 * len(speeds) * DWELL_RAMP_S
    if plateaus < 0.5 * len(speeds):
        raise InputError(f"dwell of {dwell_s:g} s is too short: the ramps alone take "
                         f"{dwell_s - plateaus:.3g} s; give at least {dwell_s - plateaus + 0.5 * len(speeds):.3g} s")
    traj = DwellTrajectory(fourier, speeds, np.array(DWELL_SHARES) * plateaus / 2.0, entry)
    check_trajectory(robot, traj, what=f"excitation with a {dwell_s:g} s dwell")
    return traj


def trajectory_from_dict(d: dict) -> FourierTrajectory | DwellTrajectory:
    """Inverse of ``to_dict`` (the ``trajectory`` entry of a truth file)."""
    fourier = FourierTrajectory(list(d["joints"]), np.array(d["q0"], float), np.array(d["a"], float),
                                np.array(d["b"], float), float(d["wf"]),
                                float(d.get("fourier_duration", d["duration"])), float(d.get("ramp_s", 0.0)))
    if d.get("kind", "fourier") == "fourier":
        return fourier
    return DwellTrajectory(fourier, np.array(d["dwell_speeds"], float), np.array(d["dwell_plateau_s"], float),
                           float(d["dwell_entry_s"]), float(d["dwell_ramp_s"]))


def load_trajectory(path: str | Path) -> FourierTrajectory | DwellTrajectory | SampledTrajectory:
    """Read a trajectory written by ``frictionid excite`` (.npz) or a CSV with columns ``t``,
    ``q:<joint>`` and optionally ``qd:<joint>``, ``qdd:<joint>`` (else cubic-spline derivatives)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such trajectory file")
    if path.suffix.lower() == ".npz":
        try:
            z = np.load(path, allow_pickle=False)
            d = {k: (z[k].tolist() if z[k].ndim else z[k].item()) for k in z.files}
            return trajectory_from_dict(d)
        except (KeyError, ValueError, OSError) as exc:
            raise InputError(f"{path}: not a trajectory written by 'frictionid excite' ({exc})") from None
    if path.suffix.lower() != ".csv":
        raise InputError(f"{path}: trajectory files are .npz or .csv")
    with path.open() as f:
        head = [h.strip() for h in f.readline().split(",")]
    try:
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except ValueError as exc:
        raise InputError(f"{path}: unreadable CSV trajectory ({exc})") from None
    if not head or head[0] != "t" or data.shape[1] != len(head):
        raise InputError(f"{path}: expected a header 't,q:<joint>,…' with one value per column")
    joints = [h[2:] for h in head if h.startswith("q:")]
    if not joints:
        raise InputError(f"{path}: no 'q:<joint>' column")
    t = data[:, 0]
    if t.size < 4 or np.any(np.diff(t) <= 0):
        raise InputError(f"{path}: time column must be strictly increasing with at least 4 samples")
    col = lambda p, j: data[:, head.index(f"{p}:{j}")] if f"{p}:{j}" in head else None
    q = np.column_stack([col("q", j) for j in joints])
    from scipy.interpolate import CubicSpline

    spline = CubicSpline(t, q, axis=0)
    qd = np.column_stack([col("qd", j) if col("qd", j) is not None else spline(t, 1)[:, k]
                          for k, j in enumerate(joints)])
    qdd = np.column_stack([col("qdd", j) if col("qdd", j) is not None else spline(t, 2)[:, k]
                           for k, j in enumerate(joints)])
    if not np.all(np.isfinite(np.column_stack([q, qd, qdd]))):
        raise InputError(f"{path}: NaN/inf in the trajectory")
    return SampledTrajectory(joints, t, q, qd, qdd)


# ---------------------------------------------------------------- limits
def _finite_limits(robot) -> tuple[np.ndarray, np.ndarray]:
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    return lo, hi


def fit_to_limits(robot, traj: FourierTrajectory, margin: float = 0.05) -> FourierTrajectory:
    """Scale each joint's (a, b) by the largest factor keeping it within (1 − margin) of its
    velocity and acceleration limits and ``margin``·range inside its position limits, on a
    dense grid over one period. Joints with a = b = 0 are left alone."""
    lo, hi = _finite_limits(robot)
    m = margin * (hi - lo)
    n = max(_GRID_PER_PERIOD, 40 * traj.harmonics)
    t = np.arange(n) * traj.period / n
    zero = FourierTrajectory(traj.joints, np.zeros_like(traj.q0), traj.a, traj.b, traj.wf, traj.duration)
    p, qd, qdd = zero.evaluate(t)
    s = np.full(len(traj.joints), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        pmax, pmin = p.max(axis=0), p.min(axis=0)
        s = np.minimum(s, np.where(pmax > 0, (hi - m - traj.q0) / pmax, np.inf))
        s = np.minimum(s, np.where(pmin < 0, (traj.q0 - lo - m) / -pmin, np.inf))
        s = np.minimum(s, (1 - margin) * robot.velocity_limit / np.abs(qd).max(axis=0))
        s = np.minimum(s, (1 - margin) * robot.acceleration_limit / np.abs(qdd).max(axis=0))
    s = np.where(np.isfinite(s), np.maximum(s, 0.0), 1.0)
    return FourierTrajectory(traj.joints, traj.q0.copy(), traj.a * s[:, None], traj.b * s[:, None], traj.wf,
                             traj.duration)


def check_trajectory(robot, traj, rate: float = 1000.0, what: str | None = None) -> None:
    """Raise InputError if the trajectory (sampled at ``rate``) leaves the robot's limits or
    names joints the robot does not have."""
    missing = [j for j in robot.joints if j not in traj.joints]
    extra = [j for j in traj.joints if j not in robot.joints]
    if missing or extra:
        raise InputError(f"trajectory joints {traj.joints} do not match the joints of {robot.name} {robot.joints}"
                         + (f"; missing {missing}" if missing else "") + (f"; unknown {extra}" if extra else ""))
    t, q, qd, qdd = traj.sample(rate)
    order = [traj.joints.index(j) for j in robot.joints]
    robot.check_limits(q[:, order], qd[:, order], qdd[:, order], t, what or "trajectory")


# ------------------------------------------------------------ criterion
def observation_matrix(system, robot, traj: FourierTrajectory, moving: list[str], samples: int = 200) -> np.ndarray:
    """Unit-norm columns: the system's rigid columns and q̇_j, sign(q̇_j) of the moving joints,
    over one period at ``samples`` points."""
    t = np.arange(samples) * traj.period / samples
    return observation_columns(system, robot, t, *traj.evaluate(t), moving)


def observation_columns(system, robot, t: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                        moving: list[str], sign_speed: float = 0.0) -> np.ndarray:
    """:func:`observation_matrix` of samples t (N,), q, q̇, q̈ (N, nv) of every robot joint;
    ``sign_speed`` > 0: tanh(q̇/sign_speed) for sign(q̇) (a criterion smooth in the motion)."""
    samples = t.size
    if system.robot is not None:
        rows_joints = list(robot.joints)
        W = system.robot.base_columns(q, qd, qdd, rows_joints)
        sel = list(range(len(rows_joints)))
    else:
        sel = [robot.joints.index(j) for j in moving]
        rows_joints = moving
        W = system.columns(Prepared(t, q[:, sel], qd[:, sel], qdd[:, sel], qd[:, sel], t[1] - t[0]), moving)
    fric = np.zeros((W.shape[0], 2 * len(moving)))
    for k, j in enumerate(moving):
        r = rows_joints.index(j) if j in rows_joints else None
        if r is None:
            continue
        v = qd[:, robot.joints.index(j)]
        fric[r * samples : (r + 1) * samples, 2 * k] = v
        fric[r * samples : (r + 1) * samples, 2 * k + 1] = np.tanh(v / sign_speed) if sign_speed > 0 else np.sign(v)
    A = np.hstack([W, fric])
    norms = np.linalg.norm(A, axis=0)
    return A / np.where(norms > 0, norms, 1.0)


def criterion(A: np.ndarray) -> float:
    """log10 of the condition number of A (unit-norm columns), from the eigenvalues of AᵀA
    (fast; exact enough below cond ≈ 1e6); 20 when A is (numerically) rank-deficient."""
    ev = np.linalg.eigvalsh(A.T @ A)
    if ev[0] <= ev[-1] * 1e-14:
        return 20.0
    return float(0.5 * np.log10(ev[-1] / ev[0]))


class _BudgetSpent(Exception):
    pass


@dataclass
class ExcitationResult:
    trajectory: FourierTrajectory
    cond: float
    cond_initial: float
    evaluations: int

    def to_dict(self) -> dict:
        return {"cond": self.cond, "cond_initial": self.cond_initial, "evaluations": self.evaluations,
                "joints": self.trajectory.joints, "harmonics": self.trajectory.harmonics,
                "wf": self.trajectory.wf, "period": self.trajectory.period, "duration": self.trajectory.duration}


def optimise_excitation(system, robot, *, moving: list[str] | None = None, hold: dict[str, float] | None = None,
                        harmonics: int = 5, period: float = 10.0, duration: float = 20.0, evals: int = 1500,
                        starts: int = 20, seed: int = 0, margin: float = 0.05, samples: int = 200) -> ExcitationResult:
    """Optimise a Fourier excitation for ``system`` (its rigid columns + friction columns) within the
    position, velocity and acceleration limits only (the design of the bundled TX40 bags,
    ``tools/make_tx40_bags.py``); ``frictionid excite`` designs within every limit, effort and
    collisions included, ramped from rest: :func:`.excitation_design.design_excitation`.

    Args:
        system: a System from :func:`~frictionid_core.systems.get_system` (robot systems or tx40-j2).
        robot: the RobotModel whose limits bound the motion.
        moving: joints that move (default: all); the others stay at ``hold`` (default 0 or the
            middle of the limits).
        harmonics, period: L and 2π/ω_f, s.
        duration: trajectory length, s (several periods if longer than ``period``).
        evals: criterion evaluations of the local search (L-BFGS-B, finite differences).
        starts: random shapes tried first; the best one starts the local search.
    """
    from scipy.optimize import minimize

    moving = list(robot.joints) if moving is None else list(moving)
    unknown = [j for j in moving + list(hold or {}) if j not in robot.joints]
    if unknown:
        raise InputError(f"joint(s) {unknown} not in {robot.name}; joints: {robot.joints}")
    if not moving:
        raise InputError("no joint to move")
    if harmonics < 1 or period <= 0 or duration <= 0:
        raise InputError("harmonics must be ≥ 1, period and duration > 0")
    lo, hi = _finite_limits(robot)
    centre = np.clip(0.0, lo, hi)
    q_hold = np.array([(hold or {}).get(j, centre[k]) for k, j in enumerate(robot.joints)], dtype=float)
    bad = [j for k, j in enumerate(robot.joints) if not lo[k] <= q_hold[k] <= hi[k]]
    if bad:
        raise InputError(f"hold position of {bad} outside the position limits")
    mi = np.array([robot.joints.index(j) for j in moving])
    nm, L = mi.size, harmonics
    wf = 2.0 * np.pi / period
    lo_m, hi_m = lo[mi] + margin * (hi[mi] - lo[mi]), hi[mi] - margin * (hi[mi] - lo[mi])

    def build(x: np.ndarray) -> FourierTrajectory:
        a = np.zeros((robot.nv, L))
        b = np.zeros((robot.nv, L))
        a[mi] = x[: nm * L].reshape(nm, L)
        b[mi] = x[nm * L : 2 * nm * L].reshape(nm, L)
        q0 = q_hold.copy()
        q0[mi] = lo_m + np.clip(x[2 * nm * L :], 0, 1) * (hi_m - lo_m)
        return fit_to_limits(robot, FourierTrajectory(list(robot.joints), q0, a, b, wf, duration), margin)

    count = [0]
    seen = {"f": np.inf, "x": None}

    def cost(x: np.ndarray) -> float:
        if count[0] >= evals and seen["x"] is not None:
            raise _BudgetSpent
        count[0] += 1
        f = criterion(observation_matrix(system, robot, build(x), moving, samples))
        if f < seen["f"]:
            seen["f"], seen["x"] = f, np.array(x, copy=True)
        return f

    rng = np.random.default_rng(seed)
    x0_q = (np.clip(q_hold[mi], lo_m, hi_m) - lo_m) / np.where(hi_m > lo_m, hi_m - lo_m, 1.0)
    cands = [np.concatenate([rng.uniform(-1, 1, 2 * nm * L) / np.tile(np.arange(1, L + 1), 2 * nm), x0_q])]
    for _ in range(max(0, starts - 1)):
        cands.append(np.concatenate([rng.uniform(-1, 1, 2 * nm * L), rng.uniform(0.2, 0.8, nm)]))
    evals = max(evals, len(cands))
    scores = [cost(x) for x in cands]
    initial = scores[0]
    x = cands[int(np.argmin(scores))]
    if evals - len(cands) > 2 * x.size:
        bounds = [(-1.0, 1.0)] * (2 * nm * L) + [(0.0, 1.0)] * nm
        try:
            minimize(cost, x, method="L-BFGS-B", bounds=bounds, options={"maxfun": evals, "eps": 1e-4})
        except _BudgetSpent:
            pass
    traj = build(seen["x"])
    final = criterion(observation_matrix(system, robot, traj, moving, samples))
    check_trajectory(robot, traj, what="optimised trajectory")
    return ExcitationResult(traj, float(10**final), float(10**initial), count[0])


# ---------------------------------------------------------------- robots
def robot_of(system, system_name: str):
    """The RobotModel behind a system (robot systems, tx40-j2), and its default moving joints."""
    if system.robot is not None:
        return system.robot.model, None
    if system_name == "tx40-j2":
        return build_tx40(), ["joint_2"]
    raise FrictionIdError(f"system '{system_name}' has no robot model; use tx40, tx40-j2 or urdf:PATH")
