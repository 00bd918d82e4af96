"""MapServerNode and MapSaverNode: ROS's map_server and map_saver (not packaged by Debian 12), same names.

``map_server MAP.yaml`` loads a map_server map (:func:`mrs_nav.maps.map_io.load_map`) and publishes it on
``map`` (nav_msgs/OccupancyGrid, latched) and ``map_metadata`` (latched) in frame ``~frame_id`` (``map``), and
answers the ``static_map`` service (nav_msgs/GetMap). ``map_saver -f NAME [--occ 65 --free 25]`` waits for
one message on ``map`` and writes NAME.yaml + NAME.pgm (:func:`mrs_nav.maps.map_io.save_map`): cells at or
above ``--occ`` occupied, ``0..--free`` free, the rest unknown.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import rospy
from nav_msgs.msg import MapMetaData
from nav_msgs.msg import OccupancyGrid as OccupancyGridMsg
from nav_msgs.srv import GetMap, GetMapRequest, GetMapResponse

from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.maps.map_io import load_map, map_targets, save_map
from mrs_nav.maps.map_world import disagreement, world_path
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.options import Parser, integer_option
from mrs_nav.ros.map_messages import OccupancyGridArrayMsg, occupancy_grid_msg
from mrs_nav.ros.navigation_conversions import grid_from_msg
from mrs_nav.ros.params import private_params

NODE = "map_server"  # its private parameters: config/map_server.yaml
# The simulator's world file (its ~world as simulation.launch names it), when one runs.
SIMULATOR_WORLD = "simulator/world"


class MapServerNode:
    """Serves one map: latched ``map`` and ``map_metadata``, and the ``static_map`` service."""

    def __init__(self, grid: OccupancyGrid, frame_id: str) -> None:
        self._msg = occupancy_grid_msg(grid, rospy.Time.now(), frame_id)
        self._map_pub = rospy.Publisher("map", OccupancyGridArrayMsg, queue_size=1, latch=True)
        self._meta_pub = rospy.Publisher("map_metadata", MapMetaData, queue_size=1, latch=True)
        self._map_pub.publish(self._msg)
        self._meta_pub.publish(self._msg.info)
        self._service = rospy.Service("static_map", GetMap, self._on_get_map)

    def _on_get_map(self, _request: GetMapRequest) -> GetMapResponse:
        return GetMapResponse(map=self._msg)

    @classmethod
    def from_argv(cls, argv: Sequence[str]) -> MapServerNode:
        """``map_server MAP.yaml``; a bad or missing file raises MapFileError naming file and field."""
        parser = Parser(prog="map_server", description="Serve a map_server map (.yaml + .pgm).")
        parser.add_argument("map", type=Path, help="the map's .yaml description")
        args = parser.parse_args(argv)
        node = cls(load_map(args.map), private_params(NODE)["frame_id"])
        warn_if_other_world(args.map)
        return node


def warn_if_other_world(map_yaml: Path) -> None:
    """Warn once when the simulator runs another world than the one ``map_yaml`` was saved in."""
    world = rospy.get_param(SIMULATOR_WORLD, "")
    note = disagreement(map_yaml, world) if isinstance(world, str) and world else None
    if note is not None:
        rospy.logwarn(f"map_server: {note}")


@dataclass(frozen=True)
class SaverOptions:
    """Where to write (``NAME`` -> NAME.yaml, NAME.pgm) and map_saver's thresholds (percent)."""

    name: Path
    occupied_min: int = 65
    free_max: int = 25

    @property
    def yaml_path(self) -> Path:
        return self.name.with_name(self.name.name + ".yaml")

    @classmethod
    def from_argv(cls, argv: Sequence[str]) -> SaverOptions:
        """Options of ``map_saver``; a name that cannot take ``.yaml`` (``/``, ``.``, empty) or targets that cannot
        be written are refused here, before waiting for the map."""
        parser = Parser(prog="map_saver", description="Save the map on topic 'map' to NAME.yaml/.pgm.")
        parser.add_argument("-f", dest="name", default="map", help="file name without extension")
        parser.add_argument(
            "--occ", type=integer_option(0, 100), default=65, help="cells at or above this are occupied (0-100)"
        )
        parser.add_argument(
            "--free", type=integer_option(0, 100), default=25, help="cells at or below this are free (0-100)"
        )
        args = parser.parse_args(argv)
        if Path(args.name).name in ("", ".", ".."):
            raise InvalidInputError(f"-f {args.name or repr(args.name)}: not a file name")
        options = cls(Path(args.name), args.occ, args.free)
        if not 0 <= options.free_max < options.occupied_min <= 100:
            raise InvalidInputError(f"need 0 <= --free ({args.free}) < --occ ({args.occ}) <= 100")
        map_targets(options.yaml_path, "-f")
        return options


class MapSaverNode:
    """Saves the first message on ``map`` and is then :attr:`done` (``saved`` holds the yaml path, or ``error``
    why not)."""

    def __init__(self, options: SaverOptions) -> None:
        self.options = options
        self.done = threading.Event()
        self.saved: Path | None = None
        self.error: MrsNavError | None = None
        self._sub = rospy.Subscriber("map", OccupancyGridMsg, self._on_map, queue_size=1)

    def _on_map(self, msg: OccupancyGridMsg) -> None:
        if self.done.is_set():
            return
        try:
            self.saved = self._save(msg)
        except MrsNavError as err:
            self.error = err
        finally:  # whatever went wrong, map_saver reports and exits instead of waiting for a map that came
            self._sub.unregister()
            self.done.set()

    def _save(self, msg: OccupancyGridMsg) -> Path:
        try:
            grid = grid_from_msg(msg)
        except InvalidInputError as err:
            raise InvalidInputError(f"{self._sub.resolved_name}: {err}") from err
        o = self.options
        # the world a simulator runs, kept in the map for navigation.launch (mrs_nav.maps.map_world)
        world = rospy.get_param(SIMULATOR_WORLD, "")
        where = str(world_path(world).absolute()) if isinstance(world, str) and world else None
        return save_map(grid, o.yaml_path, occupied_min=o.occupied_min, free_max=o.free_max, world=where)
