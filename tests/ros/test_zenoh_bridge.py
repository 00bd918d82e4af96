"""The Zenoh bridge under a real roslaunch and real Zenoh sessions on loopback (multicast scouting off).

Two bridges for the module: ``plain`` with the defaults (nothing inbound) plus a deny rule and a rate limit,
listening on a free port; ``routed`` with goals allowed, reaching its remote peers through a Zenoh router
that tests stop and restart.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh
import zenoh.ext

from mrs_nav.bridge.decoder import MessageDecoder
from mrs_nav.bridge.keys import publish_key
from mrs_nav.bridge.monitor import serialize_goal
from mrs_nav.bridge.session import open_client_session
from mrs_nav.bridge.wire import decode_attachment, decode_definition, encoding_text, schema_of
from tests.ros.zenoh_harness import (
    Bridge,
    Collector,
    Router,
    Ticker,
    mrs_nav,
    serialized,
    start_bridge,
    status,
    wait_bridge_up,
)
from tests.rosharness import RosMaster, free_port, wait_for

pytestmark = pytest.mark.ros

GOAL = "/move_base_simple/goal"
PUBLISH_GOAL = publish_key("mrs_nav", GOAL)


@pytest.fixture(scope="module")
def plain(ros_master: RosMaster, rospy_node: Any, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Bridge]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    config = {
        "listen": [endpoint],
        "deny": ["/rosout(_agg)?", "/clock", "/zb/secret"],
        "max_rates": {"/zb/fast": 10.0},
    }
    with start_bridge(ros_master, tmp_path_factory.mktemp("plain"), "zb_plain", config) as proc:
        session = open_client_session([endpoint])
        wait_bridge_up(session, proc, "the plain bridge")
        session.close()
        yield Bridge(endpoint, ros_master.log_dir, "zb_plain")


@pytest.fixture(scope="module")
def router() -> Iterator[Router]:
    router = Router()
    router.start()
    yield router
    router.kill()


@pytest.fixture(scope="module")
def routed(
    ros_master: RosMaster, rospy_node: Any, router: Router, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Bridge]:
    config = {"listen": [f"tcp/127.0.0.1:{free_port()}"], "connect": [router.endpoint]}
    with start_bridge(ros_master, tmp_path_factory.mktemp("routed"), "zb_routed", config, "allow_goal:=true") as proc:
        session = open_client_session([router.endpoint], mode="client")
        wait_bridge_up(session, proc, "the routed bridge")
        session.close()
        yield Bridge(router.endpoint, ros_master.log_dir, "zb_routed")


def test_bytes_arrive_unchanged_and_decode_with_rosbags(plain: Bridge, rospy_node: Any) -> None:
    from nav_msgs.msg import Odometry

    def odom(i: int) -> Any:
        msg = Odometry()
        msg.header.frame_id, msg.child_frame_id = "odom", "base_footprint"  # rospy numbers header.seq itself
        msg.pose.pose.position.x, msg.pose.pose.orientation.w = float(i), 1.0
        msg.twist.twist.linear.x = 0.22
        return msg

    session = open_client_session([plain.endpoint])
    try:
        got = Collector(session, "mrs_nav/zb/odom")
        with Ticker(rospy_node, "/zb/odom", Odometry, odom, 50.0) as ticker:
            wait_for(lambda: len(got.of("mrs_nav/zb/odom")) >= 40, 15, "40 odometry samples over Zenoh")
        sent = {int(m.pose.pose.position.x): serialized(m) for m in ticker.sent}
        samples = got.of("mrs_nav/zb/odom")
        replies = list(session.get("mrs_nav/@types/nav_msgs/Odometry", timeout=2.0))
        type_name, md5, definition = decode_definition(replies[0].ok.payload.to_bytes())
    finally:
        session.close()
    decoder = MessageDecoder()
    decoder.register(type_name, definition, md5)
    assert md5 == Odometry._md5sum
    seqs = []
    for _, _, encoding, payload, attachment in samples:
        assert schema_of(encoding) == "nav_msgs/Odometry"
        assert attachment is not None
        assert decode_attachment(attachment).md5 == Odometry._md5sum
        msg = decoder.decode(type_name, payload)
        number = int(msg.pose.pose.position.x)
        assert payload == sent[number]  # byte for byte what rospy serialized
        assert msg.twist.twist.linear.x == pytest.approx(0.22)
        seqs.append(number)
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # in order, none lost once flowing


def test_deny_rules_and_rate_limits_hold(plain: Bridge, rospy_node: Any) -> None:
    from std_msgs.msg import String, UInt32

    session = open_client_session([plain.endpoint])
    try:
        got = Collector(session, "mrs_nav/**")
        with (
            Ticker(rospy_node, "/zb/fast", UInt32, UInt32, 100.0),
            Ticker(rospy_node, "/zb/secret", String, lambda i: String(f"secret {i}"), 20.0, subscribed=False),
        ):
            wait_for(lambda: len(got.of("mrs_nav/zb/fast")) >= 31, 20, "31 rate-limited samples")
        alive = [str(r.ok.key_expr) for r in session.liveliness().get("mrs_nav/**", timeout=1.0)]
    finally:
        session.close()
    times = [s[0] for s in got.of("mrs_nav/zb/fast")]
    rate = (len(times) - 1) / (times[-1] - times[0])
    assert rate == pytest.approx(10.0, rel=0.10), f"/zb/fast went out at {rate:.2f} Hz, limit 10 Hz"
    assert got.of("mrs_nav/zb/secret") == []
    assert "mrs_nav/zb/fast" in alive
    assert "mrs_nav/zb/secret" not in alive


def test_a_late_joiner_gets_the_latched_map(plain: Bridge, rospy_node: Any, tmp_path: Path) -> None:
    from nav_msgs.msg import OccupancyGrid

    grid = OccupancyGrid()
    grid.header.frame_id = "map"
    grid.info.width, grid.info.height, grid.info.resolution = 40, 30, 0.05
    grid.info.origin.position.x = grid.info.origin.position.y = -1.0
    grid.info.origin.orientation.w = 1.0
    grid.data = [0, 100, -1] * 400
    pub = rospy_node.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
    try:
        published = time.time()
        pub.publish(grid)
        session = open_client_session([plain.endpoint])
        wait_for(
            lambda: any(True for _ in session.liveliness().get("mrs_nav/map", timeout=0.5)),
            15,
            "the bridge to send /map",
        )
        session.close()
        # A monitor that joins now, after the only /map message went out.
        snapshot = tmp_path / "snap.png"
        result = mrs_nav(
            "monitor", "--connect", plain.endpoint, "--once", "--duration", "1.5", "--json", "--snapshot", str(snapshot)
        )
        ended = time.time()
    finally:
        pub.unregister()
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    # The cached map comes with its true age: at least the 1.5 s the monitor watched, at most since publication.
    assert 1.5 <= summary["topics"]["/map"]["age_s"] <= ended - published
    assert summary["topics"]["/map"]["stale"] is False  # its publisher lives
    assert summary["map"]["width"] == 40
    assert summary["map"]["height"] == 30
    assert summary["topics"]["/map"]["count"] == 1
    assert snapshot.read_bytes()[:4] == b"\x89PNG"


def goal_recorder(rospy: Any) -> tuple[list[Any], Any]:
    from geometry_msgs.msg import PoseStamped

    goals: list[Any] = []
    return goals, rospy.Subscriber(GOAL, PoseStamped, goals.append, queue_size=10)


def test_a_remote_goal_is_refused_by_default(plain: Bridge, rospy_node: Any) -> None:
    goals, sub = goal_recorder(rospy_node)
    try:
        result = mrs_nav("monitor", "--connect", plain.endpoint, "--send-goal", "1,2,0")
        # A plain put on the goal key must not get in either.
        session = open_client_session([plain.endpoint])
        session.put(
            "mrs_nav/move_base_simple/goal",
            serialize_goal(1, 2, 0),
            encoding=zenoh.Encoding(encoding_text("geometry_msgs/PoseStamped")),
        )
        time.sleep(1.0)  # absence of a message: give it a generous second to (not) arrive
        session.close()
    finally:
        sub.unregister()
    assert result.returncode == 1
    assert "inbound allow-list" in result.stderr
    assert goals == []


def test_an_allowed_remote_goal_reaches_ros(routed: Bridge, rospy_node: Any) -> None:
    goals, sub = goal_recorder(rospy_node)
    try:
        wait_for(lambda: sub.get_num_connections() > 0, 15, "the bridge's goal publisher")
        result = mrs_nav("monitor", "--connect", routed.endpoint, "--send-goal", "1.5,-0.5,1.5708")
        assert result.returncode == 0, result.stderr
        assert "published on /move_base_simple/goal" in result.stdout
        wait_for(lambda: len(goals) == 1, 10, "the goal in ROS")
    finally:
        sub.unregister()
    goal = goals[0]
    assert (goal.header.frame_id, goal.pose.position.x, goal.pose.position.y) == ("map", 1.5, -0.5)
    assert goal.pose.orientation.z == pytest.approx(0.7071, abs=1e-4)


def test_a_malformed_payload_is_dropped_with_a_log_line_and_the_bridge_keeps_running(
    routed: Bridge, rospy_node: Any
) -> None:
    goals, sub = goal_recorder(rospy_node)
    session = open_client_session([routed.endpoint], mode="client")
    try:
        pub = session.declare_publisher(
            "mrs_nav/move_base_simple/goal", encoding=zenoh.Encoding(encoding_text("geometry_msgs/PoseStamped"))
        )
        wait_for(lambda: sub.get_num_connections() > 0, 15, "the bridge's goal publisher in ROS")
        wait_for(lambda: pub.matching_status.matching, 15, "the bridge's goal subscriber on Zenoh")
        for junk in (b"\x00garbage", serialize_goal(float("nan"), 0, 0), serialize_goal(1, 1, 0, frame="odom")):
            pub.put(junk)
        wait_for(lambda: "dropped remote message on /move_base_simple/goal" in routed.log(), 10, "the drop log line")
        time.sleep(1.0 / 2.0)  # goals are limited to 2 Hz (junk does not count): one period since the last test's
        pub.put(serialize_goal(0.5, 0.25, 0.0))
        wait_for(lambda: len(goals) >= 1, 10, "a valid goal after the malformed ones")
    finally:
        session.close()
        sub.unregister()
    assert [(g.pose.position.x, g.pose.position.y) for g in goals] == [(0.5, 0.25)]


def test_a_goal_stamped_an_hour_ago_or_in_the_future_is_dropped_and_counted(routed: Bridge, rospy_node: Any) -> None:
    goals, sub = goal_recorder(rospy_node)
    session = open_client_session([routed.endpoint], mode="client")
    encoding = zenoh.Encoding(encoding_text("geometry_msgs/PoseStamped"))
    hour_ago, ahead = time.time_ns() - 3600 * 10**9, time.time_ns() + 60 * 10**9
    try:
        pub = session.declare_publisher("mrs_nav/move_base_simple/goal", encoding=encoding)
        wait_for(lambda: sub.get_num_connections() > 0, 15, "the bridge's goal publisher in ROS")
        wait_for(lambda: pub.matching_status.matching, 15, "the bridge's goal subscriber on Zenoh")
        dropped_before = status(session)["inbound"][GOAL]["dropped"]
        pub.put(serialize_goal(2.0, 2.0, 0.0, stamp_ns=hour_ago))  # captured an hour ago, replayed now
        pub.put(serialize_goal(3.0, 3.0, 0.0, stamp_ns=ahead))
        answers = [
            list(session.get(PUBLISH_GOAL, payload=serialize_goal(4.0, 4.0, 0.0, stamp_ns=s), encoding=encoding))
            for s in (hour_ago, ahead)
        ]
        wait_for(lambda: status(session)["inbound"][GOAL]["dropped"] == dropped_before + 4, 10, "4 goals counted")
        sent_stamps: list[int] = []

        def fresh_goal_taken() -> bool:
            # Goals are limited to 2 Hz and a loaded machine may deliver the last test's late: a fresh goal that
            # the limit drops is sent again, never a stale one.
            if not goals:
                sent_stamps.append(time.time_ns() - 2 * 10**9)  # 2 s old: within max_age, so taken
                pub.put(serialize_goal(0.75, 0.5, 0.0, stamp_ns=sent_stamps[-1]))
                time.sleep(0.6)
            return bool(goals)

        wait_for(fresh_goal_taken, 10, "the fresh goal")
        time.sleep(0.5)  # absence of the stale ones: anything in flight arrives
    finally:
        session.close()
        sub.unregister()
    assert {(g.pose.position.x, g.pose.position.y) for g in goals} == {(0.75, 0.5)}
    # restamped with the robot's ROS time (sim time, or the bridge's wall clock): never the sender's stamp
    assert goals[0].header.stamp.to_nsec() not in sent_stamps
    errors = [r.err.payload.to_string() for replies in answers for r in replies if r.err is not None]
    assert len(errors) == 2
    assert "stamped 3600" in errors[0]
    assert "older than its max_age 5 s" in errors[0]
    assert "in the future, beyond the 0.5 s clock tolerance" in errors[1]


def test_restarting_the_router_or_the_remote_peer_loses_nothing_in_ros_and_the_flow_resumes(
    routed: Bridge, router: Router, rospy_node: Any
) -> None:
    from std_msgs.msg import UInt32

    ros_got: list[int] = []
    sub = rospy_node.Subscriber("/zb/beat", UInt32, lambda m: ros_got.append(m.data), queue_size=1000)
    key = "mrs_nav/zb/beat"

    def flowing(collector: Collector, after: int) -> bool:
        return any(int.from_bytes(s[3][:4], "little") > after for s in collector.of(key))

    session = open_client_session([routed.endpoint], mode="client")
    try:
        got = Collector(session, key)
        ticker = Ticker(rospy_node, "/zb/beat", UInt32, UInt32, 50.0)
        wait_for(lambda: sub.get_num_connections() > 0, 15, "the direct ROS subscriber")
        with ticker:
            wait_for(lambda: flowing(got, 0), 15, "the heartbeat over Zenoh")
            router.kill()
            time.sleep(1.0)  # the router is away for a second while ROS keeps publishing
            router.start()
            mark = len(ticker.sent)
            wait_for(lambda: flowing(got, mark), 20, "the flow to resume after the router restart")
            # Now the remote peer goes away and comes back.
            session.close()
            session = open_client_session([routed.endpoint], mode="client")
            again = Collector(session, key)
            mark = len(ticker.sent)
            wait_for(lambda: flowing(again, mark), 20, "the flow to resume for the restarted peer")
        wait_for(lambda: len(ros_got) >= len(ticker.sent), 10, "the ROS subscriber to catch up")
    finally:
        session.close()
        sub.unregister()
    # The ROS side never noticed: every message published reached the direct subscriber, in order.
    assert ros_got == list(range(len(ticker.sent)))
