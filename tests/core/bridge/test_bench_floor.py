"""``bench bridge --floors``: the socket and Zenoh floors measure every message each subscriber process got."""

from __future__ import annotations

import json
from pathlib import Path

from mrs_nav.bench import bridge_floor
from mrs_nav.bench.bridge import tls_files

DURATION = 0.3  # s: 30 messages at 100 Hz
SENT = round(DURATION * bridge_floor.RATE)


def test_socket_floor_measures_each_message_at_each_subscriber(tmp_path: Path) -> None:
    latencies = bridge_floor._sockets(tmp_path, 2, DURATION)
    assert len(latencies) == 2 * SENT
    assert all(0 < ms < 1000 for ms in latencies)  # after the send, and not some other clock's


def test_zenoh_floor_over_mutual_tls_with_the_lowlatency_transport(tmp_path: Path) -> None:
    server, client = tls_files(tmp_path)
    for path in (server, client):  # the merge keeps the certificates and adds the transport
        merged = bridge_floor._merge(json.loads(path.read_text()), bridge_floor.LOWLATENCY)
        assert merged["transport"]["link"]["tls"]
        assert merged["transport"]["unicast"]["lowlatency"]
        path.write_text(json.dumps(merged))
    latencies, missed = bridge_floor._zenoh(tmp_path, "tls", server, client, subscribers=2, duration=DURATION)
    assert missed == 0
    assert len(latencies) == 2 * SENT
    assert all(0 < ms < 1000 for ms in latencies)
