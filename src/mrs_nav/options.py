"""Option values given as text (command line, launch arguments) parsed into checked numbers.

Every parser raises :class:`InvalidInputError` naming the option, so each front end turns a bad value into one
``ERROR:`` line.
"""

from __future__ import annotations

import math

from mrs_nav.errors import InvalidInputError


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
