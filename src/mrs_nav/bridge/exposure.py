"""What a Zenoh configuration exposes: which client credentials it checks, and which listen endpoints anyone on a
network could reach without them.

A listen endpoint is closed when only this machine can reach it (a loopback address, ``localhost`` or a Unix
socket) or when it is TLS (``tls/``, ``quic/``) and the client must authenticate (a certificate of the CA,
``enable_mtls``, or a password of ``transport/auth/usrpwd``). Anything else (``tcp/0.0.0.0``, ``tcp/[::]``,
``ws/``, ``udp/`` or TLS that any client may open) lets whoever reaches the address read the robot's topics and
put on its keys; the bridge and ``mrs-nav router`` refuse such an endpoint unless told ``insecure``.
"""

from __future__ import annotations

import ipaddress
import json
from enum import Enum
from typing import TYPE_CHECKING, Any

from mrs_nav.errors import InvalidInputError

if TYPE_CHECKING:  # only configurations are passed in: the configuration module loads no Zenoh through this one
    import zenoh

TLS_PROTOCOLS = ("tls/", "quic/")  # endpoint prefixes of the encrypted links
_LOCAL_NAMES = ("localhost",)


class Credential(Enum):
    """A client credential a Zenoh configuration checks on its listen endpoints."""

    CERTIFICATE = "certificate"  # mutual TLS: the client's certificate, named by its common name
    PASSWORD = "password"  # transport/auth/usrpwd: a username and its password


def _setting(config: zenoh.Config, path: str) -> Any:
    return json.loads(config.get_json(path))


def credentials(config: zenoh.Config) -> frozenset[Credential]:
    """The credentials clients must present to ``config``'s listen endpoints."""
    found = set()
    tls_listeners = [e for e in endpoints(config) if e.startswith(TLS_PROTOCOLS)]
    if _setting(config, "transport/link/tls/enable_mtls") and tls_listeners:
        found.add(Credential.CERTIFICATE)
    if _setting(config, "transport/auth/usrpwd/dictionary_file"):
        found.add(Credential.PASSWORD)
    return frozenset(found)


def endpoints(config: zenoh.Config, kind: str = "listen") -> list[str]:
    """``config``'s ``kind`` (listen, connect) endpoints (a router or peer may give them per mode: every mode's are
    counted)."""
    value = _setting(config, f"{kind}/endpoints")
    items = value.values() if isinstance(value, dict) else [value]
    return [e for group in items for e in (group if isinstance(group, list) else [group])]


def _loopback(endpoint: str) -> bool:
    protocol, _, address = endpoint.partition("/")
    if protocol == "unixsock-stream":
        return True
    host = address.split("?", 1)[0].split("#", 1)[0].rpartition(":")[0].strip("[]")
    if host.lower() in _LOCAL_NAMES:
        return True
    try:
        ip = ipaddress.ip_address(host)
    except ValueError:  # a host name: it may resolve to anything, now or later
        return False
    mapped = ip.ipv4_mapped if isinstance(ip, ipaddress.IPv6Address) else None  # [::ffff:127.0.0.1]
    return ip.is_loopback or (mapped is not None and mapped.is_loopback)


def open_endpoints(config: zenoh.Config) -> list[str]:
    """One line per listen endpoint of ``config`` that a network can reach without a client credential."""
    authenticated = bool(credentials(config))
    found = []
    for endpoint in endpoints(config):
        if _loopback(endpoint):
            continue
        if not endpoint.startswith(TLS_PROTOCOLS):
            found.append(f"{endpoint} is reachable from the network without encryption or client authentication")
        elif not authenticated:
            found.append(
                f"{endpoint} is TLS without client authentication (set transport.link.tls.enable_mtls or "
                "transport.auth.usrpwd in the Zenoh file)"
            )
    return found


def refuse_open_endpoints(config: zenoh.Config, insecure: bool, flag: str) -> list[str]:
    """Raise InvalidInputError naming the first open endpoint of ``config`` unless ``insecure``; return the
    warnings to give at every start when ``insecure`` lets them through. ``flag`` names the option that allows
    it (``insecure: true``, ``--insecure``)."""
    found = open_endpoints(config)
    if found and not insecure:
        raise InvalidInputError(
            f"listen endpoint {found[0]}; listen on tls/ with client certificates or passwords, on 127.0.0.1, "
            f"or give {flag} to accept that anyone who reaches it may watch the robot and send what its inbound "
            "allow-list accepts"
        )
    why = "anyone who reaches it may watch the robot and send what its inbound allow-list accepts"
    return [f"INSECURE ({flag}): {line}: {why}" for line in found]
