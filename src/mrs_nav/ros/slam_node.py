"""SlamNode: SLAM-lite (:class:`mrs_nav.slam.Slam`) as a ROS 1 node in place of slam_gmapping.

Subscribes ``scan`` (sensor_msgs/LaserScan). For every scan it looks up the odometry pose
(``odom_frame -> base_frame``) at the scan's stamp through tf, waiting up to ``~tf_wait`` s for the odometry to
catch up instead of dropping the scan on extrapolation, and feeds the pair to the core, which processes it when
the update gates open. Publishes ``map`` (nav_msgs/OccupancyGrid, latched) and ``map_metadata`` (latched) every
``~map_update_interval`` s of map change, and serves the map as of the call on ``dynamic_map`` (nav_msgs/GetMap,
as gmapping), and tf ``map_frame -> odom_frame`` every ``~transform_publish_period``
s (20 Hz by default). Parameters take gmapping's names (see config/slam.yaml and the README).

A scan that cannot be used (wrong length, NaN angles, bad geometry, no transform, a pose far outside any
building) is logged (throttled) and skipped; the node never dies of one and no message changes the map but by
being mapped. A scan in another frame than the laser's (e.g. ``base_link``) is used with that frame's mounting
when tf knows it, else dropped with a throttled warning. The map is reset only by the ``~reset`` service
(std_srvs/Empty), or when sim time jumps backwards (a bag played again, the simulator restarted) and
``~reset_map_on_time_jump`` is true; each reset is logged. On a jump back the map and the correction are kept by
default: the tf buffer is cleared and map -> odom and /map go on from the new time (:mod:`mrs_nav.ros.clock_jump`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import rospy
import tf2_ros
from nav_msgs.msg import MapMetaData
from nav_msgs.msg import OccupancyGrid as OccupancyGridMsg
from nav_msgs.srv import GetMap, GetMapRequest, GetMapResponse
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty, EmptyRequest, EmptyResponse

from mrs_nav.config_files import node_default
from mrs_nav.errors import MrsNavError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.ros.clock_jump import TimeJumpGuard
from mrs_nav.ros.conversions import any_reading, scan_data
from mrs_nav.ros.map_messages import OccupancyGridArrayMsg, occupancy_grid_msg
from mrs_nav.ros.map_odom import MapOdomBroadcaster, check_timing, lookup_pose, tf_state
from mrs_nav.ros.navigation_conversions import publish_unless_shutdown
from mrs_nav.ros.params import private_params
from mrs_nav.slam import Slam, SlamConfig

NODE = "slam"
_default = functools.partial(node_default, NODE)
_TF_ERRORS = (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException)


@dataclass(frozen=True)
class SlamNodeConfig:
    """The node's private parameters: frames, timing, and the core :class:`SlamConfig`."""

    slam: SlamConfig
    base_frame: str = _default("base_frame")
    odom_frame: str = _default("odom_frame")
    map_frame: str = _default("map_frame")
    transform_publish_period: float = _default("transform_publish_period")
    tf_wait: float = _default("tf_wait")
    reset_map_on_time_jump: bool = _default("reset_map_on_time_jump")

    def __post_init__(self) -> None:
        check_timing(self.transform_publish_period, tf_wait=self.tf_wait)

    @classmethod
    def from_params(cls) -> SlamNodeConfig:
        """Read the ``~`` parameters once (defaults: config/slam.yaml); bad values raise InvalidInputError."""
        return cls.from_values(private_params(NODE))

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> SlamNodeConfig:
        """The config from every parameter of config/slam.yaml by name."""
        own = {f.name for f in dataclasses.fields(cls)} - {"slam"}
        return cls(
            slam=SlamConfig.from_mapping({k: v for k, v in values.items() if k not in own}),
            **{name: values[name] for name in own},
        )


