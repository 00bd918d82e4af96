"""Surviving a restarted roscore: every node registers again, and puts back the parameters it owns.

rospy registers a node's publishers, subscribers and services with the master once, at start. A roscore stopped
and started again on its port knows none of them: the running nodes keep talking over the connections they
already have, but a new client finds nothing (``rosnode list`` is empty, a move_base client's
``wait_for_server`` never returns). :func:`watch_master`, started by every node in
:func:`mrs_nav.ros.node_init.init_node`, runs a daemon thread that asks the master for its pid once a wall-clock
second and applies :mod:`mrs_nav.master_restart`'s rule. When the master is lost it logs one warning; when a
master answers again it

1. puts back the parameters the node owns, as they were at the last poll before the loss: the node's private
   namespace (``~``, its running configuration and whatever it stores there, such as localisation's last pose),
   ``/use_sim_time`` when the node runs on sim time, and the names the node asked to keep (the simulator keeps
   ``robot_description``);
2. registers every publisher, subscriber and service again through rospy's own registration manager, which also
   connects each subscriber to the publishers the new master returns (actionlib's servers and clients are plain
   publishers and subscribers, so the move_base action server comes back with them);
3. logs one line saying how many of each it registered.

The thread never holds a lock a callback needs and its master calls time out, so a master that hangs delays no
callback. Parameters that no running node owns (those a launch file sets outside any node, such as a
``robot_description`` in a robot's namespace) are not put back: the docs list them for the user to set again.
"""

from __future__ import annotations

import threading
import time
import xmlrpc.client
from collections.abc import Sequence
from typing import Any

import rosgraph
import rospy
from rospy.impl.registration import (
    Registration,
    RegManager,
    get_registration_listeners,
    get_service_manager,
    get_topic_manager,
)

from mrs_nav.master_restart import MasterLiveness, MasterState
from mrs_nav.ros_processes import TimeoutTransport

POLL_PERIOD_S = 1.0  # wall s between two questions to the master
CALL_TIMEOUT_S = 5.0  # wall s a master call may take; a call that times out is skipped, only a refusal means lost


class MasterWatch:
    """A node's watch on its master (see the module docstring); :meth:`start` runs it in a daemon thread."""

    def __init__(self, keep: Sequence[str] = ()) -> None:
        """``keep``: parameter names (relative ones resolved in the node's namespace) the node puts back besides
        its private namespace."""
        self._who = rospy.get_name()
        self._uri = rosgraph.get_master_uri()  # as rospy finds it
        self._names = [self._who, *(rospy.resolve_name(name) for name in keep)]
        self._liveness = MasterLiveness()
        self._kept: dict[str, Any] = {}

    def start(self) -> None:
        threading.Thread(target=self._run, name="master_watch", daemon=True).start()

    def _run(self) -> None:
        while not rospy.is_shutdown():
            self.poll()
            time.sleep(POLL_PERIOD_S)

    def _ask(self, method: str, *args: Any) -> tuple[int, str, Any]:
        """One master API call as ``(code, message, value)``; raises OSError or xmlrpc.client.Error when the
        master does not answer within CALL_TIMEOUT_S."""
        master = xmlrpc.client.ServerProxy(self._uri, transport=TimeoutTransport(CALL_TIMEOUT_S))
        reply: Any = getattr(master, method)(self._who, *args)
        return int(reply[0]), str(reply[1]), reply[2]

    def _pid(self) -> int | None:
        """The master's pid, or None when it is not there; raises TimeoutError when it is there but slow."""
        try:
            code, _, pid = self._ask("getPid")
        except TimeoutError:
            raise
        except (OSError, xmlrpc.client.Error):
            return None
        return int(pid) if code == 1 else None

    def _read_params(self) -> dict[str, Any] | None:
        """The values of the kept names that are set now (an unset name is left out); None when the master did
        not answer every question."""
        values = {}
        try:
            for name in self._names:
                code, _, value = self._ask("getParam", name)
                if code == 1:
                    values[name] = value
        except (OSError, xmlrpc.client.Error):
            return None
        return values

    def poll(self) -> None:
        """Ask the master once and act on what changed."""
        # Read before asking the pid: the values count only if the same master answers after them.
        params = self._read_params()
        try:
            pid = self._pid()
        except TimeoutError:
            return  # slow, not gone (a loaded machine's master answers late): no "lost", no registering again
        change = self._liveness.observe(pid)
        if change is None:
            if params is not None:
                self._kept = params
        elif change.state is MasterState.LOST:
            rospy.logwarn(f"{self._who}: master lost at {self._uri}; will register again when it is back")
        else:
            restored = self._restore_params()
            pubs, subs, services = register_again()
            rospy.loginfo(
                f"{self._who}: master back (pid {change.pid}): re-registered {pubs} publishers, {subs} subscribers, "
                f"{services} services; put back {restored} parameters"
            )

    def _restore_params(self) -> int:
        """Set the kept values on the (new) master; how many parameters that is (a namespace counts its
        leaves)."""
        values = dict(self._kept)
        if not rospy.rostime.is_wallclock():
            values["/use_sim_time"] = True
        done = 0
        for name, value in values.items():
            try:
                code, message, _ = self._ask("setParam", name, value)
            except (OSError, xmlrpc.client.Error) as err:
                code, message = 0, str(err)
            if code == 1:
                done += _leaves(value)
            else:
                rospy.logwarn(f"{self._who}: could not put back parameter {name} on the new master: {message}")
        return done


def _leaves(value: Any) -> int:
    """How many parameters ``value`` holds: a namespace (a mapping) those under it, anything else one."""
    return sum(_leaves(inner) for inner in value.values()) if isinstance(value, dict) else 1


def register_again() -> tuple[int, int, int]:
    """Register every publisher, subscriber and service of this process with the master again (subscribers
    connect to the publishers it returns); the numbers of each. Blocks until the master takes them."""
    manager = next((x for x in get_registration_listeners().listeners if isinstance(x, RegManager)), None)
    if manager is None:  # rospy registers the node only after its first registration succeeded
        return 0, 0, 0
    topics = get_topic_manager()
    with topics.lock:  # a copy, taken as rospy takes it: topics may be added or removed meanwhile
        pubs, subs = topics.get_publications(), topics.get_subscriptions()
    services = get_service_manager().get_services()
    for name, data_type in pubs:
        manager.reg_added(name, data_type, Registration.PUB)
    for name, data_type in subs:
        manager.reg_added(name, data_type, Registration.SUB)
    for name, uri in services:
        manager.reg_added(name, uri, Registration.SRV)
    return len(pubs), len(subs), len(services)


def watch_master(keep: Sequence[str] = ()) -> MasterWatch:
    """Start watching the master for this node (after ``rospy.init_node``); see :class:`MasterWatch`."""
    watch = MasterWatch(keep)
    watch.poll()  # the pid of the master the node registered with, before any restart can happen unseen
    watch.start()
    return watch
