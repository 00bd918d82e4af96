"""``mrs-nav monitor``: watch a robot through the Zenoh bridge."""

from __future__ import annotations

import argparse
from typing import Any

from mrs_nav.cli.common import fail


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "monitor", help="watch a robot through the Zenoh bridge (not available yet)"
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    return fail("'mrs-nav monitor' is not available in this version yet")
