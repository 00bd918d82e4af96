"""A fleet behind one Zenoh router: find every robot's bridge and watch them all through one session.

Each robot runs its own bridge with its own key prefix (``mrs_nav/tb3_0``, ``mrs_nav/tb3_1``, ... when the
bridges run in the robots' namespaces; any prefix when each robot has its own master). Every bridge answers
``P/@bridge/status``, so one query on ``ROOT/**/@bridge/status`` (``**`` matches no ``@`` chunk, so only the
status keys themselves reply) lists the fleet: the prefixes are the reply keys without the status suffix.
"""

from __future__ import annotations

import time
from typing import Any

import zenoh

from mrs_nav.bridge.keys import STATUS_SUFFIX, robot_prefix
from mrs_nav.bridge.monitor import RemoteMonitor
from mrs_nav.bridge.session import open_client_session
from mrs_nav.errors import InvalidInputError


def discover_prefixes(session: zenoh.Session, root: str = "mrs_nav", timeout: float = 2.0) -> list[str]:
    """Key prefixes of the bridges under ``root`` (``root`` itself included) that answer within ``timeout`` s.

    A router learns a bridge's queryable some milliseconds after the bridge connects, so the question is asked
    again until the answers stop changing for a while or the timeout ends; an empty list means none answered.
    """
    root = robot_prefix(root)
    selectors = [f"{root}/**{STATUS_SUFFIX}", f"{root}{STATUS_SUFFIX}"] if root else [f"**{STATUS_SUFFIX}"]
    found: set[str] = set()
    deadline = time.monotonic() + timeout
    settled_since = time.monotonic()
    while time.monotonic() < deadline:
        before = len(found)
        for selector in selectors:
            for reply in session.get(selector, timeout=min(0.5, max(0.05, deadline - time.monotonic()))):
                if reply.ok is not None:
                    found.add(str(reply.ok.key_expr).removesuffix(STATUS_SUFFIX))
        if len(found) != before:
            settled_since = time.monotonic()
        elif found and time.monotonic() - settled_since >= 0.3:
            break
        time.sleep(0.05)
    return sorted(found)


def robot_name(prefix: str) -> str:
    """How the fleet names a robot: the last chunk of its prefix (``mrs_nav/tb3_1`` -> ``tb3_1``)."""
    return prefix.rsplit("/", 1)[-1]


class FleetMonitor:
    """One :class:`RemoteMonitor` per robot found under ``root``, all on one Zenoh session."""

    def __init__(
        self,
        connect: list[str],
        root: str = "mrs_nav",
        timeout: float = 2.0,
        mode: str = "client",
        config_file: str = "",
    ) -> None:
        self.connect = connect
        self.root = robot_prefix(root)
        self.timeout = timeout
        self.mode = mode
        self.config_file = config_file
        self.robots: dict[str, RemoteMonitor] = {}
        self._session: zenoh.Session | None = None

    def open(self) -> FleetMonitor:
        """Connect and discover the fleet; InvalidInputError when no bridge answers under ``root``."""
        self._session = open_client_session(self.connect, self.mode, self.config_file)
        prefixes = discover_prefixes(self._session, self.root, self.timeout)
        if not prefixes:
            where = ", ".join(self.connect)
            raise InvalidInputError(f"no bridge under {self.root!r} answered on {where} within {self.timeout:g} s")
        for prefix in prefixes:
            monitor = RemoteMonitor(self.connect, prefix, self.timeout, self.mode, self.config_file)
            self.robots[robot_name(prefix) if prefix != self.root else prefix] = monitor.attach(self._session)
        return self

    def robot(self, name: str) -> RemoteMonitor:
        """The monitor of robot ``name`` (its name or its whole prefix)."""
        for key, monitor in self.robots.items():
            if name in (key, monitor.prefix):
                return monitor
        raise InvalidInputError(f"robot {name!r} is not in the fleet (found: {', '.join(self.robots)})")

    def close(self) -> None:
        for monitor in self.robots.values():
            monitor.close()  # its subscribers; the session is ours
        session, self._session = self._session, None
        if session is not None:
            session.close()  # type: ignore[no-untyped-call]

    def __enter__(self) -> FleetMonitor:
        try:
            return self.open()
        except BaseException:
            self.close()
            raise

    def __exit__(self, *_: Any) -> None:
        self.close()
