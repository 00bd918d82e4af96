"""Entry point of ``mrs-nav``: one subcommand per module in :mod:`mrs_nav.cli`.

Each subcommand module exposes ``register(subparsers)``, which adds its parser and sets ``handler`` to a
typed function returning the exit code. Domain errors (:class:`MrsNavError`) become one ``ERROR:`` line and
exit 1; anything else is a bug and keeps its traceback.

Only the module of the command being run is imported, so that ``mrs-nav monitor`` works in a monitor-only
install (``pip install "mrs_nav[monitor]"``: no ROS, ODE, scipy or yaml); there the other commands are listed
as unavailable and say which module they miss.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

from mrs_nav import __version__
from mrs_nav.cli.common import fail
from mrs_nav.errors import MrsNavError

SUBCOMMANDS = ("demo", "figures", "plan", "replay", "carmen2bag", "bench", "monitor")


def build_parser(commands: Sequence[str] = SUBCOMMANDS) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mrs-nav",
        description="mrs_nav offline tools: simulate, plan, replay bags, benchmark and monitor; no ROS master needed.",
    )
    parser.add_argument("--version", action="version", version=f"mrs-nav {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in commands:
        try:
            module = importlib.import_module(f"mrs_nav.cli.{name}")
        except ModuleNotFoundError as err:
            missing = f"mrs-nav {name} needs the Python module {err.name!r}, which is not installed"
            sub = subparsers.add_parser(name, help=f"unavailable: needs {err.name}", add_help=False)
            sub.add_argument("ignored", nargs=argparse.REMAINDER)
            sub.set_defaults(handler=lambda _args, why=missing: fail(why))
            continue
        module.register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser((command,) if command in SUBCOMMANDS else SUBCOMMANDS)
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 1
    try:
        code: int = args.handler(args)
    except MrsNavError as err:
        return fail(str(err))
    except KeyboardInterrupt:
        return fail("interrupted", 130)
    except BrokenPipeError:
        # The reader went away (`mrs-nav plan --json | head`): nothing is wrong with the command. Point stdout at
        # /dev/null so that Python's own flush at exit does not raise again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    return code


if __name__ == "__main__":
    sys.exit(main())
