"""Opening Zenoh sessions from the bridge's settings (multicast scouting off, loopback by default)."""

from __future__ import annotations

import json
from collections.abc import Iterable
from typing import Any

import zenoh

from mrs_nav.bridge.config import zenoh_settings
from mrs_nav.errors import InvalidInputError


def open_session(settings: dict[str, Any]) -> zenoh.Session:
    """Open a session with the given configuration entries (see :func:`mrs_nav.bridge.config.zenoh_settings`)."""
    config = zenoh.Config()
    for path, value in settings.items():
        config.insert_json5(path, json.dumps(value))
    try:
        return zenoh.open(config)
    except zenoh.ZError as err:
        raise InvalidInputError(f"cannot open a Zenoh session ({settings.get('mode')}): {err}") from None


def open_client_session(connect: Iterable[str], mode: str = "peer") -> zenoh.Session:
    """A session that only connects out (a monitor or a test peer), listening on nothing."""
    return open_session(zenoh_settings(mode, (), connect))
