"""Starting a node whose shutdown cannot deadlock.

rospy's own SIGINT handler runs ``signal_shutdown`` in the main thread, between two bytecodes of whatever the
main thread was doing. When that was ``Publisher.publish`` (a node publishing at high rate, such as the
simulator at maximum speed), the handler closes the very connection whose lock ``publish`` holds and the
process hangs for ever; roslaunch then leaves it behind as an orphan. Here the handler only starts a thread
that calls ``signal_shutdown``: it waits for the lock like any other thread, and the main loop sees
``rospy.is_shutdown()`` on its next turn.

Before that handler is in place, while ``rospy.init_node`` walks the package path and waits for the master
(seconds on a loaded machine, for ever without a master), a Ctrl-C ends the process as the signal's default
action does, without the ``KeyboardInterrupt`` traceback Python's handler would leave in the launch log: there is
nothing to shut down yet. The node scripts set that default as their first statement, before imports that take
seconds on a loaded machine.

Private parameters given on the command line (``_seed:=7``) reach the parameter server through XML-RPC, whose
integers are 32-bit: rospy raises ``OverflowError`` from deep inside ``init_node`` for a larger one, and
``ROSInitException`` for text YAML cannot read. Both end the node with one line naming the parameter instead.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Sequence
from types import FrameType

import rospy
from rospy.client import load_command_line_node_params
from rospy.exceptions import ROSInitException

from mrs_nav.ros.master_watch import watch_master

XMLRPC_INT_MIN, XMLRPC_INT_MAX = -(2**31), 2**31 - 1


def _shutdown_in_thread(signum: int, _frame: FrameType | None) -> None:
    reason = f"signal {signal.Signals(signum).name}"
    threading.Thread(target=rospy.signal_shutdown, args=(reason,), name="shutdown", daemon=True).start()


def _check_command_line_params(argv: list[str]) -> None:
    """Exit with one line when a ``_name:=value`` argument cannot reach the parameter server."""
    params = {}
    for arg in argv[1:]:
        try:
            params.update(load_command_line_node_params([arg]))
        except ROSInitException as err:
            sys.exit(f"ERROR: {arg}: {' '.join(str(err).split())}")
    for key, value in params.items():
        if isinstance(value, int) and not isinstance(value, bool) and not XMLRPC_INT_MIN <= value <= XMLRPC_INT_MAX:
            sys.exit(
                f"ERROR: ~{key}: {value} is outside the integers ROS parameters can hold "
                f"({XMLRPC_INT_MIN}..{XMLRPC_INT_MAX}, XML-RPC's 32 bits)"
            )


def init_node(name: str, keep_params: Sequence[str] = (), **kwargs: object) -> None:
    """``rospy.init_node`` with SIGINT and SIGTERM handled off the main thread, after checking the command line's
    private parameters (see the module docstring); then the node watches its master and registers again with a
    restarted one (:mod:`mrs_nav.ros.master_watch`), putting back its private parameters and ``keep_params``."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    _check_command_line_params(sys.argv)
    rospy.init_node(name, disable_signals=True, **kwargs)  # type: ignore[arg-type]
    signal.signal(signal.SIGINT, _shutdown_in_thread)
    signal.signal(signal.SIGTERM, _shutdown_in_thread)
    watch_master(keep_params)
