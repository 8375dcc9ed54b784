"""ROS messages of the node's results and diagnostics, built from plain values."""

from __future__ import annotations

import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
    from builtin_interfaces.msg import Time
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from frictionid_interfaces.msg import IdentifiedParameters, JointFriction
    from geometry_msgs.msg import Inertia, Vector3

from frictionid_ros.inputs import NS
from frictionid_ros.store import JointParams, Results, shared_parameters

NAN = float("nan")


def to_time(ns: int) -> Time:
    """ns since the epoch as a builtin_interfaces/Time."""
    ns = int(ns)
    return Time(sec=ns // NS, nanosec=ns % NS)


def joint_friction(p: JointParams) -> JointFriction:
    m = p.metrics
    return JointFriction(
        joint_name=p.joint, system_model=p.system, friction_model=p.friction, asymmetric=p.asymmetric,
        solver=p.solver, param_names=list(p.params), param_values=[float(v) for v in p.params.values()],
        param_std=[float(p.std.get(k, NAN)) for k in p.params],
        relerr_pct=float(m.get("relerr_pct", NAN)), r2=float(m.get("r2", NAN)), rmse=float(m.get("rmse", NAN)),
        err_std=float(m.get("error_std", NAN)), cond=float(m.get("cond", NAN)),
        samples=max(0, min(int(p.samples), 2**32 - 1)), stamp=to_time(p.stamp_ns))


def parameters_msg(results: Results, joints: list[str]) -> IdentifiedParameters:
    """``results`` as an IdentifiedParameters: its joints in the order of ``joints``, then the
    others; shared parameters from ``results.last`` (the core's IdentifyResult)."""
    msg = IdentifiedParameters()
    msg.shared_param_names, msg.shared_param_values, msg.shared_param_std = shared_parameters(results.last)
    msg.header.stamp = to_time(results.stamp_ns)
    msg.window_start, msg.window_end = to_time(results.window_start_ns), to_time(results.window_end_ns)
    msg.samples = int(results.window_samples)
    per_joint = results.per_joint
    order = [j for j in joints if j in per_joint]
    msg.joints = [joint_friction(per_joint[j]) for j in order + [j for j in per_joint if j not in order]]
    return msg


def diagnostic_array(node_name: str, statuses: list[tuple[str, bool, str, dict]], stamp) -> DiagnosticArray:
    """One DiagnosticStatus ``"<node>: <title>"`` per (title, ok, message, values); ok → OK, else WARN."""
    name = node_name.lstrip("/")
    arr = DiagnosticArray(status=[
        DiagnosticStatus(name=f"{name}: {title}", hardware_id=node_name,
                         level=DiagnosticStatus.OK if ok else DiagnosticStatus.WARN, message=message,
                         values=[KeyValue(key=k, value=str(v)) for k, v in values.items()])
        for title, ok, message, values in statuses])
    arr.header.stamp = stamp
    return arr


def inertia_msg(payload) -> Inertia:
    """A :class:`~frictionid_core.robots.Payload` as a geometry_msgs/Inertia: m [kg], com [m] in its
    link's frame, the inertia about the centre of mass [kg·m²] in the link's axes."""
    inertia = payload.inertia
    return Inertia(m=float(payload.mass), com=Vector3(x=float(payload.com[0]), y=float(payload.com[1]),
                                                      z=float(payload.com[2])),
                   ixx=float(inertia[0][0]), ixy=float(inertia[0][1]), ixz=float(inertia[0][2]),
                   iyy=float(inertia[1][1]), iyz=float(inertia[1][2]), izz=float(inertia[2][2]))


def fill_payload(response, result) -> None:
    """The payload fields of an IdentifyPayload response (or action result) from a
    :class:`~frictionid_core.identification.PayloadResult` (nothing when None)."""
    if result is None:
        return
    import json

    p = result.payload
    response.link, response.inertia = p.link, inertia_msg(p)
    response.mass_sigma = float((p.sigma or {}).get("mass") or NAN)
    response.resolved, response.feasible = list(p.resolved), bool(p.feasible)
    response.json = json.dumps(result.to_dict(), default=float)
