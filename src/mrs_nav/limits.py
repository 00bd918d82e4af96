"""The stated maxima of what mrs_nav accepts from files and options, checked before any work or allocation.

Each limit is far above what a TurtleBot3-sized robot in a building needs and low enough that the work or
memory it allows stays within a few seconds and a few hundred megabytes on a small machine. Past a limit the
input is refused with an :class:`~mrs_nav.errors.InvalidInputError` (or the loader's own domain error) that
names the input, the field and the limit; nothing is truncated or clamped silently. The README lists them.
"""

from __future__ import annotations

from mrs_nav.errors import InvalidInputError

#: World geometry: every coordinate within +-this of the origin, metres (a 2 km square site).
MAX_COORDINATE_M = 1000.0
#: World geometry: the largest size (box side, cylinder radius or length), metres.
MAX_SIZE_M = 1000.0
#: Boxes plus cylinders in one world: the simulator's 360 rays and the contact checks scale with this.
MAX_SHAPES = 2000
#: Cells of one occupancy grid (rasterised world, map file, inflated map): 20 million (e.g. 4472 x 4472,
#: 224 m square at 5 cm); rasterising that peaks near 1.5 GB, so anything larger is refused before allocating.
MAX_GRID_CELLS = 20_000_000
#: A map file's image (.pgm) in bytes: 16-bit pixels of the largest grid plus header room.
MAX_IMAGE_BYTES = 2 * MAX_GRID_CELLS + 4096
#: A map file's resolution (cell side), metres: 0.1 mm is finer than any range sensor resolves and 1 km coarser
#: than any map a robot plans on; map_server takes any positive number, but at 1e-300 or 1e300 the cell
#: arithmetic (and the message's float32 resolution) turns to zero or infinity.
MIN_MAP_RESOLUTION_M = 1e-4
MAX_MAP_RESOLUTION_M = 1e3
#: A map file's origin x and y, metres from the map frame: 10,000 km holds any UTM easting and northing (maps
#: anchored in geographic coordinates) while keeping cell positions exact to far below a millimetre in float64.
MAX_MAP_ORIGIN_M = 1e7
#: Obstacle inflation radius (the robot's radius), metres: larger than any robot this stack drives.
MAX_ROBOT_RADIUS_M = 2.0
#: Planner and navigation budgets: wall or sim seconds.
MAX_BUDGET_S = 3600.0
#: Iteration and step counts (samples of RRT/RRT*, integration steps of the potential field).
MAX_ITERATIONS = 10_000_000
#: Random seeds: numpy's and ODE's seeds are unsigned 32-bit.
MAX_SEED = 2**32 - 1
#: Benchmark runs, seeds, repeats, bags and worker processes.
MAX_RUNS = 10_000
#: Benchmark durations, seconds.
MAX_BENCH_S = 24 * 3600.0
#: Nesting depth of a JSON obstacle list: a list of [x, y, r] lists needs 2.
MAX_JSON_DEPTH = 2


def check_grid_cells(width: int, height: int, what: str) -> None:
    """Refuse a ``width`` x ``height`` grid above :data:`MAX_GRID_CELLS` before anything is allocated."""
    if width * height > MAX_GRID_CELLS:
        raise InvalidInputError(
            f"{what}: a {width} x {height} grid ({width * height:.3g} cells) exceeds the limit of "
            f"{MAX_GRID_CELLS:.3g} cells; use a coarser resolution or a smaller area"
        )
