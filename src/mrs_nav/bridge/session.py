"""Opening Zenoh sessions: the bridge's settings (multicast scouting off, loopback by default) laid over an
optional Zenoh JSON5 file that brings TLS, authentication and any other Zenoh setting, passed through."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import zenoh

from mrs_nav.bridge.config import zenoh_settings
from mrs_nav.errors import InvalidInputError

_SECURE = ("tls/", "quic/")


def zenoh_config(settings: Mapping[str, Any], config_file: str = "") -> zenoh.Config:
    """A Zenoh configuration: ``config_file`` (JSON5, Zenoh's own format) if given, then ``settings``
    (path -> JSON value) on top. Raise InvalidInputError naming the file or the setting when it cannot work,
    in particular a TLS endpoint without the certificates Zenoh would otherwise ask for every few seconds."""
    if config_file:
        path = Path(config_file)
        if not path.is_file():
            raise InvalidInputError(f"zenoh_config {config_file}: no such file")
        try:
            config = zenoh.Config.from_file(str(path))
        except zenoh.ZError as err:
            raise InvalidInputError(f"zenoh_config {config_file}: {err}") from None
    else:
        config = zenoh.Config()
    for key, value in settings.items():
        try:
            config.insert_json5(key, json.dumps(value))
        except zenoh.ZError as err:
            raise InvalidInputError(f"zenoh setting {key}: {err}") from None
    _check_tls(config, config_file)
    return config


def _check_tls(config: zenoh.Config, config_file: str) -> None:
    def endpoints(kind: str) -> list[str]:
        value = json.loads(config.get_json(f"{kind}/endpoints"))
        # A router or peer may give endpoints per mode: {"router": [...], "peer": [...]}.
        items = value.values() if isinstance(value, dict) else [value]
        return [e for group in items for e in (group if isinstance(group, list) else [group])]

    tls = json.loads(config.get_json("transport/link/tls"))
    source = f"zenoh_config {config_file}" if config_file else "no zenoh_config file"
    for endpoint in endpoints("listen"):
        missing = [k for k in ("listen_certificate", "listen_private_key") if not tls.get(k)]
        if endpoint.startswith(_SECURE) and missing:
            raise InvalidInputError(
                f"listen endpoint {endpoint} needs transport.link.tls.{' and '.join(missing)} ({source} sets none)"
            )
    for endpoint in endpoints("connect"):
        if endpoint.startswith(_SECURE) and not tls.get("root_ca_certificate"):
            raise InvalidInputError(
                f"connect endpoint {endpoint} needs transport.link.tls.root_ca_certificate ({source} sets none)"
            )
    for key in ("root_ca_certificate", "listen_certificate", "listen_private_key", "connect_certificate",
                "connect_private_key"):  # fmt: skip
        if tls.get(key) and not Path(tls[key]).is_file():
            raise InvalidInputError(f"transport.link.tls.{key} {tls[key]}: no such file ({source})")


def refuse_lowlatency(config: zenoh.Config, config_file: str = "") -> None:
    """Raise InvalidInputError if ``config`` turns on Zenoh's ``transport/unicast/lowlatency``, for the bridge.

    That transport writes each message as one frame and has no fragmentation: a message above the negotiated
    batch size (at most 64 KiB; a 384 x 384 map is 147 KB) makes the receiver drop the link ("Batch len is
    invalid"), so every subscriber loses what was in flight while its session reconnects. (A remote user's
    session asking for it alone is harmless: both ends must, or the link stays on the default transport.)
    """
    if json.loads(config.get_json("transport/unicast/lowlatency")):
        source = f"zenoh_config {config_file}" if config_file else "the Zenoh settings"
        raise InvalidInputError(
            f"{source}: transport.unicast.lowlatency cannot carry messages above 64 KiB (a map) without dropping "
            "the link; the bridge needs the default transport"
        )


def open_session(settings: Mapping[str, Any], config_file: str = "") -> zenoh.Session:
    """Open a session with ``settings`` over ``config_file`` (see :func:`zenoh_config`)."""
    config = zenoh_config(settings, config_file)
    try:
        return zenoh.open(config)
    except zenoh.ZError as err:
        raise InvalidInputError(f"cannot open a Zenoh session ({settings.get('mode')}): {err}") from None


def open_client_session(connect: Iterable[str], mode: str = "peer", config_file: str = "") -> zenoh.Session:
    """A session that only connects out (a monitor or a test peer), listening on nothing."""
    return open_session(zenoh_settings(mode, (), connect), config_file)
