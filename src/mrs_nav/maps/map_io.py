"""map_server map files: a ``.yaml`` description plus a ``.pgm`` image, read and written.

Reading follows map_server: the image's top row is the largest y; a pixel's occupancy is
``p = (255 - v) / 255`` (``p = v / 255`` when ``negate`` is 1), scaled to the image's maxval. In ``trinary``
mode (the default) ``p > occupied_thresh`` gives 100, ``p < free_thresh`` gives 0, anything else -1 (unknown);
``scale`` mode keeps ``99 * (p - free_thresh) / (occupied_thresh - free_thresh)`` between the thresholds;
``raw`` mode takes the pixel value as the cell value. Writing follows map_saver: free 254, occupied 0,
unknown 205, with ``occupied_thresh 0.65`` and ``free_thresh 0.196``, so that a saved trinary grid reads back
identical. Only PGM images (binary P5 or ASCII P2) are read.

Both directions hold a map to a resolution of :data:`~mrs_nav.limits.MIN_MAP_RESOLUTION_M` ..
:data:`~mrs_nav.limits.MAX_MAP_RESOLUTION_M` and an origin within :data:`~mrs_nav.limits.MAX_MAP_ORIGIN_M` of the
frame, so that every map written here reads back. Numbers are written as floats that YAML 1.1 readers (PyYAML,
rosparam) read as floats too, and the two files are written beside their targets and then renamed into place, so
a failure leaves neither half-written.
"""

from __future__ import annotations

import contextlib
import json
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from mrs_nav.atomic_write import atomic_path
from mrs_nav.errors import InvalidInputError, MapFileError, OutputFileError
from mrs_nav.limits import (
    MAX_IMAGE_BYTES,
    MAX_MAP_ORIGIN_M,
    MAX_MAP_RESOLUTION_M,
    MIN_MAP_RESOLUTION_M,
    check_grid_cells,
)
from mrs_nav.maps.occupancy_grid import FREE_MAX, OCCUPIED, OCCUPIED_MIN, UNKNOWN, OccupancyGrid
from mrs_nav.textfiles import check_writable, load_yaml, read_regular, read_text

_SAVE_FREE, _SAVE_OCCUPIED, _SAVE_UNKNOWN = 254, 0, 205
_MODES = ("trinary", "scale", "raw")
# A map description holds a handful of keys; anything this large is not one.
_MAX_YAML_BYTES = 1 << 20


