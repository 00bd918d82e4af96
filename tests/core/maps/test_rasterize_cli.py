"""``python -m mrs_nav.maps.rasterize WORLD OUT.yaml``: map_server files of a world, and bad outputs refused first."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from mrs_nav.maps.map_io import load_map
from mrs_nav.maps.rasterize import main, rasterize_world
from mrs_nav.maps.world import load_world
from mrs_nav.resources import WORLDS_DIR

WORLD = WORLDS_DIR / "simple.world"


def test_the_written_map_is_the_rasterised_world(tmp_path: Path) -> None:
    assert main([str(WORLD), str(tmp_path / "simple.yaml"), "--resolution", "0.1"]) == 0
    written = load_map(tmp_path / "simple.yaml")
    assert np.array_equal(written.values, rasterize_world(load_world(WORLD), 0.1).values)


@pytest.mark.parametrize(
    ("out", "message"),
    [
        ("plain/map.yaml", "OUT: cannot write into .*plain: a file is in the way of that folder"),
        ("map.png", r"map\.png: a map description must end in \.yaml"),
    ],
)
def test_an_output_that_cannot_be_written_is_one_line_before_the_work(
    out: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "plain").write_text("x")
    assert main([str(WORLD), str(tmp_path / out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("ERROR: ")
    assert re.search(message, err[0])
