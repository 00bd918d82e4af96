"""LocalisationNode: Monte Carlo localisation (:class:`mrs_nav.localisation.ParticleFilter`) in place of AMCL.

Subscribes ``scan`` (sensor_msgs/LaserScan), ``map`` (nav_msgs/OccupancyGrid, latched; with ``~use_map_topic``
false the ``static_map`` service is called once instead) and ``initialpose`` (PoseWithCovarianceStamped: rviz's
2D Pose Estimate). For every scan it looks up the odometry pose (``odom_frame_id -> base_frame_id``) at the
scan's stamp through tf and feeds both to the filter, which updates once the robot has moved ``update_min_d``
or turned ``update_min_a``. Publishes ``amcl_pose`` (PoseWithCovarianceStamped) and ``particlecloud``
(PoseArray) after each update, and tf ``global_frame_id -> odom_frame_id`` every ``~transform_publish_period``
s, dated ``transform_tolerance`` s ahead as AMCL does (:mod:`mrs_nav.ros.map_odom`). ``map -> odom`` moves only
with a confident estimate (:meth:`mrs_nav.localisation.ParticleFilter.estimate`): while the filter is not, it
stays where the last confident one put it (or is not published before the first), and the node logs the change
once each way; ``amcl_pose`` is published after every update, its covariance telling how sure the filter is. Service
``global_localization`` (std_srvs/Empty) spreads the particles over the free space; ``request_nomotion_update``
(std_srvs/Empty) makes the next scan update the filter although the robot has not moved, as AMCL's. Parameters
take AMCL's names (config/localisation.yaml, the README).

After a 2D Pose Estimate or ``global_localization`` the filter takes only scans stamped after it: the new cloud
describes the robot as it is then, and a node behind on its scans (10 000 particles after a global spread) would
otherwise weigh it against scans of where the robot was before (a kidnapped or teleported robot), which puts the
particles on the wrong place before the first true scan arrives.

When sim time jumps backwards (a bag played again, the simulator restarted) the particles are kept, the tf
buffer is cleared and map -> odom goes on from the new time (:mod:`mrs_nav.ros.clock_jump`).

As AMCL does, the last published pose and its covariance are stored on the parameter server as
``~initial_pose_x``, ``~initial_pose_y``, ``~initial_pose_a``, ``~initial_cov_xx``, ``~initial_cov_yy`` and
``~initial_cov_aa`` at most ``~save_pose_rate`` times per second of sim time (<= 0: never), so that the node
restarted under the same name (after a crash or ``kill -9``) resumes from where the robot was instead of from the
launch pose: it reads those parameters at start.

A scan or pose that cannot be used is logged (throttled) and skipped; the node never dies of one.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid as OccupancyGridMsg
from nav_msgs.srv import GetMap
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty, EmptyRequest, EmptyResponse

from mrs_nav.config_files import node_default
from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.geometry import FloatArray, Pose2D, format_point
from mrs_nav.localisation import BeamScan, LocalisationConfig, ParticleFilter, PoseEstimate
from mrs_nav.ros.clock_jump import TimeJumpGuard
from mrs_nav.ros.conversions import COV_INDEX, covariance_3x3, pose_from_msg, pose_msg
from mrs_nav.ros.map_odom import MapOdomBroadcaster, check_timing, lookup_pose, tf_state
from mrs_nav.ros.navigation_conversions import grid_from_msg
from mrs_nav.ros.params import private_params

NODE = "localisation"
_default = functools.partial(node_default, NODE)


@dataclass(frozen=True)
class LocalisationNodeConfig:
    """The node's private parameters: frames, timing, map source, and the core :class:`LocalisationConfig`."""

    filter: LocalisationConfig
    global_frame_id: str = _default("global_frame_id")
    odom_frame_id: str = _default("odom_frame_id")
    base_frame_id: str = _default("base_frame_id")
    transform_tolerance: float = _default("transform_tolerance")
    transform_publish_period: float = _default("transform_publish_period")
    tf_wait: float = _default("tf_wait")
    use_map_topic: bool = _default("use_map_topic")
    save_pose_rate: float = _default("save_pose_rate")  # Hz of sim time; <= 0 never stores the pose

    def __post_init__(self) -> None:
        check_timing(self.transform_publish_period, transform_tolerance=self.transform_tolerance, tf_wait=self.tf_wait)

    @classmethod
    def from_params(cls) -> LocalisationNodeConfig:
        """Read the ``~`` parameters once (defaults: config/localisation.yaml); bad values raise."""
        return cls.from_values(private_params(NODE))

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> LocalisationNodeConfig:
        """The config from every parameter of config/localisation.yaml by name."""
        own = {f.name for f in dataclasses.fields(cls)} - {"filter"}
        return cls(
            filter=LocalisationConfig.from_mapping({k: v for k, v in values.items() if k not in own}),
            **{name: values[name] for name in own},
        )