def _number(meta: dict[str, Any], key: str, where: Path, default: float | None = None) -> float:
    if key not in meta:
        if default is None:
            raise MapFileError(f"{where}: missing key {key!r}")
        return default
    value = meta[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise MapFileError(f"{where}: {key} must be a finite number, got {value!r}")
    return float(value)


def _check_geometry(resolution: float, origin: Sequence[float], where: Path) -> None:
    if not MIN_MAP_RESOLUTION_M <= resolution <= MAX_MAP_RESOLUTION_M:
        raise MapFileError(
            f"{where}: resolution must be {MIN_MAP_RESOLUTION_M:g} .. {MAX_MAP_RESOLUTION_M:g} m per cell, "
            f"got {resolution:g}"
        )
    if not (abs(origin[0]) <= MAX_MAP_ORIGIN_M and abs(origin[1]) <= MAX_MAP_ORIGIN_M):
        raise MapFileError(
            f"{where}: origin x and y must be within +-{MAX_MAP_ORIGIN_M:g} m, got {origin[0]:g}, {origin[1]:g}"
        )


def _yaml_string(text: str) -> str:
    """``text`` as a YAML scalar: plain, as map_saver writes names, when YAML reads that back as the same text;
    otherwise double-quoted (a JSON string is one), so that a name holding ': ', '#', a newline, or reading as a
    number or a boolean (``1e5``, ``yes``) reads back too."""
    try:
        if load_yaml(f"image: {text}", "image") == {"image": text}:
            return text
    except InvalidInputError:
        pass
    return json.dumps(text)


def _yaml_float(value: float) -> str:
    """``value`` as a YAML float for 1.1 readers too: ``repr`` writes ``1e-05``, which YAML 1.1 reads as text, so
    the mantissa gets a dot (``1.0e-05``)."""
    text = repr(float(value))
    return text if "." in text else text.replace("e", ".0e")


def read_pgm(path: Path) -> npt.NDArray[np.int32]:
    """Pixels of a PGM image (P5 binary or P2 ASCII, maxval up to 65535) as ``(rows, cols)`` ints, top row first.

    The array is scaled to 0..255 when maxval differs from 255.
    """
    data = read_regular(path, MAX_IMAGE_BYTES, "map image", MapFileError)
    # Header: magic, width, height, maxval, separated by whitespace, with # comments; one whitespace byte ends it.
    # At most 9 digits per number: Python refuses to convert thousands of digits, and no valid size needs more.
    header = re.match(
        rb"(P[25])((?:\s+|#[^\n]*\n)+)(\d{1,9})((?:\s+|#[^\n]*\n)+)(\d{1,9})((?:\s+|#[^\n]*\n)+)(\d{1,9})\s", data
    )
    if header is None:
        raise MapFileError(f"{path}: not a PGM image (expected a P5 or P2 header)")
    magic, width, height, maxval = header.group(1), int(header.group(3)), int(header.group(5)), int(header.group(7))
    if width < 1 or height < 1 or not 0 < maxval < 65536:
        raise MapFileError(f"{path}: bad PGM size {width}x{height} or maxval {maxval}")
    try:
        check_grid_cells(width, height, f"{path}: PGM size")
    except InvalidInputError as err:
        raise MapFileError(str(err)) from None
    body = data[header.end() :]
    count = width * height
    if magic == b"P5":
        dtype = np.dtype(">u2") if maxval > 255 else np.dtype(np.uint8)
        if len(body) < count * dtype.itemsize:
            raise MapFileError(
                f"{path}: PGM is truncated: {len(body)} bytes of pixels, expected {count * dtype.itemsize}"
            )
        pixels = np.frombuffer(body, dtype=dtype, count=count).astype(np.int32)
    else:
        # Only digits: numpy would read "-5" and wrap 4294967296 to 0 in int32, both then passing as pixels.
        # Six digits are more than any maxval (65535) needs.
        bad = re.search(rb"\S*(?:[^\s\d]|\d{6})\S*", body)
        if bad is not None:
            token = bad.group()[:20].decode(errors="replace")
            raise MapFileError(f"{path}: PGM (P2) pixels must be integers 0 .. {maxval}, got {token!r}")
        pixels = np.array(body.split(), dtype=np.int32)
        if pixels.size != count:
            raise MapFileError(f"{path}: PGM has {pixels.size} pixels, expected {count}")
    if np.any(pixels > maxval):
        raise MapFileError(f"{path}: PGM pixel values exceed maxval {maxval}")
    if maxval != 255:
        pixels = np.rint(pixels * (255.0 / maxval)).astype(np.int32)
    return pixels.reshape(height, width)


def map_image(path: Path) -> Path:
    """The image file the map description at ``path`` names (an input of whatever reads the map)."""
    return _image_path(_parse_yaml(path), path)


def _image_path(meta: dict[str, Any], path: Path) -> Path:
    image = meta.get("image")
    if not isinstance(image, str) or not image:
        raise MapFileError(f"{path}: missing or empty key 'image'")
    if "\0" in image:  # no file name holds one; the OS would refuse the path with a bare ValueError
        raise MapFileError(f"{path}: key 'image' holds a NUL byte")
    return Path(image) if Path(image).is_absolute() else path.parent / image


def _parse_yaml(path: Path) -> dict[str, Any]:
    meta = load_yaml(read_text(path, _MAX_YAML_BYTES, "map description", MapFileError), str(path), MapFileError)
    if not isinstance(meta, dict):
        raise MapFileError(f"{path}: expected a YAML mapping with image, resolution and origin")
    return meta


def load_map(path: str | Path) -> OccupancyGrid:
    """Load a map_server map from its ``.yaml`` file; errors name the file."""
    path = Path(path)
    meta = _parse_yaml(path)
    image_path = _image_path(meta, path)
    resolution = _number(meta, "resolution", path)
    origin = meta.get("origin")
    if (
        not isinstance(origin, list)
        or len(origin) != 3
        or not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in origin)
    ):
        raise MapFileError(f"{path}: origin must be a list of three finite numbers [x, y, yaw], got {origin!r}")
    _check_geometry(resolution, origin, path)
    negate = meta.get("negate", 0)
    if negate not in (0, 1) or isinstance(negate, float):
        raise MapFileError(f"{path}: negate must be 0 or 1, got {negate!r}")
    occupied_thresh = _number(meta, "occupied_thresh", path, 0.65)
    free_thresh = _number(meta, "free_thresh", path, 0.196)
    if not 0.0 <= free_thresh <= occupied_thresh <= 1.0:
        raise MapFileError(
            f"{path}: need 0 <= free_thresh <= occupied_thresh <= 1, got {free_thresh}, {occupied_thresh}"
        )
    mode = meta.get("mode", "trinary")
    if mode not in _MODES:
        raise MapFileError(f"{path}: mode must be one of {', '.join(_MODES)}, got {mode!r}")
    pixels = read_pgm(image_path)[::-1]  # image top row is the largest y; grid row 0 is the smallest
    if mode == "raw":
        values = np.where(pixels > OCCUPIED, UNKNOWN, pixels)
    else:
        p = pixels / 255.0 if negate else (255 - pixels) / 255.0
        values = np.full(pixels.shape, UNKNOWN, dtype=np.int32)
        values[p > occupied_thresh] = OCCUPIED
        values[p < free_thresh] = 0
        if mode == "scale" and occupied_thresh > free_thresh:
            between = (p >= free_thresh) & (p <= occupied_thresh)
            values[between] = np.rint(99.0 * (p[between] - free_thresh) / (occupied_thresh - free_thresh))
    try:
        return OccupancyGrid(values.astype(np.int8), resolution, (float(origin[0]), float(origin[1]), float(origin[2])))
    except InvalidInputError as err:
        raise MapFileError(f"{path}: {err}") from err


