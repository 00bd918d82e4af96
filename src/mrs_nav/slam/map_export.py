"""Writing an occupancy grid in map_server format (``.yaml`` + binary ``.pgm``, trinary mode).

Pixels: 0 (black) occupied, 254 free, 205 unknown; the image's first row is the map's top (largest y).
The YAML's thresholds make map_server read the image back to the same three classes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import MapFileError


def write_map(stem: Path, occupancy: npt.NDArray[np.int8], resolution: float, origin: tuple[float, float]) -> Path:
    """Write ``stem.pgm`` and ``stem.yaml`` from ROS occupancy values (100, 0, -1); return the YAML's path."""
    image = np.full(occupancy.shape, 205, dtype=np.uint8)
    image[occupancy == 0] = 254
    image[occupancy == 100] = 0
    image = image[::-1]
    pgm, yaml = stem.with_suffix(".pgm"), stem.with_suffix(".yaml")
    header = f"P5\n# mrs_nav SLAM map, {resolution} m/cell\n{image.shape[1]} {image.shape[0]}\n255\n".encode()
    try:
        stem.parent.mkdir(parents=True, exist_ok=True)
        pgm.write_bytes(header + image.tobytes())
        yaml.write_text(
            f"image: {pgm.name}\nresolution: {resolution}\norigin: [{origin[0]:.6f}, {origin[1]:.6f}, 0.0]\n"
            "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n",
            encoding="utf-8",
        )
    except OSError as err:
        raise MapFileError(f"cannot write map {yaml}: {err}") from None
    return yaml
