"""Floors under ``bench bridge``'s latency on this machine, in its shape: one publisher, 5 subscriber processes.

No ROS and no bridge: an odometry-sized payload (700 B) at 100 Hz, stamped just before it is sent, and each
subscriber's receive time minus that stamp (wall clock, one machine):

- the kernel: plain TCP sockets (TCP_NODELAY), the publisher writing each message to every subscriber in turn
  and each subscriber blocked in ``recv`` (what any transport pays at least: one wake-up per process);
- Zenoh: this process as a Zenoh router publishing with ``express`` (as the bridge does), the subscribers the
  ``bench bridge`` ones (:mod:`mrs_nav.bench.bridge_subscriber`, client sessions), over TCP or mutual TLS, with
  Zenoh's default (universal) unicast transport or its ``lowlatency`` one (QoS off on both ends, as it requires).

Run by ``mrs-nav bench bridge --floors S``; ``python -m mrs_nav.bench.bridge_floor PORT OUT`` is one socket
subscriber.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import struct
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.bench.bridge import (
    SUBSCRIBERS,
    TARGET_P50_MS,
    TARGET_P99_MS,
    Received,
    subscriber_command,
    tls_files,
    wait_ready,
)
from mrs_nav.bridge.config import zenoh_settings
from mrs_nav.bridge.session import open_session
from mrs_nav.bridge.wire import encode_attachment
from mrs_nav.ros_processes import RosProcessError, free_port, process, stop
from mrs_nav.tables import markdown_table

RATE = 100.0  # Hz, /odom's
PAYLOAD = 700  # bytes, about a serialized nav_msgs/Odometry
_STAMP = struct.Struct("<Iq")  # header.seq's place, then the send time (ns); padded to PAYLOAD
LOWLATENCY = {"transport": {"unicast": {"lowlatency": True, "qos": {"enabled": False}}}}


def measure(tmp: Path, duration: float) -> str:
    """Every floor for ``duration`` seconds each, as a markdown table with its conditions."""
    rows: list[list[object]] = [
        ["kernel: TCP sockets", n, *_percentiles(_sockets(tmp, n, duration)), 0] for n in (1, SUBSCRIBERS)
    ]  # TCP delivers every byte or the run fails
    bridge_tls, client_tls = tls_files(tmp)
    variants = [
        ("tls", "universal", 1),
        *((scheme, transport, SUBSCRIBERS) for scheme in ("tcp", "tls") for transport in ("universal", "lowlatency")),
    ]
    tls_floor: list[float] = []  # p50, p99 ms: the bridge's own transport and shape without ROS or the bridge
    for scheme, transport, subscribers in variants:
        server, client = (_json(bridge_tls), _json(client_tls)) if scheme == "tls" else ({}, {})
        extra = LOWLATENCY if transport == "lowlatency" else {}
        server_file, client_file = tmp / "floor_router.json5", tmp / "floor_client.json5"
        server_file.write_text(json.dumps(_merge(server, extra)))
        client_file.write_text(json.dumps(_merge(client, extra)))
        latencies, missed = _zenoh(tmp, scheme, server_file, client_file, subscribers=subscribers, duration=duration)
        percentiles = _percentiles(latencies)
        rows.append([f"Zenoh {scheme}, {transport} transport", subscribers, *percentiles, missed])
        if (scheme, transport, subscribers) == ("tls", "universal", SUBSCRIBERS):
            tls_floor = percentiles[:2]
    table = markdown_table(["path", "subscriber processes", "p50 ms", "p99 ms", "max ms", "messages missed"], rows)
    return (
        f"Floors, {duration:g} s each, {PAYLOAD} B at {RATE:g} Hz from one publisher (send time stamped just before "
        "the send or put) to each subscriber process's receive time, on loopback:\n\n" + table + "\n\n"
        f"Zenoh alone over mutual TLS to {SUBSCRIBERS} subscriber processes (no ROS, no bridge) takes p50 "
        f"{tls_floor[0]:.3f} ms / p99 {tls_floor[1]:.3f} ms here, against the bridge's target of p50 "
        f"{TARGET_P50_MS:g} / p99 {TARGET_P99_MS:g} ms: "
        + (
            "the target is below what this machine gives the transport alone.\n"
            if tls_floor[0] > TARGET_P50_MS or tls_floor[1] > TARGET_P99_MS
            else "the transport alone fits within the target.\n"
        )
    )


def _json(path: Path) -> dict[str, Any]:
    loaded: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    return loaded


def _merge(a: dict[str, Any], b: dict[str, Any]) -> dict[str, Any]:
    """``a`` with ``b`` laid over it, nested mappings merged."""
    out = dict(a)
    for key, value in b.items():
        mine = out.get(key)
        out[key] = _merge(mine, value) if isinstance(mine, dict) and isinstance(value, dict) else value
    return out


def _percentiles(latencies_ms: list[float]) -> list[float]:
    if not latencies_ms:
        return [float("nan")] * 3
    return [float(v) for v in np.percentile(latencies_ms, [50, 99, 100])]


def _paced(duration: float) -> range:
    """Message numbers; each is sent at its time (``RATE``) by the caller through :func:`_wait_turn`."""
    return range(round(duration * RATE))


def _wait_turn(start: float, k: int) -> None:
    time.sleep(max(0.0, start + k / RATE - time.monotonic()))


def _zenoh(
    tmp: Path, scheme: str, server_file: Path, client_file: Path, *, subscribers: int, duration: float
) -> tuple[list[float], int]:
    """Latencies (ms) of all subscribers, and the messages any of them missed."""
    endpoint = f"{scheme}/127.0.0.1:{free_port()}"
    session = open_session(zenoh_settings("router", [endpoint], []), str(server_file))
    with contextlib.ExitStack() as stack:
        stack.callback(session.close)
        subs = [
            stack.enter_context(
                process(subscriber_command(endpoint, client_file, tmp, i), dict(os.environ), tmp / f"floor_sub{i}.log")
            )
            for i in range(subscribers)
        ]
        wait_ready(tmp, subs)
        publisher = session.declare_publisher("mrs_nav/odom", express=True)
        time.sleep(0.5)  # the subscriptions' declarations reach the router
        padding = bytes(PAYLOAD - _STAMP.size)
        start = time.monotonic()
        for k in _paced(duration):
            _wait_turn(start, k)
            now = time.time_ns()
            publisher.put(_STAMP.pack(k, now) + padding, attachment=encode_attachment("0" * 32, now))
        time.sleep(0.5)
        received = []
        for i, sub in enumerate(subs):
            stop(sub)
            path = tmp / f"sub{i}.json"
            if not path.exists():
                raise RosProcessError(f"bench bridge --floors: subscriber {i} wrote nothing")
            received.append(Received.from_json(path.read_text(encoding="utf-8")))
            path.unlink()
            (tmp / f"sub{i}.ready").unlink()
    sent = range(len(_paced(duration)))
    latencies = [
        (r.times["/odom"][k] - r.bridge["/odom"][k]) * 1e3 for r in received for k in sent if k in r.times["/odom"]
    ]
    missed = sum(any(k not in r.times["/odom"] for r in received) for k in sent)
    return latencies, missed


def _sockets(tmp: Path, subscribers: int, duration: float) -> list[float]:
    """Latencies (ms) of ``subscribers`` socket subscriber processes."""
    with contextlib.ExitStack() as stack:
        server = stack.enter_context(socket.create_server(("127.0.0.1", 0)))
        port = server.getsockname()[1]
        outs = [tmp / f"socket_sub{i}.json" for i in range(subscribers)]
        for i, out in enumerate(outs):
            cmd = [sys.executable, "-m", "mrs_nav.bench.bridge_floor", str(port), str(out)]
            stack.enter_context(process(cmd, dict(os.environ), tmp / f"socket_sub{i}.log"))
        server.settimeout(30.0)
        conns = [stack.enter_context(server.accept()[0]) for _ in outs]
        for conn in conns:
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        padding = bytes(PAYLOAD - _STAMP.size)
        start = time.monotonic()
        for k in _paced(duration):
            _wait_turn(start, k)
            message = _STAMP.pack(k, time.time_ns()) + padding
            for conn in conns:
                conn.sendall(message)
        for conn in conns:
            conn.shutdown(socket.SHUT_WR)  # end of stream: each subscriber writes what it measured and exits
        deadline = time.monotonic() + 30.0
        while not all(out.exists() for out in outs):
            if time.monotonic() > deadline:
                raise RosProcessError("bench bridge --floors: a socket subscriber wrote nothing")
            time.sleep(0.1)
    return [v for out in outs for v in json.loads(out.read_text(encoding="utf-8"))]


def socket_subscriber(port: int, out: Path) -> None:
    """Receive stamped messages on ``port`` until the stream ends; write the latencies (ms) to ``out``."""
    latencies: list[float] = []
    with socket.create_connection(("127.0.0.1", port)) as conn:
        buffer = bytearray(PAYLOAD)
        view = memoryview(buffer)
        while True:
            got = 0
            while got < PAYLOAD:
                n = conn.recv_into(view[got:])
                if n == 0:
                    tmp = out.with_suffix(".part")
                    tmp.write_text(json.dumps(latencies), encoding="utf-8")
                    tmp.rename(out)
                    return
                if got == 0:
                    now = time.time_ns()  # the first bytes of the message woke us
                got += n
            latencies.append((now - _STAMP.unpack_from(buffer)[1]) * 1e-6)


if __name__ == "__main__":
    socket_subscriber(int(sys.argv[1]), Path(sys.argv[2]))
