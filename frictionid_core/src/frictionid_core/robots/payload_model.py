"""A payload: a rigid body fixed to a link of a robot (a tool, a gripper, a held part).

Its ten standard parameters are those of a Pinocchio body, in the link's frame: [m, m·c, I_o]
(``m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz``, I_o about the link frame's origin), named
``payload.<p>`` (:data:`PAYLOAD_NAMES`). The link is a body frame of the robot model (a URDF
link, fixed ones such as ``tool0`` included; the built-in TX40's links are ``link_1`` …
``link_6``); the body it is fixed to is the one its parent joint moves, so the payload's
torque is that body's columns of the joint torque regressor, its parameters carried from the
link frame into the joint frame by the rigid transform between them (linear in the ten
parameters: the pseudo-inertia J ↦ H·J·Hᵀ, H the link frame's pose in the joint frame).

:class:`Payload` is the record a payload file holds (mass kg, centre of mass m in the link
frame, inertia kg·m² about the centre of mass in the link's axes, their σ, what the data
resolved); :func:`with_payload` adds its ten columns to a robot system;
:func:`robot_with_payload` fixes it to a robot model (synthetic data, the simulated arm).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from frictionid_core.consistency import PSEUDO_INERTIA_BASIS, body_report
from frictionid_core.errors import InputError
from frictionid_core.robots.robot_model import BODY_PARAMS

PAYLOAD = "payload"
PAYLOAD_NAMES = tuple(f"{PAYLOAD}.{p}" for p in BODY_PARAMS)
# The payload's physical quantities, as its ``resolved`` list names them.
QUANTITIES = ("mass", "com.x", "com.y", "com.z", "inertia.xx", "inertia.yy", "inertia.zz", "inertia.xy",
              "inertia.xz", "inertia.yz")
INERTIA_ENTRIES = {"xx": (0, 0), "yy": (1, 1), "zz": (2, 2), "xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
# A point mass as the held value of an inertia the data do not resolve: a solid sphere of this
# radius (m) about its centre (0.4·m·r² on the diagonal), so its pseudo-inertia stays positive definite.
POINT_RADIUS_M = 0.01


def link_name(joint: str) -> str:
    """The name of the link a joint of a model without link frames moves (``joint_6`` → ``link_6``;
    the URDF ``export`` writes of such a model names its links so)."""
    return joint.replace("joint", "link") if "joint" in joint else f"{joint}_link"


def link_frames(robot) -> dict[str, tuple[int, object]]:
    """{link name: (Pinocchio joint index of the body it is fixed to, its pose in that joint's
    frame (pinocchio.SE3))} of a RobotModel: its body frames (URDF links) in model order; a
    moving joint without a body frame (a model built in code) gives ``link_<k>``."""
    import pinocchio as pin

    m = robot.model
    out = {}
    for frame in m.frames:
        if frame.type == pin.FrameType.BODY:
            out[frame.name] = (int(frame.parentJoint), frame.placement.copy())
    having = {j for j, _ in out.values()}
    for i in range(1, m.njoints):
        if i not in having:
            out[link_name(m.names[i])] = (i, pin.SE3.Identity())
    return out


def default_link(robot) -> str:
    """The last link of the chain: the last body frame fixed to the model's last joint."""
    frames = link_frames(robot)
    last = robot.model.njoints - 1
    return [name for name, (joint, _) in frames.items() if joint == last][-1]


def link_frame(robot, link: str | None) -> tuple[str, int, object]:
    """(link name, joint index, pose in the joint frame) of ``link`` (default: :func:`default_link`);
    InputError naming the link when the model has no such link or it is fixed to the base."""
    frames = link_frames(robot)
    name = default_link(robot) if link is None else link
    if name not in frames:
        shown = ", ".join(list(frames)[-8:])
        raise InputError(f"link '{name}' is not a link of {robot.name} (its last links: {shown})")
    joint, pose = frames[name]
    if joint == 0:
        raise InputError(f"link '{name}' of {robot.name} is fixed to the base: a payload there moves no joint")
    return name, joint, pose


def parameters_of(J: np.ndarray) -> np.ndarray:
    """[m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] of a 4×4 pseudo-inertia (inverse of
    :func:`~frictionid_core.consistency.check.pseudo_inertia`)."""
    sigma = J[:3, :3]
    I_o = np.trace(sigma) * np.eye(3) - sigma
    return np.array([J[3, 3], *J[:3, 3], I_o[0, 0], I_o[0, 1], I_o[1, 1], I_o[0, 2], I_o[1, 2], I_o[2, 2]])


