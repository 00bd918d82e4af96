"""Nav2's NavigateToPose action over ros2_bridge's pipe, served by ROS 1's move_base action.

The ROS 2 half (:mod:`mrs_nav.ros2.navigate_to_pose`) serves ``navigate_to_pose`` (nav2_msgs/action/
NavigateToPose, generated at install) when ``/navigate_to_pose`` is in the bridge's ``allow_inbound``; the ROS 1
half (:mod:`mrs_nav.ros.ros2_bridge_action`) is an actionlib client of ``move_base``. They talk on the pipe's
channel :data:`ACTION_CHANNEL` (no route has it) with payloads ``<kind: uint8><goal id: 16 bytes><body>``, the
goal id being the ROS 2 goal's UUID:

- ``GOAL`` (ROS 2 -> ROS 1): the ROS 1 bytes of the goal's geometry_msgs/PoseStamped (its ``behavior_tree`` is
  not carried: move_base has none);
- ``CANCEL`` (ROS 2 -> ROS 1): empty;
- ``FEEDBACK`` (ROS 1 -> ROS 2): :data:`FEEDBACK_NUMBERS` (navigation time and estimated time remaining in ns,
  distance remaining in m, recoveries) then the ROS 1 bytes of move_base's ``base_position`` (PoseStamped);
- ``RESULT`` (ROS 1 -> ROS 2): the goal's actionlib status (uint8) then its text (UTF-8).

move_base's feedback is the robot's pose only; the rest of Nav2's feedback is worked out here
(:class:`FeedbackTracker`), and actionlib's end states are mapped onto a ROS 2 action's (:func:`outcome`).
"""

from __future__ import annotations

import enum
import math
import struct
import uuid
from collections import deque
from dataclasses import dataclass, field

from mrs_nav.errors import InvalidInputError

#: The pipe's channel of the action (route channels count up from 0).
ACTION_CHANNEL = 0xFFFF
#: The action's name on ROS 2 (before the robot's namespace) as ``allow_inbound`` names it; move_base on ROS 1.
ACTION_NAME = "/navigate_to_pose"
ROS1_ACTION = "move_base"
_HEAD = struct.Struct("<B16s")
#: navigation_time (ns), estimated_time_remaining (ns), distance_remaining (m), number_of_recoveries
FEEDBACK_NUMBERS = struct.Struct("<qqfh")
#: The robot's speed for the time remaining is measured over this much time (s) of feedback.
SPEED_WINDOW = 1.0
#: As Nav2: no time remaining is estimated below this speed (m/s) or distance (m).
MIN_SPEED = 0.01
MIN_DISTANCE = 0.1

# nav2_msgs/action/NavigateToPose result error codes: Jazzy's action defines NONE only (its bt_navigator passes
# on the failing task's code); 9000 is the code Nav2's releases after Jazzy name UNKNOWN.
ERROR_NONE = 0
ERROR_UNKNOWN = 9000


class Kind(enum.IntEnum):
    GOAL = 1
    CANCEL = 2
    FEEDBACK = 3
    RESULT = 4


class GoalStatus(enum.IntEnum):
    """actionlib_msgs/GoalStatus."""

    PENDING = 0
    ACTIVE = 1
    PREEMPTED = 2
    SUCCEEDED = 3
    ABORTED = 4
    REJECTED = 5
    PREEMPTING = 6
    RECALLING = 7
    RECALLED = 8
    LOST = 9


@dataclass(frozen=True)
class ActionFrame:
    kind: Kind
    goal_id: bytes  # 16 bytes
    body: bytes

    def encode(self) -> bytes:
        return _HEAD.pack(self.kind, self.goal_id) + self.body

    @classmethod
    def decode(cls, payload: bytes) -> ActionFrame:
        if len(payload) < _HEAD.size:
            raise InvalidInputError(f"action frame of {len(payload)} bytes, needs at least {_HEAD.size}")
        kind, goal_id = _HEAD.unpack_from(payload)
        try:
            return cls(Kind(kind), goal_id, payload[_HEAD.size :])
        except ValueError:
            raise InvalidInputError(f"action frame of unknown kind {kind}") from None


def goal_name(goal_id: bytes) -> str:
    """The goal's UUID as text (logs, and the ROS 1 goal id)."""
    return str(uuid.UUID(bytes=goal_id))


@dataclass(frozen=True)
class Feedback:
    navigation_time: float  # s since the goal was sent (sim time)
    estimated_time_remaining: float  # s; 0 when the robot stands or is nearly there (as Nav2)
    distance_remaining: float  # m, straight line to the goal
    number_of_recoveries: int

    def encode(self, pose_bytes: bytes) -> bytes:
        return (
            FEEDBACK_NUMBERS.pack(
                round(self.navigation_time * 1e9),
                round(self.estimated_time_remaining * 1e9),
                self.distance_remaining,
                self.number_of_recoveries,
            )
            + pose_bytes
        )

    @classmethod
    def decode(cls, body: bytes) -> tuple[Feedback, bytes]:
        """The numbers and the ROS 1 bytes of the current pose."""
        if len(body) < FEEDBACK_NUMBERS.size:
            raise InvalidInputError(f"action feedback of {len(body)} bytes, needs at least {FEEDBACK_NUMBERS.size}")
        nav_ns, eta_ns, distance, recoveries = FEEDBACK_NUMBERS.unpack_from(body)
        return cls(nav_ns * 1e-9, eta_ns * 1e-9, distance, recoveries), body[FEEDBACK_NUMBERS.size :]


@dataclass
class FeedbackTracker:
    """Nav2's feedback numbers for one goal from move_base's poses (x, y in the goal's frame, t in s)."""

    goal_x: float
    goal_y: float
    start: float
    _poses: deque[tuple[float, float, float]] = field(default_factory=deque)

    def update(self, t: float, x: float, y: float) -> Feedback:
        self._poses.append((t, x, y))
        while len(self._poses) > 2 and t - self._poses[1][0] >= SPEED_WINDOW:
            self._poses.popleft()
        t0, x0, y0 = self._poses[0]
        speed = math.hypot(x - x0, y - y0) / (t - t0) if t > t0 else 0.0
        distance = math.hypot(self.goal_x - x, self.goal_y - y)
        eta = distance / speed if speed > MIN_SPEED and distance > MIN_DISTANCE else 0.0
        return Feedback(max(0.0, t - self.start), eta, distance, 0)


@dataclass(frozen=True)
class Outcome:
    """How a ROS 2 goal ends: ``state`` is the ServerGoalHandle call (succeed, abort or canceled)."""

    state: str
    error_code: int
    error_msg: str


def outcome(status: int, text: str, cancel_requested: bool) -> Outcome:
    """The ROS 2 end of a goal that ended on ROS 1 with actionlib ``status`` and ``text``.

    A goal preempted or recalled after the ROS 2 client asked to cancel it is canceled; one preempted on ROS 1
    without that (a newer goal, a ROS 1 client's cancel) is aborted, as Nav2 ends a goal it drops by itself."""
    if status == GoalStatus.SUCCEEDED:
        return Outcome("succeed", ERROR_NONE, "")
    if status in (GoalStatus.PREEMPTED, GoalStatus.RECALLED) and cancel_requested:
        return Outcome("canceled", ERROR_NONE, "")
    try:
        name = GoalStatus(status).name
    except ValueError:
        name = f"status {status}"
    return Outcome("abort", ERROR_UNKNOWN, f"move_base: {name}" + (f": {text}" if text else ""))
