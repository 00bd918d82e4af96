"""SimulatorNode: the ODE simulator (:class:`mrs_nav.sim.MultiRobotSimulator`) as a ROS 1 node in place of Gazebo.

Subscribes ``cmd_vel`` (geometry_msgs/Twist). Publishes ``clock`` (it *is* the clock: run with
``/use_sim_time`` true), ``odom`` (nav_msgs/Odometry) and tf ``odom -> base_footprint``, ``scan``
(sensor_msgs/LaserScan, frame ``base_scan``), ``ground_truth/odom`` (the true pose, frame ``world``, which
coincides with ``odom`` at time zero), ``ground_truth/contacts`` (std_msgs/UInt32, latched: how many times the
robot has run into an obstacle) and ``joint_states`` (the wheels, for robot_state_publisher, which
publishes the static base_footprint -> base_link -> base_scan from ``urdf/burger.urdf``).

The node steps the simulator in its own loop at the fixed physics rate, paced against the wall clock by
``~real_time_factor`` (1 = real time, 2 = twice as fast, 0 = as fast as the machine allows). ``/clock`` goes
out every ``physics_rate / clock_rate`` steps, so sim-time timers in other nodes keep their resolution at any
speed; every tick wakes every sim-time timer of every node, which with several robots costs more than the physics
(multi_robot.launch publishes 20 Hz, what the 10 Hz controllers need). With ``~lockstep`` true the loop never runs
more than ``~lockstep_period`` of sim time past the last ``cmd_vel`` it received (and publishes the clock where it
waits), so a controller ticking on sim time keeps up at any rate (see
:mod:`mrs_nav.sim.lockstep`: free running before the first command, after ``~lockstep_timeout`` wall seconds of
silence once no publisher is connected to ``cmd_vel`` or the last command was a stop, and after
``~lockstep_stall_timeout`` while one still is and the last command a motion, with one period of grace after
``~lockstep_timeout``: a connected controller that is silent mid-drive is slow or waiting for a tick just past the
horizon, not gone; each switch is logged once). A bad
``cmd_vel`` (non-finite numbers) is logged and ignored; the watchdog then stops the robot.
``~add_box`` (visualization_msgs/Marker of type CUBE: pose in the world frame, scale = full sizes in m, ``ns``
its name) puts a box into the world at run time, e.g. across a corridor after the map was made. A goal on
``move_base_simple/goal`` (rviz's 2D Nav Goal) that no navigation node listens for is warned of once
(:mod:`mrs_nav.ros.unheard_goal`).

``~set_pose`` (geometry_msgs/Pose2D, world frame) teleports the robot, stopped, without its odometry noticing:
the kidnapped-robot test of a localisation. A pose inside an obstacle is logged and ignored.

Several robots: ``~robots`` ("x y yaw; x y yaw; ...", world frame; empty = the one robot at ``~x ~y ~yaw``)
puts robot ``i`` as ``tb3_i`` into the same ODE world. Each has its own topics under ``tb3_i/`` (``cmd_vel``,
``odom``, ``scan``, ``ground_truth/odom``, ``ground_truth/contacts``, ``joint_states``; ``~tb3_i/set_pose``)
and frames prefixed ``tb3_i/`` (``tb3_i/odom -> tb3_i/base_footprint``, scans in ``tb3_i/base_scan``); they
share ``/clock`` and the ground-truth frame. Each sees the others in its scan, contacts between robots count
like wall contacts, and in lockstep the simulation waits for every robot's controller.
"""

from __future__ import annotations

import functools
import math
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import rospkg
import rospy
import tf2_ros
from geometry_msgs.msg import Pose2D as Pose2DMsg
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry as OdometryMsg
from rosgraph_msgs.msg import Clock
from rospy import rostime
from rospy.impl import simtime
from sensor_msgs.msg import JointState, LaserScan
from std_msgs.msg import UInt32
from visualization_msgs.msg import Marker

from mrs_nav.config_files import node_default
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.map_world import world_of_map
from mrs_nav.maps.world import Box, load_world
from mrs_nav.ros.conversions import (
    clock_msg,
    joint_state_msg,
    laser_scan_msg,
    odometry_msg,
    pose_from_msg,
    to_ros_time,
    transform_stamped,
    twist_from_msg,
)
from mrs_nav.ros.params import private_params
from mrs_nav.ros.unheard_goal import UnheardGoalWarning
from mrs_nav.sim import (
    LaserParams,
    LockstepConfig,
    LockstepGate,
    LockstepSwitch,
    MultiRobotSimulator,
    SimulatedRobot,
    SimulatorConfig,
    Twist2D,
)
from mrs_nav.sim.lockstep import FREE_RUN_LOG