def frame_map(pose) -> np.ndarray:
    """(10, 10) T with π_joint = T·π_link: a body's standard parameters in the link frame carried
    into the joint frame where the link sits at ``pose`` (pinocchio.SE3)."""
    H = np.eye(4)
    H[:3, :3], H[:3, 3] = pose.rotation, pose.translation
    return np.column_stack([parameters_of(H @ E @ H.T) for E in PSEUDO_INERTIA_BASIS])


def body_parameters(mass: float, com, inertia) -> np.ndarray:
    """Standard parameters [m, m·c, I_o] of a body of ``mass`` (kg) at ``com`` (3,) with
    ``inertia`` (3, 3) about it (kg·m²), all in one frame."""
    c = np.asarray(com, dtype=float)
    I_o = np.asarray(inertia, dtype=float) + mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([mass, *(mass * c), I_o[0, 0], I_o[0, 1], I_o[1, 1], I_o[0, 2], I_o[1, 2], I_o[2, 2]])


def body_quantities(p: np.ndarray) -> np.ndarray:
    """The :data:`QUANTITIES` (m, c, inertia about c) of standard parameters ``p`` (10,) with m > 0."""
    m, h = p[0], p[1:4]
    c = h / m
    I_o = np.array([[p[4], p[5], p[7]], [p[5], p[6], p[8]], [p[7], p[8], p[9]]])
    Ic = I_o - m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([m, *c, *(Ic[a, b] for a, b in INERTIA_ENTRIES.values())])


def point_inertia(mass: float) -> np.ndarray:
    """The inertia (3, 3) about its centre of the point mass :data:`POINT_RADIUS_M` stands for."""
    return 0.4 * mass * POINT_RADIUS_M**2 * np.eye(3)


def _matrix(entries: dict[str, float | None]) -> list[list[float | None]]:
    """The symmetric 3×3 of {xx, yy, zz, xy, xz, yz} entries."""
    out = [[None] * 3 for _ in range(3)]
    for key, (a, b) in INERTIA_ENTRIES.items():
        out[a][b] = out[b][a] = entries[key]
    return out


@dataclass(frozen=True)
class Payload:
    """A rigid body fixed to ``link``.

    Attributes:
        link: the robot link it is fixed to (a body frame of the model).
        mass: kg; com: centre of mass (3,), m, in the link frame; inertia: (3, 3) about the
            centre of mass, link axes, kg·m².
        sigma: {"mass": σ, "com": [3], "inertia": [[3×3]]} (None for what the data did not
            resolve), or None (a payload typed by hand).
        feasible: its pseudo-inertia is positive definite (a density can realise it).
        resolved: the quantities (:data:`QUANTITIES`) the data determined; the others are held.
    """

    link: str
    mass: float
    com: tuple[float, float, float]
    inertia: tuple[tuple[float, ...], ...]
    sigma: dict | None = None
    feasible: bool = True
    resolved: tuple[str, ...] = field(default=QUANTITIES)

    def standard(self) -> np.ndarray:
        """Its standard parameters (10,) in the link frame (:data:`PAYLOAD_NAMES` order)."""
        return body_parameters(self.mass, self.com, self.inertia)

    def parameters(self) -> dict[str, float]:
        """{payload.<p>: value} (link frame)."""
        return dict(zip(PAYLOAD_NAMES, map(float, self.standard())))

    @classmethod
    def from_standard(cls, link: str, p: np.ndarray, sigma: dict | None = None,
                      resolved: tuple[str, ...] = QUANTITIES) -> Payload:
        """The payload of standard parameters ``p`` (10,) in ``link``'s frame (m > 0), with its
        ``sigma`` and ``resolved`` (as the attributes)."""
        q = body_quantities(np.asarray(p, dtype=float))
        inertia = _matrix(dict(zip(INERTIA_ENTRIES, map(float, q[4:]))))
        feasible = body_report(np.asarray(p, dtype=float))["consistent"]
        return cls(link, float(q[0]), tuple(map(float, q[1:4])), tuple(map(tuple, inertia)), sigma, feasible,
                   tuple(resolved))

    def to_dict(self) -> dict:
        """The ``payload`` block of a payload file (the keys in their contract order)."""
        return {"link": self.link, "mass": self.mass, "com": list(self.com), "inertia": [list(r) for r in self.inertia],
                "sigma": self.sigma, "feasible": bool(self.feasible), "resolved": list(self.resolved)}

    @classmethod
    def from_dict(cls, data, where: str = "payload") -> Payload:
        """The payload of a ``payload`` block; InputError naming the key at fault."""
        if not isinstance(data, dict):
            raise InputError(f"{where}: expected an object with link, mass, com, inertia, got {type(data).__name__}")
        missing = [k for k in ("link", "mass", "com", "inertia") if k not in data]
        if missing:
            raise InputError(f"{where} lacks {', '.join(map(repr, missing))}: expected the 'payload' block "
                             "written by 'frictionid payload'")
        link = data["link"]
        if not isinstance(link, str) or not link:
            raise InputError(f"{where}: key 'link' must be a link name, got {link!r}")
        mass = _finite(data["mass"], f"{where}: key 'mass'")
        if mass <= 0:
            raise InputError(f"{where}: key 'mass' must be > 0 kg, got {mass:g}")
        com = _array(data["com"], (3,), f"{where}: key 'com'")
        inertia = _array(data["inertia"], (3, 3), f"{where}: key 'inertia'")
        if not np.allclose(inertia, inertia.T, rtol=1e-9, atol=1e-12):
            raise InputError(f"{where}: key 'inertia' is not symmetric: {inertia.tolist()}")
        resolved = data.get("resolved", list(QUANTITIES))
        if not isinstance(resolved, list) or any(r not in QUANTITIES for r in resolved):
            raise InputError(f"{where}: key 'resolved' must list names of {list(QUANTITIES)}, got {resolved!r}")
        p = body_parameters(mass, com, inertia)
        return cls(link, mass, tuple(map(float, com)), tuple(map(tuple, inertia.tolist())), data.get("sigma"),
                   body_report(p)["consistent"], tuple(resolved))


