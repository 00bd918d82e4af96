"""The goal state machine of a :class:`~mrs_nav.navigation.navigator.Navigator`: which goal is held, what state
it is in (the values of ``actionlib_msgs/GoalStatus``), the events each transition reports, and which goals are
refused before they start.

A goal is accepted (``ACTIVE``, preempting an active one) or refused (the current goal, if any, runs on); it
ends ``REACHED``, ``FAILED`` or ``PREEMPTED`` (cancelled). Only :meth:`GoalTracker.accept`,
:meth:`GoalTracker.cancel` and :meth:`GoalTracker.end` change the state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, format_point
from mrs_nav.maps.admissible import grid_refusal
from mrs_nav.maps.occupancy_grid import OccupancyGrid


class GoalState(Enum):
    """Where the current (or last) goal stands; the values are those of ``actionlib_msgs/GoalStatus``."""

    IDLE = 0  # no goal yet (GoalStatus.PENDING)
    ACTIVE = 1
    PREEMPTED = 2
    REACHED = 3  # GoalStatus.SUCCEEDED
    FAILED = 4  # GoalStatus.ABORTED
    REFUSED = 5  # GoalStatus.REJECTED


class EventKind(Enum):
    """What happened; ``warning`` kinds are those a node logs as warnings."""

    ACCEPTED = "accepted"
    REFUSED = "refused"
    PREEMPTED = "preempted"
    PLANNED = "planned"
    PLAN_FAILED = "plan_failed"
    REACHED = "reached"
    FAILED = "failed"
    HOLDING = "holding"
    RESUMED = "resumed"
    CANCELLED = "cancelled"
    RECOVERY = "recovery"  # a recovery behaviour started (navigation.recovery)

    @property
    def warning(self) -> bool:
        return self in {
            EventKind.REFUSED,
            EventKind.PLAN_FAILED,
            EventKind.FAILED,
            EventKind.HOLDING,
            EventKind.RECOVERY,
        }


@dataclass(frozen=True)
class NavEvent:
    """One thing worth reporting, with a one-line human-readable ``message``."""

    kind: EventKind
    message: str


@dataclass(frozen=True)
class NavGoal:
    """A goal in the map frame: the position ``(x, y)`` (m) and the heading ``yaw`` (rad) to end with, None when
    any will do.

    Made once where a goal enters (the ROS adapter converts its message into one, the demo and the bench build
    theirs) and passed down unchanged; finite by construction, so nothing below checks that again.
    """

    x: float
    y: float
    yaw: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.x) and math.isfinite(self.y)):
            raise InvalidInputError(f"goal ({self.x}, {self.y}): its position is not a finite number")
        if self.yaw is not None and not math.isfinite(self.yaw):
            raise InvalidInputError(f"goal {format_point(self.x, self.y)}: its heading is not a finite number")

    @property
    def position(self) -> tuple[float, float]:
        return (self.x, self.y)

    def seen_from(self, frame: Pose2D) -> NavGoal:
        """This goal, given in a frame whose pose is ``frame``, expressed in the frame ``frame`` is given in."""
        pose = frame.compose(Pose2D(self.x, self.y, 0.0 if self.yaw is None else self.yaw))
        return NavGoal(pose.x, pose.y, None if self.yaw is None else pose.yaw)

    def describe(self) -> str:
        heading = "" if self.yaw is None else f", heading {self.yaw:.2f} rad"
        return f"goal {format_point(self.x, self.y)}{heading}"


def goal_refusal(
    raw: OccupancyGrid | None, grid: OccupancyGrid | None, goal: NavGoal, *, inflation_m: float
) -> str | None:
    """Why ``goal`` must be refused on the map ``raw`` planned on as ``grid`` (inflated by ``inflation_m``,
    unknown made free when allowed), or None when it may be tried."""
    if grid is None or raw is None:
        return "no map received yet"
    why = grid_refusal(grid, goal.x, goal.y, raw=raw, inflation_m=inflation_m, unknown_hint=" and allow_unknown is off")
    return None if why is None else f"it lies {why}"


class GoalTracker:
    """The goal held and its state."""

    def __init__(self) -> None:
        self.state = GoalState.IDLE
        self.goal: NavGoal | None = None

    @property
    def active(self) -> bool:
        return self.state is GoalState.ACTIVE and self.goal is not None

    def describe(self) -> str:
        assert self.goal is not None
        return f"goal {format_point(self.goal.x, self.goal.y)}"

    def accept(self, goal: NavGoal) -> list[NavEvent]:
        """Make ``goal`` the active goal; the events (a preemption first, if any)."""
        events = []
        if self.active:
            events.append(NavEvent(EventKind.PREEMPTED, f"{self.describe()} preempted by a new goal"))
        self.goal = goal
        self.state = GoalState.ACTIVE
        events.append(NavEvent(EventKind.ACCEPTED, f"{goal.describe()} accepted"))
        return events

    def cancel(self) -> list[NavEvent]:
        """Drop the active goal (no event when there is none)."""
        if not self.active:
            return []
        self.end(GoalState.PREEMPTED)
        return [NavEvent(EventKind.CANCELLED, "goal cancelled")]

    def end(self, state: GoalState) -> None:
        """End the active goal in ``state``."""
        self.goal = None
        self.state = state
