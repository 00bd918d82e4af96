"""``mrs-nav router``: two client sessions that only know the router reach each other through it; a bad endpoint
is one ERROR line; SIGTERM stops it cleanly."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from mrs_nav.bridge.session import open_client_session
from mrs_nav.cli.main import main
from tests.rosharness import REPO, free_port


def test_clients_of_the_router_reach_each_other_and_sigterm_stops_it() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    command = [sys.executable, "-m", "mrs_nav", "router", "--listen", endpoint]
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    with subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as router:
        try:
            assert router.stdout is not None
            assert router.stdout.readline() == f"zenoh router listening on {endpoint}\n"
            got = threading.Event()
            listener = open_client_session([endpoint], "client")
            talker = open_client_session([endpoint], "client")
            try:
                listener.declare_subscriber("fleet/ping", lambda _sample: got.set())
                publisher = talker.declare_publisher("fleet/ping")
                for _ in range(100):  # until the router has learnt the subscription
                    publisher.put(b"x")
                    if got.wait(0.1):
                        break
                assert got.is_set()
            finally:
                listener.close()
                talker.close()
        finally:
            router.send_signal(signal.SIGTERM)
            _, err = router.communicate(timeout=30)
    assert router.returncode == 0
    assert err.strip() == "zenoh router stopped"


@pytest.mark.parametrize("endpoint", ["127.0.0.1:7447", "tcp/", "", "tcp/127.0.0.1:99999", "tcp/[::1"])
def test_a_bad_endpoint_is_one_error_line(endpoint: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["router", "--listen", endpoint]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("ERROR: ")
    assert "\n" not in err
    assert ".rs:" not in err


@pytest.mark.parametrize("endpoint", ["tcp/0.0.0.0:7447", "tcp/[::]:7447", "ws/0.0.0.0:7448", "udp/0.0.0.0:7447"])
def test_an_endpoint_open_to_the_network_is_refused_without_insecure(
    endpoint: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Refused before any socket is opened (with --insecure it would listen there: not run here, loopback only)."""
    assert main(["router", "--listen", endpoint]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"ERROR: listen endpoint {endpoint} is reachable from the network without encryption")
    assert err.endswith("or give --insecure to accept that anyone who reaches it may watch the robot and send what "
                        "its inbound allow-list accepts")  # fmt: skip
    assert "\n" not in err


@pytest.mark.parametrize(
    ("content", "match"),
    [("{ mode: 5 }", "line 1, column 9: invalid type: integer `5`"), (b"\xff", "cannot read zenoh_config: not UTF-8")],
)
def test_a_bad_zenoh_config_is_one_readable_error_line(
    content: str | bytes, match: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "router.json5"
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    assert main(["router", "--listen", f"tcp/127.0.0.1:{free_port()}", "--zenoh-config", str(path)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("ERROR: ")
    assert str(path) in err
    assert match in err
    assert "\n" not in err
    assert ".rs:" not in err
