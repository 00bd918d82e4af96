"""MoveBaseForwarder: the ROS 1 side of ros2_bridge's NavigateToPose, an actionlib client of move_base.

Goals from the ROS 2 half (frames of :mod:`mrs_nav.bridge.ros2_action`) are checked as the bridge's inbound
topics are (exactly one geometry_msgs/PoseStamped, every number finite) and sent to move_base; cancels are
forwarded; move_base's feedback goes back with Nav2's numbers, and its result with actionlib's status and text.
"""

from __future__ import annotations

import contextlib
import io
import threading
import time
from collections.abc import Callable

import actionlib
import rospy
from geometry_msgs.msg import PoseStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseFeedback, MoveBaseGoal

from mrs_nav.bridge.decoder import deserialize_exactly, first_non_finite, noetic_store
from mrs_nav.bridge.ros2_action import ACTION_CHANNEL, ActionFrame, FeedbackTracker, GoalStatus, Kind, goal_name
from mrs_nav.errors import InvalidInputError

POSE_TYPE = "geometry_msgs/PoseStamped"
# Wall seconds a goal waits for the move_base server to be connected (goal, cancel, feedback and result topics)
# before it is refused: right after start-up the connections may still be under way, and move_base (like
# rrt_navigation) starts its action only once it has a map, which SLAM on a loaded machine can take a while to make.
SERVER_WAIT = 60.0


def _serialized(msg: PoseStamped) -> bytes:
    buffer = io.BytesIO()
    msg.serialize(buffer)
    return buffer.getvalue()


def checked_pose(payload: bytes) -> PoseStamped:
    """The pose of a goal from ROS 2; InvalidInputError naming the field when a number is not finite."""
    bad = first_non_finite(deserialize_exactly(noetic_store(), POSE_TYPE, payload))
    if bad:
        raise InvalidInputError(f"field {bad} is not a finite number")
    pose = PoseStamped()
    pose.deserialize(payload)
    return pose


class MoveBaseForwarder:
    """``send(channel, payload)`` writes a frame to the ROS 2 half; :meth:`deliver` takes one from it."""

    def __init__(self, action_ns: str, send: Callable[[int, bytes], None]) -> None:
        self._client = actionlib.ActionClient(action_ns, MoveBaseAction)
        self._action_ns = action_ns
        self._send = send
        self._lock = threading.Lock()
        self._goals: dict[bytes, tuple[actionlib.ClientGoalHandle, FeedbackTracker]] = {}
        self._cancelled: set[bytes] = set()  # cancelled before they were sent on

    def deliver(self, payload: bytes) -> None:
        """A frame from the ROS 2 half on the action's channel; InvalidInputError if it is not one it sends."""
        frame = ActionFrame.decode(payload)
        if frame.kind is Kind.GOAL:  # in a thread: it may wait for move_base, the pipe's reader must not
            threading.Thread(target=self._start, args=(frame.goal_id, frame.body), daemon=True).start()
        elif frame.kind is Kind.CANCEL:
            with self._lock:
                entry = self._goals.get(frame.goal_id)
                if entry is None:  # not sent on yet, or ended already (its result is on its way)
                    self._cancelled.add(frame.goal_id)
            if entry is not None:
                entry[0].cancel()
        else:
            raise InvalidInputError(f"action frame {frame.kind.name} from the ROS 2 half")

    def _start(self, goal_id: bytes, body: bytes) -> None:
        try:
            pose = checked_pose(body)
        except Exception as err:  # anything from the other side may be broken: refuse the goal, go on
            self._result(goal_id, GoalStatus.REJECTED, f"goal refused by ros2_bridge: {err}")
            return
        if not self._server_ready():
            self._result(goal_id, GoalStatus.REJECTED, f"no action server on {self._action_ns}")
            return
        tracker = FeedbackTracker(pose.pose.position.x, pose.pose.position.y, rospy.get_time())
        with self._lock:  # the callbacks (rospy's threads) find the goal once it is sent
            if goal_id in self._cancelled:
                self._cancelled.discard(goal_id)
                self._result(goal_id, GoalStatus.RECALLED, "cancelled before it was sent")
                return
            rospy.loginfo("ros2 bridge: NavigateToPose goal %s sent to %s", goal_name(goal_id), self._action_ns)
            handle = self._client.send_goal(
                MoveBaseGoal(target_pose=pose),
                transition_cb=lambda h: self._on_transition(goal_id, h),
                feedback_cb=lambda _h, feedback: self._on_feedback(goal_id, feedback),
            )
            self._goals[goal_id] = (handle, tracker)

    def _server_ready(self) -> bool:
        """Whether move_base is connected, waiting up to SERVER_WAIT wall seconds (actionlib's own wait counts
        in sim time, which runs many times faster than the connections are made at maximum rate)."""
        deadline = time.monotonic() + SERVER_WAIT
        while time.monotonic() < deadline and not rospy.is_shutdown():
            if self._client.wait_for_server(rospy.Duration(0.001)):
                return True
        return False

    def _on_transition(self, goal_id: bytes, handle: actionlib.ClientGoalHandle) -> None:
        if handle.get_comm_state() != actionlib.CommState.DONE:
            return
        with self._lock:
            if self._goals.pop(goal_id, None) is None:
                return
        self._result(goal_id, handle.get_goal_status(), handle.get_goal_status_text())

    def _on_feedback(self, goal_id: bytes, feedback: MoveBaseFeedback) -> None:
        with self._lock:
            entry = self._goals.get(goal_id)
        if entry is None:
            return
        pose = feedback.base_position
        numbers = entry[1].update(pose.header.stamp.to_sec(), pose.pose.position.x, pose.pose.position.y)
        self._emit(ActionFrame(Kind.FEEDBACK, goal_id, numbers.encode(_serialized(pose))))

    def _result(self, goal_id: bytes, status: int, text: str) -> None:
        self._emit(ActionFrame(Kind.RESULT, goal_id, bytes([status]) + text.encode()))

    def _emit(self, frame: ActionFrame) -> None:
        with contextlib.suppress(BrokenPipeError, ValueError):  # the ROS 2 half is gone; the node ends for that
            self._send(ACTION_CHANNEL, frame.encode())

    def close(self) -> None:
        """Cancel the goals still running: nobody on ROS 2 can follow them any more."""
        with self._lock:
            handles = [handle for handle, _ in self._goals.values()]
            self._goals.clear()
        for handle in handles:  # goals that ended are no longer here
            handle.cancel()
        self._client.stop()
