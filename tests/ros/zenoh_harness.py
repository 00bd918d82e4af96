"""Helpers for the Zenoh bridge's ROS tests: starting bridges and routers, Zenoh collectors, ROS tickers, and
``mrs-nav`` run with ROS imports blocked."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zenoh

from mrs_nav.bridge.keys import status_key
from mrs_nav.bridge.wire import decode_status
from tests.rosharness import REPO, RosMaster, free_port, stop, wait_for


@dataclass
class Bridge:
    endpoint: str  # where remote peers connect
    log_dir: Path
    name: str

    def log(self) -> str:
        return "".join(p.read_text(errors="replace") for p in sorted(self.log_dir.glob(f"{self.name}-*.log")))


def start_bridge(ros_master: RosMaster, tmp: Path, name: str, config: dict[str, Any], *args: str) -> Any:
    path = tmp / f"{name}.yaml"
    path.write_text(json.dumps({"discovery_period": 0.2, **config}))  # JSON is YAML
    return ros_master.launch("zenoh_bridge.launch", f"config_file:={path}", f"node_name:={name}", *args, name=name)


def status(session: zenoh.Session) -> dict[str, Any]:
    """The bridge's ``@bridge/status`` answer."""
    for reply in session.get(status_key("mrs_nav"), timeout=2.0):
        if reply.ok is not None:
            return decode_status(reply.ok.payload.to_bytes())
    raise AssertionError("the bridge did not answer its status")


def wait_bridge_up(session: zenoh.Session, proc: Any, what: str) -> None:
    """The bridge answers queries once its session is open (nothing bridged needed)."""

    def answered() -> bool:
        assert proc.poll() is None, f"{what}: roslaunch exited"
        return any(r.ok is not None for r in session.get(status_key("mrs_nav"), timeout=0.5))

    wait_for(answered, 30, f"{what} to answer on Zenoh")


class Router:
    """``mrs-nav router`` in a subprocess on a fixed endpoint, restartable."""

    def __init__(self) -> None:
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.proc: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mrs_nav", "router", "--listen", self.endpoint],
            cwd=REPO,
            env={**os.environ, "PYTHONPATH": str(REPO / "src")},
            stdout=subprocess.PIPE,
            start_new_session=True,
        )
        assert self.proc.stdout is not None
        assert self.proc.stdout.readline().decode() == f"zenoh router listening on {self.endpoint}\n"

    def kill(self) -> None:
        if self.proc is not None:
            stop(self.proc, grace=0.0)
            self.proc = None


class Collector:
    """A Zenoh subscriber keeping (arrival time, key, encoding, payload, attachment) of every sample."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        self.samples: list[tuple[float, str, str, bytes, bytes | None]] = []
        self._lock = threading.Lock()
        self.sub = session.declare_subscriber(key, self._on)

    def _on(self, s: zenoh.Sample) -> None:
        att = s.attachment.to_bytes() if s.attachment is not None else None
        with self._lock:
            self.samples.append((time.monotonic(), str(s.key_expr), str(s.encoding), s.payload.to_bytes(), att))

    def of(self, key: str) -> list[tuple[float, str, str, bytes, bytes | None]]:
        with self._lock:
            return [s for s in self.samples if s[1] == key]


class Ticker:
    """Publishes on a ROS topic from a thread at ``rate`` Hz; ``make(i)`` builds message number i."""

    def __init__(
        self, rospy: Any, topic: str, msg_type: Any, make: Any, rate: float, *, subscribed: bool = True
    ) -> None:
        self.pub = rospy.Publisher(topic, msg_type, queue_size=1000)
        self.make, self.period, self.subscribed = make, 1.0 / rate, subscribed
        self.sent: list[Any] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set():
            msg = self.make(len(self.sent))
            self.pub.publish(msg)
            self.sent.append(msg)
            next_t += self.period
            self._stop.wait(max(0.0, next_t - time.monotonic()))

    def __enter__(self) -> Ticker:
        if self.subscribed:
            wait_for(lambda: self.pub.get_num_connections() > 0, 15, f"a bridge subscribed to {self.pub.resolved_name}")
        self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        self._thread.join()
        self.pub.unregister()


# Runs mrs-nav in a process where ROS cannot be imported: the monitor must work on a machine without ROS.
_WITHOUT_ROS = """
import sys
class Block:
    def find_spec(self, name, path=None, target=None):
        root = name.split('.')[0]
        if root in ('rospy', 'roslib', 'genpy', 'rosgraph', 'tf2_ros') or root.endswith('_msgs'):
            raise ImportError('the monitor imported ' + name)
sys.meta_path.insert(0, Block())
from mrs_nav.cli.main import main
sys.exit(main(sys.argv[1:]))
"""


def mrs_nav(*args: str) -> subprocess.CompletedProcess[str]:
    """Run this checkout's ``mrs-nav`` (not whichever one is installed), with ROS imports blocked."""
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    cmd = [sys.executable, "-c", _WITHOUT_ROS, *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=60, check=False, env=env)


def serialized(msg: Any) -> bytes:
    buf = io.BytesIO()
    msg.serialize(buf)
    return buf.getvalue()
