"""The limits an excitation is kept within (``frictionid excite``): per joint position, velocity,
acceleration and effort, the effort being the model's inverse dynamics plus a joint friction
(:class:`JointFriction`: an identification result's, or a nominal one); :func:`verify` gives the worst
ratio of each kind (and the smallest distance of a :class:`~.collision.CollisionModel`) over a
trajectory sampled on a fine grid. The design itself: :mod:`.excitation_design`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import InputError

NOMINAL_FRICTION_SHARE = 0.05  # nominal guess: Fc and Fv·v_max each this share of the effort limit
SIGN_SPEED = 0.05  # rad/s (m/s): the Coulomb step spread over ±this in friction slopes


# ------------------------------------------------------------------------------------- friction
@dataclass
class JointFriction:
    """Per joint a friction law and its parameters (None: no friction), and where they come from."""

    joints: list[str]
    laws: list
    source: str

    def torque(self, qd: np.ndarray) -> np.ndarray:
        """τ_f (N, nv) at velocities qd (N, nv) (sign(0) = 0: no friction at rest)."""
        out = np.zeros_like(qd)
        for k, law in enumerate(self.laws):
            if law is not None:
                out[:, k] = law[0].torque(law[1], qd[:, k])
        return out

    def slope(self, qd: np.ndarray, dv: float = SIGN_SPEED) -> np.ndarray:
        """∂τ_f/∂q̇ (N, nv) over ±dv (the Coulomb step spread over 2·dv: a gradient for the optimiser)."""
        return (self.torque(qd + dv) - self.torque(qd - dv)) / (2.0 * dv)

    def to_dict(self) -> dict:
        return {"source": self.source,
                "joints": {j: ({"law": law[0].label, **dict(zip(law[0].names, map(float, law[1])))}
                               if law is not None else None) for j, law in zip(self.joints, self.laws)}}


def nominal_friction(robot) -> JointFriction:
    """The friction assumed without a result: the TX40's published Stribeck friction; a URDF joint's
    ``<dynamics damping friction>`` when it has one; else Fc = 5 % of the effort limit and Fv such that
    Fv·v_max is another 5 % (none for a joint without an effort limit)."""
    from frictionid_core.friction import get_model

    coulomb = get_model("coulomb")
    if robot.name == "tx40" and robot.source.startswith("docs/reference.md"):
        from frictionid_core.robots import tx40

        law = get_model("stribeck")
        table = tx40.published_friction("stribeck", False)
        return JointFriction(list(robot.joints), [(law, np.array([table[j][n] for n in law.names]))
                                                  for j in robot.joints], "the TX40's published friction")
    effort = effort_limits(robot)
    damping = np.nan_to_num(np.asarray(robot.model.damping, float))
    dry = np.nan_to_num(np.asarray(robot.model.friction, float))
    laws, kinds = [], set()
    for k in range(robot.nv):
        if damping[k] > 0 or dry[k] > 0:
            laws.append((coulomb, np.array([damping[k], dry[k]])))
            kinds.add("the URDF's <dynamics>")
        elif np.isfinite(effort[k]):
            vmax = robot.velocity_limit[k] if np.isfinite(robot.velocity_limit[k]) else 1.0
            share = NOMINAL_FRICTION_SHARE * effort[k]
            laws.append((coulomb, np.array([share / vmax, share])))
            kinds.add("a nominal guess (Fc and Fv·v_max each 5 % of the effort limit)")
        else:
            laws.append(None)
    return JointFriction(list(robot.joints), laws, " and ".join(sorted(kinds)) or "none")


def result_friction(result: dict, robot, where: str) -> JointFriction:
    """The friction of an identification result (``frictionid identify --json``) on the robot's joints
    (through the result's joint map); a dynamic law by its sliding limit; joints the result lacks keep
    the nominal friction (:func:`nominal_friction`)."""
    from frictionid_core.drive import friction_rows
    from frictionid_core.friction import elements_of, get_model

    if result.get("drive") and result["drive"].get("friction_on") == "motor":
        raise InputError(f"{where}: its friction acts on the drive's motors; --params takes a result with "
                         "friction on the joints")
    model = get_model(result["friction"], bool(result["asymmetric"]), elements_of(result["friction"],
                                                                                   result["params"]))
    rows = friction_rows(result)
    joint_map = result.get("joint_map") or {}
    nominal = nominal_friction(robot)
    laws = list(nominal.laws)
    found = []
    for row in rows:
        joint = joint_map.get(row, row)
        if joint not in robot.joints:
            raise InputError(f"{where}: joint '{joint}' of the result is not a joint of {robot.name} {robot.joints}")
        prefix = f"{row}/" if len(rows) > 1 else ""
        missing = [prefix + n for n in model.names if prefix + n not in result["params"]]
        if missing:
            raise InputError(f"{where}: no friction parameter {missing[0]} for {model.label}")
        law, values = model.static_equivalent(np.array([result["params"][prefix + n] for n in model.names], float))
        laws[robot.joints.index(joint)] = (law, values)
        found.append(joint)
    rest = [j for j in robot.joints if j not in found]
    source = f"{where} ({model.label})" + (f"; {', '.join(rest)}: {nominal.source}" if rest else "")
    return JointFriction(list(robot.joints), laws, source)


# --------------------------------------------------------------------------------------- limits
def effort_limits(robot) -> np.ndarray:
    """(nv,) the model's effort limits (URDF ``<limit effort>``); inf where none (≤ 0 or absent)."""
    e = np.asarray(robot.model.effortLimit, dtype=float)[: robot.nv]
    return np.where(np.isfinite(e) & (e > 0), e, np.inf)


@dataclass
class Limits:
    """What :func:`design_excitation` keeps the motion within (each (nv,), robot joint order)."""

    lower: np.ndarray  # finite: ±π for a joint without position limits
    upper: np.ndarray
    velocity: np.ndarray  # inf: no limit
    acceleration: np.ndarray
    effort: np.ndarray
    friction: JointFriction
    margin: float

    @property
    def centre(self) -> np.ndarray:
        return (self.lower + self.upper) / 2.0

    @property
    def half(self) -> np.ndarray:
        return (self.upper - self.lower) / 2.0

    def to_dict(self, joints: list[str]) -> dict:
        num = lambda x: float(x) if np.isfinite(x) else None
        return {j: {"lower": float(self.lower[k]), "upper": float(self.upper[k]), "velocity": num(self.velocity[k]),
                    "acceleration": num(self.acceleration[k]), "effort": num(self.effort[k])}
                for k, j in enumerate(joints)}


def robot_limits(robot, margin: float = 0.05, acceleration: dict[str, float] | float | None = None,
                 friction: JointFriction | None = None) -> Limits:
    """The robot's limits; ``acceleration`` replaces its acceleration limits (one value for all joints,
    or per joint name; default the model's: the TX40's table, 10 rad/s² for a URDF)."""
    if not (np.isfinite(margin) and 0 <= margin < 1):
        raise InputError(f"--margin must be a fraction in [0, 1), got {margin:g}")
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    acc = np.array(robot.acceleration_limit, dtype=float)
    if isinstance(acceleration, dict):
        unknown = [j for j in acceleration if j not in robot.joints]
        if unknown:
            raise InputError(f"--max-acc: joint '{unknown[0]}' is not a joint of {robot.name} {robot.joints}")
        for j, v in acceleration.items():
            acc[robot.joints.index(j)] = v
    elif acceleration is not None:
        acc[:] = acceleration
    bad = [j for j, v in zip(robot.joints, acc) if not (np.isfinite(v) and v > 0)]
    if bad:
        raise InputError(f"--max-acc: the acceleration limit of joint '{bad[0]}' must be > 0")
    return Limits(lo, hi, np.array(robot.velocity_limit, float), acc, effort_limits(robot),
                  friction or nominal_friction(robot), float(margin))


def motion_ratios(robot, limits: Limits, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> dict[str, np.ndarray]:
    """Per kind the ratio (N, nv) of each sample to its limit (position: |q − centre|/half-range)."""
    tau = robot.inverse_dynamics(q, qd, qdd) + limits.friction.torque(qd)
    with np.errstate(divide="ignore", invalid="ignore"):
        return {"position": np.abs(q - limits.centre) / limits.half,
                "velocity": np.abs(qd) / limits.velocity, "acceleration": np.abs(qdd) / limits.acceleration,
                "effort": np.abs(tau) / limits.effort}


def verify(robot, limits: Limits, traj, rate: float = 1000.0, collision=None) -> dict:
    """The worst ratio per limit kind (and where), and the smallest distance of the collision pairs,
    over the trajectory sampled at ``rate``; ``ok``: every ratio ≤ 1 − margin and every distance ≥ the
    clearance."""
    t, q, qd, qdd = traj.sample(rate)
    ratios = motion_ratios(robot, limits, q, qd, qdd)
    out = {"rate_hz": rate, "max_ratio": {}, "worst": {}, "ok": True, "violations": []}
    for kind, r in ratios.items():
        k, j = np.unravel_index(int(np.argmax(r)), r.shape)
        out["max_ratio"][kind] = float(r[k, j])
        out["worst"][kind] = {"joint": robot.joints[j], "t": float(t[k])}
        if r[k, j] > 1.0 - limits.margin + 1e-9:
            out["ok"] = False
            bad = np.flatnonzero(r.max(axis=1) > 1.0 - limits.margin + 1e-9)
            out["violations"].append((kind, robot.joints[j], float(r[k, j]), t[bad]))
    if collision is not None:
        d = collision.distances(q)
        k, p = np.unravel_index(int(np.argmin(d)), d.shape)
        out["min_clearance_m"] = float(d[k, p])
        out["closest"] = {"pair": collision.pairs[p], "t": float(t[k])}
        if d[k, p] < collision.clearance - 1e-9:
            out["ok"] = False
            bad = np.flatnonzero(d.min(axis=1) < collision.clearance - 1e-9)
            out["violations"].append(("clearance", collision.pairs[p], float(d[k, p]), t[bad]))
    return out


def violation_text(report: dict, margin: float) -> str:
    parts = []
    for kind, who, value, times in report["violations"]:
        if kind == "clearance":
            parts.append(f"pair {who} {value * 1000:.3g} mm apart (first at t = {times[0]:.4g} s)")
        else:
            parts.append(f"joint '{who}' {kind} at {value:.4g} of its limit > {1 - margin:.4g} "
                         f"(first at t = {times[0]:.4g} s)")
    return "; ".join(parts)
