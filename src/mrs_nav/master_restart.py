"""A ROS master that went away and came back: the one rule by which a node decides to register again.

A roscore stopped and started again on its port (Ctrl-C in its terminal, a crash) knows nothing of the nodes
still running: no publishers, subscribers or services, no parameters. rospy registers only once, at start, so
every node would carry on unseen by new clients. A node therefore asks the master for its process id about once
a second (:mod:`mrs_nav.ros.master_watch`) and feeds the answers to :class:`MasterLiveness`:

- no answer after answers: the master is **lost** (said once, however long it stays away);
- an answer after a loss: the master is **back** and the node registers again, whatever the pid (a master
  restarted in a container may get the same pid; registering again with the same master changes nothing);
- an answer with another pid than before, without a loss seen in between (restarted between two polls): **back**.

Anything a node reads from the master to put back later (its parameters) is taken only while the answers say the
master is the one the node knows (:meth:`MasterLiveness.observe` returns ``None``), so that a snapshot of a new,
empty master never replaces it.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass


class MasterState(enum.Enum):
    LOST = "lost"
    BACK = "back"


@dataclass(frozen=True)
class MasterChange:
    """What a poll found: the master lost, or back with the process id ``pid``."""

    state: MasterState
    pid: int | None = None


class MasterLiveness:
    """Told the master's process id at every poll (``None`` when it did not answer); says when it changes."""

    def __init__(self) -> None:
        self._pid: int | None = None
        self._lost = False

    def observe(self, pid: int | None) -> MasterChange | None:
        """The change this answer makes, by the module's rule; ``None`` while the master stays the one known (or
        stays away)."""
        if pid is None:
            if self._lost:
                return None
            self._lost = True
            return MasterChange(MasterState.LOST)
        restarted = self._lost or (self._pid is not None and pid != self._pid)
        self._pid, self._lost = pid, False
        return MasterChange(MasterState.BACK, pid) if restarted else None
