"""``mrs-nav router``: a Zenoh router that joins a fleet's bridges and monitors (no ROS, no zenohd needed).

Each robot's bridge connects to it as a client (``mode: client``, ``connect: [tcp/ROUTER:7447]``) and so does
``mrs-nav monitor --fleet``; the router forwards between them. It is the Zenoh library's own router mode, with
multicast scouting off like every session mrs_nav opens; TLS, users and the rest come from ``--zenoh-config``.
An endpoint a network reaches without TLS and client authentication is refused unless ``--insecure``.
"""

from __future__ import annotations

import argparse
import sys
import threading
from typing import Any

from mrs_nav.errors import InvalidInputError


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "router",
        help="run a Zenoh router for a fleet of bridges (no ROS needed)",
        description="Listen on the given Zenoh endpoints and route between the robots' bridges and the monitors "
        "connected to them, until stopped (Ctrl-C or SIGTERM).",
    )
    parser.add_argument(
        "--listen",
        action="append",
        default=None,
        metavar="ENDPOINT",
        help="Zenoh endpoint to listen on (repeatable; default tcp/127.0.0.1:7447; for a network "
        "tls/0.0.0.0:7447 with client certificates or passwords in --zenoh-config)",
    )
    parser.add_argument(
        "--insecure",
        action="store_true",
        help="listen where a network reaches the router without TLS and client authentication (warned)",
    )
    parser.add_argument(
        "--zenoh-config",
        default="",
        metavar="JSON5",
        help=(
            "Zenoh configuration file (TLS certificates, users, ...); --listen and router mode are laid over it "
            "(they replace its endpoints and mode)"
        ),
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    # Imported here so that other commands do not load zenoh.
    from mrs_nav.bridge.config import DEFAULT_LISTEN, zenoh_settings  # noqa: PLC0415
    from mrs_nav.bridge.exposure import refuse_open_endpoints  # noqa: PLC0415
    from mrs_nav.bridge.session import open_session, zenoh_config  # noqa: PLC0415

    listen = [e.strip() for item in args.listen or DEFAULT_LISTEN for e in item.split(",") if e.strip()]
    if not listen:
        raise InvalidInputError("--listen: give at least one endpoint, e.g. tcp/127.0.0.1:7447")
    settings = zenoh_settings("router", listen, [])
    for warning in refuse_open_endpoints(zenoh_config(settings, args.zenoh_config), args.insecure, "--insecure"):
        print(f"WARNING: {warning}", file=sys.stderr, flush=True)
    session = open_session(settings, args.zenoh_config)
    print(f"zenoh router listening on {', '.join(listen)}", flush=True)
    try:
        threading.Event().wait()
    except KeyboardInterrupt:
        print("zenoh router stopped", file=sys.stderr)
    finally:
        session.close()  # type: ignore[no-untyped-call]
    return 0
