"""Zenoh's TLS, authentication and the bridge's access control, with real certificates made by openssl and
real Zenoh sessions on loopback (no ROS): a stand-in bridge runs as the robot's router with exactly the
settings :class:`BridgeConfig` gives the node, and remote sessions connect in client mode."""

from __future__ import annotations

import json
import os
import re
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import zenoh
import zenoh.ext

from mrs_nav.bridge.certs import KeyPair, make_ca, make_cert
from mrs_nav.bridge.config import BridgeConfig, zenoh_settings
from mrs_nav.bridge.decoder import noetic_store
from mrs_nav.bridge.keys import publish_key, status_key, topic_key
from mrs_nav.bridge.monitor import RemoteMonitor, serialize_goal
from mrs_nav.bridge.session import (
    bridge_settings,
    open_client_session,
    open_session,
    refuse_lowlatency,
    zenoh_config,
)
from mrs_nav.bridge.wire import encode_attachment, encode_status, encoding_text
from mrs_nav.errors import InvalidInputError
from tests.core.bridge.test_monitor import answer_types, grid, odometry
from tests.rosharness import free_port, wait_for

STORE = noetic_store()
GOAL = "/move_base_simple/goal"
GOAL_MD5 = STORE.generate_msgdef("geometry_msgs/msg/PoseStamped", ros_version=1)[1]


@dataclass
class Pki:
    ca: KeyPair
    server: KeyPair
    monitor: KeyPair  # a viewer's certificate
    intruder: KeyPair  # signed by another CA
    users: Path
    operator: KeyPair | None = None


def client_file(
    tmp: Path, pki: Pki, user: str, password: str, *, pair: KeyPair | None = None, ca: Path | None = None
) -> str:
    """A Zenoh JSON5 file as a remote user would write it (mutual TLS + user/password)."""
    pair = pair or pki.monitor
    path = tmp / f"client-{user}-{password}-{pair.cert.stem}.json5"
    tls = {
        "root_ca_certificate": str(ca or pki.ca.cert),
        "connect_certificate": str(pair.cert),
        "connect_private_key": str(pair.key),
        "enable_mtls": True,
    }
    path.write_text(
        json.dumps({"transport": {"link": {"tls": tls}, "auth": {"usrpwd": {"user": user, "password": password}}}})
    )
    return str(path)


@pytest.fixture(scope="module")
def pki(tmp_path_factory: pytest.TempPathFactory) -> Pki:
    d = tmp_path_factory.mktemp("pki")
    ca = make_ca(d)
    users = d / "users.txt"
    users.write_text("operator:op-secret\nviewer:view-secret\n")
    rogue = make_ca(d, "rogue-ca")
    return Pki(ca, make_cert(ca, d, "bridge", ("127.0.0.1", "localhost")), make_cert(ca, d, "monitor"),
               make_cert(rogue, d, "intruder"), users, make_cert(ca, d, "operator"))  # fmt: skip


