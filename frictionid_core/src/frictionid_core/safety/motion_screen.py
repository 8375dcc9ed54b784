"""The screen of a motion before it is commanded: nothing moves a robot before its limits are checked.

:func:`screen_motion` samples a commanded motion (any trajectory with ``joints`` and
``sample(rate)``, such as :class:`frictionid_core.experiment.Motion`) at ``rate`` (1 kHz) and checks
every sample against the robot's limits with their margin — position, velocity, acceleration, and the
effort of the model's inverse dynamics plus the joint friction of the limits (those of ``frictionid
excite``: :func:`frictionid_core.excitation.verify`) — and, with a collision model, the clearance of
every checked pair of links. A motion that breaks one is refused in one line naming what, which joint
(or pair) and when; the report of the check is returned otherwise.
"""

from __future__ import annotations

from frictionid_core.errors import FrictionIdError

SCREEN_RATE_HZ = 1000.0


def screen_motion(robot, limits, motion, collision=None, what: str = "the motion",
                  rate: float = SCREEN_RATE_HZ) -> dict:
    """The check of ``motion`` (joints in ``robot``'s order) against ``limits`` (an
    :func:`frictionid_core.excitation.robot_limits`) and ``collision``; FrictionIdError naming the
    violations (``what`` names the motion in it)."""
    from frictionid_core.excitation import verify, violation_text

    if list(motion.joints) != list(robot.joints):
        raise FrictionIdError(f"{what}: its joints {list(motion.joints)} are not {robot.name}'s {list(robot.joints)}")
    report = verify(robot, limits, motion, rate, collision)
    if not report["ok"]:
        raise FrictionIdError(f"refused by the safety screen: {what} breaks the robot's limits: "
                              + violation_text(report, limits.margin))
    return report
