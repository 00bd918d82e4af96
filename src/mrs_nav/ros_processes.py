"""Real ROS processes for benchmarks: a roscore on a free port, launches, reading /clock; all cleaned up.

No rospy here (the benchmarks are part of the ROS-free core): processes are started with Debian's
``roscore``/``roslaunch``/``rostopic`` and stopped by process group (SIGINT as Ctrl-C would, then SIGKILL).
When run from a source checkout, the checkout is put first on ROS_PACKAGE_PATH and PYTHONPATH so that
``roslaunch mrs_nav ...`` runs this code.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import uuid
import xmlrpc.client
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mrs_nav.errors import MrsNavError
from mrs_nav.geometry import Pose2D
from mrs_nav.resources import CHECKOUT


class RosProcessError(MrsNavError):
    """A ROS process the benchmark needs did not start or answer."""


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def ros_env(uri: str, log_dir: Path) -> dict[str, str]:
    """Environment for ROS processes on master ``uri``, logging under ``log_dir``, this interpreter's venv first."""
    env = dict(os.environ)
    env.update(
        ROS_MASTER_URI=uri,
        ROS_HOME=str(log_dir),
        ROS_LOG_DIR=str(log_dir),
        ROS_IP="127.0.0.1",
        ROS_PYTHON_VERSION="3",
        PATH=f"{Path(sys.executable).parent}:{env.get('PATH', '')}",
    )
    if (CHECKOUT / "package.xml").is_file():
        env["ROS_PACKAGE_PATH"] = f"{CHECKOUT}:{env.get('ROS_PACKAGE_PATH', '')}".rstrip(":")
        env["PYTHONPATH"] = f"{CHECKOUT / 'src'}:{env.get('PYTHONPATH', '')}".rstrip(":")
    return env


# Every process started here carries a unique value of this variable, and so do the nodes roslaunch starts
# from it: roslaunch puts each node in a session of its own, where a signal to roslaunch's group never
# reaches, so leftovers are found by this tag instead.
TAG_VARIABLE = "MRS_NAV_PROCESS_TAG"


def tagged_pids(tag: str) -> list[int]:
    """The live processes whose environment holds ``TAG_VARIABLE=tag``."""
    needle = f"{TAG_VARIABLE}={tag}".encode()
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            environ = (entry / "environ").read_bytes()
        except OSError:
            continue
        if needle in environ.split(b"\0"):
            pids.append(int(entry.name))
    return pids


def kill_tagged(tag: str) -> list[int]:
    """SIGKILL every process whose environment holds ``TAG_VARIABLE=tag``; returns their pids."""
    killed = []
    for pid in tagged_pids(tag):
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)
    return killed


@contextlib.contextmanager
def process(args: list[str], env: dict[str, str], log: Path, grace: float = 20.0) -> Iterator[subprocess.Popen[bytes]]:
    """A process in its own group, output to ``log``, for the block.

    At the end it gets SIGINT (as Ctrl-C would; roslaunch then stops its nodes), ``grace`` seconds to exit,
    then SIGKILL, and any process it left behind (found by its tag) is killed too.
    """
    tag = uuid.uuid4().hex
    with log.open("wb") as out:
        proc = subprocess.Popen(
            args, env={**env, TAG_VARIABLE: tag}, start_new_session=True, stdout=out, stderr=subprocess.STDOUT
        )
        try:
            yield proc
        finally:
            stop(proc, grace)
            kill_tagged(tag)


def stop(proc: subprocess.Popen[bytes], grace: float = 10.0) -> None:
    """SIGINT the process group (as Ctrl-C would), ``grace`` seconds to exit, then SIGKILL what is left."""
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGINT)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=grace)
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=5)


class TimeoutTransport(xmlrpc.client.Transport):
    """XML-RPC with a socket timeout (s): a peer that stopped answering must not hang its caller."""

    def __init__(self, timeout: float) -> None:
        super().__init__()
        self.timeout = timeout

    def make_connection(self, host: Any) -> Any:
        connection = super().make_connection(host)
        connection.timeout = self.timeout
        return connection


