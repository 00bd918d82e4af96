"""Zenoh bridge: latency added over a direct ROS subscriber, loss, CPU and RSS at /odom 100 Hz + /scan 5 Hz +
/map 1 Hz, with TLS on and 5 remote subscribers.

Starts its own roscore and a zenoh_bridge as the robot's Zenoh router on a free loopback TLS port (mutual TLS
with certificates made by openssl for the run, the bridge's access control on, multicast scouting off), a ROS
peer (:mod:`mrs_nav.ros.bridge_bench_peer`) that publishes the load and subscribes to it directly, and 5 remote
subscribers (:mod:`mrs_nav.bench.bridge_subscriber`), each a process with its own TLS client session, as remote
users' would be. For every message (matched by ``header.seq``, the first 4
bytes of the payload) and subscriber the added latency is the Zenoh receive time minus the direct ROS
subscriber's receive time, both wall clock on this machine; a message is lost if any subscriber misses it. The
bridge's CPU use is its process's user + system time over the run, in % of one core; its RSS is sampled every
second, and its drift is the slope of a least-squares line through the samples.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import zenoh

from mrs_nav.bridge.certs import make_ca, make_cert
from mrs_nav.bridge.session import open_client_session
from mrs_nav.bridge.wire import decode_attachment
from mrs_nav.errors import MrsNavError
from mrs_nav.options import duration_option
from mrs_nav.resources import CHECKOUT
from mrs_nav.ros_processes import RosProcessError, free_port, process, roscore, stop
from mrs_nav.tables import markdown_table

TOPICS = {"/odom": 100.0, "/scan": 5.0, "/map": 1.0}
SUBSCRIBERS = 5
SETTLE = 0.2  # the RSS drift is fitted after this fraction of the run
TARGET_P50_MS, TARGET_P99_MS = 0.5, 3.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--duration", type=duration_option, default=60.0, help="measured seconds (default 60)")
    parser.add_argument(
        "--floors",
        type=duration_option,
        default=None,
        help="then measure the floors under it for this many seconds each (sockets; Zenoh TCP/TLS, "
        "universal/lowlatency transport; no ROS, no bridge) and add them to the section",
    )


def rss_mb(pid: int) -> float:
    """Resident set size (MB) of process ``pid`` from /proc."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise MrsNavError(f"no VmRSS for process {pid}")


def tls_files(tmp: Path) -> tuple[Path, Path]:
    """Zenoh JSON5 files of the bridge (router, mutual TLS) and of its remote clients, with fresh certificates."""
    ca = make_ca(tmp / "pki")
    server, client = make_cert(ca, tmp / "pki", "bridge", ("127.0.0.1",)), make_cert(ca, tmp / "pki", "client")
    bridge, remote = tmp / "bridge.json5", tmp / "client.json5"
    common = {"root_ca_certificate": str(ca.cert), "enable_mtls": True}
    tls = {**common, "listen_certificate": str(server.cert), "listen_private_key": str(server.key)}
    bridge.write_text(json.dumps({"transport": {"link": {"tls": tls}}}))
    tls = {**common, "connect_certificate": str(client.cert), "connect_private_key": str(client.key)}
    remote.write_text(json.dumps({"transport": {"link": {"tls": tls}}}))
    return bridge, remote