class SlamNode:
    """Wires :class:`Slam` to ``scan``, tf, ``map`` and ``map_metadata``; :meth:`spin` runs until shutdown."""

    def __init__(self, config: SlamNodeConfig) -> None:
        self.config = config
        self._lock = threading.Lock()
        self._slam: Slam | None = None  # made at the first scan, once the laser's mounting is known
        # map -> odom as of the last processed scan, read by the tf timer without the lock: a scan match, and a
        # map rebuild after a closure (0.1 s and more on a large map), must not delay the correction past the
        # navigators' correction_freshness (0.15 s), or they stop the robot while SLAM is merely busy.
        self._correction: Pose2D | None = None
        self._mountings: dict[str, Pose2D] = {}  # base -> scan frame, per frame seen (static mountings)
        self._last_map_time = -math.inf
        self._buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self._listener = tf2_ros.TransformListener(self._buffer)
        # dated one period ahead, as gmapping does, so lookups at the newest odometry stamp find it
        self._map_odom = MapOdomBroadcaster(config.map_frame, config.odom_frame, config.transform_publish_period)
        self._map_pub = rospy.Publisher("map", OccupancyGridArrayMsg, queue_size=1, latch=True)
        self._meta_pub = rospy.Publisher("map_metadata", MapMetaData, queue_size=1, latch=True)
        self._scan_sub = rospy.Subscriber("scan", LaserScan, self._on_scan, queue_size=5)
        self._time_jump = TimeJumpGuard("slam", self._on_time_jump, self._buffer)
        self._timer = self._time_jump.timer(config.transform_publish_period, self._publish_transform)
        self._reset_srv = rospy.Service("~reset", Empty, self._on_reset)
        self._map_srv = rospy.Service("dynamic_map", GetMap, self._on_dynamic_map)

    # -- scans ----------------------------------------------------------------------------------------------------

    def _on_scan(self, msg: LaserScan) -> None:
        stamp = msg.header.stamp.to_sec()
        # The clock, not the scans' stamps, decides whether time went back: one bogus stamp must not reset.
        self._time_jump.check()
        try:
            scan = scan_data(msg)
            if not any_reading(scan.ranges):
                rospy.logwarn_throttle(5.0, f"slam: skipping scan at {stamp:.3f}: no range is a number >= 0")
                return
            try:
                mounting = self._mounting(msg.header.frame_id, msg.header.stamp)
            except _TF_ERRORS as err:
                # A call of its own, so that its throttle is its own: the transient "odometry not there yet" below
                # must not hide a frame that will never work.
                rospy.logwarn_throttle(
                    5.0,
                    f"slam: dropping scans in frame {msg.header.frame_id!r}: no transform to the base: {err} "
                    f"({tf_state(self._buffer, self._listener)})",
                )
                return
            odom = self._lookup(self.config.odom_frame, self.config.base_frame, msg.header.stamp)
            with self._lock:
                if self._slam is None:
                    # The first usable scan's frame is the laser's; others are mapped with their own mounting.
                    # The node publishes the map and the correction; a kept trajectory would grow with every scan.
                    self._slam = Slam(self.config.slam, mounting, keep_trajectory=False)
                    self._last_map_time = -math.inf
                done = self._slam.add_scan(odom, scan, stamp, laser_pose=mounting)
                self._correction = self._slam.map_to_odom
        except MrsNavError as err:
            rospy.logwarn_throttle(5.0, f"slam: skipping scan at {stamp:.3f} (frame {msg.header.frame_id!r}): {err}")
            return
        except _TF_ERRORS as err:
            rospy.logwarn_throttle(5.0, f"slam: skipping scan at {stamp:.3f}, no odometry at its time: {err}")
            return
        # The first processed scan publishes a map at once; later ones every map_update_interval.
        if done is not None and stamp - self._last_map_time >= self.config.slam.map_update_interval:
            self._publish_map(msg.header.stamp)

    def _lookup(self, parent: str, child: str, stamp: rospy.Time) -> Pose2D:
        return lookup_pose(self._buffer, parent, child, stamp, self.config.tf_wait)

    def _mounting(self, frame: str, stamp: rospy.Time) -> Pose2D:
        """base -> ``frame`` from tf (looked up once per frame: laser mountings are static)."""
        if frame not in self._mountings:
            self._mountings[frame] = self._lookup(self.config.base_frame, frame, stamp)
        return self._mountings[frame]

    def _new_map(self) -> None:
        with self._lock:
            self._slam = None
            self._correction = None
            self._mountings.clear()
        self._map_odom.reset()

    def _on_reset(self, _request: EmptyRequest) -> EmptyResponse:
        rospy.logwarn("slam: reset requested on ~reset; starting a new map")
        self._new_map()
        return EmptyResponse()

    def _on_time_jump(self, _seconds: float) -> str:
        """Sim time went back: broadcast and publish from the new time on; a new map only if asked."""
        self._map_odom.reset()
        self._last_map_time = -math.inf  # the next processed scan publishes /map, not one map_update_interval later
        if self.config.reset_map_on_time_jump:
            self._new_map()
            return "starting a new map (~reset_map_on_time_jump)"
        return "map and correction kept (~reset_map_on_time_jump false)"

    # -- outputs --------------------------------------------------------------------------------------------------

    def _publish_transform(self, _event: Any) -> None:
        correction = self._correction
        if correction is not None:
            self._map_odom.send(correction)

    def _map_message(self, stamp: rospy.Time) -> OccupancyGridMsg | None:
        """The map as it is now, stamped ``stamp``; None before the first processed scan."""
        with self._lock:
            if self._slam is None:
                return None
            grid = self._slam.grid
            values = grid.to_occupancy().reshape(grid.height, grid.width)
            origin = (grid.origin_x, grid.origin_y, 0.0)
            resolution = grid.resolution
        return occupancy_grid_msg(OccupancyGrid(values, resolution, origin), stamp, self.config.map_frame)

    def _publish_map(self, stamp: rospy.Time) -> None:
        msg = self._map_message(stamp)
        if msg is None:
            return
        publish_unless_shutdown(self._map_pub, msg, "slam")
        publish_unless_shutdown(self._meta_pub, msg.info, "slam")
        self._last_map_time = stamp.to_sec()

    def _on_dynamic_map(self, _request: GetMapRequest) -> GetMapResponse:
        """gmapping's ``dynamic_map``: the map as of now (an error before the first scan is mapped, as gmapping)."""
        msg = self._map_message(rospy.Time.now())
        if msg is None:
            raise rospy.ServiceException("slam: no map yet (no scan mapped)")
        return GetMapResponse(map=msg)

    def spin(self) -> None:
        rospy.spin()
        self._timer.shutdown()
