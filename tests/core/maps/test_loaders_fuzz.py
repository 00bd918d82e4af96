"""Property-based fuzzing of the world and map loaders: any input gives a result or the loader's domain error.

Inputs are built from the shapes of real files with hostile values in every field (non-numbers, ``0_2``, NaN,
huge, far, vertical planes, floating boxes) and then mutated byte by byte. The property is the contract of
every loader: a :class:`~mrs_nav.errors.MrsNavError` naming the file, or a result within the stated limits;
never another exception. Examples are bounded and derandomised (tests/conftest.py's profile).
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrs_nav.errors import MapFileError, MrsNavError, WorldFileError
from mrs_nav.limits import MAX_COORDINATE_M, MAX_GRID_CELLS, MAX_SHAPES, MAX_SIZE_M
from mrs_nav.maps.map_io import load_map
from mrs_nav.maps.rasterize import raster_frame, rasterize_world
from mrs_nav.maps.world import World, parse_world
from tests.core.fuzzing import attempt

# Tokens a careless user or an attacker puts where a number belongs.
HOSTILE_NUMBERS = st.sampled_from(
    ["0", "1", "-1", "0.5", "0_2", "1e308", "-1e308", "1e400", "nan", "inf", "-inf", "1e7", "1e-300", "", "x",
     "0x10", "1,5", "\u0661", "2.5e3", "999", "-0", "+3", ".5", "5."]
)  # fmt: skip
SANE_NUMBERS = st.floats(-20, 20, allow_nan=False).map(lambda v: f"{v:.3f}")
NUMBERS = st.one_of(SANE_NUMBERS, HOSTILE_NUMBERS)


def numbers(count: int) -> st.SearchStrategy[str]:
    return st.lists(NUMBERS, min_size=count - 1, max_size=count + 1).map(" ".join)


@st.composite
def shapes(draw: st.DrawFn) -> str:
    kind = draw(st.sampled_from(["box", "cylinder", "plane", "sphere", "mesh", ""]))
    if kind == "box":
        inner = f"<size>{draw(numbers(3))}</size>"
    elif kind == "cylinder":
        inner = f"<radius>{draw(NUMBERS)}</radius><length>{draw(NUMBERS)}</length>"
    elif kind == "plane":
        normal = draw(st.sampled_from(["0 0 1", "1 0 0", "0 1 0", "0 0 -1", "0 0 0", "nan 0 1", "0.1 0 1"]))
        inner = f"<normal>{normal}</normal><size>100 100</size>"
    else:
        inner = ""
    return f"<{kind}>{inner}</{kind}>" if kind else ""


@st.composite
def sdf_worlds(draw: st.DrawFn) -> str:
    models = []
    for i in range(draw(st.integers(0, 4))):
        pose = f"<pose>{draw(numbers(6))}</pose>" if draw(st.booleans()) else ""
        static = draw(st.sampled_from(["<static>true</static>", "<static>1</static>", "", "<static>no</static>"]))
        collisions = "".join(
            f"<collision name='c{j}'>{draw(st.sampled_from(['', f'<pose>{draw(numbers(6))}</pose>']))}"
            f"<geometry>{draw(shapes())}</geometry></collision>"
            for j in range(draw(st.integers(0, 2)))
        )
        models.append(f"<model name='m{i}'>{static}{pose}<link name='l'>{collisions}</link></model>")
    extra = draw(st.sampled_from(["", "<include><uri>model://sun</uri></include>", "<light/>", "<actor/>"]))
    return f"<sdf version='1.6'><world name='w'>{extra}{''.join(models)}</world></sdf>"


def mutate(text: str, edits: list[tuple[int, str]]) -> str:
    for position, replacement in edits:
        at = position % (len(text) + 1)
        text = text[:at] + replacement + text[at + 1 :]
    return text


EDITS = st.lists(st.tuples(st.integers(0, 10_000), st.sampled_from(["<", ">", "/", "'", "\x00", "&", " ", "9", ""])))


def _check_world(world: World) -> None:
    assert len(world.boxes) + len(world.cylinders) <= MAX_SHAPES
    for box in world.boxes:
        assert max(abs(box.x), abs(box.y)) <= MAX_COORDINATE_M
        assert min(box.size_x, box.size_y, box.size_z) > 0.0
        assert max(box.size_x, box.size_y) <= MAX_SIZE_M
    assert all(math.isfinite(v) for v in world.bounds())
    # The rasteriser refuses what it cannot hold before allocating; what it accepts is within the cell limit.
    try:
        _, _, width, height = raster_frame(world, 0.05)
    except MrsNavError:
        return
    assert width * height <= MAX_GRID_CELLS
    if width * height <= 200_000:
        rasterize_world(world, 0.05)


@given(sdf_worlds())
@settings(max_examples=300)
def test_any_world_loads_or_fails_with_a_world_file_error(text: str) -> None:
    world = attempt(lambda: parse_world(text, "fuzz.world"), WorldFileError)
    if isinstance(world, str):
        assert world.startswith("fuzz.world: <")  # names the file and the element
        return
    _check_world(world)


@given(sdf_worlds(), EDITS)
@settings(max_examples=200)
def test_mutated_worlds_load_or_fail_with_a_world_file_error(text: str, edits: list[tuple[int, str]]) -> None:
    world = attempt(lambda: parse_world(mutate(text, edits), "fuzz.world"), WorldFileError)
    if isinstance(world, str):
        assert world.startswith("fuzz.world:")
        return
    _check_world(world)


def test_deeply_nested_xml_is_a_world_file_error() -> None:
    with pytest.raises(WorldFileError, match=r"fuzz\.world"):
        parse_world("<sdf>" + "<a>" * 100_000 + "</a>" * 100_000 + "</sdf>", "fuzz.world")


# ---- map_server maps -------------------------------------------------------------------------------------------

YAML_VALUES = st.sampled_from(
    ["0.05", "5e-2", "5E-2", "-0.05", "0", ".nan", ".inf", "1e400", "'0.05'", "[]", "{}", "null", "true", "0_2",
     "1e-300", "[0, 0, 0]", "[0, 0]", "[.nan, 0, 0]", "[1e308, 1e308, 0]", "!!binary aGk=", "*x", "&x 1"]
)  # fmt: skip
IMAGES = st.sampled_from(["m.pgm", "/dev/zero", "/dev/urandom", "/dev/null", ".", "missing.pgm", "", "m.yaml"])


@st.composite
def map_descriptions(draw: st.DrawFn) -> str:
    lines = [f"image: {draw(IMAGES)}"]
    modes = st.sampled_from(["trinary", "raw", "x"])
    keys = ("resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
    lines += [f"{key}: {draw(modes if key == 'mode' else YAML_VALUES)}" for key in keys if draw(st.integers(0, 5))]
    return "\n".join(draw(st.permutations(lines)))


@st.composite
def pgm_images(draw: st.DrawFn) -> bytes:
    magic = draw(st.sampled_from([b"P5", b"P2", b"P6", b"P5x"]))
    width, height = draw(st.sampled_from([b"3", b"0", b"-1", b"99999999", b"9" * 5000, b"2"])), b"2"
    maxval = draw(st.sampled_from([b"255", b"65535", b"0", b"70000", b"1"]))
    body = draw(st.binary(max_size=40))
    if magic == b"P2":
        body = b" ".join(draw(st.lists(st.sampled_from([b"0", b"255", b"-5", b"99999999999", b"x"]), max_size=8)))
    return magic + b"\n" + width + b" " + height + b"\n" + maxval + b"\n" + body


@given(map_descriptions(), pgm_images(), EDITS)
@settings(max_examples=300)
def test_any_map_loads_or_fails_with_a_map_file_error(
    tmp_path_factory: pytest.TempPathFactory, description: str, image: bytes, edits: list[tuple[int, str]]
) -> None:
    folder = tmp_path_factory.mktemp("map")
    (folder / "m.pgm").write_bytes(image)
    path = folder / "m.yaml"
    path.write_text(mutate(description, edits[:2]), encoding="utf-8")
    grid = attempt(lambda: load_map(path), MapFileError)
    if isinstance(grid, str):
        assert grid.startswith((str(folder), "/dev/", ".:")), grid  # names the file at fault
        return
    assert grid.width * grid.height <= MAX_GRID_CELLS
    assert grid.resolution > 0.0


def test_map_resolution_written_as_5e_minus_2_is_read(tmp_path: Path) -> None:
    (tmp_path / "m.pgm").write_bytes(b"P5\n2 2\n255\n\xfe\xfe\x00\xfe")
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 5e-2\norigin: [0, 0, 0]\n")
    assert load_map(tmp_path / "m.yaml").resolution == 0.05


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom"])
def test_map_image_must_be_a_regular_file(tmp_path: Path, device: str) -> None:
    (tmp_path / "m.yaml").write_text(f"image: {device}\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(MapFileError, match=f"{device}: cannot read map image: not a regular file"):
        load_map(tmp_path / "m.yaml")


def test_map_image_dimensions_are_checked_before_reading_pixels(tmp_path: Path) -> None:
    (tmp_path / "m.pgm").write_bytes(b"P5\n100000 100000\n255\n\x00")
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(MapFileError, match="exceeds the limit of 2e\\+07 cells"):
        load_map(tmp_path / "m.yaml")
