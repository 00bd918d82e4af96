"""``mrs-nav figures``: Figures 1-7, 9 and 10 written as PNGs, the same bytes for the same seed."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrs_nav.cli.main import main


def test_figures_are_written_and_deterministic(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["figures", "--out", str(tmp_path / "a"), "--seed", "3"]) == 0
    listed = capsys.readouterr().out.split()
    assert main(["figures", "--out", str(tmp_path / "b"), "--seed", "3"]) == 0
    first = sorted((tmp_path / "a").glob("*.png"))
    numbers = sorted(int(p.name[6:].split("_")[0]) for p in first)
    assert numbers == [1, 2, 3, 4, 5, 6, 7, 9, 10]
    assert sorted(listed) == sorted(str(p) for p in first)
    for png in first:
        data = png.read_bytes()
        assert data.startswith(b"\x89PNG")
        assert data == (tmp_path / "b" / png.name).read_bytes(), png.name
