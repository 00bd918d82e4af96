"""A plain rclpy process (tests/ros/ros2_peer.py, from the ROS 2 venv) for the ros2_bridge tests.

Each peer runs on its own ROS_DOMAIN_ID (picked from a free port, so concurrent runs do not meet) with discovery
on this machine only. Tests that need it skip when the ROS 2 venv is absent (``make test`` makes it).
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest

from mrs_nav.bridge.ros2_link import ros2_python
from mrs_nav.ros_processes import free_port, stop

PEER = Path(__file__).with_name("ros2_peer.py")
ROS2_PYTHON = ros2_python("", os.environ, sys.prefix)
needs_ros2 = pytest.mark.skipif(
    not ROS2_PYTHON.exists(), reason=f"no ROS 2 venv at {ROS2_PYTHON.parent.parent} (MRS_NAV_ROS2=1 make install)"
)


def free_domain() -> int:
    """A ROS_DOMAIN_ID for one test: from a free port, so two runs on one machine are unlikely to share it."""
    return 1 + free_port() % 100


def high_domain() -> int:
    """A ROS_DOMAIN_ID at random from 201..232, above those of :func:`free_domain` and ``mrs-nav bench ros2``
    (1..200): a test's own, away from the others'."""
    return random.SystemRandom().randint(201, 232)


def ros2_env(domain: int) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE")}
    env.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", PYTHONUNBUFFERED="1")
    env.pop("ROS_LOCALHOST_ONLY", None)
    return env


class Ros2Peer:
    """The peer process; :attr:`last` holds each topic's latest JSON line."""

    def __init__(self, domain: int, log: Path, namespace: str = "") -> None:
        self.last: dict[str, dict[str, Any]] = {}
        self.lines: list[dict[str, Any]] = []
        self._log = log.open("wb")
        self.proc = subprocess.Popen(
            [str(ROS2_PYTHON), str(PEER), namespace],
            env=ros2_env(domain),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._log,
            start_new_session=True,
        )
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for raw in self.proc.stdout:
            line = json.loads(raw)
            self.lines.append(line)
            if "topic" in line:
                self.last[line["topic"]] = line

    def ready(self) -> bool:
        return any(line.get("ready") for line in self.lines)

    def send(self, command: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(command.encode() + b"\n")
        self.proc.stdin.flush()

    def close(self) -> None:
        """End of input ends the peer; a peer that does not end is stopped."""
        assert self.proc.stdin is not None
        self.proc.stdin.close()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=10.0)
        stop(self.proc)  # type: ignore[arg-type]
        self._log.close()
