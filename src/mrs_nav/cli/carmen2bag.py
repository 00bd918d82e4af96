"""``mrs-nav carmen2bag``: convert a CARMEN log to a ROS bag."""

from __future__ import annotations

import argparse
from typing import Any

from mrs_nav.cli.common import fail


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "carmen2bag", help="convert a CARMEN log to a ROS bag (not available yet)"
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    return fail("'mrs-nav carmen2bag' is not available in this version yet")
