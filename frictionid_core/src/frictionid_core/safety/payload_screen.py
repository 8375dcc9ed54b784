"""The safety screen of a payload that can reach a robot's model (no ROS import): the node's
``~/identify_payload`` result and ``frictionid export --payload``.

Refused, one line each naming the problem:

* a number that is not finite, or whose magnitude is over ``max_abs`` (kg, m, kg·m²);
* a mass ≤ 0, or a pseudo-inertia that is not positive definite (no rigid body has it);
* a payload whose gravity torque alone is over a joint's effort limit (the robot model's) in some
  pose within the joint limits (:data:`POSES` random poses, seeded): the robot cannot hold it, so
  the estimate is not that robot's payload.
"""

from __future__ import annotations

import math

import numpy as np

from frictionid_core.safety.screen import MAX_ABS, robot_limits

POSES = 256  # random poses within the joint limits the gravity torque is checked at
POSES_SEED = 0


def payload_refusals(payload, system, *, max_abs: float = MAX_ABS) -> list[str]:
    """The screen's refusals of ``payload`` (a :class:`~frictionid_core.robots.payload_model.Payload`) on
    the robot ``system`` (a robot System), one line each; empty: accepted."""
    from frictionid_core.robots import frame_map, link_frame, random_samples

    where = f"payload on '{payload.link}'"
    values = [payload.mass, *payload.com, *np.ravel(payload.inertia)]
    if not all(math.isfinite(v) for v in values):
        return [f"{where}: a value is not finite ({values})"]
    out = [f"{where}: |{v:.6g}| is over {max_abs:g}" for v in values if abs(v) > max_abs]
    if payload.mass <= 0:
        out.append(f"{where}: mass {payload.mass:.6g} kg ≤ 0")
    if not payload.feasible:
        out.append(f"{where}: its pseudo-inertia is not positive definite (no rigid body has this mass, centre of "
                   "mass and inertia)")
    info = getattr(system, "robot", None)
    if out or info is None:
        return out
    robot = info.model
    _, joint, pose = link_frame(robot, payload.link)
    q, _, _ = random_samples(robot, POSES, seed=POSES_SEED)
    still = np.zeros_like(q)
    columns = robot.regressor(q, still, still)[..., 10 * (joint - 1): 10 * joint] @ frame_map(pose)
    gravity = np.max(np.abs(columns @ payload.standard()), axis=0)
    limits = robot_limits(system)
    for k, name in enumerate(robot.joints):
        limit = limits.get(name)
        if limit is not None and gravity[k] > limit.effort:
            out.append(f"{where} ({payload.mass:.4g} kg): its gravity torque {gravity[k]:.4g} on '{name}' is over the "
                       f"effort limit {limit.effort:.4g} ({limit.source})")
    return out