def cpu_seconds(pid: int) -> float:
    """User + system CPU time (s) of process ``pid`` from /proc."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@dataclass(frozen=True)
class Received:
    """What one remote subscriber got: per topic, header.seq -> its receive time and -> the time the bridge's
    rospy callback got the message (both wall clock, s)."""

    times: dict[str, dict[int, float]]
    bridge: dict[str, dict[int, float]]

    def to_json(self) -> str:
        return json.dumps({"times": self.times, "bridge": self.bridge})

    @classmethod
    def from_json(cls, text: str) -> Received:
        data = json.loads(text)  # JSON keys are text: header.seq back to int
        times, bridge = (
            {t: {int(s): v for s, v in seqs.items()} for t, seqs in data[k].items()} for k in ("times", "bridge")
        )
        return cls(times, bridge)


class Receiver:
    """Zenoh receive times (wall clock, s) per ROS topic and header.seq, and the attachments, which carry the
    time the bridge's rospy callback got the message.

    :meth:`subscribe` declares one subscriber per topic (key ``mrs_nav`` + topic), each with a callback run on
    the Zenoh thread that read the sample and doing only what it must: every sample arrives cold (10 ms apart,
    other processes in between), where this callback costs 45-50 us against 76-78 us for one subscriber on
    ``mrs_nav/**`` that parses the key and takes a lock (what the README advises remote users too)."""

    def __init__(self, topics: Iterable[str] = TOPICS) -> None:
        topics = tuple(topics)  # read twice (the fleet bench passes a generator)
        self.times: dict[str, dict[int, float]] = {t: {} for t in topics}
        self.attachments: dict[str, dict[int, bytes]] = {t: {} for t in topics}

    def subscribe(self, session: Any) -> None:
        """One subscriber per topic on ``session`` (each topic's dictionaries are written by its callback only,
        and read after the session is closed: no lock)."""
        for topic in self.times:
            callback = self._callback(self.times[topic], self.attachments[topic])
            session.declare_subscriber(f"mrs_nav{topic}", zenoh.handlers.Callback(callback, indirect=False))

    @staticmethod
    def _callback(times: dict[int, float], attachments: dict[int, bytes]) -> Callable[[Any], None]:
        def on_sample(sample: Any, now: Callable[[], float] = time.time) -> None:
            received = now()
            seq = int.from_bytes(sample.payload.to_bytes()[:4], "little")
            times[seq] = received
            attachment = sample.attachment
            if attachment is not None:
                attachments[seq] = attachment.to_bytes()

        return on_sample

    def received(self) -> Received:
        """Everything received so far, the attachments decoded (after the run: the callback only stores)."""
        times = {topic: dict(by_seq) for topic, by_seq in self.times.items()}
        attachments = {topic: dict(by_seq) for topic, by_seq in self.attachments.items()}
        bridge = {
            topic: {seq: decode_attachment(a).receive_time_ns * 1e-9 for seq, a in by_seq.items()}
            for topic, by_seq in attachments.items()
        }
        return Received(times, bridge)


def run(args: argparse.Namespace) -> str:
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_bridge_") as tmp:
        body = _measure(Path(tmp), args.duration)
        if args.floors:
            from mrs_nav.bench import bridge_floor  # noqa: PLC0415 - it imports this module

            body += "\n" + bridge_floor.measure(Path(tmp), args.floors)
        return body


def _measure(tmp: Path, duration: float) -> str:
    endpoint = f"tls/127.0.0.1:{free_port()}"
    bridge_tls, client_tls = tls_files(tmp)
    config = tmp / "bridge.yaml"
    config.write_text(json.dumps({"mode": "router", "listen": [endpoint], "zenoh_config": str(bridge_tls)}))
    rss: list[tuple[float, float]] = []
    with contextlib.ExitStack() as stack:
        env = stack.enter_context(roscore(tmp))
        bridge_cmd = [sys.executable, str(CHECKOUT / "scripts" / "zenoh_bridge"), f"_config_file:={config}"]
        bridge = stack.enter_context(process(bridge_cmd, env, tmp / "zenoh_bridge.log"))
        connect_when_up(endpoint, str(client_tls), bridge).close()
        subscribers = [
            stack.enter_context(process(subscriber_command(endpoint, client_tls, tmp, i), env, tmp / f"sub{i}.log"))
            for i in range(SUBSCRIBERS)
        ]
        wait_ready(tmp, subscribers)
        out = tmp / "peer.json"
        peer_cmd = [sys.executable, "-m", "mrs_nav.ros.bridge_bench_peer", "--out", str(out)]
        with process([*peer_cmd, "--duration", str(duration)], env, tmp / "peer.log") as peer:
            cpu0, wall0 = cpu_seconds(bridge.pid), time.monotonic()
            while peer.poll() is None:
                if time.monotonic() - wall0 > duration + 120:
                    raise RosProcessError("bench bridge: the ROS peer did not finish in time")
                rss.append((time.monotonic() - wall0, rss_mb(bridge.pid)))
                time.sleep(1.0)
            cpu = (cpu_seconds(bridge.pid) - cpu0) / (time.monotonic() - wall0) * 100
        if peer.returncode != 0 or not out.exists():
            raise RosProcessError(f"bench bridge: the ROS peer failed ({peer.returncode}):\n{_tail(tmp / 'peer.log')}")
        received = []
        for i, subscriber in enumerate(subscribers):
            stop(subscriber)  # SIGINT: it writes what it received
            path = tmp / f"sub{i}.json"
            if not path.exists():
                log = _tail(tmp / f"sub{i}.log")
                raise RosProcessError(f"bench bridge: remote subscriber {i} wrote nothing:\n{log}")
            received.append(Received.from_json(path.read_text(encoding="utf-8")))
    return _report(json.loads(out.read_text()), received, cpu, rss, duration)


def _tail(log: Path) -> str:
    """The end of a process's log, for an error message."""
    return log.read_text(errors="replace")[-2000:]


def subscriber_command(endpoint: str, client_tls: Path, tmp: Path, i: int) -> list[str]:
    return [
        sys.executable, "-m", "mrs_nav.bench.bridge_subscriber", "--connect", endpoint,
        "--zenoh-config", str(client_tls), "--ready", str(tmp / f"sub{i}.ready"), "--out", str(tmp / f"sub{i}.json"),
    ]  # fmt: skip


def wait_ready(tmp: Path, subscribers: list[subprocess.Popen[bytes]]) -> None:
    """Until every remote subscriber has subscribed (its ready file), at most 60 s."""
    deadline = time.monotonic() + 60.0
    for i, subscriber in enumerate(subscribers):
        while not (tmp / f"sub{i}.ready").exists():
            if subscriber.poll() is not None or time.monotonic() > deadline:
                log = _tail(tmp / f"sub{i}.log")
                raise RosProcessError(f"bench bridge: remote subscriber {i} did not subscribe:\n{log}")
            time.sleep(0.1)


def connect_when_up(endpoint: str, config_file: str, bridge: subprocess.Popen[bytes]) -> Any:
    """A client session to the bridge's router (``bridge``: its process, or roslaunch's) once it listens."""
    deadline = time.monotonic() + 60.0
    while True:
        if bridge.poll() is not None:
            raise RosProcessError("bench bridge: the bridge exited at start")
        try:
            return open_client_session([endpoint], "client", config_file)
        except MrsNavError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)


def _report(
    report: dict[str, Any],
    receivers: list[Received],
    cpu: float,
    rss: list[tuple[float, float]],
    duration: float,
) -> str:
    rows: list[list[object]] = []
    all_added: list[float] = []
    per_subscriber: list[list[float]] = [[] for _ in receivers]
    ros_hop: list[float] = []  # the bridge's rospy callback minus the direct subscriber's
    zenoh_hop: list[float] = []  # a Zenoh subscriber's callback minus the bridge's rospy callback
    lost_total = 0
    missed = [0] * len(receivers)  # per subscriber process, all topics
    for topic, rate in TOPICS.items():
        sent = report[topic]["sent"]
        direct = {int(k): v for k, v in report[topic]["direct"].items()}
        lost = sum(any(seq not in r.times[topic] for r in receivers) for seq in sent)
        lost_total += lost
        for i, receiver in enumerate(receivers):
            missed[i] += sum(seq not in receiver.times[topic] for seq in sent)
        added: list[float] = []
        for receiver, mine in zip(receivers, per_subscriber, strict=True):
            got, at_bridge = receiver.times[topic], receiver.bridge[topic]
            both = [s for s in sent if s in got and s in direct]
            values = [(got[s] - direct[s]) * 1e3 for s in both]
            mine.extend(values)
            added.extend(values)
            ros_hop.extend((at_bridge[s] - direct[s]) * 1e3 for s in both if s in at_bridge)
            zenoh_hop.extend((got[s] - at_bridge[s]) * 1e3 for s in both if s in at_bridge)
        all_added.extend(added)
        p50, p99, worst = np.percentile(added, [50, 99, 100]) if added else (np.nan,) * 3
        rows.append(
            [topic, f"{rate:g}", len(sent), sum(s in direct for s in sent), len(sent) - lost, lost, p50, p99, worst]
        )
    p50, p99 = np.percentile(all_added, [50, 99]) if all_added else (np.nan, np.nan)
    table = markdown_table(
        ["topic", "Hz", "sent", "direct ROS got", f"all {SUBSCRIBERS} got", "lost", "added p50 ms", "added p99 ms",
         "added max ms"],
        rows,
    )  # fmt: skip
    hops = ", ".join(
        f"{name} p50 {np.percentile(values, 50):.3f} ms / p99 {np.percentile(values, 99):.3f} ms"
        for name, values in (("ROS to the bridge's callback", ros_hop), ("bridge callback to subscriber", zenoh_hop))
        if values
    )
    subscribers = ", ".join(f"{np.percentile(v, 50):.3f}" for v in per_subscriber if v)
    t, mb = np.array(rss).T if rss else (np.zeros(1), np.zeros(1))
    settled = t >= SETTLE * t[-1]  # connections and buffers grow in the first seconds: not a leak
    slope = float(np.polyfit(t[settled], mb[settled], 1)[0]) * 60 if settled.sum() > 2 else math.nan
    load, cores = os.getloadavg()[0], os.cpu_count() or 1
    verdict = "meets" if p50 <= TARGET_P50_MS and p99 <= TARGET_P99_MS and lost_total == 0 else "MISSES"
    return (
        f"{duration:g} s measured after a 1 s warm-up; added latency = Zenoh receive time minus a direct rospy "
        f"subscriber's receive time for the same message, over {SUBSCRIBERS} remote subscribers (each a process "
        "with its own client session and one subscriber per topic, its callback run on the Zenoh thread that read "
        "the sample) of the bridge "
        "running as the robot's Zenoh router with mutual TLS, its access control on and its default settings "
        f"(loopback, one machine).\n\n{table}\n\n"
        f"All topics: added latency p50 {p50:.3f} ms, p99 {p99:.3f} ms; {lost_total} lost. Split at the bridge's "
        f"receive time (its attachment, same clock): {hops}. Added p50 per subscriber process: {subscribers} ms; "
        f"messages each missed: {', '.join(map(str, missed))}.\n"
        f"Bridge CPU "
        f"{cpu:.1f} % of one core (load average {load:.1f} on {cores} cores); bridge RSS "
        f"{mb[0]:.1f} MB at the start, {mb[settled][0]:.1f} MB at {SETTLE:.0%} of the run, {mb[-1]:.1f} MB at the end, "
        f"{mb.max():.1f} MB at most; drift {slope:+.3f} MB/min (least squares over the last {1 - SETTLE:.0%} of "
        f"{len(rss)} one-second samples).\n"
        f"Target p50 <= {TARGET_P50_MS:g} ms, p99 <= {TARGET_P99_MS:g} ms, zero loss: **{verdict}**.\n"
        + (
            f"\nThe machine was shared (load average {load:.1f} on {cores} cores, other jobs running): latencies and "
            "loss measured under that contention, not the bridge's own cost.\n"
            if load > cores
            else ""
        )
    )