WHEEL_JOINTS = ("wheel_left_joint", "wheel_right_joint")
NODE = "simulator"
_default = functools.partial(node_default, NODE)
# When pacing falls this far behind (s of wall time), the lag is forgiven rather than caught up in a burst.
_MAX_LAG = 0.25


def _rate_divisor(physics_rate: float, rate: float, name: str) -> int:
    """Steps between publications of a stream at ``rate`` Hz; the rate must divide the physics rate."""
    if not (math.isfinite(rate) and 0.0 < rate <= physics_rate):
        raise InvalidInputError(f"~{name}: must be in (0, {physics_rate}] Hz, got {rate}")
    divisor = round(physics_rate / rate)
    if abs(physics_rate / divisor - rate) > 1e-6:
        raise InvalidInputError(f"~{name}: {rate} Hz does not divide the physics rate {physics_rate} Hz")
    return divisor


@dataclass(frozen=True)
class SimulatorNodeConfig:
    """Everything the node reads from its private parameters, validated once at start."""

    world: Path
    start: Pose2D
    sim: SimulatorConfig
    real_time_factor: float = _default("real_time_factor")
    odom_rate: float = _default("odom_rate")
    clock_rate: float = _default("clock_rate")
    joint_states_rate: float = _default("joint_states_rate")
    odom_frame: str = _default("odom_frame")
    base_frame: str = _default("base_frame")
    scan_frame: str = _default("scan_frame")
    ground_truth_frame: str = _default("ground_truth_frame")
    publish_tf: bool = _default("publish_tf")
    lockstep: LockstepConfig | None = None  # ~lockstep false
    robots: tuple[Pose2D, ...] = ()  # empty: one robot at ``start`` with unprefixed topics and frames

    def __post_init__(self) -> None:
        if not (math.isfinite(self.real_time_factor) and self.real_time_factor >= 0.0):
            raise InvalidInputError(
                f"~real_time_factor: must be >= 0 (0 = as fast as possible), got {self.real_time_factor}"
            )
        _rate_divisor(self.sim.physics_rate, self.odom_rate, "odom_rate")
        _rate_divisor(self.sim.physics_rate, self.clock_rate, "clock_rate")
        _rate_divisor(self.sim.physics_rate, self.joint_states_rate, "joint_states_rate")

    @classmethod
    def from_params(cls) -> SimulatorNodeConfig:
        """Read the ``~`` parameters (defaults: config/simulator.yaml)."""
        return cls.from_values(private_params(NODE))

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> SimulatorNodeConfig:
        """The config from every parameter of config/simulator.yaml by name."""
        if not values["world"]:
            raise InvalidInputError("~world: a world file is required")
        laser = LaserParams(
            range_min=values["range_min"],
            range_max=values["range_max"],
            rate=values["scan_rate"],
            noise_sigma=values["scan_noise"],
        )
        sim = SimulatorConfig(
            laser=laser, physics_rate=values["physics_rate"], odom_noise=values["odom_noise"], seed=values["seed"]
        )
        lockstep = LockstepConfig(
            period=values["lockstep_period"],
            timeout=values["lockstep_timeout"],
            stall_timeout=values["lockstep_stall_timeout"],
        )
        return cls(
            world=resolve_world(values["world"]),
            start=Pose2D(values["x"], values["y"], values["yaw"]),
            sim=sim,
            real_time_factor=values["real_time_factor"],
            odom_rate=values["odom_rate"],
            clock_rate=values["clock_rate"],
            joint_states_rate=values["joint_states_rate"],
            odom_frame=values["odom_frame"],
            base_frame=values["base_frame"],
            scan_frame=values["scan_frame"],
            ground_truth_frame=values["ground_truth_frame"],
            publish_tf=values["publish_tf"],
            lockstep=lockstep if values["lockstep"] else None,
            robots=parse_poses(values["robots"], "~robots"),
        )

    def robot_names(self) -> list[str]:
        """Each robot's namespace and frame prefix: ``tb3_0``, ``tb3_1``, ...; one unprefixed robot by default."""
        return [f"tb3_{i}" for i in range(len(self.robots))] if self.robots else [""]


