"""Outputs written whole or not at all: the previous file stays until the new one is complete."""

import os

import pytest

from mrs_nav.atomic_write import atomic_path, check_not_inputs, write_text
from mrs_nav.errors import OutputFileError


def test_a_failure_while_writing_keeps_the_previous_file_and_leaves_no_partial(tmp_path):
    out = tmp_path / "out.json"
    out.write_text("previous")

    def write_half() -> None:
        with atomic_path(out) as temp:
            temp.write_text("half")
            raise RuntimeError("the writer failed")

    with pytest.raises(RuntimeError, match="the writer failed"):
        write_half()
    assert out.read_text() == "previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]


def test_the_file_a_link_names_is_replaced_and_the_link_kept(tmp_path):
    target = tmp_path / "real.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    write_text(link, "new")
    assert link.is_symlink()
    assert target.read_text() == "new"


def test_a_device_is_not_replaced():
    with pytest.raises(OutputFileError, match=r"^/dev/null: cannot write figure: not a regular file$"):
        write_text("/dev/null", "x", "figure")
    assert not os.path.isfile("/dev/null")


def test_an_output_that_is_an_input_is_refused(tmp_path):
    log = tmp_path / "c.log"
    log.write_text("data")
    os.link(log, tmp_path / "same.bag")
    check_not_inputs([("bag", tmp_path / "other.bag")], [("log", log)])
    for name in ("c.log", "same.bag", "./c.log"):
        with pytest.raises(OutputFileError, match="is the log"):
            check_not_inputs([("bag", tmp_path / name)], [("log", log)])


def test_two_outputs_under_one_name_are_refused(tmp_path):
    out = tmp_path / "out"
    outputs = [("--out file", out / "metrics.json"), ("--write-golden", tmp_path / "x" / ".." / "out" / "metrics.json")]
    with pytest.raises(OutputFileError, match=r"--write-golden .* is the --out file .*: two outputs under one name"):
        check_not_inputs(outputs, [])
    check_not_inputs([("--out file", out / "metrics.json"), ("--write-golden", out / "g.json")], [])
