"""The ``~/identify`` and ``~/identify_payload`` actions: their service's request with progress
feedback and cancel (rclpy.action).

Every goal is accepted and answered in its result (``success``, ``message``) like the service:
"busy", a refused request or a failure end the goal as aborted, a client's cancel as canceled
(the active parameters stay untouched), the wall-time limit and ``~/reset`` as aborted with the
reason in the message. The work is :class:`frictionid_ros.identification.IdentifyService`'s (and
:class:`frictionid_ros.identification.PayloadService`'s).
"""

from __future__ import annotations

import threading
import time
import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
    from frictionid_interfaces.action import Identify as IdentifyAction
    from rclpy.action import ActionServer, CancelResponse

from frictionid_ros.identification import IdentifyService
from frictionid_ros.node.messages import parameters_msg
from frictionid_ros.worker import JobControl

FEEDBACK_PERIOD_S = 0.2  # [s]
CANCELLED_BY_CLIENT = "cancelled by the client"


class ServedAction:
    """An action ``name`` of type ``action`` on ``node`` whose goals ``handle(goal, control,
    on_wait)`` answers (an :class:`~frictionid_ros.identification.Answer`); ``feedback(control, elapsed_s)``
    builds its feedback, ``fill(result, answer)`` its result beyond success and message;
    ``log(ok, message)`` reports each answer."""

    def __init__(self, node, action, name: str, handle, feedback, fill, log, callback_group):
        self._action, self._handle, self._feedback, self._fill = action, handle, feedback, fill
        self._log = log
        self._controls: dict[bytes, JobControl] = {}
        self._lock = threading.Lock()
        self.server = ActionServer(node, action, name, self._execute, callback_group=callback_group,
                                   cancel_callback=self._on_cancel)

    def destroy(self) -> None:
        self.server.destroy()

    def _on_cancel(self, goal_handle) -> CancelResponse:
        with self._lock:
            control = self._controls.get(bytes(goal_handle.goal_id.uuid))
        if control is not None:
            control.cancel(CANCELLED_BY_CLIENT)
        return CancelResponse.ACCEPT

    def _execute(self, goal_handle):
        key = bytes(goal_handle.goal_id.uuid)
        control = JobControl()
        with self._lock:
            self._controls[key] = control
        last = [0.0]

        def on_wait(c: JobControl) -> None:
            if goal_handle.is_cancel_requested:  # a cancel that came before the control was known
                c.cancel(CANCELLED_BY_CLIENT)
            now = time.monotonic()
            if now - last[0] >= FEEDBACK_PERIOD_S:
                last[0] = now
                goal_handle.publish_feedback(self._feedback(c, now - c.t_start))

        try:
            answer = self._handle(goal_handle.request, control, on_wait)
        finally:
            with self._lock:
                self._controls.pop(key, None)
        self._log(answer.ok, answer.message)
        result = self._action.Result(success=answer.ok, message=answer.message)
        self._fill(result, answer)
        if answer.ok:
            goal_handle.succeed()
        elif answer.cancelled and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        else:
            goal_handle.abort()
        return result


def identify_action(node, service: IdentifyService, joints, log, callback_group) -> ServedAction:
    """``~/identify``: served by ``service``; ``joints()``: the node's joint order for the result."""

    def feedback(control: JobControl, elapsed_s: float):
        generation, evaluations, best = control.progress
        return IdentifyAction.Feedback(generation=generation, evaluations=evaluations, best_cost=best,
                                       elapsed_s=elapsed_s)

    def fill(result, answer) -> None:
        if answer.identified is not None:
            result.result = parameters_msg(answer.identified, joints())

    return ServedAction(node, IdentifyAction, "~/identify", service.handle, feedback, fill, log, callback_group)


def payload_action(node, service, log, callback_group) -> ServedAction:
    """``~/identify_payload``: served by ``service`` (a :class:`~frictionid_ros.identification.PayloadService`)."""
    from frictionid_interfaces.action import IdentifyPayload

    from frictionid_ros.node.messages import fill_payload

    return ServedAction(node, IdentifyPayload, "~/identify_payload", service.handle,
                        lambda control, elapsed_s: IdentifyPayload.Feedback(elapsed_s=elapsed_s),
                        lambda result, answer: fill_payload(result, answer.payload), log, callback_group)
