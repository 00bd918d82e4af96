"""Bridge configuration validation and the rate limiter."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mrs_nav.bridge.config import BridgeConfig, InboundRule
from mrs_nav.bridge.keys import KeyLayout
from mrs_nav.bridge.rate_limit import RateLimiter
from mrs_nav.errors import InvalidInputError


def test_defaults_are_loopback_peer_with_nothing_inbound() -> None:
    config = BridgeConfig.from_mapping({})
    assert (config.mode, config.listen, config.connect) == ("peer", ("tcp/127.0.0.1:7447",), ())
    assert config.inbound == ()
    assert config.key_prefix == "mrs_nav"
    settings = config.zenoh_settings({})
    assert settings["scouting/multicast/enabled"] is False
    # The bridge's access control is on: remote sessions may observe, and put on nothing.
    acl = settings["access_control"]
    assert (acl["enabled"], acl["default_permission"]) == (True, "deny")
    assert [r["id"] for r in acl["rules"]] == ["bridge_out", "observe"]
    assert config.topics.accepts("/odom")
    assert not config.topics.accepts("/rosout")
    assert not config.topics.accepts("/clock")


def test_mapping_with_filters_rates_and_inbound() -> None:
    config = BridgeConfig.from_mapping(
        {
            "listen": "tcp/127.0.0.1:1234, tcp/127.0.0.1:1235",
            "namespace": "r1",
            "layout": "zenoh-bridge-ros1",
            "allow": ["/scan", "/odom.*"],
            "deny": ["/odom_raw"],
            "max_rates": {"/scan": 5, "/odom.*": 20.0},
            "default_max_rate": 1,
            "inbound": ["/move_base_simple/goal", {"topic": "/cmd_vel", "type": "geometry_msgs/Twist"}],
        }
    )
    assert config.listen == ("tcp/127.0.0.1:1234", "tcp/127.0.0.1:1235")
    assert config.key_prefix == "mrs_nav/r1"
    assert config.layout is KeyLayout.ZENOH_BRIDGE_ROS1
    assert config.topics.accepts("/odom")
    assert config.topics.accepts("/scan")
    assert not config.topics.accepts("/odom_raw")
    assert not config.topics.accepts("/map")
    assert (config.max_rate("/scan"), config.max_rate("/odometry"), config.max_rate("/map")) == (5.0, 20.0, 1.0)
    assert config.inbound_rule("/move_base_simple/goal") == InboundRule(
        "/move_base_simple/goal", "geometry_msgs/PoseStamped", "map"
    )
    assert config.inbound_rule("/cmd_vel") == InboundRule("/cmd_vel", "geometry_msgs/Twist", "")
    assert config.inbound_rule("/map") is None


def test_a_bridge_in_a_namespace_names_its_robots_topics_as_the_robot_does() -> None:
    config = BridgeConfig.from_mapping({"namespace": "/tb3_1/"})
    assert config.key_prefix == "mrs_nav/tb3_1"
    assert config.ros_topic("/odom") == "/tb3_1/odom"
    assert config.robot_topic("/tb3_1/odom") == "/odom"
    assert config.robot_topic("/tb3_1/move_base/status") == "/move_base/status"
    # Another robot's topics, global ones, and a namespace that only starts alike are not this robot's.
    assert config.robot_topic("/tb3_0/odom") is None
    assert config.robot_topic("/clock") is None
    assert config.robot_topic("/tb3_10/odom") is None
    plain = BridgeConfig.from_mapping({})
    assert (plain.ros_topic("/odom"), plain.robot_topic("/tb3_0/odom")) == ("/odom", "/tb3_0/odom")


def test_numbers_a_command_line_hands_over_as_text_are_read() -> None:
    # rospy reads _max_rates:="{/scan: 1e1}" with YAML 1.1, which leaves 1e1 as text
    config = BridgeConfig.from_mapping({"max_rates": {"/scan": "1e1"}, "discovery_period": "2.5e-1"})
    assert config.max_rates == (("/scan", 10.0),)
    assert config.discovery_period == 0.25


@pytest.mark.parametrize(
    ("params", "match"),
    [
        ({"mode": "server"}, "mode"),
        ({"listen": ["127.0.0.1:7447"]}, "endpoint"),
        ({"listen": [], "connect": []}, "both empty"),
        ({"deny": ["("]}, "bad regular expression"),
        ({"max_rates": {"/scan": -1}}, "max rate"),
        ({"max_rates": {"/scan": float("nan")}}, "max rate"),
        ({"inbound": [{"topic": "/x"}]}, "type"),
        ({"inbound": ["/move_base_simple/goal", "/move_base_simple/goal"]}, "twice"),
        ({"inbound": [{"topic": "nope", "type": "a/B"}]}, "topic"),
        ({"discovery_period": 0}, "discovery_period"),
        ({"discovery_period": 1e-300}, r"discovery_period 1e-300: expected 0\.1 \.\. 60 s"),
        ({"discovery_period": 1e300}, r"discovery_period 1e\+300: expected 0\.1 \.\. 60 s"),
        ({"retry_period": 1.0e300}, r"retry_period 1e\+300: expected 0\.1 \.\. 3600 s"),
        ({"layout": "zenoh-bridge-ros1", "prefix": "", "discovery_period": 3.0}, "must be below 3 s"),
        ({"retry_period": float("nan")}, "retry_period nan"),
        ({"connect": ["tcp/127.0.0.1:99999"]}, "port 99999 is not in 0..65535"),
        ({"connect": ["tcp/[::1"]}, r"endpoint 'tcp/\[::1': expected tcp/HOST:PORT"),
        ({"connect": ["tls/[1::2::3]:7447"]}, r"\[1::2::3\] is not an IPv6 address"),
        ({"listen": ["tcp/robot"]}, "expected tcp/HOST:PORT"),
        ({"lisen": ["tcp/127.0.0.1:1"]}, "unknown"),
        ({"layout": "dds"}, "layout"),
        ({"prefix": "a b"}, "prefix"),
    ],
)
def test_bad_configuration_is_one_clear_error(params: dict[str, object], match: str) -> None:
    with pytest.raises(InvalidInputError, match=match):
        BridgeConfig.from_mapping(params)


def test_endpoints_zenoh_accepts_pass() -> None:
    endpoints = ["tcp/[::1]:7447", "tcp/robot-1.local:7447", "udp/127.0.0.1:0", "tcp/127.0.0.1:7447#iface=lo",
                 "tls/10.0.0.2:7447?prio=1", "unixsock-stream//tmp/zenoh.sock"]  # fmt: skip
    assert BridgeConfig.from_mapping({"connect": endpoints}).connect == tuple(endpoints)


def test_rate_limiter_holds_the_mean_rate_under_jittery_input() -> None:
    limiter = RateLimiter(10.0)
    # 100 Hz input with +-3 ms jitter for 20 s: the output must be 10 Hz, not the ~9 Hz a "gap >= period"
    # rule gives.
    rng = __import__("random").Random(1)
    times = [i * 0.01 + rng.uniform(-0.003, 0.003) for i in range(2000)]
    passed = [t for t in times if limiter.allow(t)]
    rate = (len(passed) - 1) / (passed[-1] - passed[0])
    assert rate == pytest.approx(10.0, rel=0.01)


@given(st.floats(min_value=0.5, max_value=200.0), st.floats(min_value=0.1, max_value=10.0))
def test_rate_limiter_never_exceeds_its_rate(max_rate: float, duration: float) -> None:
    limiter = RateLimiter(max_rate)
    times = [i * 0.001 for i in range(int(duration / 0.001))]
    passed = sum(limiter.allow(t) for t in times)
    assert passed <= max_rate * duration + 1


def test_rate_limiter_zero_means_unlimited_and_negative_is_refused() -> None:
    assert all(RateLimiter(0.0).allow(0.0) for _ in range(100))
    with pytest.raises(InvalidInputError, match="rate"):
        RateLimiter(-1.0)
