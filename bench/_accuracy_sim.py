"""The randomized accuracy corpus' truths, motions, simulations, log writers and baseline (bench/accuracy.py).

Nothing here imports frictionid_core: the rigid-body torques are Pinocchio's ``rnea`` on the URDF, the
friction laws and the LuGre integration are written below, the MuJoCo arms are the URDFs with their meshes
stripped, and the logs are written in the formats docs/data.md and docs/field.md describe.
"""

from __future__ import annotations

import math
import sysconfig
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import signal
from scipy.interpolate import make_interp_spline

# --------------------------------------------------------------------------------------------- the classes
ARMS = ("ur5", "ur10", "panda", "jaco2", "xarm7", "z1", "joint", "joint_gravity")
LAWS = ("coulomb", "stribeck", "lugre", "mujoco")
NOISES = ("white", "coloured", "quantised", "stale", "jitter", "lag", "reversed")
EXCITATIONS = ("fourier", "trapezoid", "plateaus", "micro", "trembling")
FORMATS = ("csv", "layout", "mcap")
ONE_JOINT = ("joint", "joint_gravity")
ONE_JOINT_NAME = "axis"

ERD_ROBOTS = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"


@dataclass(frozen=True)
class ArmSpec:
    """An arm of example-robot-data: its URDF (relative to the robots folder), the joints the log holds
    (the others are held at 0: ``--hold-missing``) and a nominal posture (the centre of the motion where the
    limits leave a choice)."""

    urdf: str
    joints: tuple[str, ...]
    posture: tuple[float, ...]


UR_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
             "wrist_3_joint")
ARM_SPECS = {
    "ur5": ArmSpec("ur_description/urdf/ur5_robot.urdf", UR_JOINTS, (0.0, -1.3, 1.4, -1.6, -1.5, 0.0)),
    "ur10": ArmSpec("ur_description/urdf/ur10_robot.urdf", UR_JOINTS, (0.0, -1.3, 1.4, -1.6, -1.5, 0.0)),
    "panda": ArmSpec("panda_description/urdf/panda.urdf", tuple(f"panda_joint{k}" for k in range(1, 8)),
                     (0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8)),
    "jaco2": ArmSpec("kinova_description/robots/kinova.urdf", tuple(f"j2s6s200_joint_{k}" for k in range(1, 7)),
                     (0.0, 3.14, 3.14, 0.0, 3.14, 0.0)),
    "xarm7": ArmSpec("xarm_description/urdf/xarm7.urdf", tuple(f"joint{k}" for k in range(1, 8)),
                     (0.0, 0.0, 0.0, 1.5, 0.0, 1.0, 0.0)),
    "z1": ArmSpec("z1_description/urdf/z1.urdf", tuple(f"joint{k}" for k in range(1, 7)),
                  (0.0, 1.2, -1.2, 0.0, 0.0, 0.0)),
}


def urdf_path(arm: str) -> Path:
    return ERD_ROBOTS / ARM_SPECS[arm].urdf


