"""The access control rules the bridge gives its own Zenoh session (Zenoh's ``access_control`` section).

The bridge is the only writer of its robot's keys: remote sessions may subscribe, query definitions, the
bridge's status and the late-joiner caches, and watch liveliness tokens, but the only things they may put or
query into are the inbound keys the allow-list names, and only operators may do that when ``operators`` is not
empty: a session whose every credential the configuration checks names an operator (its username when
passwords are checked, its certificate's common name when client certificates are, both when both are; a
viewer's certificate with an operator's password is no operator). Everything else a remote
session sends on these keys (a forged ``/odom``, a forged liveliness token) is dropped by Zenoh at ingress,
before it reaches the bridge or, when the bridge is the robot's router, any other subscriber.

Zenoh's ``**`` never matches chunks starting with ``@``, so the advanced publishers' ``@adv`` keys and the
bridge's ``@types`` / ``@bridge`` services are named explicitly.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable
from typing import Any

from mrs_nav.bridge.exposure import Credential
from mrs_nav.bridge.keys import (
    STATUS_SUFFIX,
    KeyLayout,
    data_pattern,
    discovery_pattern,
    publish_key,
    services_pattern,
    topic_key,
)
from mrs_nav.errors import InvalidInputError

# Zenoh's ACL message kinds (zenoh 1.x).
_ALL = [
    "put", "delete", "declare_subscriber", "query", "reply", "declare_queryable", "liveliness_token",
    "declare_liveliness_subscriber", "liveliness_query",
]  # fmt: skip
_OBSERVE = ["declare_subscriber", "query", "declare_liveliness_subscriber", "liveliness_query"]


def access_control(
    prefix: str,
    layout: KeyLayout,
    inbound: Iterable[tuple[str, str, str]],
    operators: Iterable[str] = (),
    credentials: Collection[Credential] = (),
) -> dict[str, Any]:
    """Zenoh's ``access_control`` value for a bridge with key prefix ``prefix``.

    ``inbound`` holds (topic, ROS type, md5) of each allow-listed inbound topic; ``operators`` the names allowed
    to send them (empty: any session that can connect), each checked as every one of ``credentials`` (what the
    Zenoh configuration checks: usernames, certificate common names) at once. Raise InvalidInputError when
    operators are named and no credential is checked: nobody could be told from anybody else.
    """
    data = [data_pattern(prefix, layout), f"{data_pattern(prefix, layout)}/@adv/**"]
    services = services_pattern(prefix)
    # Status queries may name any prefix (``**/@bridge/status``: Zenoh's ACL admits a query only when its whole
    # key expression lies inside an allowed one): that is how a fleet monitor finds every robot behind a router.
    # The bridge still answers with its own status only.
    observed = [*data, f"{services}/@types/**", f"**{STATUS_SUFFIX}"]
    outgoing = [*data, f"{services}/@types/**", f"{services}/@bridge/**"]
    if layout is KeyLayout.ZENOH_BRIDGE_ROS1:
        observed.append(discovery_pattern())
        outgoing.append(discovery_pattern())
    inbound_keys = []
    for topic, type_name, md5 in inbound:
        inbound_keys += [topic_key(prefix, topic, layout, type_name, md5), publish_key(services, topic)]
    operators = sorted(set(operators))
    subjects: list[dict[str, Any]] = [{"id": "anyone"}]
    senders = ["anyone"]
    if operators:
        if not credentials:
            raise InvalidInputError(
                f"operators {operators}: the Zenoh configuration checks no credential to tell them by; set "
                "transport.auth.usrpwd.dictionary_file and/or transport.link.tls.enable_mtls on a tls/ endpoint"
            )
        # One subject naming both: Zenoh matches a subject only when all its properties match (AND).
        operator: dict[str, Any] = {"id": "operators"}
        if Credential.PASSWORD in credentials:
            operator["usernames"] = operators
        if Credential.CERTIFICATE in credentials:
            operator["cert_common_names"] = operators
        subjects.append(operator)
        senders = ["operators"]
    rules: list[dict[str, Any]] = [
        {"id": "bridge_out", "messages": _ALL, "flows": ["egress"], "permission": "allow", "key_exprs": outgoing},
        {"id": "observe", "messages": _OBSERVE, "flows": ["ingress"], "permission": "allow", "key_exprs": observed},
    ]
    policies: list[dict[str, Any]] = [{"rules": ["bridge_out", "observe"], "subjects": ["anyone"]}]
    if inbound_keys:
        rules.append(
            {"id": "inbound", "messages": ["put", "query"], "flows": ["ingress"], "permission": "allow",
             "key_exprs": inbound_keys}
        )  # fmt: skip
        policies.append({"rules": ["inbound"], "subjects": senders})
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies}
