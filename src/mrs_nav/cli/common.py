"""Argument parsing helpers shared by the ``mrs-nav`` subcommands."""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mrs_nav.errors import InvalidInputError

Handler = Callable[[argparse.Namespace], int]


def check_writable(path: Path, what: str, *, folder: bool = False) -> Path:
    """``path`` when an output can be written there (a folder, created now, or a file in one); else an error.

    Checked before the work so that an unwritable ``--out`` or ``--png`` fails at once, not after a long run.
    A scratch file is really created (and removed): permission bits alone say nothing for root or odd file
    systems such as /proc.
    """
    target = path if folder else path.parent
    if not folder and path.is_dir():
        raise InvalidInputError(f"{what}: {path} is a folder, expected a file name")
    if not folder and (path.is_fifo() or path.is_socket()):  # writing would wait for a reader, maybe for ever
        raise InvalidInputError(f"{what}: {path} is a FIFO or a socket, expected a file name")
    try:
        target.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=target):
            pass
    except (FileExistsError, NotADirectoryError):
        raise InvalidInputError(f"{what}: cannot write into {target}: a file is in the way of that folder") from None
    except OSError as err:
        raise InvalidInputError(f"{what}: cannot write into {target}: {err.strerror}") from None
    return path


def print_json(payload: dict[str, Any]) -> None:
    """Print one JSON object on stdout (NaN and inf become null, as strict JSON readers expect)."""

    def clean(value: Any) -> Any:
        if isinstance(value, float) and not math.isfinite(value):
            return None
        if isinstance(value, dict):
            return {k: clean(v) for k, v in value.items()}
        if isinstance(value, list | tuple):
            return [clean(v) for v in value]
        return value

    json.dump(clean(payload), sys.stdout)
    sys.stdout.write("\n")


def fail(message: str, code: int = 1) -> int:
    """Print a one-line error on stderr and return ``code``."""
    print(f"ERROR: {message}", file=sys.stderr)
    return code