def beam_scan(msg: LaserScan, mount: Pose2D) -> BeamScan:
    """The filter's scan of a LaserScan message (InvalidInputError if its ranges do not fit its angles)."""
    ranges = np.asarray(msg.ranges, dtype=np.float64)
    if not (math.isfinite(msg.angle_min) and math.isfinite(msg.angle_increment)):
        raise InvalidInputError("scan angles are not finite")
    angles = msg.angle_min + msg.angle_increment * np.arange(ranges.size)
    return BeamScan(ranges, angles, float(msg.range_min), float(msg.range_max), mount)


class LocalisationNode:
    """Wires a :class:`ParticleFilter` to ``scan``, ``map``, ``initialpose``, tf and its outputs."""

    def __init__(self, config: LocalisationNodeConfig) -> None:
        self.config = config
        self._lock = threading.Lock()
        self._filter: ParticleFilter | None = None
        self._pending_pose: tuple[Pose2D, FloatArray] | None = None
        self._mount: tuple[str, Pose2D] | None = None
        self._map_to_odom: Pose2D | None = None
        self._covariance: FloatArray | None = None  # of the last published pose
        self._pose_saved_at = -math.inf  # sim time the pose was last stored on the parameter server
        self._pose_to_store: dict[str, float] = {}
        self._store_wanted = threading.Event()
        self._confident = True  # as last reported
        self._reset_stamp = rospy.Time(0)  # scans stamped before the last reset of the belief are not used
        self._buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self._listener = tf2_ros.TransformListener(self._buffer)
        self._map_odom = MapOdomBroadcaster(config.global_frame_id, config.odom_frame_id, config.transform_tolerance)
        self._pose_pub = rospy.Publisher("amcl_pose", PoseWithCovarianceStamped, queue_size=2, latch=True)
        self._cloud_pub = rospy.Publisher("particlecloud", PoseArray, queue_size=2, latch=True)
        self._global_srv = rospy.Service("global_localization", Empty, self._on_global_localization)
        self._nomotion_srv = rospy.Service("request_nomotion_update", Empty, self._on_nomotion_update)
        self._initial_sub = rospy.Subscriber("initialpose", PoseWithCovarianceStamped, self._on_initial_pose)
        if config.use_map_topic:
            self._map_sub = rospy.Subscriber("map", OccupancyGridMsg, self._on_map, queue_size=1)
        else:
            threading.Thread(target=self._request_map, name="static_map", daemon=True).start()
        self._scan_sub = rospy.Subscriber("scan", LaserScan, self._on_scan, queue_size=2)
        self._time_jump = TimeJumpGuard("localisation", self._on_time_jump, self._buffer)
        self._timer = self._time_jump.timer(config.transform_publish_period, self._publish_transform)
        # Six calls to the master per save: made from a thread of their own, never holding up a scan.
        threading.Thread(target=self._store_poses, name="save_pose", daemon=True).start()

    # -- inputs ---------------------------------------------------------------------------------------------------

    def _request_map(self) -> None:
        try:
            rospy.wait_for_service("static_map")
            self._on_map(rospy.ServiceProxy("static_map", GetMap)().map)
        except (rospy.ServiceException, rospy.ROSInterruptException) as err:
            rospy.logerr(f"localisation: no map from static_map: {err}")

    def _on_map(self, msg: OccupancyGridMsg) -> None:
        try:
            pf = ParticleFilter(grid_from_msg(msg), self.config.filter)
        except MrsNavError as err:
            rospy.logerr(f"localisation: ignoring map: {err}")
            return
        with self._lock:
            # a new map keeps the current belief, or takes a pose given before any map, where it fits the map
            belief = self._pending_pose
            if self._filter is not None:
                estimate = self._filter.estimate()
                belief = (estimate.pose, estimate.covariance)
            if belief is not None:
                try:
                    pf.set_pose(*belief)
                except MrsNavError as err:
                    rospy.logwarn(f"localisation: starting from the initial pose parameters: {err}")
            self._filter = pf
        rospy.loginfo(f"localisation: map {msg.info.width} x {msg.info.height} at {msg.info.resolution} m")

    def _on_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        frame = msg.header.frame_id.lstrip("/")
        try:
            if frame and frame != self.config.global_frame_id:
                raise InvalidInputError(f"initial pose in frame {frame!r}, expected {self.config.global_frame_id!r}")
            pose, cov = pose_from_msg(msg.pose.pose), covariance_3x3(msg)
            with self._lock:
                if self._filter is not None:
                    self._filter.set_pose(pose, cov)  # checks it against the map first: a refused pose changes nothing
                    # rviz stamps the pose when it is given; an unstamped or future one counts from now
                    now = rospy.Time.now()
                    self._reset_stamp = min(msg.header.stamp, now) if not msg.header.stamp.is_zero() else now
                    self._covariance = None  # nothing stored until the filter has published from the new belief
                self._pending_pose = (pose, cov)
        except MrsNavError as err:
            rospy.logwarn_throttle(5.0, f"localisation: ignoring initial pose: {err}")
            return
        rospy.loginfo(f"localisation: initial pose {format_point(pose.x, pose.y)}, yaw {pose.yaw:.2f}")

    def _on_global_localization(self, _request: EmptyRequest) -> EmptyResponse:
        with self._lock:
            if self._filter is not None:
                self._filter.global_localisation()
                self._reset_stamp = rospy.Time.now()
                self._covariance = None  # the stored pose stays the last one known until the filter converges
                rospy.loginfo("localisation: particles spread over the free space")
            else:
                rospy.logwarn("localisation: global_localization before any map; ignored")
        return EmptyResponse()

    def _on_nomotion_update(self, _request: EmptyRequest) -> EmptyResponse:
        with self._lock:
            if self._filter is not None:
                self._filter.request_update()
            else:
                rospy.logwarn("localisation: request_nomotion_update before any map; ignored")
        return EmptyResponse()

    def _on_scan(self, msg: LaserScan) -> None:
        self._time_jump.check()
        stamp = msg.header.stamp
        c = self.config
        try:
            odom = self._lookup(c.odom_frame_id, c.base_frame_id, stamp)
            scan = beam_scan(msg, self._mount_of(msg.header.frame_id, stamp))
            with self._lock:
                pf = self._filter
                if pf is None or stamp < self._reset_stamp:
                    return
                was_refuted = pf.refuted
                updated = pf.update(odom, scan)
                refuted = pf.refuted and not was_refuted
                if updated:
                    estimate = pf.estimate()
                    particles = pf.particles.copy()
                    if estimate.confident:  # else map->odom stays where the last confident estimate put it
                        self._map_to_odom = estimate.pose.compose(odom.inverse())
                    self._covariance = estimate.covariance
        except MrsNavError as err:
            rospy.logwarn_throttle(5.0, f"localisation: skipping scan at {stamp.to_sec():.3f}: {err}")
            return
        except (
            tf2_ros.TransformException
        ) as err:  # also a frame tf cannot name ("", "/base_scan"), as in rrt_navigation
            rospy.logwarn_throttle(
                5.0,
                f"localisation: skipping scan at {stamp.to_sec():.3f}, no transform: {err} "
                f"({tf_state(self._buffer, self._listener)})",
            )
            return
        if updated:
            if refuted:
                rospy.logwarn(
                    "localisation: the given pose is refuted by the scans (they fit elsewhere in the map far better);"
                    " particles spread over the free space to find the robot"
                )
            self._report_confidence(estimate)
            self._publish_estimate(estimate, particles, stamp)
        self._save_pose(odom, stamp.to_sec())

    def _on_time_jump(self, _seconds: float) -> str:
        """Sim time went back: broadcast from the new time on, and take scans whatever the date of the last
        pose given (it lies ahead of the new time)."""
        self._map_odom.reset()
        with self._lock:
            self._reset_stamp = rospy.Time(0)
        return "particles kept"

    def _report_confidence(self, estimate: PoseEstimate) -> None:
        """Log once each time the filter loses or regains its confidence (not on every scan)."""
        if estimate.confident == self._confident:
            return
        self._confident = estimate.confident
        sd = np.sqrt(np.maximum(np.diag(estimate.covariance), 0.0))
        state = f"share {estimate.share:.2f}, std dev {sd[0]:.2f} m, {sd[1]:.2f} m, {math.degrees(sd[2]):.0f} deg"
        if estimate.confident:
            rospy.loginfo(f"localisation: confident again ({state}); map->odom follows the estimate")
        else:
            rospy.logwarn(f"localisation: not confident ({state}); map->odom held at the last confident estimate")

    def _lookup(self, parent: str, child: str, stamp: rospy.Time) -> Pose2D:
        return lookup_pose(self._buffer, parent, child, stamp, self.config.tf_wait)

    def _mount_of(self, laser_frame: str, stamp: rospy.Time) -> Pose2D:
        """The laser's pose in the base frame, read from tf once per laser frame."""
        if self._mount is None or self._mount[0] != laser_frame:
            self._mount = (laser_frame, self._lookup(self.config.base_frame_id, laser_frame, stamp))
        return self._mount[1]

    # -- outputs --------------------------------------------------------------------------------------------------

    def _publish_estimate(self, estimate: PoseEstimate, particles: FloatArray, stamp: rospy.Time) -> None:
        frame = self.config.global_frame_id
        msg = PoseWithCovarianceStamped()
        msg.header.stamp, msg.header.frame_id = stamp, frame
        msg.pose.pose = pose_msg(estimate.pose)
        full = np.zeros((6, 6))
        full[np.ix_(COV_INDEX, COV_INDEX)] = estimate.covariance
        msg.pose.covariance = full.ravel().tolist()
        self._pose_pub.publish(msg)
        cloud = PoseArray()
        cloud.header = msg.header
        cloud.poses = [pose_msg(Pose2D(float(x), float(y), float(a))) for x, y, a in particles]
        self._cloud_pub.publish(cloud)

    def _save_pose(self, odom: Pose2D, now: float) -> None:
        """Store the pose as AMCL does (``~initial_pose_*``, ``~initial_cov_*``), at most ``save_pose_rate`` Hz:
        the robot's pose now (the last map->odom correction applied to the odometry of the latest scan, so that a
        robot that moved since the last filter update is stored where it is), with the last estimate's
        covariance."""
        rate, correction, cov = self.config.save_pose_rate, self._map_to_odom, self._covariance
        if rate <= 0.0 or correction is None or cov is None or abs(now - self._pose_saved_at) < 1.0 / rate:
            return  # abs: sim time may have gone back
        self._pose_saved_at = now
        pose = correction.compose(odom)
        self._pose_to_store = {
            "initial_pose_x": pose.x, "initial_pose_y": pose.y, "initial_pose_a": pose.yaw,
            "initial_cov_xx": cov[0, 0], "initial_cov_yy": cov[1, 1], "initial_cov_aa": cov[2, 2],
        }  # fmt: skip
        self._store_wanted.set()

    def _store_poses(self) -> None:
        """Write the latest pose to store onto the parameter server whenever there is one (the latest wins)."""
        while not rospy.is_shutdown():
            if not self._store_wanted.wait(1.0):
                continue
            self._store_wanted.clear()
            try:
                for name, value in self._pose_to_store.items():
                    rospy.set_param(f"~{name}", float(value))
            except (OSError, rospy.ROSException) as err:  # the master is away for a moment: the next save retries
                rospy.logwarn_throttle(5.0, f"localisation: cannot store the pose on the parameter server: {err}")

    def _publish_transform(self, _event: Any) -> None:
        correction = self._map_to_odom
        if correction is not None:
            self._map_odom.send(correction)

    def spin(self) -> None:
        rospy.spin()
        self._timer.shutdown()