def parse_poses(text: str, name: str) -> tuple[Pose2D, ...]:
    """Poses written ``"x y yaw; x y yaw"`` (m, m, rad; commas also separate numbers); empty text gives none."""
    poses = []
    for i, item in enumerate(part for part in text.split(";") if part.strip()):
        fields = item.replace(",", " ").split()
        try:
            numbers = [float(v) for v in fields]
        except ValueError:
            numbers = []
        if len(numbers) != 3 or not all(math.isfinite(v) for v in numbers):
            raise InvalidInputError(f"{name}: pose {i} must be three finite numbers 'x y yaw', got {item.strip()!r}")
        poses.append(Pose2D(*numbers))
    return tuple(poses)


def _own_the_clock() -> Any:
    """Let this node set its own rospy time instead of listening to the /clock it publishes itself.

    With /use_sim_time, rospy subscribes every node to /clock; for the node that *is* the clock that means
    deserialising its own 100 Hz stream in another thread, which at maximum rate costs more than the physics.
    rospy has no public hook for this, so the subscriber is dropped and ``rospy.rostime._set_rostime`` called
    directly; if a rospy version lacks either, the node falls back to listening (slower, still correct).
    """
    setter = getattr(rostime, "_set_rostime", None)
    subscriber = getattr(simtime, "_clock_sub", None)
    if setter is None or subscriber is None:
        return lambda _stamp: None
    subscriber.unregister()
    simtime._clock_sub = None
    return setter


def resolve_world(name: str) -> Path:
    """A world file path; a bare name (``office`` or ``office.world``) means one of this package's worlds, and a
    saved map's YAML the world it was made in (``navigation.launch map_file:=`` without ``world:=``)."""
    if name.endswith(".yaml"):
        return world_of_map(Path(name).expanduser())
    if "/" in name:
        return Path(name)
    filename = name if name.endswith(".world") else f"{name}.world"
    try:
        return Path(rospkg.RosPack().get_path("mrs_nav")) / "worlds" / filename
    except rospkg.ResourceNotFound:
        return Path(name)


class _RobotPorts:
    """One simulated robot's topics, frames and lockstep gate; ``prefix`` is ``""`` or ``"tb3_i/"``."""

    def __init__(self, node: SimulatorNode, robot: SimulatedRobot, prefix: str) -> None:
        cfg = node.config
        self.robot = robot
        self._node = node
        self.odom_frame = prefix + cfg.odom_frame
        self.base_frame = prefix + cfg.base_frame
        self.scan_frame = prefix + cfg.scan_frame
        self.who = f"simulator: {prefix[:-1]}: " if prefix else "simulator: "
        self.odom_pub = rospy.Publisher(prefix + "odom", OdometryMsg, queue_size=10)
        self.truth_pub = rospy.Publisher(prefix + "ground_truth/odom", OdometryMsg, queue_size=10)
        self.contacts_pub = rospy.Publisher(prefix + "ground_truth/contacts", UInt32, queue_size=1, latch=True)
        self.contact_events = -1
        self.scan_pub = rospy.Publisher(prefix + "scan", LaserScan, queue_size=5)
        self.joints_pub = rospy.Publisher(prefix + "joint_states", JointState, queue_size=10)
        self.cmd_sub = rospy.Subscriber(prefix + "cmd_vel", Twist, self._on_cmd_vel, queue_size=10, tcp_nodelay=True)
        self.gate = (
            LockstepGate(cfg.lockstep, publishers=self.cmd_sub.get_num_connections, on_switch=self._on_lockstep_switch)
            if cfg.lockstep is not None
            else None
        )
        self.set_pose_sub = rospy.Subscriber(f"~{prefix}set_pose", Pose2DMsg, self._on_set_pose, queue_size=1)

    def _on_cmd_vel(self, msg: Twist) -> None:
        try:
            twist = twist_from_msg(msg)
        except InvalidInputError as err:
            rospy.logwarn_throttle(5.0, f"{self.who}ignoring cmd_vel: {err}")
            return
        with self._node.lock:
            self.robot.set_command(twist.v, twist.omega)
            now = self._node.fleet.time
        if self.gate is not None:
            self.gate.on_command(now, moving=twist.v != 0.0 or twist.omega != 0.0)

    def _on_lockstep_switch(self, switch: LockstepSwitch) -> None:
        topic = self.cmd_sub.resolved_name
        if not switch.free:
            rospy.loginfo(
                f"{self.who}lockstep again from sim time {switch.sim_time:.3f} s: a command on {topic} after "
                f"{switch.silent_s:.1f} s (wall) of free running"
            )
        elif switch.publishers > 0 and not switch.moving:
            # a controller idle after a stop: the robot stands still, nobody is driven blind
            rospy.loginfo(
                f"{self.who}lockstep released while stopped: time runs freely from sim time {switch.sim_time:.3f} s; "
                f"the last command on {topic} was a stop, none for {switch.silent_s:.1f} s (wall; ~lockstep_timeout)"
            )
        elif switch.publishers > 0:
            rospy.logwarn(
                f"{self.who}{FREE_RUN_LOG} {switch.sim_time:.3f} s: {switch.publishers} connected "
                f"publisher(s) of {topic} silent for {switch.silent_s:.1f} s (wall; ~lockstep_stall_timeout)"
            )
        else:
            rospy.logwarn(
                f"{self.who}{FREE_RUN_LOG} {switch.sim_time:.3f} s: no publisher on {topic} and no "
                f"command for {switch.silent_s:.1f} s (wall; ~lockstep_timeout)"
            )

    def _on_set_pose(self, msg: Pose2DMsg) -> None:
        try:
            pose = Pose2D(msg.x, msg.y, msg.theta)
            with self._node.lock:
                self.robot.teleport(pose)
        except InvalidInputError as err:
            rospy.logwarn_throttle(5.0, f"{self.who}ignoring set_pose: {err}")
            return
        rospy.loginfo(f"{self.who}robot teleported to ({pose.x:.2f}, {pose.y:.2f}, {pose.yaw:.2f})")