# --------------------------------------------------------------------------------------------- the robot
class Robot:
    """The arm's Pinocchio model and how the logged joints sit in it (angles in, q vectors out: a continuous
    joint takes (cos, sin) of its angle); ``lo``/``hi``/``vel`` its limits (inf for continuous joints)."""

    def __init__(self, arm: str):
        import pinocchio as pin

        spec = ARM_SPECS[arm]
        self.arm, self.joints = arm, list(spec.joints)
        self.model = pin.buildModelFromUrdf(str(urdf_path(arm)))
        self.data = self.model.createData()
        m = self.model
        self.iq, self.iv, self.continuous = [], [], []
        lo, hi, vel, eff = [], [], [], []
        for j in self.joints:
            jm = m.joints[m.getJointId(j)]
            self.iq.append(jm.idx_q)
            self.iv.append(jm.idx_v)
            cont = jm.nq == 2
            self.continuous.append(cont)
            lo.append(-math.inf if cont else m.lowerPositionLimit[jm.idx_q])
            hi.append(math.inf if cont else m.upperPositionLimit[jm.idx_q])
            vel.append(m.velocityLimit[jm.idx_v])
            eff.append(m.effortLimit[jm.idx_v])
        self.lo, self.hi, self.vel, self.effort_limit = map(np.array, (lo, hi, vel, eff))
        self.held = [m.names[k] for k in range(1, m.njoints) if m.joints[k].nv > 0 and m.names[k] not in self.joints]
        self.q_neutral = pin.neutral(m)

    @property
    def nj(self) -> int:
        return len(self.joints)

    def qvec(self, angles: np.ndarray) -> np.ndarray:
        q = self.q_neutral.copy()
        for k, a in enumerate(angles):
            if self.continuous[k]:
                q[self.iq[k]], q[self.iq[k] + 1] = math.cos(a), math.sin(a)
            else:
                q[self.iq[k]] = a
        return q

    def vvec(self, x: np.ndarray) -> np.ndarray:
        v = np.zeros(self.model.nv)
        v[self.iv] = x
        return v

    def rnea(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Rigid-body joint torques (N, J) of the logged joints along (N, J) angles, velocities, accelerations."""
        import pinocchio as pin

        out = np.empty_like(q)
        iv = self.iv
        for k in range(len(q)):
            out[k] = pin.rnea(self.model, self.data, self.qvec(q[k]), self.vvec(qd[k]), self.vvec(qdd[k]))[iv]
        return out

    def mass_diag(self, angles: np.ndarray) -> np.ndarray:
        import pinocchio as pin

        M = pin.crba(self.model, self.data, self.qvec(angles))
        return np.diag(M)[self.iv].copy()

    def gravity(self, angles: np.ndarray) -> np.ndarray:
        import pinocchio as pin

        return pin.computeGeneralizedGravity(self.model, self.data, self.qvec(angles))[self.iv].copy()

    def regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Pinocchio's joint torque regressor (N, J, 10·bodies) of the logged joints' rows."""
        import pinocchio as pin

        n = len(q)
        out = np.empty((n, self.nj, 10 * (self.model.njoints - 1)))
        for k in range(n):
            Y = pin.computeJointTorqueRegressor(self.model, self.data, self.qvec(q[k]), self.vvec(qd[k]),
                                                self.vvec(qdd[k]))
            out[k] = Y[self.iv]
        return out

    def mujoco_xml(self) -> str:
        """The URDF with its meshes (visual, collision) stripped and the held joints fixed at 0."""
        root = ET.parse(urdf_path(self.arm)).getroot()
        for link in root.findall("link"):
            for tag in ("visual", "collision"):
                for e in link.findall(tag):
                    link.remove(e)
        for j in root.findall("joint"):
            if j.get("name") in self.held:
                j.set("type", "fixed")
        mj = ET.SubElement(root, "mujoco")
        c = ET.SubElement(mj, "compiler")
        c.set("discardvisual", "true")
        c.set("fusestatic", "false")
        return ET.tostring(root, encoding="unicode")


# --------------------------------------------------------------------------------------------- the draw
@dataclass
class Case:
    """One drawn case: its labels, the motion's envelope per joint, the truth and the noise."""

    sub_seed: int
    arm: str
    law: str
    noise: str
    excitation: str
    fmt: str
    rate_hz: float
    duration_est: float
    duration_val: float
    joints: list[str]
    centre: np.ndarray
    amplitude: np.ndarray
    vmax: np.ndarray
    amax: np.ndarray
    torque_size: np.ndarray
    friction: dict  # per joint lists: Fv, Fc (+ Fs, vs, delta | Fs, vs, sigma0, sigma1)
    armature: np.ndarray
    offset: np.ndarray
    one_joint: dict = field(default_factory=dict)  # J, g_sin, g_cos for a one-joint system (the truth)
    effort_sigma: np.ndarray = None
    position_sigma: float = 0.0
    noise_detail: dict = field(default_factory=dict)
    log_velocity: bool = False
    trembling: list[int] = field(default_factory=list)
    excite_seeds: tuple[int, int] = (0, 0)
    noise_seeds: tuple[int, int] = (0, 0)
    one_joint_drawn: dict = field(default_factory=dict)  # as drawn (MuJoCo's pendulum is built from it)

    def labels(self) -> dict:
        return {"arm": self.arm, "law": self.law, "noise": self.noise, "excitation": self.excitation,
                "format": self.fmt, "rate_hz": round(self.rate_hz, 3), "rate_band": rate_band(self.rate_hz)}


def rate_band(rate: float) -> str:
    return "50-200 Hz" if rate < 200 else "200-1000 Hz" if rate < 1000 else "1-5 kHz"


def draw_case(sub_seed: int, overrides: dict | None = None, quick: bool = False) -> tuple[Case, Robot | None]:
    """Every dimension of a case from its sub-seed alone (``overrides``: labels given instead of drawn).

    Each component draws from its own stream (labels, motion envelope, friction, noise, trembling joints,
    log seeds) and draws all its values whatever the labels, so a label given by ``overrides`` changes
    that label only: ``--case-seed K:noise=white`` is case K with the same truth, motion and noise
    realisation, without its pathology."""
    rl, re_, rf, rn, rt, rs = (np.random.default_rng(c) for c in np.random.SeedSequence(sub_seed).spawn(6))
    o = dict(overrides or {})
    drawn = {"arm": str(rl.choice(ARMS)), "law": str(rl.choice(LAWS)), "noise": str(rl.choice(NOISES))}
    arm, law, noise = (o.get(k) or v for k, v in drawn.items())
    excitation = str(rl.choice(EXCITATIONS))
    if arm in ONE_JOINT and excitation == "trembling":  # a one-joint system has no other joint to excite
        excitation = str(rl.choice([e for e in EXCITATIONS if e != "trembling"]))
    excitation = o.get("excitation") or excitation
    if arm in ONE_JOINT and excitation == "trembling" and "arm" not in o:  # asked for: an arm that has others
        arm = str(rl.choice([a for a in ARMS if a not in ONE_JOINT]))
    if arm in ONE_JOINT and excitation == "trembling":
        raise ValueError("a one-joint system has no other joint to excite: no 'trembling' case")
    fmt = o.get("format") or str(rl.choice(FORMATS))
    rate = float(np.exp(rl.uniform(np.log(50.0), np.log(5000.0))))
    rate = float(o["rate"]) if "rate" in o else rate
    d_est, d_val = rl.uniform(20.0, 30.0), rl.uniform(10.0, 15.0)
    if quick:
        rate, d_est, d_val = min(rate, 200.0), 12.0, 8.0
    robot = None
    if arm in ONE_JOINT:
        joints = [ONE_JOINT_NAME]
        span, share = re_.uniform(1.0, 2.5), re_.uniform(0.6, 1.0)
        centre, amp = np.array([0.0]), np.array([span * share])
        vmax = np.array([re_.uniform(1.0, 3.0)])
        J = float(np.exp(re_.uniform(np.log(0.02), np.log(2.0))))
        G = float(np.exp(re_.uniform(np.log(1.0), np.log(40.0))))
        phi = re_.uniform(-math.pi, math.pi)
        amax = np.minimum(4.0 * vmax, 8.0) * re_.uniform(0.5, 1.0)
        one = {"J": J}
        grav = 0.0
        if arm == "joint_gravity":
            one.update(g_sin=G * math.cos(phi), g_cos=G * math.sin(phi))
            grav = G
        size = np.array([grav + J * float(amax[0]) + 0.5])
    else:
        robot = Robot(arm)
        joints = robot.joints
        nj = robot.nj
        posture = np.array(ARM_SPECS[arm].posture)
        lo, hi = robot.lo, robot.hi
        span = np.where(np.isfinite(hi - lo), hi - lo, np.inf)
        amax_pos = np.minimum(0.4 * span, 1.2)
        centre = np.where(span >= 2 * math.pi, posture, np.clip(posture, lo + amax_pos, hi - amax_pos))
        amp = amax_pos * re_.uniform(0.5, 1.0, nj)
        vlim = np.where(robot.vel > 0, robot.vel, 3.0)
        vmax = np.minimum(0.6 * vlim, 2.0) * re_.uniform(0.6, 1.0, nj)
        amax = np.minimum(4.0 * vmax, 8.0) * re_.uniform(0.5, 1.0, nj)
        # the torque a joint works with: its largest gravity torque over the motion's box, plus its
        # inertia at the centre times the largest acceleration
        grav = np.zeros(nj)
        for _ in range(40):
            grav = np.maximum(grav, np.abs(robot.gravity(centre + amp * re_.uniform(-1, 1, nj))))
        mdiag = robot.mass_diag(centre)
        # at least a tenth of the URDF's effort limit: a geared joint's friction is not a sliver of its rating
        size = np.maximum(grav + mdiag * amax, 0.1 * robot.effort_limit)
        one = {}
    nj = len(joints)
    u = lambda lo, hi: rf.uniform(lo, hi, nj)
    fc, fv = size * u(0.04, 0.15), size * u(0.03, 0.15) / vmax
    stribeck = {"Fs": fc * u(1.3, 2.0), "vs": vmax * u(0.02, 0.1), "delta": u(0.5, 3.0)}
    sigma0 = fc / u(2e-4, 2e-3)  # break-away deflection 0.2–2 mrad
    inertia = np.array([one["J"]]) if one else robot.mass_diag(centre)
    lugre = {"Fs": fc * u(1.1, 1.6), "vs": vmax * u(0.02, 0.08), "sigma0": sigma0,
             "sigma1": u(0.1, 1.0) * np.sqrt(sigma0 * inertia)}
    armature_share, offset_share = u(0.1, 1.5), u(-0.03, 0.03)
    friction = {"Fc": list(fc), "Fv": list(fv)}
    friction.update({k: list(v) for k, v in {"stribeck": stribeck, "lugre": lugre}.get(law, {}).items()})
    if one:
        armature = np.zeros(1)  # the system's J holds it
    else:
        armature = robot.mass_diag(centre) * armature_share
        if law == "mujoco":  # MuJoCo needs some armature on light distal links for its stiff PD
            armature = np.maximum(armature, 1e-3)
    offset = size * offset_share
    effort_sigma = size * rn.uniform(0.004, 0.02, nj)
    pos_sigma = float(np.exp(rn.uniform(np.log(5e-7), np.log(1e-5))))
    details = {"coloured": {"cutoff_hz": float(min(rn.uniform(2.0, 30.0), 0.3 * rate)), "white_share": 0.3},
               "quantised": {"bits": int(rn.integers(12, 18))},
               "stale": {"share": float(rn.uniform(0.02, 0.15))},
               "jitter": {"sigma_periods": float(rn.uniform(0.05, 0.35))},
               "lag": {"effort_lag_s": float(rn.uniform(0.002, 0.02)),
                       "velocity_lag_s": float(rn.uniform(0.002, 0.02))},
               "reversed": {"joint": int(rn.integers(nj))}}
    detail = details.get(noise, {})
    log_velocity = bool(rn.random() < 0.5)
    tremble = sorted(int(k) for k in rt.choice(nj, size=1 if nj <= 6 else 2, replace=False))
    trembling = tremble if excitation == "trembling" else []
    if noise == "reversed" and detail["joint"] in trembling:  # a joint not excited has no fit to reverse: the next
        detail["joint"] = next(k % nj for k in range(detail["joint"], detail["joint"] + nj) if k % nj not in trembling)
    seeds = rs.integers(0, 2**31, 4)
    case = Case(sub_seed, arm, law, noise, excitation, fmt, rate, float(d_est), float(d_val), list(joints), centre,
                amp, vmax, amax, size, friction, armature, offset, one, effort_sigma, pos_sigma, detail,
                log_velocity, trembling, (int(seeds[0]), int(seeds[1])), (int(seeds[2]), int(seeds[3])))
    case.one_joint_drawn = dict(one)
    return case, robot


# --------------------------------------------------------------------------------------------- the motion
GRID_DT = 1e-3  # s: the motion is designed on this grid, then a quintic spline gives q, q̇, q̈ anywhere
PRE_ROLL = 0.5  # s before t = 0 (the lags, the MuJoCo start)


class Motion:
    """Per joint a quintic spline of the position: ``at(t)`` → q, q̇, q̈ (N, J)."""

    def __init__(self, t: np.ndarray, q: np.ndarray):
        self.splines = [make_interp_spline(t, q[:, j], k=5) for j in range(q.shape[1])]
        self.t0, self.t1 = t[0], t[-1]

    def at(self, t: np.ndarray):
        t = np.clip(np.asarray(t, dtype=float), self.t0, self.t1)
        q = np.column_stack([s(t) for s in self.splines])
        qd = np.column_stack([s(t, 1) for s in self.splines])
        qdd = np.column_stack([s(t, 2) for s in self.splines])
        return q, qd, qdd


def _smooth(x: np.ndarray, width_s: float) -> np.ndarray:
    """Convolution with a normalised Hann window (positions stay within their range)."""
    n = max(3, int(round(width_s / GRID_DT)) | 1)
    w = np.hanning(n + 2)[1:-1]
    w /= w.sum()
    pad = n // 2
    xp = np.concatenate([np.full(pad, x[0]), x, np.full(pad, x[-1])])
    return np.convolve(xp, w, mode="valid")


def _fourier(rng, t: np.ndarray, c: float, A: float, vmax: float, amax: float, envelope=None) -> np.ndarray:
    f0 = rng.uniform(0.06, 0.2)
    K = 5
    a, ph = rng.normal(0, 1, K) / np.arange(1, K + 1), rng.uniform(0, 2 * math.pi, K)
    w = 2 * math.pi * f0 * np.arange(1, K + 1)
    raw = np.sum(a[:, None] * np.sin(w[:, None] * t[None, :] + ph[:, None]), axis=0)
    if envelope is not None:
        raw = raw * envelope
    raw -= raw.mean() if envelope is None else 0.0
    d1 = np.gradient(raw, GRID_DT)
    d2 = np.gradient(d1, GRID_DT)
    s = min(A / max(np.max(np.abs(raw)), 1e-12), vmax / max(np.max(np.abs(d1)), 1e-12),
            amax / max(np.max(np.abs(d2)), 1e-12))
    return c + s * raw


def _move(p0: float, p1: float, v: float, a: float) -> np.ndarray:
    """Velocity samples (GRID_DT) of a trapezoid (or triangle) move from p0 to p1 at peak v, acceleration a."""
    D = abs(p1 - p0)
    sgn = 1.0 if p1 >= p0 else -1.0
    if D < v * v / a:
        v = math.sqrt(D * a)
    ta = v / a
    tc = (D - v * ta) / v if v > 0 else 0.0
    n_a, n_c = max(1, int(round(ta / GRID_DT))), max(0, int(round(tc / GRID_DT)))
    ramp = np.linspace(0, v, n_a, endpoint=False)
    vel = np.concatenate([ramp, np.full(n_c, v), ramp[::-1]])
    # scale so the move lands exactly on p1
    total = vel.sum() * GRID_DT
    return sgn * vel * (D / total) if total > 0 else vel


def _moves(rng, n: int, c: float, A: float, vmax: float, amax: float, kind: str) -> np.ndarray:
    lo, hi = c - A, c + A
    pos = c + rng.uniform(-0.5, 0.5) * A
    q = [np.full(int(rng.uniform(0.2, 1.0) / GRID_DT), pos)]
    count, direction = q[0].size, 1.0 if rng.random() < 0.5 else -1.0
    levels = vmax * np.array([0.02, 0.05, 0.12, 0.3, 0.7])
    while count < n:
        if kind == "trapezoid":
            v = vmax * rng.uniform(0.3, 1.0)
            target = c + direction * A * rng.uniform(0.7, 1.0)
        else:  # plateaus: constant speeds from crawling to fast, long cruises
            v = float(rng.choice(levels))
            dist = v * rng.uniform(1.5, 4.0)
            target = pos + direction * dist
            if not lo <= target <= hi:
                target = float(np.clip(target, lo, hi))
                if abs(target - pos) < 0.3 * dist:
                    direction = -direction
                    target = float(np.clip(pos + direction * dist, lo, hi))
        vel = _move(pos, target, v, amax)
        seg = pos + np.cumsum(vel) * GRID_DT
        dwell = np.full(int(rng.uniform(0.0, 0.4) / GRID_DT), target)
        q += [seg, dwell]
        count += seg.size + dwell.size
        pos = target
        direction = -direction
    return np.concatenate(q)[:n]


def design_motion(case: Case, seed: int, duration: float) -> Motion:
    """The case's excitation over [−PRE_ROLL, duration + 0.5] s within each joint's box and speed limits."""
    rng = np.random.default_rng(seed)
    t = np.arange(-PRE_ROLL, duration + 0.5 + GRID_DT / 2, GRID_DT)
    n, nj = t.size, len(case.joints)
    q = np.empty((n, nj))
    kind = case.excitation
    for j in range(nj):
        c, A, vm, am = case.centre[j], case.amplitude[j], case.vmax[j], case.amax[j]
        if kind in ("fourier",) or (kind == "trembling" and j not in case.trembling):
            q[:, j] = _fourier(rng, t, c, A, vm, am)
        elif kind == "trembling":  # not excited: a few mrad of band-limited trembling around the centre
            b, a = signal.butter(2, [1.0, 8.0], btype="band", fs=1 / GRID_DT)
            x = signal.filtfilt(b, a, rng.normal(size=n))
            q[:, j] = c + x * rng.uniform(1e-3, 4e-3) / np.std(x)
        elif kind in ("trapezoid", "plateaus"):
            q[:, j] = _smooth(_moves(rng, n, c, A, vm, am, kind), rng.uniform(0.06, 0.15))
        elif kind == "micro":  # a Fourier part fading to the centre, then micro back-and-forth blocks
            t1 = duration * rng.uniform(0.4, 0.6)
            env = np.clip((t1 - t) / 2.0, 0.0, 1.0)
            env = np.sin(0.5 * math.pi * env) ** 2
            part = _fourier(rng, t, 0.0, A, vm, am, envelope=env)
            micro = np.zeros(n)
            start = t1 + 0.3
            while start < t[-1]:
                length = rng.uniform(2.0, 4.0)
                m, f = rng.uniform(1e-4, 3e-3), rng.uniform(0.5, 3.0)
                sel = (t >= start) & (t < start + length)
                tau = (t[sel] - start) / length
                micro[sel] += m * np.sin(math.pi * tau) ** 2 * np.sin(2 * math.pi * f * (t[sel] - start))
                start += length + rng.uniform(0.2, 1.0)
            q[:, j] = c + part + micro
        else:
            raise ValueError(kind)
    return Motion(t, q)


# --------------------------------------------------------------------------------------------- friction laws
STANDSTILL = 1e-9  # rad/s: the spline's wiggle in a dwell (~1e-13) is standstill, not motion


def static_friction(case: Case, v: np.ndarray) -> np.ndarray:
    """Coulomb + viscous, or Stribeck with exponent δ, per joint on (N, J) velocities; 0 at standstill
    (|v| < ``STANDSTILL``: a dwell of the designed motion, whose spline derivative wiggles around 0 —
    its sign would flip ±Fs at random where a static law holds the joint with no friction torque)."""
    f = case.friction
    Fv, Fc = np.array(f["Fv"]), np.array(f["Fc"])
    level = Fc
    if case.law == "stribeck":
        Fs, vs, d = np.array(f["Fs"]), np.array(f["vs"]), np.array(f["delta"])
        level = Fc + (Fs - Fc) * np.exp(-((np.abs(v) / vs) ** d))
    return Fv * v + level * np.where(np.abs(v) < STANDSTILL, 0.0, np.sign(v))


def _lugre_kernel():
    try:
        from numba import njit
    except ImportError:  # pragma: no cover
        def njit(*a, **k):
            return (lambda f: f) if not a or not callable(a[0]) else a[0]

    @njit(cache=False)
    def run(v, vmid, h, Fc, Fs, vs, s0, s1, Fv):
        n, nj = v.shape
        out = np.empty((n, nj))
        for j in range(nj):
            g0 = Fc[j] + (Fs[j] - Fc[j]) * math.exp(-(v[0, j] / vs[j]) ** 2)
            z = (1.0 if v[0, j] > 0 else -1.0 if v[0, j] < 0 else 0.0) * g0 / s0[j]
            for k in range(n):
                vk = v[k, j]
                g = Fc[j] + (Fs[j] - Fc[j]) * math.exp(-(vk / vs[j]) ** 2)
                zd = vk - s0[j] * abs(vk) * z / g
                out[k, j] = s0[j] * z + s1[j] * zd + Fv[j] * vk
                if k + 1 < n:  # exact for the step's mid velocity held over the step
                    vm = vmid[k, j]
                    gm = Fc[j] + (Fs[j] - Fc[j]) * math.exp(-(vm / vs[j]) ** 2)
                    sg = 1.0 if vm > 0 else -1.0 if vm < 0 else 0.0
                    zss = sg * gm / s0[j]
                    z = zss + (z - zss) * math.exp(-s0[j] * abs(vm) * h / gm)
        return out

    return run


_LUGRE = None


def lugre_friction(case: Case, motion: Motion, t_end: float) -> tuple[np.ndarray, np.ndarray]:
    """LuGre friction (my own integration: per fine step the exact exponential solution of
    ż = v − σ0|v|z/g(v) at the step's mid velocity) on a fine grid from −PRE_ROLL: (t, F (N, J))."""
    global _LUGRE
    if _LUGRE is None:
        _LUGRE = _lugre_kernel()
    h = 5e-5
    t = np.arange(-PRE_ROLL, t_end + h / 2, h)
    f = case.friction
    _, v, _ = motion.at(t)
    _, vmid, _ = motion.at(t + h / 2)
    arr = lambda k: np.ascontiguousarray(f[k], dtype=float)
    F = _LUGRE(np.ascontiguousarray(v), np.ascontiguousarray(vmid), h, arr("Fc"), arr("Fs"), arr("vs"),
               arr("sigma0"), arr("sigma1"), arr("Fv"))
    return t, F


# --------------------------------------------------------------------------------------------- simulation
FRICTION_IMPEDANCE = 0.99  # MuJoCo solimp (d0, dwidth) of the friction-loss constraints (see simulate_mujoco)
FEEDFORWARD_SIGN_SPEED = 0.01  # rad/s: the MuJoCo controller's friction feed-forward reaches Fc·tanh(1) here


@dataclass
class Record:
    """One simulated log before its pathologies: sample times, true q, q̇ at them, the effort channel
    (noise-free, any channel lag applied) and the true noise-free joint torque at the sample times."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    effort: np.ndarray
    effort_qd: np.ndarray = None  # the velocity channel (lagged when the case lags it)


def _inverse_dynamics(case: Case, robot: Robot | None, q, qd, qdd) -> np.ndarray:
    if robot is None:
        one = case.one_joint
        tau = one["J"] * qdd
        if "g_sin" in one:
            tau = tau + one["g_sin"] * np.sin(q) + one["g_cos"] * np.cos(q)
        return tau
    return robot.rnea(q, qd, qdd) + case.armature * qdd


def simulate_prescribed(case: Case, robot: Robot | None, motion: Motion, duration: float) -> Record:
    """Inverse dynamics along the designed motion (the arm follows it exactly): Pinocchio rnea + armature
    (or the one-joint model) + the law's friction + the sensor offset, the effort channel lagged as the
    case says."""
    n = int(math.floor(duration * case.rate_hz)) + 1
    t = np.arange(n) / case.rate_hz
    lag = case.noise_detail.get("effort_lag_s", 0.0)
    te = t - lag
    q, qd, _ = motion.at(t)
    qe, qde, qdde = motion.at(te)
    tau = _inverse_dynamics(case, robot, qe, qde, qdde)
    if case.law == "lugre":
        tf, F = lugre_friction(case, motion, duration + 0.1)
        tau = tau + np.column_stack([np.interp(te, tf, F[:, j]) for j in range(F.shape[1])])
    else:
        tau = tau + static_friction(case, qde)
    vlag = case.noise_detail.get("velocity_lag_s", 0.0)
    _, qdv, _ = motion.at(t - vlag)
    return Record(t, q, qd, tau + case.offset, qdv)


def _mujoco_one_joint_xml(case: Case) -> tuple[str, float, float, float]:
    """A one-link pendulum whose inertia about the hinge matches the drawn J (gravity from the drawn
    g_sin/g_cos: a point-like mass m at distance l, in the hinge's plane)."""
    one = case.one_joint_drawn
    J = one["J"] * 0.7  # the rest of the drawn J is armature
    if "g_sin" in one:
        G = math.hypot(one["g_sin"], one["g_cos"])
        phi = math.atan2(one["g_cos"], one["g_sin"])
        l = 0.3
        m = G / (9.81 * l)
        icm = max(J - m * l * l, 0.05 * J)
        pos = f"{l * math.cos(phi):.9g} 0 {l * math.sin(phi):.9g}"
        gravity = "0 0 -9.81"
    else:
        m, icm, pos, gravity = 1.0, J * 0.5, f"{math.sqrt(J * 0.5):.9g} 0 0", "0 0 0"
    xml = f"""<mujoco><option gravity="{gravity}"/><worldbody><body name="link">
<joint name="{ONE_JOINT_NAME}" type="hinge" axis="0 1 0"/>
<inertial pos="{pos}" mass="{m:.9g}" diaginertia="{icm:.9g} {icm:.9g} {icm:.9g}"/>
</body></worldbody></mujoco>"""
    return xml, m, icm, J


def simulate_mujoco(case: Case, robot: Robot | None, motion: Motion, duration: float) -> Record:
    """MuJoCo with per-DOF damping, frictionloss and armature; the arm tracks the designed motion under
    computed torque (the model without friction) + PD; the log holds qpos, qvel and the applied torque."""
    import mujoco

    f = case.friction
    if robot is None:
        xml, _, _, _ = _mujoco_one_joint_xml(case)
        model = mujoco.MjModel.from_xml_string(xml)
    else:
        model = mujoco.MjModel.from_xml_string(robot.mujoco_xml())
    names = case.joints
    jid = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in names]
    dof = np.array([model.jnt_dofadr[k] for k in jid])
    qadr = np.array([model.jnt_qposadr[k] for k in jid])
    if robot is None:
        model.dof_armature[dof] = case.one_joint_drawn["J"] * 0.3
    else:
        model.dof_armature[dof] = case.armature
    model.dof_damping[dof] = f["Fv"]
    model.dof_frictionloss[dof] = f["Fc"]
    n_sub = max(1, int(math.ceil(1.0 / (case.rate_hz * 1e-3))))
    h = 1.0 / (case.rate_hz * n_sub)
    model.opt.timestep = h
    # frictionloss is a soft constraint: under MuJoCo's default softness (solref 0.02 s, solimp 0.9) a light
    # joint's friction is a steep viscous law that never reaches its level within the motion (xarm7 joint7,
    # armature 1e-3: 51 % of frictionloss at 1-10 rad/s), so "Fc = frictionloss" would not be in the data.
    # The stiffest stable softness (time constant 2 steps, impedance 0.99) reaches the level above ~0.01 rad/s.
    model.dof_solref[dof] = (2.0 * h, 1.0)
    model.dof_solimp[dof, :2] = FRICTION_IMPEDANCE
    data = mujoco.MjData(model)
    # truth of the one-joint model, as the product parameterises it (J, g_sin, g_cos) from MuJoCo itself
    if robot is None:
        data.qpos[:] = 0.0
        mujoco.mj_forward(model, data)
        M = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, M)
        J_total = float(M[0, 0])
        g_cos = float(data.qfrc_bias[0])
        data.qpos[:] = math.pi / 2
        mujoco.mj_forward(model, data)
        g_sin = float(data.qfrc_bias[0])
        case.one_joint = {"J": J_total, **({"g_sin": g_sin, "g_cos": g_cos} if "g_sin" in case.one_joint else {})}
    n = int(math.floor(duration * case.rate_hz)) + 1
    n_pre = int(round(PRE_ROLL / h))
    steps = n_pre + (n - 1) * n_sub + 1
    ts = (np.arange(steps) - n_pre) * h
    qr, qdr, qddr = motion.at(ts)
    # computed torque with the friction at the reference speed (a smooth sign): under a hard friction loss a
    # light joint's PD alone sticks until its error reaches Fc / kp (a UR10 wrist: 0.3 rad) and never moves
    tau_ff = (_inverse_dynamics(case, robot, qr, qdr, qddr) + np.asarray(f["Fv"]) * qdr
              + np.asarray(f["Fc"]) * np.tanh(qdr / FEEDFORWARD_SIGN_SPEED))
    mdiag = np.array([case.one_joint["J"]]) if robot is None else robot.mass_diag(case.centre) + case.armature
    w = 2 * math.pi * 6.0
    kp, kd = mdiag * w * w, 2 * 0.9 * w * mdiag
    data.qpos[qadr] = qr[0]
    data.qvel[dof] = qdr[0]
    qlog, qdlog, taulog = np.empty((steps, len(names))), np.empty((steps, len(names))), np.empty((steps, len(names)))
    for k in range(steps):
        qk, qdk = data.qpos[qadr].copy(), data.qvel[dof].copy()
        tau = tau_ff[k] + kp * (qr[k] - qk) + kd * (qdr[k] - qdk)
        data.qfrc_applied[dof] = tau
        qlog[k], qdlog[k], taulog[k] = qk, qdk, tau
        mujoco.mj_step(model, data)
    idx = n_pre + np.arange(n) * n_sub
    lag = case.noise_detail.get("effort_lag_s", 0.0)
    vlag = case.noise_detail.get("velocity_lag_s", 0.0)
    eidx = np.clip(idx - int(round(lag / h)), 0, steps - 1)
    vidx = np.clip(idx - int(round(vlag / h)), 0, steps - 1)
    t = np.arange(n) / case.rate_hz
    return Record(t, qlog[idx], qdlog[idx], taulog[eidx] + case.offset, qdlog[vidx])


