"""Opening Zenoh sessions: the bridge's settings (multicast scouting off, loopback by default) laid over an
optional Zenoh JSON5 file that brings TLS, authentication and any other Zenoh setting, passed through."""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import zenoh

from mrs_nav.bridge.config import MAX_FILE_BYTES, BridgeConfig, zenoh_settings
from mrs_nav.bridge.exposure import TLS_PROTOCOLS, credentials, endpoints, refuse_open_endpoints
from mrs_nav.errors import InvalidInputError
from mrs_nav.textfiles import read_regular, read_text

_TLS_FILES = ("root_ca_certificate", "listen_certificate", "listen_private_key", "connect_certificate",
              "connect_private_key")  # fmt: skip
# What zenoh-python's errors carry besides the message: the Rust source line that raised it, and the parsers'
# debug renderings of where in the file the problem is.
_RUST_SOURCE = re.compile(r"\s+at \S+\.rs:\d+\.?$")
_SERDE_JSON5 = re.compile(
    r'Message \{ msg: "((?:[^"\\]|\\.)*)"(?:, location: Some\(Location \{ line: (\d+), column: (\d+))?'
)
_SERDE_YAML = re.compile(r'Error\("((?:[^"\\]|\\.)*)", line: (\d+), column: (\d+)\)')
_PEST = re.compile(r"^\s*--> (\d+):(\d+)\n.*\n\s*= (.*)$", re.DOTALL)
_SINGLE = re.compile(r"Single\(([^()]*)\)")


def zenoh_message(err: zenoh.ZError) -> str:
    """A Zenoh error as one readable line: the parser's message with its line and column, without the Rust
    source location and debug wrappers zenoh-python passes through."""
    text = _RUST_SOURCE.sub("", str(err))
    pest = _PEST.match(text)
    serde = _SERDE_JSON5.search(text) or _SERDE_YAML.search(text)
    if pest:
        text = f"line {pest[1]}, column {pest[2]}: {pest[3]}"
    elif serde:
        message = re.sub(r"\\(.)", r"\1", serde[1])
        text = f"line {serde[2]}, column {serde[3]}: {message}" if serde[2] else message
    return " ".join(_SINGLE.sub(r"\1", text).split())


def zenoh_config(settings: Mapping[str, Any], config_file: str = "") -> zenoh.Config:
    """A Zenoh configuration: ``config_file`` (JSON5, Zenoh's own format) if given, then ``settings``
    (path -> JSON value) on top. Raise InvalidInputError naming the file or the setting when it cannot work,
    in particular a TLS endpoint without the certificates Zenoh would otherwise ask for every few seconds."""
    if config_file:
        # Read here first: a FIFO or a device named as the file would block or fill memory inside Zenoh.
        read_text(Path(config_file), MAX_FILE_BYTES, "zenoh_config")
        try:
            config = zenoh.Config.from_file(config_file)
        except zenoh.ZError as err:
            raise InvalidInputError(f"zenoh_config {config_file}: {zenoh_message(err)}") from None
    else:
        config = zenoh.Config()
    for key, value in settings.items():
        try:
            config.insert_json5(key, json.dumps(value))
        except zenoh.ZError as err:
            raise InvalidInputError(f"zenoh setting {key}: {zenoh_message(err)}") from None
    _check_security(config, config_file)
    return config


def _check_security(config: zenoh.Config, config_file: str) -> None:
    """TLS endpoints need their certificates; the certificate, key and password files must be readable."""

    tls = json.loads(config.get_json("transport/link/tls"))
    source = f"zenoh_config {config_file}" if config_file else "no zenoh_config file"
    for endpoint in endpoints(config, "listen"):
        missing = [k for k in ("listen_certificate", "listen_private_key") if not tls.get(k)]
        if endpoint.startswith(TLS_PROTOCOLS) and missing:
            raise InvalidInputError(
                f"listen endpoint {endpoint} needs transport.link.tls.{' and '.join(missing)} ({source} sets none)"
            )
    for endpoint in endpoints(config, "connect"):
        if endpoint.startswith(TLS_PROTOCOLS) and not tls.get("root_ca_certificate"):
            raise InvalidInputError(
                f"connect endpoint {endpoint} needs transport.link.tls.root_ca_certificate ({source} sets none)"
            )
    for key in _TLS_FILES:
        if tls.get(key):
            # Zenoh reads these when a link opens and, failing, only retries: the peer would never learn why.
            pem = read_regular(Path(tls[key]), MAX_FILE_BYTES, f"transport.link.tls.{key} ({source})")
            if b"-----BEGIN " not in pem:
                raise InvalidInputError(
                    f"{tls[key]}: transport.link.tls.{key} is not PEM, no -----BEGIN line ({source})"
                )
    dictionary = json.loads(config.get_json("transport/auth/usrpwd/dictionary_file"))
    if dictionary:
        read_text(Path(dictionary), MAX_FILE_BYTES, f"transport.auth.usrpwd.dictionary_file ({source})")


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


def bridge_settings(config: BridgeConfig, inbound_md5: Mapping[str, str]) -> tuple[dict[str, Any], list[str]]:
    """The bridge's Zenoh settings, its access control asking operators for every credential its Zenoh file
    checks, and the warnings to give at every start for listen endpoints a network reaches without TLS and client
    authentication; raise InvalidInputError for such an endpoint unless ``config.insecure``."""
    plain = zenoh_config(
        zenoh_settings(config.mode, config.listen, config.connect, config.retry_period), config.zenoh_config
    )
    warnings = refuse_open_endpoints(plain, config.insecure, "insecure: true")
    return config.zenoh_settings(inbound_md5, credentials(plain)), warnings


def open_session(settings: Mapping[str, Any], config_file: str = "") -> zenoh.Session:
    """Open a session with ``settings`` over ``config_file`` (see :func:`zenoh_config`)."""
    config = zenoh_config(settings, config_file)
    try:
        return zenoh.open(config)
    except zenoh.ZError as err:
        raise InvalidInputError(f"cannot open a Zenoh session ({settings.get('mode')}): {zenoh_message(err)}") from None


def open_client_session(connect: Iterable[str], mode: str = "peer", config_file: str = "") -> zenoh.Session:
    """A session that only connects out (a monitor or a test peer), listening on nothing."""
    return open_session(zenoh_settings(mode, (), connect), config_file)
