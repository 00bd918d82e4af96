"""``bench bridge``'s receive path and report: real Zenoh samples between two sessions on loopback, split at the
bridge's receive time carried in each sample's attachment."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import pytest

from mrs_nav.bench.bridge import TOPICS, Received, Receiver, _report
from mrs_nav.bridge.config import zenoh_settings
from mrs_nav.bridge.session import open_client_session, open_session
from mrs_nav.bridge.wire import encode_attachment
from mrs_nav.ros_processes import process, stop
from tests.rosharness import free_port, wait_for

MD5 = "cd5e73d190d741a2f92e81eda573aca7"
SEQS = range(1, 21)
ROS_HOP_S = 0.002  # the bridge's callback runs this long after the direct subscriber's, by construction


def test_report_splits_added_latency_at_the_bridges_receive_time() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    bridge = open_session(zenoh_settings("peer", [endpoint], []))
    remote = open_client_session([endpoint])
    receivers = [Receiver(), Receiver(t for t in TOPICS)]  # the fleet bench passes a generator
    direct: dict[str, dict[str, float]] = {topic: {} for topic in TOPICS}
    try:
        for receiver in receivers:
            receiver.subscribe(remote)
        publisher = bridge.declare_publisher("mrs_nav/odom", express=True)
        time.sleep(0.5)  # the subscriptions reach the publisher's session
        for seq in SEQS:
            now = time.time()
            direct["/odom"][str(seq)] = now - ROS_HOP_S
            publisher.put(seq.to_bytes(4, "little") + bytes(60), attachment=encode_attachment(MD5, int(now * 1e9)))
        wait_for(lambda: all(len(r.times["/odom"]) == len(SEQS) for r in receivers), 10.0, "all samples")
    finally:
        remote.close()  # type: ignore[no-untyped-call]
        bridge.close()  # type: ignore[no-untyped-call]
    received = [Received.from_json(r.received().to_json()) for r in receivers]  # as the subscriber processes do
    assert all(len(r.bridge["/odom"]) == len(SEQS) for r in received)
    sent = {topic: [] for topic in TOPICS} | {"/odom": list(SEQS)}
    peer = {topic: {"first": 1, "sent": sent[topic], "direct": direct[topic]} for topic in TOPICS}
    text = _report(peer, received, 1.0, [(0.0, 50.0), (1.0, 50.0)], 1.0)

    assert f"ROS to the bridge's callback p50 {ROS_HOP_S * 1e3:.3f} ms" in text
    zenoh_p50 = float(text.split("bridge callback to subscriber p50 ")[1].split(" ms")[0])
    added_p50 = float(text.split("added latency p50 ")[1].split(" ms")[0])
    assert 0 < zenoh_p50 < 1000
    # Every sample's added latency is its Zenoh hop plus the same 2 ms, so the medians add (to the 3 printed decimals).
    assert added_p50 == pytest.approx(ROS_HOP_S * 1e3 + zenoh_p50, abs=0.002)
    assert "0 lost" in text
    assert "Added p50 per subscriber process: " in text


def test_subscriber_process_reports_every_sample_with_the_bridges_time(tmp_path: Path) -> None:
    """The bench's remote subscriber, a process of its own, returns what it received when interrupted."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    bridge = open_session(zenoh_settings("peer", [endpoint], []))
    ready, out = tmp_path / "ready", tmp_path / "out.json"
    command = [sys.executable, "-m", "mrs_nav.bench.bridge_subscriber", "--connect", endpoint, "--ready", str(ready),
               "--out", str(out)]  # fmt: skip
    sent_at = {}
    try:
        with process(command, dict(os.environ), tmp_path / "sub.log") as subscriber:
            wait_for(ready.exists, 30.0, "the subscriber process subscribed")
            publisher = bridge.declare_publisher("mrs_nav/odom", express=True)
            time.sleep(0.5)  # the subscription reaches the publisher's session
            for seq in SEQS:
                sent_at[seq] = time.time()
                attachment = encode_attachment(MD5, int(sent_at[seq] * 1e9))
                publisher.put(seq.to_bytes(4, "little") + bytes(60), attachment=attachment)
            time.sleep(0.5)
            stop(subscriber)
            assert subscriber.returncode == 0
    finally:
        bridge.close()  # type: ignore[no-untyped-call]
    received = Received.from_json(out.read_text(encoding="utf-8"))
    assert sorted(received.times["/odom"]) == list(SEQS)
    assert received.bridge["/odom"] == pytest.approx(sent_at, abs=1e-6)
    assert all(received.times["/odom"][s] >= sent_at[s] for s in SEQS)  # one wall clock across processes
