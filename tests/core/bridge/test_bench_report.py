"""``bench bridge``'s receive path and report: real Zenoh samples between two sessions on loopback, split at the
bridge's receive time carried in each sample's attachment."""

from __future__ import annotations

import time

import pytest

from mrs_nav.bench.bridge import TOPICS, Receiver, _report
from mrs_nav.bridge.config import zenoh_settings
from mrs_nav.bridge.session import open_client_session, open_session
from mrs_nav.bridge.wire import encode_attachment
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
            remote.declare_subscriber("mrs_nav/**", receiver)
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
    assert all(len(r.bridge_times("/odom")) == len(SEQS) for r in receivers)
    sent = {topic: [] for topic in TOPICS} | {"/odom": list(SEQS)}
    peer = {topic: {"first": 1, "sent": sent[topic], "direct": direct[topic]} for topic in TOPICS}
    text = _report(peer, receivers, 1.0, [(0.0, 50.0), (1.0, 50.0)], 1.0)

    assert f"ROS to the bridge's callback p50 {ROS_HOP_S * 1e3:.3f} ms" in text
    zenoh_p50 = float(text.split("bridge callback to subscriber p50 ")[1].split(" ms")[0])
    added_p50 = float(text.split("added latency p50 ")[1].split(" ms")[0])
    assert 0 < zenoh_p50 < 1000
    # Every sample's added latency is its Zenoh hop plus the same 2 ms, so the medians add (to the 3 printed decimals).
    assert added_p50 == pytest.approx(ROS_HOP_S * 1e3 + zenoh_p50, abs=0.002)
    assert "0 lost" in text
    assert "Added p50 per subscriber, in the order their sessions were opened: " in text
