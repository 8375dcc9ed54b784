"""rclpy's action client with a goal future that always completes."""

from __future__ import annotations

import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from rclpy.action import ActionClient as RclpyActionClient
    from rclpy.task import Future


class ActionClient(RclpyActionClient):
    """:class:`rclpy.action.ActionClient` whose :meth:`send_goal_async` future completes when the
    server answers.

    rclpy 9.1.2 registers the goal's future under the client's lock, then registers a second one in its
    place outside the lock and returns that one (ros2/rclpy#1123, a backport that kept the old lines). A
    response the executor takes between the two completes the first future, which is then dropped: the
    caller's future never completes although the server accepted the goal and runs it. Here the feedback
    callback is registered before the goal is sent (feedback that comes first is kept) and one future is
    registered, under the lock."""

    def send_goal_async(self, goal, feedback_callback=None, goal_uuid=None) -> Future:
        """Send ``goal``; the returned future completes with its ``ClientGoalHandle`` (accepted or
        not). ``feedback_callback(feedback_message)`` is called for each of its feedback messages."""
        if not isinstance(goal, self._action_type.Goal):
            raise TypeError(f"Expected goal type ({self._action_type.Goal}) but received ({type(goal)})")
        request = self._action_type.Impl.SendGoalService.Request()
        request.goal_id = self._generate_random_uuid() if goal_uuid is None else goal_uuid
        request.goal = goal
        if feedback_callback is not None:
            self._feedback_callbacks[bytes(request.goal_id.uuid)] = feedback_callback
        future = Future()
        with self._lock:
            sequence_number = self._client_handle.send_goal_request(request)
            if sequence_number in self._pending_goal_requests:
                raise RuntimeError(f"Sequence ({sequence_number}) conflicts with pending goal request")
            self._pending_goal_requests[sequence_number] = future
            self._goal_sequence_number_to_goal_id[sequence_number] = request.goal_id
            future.add_done_callback(self._remove_pending_goal_request)
            self.add_future(future)  # the executor waits for it
        return future