def wait_for_master(uri: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            reply: Any = xmlrpc.client.ServerProxy(uri).getPid("/mrs_nav_bench")
            if reply[0] == 1:
                return
        except OSError:
            pass
        time.sleep(0.1)
    raise RosProcessError(f"roscore at {uri} did not come up within {timeout:.0f} s")


@contextlib.contextmanager
def roscore(log_dir: Path) -> Iterator[dict[str, str]]:
    """A roscore on a free loopback port for the block; yields the environment for processes using it."""
    port = free_port()
    uri = f"http://127.0.0.1:{port}"
    env = ros_env(uri, log_dir)
    with process(["roscore", "-p", str(port)], env, log_dir / "roscore.log"):
        wait_for_master(uri)
        yield env


def roslaunch_command(launch_file: str, world: Path, start: Pose2D, *args: str) -> list[str]:
    """``roslaunch --wait mrs_nav <launch_file>`` in ``world`` from ``start``, then further ``arg:=value``s."""
    return [
        "roslaunch",
        "--wait",
        "mrs_nav",
        launch_file,
        f"world:={world.resolve()}",
        f"x:={start.x}",
        f"y:={start.y}",
        f"yaw:={start.yaw}",
        *args,
    ]


#: Wall seconds a launched stack may take to publish its first /clock: every node imports numpy, scipy and the
#: compiled kernels first, which on a loaded 2-core machine took over a minute.
STARTUP_TIMEOUT_S = 180.0


def read_clock(env: dict[str, str], timeout: float = 20.0) -> tuple[float, float]:
    """(sim seconds on /clock, monotonic wall time when it was read), via ``rostopic echo``."""
    try:
        out = subprocess.run(
            ["rostopic", "echo", "-n", "1", "/clock"],
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise RosProcessError(f"no /clock within {timeout:.0f} s") from None
    wall = time.monotonic()
    match = re.search(r"secs:\s*(\d+)\s*\n\s*nsecs:\s*(\d+)", out.stdout)
    if not match:
        raise RosProcessError(f"could not read /clock: {out.stderr.strip()[-300:]}")
    return int(match.group(1)) + int(match.group(2)) * 1e-9, wall


def run_peer(proc: subprocess.Popen[bytes], env: dict[str, str], log_dir: Path, peer_args: list[str]) -> Any:
    """Once the launch ``proc`` (logging to ``log_dir/launch.log``) has its clock running, run
    :mod:`mrs_nav.ros.navigation_bench_peer` with ``peer_args`` against it; the peer's JSON result."""
    out = log_dir / "result.json"
    # the launch is up and /use_sim_time set before the peer starts
    read_clock(env, timeout=STARTUP_TIMEOUT_S)
    peer = [sys.executable, "-m", "mrs_nav.ros.navigation_bench_peer", "--out", str(out), *peer_args]
    done = subprocess.run(peer, env=env, capture_output=True, text=True, timeout=900, check=False)
    if done.returncode != 0 or not out.is_file():
        log = (log_dir / "launch.log").read_text()[-500:]
        raise RosProcessError(f"navigation bench peer failed: {done.stderr.strip()[-300:]} {log}")
    if proc.poll() is not None:
        raise RosProcessError(f"roslaunch exited early: {(log_dir / 'launch.log').read_text()[-500:]}")
    return json.loads(out.read_text())


def node_pid(uri: str, node: str, timeout: float = 10.0) -> int:
    """The process id of ``node`` (``/slam``) registered with the master at ``uri`` (its XML-RPC ``getPid``)."""
    master = xmlrpc.client.ServerProxy(uri, transport=TimeoutTransport(timeout))
    lookup: Any = master.lookupNode("/mrs_nav_bench", node)
    if lookup[0] != 1:
        raise RosProcessError(f"node {node} is not registered with {uri}: {lookup[1]}")
    reply: Any = xmlrpc.client.ServerProxy(lookup[2], transport=TimeoutTransport(timeout)).getPid("/mrs_nav_bench")
    if reply[0] != 1:
        raise RosProcessError(f"node {node} did not give its pid: {reply[1]}")
    return int(reply[2])


def resident_bytes(pid: int | str = "self") -> int:
    """Resident set size now (bytes) of process ``pid`` (this one by default), from Linux /proc."""
    with open(f"/proc/{pid}/statm", encoding="ascii") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def process_usage(pid: int) -> tuple[int, float]:
    """(resident set size in bytes, CPU seconds in user and kernel mode) of process ``pid``, from Linux /proc."""
    try:
        rss = resident_bytes(pid)
        with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
            # fields after the command name, which is in parentheses and may hold spaces: utime and stime are the
            # 14th and 15th fields of the line, the 12th and 13th after the closing parenthesis
            fields = stat.read().rsplit(")", 1)[1].split()
    except OSError as err:
        raise RosProcessError(f"process {pid} is gone: {err}") from err
    return rss, (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