# --------------------------------------------------------------------------------------------- pathologies
@dataclass
class Log:
    """A log as written: stamps, positions, velocities, efforts (N, J) and the effort channel without its
    additive noise (``clean``: the noise floor's reference, same rows and stamps)."""

    stamp: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    effort: np.ndarray
    clean: np.ndarray
    true_t: np.ndarray


def corrupt(case: Case, rec: Record, seed: int) -> Log:
    """Additive noise and the case's pathology on a simulated record (each part from its own stream: the
    same seed gives the same white noise, position noise and velocity noise whatever the pathology)."""
    r_white, r_col, r_pos, r_vel, r_stale, r_jit = (np.random.default_rng(c)
                                                    for c in np.random.SeedSequence(seed).spawn(6))
    n, nj = rec.q.shape
    d = case.noise_detail
    clean = rec.effort.copy()
    if case.noise == "reversed":
        clean[:, d["joint"]] *= -1.0
    noise = r_white.normal(size=(n, nj)) * case.effort_sigma
    if case.noise == "coloured":  # low-passed noise of the same σ, a 30 % white share
        b, a = signal.butter(2, d["cutoff_hz"], fs=case.rate_hz)
        x = signal.lfilter(b, a, r_col.normal(size=(n + 2000, nj)), axis=0)[2000:]
        x /= np.std(x, axis=0)
        share = d["white_share"]
        noise = math.sqrt(1 - share**2) * x * case.effort_sigma + share * noise
    effort = clean + noise
    q = rec.q.copy()
    if case.noise == "quantised":
        quantum = 2 * math.pi / 2 ** d["bits"]
        q = np.round(q / quantum) * quantum
    else:
        q = q + r_pos.normal(size=q.shape) * case.position_sigma
    qd = rec.effort_qd + r_vel.normal(size=q.shape) * 1e-3 * case.vmax
    stamp = rec.t.copy()
    if case.noise == "stale":  # rows that repeat the previous row's values under their own stamp
        stale = np.flatnonzero(r_stale.random(n) < d["share"])
        stale = stale[stale > 0]
        for k in stale:  # in order, so runs of stale rows repeat the last fresh one
            q[k], qd[k], effort[k], clean[k] = q[k - 1], qd[k - 1], effort[k - 1], clean[k - 1]
    if case.noise == "jitter":  # the samples are taken on the clock, their stamps are not
        stamp = stamp + r_jit.normal(size=n) * d["sigma_periods"] / case.rate_hz
    return Log(stamp, q, qd, effort, clean, rec.t)