def _finite(value, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise InputError(f"{what} must be a finite number, got {value!r}")
    return float(value)


def _array(value, shape: tuple[int, ...], what: str) -> np.ndarray:
    try:
        out = np.array(value, dtype=float)
    except (TypeError, ValueError):
        out = None
    if out is None or out.shape != shape or not np.all(np.isfinite(out)):
        raise InputError(f"{what} must be {'×'.join(map(str, shape))} finite numbers, got {value!r}")
    return out


def with_payload(system, link: str | None = None):
    """``system`` (a robot System) with the ten columns of a payload fixed to ``link`` (default:
    the last link) after its rigid columns, named :data:`PAYLOAD_NAMES` (link frame); the
    standard regressor is evaluated once for both."""
    info = system.robot
    if info is None:
        raise InputError(f"system '{system.name}' has no robot model: a payload needs tx40 or urdf:PATH")
    _, joint, pose = link_frame(info.model, link)
    body = slice(10 * (joint - 1), 10 * joint)
    T = frame_map(pose)
    width = info.base.rank + len(PAYLOAD_NAMES)

    def reduce(Y: np.ndarray) -> np.ndarray:
        return np.concatenate([info.base.reduce(Y), Y[..., body] @ T], axis=-1)

    def columns(p, joints: list[str], rows: list[str] | None = None) -> np.ndarray:
        return info.regressor_columns(p.q, p.qd, p.qdd, joints, rows, reduce, width)

    bounds = dict(system.rigid_bounds, **dict.fromkeys(PAYLOAD_NAMES, (-1e3, 1e3)))
    return replace(system, columns=columns, rigid_names=tuple(system.rigid_names) + PAYLOAD_NAMES,
                   rigid_bounds=bounds)


def payload_link(payload: Payload, parent: str, name: str = PAYLOAD):
    """The URDF ``<link>`` of ``payload`` (named ``name``) and the fixed ``<joint>`` holding it to
    the link ``parent`` (ElementTree elements): its inertial in the link frame."""
    import xml.etree.ElementTree as ET

    def text(values) -> str:
        return " ".join(repr(float(v)) for v in np.atleast_1d(values))

    link = ET.Element("link", name=name)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz=text(payload.com), rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=text(payload.mass))
    ET.SubElement(inertial, "inertia", **{f"i{key}": text(payload.inertia[a][b])
                                          for key, (a, b) in INERTIA_ENTRIES.items()})
    joint = ET.Element("joint", name=f"{name}_fixed_joint", type="fixed")
    ET.SubElement(joint, "origin", xyz="0 0 0", rpy="0 0 0")
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=name)
    return link, joint


def robot_with_payload(robot, payload: Payload):
    """A copy of ``robot`` (a RobotModel) with ``payload`` fixed to its link (the body that link
    belongs to gains the payload's inertia)."""
    import pinocchio as pin

    _, joint, pose = link_frame(robot, payload.link)
    model = robot.model.copy()
    body = pin.Inertia(payload.mass, np.asarray(payload.com, dtype=float), np.asarray(payload.inertia, dtype=float))
    model.inertias[joint] = model.inertias[joint] + pose.act(body)
    return replace(robot, model=model)

