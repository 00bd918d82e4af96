"""Argument parsing helpers shared by the ``mrs-nav`` subcommands."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from typing import Any

Handler = Callable[[argparse.Namespace], int]


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
