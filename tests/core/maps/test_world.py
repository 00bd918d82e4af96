"""World-file loading: the course arena and the errors users see for what cannot be simulated."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from mrs_nav.errors import WorldFileError
from mrs_nav.maps.world import load_world, parse_world


def _sdf(models: str) -> str:
    return f'<sdf version="1.6"><world name="w">{models}</world></sdf>'


def test_course_arena_has_walls_at_two_metres_and_the_cylinder(simple_world: Path) -> None:
    world = load_world(simple_world)
    (cyl,) = world.cylinders
    assert (cyl.x, cyl.y, cyl.radius) == pytest.approx((0.3, 0.2, 0.3))
    inner = {
        round(
            min(
                abs(c)
                for c in (b.x - b.size_x / 2, b.x + b.size_x / 2, b.y - b.size_y / 2, b.y + b.size_y / 2)
                if abs(c) > 1e-9
            ),
            6,
        )
        for b in world.boxes
    }
    assert inner == {2.0}
    assert len(world.boxes) == 4


def test_model_link_and_collision_poses_compose() -> None:
    text = _sdf(
        '<model name="m"><static>true</static><pose>1 0 0 0 0 1.5707963267948966</pose>'
        '<link name="l"><pose>1 0 0 0 0 0</pose>'
        '<collision name="c"><pose>0 1 0 0 0 0</pose>'
        "<geometry><box><size>1 2 1</size></box></geometry></collision></link></model>"
    )
    (box,) = parse_world(text).boxes
    # model at (1,0) turned 90 deg: link offset (1,0) -> (0,1); collision offset (0,1) in the link -> (-1,0)
    assert (box.x, box.y) == pytest.approx((0.0, 1.0))
    assert box.yaw == pytest.approx(math.pi / 2)


@pytest.mark.parametrize(
    ("body", "named"),
    [
        (
            '<model name="m"><static>true</static><link name="l"><collision name="c"><geometry>'
            "<mesh><uri>x.dae</uri></mesh></geometry></collision></link></model>",
            "geometry/mesh",
        ),
        (
            '<model name="m"><link name="l"><collision name="c"><geometry><box><size>1 1 1</size></box>'
            "</geometry></collision></link></model>",
            "model[m]/static",
        ),
        (
            '<model name="m"><static>true</static><link name="l"><collision name="c"><geometry><box>'
            "<size>1 -1 1</size></box></geometry></collision></link></model>",
            "geometry/box",
        ),
        ('<model name="m"><static>true</static><pose>0 0 0 0.3 0 0</pose></model>', "model[m]/pose"),
        (
            '<model name="m"><static>true</static><link name="l"><collision name="c"><geometry><cylinder>'
            "<radius>a</radius><length>1</length></cylinder></geometry></collision></link></model>",
            "radius",
        ),
        ("<include><uri>model://bookshelf</uri></include>", "include[model://bookshelf]"),
        ("<actor name='a'/>", "<actor>"),
    ],
)
def test_unsupported_or_malformed_elements_are_named(body: str, named: str) -> None:
    with pytest.raises(WorldFileError, match=r"bad\.world: .*" + named.replace("[", r"\[").replace("]", r"\]")):
        parse_world(_sdf(body), "bad.world")


def test_malformed_xml_and_missing_file_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(WorldFileError, match=r"broken\.world: malformed XML"):
        parse_world("<sdf><world>", "broken.world")
    with pytest.raises(WorldFileError, match=r"nothing\.world: cannot read"):
        load_world(tmp_path / "nothing.world")
    # a device was read without end, and binary text was a decoding traceback's message
    with pytest.raises(WorldFileError, match=r"^/dev/zero: cannot read world file: not a regular file$"):
        load_world("/dev/zero")
    (tmp_path / "binary.world").write_bytes(b"<sdf>\xff")
    with pytest.raises(WorldFileError, match=r"binary\.world: cannot read world file: not UTF-8 text \(byte 5\)$"):
        load_world(tmp_path / "binary.world")


def _box(pose: str = "0 0 0.25 0 0 0", size: str = "1 1 0.5") -> str:
    return _sdf(
        f'<model name="b"><static>true</static><pose>{pose}</pose><link name="l">'
        f'<collision name="c"><geometry><box><size>{size}</size></box></geometry></collision></link></model>'
    )


@pytest.mark.parametrize(
    ("text", "message"),
    [
        # a vertical plane is a wall the simulator would not have
        (
            _sdf(
                '<model name="p"><static>true</static><link name="l"><collision name="c"><geometry><plane>'
                "<normal>1 0 0</normal></plane></geometry></collision></link></model>"
            ),
            r"<model\[p\]/link\[l\]/collision\[c\]/geometry/plane/normal>: only a ground plane",
        ),
        # a box floating far above the robot is no obstacle; one sunk below the ground neither
        (_box(pose="0 0 10 0 0 0"), "spans z = 9.75 .. 10.25 m, which misses the robot"),
        (_box(pose="0 0 -1 0 0 0"), "which misses the robot"),
        # Python's float() reads "0_2" as 2; SDF has no such number
        (_box(size="0_2 1 1"), r"geometry/box/size>: expected 3 numbers, got '0_2 1 1'"),
        (_box(size="1 1 1e7"), "sizes must be positive and at most 1000 m"),
        (_box(pose="1e7 0 0.25 0 0 0"), "is more than 1000 m from the origin"),
    ],
)
def test_what_the_simulator_cannot_honour_is_refused_by_name(text: str, message: str) -> None:
    with pytest.raises(WorldFileError, match=message):
        parse_world(text, "w.world")


def test_more_shapes_than_the_limit_are_refused() -> None:
    boxes = "".join(
        f'<collision name="c{i}"><pose>{i % 100} {i // 100} 0.25 0 0 0</pose>'
        "<geometry><box><size>0.5 0.5 0.5</size></box></geometry></collision>"
        for i in range(2001)
    )
    text = _sdf(f'<model name="many"><static>true</static><link name="l">{boxes}</link></model>')
    with pytest.raises(WorldFileError, match="more than 2000 boxes and cylinders"):
        parse_world(text, "w.world")
