"""Running one ``mrs-nav`` command under attack and recording what it left: its exit code, its output, and the
sha256 and wholeness of every file in its work folder before and after.

Each run is a forked child of the test process: the commands' modules are already imported there (cheap), the
child may enter a mount namespace of its own (a tiny or read-only tmpfs, an immutable file, seen by nobody
else) and drop root's right to ignore permission bits, and the signal handlers ``main`` installs die with it.
The files on such a tmpfs vanish with the child, so the child itself records them before it exits.
"""

from __future__ import annotations

import contextlib
import ctypes
import hashlib
import importlib
import json
import os
import subprocess
import sys
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.rosbag1 import Reader

from mrs_nav.cli.main import build_parser, main
from mrs_nav.maps.map_io import load_map

CLONE_NEWNS = 0x00020000
# CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH, CAP_FOWNER: without them root obeys permission bits as a user does.
_DAC_CAPS = (1 << 1) | (1 << 2) | (1 << 3)
_CAP_V3 = 0x20080522


class StagingError(Exception):
    """The attack cannot be staged on this machine (no mount namespace, no chattr)."""


@dataclass(frozen=True)
class Disk:
    """A tmpfs at ``WORK/disk``: ``size`` (e.g. ``64k``), then filled, then its paths in ``immutable`` made
    immutable (``chattr +i``), remounted read-only, and root's permission override dropped, as asked."""

    size: str = "1m"
    fill: bool = False
    read_only: bool = False
    immutable: tuple[str, ...] = ()
    closed: tuple[str, ...] = ()  # folders made mode 0555, with root's override dropped for the run


@dataclass(frozen=True)
class Run:
    code: int
    out: str
    err: str
    before: dict[str, str]
    after: dict[str, str]
    whole: dict[str, bool] = field(default_factory=dict)


def warm() -> None:
    """Import in the test process what the commands import on their way (parsers, drawing), so that each
    forked child starts with them loaded instead of paying for them again."""
    build_parser()
    for name in ("mrs_nav.figures.tree_drawing", "mrs_nav.figures.potential_field", "mrs_nav.figures.rrt"):
        importlib.import_module(name)


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def files(work: Path) -> dict[str, str]:
    """Every regular file under ``work`` (symbolic links as ``->target``), by path relative to it."""
    found: dict[str, str] = {}
    for path in sorted(work.rglob("*")):
        name = str(path.relative_to(work))
        if path.is_symlink():
            found[name] = f"->{os.readlink(path)}"
        elif path.is_file():
            found[name] = sha256(path)
    return found


def is_whole(path: Path) -> bool:
    """Whether ``path`` is a complete file of its kind (an image with its end chunk, a bag that reads through)."""
    data = path.read_bytes()
    suffix = path.suffix
    if suffix == ".png":
        return data.startswith(b"\x89PNG") and data.endswith(b"IEND\xaeB`\x82")
    if suffix == ".json":
        json.loads(data)
        return True
    if suffix == ".bag":
        with Reader(path) as reader:
            return sum(1 for _ in reader.messages()) > 0
    if suffix == ".yaml":
        load_map(path)  # and the image it names
        return True
    if suffix in (".csv", ".md"):
        return data.endswith(b"\n")
    return len(data) > 0


def _check(call: int, what: str) -> None:
    if call != 0:
        raise StagingError(f"{what}: {os.strerror(ctypes.get_errno())}")


def _drop_dac_override() -> None:
    libc = ctypes.CDLL(None, use_errno=True)

    class Header(ctypes.Structure):
        _fields_ = [("version", ctypes.c_uint32), ("pid", ctypes.c_int)]

    class Data(ctypes.Structure):
        _fields_ = [("effective", ctypes.c_uint32), ("permitted", ctypes.c_uint32), ("inheritable", ctypes.c_uint32)]

    header, data = Header(_CAP_V3, 0), (Data * 2)()
    _check(libc.capget(ctypes.byref(header), data), "capget")
    data[0].effective &= ~_DAC_CAPS
    data[0].permitted &= ~_DAC_CAPS
    _check(libc.capset(ctypes.byref(header), data), "capset")


def _sh(*command: str) -> None:
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise StagingError(f"{' '.join(command)}: {result.stderr.strip()}")


def _stage(work: Path, disk: Disk, setup: Callable[[Path], None]) -> None:
    folder = work / "disk"
    folder.mkdir()
    libc = ctypes.CDLL(None, use_errno=True)
    _check(libc.unshare(CLONE_NEWNS), "unshare(CLONE_NEWNS)")
    _sh("mount", "--make-rprivate", "/")
    _sh("mount", "-t", "tmpfs", "-o", f"size={disk.size}", "tmpfs", str(folder))
    setup(work)
    if disk.fill:
        with (folder / "filler").open("wb", buffering=0) as filler, contextlib.suppress(OSError):
            while True:  # until the disk is full
                filler.write(b"\0" * 4096)
    for name in disk.immutable:
        _sh("chattr", "+i", str(work / name))
    for name in disk.closed:
        (work / name).chmod(0o555)
    if disk.read_only:
        _sh("mount", "-o", "remount,ro", str(folder))
    if disk.closed:
        _drop_dac_override()


def _child(work: Path, argv: list[str], disk: Disk | None, setup: Callable[[Path], None]) -> dict[str, Any]:
    try:
        if disk is None:
            setup(work)
        else:
            _stage(work, disk, setup)
    except StagingError as why:
        return {"skipped": str(why)}
    before = files(work)
    out, err = work.parent / "stdout", work.parent / "stderr"
    with out.open("w") as sys.stdout, err.open("w") as sys.stderr:
        os.dup2(sys.stdout.fileno(), 1)
        os.dup2(sys.stderr.fileno(), 2)
        os.chdir(work)
        try:
            code = main(argv)
        except BaseException:
            traceback.print_exc()
            code = 99
        sys.stdout.flush()
        sys.stderr.flush()
    after = files(work)
    whole = {}
    for name, digest in after.items():
        if name not in before or before[name] != digest:
            try:
                whole[name] = is_whole(work / name)
            except Exception:
                whole[name] = False
    return {
        "code": code,
        "out": out.read_text(errors="replace"),
        "err": err.read_text(errors="replace"),
        "before": before,
        "after": after,
        "whole": whole,
    }


def run(work: Path, argv: list[str], disk: Disk | None = None, setup: Callable[[Path], None] = lambda _: None) -> Run:
    """``mrs-nav ARGV`` run in ``work`` (its current folder) by a forked child, after ``setup(work)`` and the
    staging of ``disk``; what it printed and left."""
    report = work.parent / "report.json"
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        try:
            report.write_text(json.dumps(_child(work, argv, disk, setup)))
        except BaseException:
            report.write_text(json.dumps({"crashed": traceback.format_exc()}))
        finally:
            os._exit(0)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0, "the child running the command died"
    result = json.loads(report.read_text())
    assert "crashed" not in result, result.get("crashed")
    if "skipped" in result:
        raise StagingError(result["skipped"])
    return Run(**result)
