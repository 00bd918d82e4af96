"""The bridge as a network service: TLS and access control under a real roslaunch, bounded memory under a
flood of refused and oversized queries, liveness across killed nodes and a restarted master, and the monitor
installed from a wheel into a fresh venv with nothing but its PyPI dependencies."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import zenoh
import zenoh.ext

from mrs_nav.bench.bridge import connect_when_up, rss_mb
from mrs_nav.bridge.certs import make_ca, make_cert
from mrs_nav.bridge.keys import publish_key, status_key
from mrs_nav.bridge.monitor import serialize_goal
from mrs_nav.bridge.session import open_client_session
from mrs_nav.bridge.wire import encoding_text
from mrs_nav.ros_processes import process, wait_for_master
from tests.core.bridge.test_security import Pki, client_file
from tests.ros.zenoh_harness import Collector, Ticker, mrs_nav, start_bridge, status, wait_bridge_up
from tests.rosharness import REPO, RosMaster, free_port, ros_env, stop, wait_for

pytestmark = pytest.mark.ros

GOAL = "/move_base_simple/goal"
GOAL_RULE = {"topic": GOAL, "type": "geometry_msgs/PoseStamped", "frame": "map"}


def bridge_process(env: dict[str, str], tmp: Path, name: str, config: dict[str, Any]) -> Any:
    """The bridge script itself (not through roslaunch), so that tests see its pid."""
    path = tmp / f"{name}.yaml"
    path.write_text(json.dumps({"discovery_period": 0.2, **config}))
    cmd = [sys.executable, str(REPO / "scripts" / "zenoh_bridge"), f"__name:={name}", f"_config_file:={path}"]
    return process(cmd, env, tmp / f"{name}.log", grace=10.0)


def test_secured_bridge_as_the_robots_router(ros_master: RosMaster, rospy_node: Any, tmp_path: Path) -> None:
    """TLS with client certificates, passwords and the bridge's ACL, configured as a user would: a Zenoh JSON5
    file named in the bridge's YAML, the monitor in client mode with its own file."""
    from nav_msgs.msg import Odometry

    d = tmp_path / "pki"
    ca = make_ca(d)
    pki = Pki(
        ca, make_cert(ca, d, "bridge", ("127.0.0.1",)), make_cert(ca, d, "monitor"), make_cert(ca, d, "x"), d / "u"
    )
    pki.users.write_text("viewer:view-secret\noperator:op-secret\n")
    server = tmp_path / "robot-zenoh.json5"
    tls = {
        "root_ca_certificate": str(ca.cert),
        "listen_certificate": str(pki.server.cert),
        "listen_private_key": str(pki.server.key),
        "enable_mtls": True,
    }
    server.write_text(
        json.dumps({"transport": {"link": {"tls": tls}, "auth": {"usrpwd": {"dictionary_file": str(pki.users)}}}})
    )
    endpoint = f"tls/127.0.0.1:{free_port()}"
    config = {"operators": ["operator"], "inbound": [GOAL_RULE]}  # the rest as the README's recipe: launch args
    viewer = client_file(tmp_path, pki, "viewer", "view-secret")

    def odom(i: int) -> Any:
        msg = Odometry()
        msg.header.frame_id, msg.child_frame_id = "odom", "base_footprint"
        msg.pose.pose.position.x, msg.pose.pose.orientation.w = 1.0 + i * 1e-3, 1.0
        return msg

    args = ("mode:=router", f"listen:={endpoint}", f"zenoh_config:={server}")
    with start_bridge(ros_master, tmp_path, "zb_secure", config, *args) as proc:
        watcher = connect_when_up(endpoint, viewer, proc)
        forger = watcher  # closed twice at worst if the next line fails
        try:
            forger = open_client_session([endpoint], "client", client_file(tmp_path, pki, "viewer", "view-secret"))
            wait_bridge_up(watcher, proc, "the secured bridge")
            got = Collector(watcher, "mrs_nav/**")
            with Ticker(rospy_node, "/odom", Odometry, odom, 20.0):
                result = mrs_nav(
                    "monitor",
                    "--connect",
                    endpoint,
                    "--mode",
                    "client",
                    "--zenoh-config",
                    viewer,
                    "--once",
                    "--duration",
                    "2",
                    "--json",
                )
                for _ in range(50):
                    forger.put("mrs_nav/odom", b"forged", encoding=zenoh.Encoding(encoding_text("nav_msgs/Odometry")))
                refused_goal = list(
                    forger.get(publish_key("mrs_nav", GOAL), payload=serialize_goal(1, 1, 0), timeout=1.0)
                )
                wait_for(lambda: len(got.of("mrs_nav/odom")) >= 40, 15, "odometry through the router")
            plain = mrs_nav("monitor", "--connect", endpoint.replace("tls/", "tcp/"), "--mode", "client", "--once")
        finally:
            watcher.close()
            forger.close()
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["pose"]["x"] == pytest.approx(1.0, abs=0.5)
    assert summary["topics"]["/odom"]["stale"] is False
    assert [s for s in got.of("mrs_nav/odom") if s[3] == b"forged"] == []
    assert not any(r.ok is not None for r in refused_goal)  # a viewer is not an operator
    assert plain.returncode == 1
    assert plain.stderr.startswith("ERROR: cannot open a Zenoh session")
    assert len(plain.stderr.strip().splitlines()) == 1


