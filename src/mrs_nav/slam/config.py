"""SLAM parameters, named and meant as in ROS gmapping (``slam_gmapping``) where the meaning is the same.

Units: metres, radians, seconds. One set of defaults: ``config/slam.yaml`` (:mod:`mrs_nav.config_files`), which
the SLAM node reads for its private parameters' defaults and :class:`SlamConfig` for its field defaults, so the
node, ``mrs-nav replay`` and the benchmarks start from the same values. Range-dependent choices follow the
scan: the usable range is the scan's own ``range_max``, capped by ``maxUrange`` (0: no cap).

Every value is checked against the stated range in :data:`LIMITS` (a value outside raises
:class:`InvalidInputError` naming it), and the initial map extent against :data:`MAX_MAP_CELLS`, before
anything is allocated.
"""

from __future__ import annotations

import builtins
import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Any

from mrs_nav.config_files import node_default
from mrs_nav.errors import InvalidInputError

# Cells the occupancy grid may span at most, e.g. 1.4 km x 1.4 km at 20 cm or 350 m x 350 m at 5 cm (the MIT
# Infinite Corridor map spans 49 M, its 1941 scans all processed). The map grows only where scans reach; past this
# it refuses. Memory follows the cells scans reached (mrs_nav.slam.grid: 4 bytes a cell, 12 more near end points;
# the Freiburg campus map holds 15 M of the 32 M it spans), but the map saved and drawn is dense: 1 byte a cell,
# a few more while it is written.
MAX_MAP_CELLS = 50_000_000
MAX_COORDINATE_M = 100_000.0  # m: a map frame coordinate farther out than 100 km is an error, not a building

# (lowest, highest) accepted value of each numeric parameter, with its unit in the field documentation.
LIMITS: dict[builtins.str, tuple[float, float]] = {
    "delta": (0.01, 1.0),
    "maxUrange": (0.0, 1000.0),
    "maxRange": (0.0, 1000.0),
    "linearUpdate": (0.0, 100.0),
    "angularUpdate": (0.0, math.pi),
    "temporalUpdate": (-1.0, 3600.0),
    "map_update_interval": (0.01, 3600.0),
    "xmin": (-MAX_COORDINATE_M, MAX_COORDINATE_M),
    "ymin": (-MAX_COORDINATE_M, MAX_COORDINATE_M),
    "xmax": (-MAX_COORDINATE_M, MAX_COORDINATE_M),
    "ymax": (-MAX_COORDINATE_M, MAX_COORDINATE_M),
    "lfree": (0.01, 100.0),
    "loccupied": (0.01, 100.0),
    "lmax": (0.1, 100.0),
    "search_linear": (0.0, 2.0),
    "search_angular": (0.0, math.pi),
    "srr": (0.0, 10.0),
    "srt": (0.0, 10.0),
    "str": (0.0, 10.0),
    "stt": (0.0, 10.0),
    "sigma": (0.005, 1.0),
}


_default = functools.partial(node_default, "slam")


@dataclass(frozen=True)
class SlamConfig:
    """Parameters of :class:`mrs_nav.slam.Slam`; defaults from ``config/slam.yaml``.

    Attributes (gmapping's names):
        delta: map resolution, metres per cell.
        maxUrange: usable laser range, metres, at most the scan's ``range_max``; ``0`` means that
            ``range_max`` (the default 30 m serves a 3.5 m LDS at its range_max and caps an 80 m SICK).
            Longer readings only clear free space up to this distance; their end points are not marked
            occupied.
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
        loop_closure: match scans against older parts of the map and optimise a pose graph when a loop
            closes (:mod:`mrs_nav.slam.slam`).
    """

    delta: float = _default("delta")
    maxUrange: float = _default("maxUrange")  # noqa: N815 - gmapping's parameter name
    maxRange: float = _default("maxRange")  # noqa: N815
    linearUpdate: float = _default("linearUpdate")  # noqa: N815
    angularUpdate: float = _default("angularUpdate")  # noqa: N815
    temporalUpdate: float = _default("temporalUpdate")  # noqa: N815
    map_update_interval: float = _default("map_update_interval")
    xmin: float = _default("xmin")
    ymin: float = _default("ymin")
    xmax: float = _default("xmax")
    ymax: float = _default("ymax")
    map_grows: bool = _default("map_grows")
    lfree: float = _default("lfree")
    loccupied: float = _default("loccupied")
    lmax: float = _default("lmax")
    search_linear: float = _default("search_linear")
    search_angular: float = _default("search_angular")
    srr: float = _default("srr")
    srt: float = _default("srt")
    str: float = _default("str")  # gmapping's name; annotations in this class say builtins.str for the type
    stt: float = _default("stt")
    sigma: float = _default("sigma")
    loop_closure: bool = _default("loop_closure")

    def __post_init__(self) -> None:
        for name, (low, high) in LIMITS.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InvalidInputError(f"SLAM parameter {name} must be a number, got {value!r}")
            if not (math.isfinite(value) and low <= value <= high):
                raise InvalidInputError(f"SLAM parameter {name} must be in {low:g}..{high:g}, got {value}")
        for name in ("map_grows", "loop_closure"):
            if not isinstance(getattr(self, name), bool):
                raise InvalidInputError(f"SLAM parameter {name} must be true or false, got {getattr(self, name)!r}")
        if self.xmax - self.xmin < self.delta or self.ymax - self.ymin < self.delta:
            raise InvalidInputError(f"SLAM map extent is empty: x {self.xmin}..{self.xmax}, y {self.ymin}..{self.ymax}")
        cells = math.ceil((self.xmax - self.xmin) / self.delta + 1) * math.ceil(
            (self.ymax - self.ymin) / self.delta + 1
        )
        if cells > MAX_MAP_CELLS:
            raise InvalidInputError(
                f"SLAM map extent x {self.xmin:g}..{self.xmax:g}, y {self.ymin:g}..{self.ymax:g} m at delta "
                f"{self.delta:g} m needs {cells:.3g} cells, more than the limit of {MAX_MAP_CELLS:,}"
            )

    def usable_range(self, range_max: float) -> float:
        """maxUrange for a scan whose ``range_max`` is given: at most that ``range_max`` (``maxUrange`` 0: it)."""
        return range_max if self.maxUrange <= 0.0 else min(self.maxUrange, range_max)

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