class RobotRouter:
    """What the bridge node does on Zenoh, minus ROS, in router mode with TLS, passwords and its ACL."""

    def __init__(self, tmp: Path, pki: Pki) -> None:
        self.endpoint = f"tls/127.0.0.1:{free_port()}"
        server = tmp / "bridge-zenoh.json5"
        tls = {
            "root_ca_certificate": str(pki.ca.cert),
            "listen_certificate": str(pki.server.cert),
            "listen_private_key": str(pki.server.key),
            "enable_mtls": True,
        }
        server.write_text(
            json.dumps({"transport": {"link": {"tls": tls}, "auth": {"usrpwd": {"dictionary_file": str(pki.users)}}}})
        )
        config = BridgeConfig.from_mapping(
            {"mode": "router", "listen": [self.endpoint], "zenoh_config": str(server), "operators": ["operator"],
             "inbound": [GOAL]}
        )  # fmt: skip
        self.session = open_session(bridge_settings(config, {GOAL: GOAL_MD5})[0], config.zenoh_config)
        self.inbound: list[bytes] = []
        s = self.session
        self.entities: list[Any] = [
            s.declare_queryable("mrs_nav/@types/**", answer_types),
            s.declare_queryable(
                status_key("mrs_nav"), lambda q: q.reply(status_key("mrs_nav"), encode_status({"topics": {}}))
            ),
            s.declare_subscriber(topic_key("mrs_nav", GOAL), lambda x: self.inbound.append(x.payload.to_bytes())),
            s.declare_queryable(publish_key("mrs_nav", GOAL), self._publish),
        ]
        for topic in ("/odom", "/map"):
            self.entities.append(s.liveliness().declare_token(topic_key("mrs_nav", topic)))
        self.odom = s.declare_publisher("mrs_nav/odom", encoding=zenoh.Encoding(encoding_text("nav_msgs/Odometry")))
        self.map = zenoh.ext.declare_advanced_publisher(
            s, "mrs_nav/map", encoding=zenoh.Encoding(encoding_text("nav_msgs/OccupancyGrid")),
            cache=zenoh.ext.CacheConfig(max_samples=1), publisher_detection=True,
        )  # fmt: skip

    def _publish(self, query: zenoh.Query) -> None:
        self.inbound.append(query.payload.to_bytes() if query.payload is not None else b"")
        query.reply(str(query.key_expr), "published")

    def put(self, publisher: Any, msg: Any, type_name: str) -> None:
        md5 = STORE.generate_msgdef(type_name, ros_version=1)[1]
        publisher.put(bytes(STORE.serialize_ros1(msg, type_name)), attachment=encode_attachment(md5, time.time_ns()))


@pytest.fixture(scope="module")
def robot(tmp_path_factory: pytest.TempPathFactory, pki: Pki) -> Iterator[RobotRouter]:
    router = RobotRouter(tmp_path_factory.mktemp("robot"), pki)
    yield router
    router.session.close()  # type: ignore[no-untyped-call]


def test_the_monitor_connects_with_the_right_ca_and_credentials(robot: RobotRouter, pki: Pki, tmp_path: Path) -> None:
    robot.put(robot.map, grid(), "nav_msgs/msg/OccupancyGrid")  # before the monitor joins: from the cache
    config = client_file(tmp_path, pki, "viewer", "view-secret")
    with RemoteMonitor([robot.endpoint], mode="client", config_file=config) as monitor:
        assert monitor.status()["topics"] == {}
        wait_for(
            lambda: monitor.topics().get("/map") is not None and monitor.topics()["/map"].count == 1, 10, "the map"
        )
        robot.put(robot.odom, odometry(1.0, 0.1), "nav_msgs/msg/Odometry")
        wait_for(lambda: monitor.topics().get("/odom") is not None and monitor.topics()["/odom"].count == 1, 10, "odom")
        assert monitor.latest("/map").info.width == 4
        assert monitor.latest("/odom").pose.pose.position.x == pytest.approx(1.0)
        assert {t for t, s in monitor.topics().items() if s.alive} == {"/map", "/odom"}


@pytest.mark.parametrize(
    "case", ["wrong password", "unknown user", "certificate of another CA", "server not trusted", "plain TCP"]
)
def test_wrong_credentials_are_refused(robot: RobotRouter, pki: Pki, tmp_path: Path, case: str) -> None:
    endpoint = robot.endpoint
    if case == "wrong password":
        config = client_file(tmp_path, pki, "viewer", "guess")
    elif case == "unknown user":
        config = client_file(tmp_path, pki, "mallory", "view-secret")
    elif case == "certificate of another CA":
        config = client_file(tmp_path, pki, "viewer", "view-secret", pair=pki.intruder)
    elif case == "server not trusted":  # the client trusts another CA: the robot's certificate is refused
        config = client_file(tmp_path, pki, "viewer", "view-secret", ca=pki.intruder.cert)
    else:
        config, endpoint = "", endpoint.replace("tls/", "tcp/")
    with pytest.raises(InvalidInputError, match="cannot open a Zenoh session"):
        open_client_session([endpoint], mode="client", config_file=config)


