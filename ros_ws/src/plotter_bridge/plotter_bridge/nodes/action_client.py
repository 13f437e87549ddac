"""An rclpy action client that may send from any thread.

rclpy 7.1.6 (Jazzy) sends a goal, cancel or result request first and only
then files the request's sequence number.  When another thread spins the
executor, the server's answer can be taken in between: the client logs
"Ignoring unexpected goal response", and the future never completes
(ros2/rclpy#1123, fixed upstream after 7.1.6).  The plotter sends from its
job threads and from the command-line client's main thread, so it met this:
a job that the bridge had accepted was never followed to its end.

ActionClient here files every request under a lock, and the executor waits
for that lock before it matches an answer, so an answer can only be matched
once its request is filed.
"""
from __future__ import annotations

import threading

from rclpy.action import ActionClient as _RclpyActionClient


class ActionClient(_RclpyActionClient):
    """rclpy's ActionClient, safe to send from threads other than the executor's."""

    def __init__(self, *args, **kwargs) -> None:
        self._filing = threading.Lock()
        super().__init__(*args, **kwargs)

    def send_goal_async(self, goal, feedback_callback=None, goal_uuid=None):
        with self._filing:
            return super().send_goal_async(goal, feedback_callback, goal_uuid)

    def _cancel_goal_async(self, goal_handle):
        with self._filing:
            return super()._cancel_goal_async(goal_handle)

    def _get_result_async(self, goal_handle):
        with self._filing:
            return super()._get_result_async(goal_handle)

    async def execute(self, taken_data):
        # Any request whose answer is in taken_data was sent under the lock: once
        # the lock is free, that request is filed.
        with self._filing:
            pass
        return await super().execute(taken_data)
