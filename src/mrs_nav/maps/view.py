"""rviz's top-down view that frames a world or a saved map: the shipped configs open centred on what is simulated,
at a scale that shows all of it, instead of on (0, 0) at a fixed scale (the office did not fit, and a robot
starting at (-5, -5) sat on the window's edge).

``scripts/rviz_if_display --frame PATH`` writes a copy of the config with the view from :func:`framing` (the world
file's obstacles, or a map's known cells or the world the map names) and starts rviz on it; ``--drop NAME`` leaves
a display out of that copy (:func:`framed_config`).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mrs_nav.errors import InvalidInputError
from mrs_nav.maps.map_io import load_map
from mrs_nav.maps.map_world import saved_world
from mrs_nav.maps.world import load_world

#: Pixels of rviz's render panel in the shipped configs' 1200 x 800 window, less the Displays dock (about 330 px)
#: and the menu, tool and time bars (about 130 px).
RENDER_PX = (850, 650)
MARGIN_M = 0.5  # around what is framed, so the walls do not touch the window's edge


@dataclass(frozen=True)
class TopDownView:
    """rviz/TopDownOrtho's view: the centre (m, fixed frame) and the scale (px/m)."""

    x: float
    y: float
    scale: float


def framing(bounds: tuple[float, float, float, float], render_px: tuple[int, int] = RENDER_PX) -> TopDownView:
    """The view centred on ``bounds`` (xmin, ymin, xmax, ymax; m) that shows all of it plus ``MARGIN_M``."""
    xmin, ymin, xmax, ymax = bounds
    width, height = xmax - xmin + 2.0 * MARGIN_M, ymax - ymin + 2.0 * MARGIN_M
    if not (width > 0.0 and height > 0.0 and np.isfinite(width + height)):
        raise InvalidInputError(f"cannot frame bounds {bounds}: not a finite area")
    scale = min(render_px[0] / width, render_px[1] / height)
    return TopDownView((xmin + xmax) / 2.0, (ymin + ymax) / 2.0, round(scale, 1))


def bounds_of(path: Path) -> tuple[float, float, float, float]:
    """What to frame for ``path``: a world file's obstacles; for a map YAML, the world it names, else its known
    cells."""
    if path.suffix == ".yaml":
        world = saved_world(path)
        if world is None:
            grid = load_map(path)
            rows, cols = np.nonzero(grid.values >= 0)
            if rows.size == 0:
                return grid.extent
            x0, y0, _ = grid.origin
            res = grid.resolution
            return (
                x0 + cols.min() * res,
                y0 + rows.min() * res,
                x0 + (cols.max() + 1) * res,
                y0 + (rows.max() + 1) * res,
            )
        path = world
    return load_world(path).bounds()


def framed_config(text: str, view: TopDownView | None, drop: Collection[str] = (), where: str = "rviz config") -> str:
    """The rviz config ``text`` with its current view made the top-down one ``view`` (None: as it is), on the
    fixed frame, and without the displays or groups named in ``drop`` (``NAME`` at the top, ``GROUP/NAME`` in a
    group: a robot that does not run, a saved map not given; a display of a topic nobody publishes sits in a
    warning state)."""
    config = yaml.safe_load(text)
    try:
        manager = config["Visualization Manager"]
        current = manager["Views"]["Current"]
        displays = manager["Displays"]
    except (KeyError, TypeError):
        raise InvalidInputError(f"{where}: no Visualization Manager with Displays and Views/Current") from None
    manager["Displays"] = _without(displays, set(drop), where)
    if view is not None:
        current.update(
            {
                "Class": "rviz/TopDownOrtho",
                "X": view.x,
                "Y": view.y,
                "Scale": view.scale,
                "Target Frame": "<Fixed Frame>",
            }
        )
    return str(yaml.safe_dump(config, sort_keys=False))


def _without(displays: list[dict[str, Any]], drop: set[str], where: str) -> list[dict[str, Any]]:
    """``displays`` without those named in ``drop`` (``GROUP/NAME`` inside a group); a name that is not there is
    an error."""
    kept, found = [], set()
    for display in displays:
        name = str(display.get("Name"))
        if name in drop:
            found.add(name)
            continue
        inner = {item.split("/", 1)[1] for item in drop if item.startswith(f"{name}/")}
        if inner and isinstance(display.get("Displays"), list):
            display = {**display, "Displays": _without(display["Displays"], inner, f"{where}: group {name}")}
            found |= {f"{name}/{item}" for item in inner}
        kept.append(display)
    if drop - found:
        raise InvalidInputError(f"{where}: no display named {', '.join(sorted(drop - found))} to leave out")
    return kept
