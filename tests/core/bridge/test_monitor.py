"""The remote monitor against a real Zenoh peer on loopback (no ROS): discovery, definitions, decoding,
latency, dashboard and snapshot."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zenoh
import zenoh.ext

from mrs_nav.bridge.config import zenoh_settings
from mrs_nav.bridge.dashboard import render, summarise
from mrs_nav.bridge.decoder import noetic_store
from mrs_nav.bridge.keys import topic_key, types_key
from mrs_nav.bridge.monitor import RemoteMonitor, TopicStats
from mrs_nav.bridge.session import open_client_session, open_session
from mrs_nav.bridge.snapshot import RobotView, draw_snapshot
from mrs_nav.bridge.wire import encode_attachment, encode_definition, encoding_text
from tests.rosharness import free_port, wait_for

STORE = noetic_store()
T = STORE.types


def odometry(x: float, vx: float) -> Any:
    header = T["std_msgs/msg/Header"](0, T["builtin_interfaces/msg/Time"](0, 0), "odom")
    pose = T["geometry_msgs/msg/Pose"](
        T["geometry_msgs/msg/Point"](x, 0.5, 0.0), T["geometry_msgs/msg/Quaternion"](0, 0, 0, 1)
    )
    zero = T["geometry_msgs/msg/Vector3"](0.0, 0.0, 0.0)
    twist = T["geometry_msgs/msg/Twist"](T["geometry_msgs/msg/Vector3"](vx, 0.0, 0.0), zero)
    cov = np.zeros(36)
    return T["nav_msgs/msg/Odometry"](
        header,
        "base_footprint",
        T["geometry_msgs/msg/PoseWithCovariance"](pose, cov),
        T["geometry_msgs/msg/TwistWithCovariance"](twist, cov),
    )


def grid() -> Any:
    header = T["std_msgs/msg/Header"](0, T["builtin_interfaces/msg/Time"](0, 0), "map")
    origin = T["geometry_msgs/msg/Pose"](
        T["geometry_msgs/msg/Point"](-1.0, -1.0, 0.0), T["geometry_msgs/msg/Quaternion"](0, 0, 0, 1)
    )
    info = T["nav_msgs/msg/MapMetaData"](T["builtin_interfaces/msg/Time"](0, 0), 0.5, 4, 3, origin)
    return T["nav_msgs/msg/OccupancyGrid"](header, info, np.array([0, 100, -1, 0] * 3, dtype=np.int8))


def answer_types(query: zenoh.Query) -> None:
    """Answer a ``@types`` query for odometry and occupancy grids as the bridge does."""
    for name in ("nav_msgs/msg/Odometry", "nav_msgs/msg/OccupancyGrid"):
        key = types_key("mrs_nav", name)
        if zenoh.KeyExpr(key).intersects(query.key_expr):
            text, md5 = STORE.generate_msgdef(name, ros_version=1)
            query.reply(key, encode_definition(name, md5, text))


class FakeBridge:
    """A Zenoh peer speaking the bridge's wire format (what zenoh_bridge does, minus ROS)."""

    def __init__(self, endpoint: str) -> None:
        self.session = open_session(zenoh_settings("peer", [endpoint], []))
        self.entities: list[Any] = [self.session.declare_queryable("mrs_nav/@types/**", self.answer)]

    def answer(self, query: zenoh.Query) -> None:
        answer_types(query)

    def publisher(self, topic: str, type_name: str, latched: bool) -> Any:
        key = topic_key("mrs_nav", topic)
        encoding = zenoh.Encoding(encoding_text(type_name))
        self.entities.append(self.session.liveliness().declare_token(key))
        if latched:
            return zenoh.ext.declare_advanced_publisher(
                self.session,
                key,
                encoding=encoding,
                cache=zenoh.ext.CacheConfig(max_samples=1),
                publisher_detection=True,
            )
        return self.session.declare_publisher(key, encoding=encoding)

    def put(self, publisher: Any, msg: Any, type_name: str) -> None:
        md5 = STORE.generate_msgdef(type_name, ros_version=1)[1]
        payload = bytes(STORE.serialize_ros1(msg, type_name))
        publisher.put(payload, attachment=encode_attachment(md5, time.time_ns()))


@pytest.fixture
def bridge() -> Iterator[tuple[FakeBridge, str]]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    fake = FakeBridge(endpoint)
    yield fake, endpoint
    fake.session.close()


