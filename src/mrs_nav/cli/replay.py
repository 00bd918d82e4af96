"""``mrs-nav replay``: run SLAM and/or planning over a bag offline."""

from __future__ import annotations

import argparse
from typing import Any

from mrs_nav.cli.common import fail


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "replay", help="run SLAM and/or planning over a bag offline (not available yet)"
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    return fail("'mrs-nav replay' is not available in this version yet")