def map_targets(path: Path, what: str = "") -> tuple[Path, Path]:
    """The ``.yaml`` at ``path`` and the ``.pgm`` beside it that :func:`save_map` writes; MapFileError when ``path``
    does not end in ``.yaml`` or either target is something a file cannot replace (a folder). Given ``what`` (the
    option naming ``path``), both are also checked writable now, before the work that makes the map."""
    if path.suffix != ".yaml":
        raise MapFileError(f"{path}: a map description must end in .yaml")
    image_path = path.with_suffix(".pgm")
    for target in (path, image_path):
        if target.exists() and not target.is_file():
            raise MapFileError(f"{target}: cannot write map: not a regular file")
    if what:
        for target in (path, image_path):
            check_writable(target, what)
    return path, image_path


def save_map(
    grid: OccupancyGrid,
    path: str | Path,
    *,
    occupied_min: int = OCCUPIED_MIN,
    free_max: int = FREE_MAX,
    world: str | None = None,
) -> Path:
    """Write ``grid`` as map_server files: ``path`` (``.yaml``) and the ``.pgm`` beside it; returns the yaml path.

    Cells at or above ``occupied_min`` (65) are written occupied, ``0..free_max`` (19) free, the rest unknown
    (map_saver's convention; its ``--occ`` and ``--free``). A grid whose resolution or origin a map file cannot
    hold is refused before anything is written; a failure leaves both targets as they were. ``world`` (the
    simulated world the map was made in) is kept as ``mrs_nav_world``, a key map_server ignores
    (:mod:`mrs_nav.maps.map_world`).
    """
    path, image_path = map_targets(Path(path))
    if not 0 <= free_max < occupied_min <= OCCUPIED:
        raise InvalidInputError(f"need 0 <= free ({free_max}) < occupied ({occupied_min}) <= 100")
    _check_geometry(grid.resolution, grid.origin, path)
    pixels = np.full(grid.values.shape, _SAVE_UNKNOWN, dtype=np.uint8)
    pixels[(grid.values >= 0) & (grid.values <= free_max)] = _SAVE_FREE
    pixels[grid.values >= occupied_min] = _SAVE_OCCUPIED
    header = f"P5\n# CREATOR: mrs_nav {grid.resolution:g} m/pix\n{grid.width} {grid.height}\n255\n".encode()
    meta = (
        f"image: {_yaml_string(image_path.name)}\n"
        f"resolution: {_yaml_float(grid.resolution)}\n"
        f"origin: [{', '.join(_yaml_float(v) for v in grid.origin)}]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n"
    )
    if world:
        meta += f"mrs_nav_world: {_yaml_string(world)}\n"
    try:
        # The yaml is entered first so that it is renamed last: it never names an image not yet in place.
        with contextlib.ExitStack() as stack:
            yaml_temp = stack.enter_context(atomic_path(path, "map"))
            image_temp = stack.enter_context(atomic_path(image_path, "map image"))
            image_temp.write_bytes(header + pixels[::-1].tobytes())
            yaml_temp.write_bytes(meta.encode())
    except OutputFileError as err:
        raise MapFileError(str(err)) from err
    return path
