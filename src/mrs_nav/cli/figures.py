"""``mrs-nav figures``: the assignment's figures as PNGs."""

from __future__ import annotations

import argparse
from typing import Any

from mrs_nav.cli.common import fail


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "figures", help="the assignment's figures as PNGs (not available yet)"
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    return fail("'mrs-nav figures' is not available in this version yet")
