"""Rigid-body physics of the robot among a world's static obstacles, with the Open Dynamics Engine.

The robot is three bodies: a chassis (an upright cylinder of the footprint radius, clear of the ground, with a
frictionless caster sphere at the back) and two wheel spheres on hinge joints driven by velocity motors with a
torque limit. The world's boxes and cylinders become static ODE geoms; a plane is the ground. Contacts use
ODE's friction pyramid scaled by the normal force (``Approx1``), so a wheel slips when the motor asks for more
traction than friction gives, and the odometry (read from the hinges) shows it.

The python3-pyode traps (wrong joint and contact constants, swallowed callback errors, geoms destroyed with
their Python object) are handled by :mod:`mrs_nav.sim.ode_bindings` and by keeping every geom referenced here.

``dWorldStep`` (the exact big-matrix solver) is used rather than ``quickStep``: for three bodies it is as fast,
it converges fully, and it draws no random numbers (quickStep reorders constraints with ODE's global random
generator), so two simulations built alike step identically.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import ode

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import Box, World
from mrs_nav.sim.ode_bindings import (
    CONTACT_APPROX1,
    CONTACT_SOFT_CFM,
    CONTACT_SOFT_ERP,
    PARAM_FMAX,
    PARAM_VEL,
    collide_spaces,
)
from mrs_nav.sim.robot import BurgerParams

GRAVITY = 9.81  # m/s^2
_CONTACT_ERP = 0.8
_CONTACT_CFM = 1e-5


def _rotation_z(yaw: float) -> tuple[float, ...]:
    """Row-major 3x3 rotation by ``yaw`` about z, as ODE takes it."""
    c, s = math.cos(yaw), math.sin(yaw)
    return (c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)


@dataclass(frozen=True)
class WheelState:
    """Hinge angles (rad, unbounded is not guaranteed: ODE wraps them to [-pi, pi]) and rates (rad/s)."""

    left_angle: float
    right_angle: float
    left_rate: float
    right_rate: float


class Physics:
    """An ODE world holding one Burger-like robot and a :class:`World`'s static obstacles."""

    def __init__(self, world: World, params: BurgerParams, start: Pose2D) -> None:
        self.params = params
        self._world = ode.World()
        self._world.setGravity((0.0, 0.0, -GRAVITY))
        self._world.setERP(0.2)
        self._world.setCFM(1e-6)
        self._contacts = ode.JointGroup()
        # Spaces: the robot's geoms, the ground, the obstacles (which the laser casts against alone).
        self._robot_space = ode.SimpleSpace()
        self._ground_space = ode.SimpleSpace()
        self.obstacle_space = ode.HashSpace()
        self._ground = ode.GeomPlane(self._ground_space, (0.0, 0.0, 1.0), 0.0)
        self._obstacles: dict[Any, str] = {}
        self._touched: set[str] = set()
        self._add_obstacles(world)
        self._build_robot(start)
        touching = self._touching_obstacles()
        if touching:
            raise InvalidInputError(
                f"start pose ({start.x:.3f}, {start.y:.3f}) of a robot of radius {params.footprint_radius} m "
                f"overlaps {', '.join(sorted(touching))} in world {world.name!r}"
            )

    # -- construction -------------------------------------------------------------------------------------------

    def _add_obstacles(self, world: World) -> None:
        for box in world.boxes:
            self.add_box(box)
        for cyl in world.cylinders:
            geom = ode.GeomCylinder(self.obstacle_space, cyl.radius, cyl.length)  # axis along z
            geom.setPosition((cyl.x, cyl.y, cyl.z))
            self._obstacles[geom] = cyl.name

    def add_box(self, box: Box) -> None:
        """Put a static box into the world (the laser sees it from the next scan)."""
        geom = ode.GeomBox(self.obstacle_space, (box.size_x, box.size_y, box.size_z))
        geom.setPosition((box.x, box.y, box.z))
        geom.setRotation(_rotation_z(box.yaw))
        self._obstacles[geom] = box.name

    def _build_robot(self, start: Pose2D) -> None:
        p = self.params
        rotation = _rotation_z(start.yaw)
        c, s = math.cos(start.yaw), math.sin(start.yaw)

        def world_point(x: float, y: float, z: float) -> tuple[float, float, float]:
            return (start.x + c * x - s * y, start.y + s * x + c * y, z)

        self._chassis_z = p.chassis_clearance + p.chassis_height / 2.0
        self.chassis = ode.Body(self._world)
        mass = ode.Mass()
        mass.setCylinderTotal(p.chassis_mass, 3, p.footprint_radius, p.chassis_height)
        self.chassis.setMass(mass)
        self.chassis.setPosition(world_point(p.com_x, 0.0, self._chassis_z))
        self.chassis.setRotation(rotation)
        self._chassis_geom = ode.GeomCylinder(self._robot_space, p.footprint_radius, p.chassis_height)
        self._chassis_geom.setBody(self.chassis)
        self._chassis_geom.setOffsetPosition((-p.com_x, 0.0, 0.0))
        self._caster_geom = ode.GeomSphere(self._robot_space, p.caster_radius)
        self._caster_geom.setBody(self.chassis)
        self._caster_geom.setOffsetPosition((p.caster_x - p.com_x, 0.0, p.caster_radius - self._chassis_z))

        self._wheel_bodies: list[Any] = []
        self._wheel_geoms: list[Any] = []
        self._hinges: list[Any] = []
        for side in (1.0, -1.0):  # left (+y) first, then right
            anchor = world_point(0.0, side * p.wheel_separation / 2.0, p.wheel_radius)
            body = ode.Body(self._world)
            wmass = ode.Mass()
            wmass.setSphereTotal(p.wheel_mass, p.wheel_radius)
            body.setMass(wmass)
            body.setPosition(anchor)
            body.setRotation(rotation)
            geom = ode.GeomSphere(self._robot_space, p.wheel_radius)
            geom.setBody(body)
            hinge = ode.HingeJoint(self._world)
            # Rate is body1 relative to body2: with (chassis, wheel) and axis -y (in the body frame) a positive
            # rate rolls the robot forward.
            hinge.attach(self.chassis, body)
            hinge.setAnchor(anchor)
            hinge.setAxis((s, -c, 0.0))
            hinge.setParam(PARAM_FMAX, p.wheel_torque_limit)
            hinge.setParam(PARAM_VEL, 0.0)
            self._wheel_bodies.append(body)
            self._wheel_geoms.append(geom)
            self._hinges.append(hinge)
        self._surface = {
            self._chassis_geom: p.body_friction,
            self._caster_geom: p.caster_friction,
            self._wheel_geoms[0]: p.wheel_friction,
            self._wheel_geoms[1]: p.wheel_friction,
        }

    # -- stepping -----------------------------------------------------------------------------------------------

    def _touching_obstacles(self) -> set[str]:
        names: set[str] = set()

        def note(g1: Any, g2: Any) -> None:
            if ode.collide(g1, g2):
                names.add(self._obstacles.get(g1) or self._obstacles[g2])

        collide_spaces(self._robot_space, self.obstacle_space, note)
        return names

    def _join(self, g1: Any, g2: Any, contacts: list[Any], mu: float) -> None:
        for contact in contacts:
            contact.setMode(CONTACT_SOFT_ERP | CONTACT_SOFT_CFM | CONTACT_APPROX1)
            contact.setMu(mu)
            contact.setSoftERP(_CONTACT_ERP)
            contact.setSoftCFM(_CONTACT_CFM)
            joint = ode.ContactJoint(self._world, self._contacts, contact)
            joint.attach(g1.getBody(), g2.getBody())

    def _near_ground(self, g1: Any, g2: Any) -> None:
        contacts = ode.collide(g1, g2)
        if contacts:
            # Each robot part has its own grip on the floor: rubber wheels, a frictionless caster.
            self._join(g1, g2, contacts, self._surface.get(g1, self._surface.get(g2, 0.0)))

    def _near_obstacle(self, g1: Any, g2: Any) -> None:
        contacts = ode.collide(g1, g2)
        if contacts:
            self._touched.add(self._obstacles.get(g1) or self._obstacles[g2])
            self._join(g1, g2, contacts, self.params.body_friction)

    def step(self, left_rate: float, right_rate: float, dt: float) -> set[str]:
        """Drive the wheel motors at ``left_rate``/``right_rate`` (rad/s) for ``dt`` s.

        Returns the names of the obstacles the robot touched during the step (empty if none).
        """
        self._hinges[0].setParam(PARAM_VEL, left_rate)
        self._hinges[1].setParam(PARAM_VEL, right_rate)
        self._touched = set()
        collide_spaces(self._robot_space, self._ground_space, self._near_ground)
        collide_spaces(self._robot_space, self.obstacle_space, self._near_obstacle)
        self._world.step(dt)
        self._contacts.empty()
        return self._touched

    # -- state --------------------------------------------------------------------------------------------------

    def pose(self) -> Pose2D:
        """True planar pose of ``base_footprint`` in the world frame."""
        x, y, _ = self.chassis.getRelPointPos((-self.params.com_x, 0.0, 0.0))
        r = self.chassis.getRotation()
        return Pose2D(x, y, math.atan2(r[3], r[0]))

    def twist(self) -> tuple[float, float]:
        """True (forward speed m/s, yaw rate rad/s) of the chassis, in its own frame."""
        vx, vy, _ = self.chassis.getRelPointVel((-self.params.com_x, 0.0, 0.0))
        yaw = self.pose().yaw
        return (vx * math.cos(yaw) + vy * math.sin(yaw), self.chassis.getAngularVel()[2])

    def move_robot(self, pose: Pose2D) -> None:
        """Teleport the robot, at rest, so that ``base_footprint`` is at ``pose`` (the kidnapped-robot test).

        Every body is moved by the same planar rigid motion, so the wheels keep their hinge angles and the wheel
        odometry sees no motion at all. A pose overlapping an obstacle raises InvalidInputError and leaves the
        robot where it was.
        """
        before = self.pose()
        motion = pose.compose(before.inverse())

        def apply(m: Pose2D) -> None:
            turn = _rotation_z(m.yaw)
            c, s = math.cos(m.yaw), math.sin(m.yaw)
            for body in (self.chassis, *self._wheel_bodies):
                x, y, z = body.getPosition()
                body.setPosition((m.x + c * x - s * y, m.y + s * x + c * y, z))
                r = body.getRotation()
                body.setRotation(
                    tuple(sum(turn[3 * i + k] * r[3 * k + j] for k in range(3)) for i in range(3) for j in range(3))
                )
                body.setLinearVel((0.0, 0.0, 0.0))
                body.setAngularVel((0.0, 0.0, 0.0))

        apply(motion)
        touching = self._touching_obstacles()
        if touching:
            apply(motion.inverse())
            raise InvalidInputError(
                f"pose ({pose.x:.3f}, {pose.y:.3f}) of a robot of radius {self.params.footprint_radius} m overlaps "
                f"{', '.join(sorted(touching))}"
            )

    def height(self) -> float:
        """Height (m) of the chassis centre: stays near its start unless the robot climbs or sinks."""
        return float(self.chassis.getPosition()[2])

    def wheels(self) -> WheelState:
        left, right = self._hinges
        return WheelState(left.getAngle(), right.getAngle(), left.getAngleRate(), right.getAngleRate())

    def obstacle_names(self) -> Iterable[str]:
        return self._obstacles.values()