def test_a_bridge_listening_open_to_the_network_does_not_start(ros_master: RosMaster, tmp_path: Path) -> None:
    """The README's old fleet recipe (plain TCP on every interface, goals allowed): one FATAL line, exit 1, and
    no socket opened (the refusal comes before the session)."""
    config = {"listen": ["tcp/0.0.0.0:7447"], "inbound": [GOAL_RULE]}
    with bridge_process(ros_master.env, tmp_path, "zb_open", config) as bridge:
        assert bridge.wait(timeout=60) == 1
    log = (tmp_path / "zb_open.log").read_text()
    fatal = [line for line in log.splitlines() if "[FATAL]" in line]
    assert len(fatal) == 1, log
    assert "listen endpoint tcp/0.0.0.0:7447 is reachable from the network without encryption" in fatal[0]
    assert "insecure: true" in fatal[0]


def test_memory_stays_bounded_under_refused_and_oversized_queries(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with bridge_process(ros_master.env, tmp_path, "zb_flood", {"listen": [endpoint], "inbound": [GOAL_RULE]}) as bridge:
        session = open_client_session([endpoint])
        try:
            wait_for(
                lambda: any(r.ok is not None for r in session.get(status_key("mrs_nav"), timeout=0.5)), 30, "bridge"
            )
            time.sleep(2.0)  # let start-up allocations settle before the idle reading
            idle = rss_mb(bridge.pid)
            key = publish_key("mrs_nav", GOAL)
            junk = b"\x00" * 64  # the right size, not a PoseStamped: refused by the content check
            for batch in range(100):
                pending = [session.get(key, payload=junk, timeout=5.0) for _ in range(100)]
                answers = [r for handler in pending for r in handler]
                assert len(answers) == 100, f"batch {batch}: {len(answers)} answers"
                assert all(r.err is not None for r in answers)
            for size in [512 << 10] * 97 + [8 << 20] * 3:  # far over the 1 KiB limit of goals
                answers = list(session.get(key, payload=b"\x01" * size, timeout=5.0))
                assert [r.err is not None for r in answers] == [True]
            after = rss_mb(bridge.pid)
            report = status(session)
        finally:
            session.close()
        assert bridge.poll() is None, "the bridge died"
    assert report["inbound"][GOAL] == {"accepted": 0, "dropped": 10_100}
    print(f"bridge RSS {idle:.1f} MB idle, {after:.1f} MB after the flood")
    assert after - idle <= 50.0, f"RSS {idle:.0f} MB idle, {after:.0f} MB after the flood"
    log = (tmp_path / "zb_flood.log").read_text()
    assert log.count("dropped remote message on /move_base_simple/goal") <= 5  # counted, logged at a bounded rate


def start_roscore(port: int, env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
    """A roscore on ``port`` that the test stops and starts again on the same port (the bridge's master)."""
    proc = subprocess.Popen(
        ["roscore", "-p", str(port)], env=env, start_new_session=True, stdout=log.open("wb"), stderr=subprocess.STDOUT
    )
    try:
        wait_for_master(f"http://127.0.0.1:{port}")
    except BaseException:
        stop(proc)
        raise
    return proc


def test_liveness_follows_killed_nodes_and_a_restarted_master(tmp_path: Path) -> None:
    port = free_port()
    env = ros_env(f"http://127.0.0.1:{port}", tmp_path)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    talker = [sys.executable, "-m", "tests.ros.zenoh_talker", "/zl/beat", "20"]
    key = "mrs_nav/zl/beat"
    roscore = start_roscore(port, env, tmp_path / "roscore1.log")
    session = open_client_session([endpoint])
    try:
        tokens: list[tuple[str, str]] = []
        session.liveliness().declare_subscriber(
            "mrs_nav/**", lambda s: tokens.append((str(s.kind), str(s.key_expr))), history=True
        )
        got = Collector(session, key)
        with bridge_process(env, tmp_path, "zb_live", {"listen": [endpoint]}) as bridge:
            with process(talker, {**env, "PYTHONPATH": f"{REPO}:{env['PYTHONPATH']}"}, tmp_path / "talker1.log") as one:
                wait_for(lambda: len(got.of(key)) >= 10, 30, "the first talker's messages")
                wait_for(lambda: ("SampleKind.PUT", key) in tokens, 10, "the topic's token")
                one.send_signal(signal.SIGKILL)  # a crash: the master still lists the dead publisher
                wait_for(lambda: ("SampleKind.DELETE", key) in tokens, 15, "the token to go with the killed node")
            # A late joiner now gets no cached message of the dead topic.
            late: list[Any] = []
            late_sub = zenoh.ext.declare_advanced_subscriber(
                session, key, late.append, history=zenoh.ext.HistoryConfig(detect_late_publishers=True)
            )
            time.sleep(1.0)  # absence of a history reply: give it a generous second
            late_sub.undeclare()
            assert late == []
            # The master restarts, then the node: the bridge registers again by itself.
            stop(roscore, grace=5.0)
            roscore = start_roscore(port, env, tmp_path / "roscore2.log")
            mark = len(got.of(key))
            with process(talker, {**env, "PYTHONPATH": f"{REPO}:{env['PYTHONPATH']}"}, tmp_path / "talker2.log"):
                wait_for(lambda: len(got.of(key)) >= mark + 10, 40, "messages after the master and node restarts")
                wait_for(lambda: tokens.count(("SampleKind.PUT", key)) >= 2, 10, "the token back")
            assert bridge.poll() is None
    finally:
        session.close()
        stop(roscore, grace=5.0)


@pytest.mark.slow
def test_the_monitor_from_a_wheel_in_a_fresh_venv(ros_master: RosMaster, rospy_node: Any, tmp_path: Path) -> None:
    """pip install "<wheel>[monitor]" into a venv without system site packages: no ROS, ODE or scipy (PyYAML
    reads the bridge's defaults, which the wheel carries in mrs_nav/config)."""
    from nav_msgs.msg import Odometry

    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "-w",
            str(tmp_path),
            str(REPO),
        ],
        check=True,
        capture_output=True,
        timeout=300,
    )
    wheel = next(tmp_path.glob("mrs_nav-*.whl"))
    venv = tmp_path / "venv"
    subprocess.run(["/usr/bin/python3", "-m", "venv", str(venv)], check=True, timeout=120)
    # Nothing from outside the venv may count as installed (a PYTHONPATH holding a checkout with its egg-info would
    # make pip skip mrs_nav itself and install only its dependencies, exit 0); pip's own words if it goes wrong.
    outside = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    installed = subprocess.run(
        [str(venv / "bin" / "pip"), "install", "--ignore-installed", f"{wheel}[monitor]"],
        env=outside,
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )
    assert installed.returncode == 0, installed.stdout[-3000:] + installed.stderr[-3000:]
    assert (venv / "bin" / "mrs-nav").is_file(), installed.stdout[-3000:] + installed.stderr[-3000:]
    absent = subprocess.run(
        [
            str(venv / "bin" / "python"),
            "-c",
            "import importlib.util as u; print([m for m in ('rospy', 'ode', 'scipy') if u.find_spec(m)])",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    assert absent.stdout.strip() == "[]"
    monitor = str(venv / "bin" / "mrs-nav")
    endpoint = f"tcp/127.0.0.1:{free_port()}"

    def odom(i: int) -> Any:
        msg = Odometry()
        msg.header.frame_id = "odom"
        msg.pose.pose.position.x, msg.pose.pose.orientation.w = 0.5, 1.0
        msg.twist.twist.linear.x = 0.1
        return msg

    with start_bridge(ros_master, tmp_path, "zb_wheel", {"listen": [endpoint]}) as proc:
        session = open_client_session([endpoint])
        wait_bridge_up(session, proc, "the bridge")
        session.close()
        with Ticker(rospy_node, "/odom", Odometry, odom, 20.0):
            watched = subprocess.run(
                [monitor, "monitor", "--connect", endpoint, "--once", "--duration", "2", "--json"],
                capture_output=True,
                text=True,
                timeout=60,
                check=False,
            )
    dead = subprocess.run(
        [monitor, "monitor", "--connect", f"tcp/127.0.0.1:{free_port()}", "--timeout", "1"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert watched.returncode == 0, watched.stderr
    summary = json.loads(watched.stdout)
    assert summary["pose"]["x"] == pytest.approx(0.5)
    assert summary["speed"]["linear"] == pytest.approx(0.1)
    assert (dead.returncode, dead.stdout) == (1, "")
    assert dead.stderr.startswith("ERROR: no bridge under prefix 'mrs_nav'")
    assert len(dead.stderr.strip().splitlines()) == 1


def test_zenoh_bridge_ros1_layout_and_discovery_beacons(ros_master: RosMaster, rospy_node: Any, tmp_path: Path) -> None:
    """What a zenoh-bridge-ros1 (zenoh-plugin-ros1 1.0.0-rc.1) on another master subscribes to: data on
    ``<hex type>/<md5>/<topic>`` and a beacon every period on ``ros1_discovery_info/*/pub/<hex type>/<md5>/*/<topic>``
    that stops when the topic has no ROS publisher any more."""
    from std_msgs.msg import UInt32

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    config = {"listen": [endpoint], "prefix": "", "layout": "zenoh-bridge-ros1", "allow": ["/zi/.*"]}
    head = f"{b'std_msgs/UInt32'.hex()}/{UInt32._md5sum}"
    with start_bridge(ros_master, tmp_path, "zb_interop", config) as proc:
        session = open_client_session([endpoint])
        try:
            wait_bridge_up(session, proc, "the bridge with zenoh-bridge-ros1's layout")
            data = Collector(session, "*/*/zi/**")
            beacons = Collector(session, "ros1_discovery_info/**")
            with Ticker(rospy_node, "/zi/count", UInt32, UInt32, 20.0):
                wait_for(lambda: len(data.of(f"{head}/zi/count")) >= 10, 15, "data on the plugin's key")
                wait_for(lambda: len(beacons.samples) >= 3, 15, "three discovery beacons")
            stopped = time.monotonic()
            time.sleep(3.0)  # the plugin forgets a topic after 3 silent beacon periods of 1 s
        finally:
            session.close()
    assert {s[1] for s in beacons.samples} == {f"ros1_discovery_info/*/pub/{head}/*/zi/count"}
    assert all(s[3] == b"" for s in beacons.samples)
    assert [s for s in beacons.samples if s[0] > stopped + 1.0] == []  # no beacon once the publisher left
    assert [int.from_bytes(s[3], "little") for s in data.of(f"{head}/zi/count")][:3] == [0, 1, 2]


def test_a_tls_endpoint_without_certificates_stops_the_node_with_one_line(
    ros_master: RosMaster, tmp_path: Path
) -> None:
    config = {"listen": [f"tls/127.0.0.1:{free_port()}"]}
    with bridge_process(ros_master.env, tmp_path, "zb_no_certs", config) as bridge:
        code = bridge.wait(timeout=60)
    log = (tmp_path / "zb_no_certs.log").read_text()
    fatal = [line for line in log.splitlines() if "[FATAL]" in line]
    assert code == 1
    assert len(fatal) == 1
    assert "needs transport.link.tls.listen_certificate and listen_private_key" in fatal[0]
    assert "Traceback" not in log


@pytest.mark.parametrize(
    ("case", "fatal_says"),
    [
        ("fifo", "cannot read ~config_file: not a regular file"),  # used to block in open(), deaf to SIGTERM
        ("device", "/dev/zero: cannot read ~config_file: not a regular file"),  # used to fill memory
        ("binary", "cannot read ~config_file: not UTF-8 text"),
        ("tiny period", "discovery_period 1e-300: expected 0.1 .. 60 s"),  # YAML 1.2's exponent form is read
        ("huge period parameter", "discovery_period 1e+300: expected 0.1 .. 60 s"),  # text from the command line
    ],
)
def test_an_unreadable_or_out_of_range_config_stops_the_node_with_one_line(
    ros_master: RosMaster, tmp_path: Path, case: str, fatal_says: str
) -> None:
    path = tmp_path / "bridge.yaml"
    extra = []
    if case == "fifo":
        os.mkfifo(path)
    elif case == "device":
        path = Path("/dev/zero")
    elif case == "binary":
        path.write_bytes(b"\x00\xff\xfe mode: peer")
    elif case == "tiny period":
        path.write_text("discovery_period: 1e-300\n")
    else:
        path.write_text("{}\n")
        extra = ["_discovery_period:=1e300"]
    cmd = [sys.executable, str(REPO / "scripts" / "zenoh_bridge"), "__name:=zb_bad", f"_config_file:={path}", *extra]
    with process(cmd, ros_master.env, tmp_path / "zb_bad.log", grace=10.0) as bridge:
        code = bridge.wait(timeout=60)
    log = (tmp_path / "zb_bad.log").read_text()
    fatal = [line for line in log.splitlines() if "[FATAL]" in line]
    assert code == 1
    assert len(fatal) == 1
    assert fatal_says in fatal[0]
    assert "Traceback" not in log
