"""A small URDF arm for tests: a continuous base pan joint and a two-finger gripper (the joints a
log of the arm does not hold) around a gravity-loaded shoulder, an elbow and a wrist; its friction."""

from __future__ import annotations

ARM = ["shoulder", "elbow", "wrist"]
FRICTION = {"pan": (0.5, 0.3), "shoulder": (1.5, 0.8), "elbow": (1.0, 0.5), "wrist": (0.4, 0.2),
            "finger_l": (0.0, 0.0), "finger_r": (0.0, 0.0)}  # (Fv, Fc)
FINGER = 0.02  # m: where the fingers stay in the recordings


def link_xml(name: str, mass: float, com: str, inertia: float) -> str:
    return (f'<link name="{name}"><inertial><origin xyz="{com}"/><mass value="{mass}"/>'
            f'<inertia ixx="{inertia}" iyy="{1.3 * inertia}" izz="{0.7 * inertia}" ixy="{0.05 * inertia}" ixz="0" '
            f'iyz="{0.1 * inertia}"/>'
            "</inertial></link>")


def joint_xml(name: str, kind: str, parent: str, child: str, xyz: str, axis: str, limit: str = "") -> str:
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>{limit}</joint>')


URDF = "".join([
    '<robot name="little_arm"><link name="base"/>',
    link_xml("turret", 3.0, "0 0 0.1", 0.02), link_xml("upper", 2.0, "0.2 0 0", 0.03),
    link_xml("fore", 1.0, "0.15 0 0.01", 0.01), link_xml("hand", 0.4, "0.05 0.01 0", 0.002),
    link_xml("left", 0.05, "0.02 0 0", 1e-4), link_xml("right", 0.05, "0.02 0 0", 1e-4),
    joint_xml("pan", "continuous", "base", "turret", "0 0 0.1", "0 0 1", '<limit effort="50" velocity="3"/>'),
    joint_xml("shoulder", "revolute", "turret", "upper", "0 0 0.3", "0 1 0",
           '<limit lower="-2" upper="2" effort="50" velocity="3"/>'),
    joint_xml("elbow", "revolute", "upper", "fore", "0.4 0 0", "0 1 0",
           '<limit lower="-2.5" upper="2.5" effort="30" velocity="3"/>'),
    joint_xml("wrist", "revolute", "fore", "hand", "0.3 0 0", "1 0 0",
           '<limit lower="-3" upper="3" effort="10" velocity="3"/>'),
    joint_xml("finger_l", "prismatic", "hand", "left", "0.08 0.02 0", "0 1 0",
           '<limit lower="0" upper="0.04" effort="5" velocity="0.1"/>'),
    joint_xml("finger_r", "prismatic", "hand", "right", "0.08 -0.02 0", "0 -1 0",
           '<limit lower="0" upper="0.04" effort="5" velocity="0.1"/>'),
    "</robot>"])
