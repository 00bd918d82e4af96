"""Keyboard teleoperation (``rosrun mrs_nav teleop_keyboard``), turtlebot3_teleop_key's keys and limits.

Reads single keys from the terminal (:mod:`mrs_nav.control.teleop_keys` turns them into speeds) and publishes
geometry_msgs/Twist on ``cmd_vel`` ten times a second of wall time, as turtlebot3_teleop_key does. The terminal
is raw while the node runs, so Ctrl-C arrives as a key like ``q``: the loop ends, a zero Twist goes out while the
topic is still open (rospy closes its topics before any shutdown hook runs), and the terminal's settings come
back whatever ends the node.
"""

from __future__ import annotations

import contextlib
import os
import select
import sys
import termios
import tty
from collections.abc import Iterator
from typing import TextIO

import rospy
from geometry_msgs.msg import Twist

from mrs_nav.control.teleop_keys import HELP, HELP_EVERY, TeleopState, press, tick
from mrs_nav.errors import InvalidInputError

#: Seconds (wall time) a key is waited for before the command is published again.
KEY_TIMEOUT = 0.1


@contextlib.contextmanager
def raw_terminal(stream: TextIO) -> Iterator[None]:
    """``stream``'s terminal in raw mode (keys one by one, Ctrl-C as a key) with output processing kept on, so
    ``print`` still starts lines at the left edge; the old settings restored on the way out."""
    if not stream.isatty():
        raise InvalidInputError("teleop_keyboard reads keys from a terminal; its standard input is not one")
    fd = stream.fileno()
    saved = termios.tcgetattr(fd)
    try:
        tty.setraw(fd)
        attrs = termios.tcgetattr(fd)
        attrs[1] |= termios.OPOST  # oflag: "\n" becomes "\r\n" again
        termios.tcsetattr(fd, termios.TCSADRAIN, attrs)
        yield
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


def read_key(stream: TextIO, timeout: float) -> str:
    """One key from ``stream``, or ``""`` when none came within ``timeout`` seconds. Read from the descriptor:
    the text layer's buffer would swallow keys typed together, where ``select`` no longer sees them."""
    ready, _, _ = select.select([stream], [], [], timeout)
    return os.read(stream.fileno(), 1).decode(errors="replace") if ready else ""


def twist(linear: float, angular: float) -> Twist:
    message = Twist()
    message.linear.x = linear
    message.angular.z = angular
    return message


class TeleopKeyboardNode:
    """Keys from the terminal to ``cmd_vel``."""

    def __init__(self) -> None:
        self._publisher = rospy.Publisher("cmd_vel", Twist, queue_size=1)

    def spin(self, stream: TextIO) -> None:
        """Read keys and publish until ``q``, Ctrl-C or shutdown; a zero Twist last."""
        state = TeleopState()
        presses = 0
        print(HELP)
        try:
            with raw_terminal(stream):
                while not rospy.is_shutdown():
                    key = read_key(stream, KEY_TIMEOUT)
                    if key:
                        after = press(state, key)
                        if after is None:
                            break
                        if after != state:
                            presses += 1
                            print(after.status())
                            if presses % HELP_EVERY == 0:
                                print(HELP)
                        state = after
                    state = tick(state)
                    self._publisher.publish(twist(*state.command))
        finally:
            if not rospy.is_shutdown():
                self._publisher.publish(twist(0.0, 0.0))


def main() -> int:
    node = TeleopKeyboardNode()
    try:
        node.spin(sys.stdin)
    except InvalidInputError as err:
        print(f"ERROR: {err}", file=sys.stderr)
        return 1
    return 0
