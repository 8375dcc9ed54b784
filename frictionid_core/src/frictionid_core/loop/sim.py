"""A MuJoCo arm built from a Pinocchio model, with hidden joint friction (no ROS import).

The MJCF is generated from the :class:`~frictionid_core.robots.robot_model.RobotModel` (bodies,
joint placements, inertias, armature, gravity; no geometry, no contact), so MuJoCo and the
Pinocchio inverse dynamics describe the same arm. Friction is not MuJoCo's: every step applies
−f(q̇) of the core's law (:class:`~frictionid_core.friction.FrictionModel`, Stribeck + viscous
per joint, sign smoothed by tanh(v/eps)) as a generalised force. The law is stiff near v = 0,
so it is integrated semi-implicitly: f(v₀) goes to ``qfrc_applied`` and its slope c = ∂f/∂v
(≥ 0) to ``dof_damping`` under MuJoCo's ``implicitfast`` integrator — the applied friction is
f(v₀) + c·(v₁ − v₀), stable at 1 kHz for any eps. The Coulomb level (Fc and Fs) may drift:
it is scaled by 1 + drift·min(1, (t − t_start)/duration).

With ``law="lugre"`` the hidden friction is the core's LuGre law (its states stepped with the
arm, :class:`~frictionid_core.friction.StateFriction`): the Stribeck table's Fv, Fc, Fs, vs, a
bristle stiffness σ0 = Fc / :data:`BREAKAWAY_DEFLECTION` and the damping σ1 = 2·√(σ0·m) critical
for the joint's inertia m at the start. It is integrated alike: the friction at the step's end
for v₁ = v₀ and its slope in v₁ (the bristles' stiffness over the step included) go to
``qfrc_applied`` and ``dof_damping``, then the states advance with the v₁ MuJoCo found.

Under a stiff position servo (``guard_reversals``, the arm of ``frictionid experiment``) a joint slowed
near rest would chatter: away from v = 0 the tangent slope of a Stribeck hump is ≤ 0 (no implicit
damping), yet one step of the friction alone, |f(v₀)|·dt/M, can be more than |v₀|, so the velocity
flips sign every step (±0.05 rad/s on the TX40's joint 5, for ever). There the slope used is at least
the secant f(v₀)/v₀ — the friction then never carries a joint through rest within one step.

MuJoCo's own joint friction can be the hidden truth instead of (or beside) the core's law:
``damping`` (viscous, implicit) and ``frictionloss`` (dry friction as a soft constraint of
MuJoCo's solver: below its level at low speed, where the arm sticks or creeps — up to a speed that
grows with the level over the joint's inertia) per joint.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import StateFriction, get_model
from frictionid_core.robots import Payload, build_tx40, default_link, load_urdf, robot_with_payload, tx40

DT = 1e-3  # simulation step [s]
SIM_EPS = 1e-3  # sign smoothing of the hidden friction [rad/s | m/s]
_SLOPE_H = 1e-6  # step of the numerical slope ∂f/∂v [rad/s | m/s]

# Default hidden friction of a URDF arm (per joint, Stribeck): Fv [N·m·s/rad], Fc, Fs [N·m], vs [rad/s], δ.
URDF_FRICTION = {"Fv": 0.8, "Fc": 1.5, "Fs": 2.0, "vs": 0.04, "delta": 2.0}
# The hidden laws (SimArm's ``law``), and the LuGre law's break-away deflection Fc/σ0 [rad | m].
HIDDEN_LAWS = ("stribeck", "lugre")
BREAKAWAY_DEFLECTION = 5e-4
# The payload ``frictionid loop --payload-kg`` attaches to the last link: a solid cube of this edge
# [m] whose centre lies this far out along the link's z axis and a little off it [m].
PAYLOAD_EDGE_M = 0.08
PAYLOAD_COM_M = (0.01, 0.0, 0.06)


def loop_payload(robot, mass: float):
    """The loop's payload of ``mass`` [kg] on ``robot``'s last link (a :class:`~frictionid_core.robots.Payload`):
    a solid cube of :data:`PAYLOAD_EDGE_M` centred at :data:`PAYLOAD_COM_M`."""
    if not mass > 0:
        raise FrictionIdError(f"payload mass must be > 0 kg, got {mass}")
    moment = mass * PAYLOAD_EDGE_M**2 / 6.0
    return Payload(default_link(robot), float(mass), PAYLOAD_COM_M,
                   ((moment, 0.0, 0.0), (0.0, moment, 0.0), (0.0, 0.0, moment)))


def load_robot(spec: str):
    """The robot of ``spec``: ``tx40`` or ``urdf:PATH`` (a :class:`RobotModel`)."""
    if spec == "tx40":
        return build_tx40()
    if spec.startswith("urdf:"):
        return load_urdf(spec[5:])
    raise FrictionIdError(f"robot '{spec}': choose tx40 or urdf:PATH")


def hidden_friction(spec: str, joints: list[str]) -> np.ndarray:
    """The hidden Stribeck parameters (J, 5) [Fv, Fc, Fs, vs, delta] of robot ``spec``: the TX40's
    table (docs/reference.md#tx40) or :data:`URDF_FRICTION` on every joint."""
    names = get_model("stribeck").names
    if spec == "tx40":
        return np.array([[tx40.FRICTION[n][k] for n in names] for k in range(len(joints))], dtype=float)
    return np.tile([URDF_FRICTION[n] for n in names], (len(joints), 1)).astype(float)


def _axis_and_kind(jm) -> tuple[str, np.ndarray]:
    """(MuJoCo joint type, axis in the joint frame) of a 1-DOF Pinocchio joint."""
    name = jm.shortname()
    for kind, prefix in (("hinge", "JointModelR"), ("slide", "JointModelP")):
        if name.startswith(prefix):
            last = name[-1]
            if last in "XYZ" and not name.endswith("Unaligned"):
                return kind, np.eye(3)["XYZ".index(last)]
            if hasattr(jm, "axis"):
                return kind, np.asarray(jm.axis, dtype=float)
    raise FrictionIdError(f"joint type {name} has no MuJoCo counterpart here (revolute or prismatic only)")


def mjcf(robot) -> str:
    """MJCF text of ``robot`` (a RobotModel): one body per joint, inertias and armature of the
    Pinocchio model, no geometry, contacts off, ``implicitfast`` at :data:`DT`."""
    pm = robot.model
    children: dict[int, list[int]] = {}
    for i in range(1, pm.njoints):
        children.setdefault(int(pm.parents[i]), []).append(i)

    def fmt(x) -> str:
        return " ".join(f"{float(v):.17g}" for v in x)

    def body(i: int, indent: str) -> list[str]:
        jm, pl, inertia = pm.joints[i], pm.jointPlacements[i], pm.inertias[i]
        kind, axis = _axis_and_kind(jm)
        qx, qy, qz, qw = np.asarray(__import__("pinocchio").Quaternion(pl.rotation).coeffs())
        inertia_matrix = inertia.inertia
        mass = max(float(inertia.mass), 1e-9)
        lines = [f'{indent}<body name="{pm.names[i]}_link" pos="{fmt(pl.translation)}" quat="{fmt((qw, qx, qy, qz))}">',
                 f'{indent}  <inertial pos="{fmt(inertia.lever)}" mass="{mass:.17g}" '
                 f'fullinertia="{fmt(inertia_matrix[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]])}"/>',
                 f'{indent}  <joint name="{pm.names[i]}" type="{kind}" axis="{fmt(axis)}" '
                 f'armature="{float(pm.armature[jm.idx_v]):.17g}" limited="false"/>']
        for c in children.get(i, []):
            lines += body(c, indent + "  ")
        return lines + [f"{indent}</body>"]

    g = np.asarray(pm.gravity.linear, dtype=float)
    out = [f'<mujoco model="{robot.name}">',
           '  <compiler angle="radian" boundmass="1e-9" boundinertia="1e-12"/>',
           f'  <option timestep="{DT}" integrator="implicitfast" gravity="{fmt(g)}"><flag contact="disable"/></option>',
           "  <worldbody>"]
    for c in children.get(0, []):
        out += body(c, "    ")
    return "\n".join(out + ["  </worldbody>", "</mujoco>"])


class SimArm:
    """The arm of ``robot`` in MuJoCo at :data:`DT` with hidden friction ``friction`` (J, 5)
    Stribeck parameters of the core's law (None: none; ``law`` lugre: the LuGre law built from
    them, module docstring); ``q0`` start position (J,) [rad | m]; ``guard_reversals``: module docstring.
    MuJoCo's own joint friction (module docstring), each (J,) or None (none): ``damping``
    [N·m·s/rad | N·s/m], ``frictionloss`` [N·m | N]. The rotor inertias are the robot model's armature.

    :meth:`step` applies a joint torque for one step; ``q``, ``qd`` [rad, rad/s | m, m/s] and
    ``t`` [s] are the state after it, ``tau`` the torque applied, ``tau_friction`` the friction
    of the step, every kind together (N·m | N, opposing the motion: τ_cmd − τ_friction drives the arm).
    """

    def __init__(self, robot, friction: np.ndarray | None, q0: np.ndarray | None = None, eps: float = SIM_EPS, *,
                 damping: np.ndarray | None = None, frictionloss: np.ndarray | None = None, law: str = "stribeck",
                 guard_reversals: bool = False):
        import mujoco

        self._mj = mujoco
        self.robot = robot
        self.model = mujoco.MjModel.from_xml_string(mjcf(robot))
        self.data = mujoco.MjData(self.model)
        nv = self.model.nv
        if nv != robot.nv:
            raise FrictionIdError(f"MuJoCo model of {robot.name} has {nv} DOF, Pinocchio {robot.nv}")
        if law not in HIDDEN_LAWS:
            raise FrictionIdError(f"hidden friction '{law}': choose one of {', '.join(HIDDEN_LAWS)}")
        self.law = get_model(law)
        self.params = None if friction is None else np.array(friction, dtype=float).reshape(nv, 5)
        self.eps = float(eps)
        self.own_friction = damping is not None or frictionloss is not None  # MuJoCo's own as well
        self.damping = np.zeros(nv) if damping is None else np.array(damping, dtype=float).reshape(nv)
        if frictionloss is not None:
            self.model.dof_frictionloss[:] = np.asarray(frictionloss, dtype=float)
        self.model.dof_damping[:] = self.damping
        if q0 is not None:
            self.data.qpos[:] = np.asarray(q0, dtype=float)  # MuJoCo hinges and slides: one coordinate each
        mujoco.mj_forward(self.model, self.data)
        if self.law.is_dynamic and self.params is not None:
            self.params = self._lugre_params(self.params)
            self.states = StateFriction(self.law, self.params)
            self.states.reset(np.zeros(nv))
            self._trial = StateFriction(self.law, np.tile(self.params, (3, 1)))
        self.drift, self.drift_s, self._drift_t0 = 0.0, 60.0, None
        self.tau = np.zeros(nv)
        self.tau_friction = np.zeros(nv)
        self.guard_reversals = bool(guard_reversals)
        self._full_m = np.zeros((nv, nv))

    def _lugre_params(self, stribeck: np.ndarray) -> np.ndarray:
        """LuGre parameters (J, 6) from Stribeck ones (J, 5) (module docstring)."""
        sigma0 = stribeck[:, 1] / BREAKAWAY_DEFLECTION
        inertia = np.diag(self.robot.mass_matrix(self.q))
        return np.column_stack([stribeck[:, :4], sigma0, 2.0 * np.sqrt(sigma0 * inertia)])

    @property
    def t(self) -> float:
        return float(self.data.time)

    @property
    def q(self) -> np.ndarray:
        return np.array(self.data.qpos)

    @property
    def qd(self) -> np.ndarray:
        return np.array(self.data.qvel)

    def attach_payload(self, payload) -> None:
        """Fix ``payload`` (a :class:`~frictionid_core.robots.Payload`) to its link from now on: the
        MuJoCo model is rebuilt from the robot model with it, the state (q, q̇, t) carried over."""
        import mujoco

        old = self.data
        model = mujoco.MjModel.from_xml_string(mjcf(robot_with_payload(self.robot, payload)))
        model.dof_frictionloss[:] = self.model.dof_frictionloss
        model.dof_damping[:] = self.model.dof_damping
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:], data.time = old.qpos, old.qvel, old.time
        mujoco.mj_forward(model, data)
        self.model, self.data = model, data

    def start_drift(self, fraction: float, duration_s: float) -> None:
        """Scale the Coulomb level (Fc, Fs) by 1 + fraction·min(1, (t − now)/duration_s) from now on."""
        self.drift, self.drift_s, self._drift_t0 = float(fraction), max(float(duration_s), 1e-9), self.t

    def level_scale(self) -> float:
        """Factor on the Coulomb level now (1 before any drift)."""
        if self._drift_t0 is None:
            return 1.0
        return 1.0 + self.drift * min(1.0, (self.t - self._drift_t0) / self.drift_s)

    def current_params(self) -> np.ndarray:
        """Hidden parameters (J, k) of the core's law now, with the drift (zeros: none)."""
        if self.params is None:
            return np.zeros((self.model.nv, len(self.law.names)))
        p = self.params.copy()
        p[:, 1:3] *= self.level_scale()
        return p

    def friction(self, v: np.ndarray, params: np.ndarray | None = None) -> np.ndarray:
        """Hidden friction f(v) (J,) [N·m | N] of the core's Stribeck law, joint k at v[k] (not MuJoCo's own;
        a LuGre law's: of its current states)."""
        p = self.current_params() if params is None else params
        if self.law.is_dynamic:
            return StateFriction(self.law, p).reset(v) if params is not None else self.states.force(v)
        return self.law.torque_each(p, np.asarray(v, dtype=float), self.eps)

    def step(self, tau: np.ndarray) -> None:
        """Apply the joint torque ``tau`` (J,) for one step (friction semi-implicit, module docstring)."""
        d = self.data
        v0 = np.array(d.qvel)
        self.tau[:] = tau
        if self.params is None:  # MuJoCo's own friction only
            d.qfrc_applied[:] = self.tau
            self._mj.mj_step(self.model, d)
            self.tau_friction[:] = self.damping * d.qvel - d.qfrc_constraint
            return
        n = len(v0)
        p = np.tile(self.current_params(), (3, 1))  # one law call: f(v0), f(v0 + h), f(v0 − h)
        guesses = np.concatenate([v0, v0 + _SLOPE_H, v0 - _SLOPE_H])
        if self.law.is_dynamic:  # the friction at the step's end for each guess of v1, states advanced
            self.states.table[:] = p[:n].T
            self._trial.table[:] = p.T
            self._trial.z, self._trial.v = np.tile(self.states.z, (1, 3)), np.tile(self.states.v, 3)
            f = self._trial.step(guesses, self.model.opt.timestep)
        else:
            f = self.law.torque_each(p, guesses, self.eps)
        f0, c = f[:n], (f[n:2 * n] - f[2 * n:]) / (2.0 * _SLOPE_H)
        np.maximum(c, 0.0, out=c)
        if self.guard_reversals and not self.law.is_dynamic:  # module docstring
            self._mj.mj_fullM(self.model, d, self._full_m)  # of the last step's state: near enough
            with np.errstate(divide="ignore", invalid="ignore"):
                secant = np.abs(f0 / v0)
                flips = np.abs(f0) * self.model.opt.timestep / np.diag(self._full_m) > np.abs(v0)
            np.maximum(c, np.where(flips & np.isfinite(secant), secant, 0.0), out=c)
        self.model.dof_damping[:] = self.damping + c if self.own_friction else c
        d.qfrc_applied[:] = self.tau - f0 + c * v0
        self._mj.mj_step(self.model, d)
        self.tau_friction[:] = f0 + c * (np.asarray(d.qvel) - v0)
        if self.law.is_dynamic:
            self.states.step(np.array(d.qvel), self.model.opt.timestep)
        if self.own_friction:
            self.tau_friction += self.damping * d.qvel - d.qfrc_constraint