# --------------------------------------------------------------------------------------------- writers
def write_log(case: Case, log: Log, folder: Path, name: str) -> tuple[Path, Path | None]:
    """Write the log in the case's format: (source, layout or None)."""
    folder.mkdir(parents=True, exist_ok=True)
    joints = case.joints
    if case.fmt == "csv":  # frictionid's own format
        cols = ["time"] + [f"{j}.position" for j in joints] + [f"{j}.effort" for j in joints]
        data = [log.stamp[:, None], log.q, log.effort]
        if case.log_velocity:
            cols += [f"{j}.velocity" for j in joints]
            data.append(log.qd)
        path = folder / f"{name}.csv"
        np.savetxt(path, np.hstack(data), delimiter=",", header=",".join(cols), comments="", fmt="%.10g")
        return path, None
    if case.fmt == "layout":  # another shape: ms time column (or a rate), other names, efforts apart
        rng = np.random.default_rng(case.sub_seed + 7)
        delim = str(rng.choice([",", ";"]))
        sep_effort = bool(rng.random() < 0.5)
        use_rate = case.noise != "jitter" and rng.random() < 0.5
        pos_cols = [f"pos_{k}" for k in range(len(joints))]
        eff_cols = [f"tau_{k}" for k in range(len(joints))]
        vel_cols = [f"vel_{k}" for k in range(len(joints))]
        main_cols = ([] if use_rate else ["t_ms"]) + pos_cols + (vel_cols if case.log_velocity else [])
        main = ([] if use_rate else [1000.0 * log.stamp[:, None]]) + [log.q] + ([log.qd] if case.log_velocity else [])
        if not sep_effort:
            main_cols += eff_cols
            main.append(log.effort)
        path = folder / f"{name}.txt"
        np.savetxt(path, np.hstack(main), delimiter=delim, header=delim.join(main_cols), comments="", fmt="%.10g")
        layout = ["header: true"]
        layout.append(f"rate_hz: {case.rate_hz!r}" if use_rate else "time: {column: t_ms, scale: 0.001}")
        layout.append(f"joints: [{', '.join(joints)}]")
        layout.append(f"position: [{', '.join(pos_cols)}]")
        layout.append(f"effort: [{', '.join(eff_cols)}]")
        if case.log_velocity:
            layout.append(f"velocity: [{', '.join(vel_cols)}]")
        if sep_effort:
            efile = folder / f"{name}_effort.txt"
            np.savetxt(efile, log.effort, delimiter=delim, header=delim.join(eff_cols), comments="", fmt="%.10g")
            layout.append(f"effort_file: {efile.name}")
        layout.append(f"delimiter: \"{delim}\"")
        lpath = folder / f"{name}_layout.yaml"
        lpath.write_text("\n".join(layout) + "\n")
        return path, lpath
    if case.fmt == "mcap":
        return _write_mcap(case, log, folder / f"{name}_bag"), None
    raise ValueError(case.fmt)


