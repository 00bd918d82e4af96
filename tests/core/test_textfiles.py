"""Files handed over by name: devices, FIFOs, oversized and non-UTF-8 files are one error line; YAML reads
YAML 1.2's exponent numbers as floats."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from mrs_nav.errors import InvalidInputError, MapFileError
from mrs_nav.textfiles import bounded_lines, check_regular, load_yaml, read_regular, read_text


def test_a_device_is_refused_before_it_is_read() -> None:
    with pytest.raises(InvalidInputError, match=r"^/dev/zero: cannot read config: not a regular file$"):
        read_regular(Path("/dev/zero"), 100, "config")


def test_a_fifo_is_refused_without_blocking_on_open(tmp_path: Path) -> None:
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(MapFileError, match="not a regular file"):
        read_text(fifo, 100, "map description", MapFileError)


def test_a_file_over_the_limit_and_a_binary_file_are_refused(tmp_path: Path) -> None:
    big = tmp_path / "big"
    big.write_bytes(b"x" * 101)
    with pytest.raises(InvalidInputError, match="is 101 bytes, above the limit of 100"):
        read_regular(big, 100, "config")
    binary = tmp_path / "bin"
    binary.write_bytes(b"ok\x96")
    with pytest.raises(InvalidInputError, match=r"bin: cannot read config: not UTF-8 text \(byte 2\)$"):
        read_text(binary, 100, "config")
    with pytest.raises(InvalidInputError, match="missing: cannot read config: No such file"):
        read_text(tmp_path / "missing", 100, "config")
    with pytest.raises(InvalidInputError, match="cannot read config: the name holds a NUL byte"):
        read_text(tmp_path / "a\0b", 100, "config")


def test_yaml_reads_exponents_without_a_dot_as_floats() -> None:
    values = load_yaml("origin: [1e-05, -2.0, 0]\nrate: 5e-2\nbig: 1E+300\nword: 1e\nint: 10\nplain: 0.5", "m.yaml")
    assert values == {"origin": [1e-05, -2.0, 0], "rate": 0.05, "big": 1e300, "word": "1e", "int": 10, "plain": 0.5}
    assert isinstance(values["int"], int)


def test_malformed_yaml_names_the_file() -> None:
    with pytest.raises(InvalidInputError, match=r"^m.yaml: malformed YAML: "):
        load_yaml("a: [1, 2", "m.yaml")
    with pytest.raises(InvalidInputError, match="nested too deeply"):
        load_yaml("[" * 100_000, "m.yaml")


def test_a_line_past_the_limit_is_refused_before_the_rest_is_read(tmp_path: Path) -> None:
    log = tmp_path / "log"
    log.write_text("short\n" + "x" * 10_000)
    with log.open() as handle:
        lines = bounded_lines(handle, 100, str(log))
        assert next(lines) == "short\n"
        with pytest.raises(InvalidInputError, match=r"log:2: line longer than 100 characters$"):
            next(lines)
        assert handle.tell() <= len("short\n") + 101
    assert check_regular(log, "log") == 10_006
