"""Real ROS 1 for integration tests: a roscore on a free port, roslaunch runs, bounded waits.

One master serves the whole pytest session (rospy can join only one master per process); each test starts
its own ``roslaunch`` against it and every process it started is ended when the test ends. Waits are bounded
in wall-clock time and sim time runs at the simulator's maximum rate, so no test sleeps for sim seconds.
"""

from __future__ import annotations

import contextlib
import os
import re
import subprocess
import sys
import time
import uuid
import xmlrpc.client
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from mrs_nav.ros_processes import TAG_VARIABLE, TimeoutTransport, free_port, kill_tagged, process, stop

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


def _call(uri: str, method: str, *args: Any, timeout: float = 5.0) -> Any:
    code, message, value = getattr(xmlrpc.client.ServerProxy(uri, transport=TimeoutTransport(timeout)), method)(
        "/pytest", *args
    )
    if code != 1:
        raise OSError(message)
    return value


def forget_dead_nodes(master_uri: str) -> list[str]:
    """Unregister every node whose XML-RPC server no longer answers (``rosnode cleanup``, without asking); return
    their names.

    The session's master outlives each launch, and a node killed before it could unregister stays listed with its
    old port. When a later launch starts a node of the same name, the master sends ``shutdown`` to that old port,
    which by then may belong to another new node: a CI run lost its simulator that way ("[/map_server] Reason: new
    node registered with same name" in the simulator's log), and the launch died with it."""
    publications, subscriptions, services = _call(master_uri, "getSystemState")
    nodes = {node for _, names in [*publications, *subscriptions, *services] for node in names}
    dead: list[str] = []
    for node in sorted(nodes):
        try:
            _call(_call(master_uri, "lookupNode", node), "getPid", timeout=2.0)
        except ConnectionRefusedError:
            dead.append(node)
        except (OSError, xmlrpc.client.Error):
            continue  # slow or half-started: not provably dead, leave it
    master = xmlrpc.client.ServerProxy(master_uri, transport=TimeoutTransport(5.0))
    for node in dead:
        try:
            api = _call(master_uri, "lookupNode", node)
        except OSError:
            continue
        for topic, names in publications:
            if node in names:
                master.unregisterPublisher(node, topic, api)
        for topic, names in subscriptions:
            if node in names:
                master.unregisterSubscriber(node, topic, api)
        for service, names in services:
            if node in names:
                with contextlib.suppress(OSError):
                    master.unregisterService(node, service, _call(master_uri, "lookupService", service))
    return dead


def unconnected(master_uri: str) -> dict[str, list[tuple[str, str]]]:
    """Per publishing node, each ``(topic, subscriber)`` the master lists whose connection the publisher does not
    have; a node that does not answer maps to ``[("not answering", reason)]``.

    A publisher adds a subscriber's connection only after the handshake, so this names subscribers that never got
    a publisher's messages (a subscriber's own bus info lists a connection before it is made). For the message
    of a test that timed out waiting for a launch: it tells a node that stopped accepting from one that is slow."""
    publications, subscriptions, _ = _call(master_uri, "getSystemState")
    subscribers = dict(subscriptions)
    topics_of: dict[str, list[str]] = {}
    for topic, nodes in publications:
        for node in nodes:
            topics_of.setdefault(node, []).append(topic)
    gaps: dict[str, list[tuple[str, str]]] = {}
    for node, topics in sorted(topics_of.items()):
        try:
            bus = _call(_call(master_uri, "lookupNode", node), "getBusInfo")
        except (OSError, xmlrpc.client.Error) as err:
            gaps[node] = [("not answering", str(err))]
            continue
        # outbound entries: (id, subscriber's caller id, "o", transport, topic, connected, ...)
        served = {(entry[4], entry[1]) for entry in bus if entry[2] == "o"}
        missing = [(t, s) for t in topics for s in sorted(subscribers.get(t, ())) if (t, s) not in served]
        if missing:
            gaps[node] = missing
    return gaps


# rospy's connection set-up: a thread with one of these among its innermost frames when a launch stalls is where it
# waits (the TCPROS server reads each handshake in its accept thread, so one stuck peer holds up every later one)
_HANDSHAKE_FRAMES = ("_tcp_server_callback", "add_connection", "read_ros_handshake_header", "connect (", "read_header")


def handshake_stacks(master_uri: str, nodes: list[str]) -> list[str]:
    """The threads of ``nodes`` (py-spy dumps with locals) that run, or wait in rospy's connection set-up, each
    peer port in them named with the process that owns it."""
    spy = Path(sys.executable).parent / "py-spy"
    out: list[str] = []
    for node in nodes:
        try:
            pid = _call(_call(master_uri, "lookupNode", node), "getPid")
            dump = subprocess.run(
                [str(spy), "dump", "--locals", "--pid", str(pid)],
                check=False,
                capture_output=True,
                text=True,
                timeout=30,
            )
        except (OSError, xmlrpc.client.Error, subprocess.TimeoutExpired) as err:
            out.append(f"{node}: no stack ({err})")
            continue
        shown = []
        for thread in dump.stdout.split("\nThread ")[1:]:
            head, *lines = thread.splitlines()
            frames = [f for f in lines if not f.startswith("        ")]  # frame lines; deeper ones are their locals
            if "(active" in head or any(name in f for f in frames[:4] for name in _HANDSHAKE_FRAMES):
                kept = "\n".join(_without_threading_frames(lines))
                ports = sorted(set(re.findall(r'\("127\.0\.0\.1", (\d+)\)', thread)))
                owners = "".join(f"\n    port {port}: {_owner(int(port))}" for port in ports)
                shown.append(f"{node} (pid {pid}) thread {head}\n{kept}{owners}")
        out += shown or [f"{node} (pid {pid}): nothing in connection set-up {dump.stderr.strip()}".rstrip()]
    return out