def test_only_the_bridge_publishes_data_keys_and_only_operators_send_goals(
    robot: RobotRouter, pki: Pki, tmp_path: Path
) -> None:
    watcher = open_client_session([robot.endpoint], "client", client_file(tmp_path, pki, "viewer", "view-secret"))
    forger = open_client_session([robot.endpoint], "client", client_file(tmp_path, pki, "viewer", "view-secret"))
    operator = open_client_session(
        [robot.endpoint], "client", client_file(tmp_path, pki, "operator", "op-secret", pair=pki.operator)
    )
    try:
        seen: list[tuple[str, bytes]] = []
        tokens: list[str] = []
        watcher.declare_subscriber("mrs_nav/**", lambda s: seen.append((str(s.key_expr), s.payload.to_bytes())))
        watcher.liveliness().declare_subscriber("mrs_nav/**", lambda s: tokens.append(str(s.key_expr)))
        time.sleep(0.5)  # declarations propagate through the router
        forged_token = forger.liveliness().declare_token("mrs_nav/forged")
        for _ in range(20):
            forger.put("mrs_nav/odom", b"forged")
        forger.put(topic_key("mrs_nav", GOAL), serialize_goal(9, 9, 0))  # a viewer may not send goals
        refused = list(forger.get(publish_key("mrs_nav", GOAL), payload=serialize_goal(8, 8, 0), timeout=1.0))
        operator.put(topic_key("mrs_nav", GOAL), serialize_goal(1, 2, 0, stamp_ns=1))
        accepted = list(
            operator.get(publish_key("mrs_nav", GOAL), payload=serialize_goal(3, 4, 0, stamp_ns=1), timeout=2.0)
        )
        robot.put(robot.odom, odometry(2.0, 0.0), "nav_msgs/msg/Odometry")
        wait_for(lambda: any(k == "mrs_nav/odom" for k, _ in seen), 10, "the bridge's own odometry")
        wait_for(lambda: len(robot.inbound) == 2, 10, "the operator's two goals")
        time.sleep(0.5)  # absence of forged samples: let anything in flight arrive
        forged_token.undeclare()
    finally:
        for session in (watcher, forger, operator):
            session.close()  # type: ignore[no-untyped-call]
    assert [p for k, p in seen if k == "mrs_nav/odom" and p == b"forged"] == []
    assert "mrs_nav/forged" not in tokens
    assert not any(r.ok is not None for r in refused)
    assert [r.ok is not None for r in accepted] == [True]
    expected = [serialize_goal(1, 2, 0, stamp_ns=1), serialize_goal(3, 4, 0, stamp_ns=1)]
    assert sorted(robot.inbound) == sorted(expected)  # put and query race
    assert [k for k, _ in seen if k == topic_key("mrs_nav", GOAL)] == [topic_key("mrs_nav", GOAL)]  # operator's


@pytest.mark.parametrize(
    ("credentials", "operator"),
    [
        (("viewer", "operator", "op-secret"), False),  # a viewer's certificate with the operator's password
        (("operator", "viewer", "view-secret"), False),  # the operator's certificate with a viewer's password
        (("operator", "operator", "op-secret"), True),
    ],
)
def test_the_operator_role_needs_both_the_certificate_and_the_password(
    robot: RobotRouter, pki: Pki, tmp_path: Path, credentials: tuple[str, str, str], operator: bool
) -> None:
    certificate, user, password = credentials
    pair = pki.operator if certificate == "operator" else pki.monitor
    session = open_client_session([robot.endpoint], "client", client_file(tmp_path, pki, user, password, pair=pair))
    try:
        time.sleep(0.5)  # the session's declarations reach the router
        replies = list(session.get(publish_key("mrs_nav", GOAL), payload=serialize_goal(1, 1, 0), timeout=2.0))
    finally:
        session.close()  # type: ignore[no-untyped-call]
    assert [r.ok is not None for r in replies] == ([True] if operator else [])


def test_operators_without_a_credential_to_check_are_refused() -> None:
    config = BridgeConfig.from_mapping({"operators": ["operator"], "inbound": [GOAL]})
    with pytest.raises(InvalidInputError, match=r"operators \['operator'\]: the Zenoh configuration checks no cred"):
        bridge_settings(config, {GOAL: GOAL_MD5})


