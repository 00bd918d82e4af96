"""Option values given as text (command line, launch arguments) parsed into checked numbers.

Every parser raises :class:`InvalidInputError` naming the option, so each front end turns a bad value into one
``ERROR:`` line.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable
from typing import Any, NoReturn

from mrs_nav.errors import InvalidInputError
from mrs_nav.limits import MAX_BENCH_S, MAX_BUDGET_S, MAX_ITERATIONS, MAX_ROBOT_RADIUS_M, MAX_RUNS, MAX_SEED, MAX_SIZE_M

_INTEGER = re.compile(r"[+-]?\d+")
_MAX_DIGITS = 30


class Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors raise :class:`InvalidInputError`: one ``ERROR:`` line and exit 1.

    argparse's own exit status 2 would collide with the documented "ran but did not reach the goal". Subparsers
    made by ``add_subparsers`` are of the same class, so every subcommand behaves alike.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # Let "--start -1.5,-1.5,0" through as a value: argparse takes only plain numbers like "-1.5" for negative
        # values, and would read a comma-separated list starting with "-" as an unknown option.
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def error(self, message: str) -> NoReturn:
        raise InvalidInputError(f"{self.prog}: {message} (see {self.prog} --help)")


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


def integer_option(minimum: int, maximum: int) -> Callable[[str], int]:
    """An argparse ``type=`` that takes a base-10 integer in ``[minimum, maximum]``.

    argparse names the option in front of the message; past the stated maximum the option is refused, never
    clamped.
    """

    def parse(text: str) -> int:
        text = text.strip()
        if not _INTEGER.fullmatch(text):
            raise argparse.ArgumentTypeError(f"expected an integer, got {text[:40]!r}")
        # int() refuses thousands of digits, and a count with that many is out of range anyway.
        if len(text) > _MAX_DIGITS or not minimum <= int(text) <= maximum:
            shown = text if len(text) <= _MAX_DIGITS else f"{text[:20]}... ({len(text)} digits)"
            raise argparse.ArgumentTypeError(f"must be an integer in [{minimum}, {maximum}], got {shown}")
        return int(text)

    parse.__name__ = "integer"
    return parse


def number_option(minimum: float, maximum: float) -> Callable[[str], float]:
    """An argparse ``type=`` that takes a finite number in ``[minimum, maximum]``."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text[:40]!r}") from None
        if not (math.isfinite(value) and minimum <= value <= maximum):
            raise argparse.ArgumentTypeError(f"must be a finite number in [{minimum:g}, {maximum:g}], got {text}")
        return value

    parse.__name__ = "number"
    return parse


#: ``--seed``: numpy's and ODE's seeds are unsigned 32-bit.
seed_option = integer_option(0, MAX_SEED)
#: Iteration and step counts.
count_option = integer_option(1, MAX_ITERATIONS)
#: Planner time budgets and timeouts, seconds.
budget_option = number_option(1e-3, MAX_BUDGET_S)
#: Obstacle inflation, metres.
radius_option = number_option(0.0, MAX_ROBOT_RADIUS_M)
#: Benchmark seeds, runs and workers: at least one, or none where ``0`` turns a part off.
runs_option = integer_option(1, MAX_RUNS)
optional_runs_option = integer_option(0, MAX_RUNS)
#: Benchmark durations, seconds.
duration_option = number_option(1e-3, MAX_BENCH_S)
#: Lengths, metres.
length_option = number_option(0.0, MAX_SIZE_M)
