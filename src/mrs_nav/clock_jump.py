"""Time going backwards: the one rule by which every node decides that its clock jumped back.

Sim time goes back when a bag is played again with ``rosbag play --clock``, when the simulator is restarted under
running nodes (it starts again at 0), or when someone publishes an earlier ``/clock``. Whatever a node keeps
stamped in the old time line then lies in the future: tf transforms, the date of its last broadcast or map, the
deadlines of a goal. The rule: a clock reading earlier than the previous reading by more than
:data:`TIME_JUMP_BACK_S` is a jump back. The ROS nodes apply it through :mod:`mrs_nav.ros.clock_jump`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

#: s: how far the clock must fall behind its previous reading to count as a jump back. Zero, i.e. any step back,
#: as rospy's timers and tf2's listener count it: a single clock source (a simulator, a bag) never steps back, and
#: even a small step leaves a node's last broadcast dated ahead of the clock, so that it would send nothing until
#: the clock caught up. (SLAM and localisation used to wait for 1 s, which a jump of exactly 1 s escaped.)
TIME_JUMP_BACK_S = 0.0


@dataclass(frozen=True)
class ClockJump:
    """A jump back of the clock: the reading before it and the first reading after it (s)."""

    before: float
    after: float

    @property
    def seconds(self) -> float:
        """How far the clock went back (s, > 0)."""
        return self.before - self.after


class ClockJumpDetector:
    """Reads ``clock`` (seconds) at each :meth:`check` and reports a jump back by the module's rule.

    Not thread-safe: callers that check from several threads serialise the calls, so that the readings are
    compared in the order they were taken."""

    def __init__(self, clock: Callable[[], float]) -> None:
        self._clock = clock
        self._last = -math.inf

    def check(self) -> ClockJump | None:
        """Read the clock; the jump when it is behind the previous reading by more than :data:`TIME_JUMP_BACK_S`."""
        now = self._clock()
        before, self._last = self._last, now
        return ClockJump(before, now) if now < before - TIME_JUMP_BACK_S else None
