"""map_server files: reading (thresholds, negate, modes, P2/P5), writing, round trips, and clear errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from mrs_nav.errors import MapFileError
from mrs_nav.maps.map_io import load_map, save_map
from mrs_nav.maps.occupancy_grid import OCCUPIED, UNKNOWN, OccupancyGrid
from mrs_nav.maps.rasterize import main as rasterize_main
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world

REPO = Path(__file__).resolve().parents[3]


def _write(tmp_path: Path, yaml_text: str, pgm: bytes, name: str = "m") -> Path:
    (tmp_path / f"{name}.pgm").write_bytes(pgm)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml_text)
    return path


def test_round_trip_of_a_non_square_map_keeps_values_resolution_and_origin(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    values = rng.choice(np.array([0, OCCUPIED, UNKNOWN], dtype=np.int8), size=(7, 13))
    grid = OccupancyGrid(values, 0.025, (-3.25, 1.5, 0.1))
    first = load_map(save_map(grid, tmp_path / "a.yaml"))
    second = load_map(save_map(first, tmp_path / "b.yaml"))
    for loaded in (first, second):
        assert np.array_equal(loaded.values, values)
        assert loaded.resolution == 0.025
        assert loaded.origin == (-3.25, 1.5, 0.1)


@pytest.mark.parametrize(
    ("resolution", "origin"),
    [(5e-2, (1e-05, -2.0, 1e5)), (1e-4, (-1e7, 1e7, -3.0)), (1e3, (1e-300, 5e-324, 1e-05))],
)
def test_saved_numbers_read_back_exactly_and_as_floats_in_yaml_1_1(
    tmp_path: Path, resolution: float, origin: tuple[float, float, float]
) -> None:
    grid = OccupancyGrid(np.array([[0, OCCUPIED]], dtype=np.int8), resolution, origin)
    path = save_map(grid, tmp_path / "m.yaml")
    loaded = load_map(path)
    assert (loaded.resolution, loaded.origin) == (resolution, origin)
    assert np.array_equal(loaded.values, grid.values)
    meta = yaml.safe_load(path.read_text())  # PyYAML's YAML 1.1, as rosparam reads it: 1e-05 would be text
    assert meta["resolution"] == resolution
    assert meta["origin"] == list(origin)


def test_origin_with_exponent_numbers_is_read(tmp_path: Path) -> None:
    path = _write(tmp_path, "image: m.pgm\nresolution: 5e-2\norigin: [5e-2, -1E+2, 0]\n", b"P5\n1 1\n255\n\x00")
    assert load_map(path).origin == (0.05, -100.0, 0.0)


@pytest.mark.parametrize("name", ["a: b", "#1", "[x]", "it's", "&a", "é", "line\nbreak"])
def test_any_file_name_round_trips(tmp_path: Path, name: str) -> None:
    grid = OccupancyGrid(np.array([[0, OCCUPIED]], dtype=np.int8), 0.05)
    assert np.array_equal(load_map(save_map(grid, tmp_path / f"{name}.yaml")).values, grid.values)


@pytest.mark.parametrize(("resolution", "origin"), [(1e-30, (0, 0, 0)), (2e3, (0, 0, 0)), (0.05, (1e300, 0, 0))])
def test_a_grid_no_map_file_can_hold_is_not_written(
    tmp_path: Path, resolution: float, origin: tuple[float, float, float]
) -> None:
    grid = OccupancyGrid(np.zeros((2, 2), dtype=np.int8), resolution, origin)
    with pytest.raises(MapFileError, match=r"m\.yaml: (resolution|origin)"):
        save_map(grid, tmp_path / "m.yaml")
    assert list(tmp_path.iterdir()) == []


def test_a_target_that_is_a_folder_leaves_both_files_as_they_were(tmp_path: Path) -> None:
    (tmp_path / "d.yaml").mkdir()
    (tmp_path / "d.pgm").write_bytes(b"earlier")
    grid = OccupancyGrid(np.zeros((2, 2), dtype=np.int8), 0.05)
    with pytest.raises(MapFileError, match=r"d\.yaml: cannot write map: not a regular file"):
        save_map(grid, tmp_path / "d.yaml")
    assert (tmp_path / "d.pgm").read_bytes() == b"earlier"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.pgm", "d.yaml"]


def test_an_unwritable_folder_leaves_nothing_behind(tmp_path: Path) -> None:
    (tmp_path / "d.pgm").write_bytes(b"earlier")
    grid = OccupancyGrid(np.zeros((2, 2), dtype=np.int8), 0.05)
    with pytest.raises(MapFileError, match=r"d\.yaml: cannot write map: "):
        save_map(grid, tmp_path / "d.pgm" / "d.yaml")  # a file where the folder should be
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.pgm"]


def test_image_top_row_is_the_largest_y_and_thresholds_apply(tmp_path: Path) -> None:
    # 2 x 2 image: top row (y = 1) [black, white], bottom row (y = 0) [grey 205, grey 100]
    pgm = b"P5\n2 2\n255\n" + bytes([0, 254, 205, 100])
    path = _write(
        tmp_path,
        "image: m.pgm\nresolution: 1.0\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
        pgm,
    )
    grid = load_map(path)
    # p = (255 - v) / 255: 205 -> 0.196 (unknown), 100 -> 0.61 (unknown), 0 -> 1 (occupied), 254 -> free
    assert grid.values.tolist() == [[UNKNOWN, UNKNOWN], [OCCUPIED, 0]]


def test_negate_scale_mode_and_ascii_pgm(tmp_path: Path) -> None:
    pgm = b"P2\n# comment\n3 1\n255\n0 128 255\n"
    path = _write(
        tmp_path,
        "image: m.pgm\nresolution: 0.1\norigin: [1, 2, 0]\nnegate: 1\nmode: scale\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n",
        pgm,
    )
    grid = load_map(path)
    # negate: p = v / 255 -> 0 free, 0.502 scaled to 99 (0.502 - 0.196) / 0.454 = 67, 1.0 occupied
    assert grid.values.tolist() == [[0, 67, OCCUPIED]]


def test_shipped_course_map_is_what_the_rasteriser_makes_now() -> None:
    shipped = load_map(REPO / "maps" / "simple.yaml")
    made = rasterize_world(load_world(REPO / "worlds" / "simple.world"), 0.05)
    assert np.array_equal(shipped.values, made.values), (
        "regenerate: python -m mrs_nav.maps.rasterize worlds/simple.world maps/simple.yaml"
    )
    assert shipped.origin == pytest.approx(made.origin)
    assert shipped.resolution == made.resolution
    # the inner faces of the walls at +-2 m and the cylinder r = 0.3 at (0.3, 0.2)
    assert shipped.is_free([[1.97, 0.0], [-1.97, 0.0], [0.0, 1.97], [0.3, 0.54]]).all()
    assert shipped.is_occupied([[2.03, 0.0], [0.0, -2.03], [0.3, 0.2], [0.3, 0.48], [0.58, 0.2]]).all()


@pytest.mark.parametrize(
    ("yaml_text", "message"),
    [
        ("image: m.pgm\nresolution: [0.05\n", "malformed YAML"),
        ("- just\n- a list\n", "expected a YAML mapping"),
        ("resolution: 0.05\norigin: [0, 0, 0]\n", "missing or empty key 'image'"),
        ("image: m.pgm\norigin: [0, 0, 0]\n", "missing key 'resolution'"),
        ("image: m.pgm\nresolution: -1\norigin: [0, 0, 0]\n", r"resolution must be 0.0001 \.\. 1000 m"),
        ("image: m.pgm\nresolution: 1e-300\norigin: [0, 0, 0]\n", r"resolution must be 0.0001 \.\. 1000 m"),
        ("image: m.pgm\nresolution: 1e300\norigin: [0, 0, 0]\n", r"resolution must be 0.0001 \.\. 1000 m"),
        ("image: m.pgm\nresolution: 0.05\norigin: [1e300, 0, 0]\n", r"origin x and y must be within \+-1e\+07 m"),
        ("image: m.pgm\nresolution: 0.05\norigin: [0, -2e7, 0]\n", r"origin x and y must be within \+-1e\+07 m"),
        ('image: "\\0"\nresolution: 0.05\norigin: [0, 0, 0]\n', "key 'image' holds a NUL byte"),
        ("image: m.pgm\nresolution: 0.05\norigin: [0, 0]\n", "origin must be a list of three"),
        ("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 2\n", "negate must be 0 or 1"),
        ("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nmode: fancy\n", "mode must be one of"),
        ("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 0.9\n", "free_thresh <= occupied_thresh"),
        ("image: other.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", "other.pgm: cannot read map image"),
    ],
)
def test_malformed_yaml_names_the_file_and_the_problem(tmp_path: Path, yaml_text: str, message: str) -> None:
    path = _write(tmp_path, yaml_text, b"P5\n1 1\n255\n\x00")
    with pytest.raises(MapFileError, match=message) as info:
        load_map(path)
    assert str(tmp_path) in str(info.value)


@pytest.mark.parametrize(
    ("pgm", "message"),
    [
        (b"P6\n1 1\n255\n\x00\x00\x00", "not a PGM image"),
        (b"P5\n4 4\n255\n\x00\x00", "truncated"),
        (b"P2\n2 1\n255\n0 x\n", "must be integers 0 .. 255, got 'x'"),
        (b"P2\n2 1\n255\n0 -5\n", "must be integers 0 .. 255, got '-5'"),
        (b"P2\n1 1\n255\n4294967296\n", "got '4294967296'"),  # would wrap to 0 in int32
        (b"P2\n2 1\n100\n0 200\n", "exceed maxval"),
        (b"", "not a PGM image"),
    ],
)
def test_malformed_pgm_names_the_image(tmp_path: Path, pgm: bytes, message: str) -> None:
    path = _write(tmp_path, "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", pgm)
    with pytest.raises(MapFileError, match=message) as info:
        load_map(path)
    assert "m.pgm" in str(info.value)


def test_missing_yaml_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(MapFileError, match=r"nope\.yaml: cannot read map description"):
        load_map(tmp_path / "nope.yaml")


def test_rasterize_command_writes_the_map_and_refuses_bad_options_in_one_line(tmp_path, capsys) -> None:
    world = str(REPO / "worlds" / "simple.world")
    assert rasterize_main([world, str(tmp_path / "m.yaml")]) == 0
    assert np.array_equal(load_map(tmp_path / "m.yaml").values, load_map(REPO / "maps" / "simple.yaml").values)
    for bad in (["--resolution", "nan"], ["--resolution", "0"], ["--margin", "-1"], ["--nope"], []):
        assert rasterize_main([*bad, world, str(tmp_path / "x.yaml")] if bad else []) == 1, bad
        err = capsys.readouterr().err.strip()
        assert err.startswith("ERROR: python -m mrs_nav.maps.rasterize: "), err
        assert "\n" not in err
    assert not (tmp_path / "x.yaml").exists()
