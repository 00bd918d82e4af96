"""The files users name: inputs read as regular files only, bounded in size, text as UTF-8, YAML with YAML 1.2's
numbers; outputs checked writable before the work.

A path to a device (``/dev/zero``), a FIFO or a huge file would otherwise be read without end or block in
``open``; each reader here refuses it with one line naming the file, before reading. PyYAML implements YAML 1.1,
which reads ``1e-05`` or ``5e-2`` (an exponent without a dot) as text; ROS 1 tools (map_server's yaml-cpp,
rosparam) and Python's own ``repr`` produce and accept such numbers, so :func:`load_yaml` reads them as floats.
Logs too large to hold are streamed instead: :func:`check_regular` before opening them, and
:func:`bounded_lines` so that a file without line breaks is not read into one endless line.
"""

from __future__ import annotations

import functools
import re
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from mrs_nav.errors import InvalidInputError, MrsNavError

_EXPONENT_FLOAT = re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$")


@functools.cache
def _yaml12_loader() -> Any:
    """PyYAML's safe loader with YAML 1.2's float forms (digits with an exponent and no dot). Built on first use:
    the remote monitor installs without PyYAML and reads no YAML."""
    import yaml  # noqa: PLC0415

    class Yaml12Loader(yaml.SafeLoader):  # type: ignore[misc]  # PyYAML ships no stubs here
        pass

    Yaml12Loader.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+0123456789."))
    return Yaml12Loader


def yaml12_number(value: Any) -> Any:
    """``value``, or the float it stands for when it is text in YAML 1.2's exponent form: a ROS parameter given
    on the command line (``_rate:=1e1``) reaches a node as the text ``"1e1"``, since rospy reads it as YAML 1.1."""
    if isinstance(value, str) and _EXPONENT_FLOAT.match(value.strip()):
        return float(value.replace("_", ""))
    return value


# A description written by hand or by a tool (world, map, obstacles, config, golden file) is kilobytes.
DESCRIPTION_LIMIT = 16 << 20


def check_regular(path: Path, what: str, error: type[MrsNavError] = InvalidInputError) -> int:
    """The size of ``path`` when it is a regular file; otherwise ``error`` naming ``path`` and ``what``."""
    try:
        info = path.stat()
    except OSError as err:
        raise error(f"{path}: cannot read {what}: {err.strerror or err}") from err
    except ValueError:  # the OS takes no NUL in a path; Python says so with a bare ValueError
        raise error(f"{path!r}: cannot read {what}: the name holds a NUL byte") from None
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{path}: cannot read {what}: not a regular file")
    return info.st_size


def bounded_lines(
    handle: IO[str], limit: int, where: str, error: type[MrsNavError] = InvalidInputError
) -> Iterator[str]:
    """The lines of ``handle``, each at most ``limit`` characters with its line break; a longer one raises
    ``error`` naming ``where:number`` before more of it is read."""
    number = 0
    while line := handle.readline(limit + 1):
        number += 1
        if len(line) > limit:
            raise error(f"{where}:{number}: line longer than {limit} characters")
        yield line


def read_regular(path: Path, limit: int, what: str, error: type[MrsNavError] = InvalidInputError) -> bytes:
    """The bytes of ``path`` when it is a regular file of at most ``limit`` bytes; otherwise ``error`` with one
    line naming ``path`` and ``what`` it was read as."""
    size = check_regular(path, what, error)
    if size > limit:
        raise error(f"{path}: {what} is {size} bytes, above the limit of {limit}")
    try:
        with path.open("rb") as f:
            data = f.read(limit + 1)
    except OSError as err:
        raise error(f"{path}: cannot read {what}: {err.strerror or err}") from err
    if len(data) > limit:  # it grew after the stat
        raise error(f"{path}: {what} is above the limit of {limit} bytes")
    return data


def read_text(path: Path, limit: int, what: str, error: type[MrsNavError] = InvalidInputError) -> str:
    """:func:`read_regular` decoded as UTF-8."""
    try:
        return read_regular(path, limit, what, error).decode("utf-8")
    except UnicodeDecodeError as err:
        raise error(f"{path}: cannot read {what}: not UTF-8 text (byte {err.start})") from None


def load_yaml(text: str, where: str, error: type[MrsNavError] = InvalidInputError) -> Any:
    """``text`` parsed as YAML (safe types, YAML 1.2 floats); ``error`` names ``where`` on malformed input."""
    import yaml  # noqa: PLC0415 - see _yaml12_loader

    try:
        return yaml.load(text, Loader=_yaml12_loader())  # a SafeLoader subclass: safe types only
    except yaml.YAMLError as err:
        raise error(f"{where}: malformed YAML: {' '.join(str(err).split())}") from None
    except RecursionError:
        raise error(f"{where}: malformed YAML: nested too deeply") from None


def check_writable(path: Path, what: str, *, folder: bool = False) -> Path:
    """``path`` when an output can be written there (a folder, created now, or a file in one); else an error.

    Checked before the work so that an unwritable ``--out`` or ``--png`` fails at once, not after a long run.
    A scratch file is really created (and removed): permission bits alone say nothing for root or odd file
    systems such as /proc.
    """
    target = path if folder else path.parent
    if not folder and path.is_dir():
        raise InvalidInputError(f"{what}: {path} is a folder, expected a file name")
    if not folder and (path.is_fifo() or path.is_socket()):  # writing would wait for a reader, maybe for ever
        raise InvalidInputError(f"{what}: {path} is a FIFO or a socket, expected a file name")
    if not folder and path.exists() and not path.is_file():  # a device: outputs are renamed over their name
        raise InvalidInputError(f"{what}: {path} is a device, expected a file name")
    try:
        target.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=target):
            pass
    except (FileExistsError, NotADirectoryError):
        raise InvalidInputError(f"{what}: cannot write into {target}: a file is in the way of that folder") from None
    except OSError as err:
        raise InvalidInputError(f"{what}: cannot write into {target}: {err.strerror}") from None
    return path