def _without_threading_frames(lines: list[str]) -> Iterator[str]:
    """A py-spy thread's lines less the frames (and their locals) of threading.py's start-up."""
    skipping = False
    for line in lines:
        if not line.startswith("        "):
            skipping = "(threading.py:" in line
        if not skipping:
            yield line


def _owner(port: int) -> str:
    """The process (pid and command) with a loopback TCP socket on local ``port``, from /proc."""
    inodes = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with contextlib.suppress(OSError), open(table, encoding="ascii") as rows:
            for row in list(rows)[1:]:
                fields = row.split()
                if int(fields[1].rsplit(":", 1)[1], 16) == port:
                    inodes.add(f"socket:[{fields[9]}]")
    for fd_dir in Path("/proc").glob("[0-9]*/fd"):
        with contextlib.suppress(OSError):
            if any(os.readlink(fd) in inodes for fd in fd_dir.iterdir()):
                command = (fd_dir.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
                return f"pid {fd_dir.parent.name}: {command[:200]}"
    return "no process found"


def stall_report(master_uri: str, limit: int = 30) -> list[str]:
    """Notes for a test that timed out inside a launch: the connections that never came up (at most ``limit``),
    then the stacks of both ends of each (the stuck one may be either)."""
    gaps = unconnected(master_uri)
    missing = [f"{t}: {pub} -> {sub}" for pub, pairs in gaps.items() for t, sub in pairs]
    listed = "; ".join(missing[:limit]) + (f"; ... and {len(missing) - limit} more" if len(missing) > limit else "")
    ends = set(gaps) | {sub for pairs in gaps.values() for t, sub in pairs if t != "not answering"}
    stacks = handshake_stacks(master_uri, sorted(ends))
    return [f"connections the master lists and the publisher lacks: {listed or 'none'}", *stacks]


def last_warnings(launch_logs: Path, per_node: int = 2) -> list[str]:
    """The last ``per_node`` warnings or errors in each rospy node log of a launch's log folder, named by file."""
    out = []
    for path in sorted(p for p in launch_logs.glob("*/*.log") if p.parent.name != "latest"):
        lines = path.read_text(errors="replace").splitlines()
        warnings = [line for line in lines if "][WARNING]" in line or "][ERROR]" in line]
        out += [f"{path.name}: {line}" for line in warnings[-per_node:]]
    return out


def node_pid(master: RosMaster, node: str) -> int:
    """The process id of the registered ROS node ``node`` (from its own XML-RPC server)."""
    code, _, uri = xmlrpc.client.ServerProxy(master.uri).lookupNode("/pytest", node)
    assert code == 1, f"node {node} is not registered"
    code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/pytest")
    assert code == 1
    return int(pid)


class RosMaster:
    """A roscore on a free loopback port, with its logs under ``log_dir``."""

    def __init__(self, log_dir: Path) -> None:
        self.port = free_port()
        self.uri = f"http://127.0.0.1:{self.port}"
        self.log_dir = log_dir
        # Everything started with this environment carries the tag, so close() finds what a test left behind.
        self.tag = uuid.uuid4().hex
        self.env = {**ros_env(self.uri, log_dir), TAG_VARIABLE: self.tag}
        self._start("roscore.out")

    def _start(self, log_name: str) -> None:
        self.proc = subprocess.Popen(
            ["roscore", "-p", str(self.port)],
            env=self.env,
            start_new_session=True,
            stdout=(self.log_dir / log_name).open("wb"),
            stderr=subprocess.STDOUT,
        )
        wait_for(self.is_up, 30.0, f"roscore on port {self.port}")

    def restart(self) -> None:
        """Stop roscore as Ctrl-C in its terminal does and start a new one on the same port (a new master with
        no registrations and no parameters); its output goes to ``roscore-restarted.out``."""
        stop(self.proc)
        self._start("roscore-restarted.out")

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
        # Each launch's node logs in a folder of its own: a later launch's nodes of the same names would overwrite
        # them (roslaunch numbers them per launch), and a failure is read from them after the whole run.
        nodes = log.with_suffix("")
        where = f"roslaunch log: {log}; its nodes' logs: {nodes}"
        forget_dead_nodes(self.uri)  # a node an earlier test killed must not take one of this launch's down
        try:
            with process(
                ["roslaunch", "--wait", "mrs_nav", launch_file, *args], {**self.env, "ROS_LOG_DIR": str(nodes)}, log
            ) as proc:
                try:
                    yield proc
                except AssertionError as err:
                    if str(err).startswith("timed out"):
                        for note in [*stall_report(self.uri), *last_warnings(nodes)]:
                            err.add_note(note)
                    err.add_note(where)
                    raise
        finally:
            forget_dead_nodes(self.uri)  # what roslaunch had to SIGKILL is still registered
        # Keep the launch log next to the test's output: pytest shows it with -rA.
        print(where)


@contextlib.contextmanager
def robot_state_publisher(master: RosMaster) -> Iterator[subprocess.Popen[bytes]]:
    """The Burger's description and robot_state_publisher (/tf_static base_footprint -> base_scan), as a robot's
    bringup provides them: slam.launch and navigation.launch with sim:=false start none, a robot already runs."""
    urdf = (REPO / "urdf" / "burger.urdf").read_text(encoding="utf-8")
    _call(master.uri, "setParam", "/robot_description", urdf)
    log = master.log_dir / f"robot_state_publisher-{time.monotonic_ns()}.log"
    try:
        with process(["rosrun", "robot_state_publisher", "robot_state_publisher"], master.env, log) as proc:
            yield proc
    finally:
        forget_dead_nodes(master.uri)
