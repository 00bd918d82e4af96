"""Starting a node whose shutdown cannot deadlock.

rospy's own SIGINT handler runs ``signal_shutdown`` in the main thread, between two bytecodes of whatever the
main thread was doing. When that was ``Publisher.publish`` (a node publishing at high rate, such as the
simulator at maximum speed), the handler closes the very connection whose lock ``publish`` holds and the
process hangs for ever; roslaunch then leaves it behind as an orphan. Here the handler only starts a thread
that calls ``signal_shutdown``: it waits for the lock like any other thread, and the main loop sees
``rospy.is_shutdown()`` on its next turn.
"""

from __future__ import annotations

import signal
import threading
from types import FrameType

import rospy


def _shutdown_in_thread(signum: int, _frame: FrameType | None) -> None:
    reason = f"signal {signal.Signals(signum).name}"
    threading.Thread(target=rospy.signal_shutdown, args=(reason,), name="shutdown", daemon=True).start()


def init_node(name: str, **kwargs: object) -> None:
    """``rospy.init_node`` with SIGINT and SIGTERM handled off the main thread (see the module docstring)."""
    rospy.init_node(name, disable_signals=True, **kwargs)  # type: ignore[arg-type]
    signal.signal(signal.SIGINT, _shutdown_in_thread)
    signal.signal(signal.SIGTERM, _shutdown_in_thread)
