"""Sim time going backwards, handled the same way by every node that keeps time-dependent state.

A node makes one :class:`TimeJumpGuard` and calls :meth:`TimeJumpGuard.check` at the top of every callback that
uses the time (its scan callback; the guard's own :meth:`TimeJumpGuard.timer` does it before each tick). When the
clock is behind its previous reading (:mod:`mrs_nav.clock_jump`'s rule), the guard clears the node's tf buffer,
calls the node's reset, and logs one warning saying how far the clock went back and what the node reset.

Every repeating timer is made by :func:`repeating_timer`: a plain ``rospy.Timer`` dies for good with
``ROSTimeMovedBackwardsException`` when the clock goes back during its sleep, and with it the node's map -> odom
broadcast or control loop; ``reset=True`` (rospy 1.15) makes it start its period again instead.
:func:`keep_status_timer` does the same for the status timer of an actionlib action server.

What each node resets (its module says more):

- SLAM: the tf buffer, the date of its last map -> odom broadcast and of its last /map (so both go on at once);
  the map and the correction are kept unless ``~reset_map_on_time_jump`` is true (then a new map is started).
- Localisation: the tf buffer and the date of its last broadcast; the particles are kept (the robot did not move
  because the clock did), and scans are taken whatever the date of the last pose estimate given.
- RRT navigation and the potential-field follower: the tf buffer and their stamped inputs; the active goal is
  aborted (move_base's ABORTED, ``~status`` ``failed: sim time went back ...``) and the robot stopped: the goal's
  deadlines and progress belong to the old time line. A goal sent afterwards is driven as usual.

The simulator is the clock and keeps nothing stamped by another node; the Zenoh bridge runs on the wall clock.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import actionlib
import rospy
import tf2_ros

from mrs_nav.clock_jump import ClockJumpDetector

TimerCallback = Callable[[rospy.timer.TimerEvent], None]


def repeating_timer(period_s: float, callback: TimerCallback) -> rospy.Timer:
    """A ``rospy.Timer`` calling ``callback`` every ``period_s`` s of ROS time that survives the clock going
    back (it starts its period again from the new time)."""
    return rospy.Timer(rospy.Duration(period_s), callback, reset=True)


def keep_status_timer(server: actionlib.ActionServer) -> None:
    """Replace a started action server's status timer (actionlib makes a plain one, which a jump back ends, and
    with it the periodic ``status`` a new client waits for) by one that survives it."""
    old = getattr(server, "status_timer", None)
    if old is None:  # status_frequency 0: no periodic status
        return
    old.shutdown()
    server.status_timer = repeating_timer(1.0 / server.status_frequency, server.publish_status_async)


class TimeJumpGuard:
    """One node's watch on the clock: ``reset(seconds)`` is called once per jump back, after ``buffer`` (the
    node's tf buffer) was cleared, and returns what the node did, for the log line."""

    def __init__(self, who: str, reset: Callable[[float], str], buffer: tf2_ros.Buffer | None = None) -> None:
        self.who = who
        self._reset = reset
        self._buffer = buffer
        self._detector = ClockJumpDetector(rospy.get_time)
        # Readings from several threads (scans, timer) are compared in order, and a second thread waits until a
        # reset in progress is done rather than working on the state being reset.
        self._lock = threading.Lock()

    def check(self) -> bool:
        """Whether the clock went back since the last check (the node's state is reset by then). Not to be
        called from the node's reset, nor with a lock that the reset takes."""
        with self._lock:
            jump = self._detector.check()
            if jump is None:
                return False
            if self._buffer is not None:
                self._buffer.clear()
            done = self._reset(jump.seconds)
            rospy.logwarn(
                f"{self.who}: sim time went back {jump.seconds:.3f} s, from {jump.before:.3f} to {jump.after:.3f} s "
                f"(a bag played again or the simulator restarted?); tf buffer cleared; {done}"
            )
        return True

    def timer(self, period_s: float, callback: TimerCallback) -> rospy.Timer:
        """A :func:`repeating_timer` that checks the clock before each call of ``callback``."""

        def tick(event: Any) -> None:
            self.check()
            callback(event)

        return repeating_timer(period_s, tick)
