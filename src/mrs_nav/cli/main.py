"""Entry point of ``mrs-nav``: one subcommand per module in :mod:`mrs_nav.cli`.

Each subcommand module exposes ``register(subparsers)``, which adds its parser and sets ``handler`` to a
typed function returning the exit code. Domain errors (:class:`MrsNavError`), usage errors and files that
cannot be written become one ``ERROR:`` line and exit 1; exit 2 means only "ran but did not reach the goal";
anything else is a bug and keeps its traceback. Ctrl-C, SIGTERM and SIGHUP unwind alike (exit 130), so temporary folders
are removed and partial outputs closed when the command is killed (SIGKILL cannot be caught).

Only the module of the command being run is imported, so that ``mrs-nav monitor`` works in a monitor-only
install (``pip install "mrs_nav[monitor]"``: no ROS, ODE, scipy or yaml); there the other commands are listed
as unavailable and say which module they miss.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
from collections.abc import Sequence
from types import FrameType

from mrs_nav import __version__
from mrs_nav.atomic_write import WRITE_ERRNOS
from mrs_nav.cli.common import fail
from mrs_nav.errors import MrsNavError
from mrs_nav.options import Parser

_NAMED_FILE_ERRORS = (PermissionError, FileNotFoundError, IsADirectoryError, NotADirectoryError, FileExistsError)
SUBCOMMANDS = ("demo", "figures", "plan", "replay", "carmen2bag", "bench", "monitor", "router")


def build_parser(commands: Sequence[str] = SUBCOMMANDS) -> argparse.ArgumentParser:
    parser = Parser(
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


class Interrupted(KeyboardInterrupt):
    """Ctrl-C, SIGTERM or SIGHUP, caught by :func:`main` and reported as exit 130.

    A subclass rather than ``KeyboardInterrupt`` itself: CPython 3.11 remembers a plain ``KeyboardInterrupt``
    that passed through ``exec`` of a string (every dataclass and namedtuple is built that way, so a signal
    during a lazy import does it) and then kills itself with SIGINT at exit even though the exception was
    caught, turning our 130 into -2. It compares the exception's exact type, so a subclass is never remembered.
    """


def _interrupt(signum: int, _frame: FrameType | None) -> None:
    raise Interrupted(signal.Signals(signum).name)


def main(argv: Sequence[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser((command,) if command in SUBCOMMANDS else SUBCOMMANDS)
    try:
        args = parser.parse_args(argv)
    except MrsNavError as err:
        return fail(str(err))
    if args.command is None:
        parser.print_help()
        return 1
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, _interrupt)
    try:
        code: int = args.handler(args)
    except MrsNavError as err:
        return fail(str(err))
    except KeyboardInterrupt as err:
        return fail(f"interrupted ({err})" if err.args else "interrupted", 130)
    except BrokenPipeError:
        # The reader went away (`mrs-nav plan --json | head`): nothing is wrong with the command. Point stdout at
        # /dev/null so that Python's own flush at exit does not raise again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as err:
        # A file the user named cannot be opened or written, or a disk that fills or a folder that turns
        # read-only under a writer that did not name its file: the environment's fault, not a bug.
        named = isinstance(err, _NAMED_FILE_ERRORS) and err.filename is not None
        if not named and err.errno not in WRITE_ERRNOS:
            raise
        return fail(f"{err.filename}: {err.strerror}" if err.filename else f"cannot write: {err.strerror or err}")
    return code


if __name__ == "__main__":
    sys.exit(main())
