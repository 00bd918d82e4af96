"""Outputs are checked writable before any work: a folder, a FIFO or a file in the way is one error line."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.textfiles import check_writable


def test_a_fifo_as_an_output_file_is_refused(tmp_path: Path) -> None:
    # the write at the end of a run would block until someone read the FIFO
    fifo = tmp_path / "out.png"
    os.mkfifo(fifo)
    with pytest.raises(InvalidInputError, match=r"^--png: .*out\.png is a FIFO or a socket, expected a file name$"):
        check_writable(fifo, "--png")


def test_a_file_in_the_way_of_the_folder_is_named(tmp_path: Path) -> None:
    (tmp_path / "plain").write_text("x")
    for path, folder in ((tmp_path / "plain" / "out.png", False), (tmp_path / "plain" / "sub", True)):
        with pytest.raises(InvalidInputError, match=r"plain.*: a file is in the way of that folder$"):
            check_writable(path, "--out", folder=folder)


def test_a_file_in_a_new_folder_is_writable(tmp_path: Path) -> None:
    path = tmp_path / "new" / "out.png"
    assert check_writable(path, "--png") == path
    assert path.parent.is_dir()
    assert list(path.parent.iterdir()) == []  # the scratch file is gone