def tls_file(tmp: Path, pki: Pki, *, mtls: bool = False, passwords: bool = False) -> str:
    """A robot's Zenoh file with a server certificate, client certificates and/or passwords."""
    path = tmp / f"robot-{mtls}-{passwords}.json5"
    tls = {"listen_certificate": str(pki.server.cert), "listen_private_key": str(pki.server.key)}
    if mtls:
        tls |= {"root_ca_certificate": str(pki.ca.cert), "enable_mtls": True}
    auth = {"usrpwd": {"dictionary_file": str(pki.users)}} if passwords else {}
    path.write_text(json.dumps({"transport": {"link": {"tls": tls}, "auth": auth}}))
    return str(path)


@pytest.mark.parametrize(
    ("endpoint", "security", "why"),
    [
        ("tcp/0.0.0.0:7447", "", "without encryption or client authentication"),
        ("tcp/[::]:7447", "", "without encryption"),
        ("ws/0.0.0.0:7448", "", "without encryption"),
        ("udp/0.0.0.0:7447", "", "without encryption"),
        ("tcp/robot.example:7447", "", "without encryption"),
        ("tcp/[::ffff:192.168.1.20]:7447", "", "without encryption"),
        ("tls/0.0.0.0:7447", "tls", "TLS without client authentication"),
    ],
)
def test_a_listen_endpoint_open_to_the_network_is_refused_unless_insecure(
    pki: Pki, tmp_path: Path, endpoint: str, security: str, why: str
) -> None:
    params: dict[str, Any] = {"listen": [endpoint], "inbound": [GOAL]}
    if security:
        params["zenoh_config"] = tls_file(tmp_path, pki)
    with pytest.raises(InvalidInputError, match=rf"listen endpoint {re.escape(endpoint)} .*{why}.*insecure: true"):
        bridge_settings(BridgeConfig.from_mapping(params), {GOAL: GOAL_MD5})
    _, warnings = bridge_settings(BridgeConfig.from_mapping({**params, "insecure": True}), {GOAL: GOAL_MD5})
    assert len(warnings) == 1
    assert warnings[0].startswith(f"INSECURE (insecure: true): {endpoint} ")


@pytest.mark.parametrize(
    ("endpoint", "security"),
    [
        ("tcp/127.0.0.1:7447", ""),
        ("tcp/[::1]:7447", ""),
        ("tcp/[::ffff:127.0.0.1]:7447", ""),
        ("tcp/127.0.0.2:7447", ""),
        ("ws/localhost:7448", ""),
        ("unixsock-stream/tmp/robot.sock", ""),
        ("tls/0.0.0.0:7447", "mtls"),
        ("tls/0.0.0.0:7447", "passwords"),
    ],
)
def test_loopback_and_authenticated_tls_endpoints_are_accepted_without_warning(
    pki: Pki, tmp_path: Path, endpoint: str, security: str
) -> None:
    params: dict[str, Any] = {"listen": [endpoint]}
    if security:
        params["zenoh_config"] = tls_file(tmp_path, pki, mtls=security == "mtls", passwords=security == "passwords")
    assert bridge_settings(BridgeConfig.from_mapping(params), {})[1] == []


def test_a_tls_endpoint_without_certificates_is_one_clear_error(tmp_path: Path) -> None:
    config = BridgeConfig.from_mapping({"listen": ["tls/127.0.0.1:7447"]})
    with pytest.raises(InvalidInputError, match=r"needs transport\.link\.tls\.listen_certificate and listen_priv"):
        zenoh_config(config.zenoh_settings({}), config.zenoh_config)
    with pytest.raises(InvalidInputError, match="cannot read zenoh_config: No such file"):
        zenoh_config(config.zenoh_settings({}), str(tmp_path / "missing.json5"))


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("{transport: {link: {tls: {root_ca_certificate: 3}}}}", "line 1, column 48: invalid type: integer `3`"),
        ("{ mode: 5 }", "line 1, column 9: invalid type: integer `5`, expected either 'router', 'peer' or 'client'"),
        ("{\n  mode: 'peer',,\n}", "line 2, column 16: expected identifier or string"),
        ("{ transport: { link: { tls: { root_ca_certificate: '/dev/zero' } } } }", "not a regular file"),
        ("{ transport: { auth: { usrpwd: { dictionary_file: '/dev/zero' } } } }", "/dev/zero: cannot read transport"),
    ],
)
def test_a_malformed_zenoh_file_is_one_readable_line_naming_it(text: str, match: str, tmp_path: Path) -> None:
    path = tmp_path / "bad.json5"
    path.write_text(text)
    with pytest.raises(InvalidInputError) as raised:
        zenoh_config({}, str(path))
    message = str(raised.value)
    assert str(path) in message
    assert match in message
    assert ".rs:" not in message
    assert "Location" not in message
    assert "\n" not in message


