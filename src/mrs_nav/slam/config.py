"""SLAM parameters, named and meant as in ROS gmapping (``slam_gmapping``) where the meaning is the same.

Units: metres, radians, seconds. A value that makes no sense raises :class:`InvalidInputError` naming it.
"""

from __future__ import annotations

import builtins
import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from mrs_nav.errors import InvalidInputError


@dataclass(frozen=True)
class SlamConfig:
    """Parameters of :class:`mrs_nav.slam.Slam`.

    Attributes (gmapping's names):
        delta: map resolution, metres per cell.
        maxUrange: usable laser range, metres. Longer readings only clear free space up to this distance;
            their end points are not marked occupied.
        maxRange: readings at or beyond this (or the scan's own ``range_max``) are "no return" and ignored,
            as in gmapping. ``0`` means use the scan's ``range_max``.
        linearUpdate, angularUpdate: process a scan once the robot has travelled this far (m) or turned this
            much (rad) since the last processed scan.
        temporalUpdate: also process a scan when this much time (s) has passed since the last one; a value
            ``<= 0`` turns the time gate off (as in gmapping).
        map_update_interval: seconds between map publications (used by the node, not the core).
        xmin, ymin, xmax, ymax: initial map extent in the map frame, metres.
        map_grows: grow the map when scans reach outside the extent (gmapping does); if false, the extent is
            fixed and beams are clipped to it.
        lfree, loccupied, lmax: log-odds added per free / occupied observation and its clamp.
        search_linear, search_angular: half-widths of the scan matcher's correlative search window around
            the odometry prediction (m, rad).
        srr, srt, str, stt: odometry error model of the matcher's prior (gmapping's names): the prediction's
            position spread is ``srr * travelled + srt * turned`` (m) and its heading spread
            ``str * travelled + stt * turned`` (rad), plus a floor of 1 cm and 0.5 degree.
        sigma: standard deviation of the likelihood field (m) used to score a scan against the map.
    """

    delta: float = 0.05
    maxUrange: float = 80.0  # noqa: N815 - gmapping's parameter name
    maxRange: float = 0.0  # noqa: N815
    linearUpdate: float = 0.2  # noqa: N815
    angularUpdate: float = 0.2  # noqa: N815
    temporalUpdate: float = -1.0  # noqa: N815
    map_update_interval: float = 2.0
    xmin: float = -10.0
    ymin: float = -10.0
    xmax: float = 10.0
    ymax: float = 10.0
    map_grows: bool = True
    lfree: float = 0.4
    loccupied: float = 0.9
    lmax: float = 8.0
    search_linear: float = 0.3
    search_angular: float = 0.5
    srr: float = 0.1
    srt: float = 0.2
    str: float = 0.1  # gmapping's name; annotations in this class say builtins.str for the type
    stt: float = 0.2
    sigma: float = 0.05

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, float) and not math.isfinite(value):
                raise InvalidInputError(f"SLAM parameter {field.name} must be finite, got {value}")
        positive = ("delta", "maxUrange", "lfree", "loccupied", "lmax", "sigma", "map_update_interval")
        for name in positive:
            if getattr(self, name) <= 0.0:
                raise InvalidInputError(f"SLAM parameter {name} must be > 0, got {getattr(self, name)}")
        non_negative: tuple[builtins.str, ...] = ("maxRange", "linearUpdate", "angularUpdate", "search_linear")
        non_negative += ("search_angular", "srr", "srt", "str", "stt")
        for name in non_negative:
            if getattr(self, name) < 0.0:
                raise InvalidInputError(f"SLAM parameter {name} must be >= 0, got {getattr(self, name)}")
        if self.delta > 1.0:
            raise InvalidInputError(f"SLAM parameter delta (map resolution) must be <= 1 m, got {self.delta}")
        if self.xmax - self.xmin < self.delta or self.ymax - self.ymin < self.delta:
            raise InvalidInputError(f"SLAM map extent is empty: x {self.xmin}..{self.xmax}, y {self.ymin}..{self.ymax}")

    @classmethod
    def from_assignments(cls, items: list[builtins.str]) -> SlamConfig:
        """``["name=value", ...]`` (``mrs-nav replay --param``) into a validated config."""
        values: dict[builtins.str, builtins.str] = {}
        for item in items:
            name, sep, value = item.partition("=")
            if not sep or not name.strip():
                raise InvalidInputError(f"--param: expected NAME=VALUE, got {item!r}")
            values[name.strip()] = value.strip()
        return cls.from_mapping(values)

    @classmethod
    def from_mapping(cls, values: dict[builtins.str, Any]) -> SlamConfig:
        """Build a config from ``{name: value}`` (e.g. ROS params), rejecting unknown names and bad types."""
        known = {f.name: f for f in dataclasses.fields(cls)}
        kwargs: dict[builtins.str, Any] = {}
        for name, value in values.items():
            if name not in known:
                raise InvalidInputError(f"unknown SLAM parameter {name!r}; known: {', '.join(sorted(known))}")
            default = getattr(cls, name)
            try:
                if isinstance(default, bool):
                    kwargs[name] = _to_bool(value)
                else:
                    kwargs[name] = float(value)
            except (TypeError, ValueError):
                raise InvalidInputError(f"SLAM parameter {name}: expected a number, got {value!r}") from None
        return cls(**kwargs)


def _to_bool(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in ("1", "true", "yes", "on"):
        return True
    if text in ("0", "false", "no", "off"):
        return False
    raise ValueError(value)
