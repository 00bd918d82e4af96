"""Helpers shared by the property-based fuzz tests."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def attempt(load: Callable[[], T], error: type[Exception]) -> T | str:
    """``load()``'s result, or the message of the domain ``error`` it raised; any other exception propagates."""
    try:
        return load()
    except error as err:
        return str(err)