class SimulatorNode:
    """Wires a :class:`MultiRobotSimulator` to ROS topics; :meth:`spin` runs the stepping loop until shutdown."""

    def __init__(self, config: SimulatorNodeConfig) -> None:
        self.config = config
        names = config.robot_names()
        starts = config.robots or (config.start,)
        self.fleet = MultiRobotSimulator(load_world(config.world), config.sim, starts, names)
        self.lock = threading.Lock()
        self._odom_every = _rate_divisor(config.sim.physics_rate, config.odom_rate, "odom_rate")
        self._clock_every = _rate_divisor(config.sim.physics_rate, config.clock_rate, "clock_rate")
        self._joints_every = _rate_divisor(config.sim.physics_rate, config.joint_states_rate, "joint_states_rate")
        # no Nagle on the lockstep round trip (clock out, command back): the last small message before a pause
        # must not wait for the peer's delayed ACK
        self._clock_pub = rospy.Publisher("clock", Clock, queue_size=10, tcp_nodelay=True)
        self._tf = tf2_ros.TransformBroadcaster() if config.publish_tf else None
        self._robots = [
            _RobotPorts(self, robot, f"{name}/" if name else "")
            for robot, name in zip(self.fleet.robots, names, strict=True)
        ]
        self._box_sub = rospy.Subscriber("~add_box", Marker, self._on_add_box, queue_size=10)
        self._unheard_goals = [
            UnheardGoalWarning("simulator", (f"{name}/" if name else "") + "move_base_simple/goal") for name in names
        ]
        self._set_own_time = _own_the_clock()
        self._clock_sent = -math.inf  # sim time of the last /clock published

    def _on_add_box(self, msg: Marker) -> None:
        """Add a box obstacle at run time: a CUBE marker's pose (world frame) and scale (full sizes, m)."""
        pose = msg.pose
        if msg.type != Marker.CUBE:
            rospy.logwarn_throttle(5.0, f"simulator: ~add_box: ignoring a marker of type {msg.type}, not CUBE")
            return
        box = Box(
            msg.ns or f"box_{msg.id}",
            pose.position.x,
            pose.position.y,
            pose.position.z if pose.position.z else msg.scale.z / 2.0,
            pose_from_msg(pose).yaw,
            msg.scale.x,
            msg.scale.y,
            msg.scale.z,
        )
        try:
            with self.lock:
                self.fleet.add_box(box)
        except InvalidInputError as err:
            rospy.logwarn_throttle(5.0, f"simulator: ~add_box: {err}")
            return
        rospy.loginfo(f"simulator: added box {box.name!r} at ({box.x:.2f}, {box.y:.2f})")

    def _publish_state(self) -> None:
        cfg = self.config
        with self.lock:
            now = self.fleet.time
            states = [(r.robot.odometry(), r.robot.ground_truth(), r.robot.ground_truth_twist()) for r in self._robots]
        transforms = []
        for ports, (odom, truth, truth_twist) in zip(self._robots, states, strict=True):
            # Odometry messages only for listeners: the navigation stack reads the pose from tf, and with several
            # robots a message per robot and stream at odom_rate is built for nobody otherwise.
            if ports.odom_pub.get_num_connections() > 0:
                ports.odom_pub.publish(
                    odometry_msg(
                        odom.pose,
                        Twist2D(odom.v, odom.omega),
                        now,
                        frame_id=ports.odom_frame,
                        child_frame_id=ports.base_frame,
                    )
                )
            transforms.append(transform_stamped(odom.pose, now, ports.odom_frame, ports.base_frame))
            if ports.truth_pub.get_num_connections() > 0:
                ports.truth_pub.publish(
                    odometry_msg(
                        truth, truth_twist, now, frame_id=cfg.ground_truth_frame, child_frame_id=ports.base_frame
                    )
                )
        if self._tf is not None:
            # one /tf message for every robot: each message costs every tf listener a deserialisation
            self._tf.sendTransform(transforms)

    def _publish_joints(self) -> None:
        with self.lock:
            now = self.fleet.time
            wheels = [ports.robot.wheels() for ports in self._robots]
        for ports, w in zip(self._robots, wheels, strict=True):
            ports.joints_pub.publish(
                joint_state_msg(WHEEL_JOINTS, (w.left_angle, w.right_angle), (w.left_rate, w.right_rate), now)
            )

    def step(self) -> None:
        """One physics step and whatever publications fall due at its end."""
        with self.lock:
            scans = self.fleet.step()
            steps, now = self.fleet.steps, self.fleet.time
            contacts = [ports.robot.contacts.events for ports in self._robots]
        for ports, events in zip(self._robots, contacts, strict=True):
            if events != ports.contact_events:
                ports.contact_events = events
                ports.contacts_pub.publish(UInt32(data=events))
        if steps % self._clock_every == 0:
            self._publish_clock(now)
        if steps % self._odom_every == 0:
            self._publish_state()
        if steps % self._joints_every == 0:
            self._publish_joints()
        for ports, scan in zip(self._robots, scans, strict=True):
            if scan is not None:
                ports.scan_pub.publish(laser_scan_msg(scan, ports.scan_frame))

    def _publish_clock(self, now: float) -> None:
        self._clock_pub.publish(clock_msg(now))
        self._set_own_time(to_ros_time(now))
        self._clock_sent = now

    def _blocking_gate(self) -> LockstepGate | None:
        """In lockstep, the gate of a robot whose controller the simulation must wait for (None: step on)."""
        now = self.fleet.time
        return next((p.gate for p in self._robots if p.gate is not None and not p.gate.may_step(now)), None)

    def spin(self) -> None:
        """Step until shutdown, paced by ``real_time_factor`` against the wall clock and, in lockstep, held
        within one control period of every robot's last command."""
        rtf = self.config.real_time_factor
        self._publish_clock(self.fleet.time)
        wall_start, sim_start = time.monotonic(), self.fleet.time
        while not rospy.is_shutdown():
            gate = self._blocking_gate()
            if gate is not None:
                if self._clock_sent != self.fleet.time:
                    # The controllers tick on sim time: the instant the simulation waits at must reach them even
                    # when it falls between two /clock ticks (clock_rate below physics_rate), or no command comes.
                    self._publish_clock(self.fleet.time)
                # bounded wait so shutdown is noticed; the wall clock stands still for pacing meanwhile
                waited_from = time.monotonic()
                gate.wait_for_command(self.fleet.time, 0.1)
                wall_start += time.monotonic() - waited_from
                continue
            try:
                self.step()
            except rospy.ROSException:
                # Shutdown (from a signal, in another thread) closed the publishers under this step; the
                # shutdown flag may still be on its way when the topic is already closed.
                if rospy.is_shutdown() or rospy.core.is_shutdown_requested():
                    return
                raise
            if rtf > 0.0:
                ahead = (self.fleet.time - sim_start) / rtf - (time.monotonic() - wall_start)
                if ahead > 0.0:
                    time.sleep(ahead)
                elif ahead < -_MAX_LAG:
                    # The machine cannot keep this rate: carry on from here rather than bursting to catch up.
                    wall_start, sim_start = time.monotonic(), self.fleet.time
            # Flat out (rtf 0) there is no sleep at all: the interpreter's switch interval (5 ms) already lets
            # the cmd_vel and publisher threads run, and yielding every step measured 40 % slower.
