"""Real ROS 1 for integration tests: a roscore on a free port, roslaunch runs, bounded waits.

One master serves the whole pytest session (rospy can join only one master per process); each test starts
its own ``roslaunch`` against it and every process it started is ended when the test ends. Waits are bounded
in wall-clock time and sim time runs at the simulator's maximum rate, so no test sleeps for sim seconds.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import time
import uuid
import xmlrpc.client
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from mrs_nav.ros_processes import TAG_VARIABLE, free_port, kill_tagged, process, stop

REPO = Path(__file__).resolve().parents[1]
__all__ = ["REPO", "RosMaster", "free_port", "ros_env", "stop", "wait_for"]


def ros_env(master_uri: str, log_dir: Path) -> dict[str, str]:
    """Environment for ROS processes: this checkout as the package, the running interpreter's venv first."""
    env = dict(os.environ)
    env["ROS_MASTER_URI"] = master_uri
    env["ROS_PACKAGE_PATH"] = str(REPO)
    env["ROS_HOME"] = str(log_dir)
    env["ROS_LOG_DIR"] = str(log_dir)
    env["ROS_PYTHON_VERSION"] = "3"
    env["ROS_IP"] = "127.0.0.1"
    env["PATH"] = f"{Path(sys.executable).parent}:{env.get('PATH', '')}"
    env["PYTHONPATH"] = f"{REPO / 'src'}:{env.get('PYTHONPATH', '')}".rstrip(":")
    env["PYTHONUNBUFFERED"] = "1"
    return env


def wait_for(predicate: Callable[[], bool], timeout: float, what: str, period: float = 0.05) -> None:
    """Poll ``predicate`` until it holds; fail the test naming ``what`` after ``timeout`` wall seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(period)
    raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")


class _TimeoutTransport(xmlrpc.client.Transport):
    """XML-RPC with a socket timeout: a node that stopped answering must not hang a failure report."""

    def __init__(self, timeout: float) -> None:
        super().__init__()
        self.timeout = timeout

    def make_connection(self, host: Any) -> Any:
        connection = super().make_connection(host)
        connection.timeout = self.timeout
        return connection


def _call(uri: str, method: str, *args: Any, timeout: float = 5.0) -> Any:
    code, message, value = getattr(xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(timeout)), method)(
        "/pytest", *args
    )
    if code != 1:
        raise OSError(message)
    return value


def unconnected(master_uri: str, limit: int = 30) -> list[str]:
    """Each ``topic: publisher -> subscriber`` the master lists whose connection the publisher does not have.

    A publisher adds a subscriber's connection only after the handshake, so this names subscribers that never got
    a publisher's messages (a subscriber's own bus info lists a connection before it is made). For the message
    of a test that timed out waiting for a launch: it tells a node that stopped accepting from one that is slow."""
    publications, subscriptions, _ = _call(master_uri, "getSystemState")
    subscribers = dict(subscriptions)
    topics_of: dict[str, list[str]] = {}
    for topic, nodes in publications:
        for node in nodes:
            topics_of.setdefault(node, []).append(topic)
    lines: list[str] = []
    for node, topics in sorted(topics_of.items()):
        try:
            bus = _call(_call(master_uri, "lookupNode", node), "getBusInfo")
        except (OSError, xmlrpc.client.Error) as err:
            lines.append(f"{node}: not answering ({err})")
            continue
        # outbound entries: (id, subscriber's caller id, "o", transport, topic, connected, ...)
        served = {(entry[4], entry[1]) for entry in bus if entry[2] == "o"}
        lines += [f"{t}: {node} -> {s}" for t in topics for s in sorted(subscribers.get(t, ())) if (t, s) not in served]
    return lines[:limit] + ([f"... and {len(lines) - limit} more"] if len(lines) > limit else [])


class RosMaster:
    """A roscore on a free loopback port, with its logs under ``log_dir``."""

    def __init__(self, log_dir: Path) -> None:
        self.port = free_port()
        self.uri = f"http://127.0.0.1:{self.port}"
        self.log_dir = log_dir
        # Everything started with this environment carries the tag, so close() finds what a test left behind.
        self.tag = uuid.uuid4().hex
        self.env = {**ros_env(self.uri, log_dir), TAG_VARIABLE: self.tag}
        self.proc = subprocess.Popen(
            ["roscore", "-p", str(self.port)],
            env=self.env,
            start_new_session=True,
            stdout=(log_dir / "roscore.out").open("wb"),
            stderr=subprocess.STDOUT,
        )
        wait_for(self.is_up, 30.0, f"roscore on port {self.port}")

    def is_up(self) -> bool:
        if self.proc.poll() is not None:
            raise AssertionError(f"roscore exited with {self.proc.returncode}; see {self.log_dir}/roscore.out")
        try:
            code, _, _ = xmlrpc.client.ServerProxy(self.uri).getPid("/pytest")
        except OSError:
            return False
        return bool(code == 1)

    def close(self) -> None:
        stop(self.proc)
        kill_tagged(self.tag)

    @contextlib.contextmanager
    def launch(self, launch_file: str, *args: str, name: str | None = None) -> Iterator[subprocess.Popen[bytes]]:
        """Run ``roslaunch mrs_nav LAUNCH_FILE ARGS`` for the duration of the ``with`` block."""
        log = self.log_dir / f"{name or Path(launch_file).stem}-{time.monotonic_ns()}.log"
        with process(["roslaunch", "--wait", "mrs_nav", launch_file, *args], self.env, log) as proc:
            try:
                yield proc
            except AssertionError as err:
                if str(err).startswith("timed out"):
                    missing = "; ".join(unconnected(self.uri)) or "none"
                    err.add_note(f"connections the master lists and the publisher lacks: {missing}")
                raise
        # Keep the launch log next to the failure: pytest shows it with -rA on error.
        print(f"roslaunch log: {log}")