def _write_mcap(case: Case, log: Log, path: Path) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    JointState = ts.types["sensor_msgs/msg/JointState"]
    Header = ts.types["std_msgs/msg/Header"]
    Time = ts.types["builtin_interfaces/msg/Time"]
    t0 = 1_700_000_000_000_000_000
    stamps = t0 + np.round(log.stamp * 1e9).astype(np.int64)
    received = t0 + np.round(log.true_t * 1e9).astype(np.int64) + 200_000  # arrival order: the true order
    empty = np.zeros(0)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
        for k in range(len(stamps)):
            st = int(stamps[k])
            msg = JointState(header=Header(stamp=Time(sec=st // 1_000_000_000, nanosec=st % 1_000_000_000),
                                           frame_id=""),
                             name=list(case.joints), position=np.ascontiguousarray(log.q[k]),
                             velocity=np.ascontiguousarray(log.qd[k]) if case.log_velocity else empty,
                             effort=np.ascontiguousarray(log.effort[k]))
            writer.write(conn, int(received[k]), ts.serialize_cdr(msg, "sensor_msgs/msg/JointState"))
    return path


# --------------------------------------------------------------------------------------------- baseline
BASELINE_CUTOFF_HZ = 10.0
BASELINE_RATE_HZ = 200.0
BASELINE_TRIM_S = 1.0
BASELINE_SPEED_SHARE = 0.02


def _baseline_rows(case: Case, robot: Robot | None, log: Log, every_row: bool = False):
    """The baseline's pre-processing of one log: stamps sorted, resampled at the mean rate, Butterworth
    order 4 at 10 Hz (≤ 0.2 × rate) forward-backward, central differences, every k-th row (≈ 200 Hz), 1 s
    trimmed (``every_row``: every instant of the grid, none trimmed); (X (n, J, p), y (n, J), recorded
    (n, J), clean (n, J), keep (n, J), t (n,) the instants on the log's clock): ``y`` the effort the
    baseline fits (interpolated onto its grid), ``recorded`` and ``clean`` the recorded sample nearest each
    grid instant and its effort without noise (the noise floor's: interpolating between two samples at
    scattered stamps averages their noise, which would lower the floor by up to 18 %)."""
    order = np.argsort(log.stamp, kind="stable")
    st, q, y, clean = log.stamp[order], log.q[order], log.effort[order], log.clean[order]
    keep_t = np.concatenate([[True], np.diff(st) > 0])
    st, q, y, clean = st[keep_t], q[keep_t], y[keep_t], clean[keep_t]
    rate = (len(st) - 1) / (st[-1] - st[0])
    grid = st[0] + np.arange(len(st)) / rate
    interp = lambda a: np.column_stack([np.interp(grid, st, a[:, j]) for j in range(a.shape[1])])
    after = np.clip(np.searchsorted(st, grid), 1, len(st) - 1)
    nearest = np.where(grid - st[after - 1] <= st[after] - grid, after - 1, after)
    recorded, clean = y[nearest], clean[nearest]
    q, y = interp(q), interp(y)
    fc = min(BASELINE_CUTOFF_HZ, 0.2 * rate)
    sos = signal.butter(4, fc, fs=rate, output="sos")
    qf = signal.sosfiltfilt(sos, q, axis=0)
    qd = np.gradient(qf, 1 / rate, axis=0)
    qdd = np.gradient(qd, 1 / rate, axis=0)
    step = max(1, int(round(rate / BASELINE_RATE_HZ)))
    tt = grid - grid[0]
    pick = (np.arange(len(grid)) if every_row
            else np.flatnonzero((tt >= BASELINE_TRIM_S) & (tt <= tt[-1] - BASELINE_TRIM_S))[::step])
    qf, qd, qdd, y, recorded, clean = qf[pick], qd[pick], qdd[pick], y[pick], recorded[pick], clean[pick]
    n, nj = y.shape
    if robot is None:
        cols = [qdd[:, 0]]
        if "g_sin" in case.one_joint:
            cols += [np.sin(qf[:, 0]), np.cos(qf[:, 0])]
        rigid = np.column_stack(cols)[:, None, :]
    else:
        rigid = robot.regressor(qf, qd, qdd)
    fric = np.zeros((n, nj, 4 * nj))
    for j in range(nj):
        for c, col in enumerate((qdd[:, j], qd[:, j], np.sign(qd[:, j]), np.ones(n))):
            fric[:, j, 4 * j + c] = col
    if robot is None:
        fric = fric[:, :, 1:]  # J is the rigid column
    X = np.concatenate([rigid, fric], axis=2)
    speed = np.abs(qd)
    keep = speed >= np.maximum(BASELINE_SPEED_SHARE * np.percentile(speed, 99, axis=0), 1e-4)
    return X, y, recorded, clean, keep, grid[pick]


def product_rows(case: Case, robot: Robot | None, log: Log, residuals: Path, theta: np.ndarray,
                 uniform_clock: bool = False) -> dict:
    """The noise floor and the baseline's error on the rows the product's cross-test compares (``frictionid
    validate --residuals``): at each instant it counts (the product's clock: a bag's starts at its first
    message, a CSV's is the log's stamps or row index / rate, which are the log's stamps here), the recorded
    effort and its noise interpolated linearly between the samples around it — the sample itself at a
    sample's stamp, what the product compares where it resamples jittered stamps — then 100·‖y − y_clean‖/‖y‖
    (``floor_pct``) and 100·‖y − ŷ‖/‖y‖ of the baseline's parameters ``theta`` predicting at its grid
    instant nearest (``baseline_relerr_pct``), over the excited joints. ``uniform_clock``: the product
    replaced the stamps by a uniform clock in row order (it said so): its instants are the samples' true
    instants, each compared with its own sample (no interpolation). Also the largest distance from an
    instant to its nearest sample, in sample periods (≤ 0.5 when the clocks agree)."""
    with open(residuals) as f:
        header = f.readline().rstrip("\n").split(",")
    table = np.loadtxt(residuals, delimiter=",", skiprows=1, usecols=range(1, len(header)), ndmin=2)
    clock = log.true_t if uniform_clock else log.stamp
    t = table[:, 0] + (clock[0] if case.fmt == "mcap" or uniform_clock else 0.0)

    def nearest_of(sorted_times: np.ndarray, at: np.ndarray) -> np.ndarray:
        after = np.clip(np.searchsorted(sorted_times, at), 1, len(sorted_times) - 1)
        return np.where(at - sorted_times[after - 1] <= sorted_times[after] - at, after - 1, after)

    order = np.argsort(clock, kind="stable")
    st, effort, noise_of = clock[order], log.effort[order], (log.effort - log.clean)[order]
    rows = nearest_of(st, t)
    off = np.abs(st[rows] - t)
    X, *_, grid_t = _baseline_rows(case, robot, log, every_row=True)  # the grid is increasing
    predicted = X @ theta
    on_grid = nearest_of(grid_t, t)
    noise = power = miss = 0.0
    for k, name in enumerate(case.joints):
        if k in case.trembling or f"{name}.used" not in header:
            continue
        used = table[:, header.index(f"{name}.used") - 1] > 0.5
        if uniform_clock:
            y, e = effort[rows[used], k], noise_of[rows[used], k]
        else:
            y, e = np.interp(t[used], st, effort[:, k]), np.interp(t[used], st, noise_of[:, k])
        noise += float(np.sum(e**2))
        power += float(np.sum(y**2))
        miss += float(np.sum((y - predicted[on_grid[used], k]) ** 2))
    return {"floor_pct": 100 * math.sqrt(noise / power) if power > 0 else None,
            "baseline_relerr_pct": 100 * math.sqrt(miss / power) if power > 0 else None,
            "max_offset_periods": float(off.max() * case.rate_hz) if off.size else None}


def baseline(case: Case, robot: Robot | None, est: Log, val: Log) -> dict:
    """An independent least-squares fit on the estimation log, its relative error on the validation log's
    rows and the noise floor (the log's clean effort channel against the recorded one) on the same rows;
    ``theta`` its parameters (an array: :func:`product_rows` predicts with them, not for the JSON)."""
    Xe, ye, _, _, ke, _ = _baseline_rows(case, robot, est)
    A, b = Xe[ke], ye[ke]
    norms = np.linalg.norm(A, axis=0)
    live = norms > 1e-9 * norms.max()
    theta = np.zeros(A.shape[1])
    theta[live] = np.linalg.lstsq(A[:, live] / norms[live], b, rcond=1e-10)[0] / norms[live]
    Xv, yv, rv, cv, kv, _ = _baseline_rows(case, robot, val)
    pred = Xv @ theta
    # the error and the floor over the excited joints: a trembling joint is not fitted (the product holds
    # it, rightly), and its effort — often a large gravity torque with little noise — would lower the floor
    # of the joints that are
    excited = np.array([k not in case.trembling for k in range(len(case.joints))])
    on = kv & excited[None, :] if excited.any() else kv
    relerr = 100 * np.linalg.norm((pred - yv)[on]) / np.linalg.norm(yv[on])
    floor = 100 * np.linalg.norm((rv - cv)[on]) / np.linalg.norm(rv[on])
    per_joint = {}
    for j, name in enumerate(case.joints):
        m = kv[:, j]
        if m.sum() > 1:
            per_joint[name] = {"relerr_pct": float(100 * np.linalg.norm((pred - yv)[m, j]) / np.linalg.norm(yv[m, j])),
                               "floor_pct": float(100 * np.linalg.norm((rv - cv)[m, j]) / np.linalg.norm(rv[m, j]))}
    nf = ke.shape[1] * 4 if robot is not None else 0
    fr = theta[-nf:].reshape(-1, 4) if nf else None
    return {"relerr_pct": float(relerr), "floor_pct": float(floor), "rows": int(on.sum()),
            "per_joint": per_joint, "columns": int(live.sum()),
            "friction": ({j: {"Ia": float(fr[k, 0]), "Fv": float(fr[k, 1]), "Fc": float(fr[k, 2])}
                          for k, j in enumerate(case.joints)} if fr is not None else
                         {case.joints[0]: {"J": float(theta[0]), "Fv": float(theta[-3]), "Fc": float(theta[-2])}}),
            "theta": theta}
