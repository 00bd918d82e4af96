"""``mrs-nav demo``: headless whole stack: simulate, map, navigate to goals, record a bag."""

from __future__ import annotations

import argparse
from typing import Any

from mrs_nav.cli.common import fail


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "demo", help="headless whole stack: simulate, map, navigate to goals, record a bag (not available yet)"
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    return fail("'mrs-nav demo' is not available in this version yet")
