"""Argument parsing helpers shared by the ``mrs-nav`` subcommands."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from typing import Any

from mrs_nav.errors import InvalidInputError

Handler = Callable[[argparse.Namespace], int]


def parse_floats(text: str, count: int | tuple[int, ...], what: str) -> tuple[float, ...]:
    """Parse ``"a,b,c"`` into ``count`` finite floats; ``what`` names the argument in errors."""
    counts = (count,) if isinstance(count, int) else count
    try:
        values = tuple(float(p) for p in text.split(","))
    except ValueError:
        raise InvalidInputError(f"{what}: expected comma-separated numbers, got {text!r}") from None
    if len(values) not in counts:
        wanted = " or ".join(str(c) for c in counts)
        raise InvalidInputError(f"{what}: expected {wanted} numbers, got {len(values)} in {text!r}")
    if not all(math.isfinite(v) for v in values):
        raise InvalidInputError(f"{what}: numbers must be finite, got {text!r}")
    return values


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
