"""The ``navigate_to_pose`` action server of ros2_bridge's ROS 2 half (nav2_msgs/action/NavigateToPose).

Each accepted goal goes down the pipe to the ROS 1 half, which sends it to move_base; move_base's feedback and
result come back (frames of :mod:`mrs_nav.bridge.ros2_action`). An execution waits for them in a thread of the
node's executor (a multi-threaded one: cancel requests are served meanwhile).
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from typing import Any

from builtin_interfaces.msg import Duration
from nav2_msgs.action import NavigateToPose
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node

from mrs_nav.bridge.ros1_codec import Ros1Codec
from mrs_nav.bridge.ros2_action import ACTION_CHANNEL, ActionFrame, Feedback, GoalStatus, Kind, goal_name, outcome
from mrs_nav.errors import MrsNavError

POSE_TYPE = "geometry_msgs/PoseStamped"
#: What a goal still executing when the bridge ends is aborted with.
CLOSING = ActionFrame(Kind.RESULT, bytes(16), bytes([GoalStatus.ABORTED]) + b"ros2_bridge is shutting down")
#: How long (s) :meth:`NavigateToPoseServer.close` waits for the executions to end.
CLOSE_TIMEOUT = 5.0


def _duration(seconds: float) -> Duration:
    sec, nanosec = divmod(round(seconds * 1e9), 1_000_000_000)
    return Duration(sec=sec, nanosec=nanosec)


class NavigateToPoseServer:
    """``send(channel, payload)`` writes a frame to the ROS 1 half; :meth:`deliver` takes one from it."""

    def __init__(
        self, node: Node, name: str, codec: Ros1Codec, send: Callable[[int, bytes], None], log: Callable[[str], None]
    ) -> None:
        self._codec = codec
        self._send = send
        self._log = log
        self._lock = threading.Condition()
        self._goals: dict[bytes, queue.Queue[ActionFrame]] = {}
        self._closing = False
        self.server = ActionServer(
            node,
            NavigateToPose,
            name,
            execute_callback=self._execute,
            goal_callback=self._on_goal,
            cancel_callback=self._on_cancel,
            callback_group=ReentrantCallbackGroup(),
        )

    def _on_goal(self, _request: Any) -> GoalResponse:
        return GoalResponse.REJECT if self._closing else GoalResponse.ACCEPT

    def _on_cancel(self, handle: ServerGoalHandle) -> CancelResponse:
        self._send(ACTION_CHANNEL, ActionFrame(Kind.CANCEL, bytes(handle.goal_id.uuid), b"").encode())
        return CancelResponse.ACCEPT  # the goal ends when move_base has stopped it (its result comes back)

    def _execute(self, handle: ServerGoalHandle) -> Any:
        goal_id = bytes(handle.goal_id.uuid)
        inbox: queue.Queue[ActionFrame] = queue.Queue()
        with self._lock:
            self._goals[goal_id] = inbox
        try:
            frame = self._follow(handle, goal_id, inbox)
            end = outcome(frame.body[0], frame.body[1:].decode(errors="replace"), handle.is_cancel_requested)
            getattr(handle, end.state)()
        finally:
            with self._lock:
                del self._goals[goal_id]
                self._lock.notify_all()
        self._log(f"goal {goal_name(goal_id)}: {end.state} {end.error_msg}".rstrip())
        return NavigateToPose.Result(error_code=end.error_code, error_msg=end.error_msg)

    def _follow(self, handle: ServerGoalHandle, goal_id: bytes, inbox: queue.Queue[ActionFrame]) -> ActionFrame:
        """Send the goal on and publish its feedback until its result comes: that RESULT frame."""
        if handle.is_cancel_requested:  # cancelled before it went out: move_base never hears of it
            return ActionFrame(Kind.RESULT, goal_id, bytes([GoalStatus.RECALLED]))
        try:
            pose = self._codec.encode(POSE_TYPE, handle.request.pose)
            self._send(ACTION_CHANNEL, ActionFrame(Kind.GOAL, goal_id, pose).encode())
        except (MrsNavError, OSError) as err:  # a pose that cannot be encoded, the pipe gone
            return ActionFrame(Kind.RESULT, goal_id, bytes([GoalStatus.REJECTED]) + str(err).encode())
        while (frame := inbox.get()).kind is Kind.FEEDBACK:
            self._feedback(handle, frame.body)
        return frame

    def _feedback(self, handle: ServerGoalHandle, body: bytes) -> None:
        try:
            numbers, pose = Feedback.decode(body)
            current = self._codec.decode(POSE_TYPE, pose)
        except MrsNavError as err:
            self._log(f"feedback dropped: {err}")
            return
        handle.publish_feedback(
            NavigateToPose.Feedback(
                current_pose=current,
                navigation_time=_duration(numbers.navigation_time),
                estimated_time_remaining=_duration(numbers.estimated_time_remaining),
                number_of_recoveries=numbers.number_of_recoveries,
                distance_remaining=numbers.distance_remaining,
            )
        )

    def deliver(self, payload: bytes) -> None:
        """A frame from the ROS 1 half on the action's channel."""
        frame = ActionFrame.decode(payload)
        if frame.kind not in (Kind.FEEDBACK, Kind.RESULT) or (frame.kind is Kind.RESULT and not frame.body):
            raise MrsNavError(f"action frame {frame.kind.name} with {len(frame.body)} bytes from the ROS 1 half")
        with self._lock:
            inbox = self._goals.get(frame.goal_id)
        if inbox is not None:  # else the goal has ended already (feedback after its result)
            inbox.put(frame)

    def close(self) -> None:
        """Abort every goal still executing (the ROS 1 half is gone) so that the executor can stop."""
        with self._lock:
            self._closing = True
            for inbox in self._goals.values():
                inbox.put(CLOSING)
            self._lock.wait_for(lambda: not self._goals, CLOSE_TIMEOUT)
        self.server.destroy()
