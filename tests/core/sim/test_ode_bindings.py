"""The pyode work-arounds: errors in near-callbacks surface, and the corrected motor constants drive a hinge."""

from __future__ import annotations

import ode
import pytest

from mrs_nav.sim.ode_bindings import PARAM_FMAX, PARAM_VEL, collide_spaces


def test_an_error_in_a_near_callback_is_raised_not_swallowed() -> None:
    first, second = ode.SimpleSpace(), ode.SimpleSpace()
    geoms = [ode.GeomSphere(first, 1.0), ode.GeomSphere(second, 1.0)]  # overlapping at the origin

    def near(_g1: object, _g2: object) -> None:
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        collide_spaces(first, second, near)
    assert len(geoms) == 2  # kept referenced: a collected geom silently leaves its space


def test_corrected_constants_give_a_hinge_motor_torque() -> None:
    world = ode.World()
    base, wheel = ode.Body(world), ode.Body(world)
    for body in (base, wheel):
        mass = ode.Mass()
        mass.setSphereTotal(1.0, 0.1)
        body.setMass(mass)
    hinge = ode.HingeJoint(world)
    hinge.attach(base, wheel)
    hinge.setAnchor((0.0, 0.0, 0.0))
    hinge.setAxis((0.0, 1.0, 0.0))
    hinge.setParam(PARAM_FMAX, 1.0)
    hinge.setParam(PARAM_VEL, 2.0)
    for _ in range(10):
        world.step(0.01)
    assert hinge.getAngleRate() == pytest.approx(2.0, rel=1e-3)