@pytest.mark.parametrize("kind", ["fifo", "device", "binary"])
def test_a_zenoh_file_that_is_no_text_file_is_refused_before_zenoh_reads_it(kind: str, tmp_path: Path) -> None:
    path = tmp_path / "zenoh.json5"
    if kind == "fifo":
        os.mkfifo(path)  # Zenoh would block opening it, for ever
    elif kind == "device":
        path = Path("/dev/zero")  # Zenoh would read it until memory runs out
    else:
        path.write_bytes(b"{\xff\xfe}")
    with pytest.raises(InvalidInputError, match=rf"{re.escape(str(path))}: cannot read zenoh_config: not"):
        zenoh_config({}, str(path))


def test_a_certificate_that_is_not_pem_is_refused_before_connecting(pki: Pki, tmp_path: Path) -> None:
    garbage = tmp_path / "ca.pem"
    garbage.write_text("garbage\n")
    config = client_file(tmp_path, pki, "viewer", "view-secret", ca=garbage)
    with pytest.raises(InvalidInputError, match=rf"{re.escape(str(garbage))}: transport.link.tls.root_ca_certificate"):
        open_client_session([f"tls/127.0.0.1:{free_port()}"], config_file=config)


LOWLATENCY = {"transport": {"unicast": {"lowlatency": True, "qos": {"enabled": False}}}}


def test_zenoh_lowlatency_transport_is_refused_with_one_clear_error(tmp_path: Path) -> None:
    settings = BridgeConfig.from_mapping({}).zenoh_settings({})
    lowlatency = tmp_path / "lowlatency.json5"
    lowlatency.write_text(json.dumps(LOWLATENCY))
    with pytest.raises(InvalidInputError, match=rf"zenoh_config {re.escape(str(lowlatency))}: .*lowlatency cannot"):
        refuse_lowlatency(zenoh_config(settings, str(lowlatency)), str(lowlatency))
    refuse_lowlatency(zenoh_config(settings))  # the default transport passes


@pytest.mark.parametrize(("transport", "map_arrives"), [("universal", True), ("lowlatency", False)])
def test_zenoh_lowlatency_transport_drops_the_link_on_a_message_above_the_batch_size(
    tmp_path: Path, transport: str, map_arrives: bool
) -> None:
    """Why the bridge refuses it: a map-sized sample over lowlatency links never arrives (the link is dropped and
    reconnected), while the default (universal) transport fragments it. Small samples after it arrive either way."""
    config_file = ""
    if transport == "lowlatency":
        config_file = str(tmp_path / "lowlatency.json5")
        Path(config_file).write_text(json.dumps(LOWLATENCY))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_session(zenoh_settings("router", [endpoint], []), config_file)
    client = open_client_session([endpoint], "client", config_file)
    try:
        sizes: list[int] = []
        client.declare_subscriber("m/**", lambda s: sizes.append(len(s.payload)))
        publisher = router.declare_publisher("m/x", express=True)
        wait_for(lambda: publisher.put(b"s") or 1 in sizes, 10.0, "the subscription to reach the router")
        sizes.clear()
        publisher.put(bytes(150_000))
        if map_arrives:
            # waited for itself: under load a small sample put after it can arrive first
            wait_for(lambda: 150_000 in sizes, 30.0, "the map-sized sample")
        # the lowlatency link is dropped and reconnected meanwhile, which takes seconds on a loaded machine
        wait_for(lambda: publisher.put(b"s") or 1 in sizes, 30.0, "a small sample after the big one")
        assert (150_000 in sizes) == map_arrives
    finally:
        client.close()  # type: ignore[no-untyped-call]
        router.close()  # type: ignore[no-untyped-call]