def test_monitor_discovers_decodes_and_gets_the_latched_map_late(
    bridge: tuple[FakeBridge, str], tmp_path: Path
) -> None:
    fake, endpoint = bridge
    map_pub = fake.publisher("/map", "nav_msgs/msg/OccupancyGrid", latched=True)
    fake.put(map_pub, grid(), "nav_msgs/msg/OccupancyGrid")  # before the monitor exists: history must bring it
    odom_pub = fake.publisher("/odom", "nav_msgs/msg/Odometry", latched=False)
    with RemoteMonitor([endpoint]) as monitor:
        wait_for(lambda: "/map" in monitor.topics() and monitor.topics()["/map"].count == 1, 10, "the latched map")
        for i in range(20):
            fake.put(odom_pub, odometry(0.1 * i, 0.2), "nav_msgs/msg/Odometry")
            time.sleep(0.01)
        wait_for(
            lambda: monitor.topics().get("/odom") is not None and monitor.topics()["/odom"].count == 20, 5, "20 odom"
        )
        odom = monitor.latest("/odom")
        assert odom.pose.pose.position.x == pytest.approx(1.9)
        stats = monitor.topics()
        assert stats["/odom"].type == "nav_msgs/Odometry"
        assert 0 < stats["/odom"].latency_ms(50) < 50  # loopback: well under a frame time
        summary = summarise({"/odom": odom, "/map": monitor.latest("/map")}, stats, time.monotonic())
    assert summary["pose"]["x"] == pytest.approx(1.9)
    assert summary["speed"]["linear"] == pytest.approx(0.2)
    assert summary["map"] == {"width": 4, "height": 3, "resolution": 0.5, "size_m": [2.0, 1.5]}
    odom_stats = stats["/odom"]
    assert odom_stats.rate_hz(odom_stats.arrivals[-1]) > 20  # sent at ~100 Hz
    assert odom_stats.rate_hz(odom_stats.arrivals[-1] + 10.0) == 0.0  # silent for long: shown as stopped
    text = render(summary)
    assert "4 x 3 cells" in text
    assert "/odom" in text
    png = draw_snapshot(tmp_path / "snap.png", {"mrs_nav": RobotView(grid(), odom)})
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("name", ["robot", "robot.jpg"])
def test_the_snapshot_is_a_png_written_under_exactly_the_name_given(name: str, tmp_path: Path) -> None:
    out = draw_snapshot(tmp_path / name, {"mrs_nav": RobotView(grid())})
    assert out == tmp_path / name
    assert [p.name for p in tmp_path.iterdir()] == [name]
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_send_goal_without_a_bridge_says_nobody_answered(bridge: tuple[FakeBridge, str]) -> None:
    _, endpoint = bridge
    with RemoteMonitor([endpoint], timeout=0.5) as monitor:
        accepted, answer = monitor.send_goal(1.0, 2.0, 0.0)
    assert not accepted
    assert "no bridge" in answer


def test_a_topic_is_stale_without_its_publisher_or_after_three_silent_periods() -> None:
    stats = TopicStats(alive=True, received_ns=10_000_000_000)
    stats.arrivals.extend([0.0, 0.1, 0.2])  # 10 Hz
    assert stats.age_s(10_250_000_000) == pytest.approx(0.25)
    assert not stats.stale(0.25, 10_250_000_000)
    assert stats.stale(0.6, 10_400_000_000)  # 0.4 s silent > 3 periods of 0.1 s
    latched = TopicStats(alive=True, received_ns=1_000_000_000)
    latched.arrivals.append(0.0)  # one cached map, 34 s old but its publisher lives: live, with its age shown
    assert not latched.stale(34.0, 35_000_000_000)
    assert latched.age_s(35_000_000_000) == pytest.approx(34.0)
    latched.alive = False  # the token went with the publisher
    assert latched.stale(34.0, 35_000_000_000)
    summary = summarise({}, {"/map": latched}, 34.0, 35_000_000_000)
    assert summary["topics"]["/map"]["stale"] is True
    assert summary["topics"]["/map"]["age_s"] == pytest.approx(34.0)
    assert "STALE" in render(summary)


def test_a_monitor_closed_on_a_shared_session_stops_receiving(bridge: tuple[FakeBridge, str]) -> None:
    fake, endpoint = bridge
    odom_pub = fake.publisher("/odom", "nav_msgs/msg/Odometry", latched=False)

    def received(monitor: RemoteMonitor) -> bool:
        fake.put(odom_pub, odometry(0.0, 0.1), "nav_msgs/msg/Odometry")  # again until its subscriber is in place
        return odom_count(monitor) > 0

    session = open_client_session([endpoint], "peer")
    try:
        closed = RemoteMonitor([endpoint]).attach(session)
        wait_for(lambda: received(closed), 10, "odom")
        # A last message, and every one put before it has been delivered (one publisher keeps its order): nothing
        # is left in flight when the monitor closes.
        fake.put(odom_pub, odometry(9.0, 0.1), "nav_msgs/msg/Odometry")
        wait_for(lambda: closed.latest("/odom").pose.pose.position.x == 9.0, 10, "the last odom")
        closed.close()
        before = odom_count(closed)
        # A second monitor on the same session gets the next messages; a subscriber left behind would too.
        second = RemoteMonitor([endpoint]).attach(session)
        wait_for(lambda: received(second), 10, "odom on the second monitor")
        second.close()
        assert odom_count(closed) == before
    finally:
        session.close()  # type: ignore[no-untyped-call]


def odom_count(monitor: RemoteMonitor) -> int:
    stats = monitor.topics().get("/odom")
    return 0 if stats is None else stats.count
