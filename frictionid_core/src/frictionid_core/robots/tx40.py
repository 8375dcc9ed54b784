"""The Stäubli TX40 of docs/reference.md#tx40 as a Pinocchio model, its friction and noise levels.

Modified Denavit–Hartenberg (Craig/Khalil, proximal): frame i is reached from frame i−1 by
Rot_x(α_{i−1})·Trans_x(a_{i−1})·Rot_z(θ_i)·Trans_z(d_i), θ_i = q_i + θoffset_i; the base
frame sits at z = 0.32 m. Masses, first moments M·c and inertias about the DH frame origin
are given in the DH frame; Pinocchio's joint frame *is* the DH frame here, so a body is
``Inertia.FromDynamicParameters([m, mc, I_O])`` (the inertia about the frame origin, not
about the centre of mass). Rotor inertias become the model's armature.

Not in the published model (docs/reference.md#tx40) and assumed here (stated in every truth file this package writes):
acceleration limits; Stribeck Fs of joints 5 and 6 (the model gives '—'; we use 1.2·Fc so that vs
and δ of those joints mean something); the wrist 5/6 coupling friction is not modelled.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model

JOINTS = tuple(f"joint_{i}" for i in range(1, 7))
BASE_HEIGHT = 0.32
G = 9.81

# (α_{i−1}, a_{i−1}, d_i, θ offset)
DH = (
    (0.0, 0.0, 0.0, 0.0),
    (-np.pi / 2, 0.0, 0.0, -np.pi / 2),
    (0.0, 0.225, 0.035, np.pi / 2),
    (np.pi / 2, 0.0, 0.225, 0.0),
    (-np.pi / 2, 0.0, 0.0, 0.0),
    (np.pi / 2, 0.0, 0.0, np.pi),
)
MASS = (8.61, 4.85, 4.07, 3.62, 1.02, 0.20)
FIRST_MOMENT = (
    (0.0, 0.0, -0.05 * 8.61),
    (0.392, -0.0072, 0.162),
    (0.0326, 0.0244, 0.265),
    (0.0145, -0.00724, -0.586),
    (0.0, -0.00306, -0.00102),
    (0.0, 0.0, 0.0084),
)
# About the DH frame origin: (XX, XY, XZ, YY, YZ, ZZ)
INERTIA = (
    (0.424, 0.0, 0.0, 0.424, 0.0, 0.352),
    (0.0163, 7.85e-4, -0.0157, 0.0881, 3.24e-4, 0.0828),
    (0.0223, -1.95e-4, -1.16e-3, 0.0224, -2.22e-3, 4.41e-3),
    (0.109, 2.9e-5, 1.35e-3, 0.108, -1.17e-3, 4.07e-3),
    (1.01e-3, 0.0, 0.0, 1.00e-3, -3.06e-6, 1.01e-3),
    (3.53e-3, 0.0, 0.0, 3.53e-3, 0.0, 3.53e-4),
)
ROTOR_INERTIA = (0.362, 0.507, 0.0829, 0.0341, 0.0361, 0.0114)
GEAR_RATIO = (32, 32, 45, 48, 45, 32)
DRIVE_GAIN = (35.24, 32.04, 23.94, 9.05, 15.5, 6.56)

_DEG = np.pi / 180.0
LOWER = tuple(x * _DEG for x in (-180.0, -125.0, -138.0, -270.0, -120.0, -270.0))
UPPER = tuple(x * _DEG for x in (180.0, 125.0, 138.0, 270.0, 133.5, 270.0))
VELOCITY_LIMIT = tuple(x * _DEG for x in (287.0, 287.0, 430.0, 410.0, 320.0, 700.0))
ACCELERATION_LIMIT = (10.0, 10.0, 15.0, 20.0, 20.0, 30.0)  # assumed (not published), rad/s²
# Joint torque limits, N·m: the <limit effort> of FIGAROH's TX40 URDF (tx40_mdh_modified.urdf of its
# Stäubli TX40 example, whose velocity limits are the ones above); not in docs/reference.md#tx40.
EFFORT_LIMIT = (131.84, 131.84, 103.49, 46.08, 43.19, 30.72)

# Friction (docs/reference.md#tx40), symmetric Stribeck: Fv·v + [Fc + (Fs−Fc)·exp(−(|v|/vs)^δ)]·sign(v)
FRICTION = {
    "Fv": (7.9379, 5.6948, 1.9804, 1.1141, 1.60, 0.6894),
    "Fc": (6.9822, 7.8301, 6.1939, 2.4063, 3.4092, 1.8313),
    "Fs": (4.78, 7.97, 5.81, 2.15, 1.2 * 3.4092, 1.2 * 1.8313),  # joints 5, 6 assumed
    "vs": (0.025, 0.05, 0.05, 0.05, 0.05, 0.05),
    "delta": (2.09, 2.78, 2.72, 1.60, 2.0, 2.0),
}
# 1σ noise: position (docs/reference.md#tx40-limits, 1e−3 deg) in rad; torque N·m.
POSITION_NOISE = tuple(x * 1e-3 * _DEG for x in (0.057, 0.057, 0.122, 0.114, 0.122, 0.172))
TORQUE_NOISE = 0.05

# Where joints other than joint 2 are held for the thesis joint-2 protocol (rad).
JOINT2_HOLD = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

ASSUMPTIONS = (
    "acceleration limits (10, 10, 15, 20, 20, 30) rad/s² are assumed (not in SPEC)",
    "Stribeck Fs of joints 5 and 6 is assumed to be 1.2·Fc (SPEC gives none)",
    "the joint 5/6 wrist coupling friction (Fv 0.8, Fc 1.6) is not modelled",
)


def _placement(alpha: float, a: float, d: float, theta: float, z0: float = 0.0):
    import pinocchio as pin

    def rot(axis, ang):
        c, s = np.cos(ang), np.sin(ang)
        if axis == "x":
            return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    return (pin.SE3(np.eye(3), np.array([0.0, 0.0, z0])) * pin.SE3(rot("x", alpha), np.zeros(3))
            * pin.SE3(np.eye(3), np.array([a, 0.0, 0.0])) * pin.SE3(rot("z", theta), np.array([0.0, 0.0, d])))


def body_parameters(k: int) -> np.ndarray:
    """Standard parameters [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] of link k (0-based)."""
    xx, xy, xz, yy, yz, zz = INERTIA[k]
    return np.array([MASS[k], *FIRST_MOMENT[k], xx, xy, yy, xz, yz, zz], dtype=float)


def build_tx40():
    """The TX40 :class:`~frictionid_core.robots.robot_model.RobotModel` (joints ``joint_1`` … ``joint_6``)."""
    import pinocchio as pin

    from frictionid_core.robots.robot_model import from_pinocchio

    model = pin.Model()
    model.name = "tx40"
    parent = 0
    for k, (alpha, a, d, theta) in enumerate(DH):
        placement = _placement(alpha, a, d, theta, BASE_HEIGHT if k == 0 else 0.0)
        parent = model.addJoint(parent, pin.JointModelRZ(), placement, JOINTS[k],
                                np.array([EFFORT_LIMIT[k]]), np.array([VELOCITY_LIMIT[k]]),
                                np.array([LOWER[k]]), np.array([UPPER[k]]))
        model.appendBodyToJoint(parent, pin.Inertia.FromDynamicParameters(body_parameters(k)), pin.SE3.Identity())
    model.armature[:] = np.array(ROTOR_INERTIA)
    return from_pinocchio(model, "tx40", "docs/reference.md#tx40 (modified DH)", np.array(ACCELERATION_LIMIT))


def joint2_columns(q: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """Thesis joint-2 model columns (ZZ, MX, MY): [q̈, −g·cos q, g·sin q], each (N,) → (N, 3)."""
    return np.column_stack([qdd, -G * np.cos(q), G * np.sin(q)])


def joint2_effective_parameters(robot=None, hold=JOINT2_HOLD) -> dict[str, float]:
    """The thesis model's (ZZ, MX, MY) that the full model reduces to when only joint 2 moves
    and the other joints stay at ``hold``: ZZ = M₂₂ (links 2…6 + rotor), MX, MY from an exact
    least-squares fit of the Pinocchio gravity torque g₂ = −g·MX·cos θ + g·MY·sin θ in the DH
    angle θ = q₂ − π/2 (the thesis' convention: MX ≈ 2.9 > 0 with the arm horizontal at q₂ = π/2).
    With one joint moving there is no Coriolis/centrifugal torque on it (∂M₂₂/∂q₂ = 0)."""
    robot = robot or build_tx40()
    q2 = np.linspace(-np.pi, np.pi, 73)
    q = np.tile(np.asarray(hold, dtype=float), (q2.size, 1))
    q[:, 1] = q2
    g2 = robot.gravity(q)[:, 1]
    theta = q2 + DH[1][3]
    A = np.column_stack([-G * np.cos(theta), G * np.sin(theta)])
    (mx, my), *_ = np.linalg.lstsq(A, g2, rcond=None)
    fit = float(np.max(np.abs(A @ [mx, my] - g2)))
    zz = robot.mass_matrix(q[0])[1, 1]
    return {"ZZ": float(zz), "MX": float(mx), "MY": float(my), "_gravity_fit_max_abs": fit}


def published_friction(friction: str, asymmetric: bool) -> dict[str, dict[str, float]]:
    """The published friction of the TX40 (docs/reference.md#tx40-friction) for the law ``friction``
    (asymmetric: the v < 0 branch has 0.85·Fv, 0.85·Fc, 0.85·Fs and the same vs, δ — an assumption,
    the published model is symmetric)."""
    if friction == "threlfall" or get_model(friction).is_dynamic:
        raise FrictionIdError(f"the published TX40 model has no {friction} parameters; pass --friction-params")
    names = get_model(friction, False).names
    out = {}
    for k, j in enumerate(JOINTS):
        sym = {n: float(FRICTION[n][k]) for n in names}
        if not asymmetric:
            out[j] = sym
        else:
            neg = {n: (0.85 * v if n in ("Fv", "Fc", "Fs") else v) for n, v in sym.items()}
            out[j] = {**{f"{n}_pos": v for n, v in sym.items()}, **{f"{n}_neg": v for n, v in neg.items()}}
    return out
