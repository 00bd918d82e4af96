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

from mrs_nav.geometry import format_point
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

    @property
    def warning(self) -> bool:
        return self in {EventKind.REFUSED, EventKind.PLAN_FAILED, EventKind.FAILED, EventKind.HOLDING}


@dataclass(frozen=True)
class NavEvent:
    """One thing worth reporting, with a one-line human-readable ``message``."""

    kind: EventKind
    message: str


def goal_refusal(
    raw: OccupancyGrid | None, grid: OccupancyGrid | None, x: float, y: float, *, yaw: float | None, inflation_m: float
) -> str | None:
    """Why the goal ``(x, y)`` (heading ``yaw``, None for any) must be refused on the map ``raw`` planned on as
    ``grid`` (inflated by ``inflation_m``, unknown made free when allowed), or None when it may be tried."""
    if not (math.isfinite(x) and math.isfinite(y)):
        return "its position is not a finite number"
    if yaw is not None and not math.isfinite(yaw):
        return "its heading is not a finite number"
    if grid is None or raw is None:
        return "no map received yet"
    why = grid_refusal(grid, x, y, raw=raw, inflation_m=inflation_m, unknown_hint=" and allow_unknown is off")
    return None if why is None else f"it lies {why}"


class GoalTracker:
    """The goal held and its state."""

    def __init__(self) -> None:
        self.state = GoalState.IDLE
        self.goal: tuple[float, float] | None = None
        self.yaw: float | None = None  # the goal heading (rad), None when any will do

    @property
    def active(self) -> bool:
        return self.state is GoalState.ACTIVE and self.goal is not None

    def describe(self) -> str:
        assert self.goal is not None
        return f"goal {format_point(*self.goal)}"

    def accept(self, x: float, y: float, yaw: float | None = None) -> list[NavEvent]:
        """Make ``(x, y)`` (heading ``yaw``) the active goal; the events (a preemption first, if any)."""
        events = []
        if self.active:
            events.append(NavEvent(EventKind.PREEMPTED, f"{self.describe()} preempted by a new goal"))
        self.goal = (float(x), float(y))
        self.yaw = None if yaw is None else float(yaw)
        self.state = GoalState.ACTIVE
        heading = "" if yaw is None else f", heading {yaw:.2f} rad"
        events.append(NavEvent(EventKind.ACCEPTED, f"goal {format_point(x, y)}{heading} accepted"))
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
        self.yaw = None
        self.state = state
