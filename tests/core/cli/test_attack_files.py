"""Every file-writing command ends clean under attack: an output typed equal to an input (by another spelling, a
link, a folder that holds it), a full, tiny, read-only or closed disk, an immutable file, a device, a folder where
a file goes, and malformed inputs. Each case ends with exit 0 and its work done, or exit 1 and one ``ERROR:`` line
naming what and where; never a traceback, an input changed (sha256), a file under a final name that is not whole,
or a temporary file left behind.

The inputs are the smallest that reach each path: a 3-second cut of simple.bag, an 8-scan CARMEN log, the simple
world, a 2 m map. Disks are tmpfs mounts in a mount namespace of the forked child that runs the command
(:mod:`tests.core.cli.attack_harness`); a closed folder is one of mode 0555 with root's override dropped.
The cases named in issue 43 themselves live in ``test_output_files.py``. Not here: ``map_saver`` (it needs a ROS
master; it writes through the same ``save_map``) and ``monitor --snapshot`` (it needs a bridge; the path is checked
by the same ``check_writable`` before connecting).
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Reader, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from mrs_nav.maps.map_io import save_map
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from tests.core.bag.carmen_fixture import drive, log_lines, write_log
from tests.core.cli.attack_harness import Disk, Run, StagingError, run, warm

REPO = Path(__file__).resolve().parents[3]
SIMPLE_BAG = REPO / "tests" / "data" / "bags" / "simple.bag"
TOPICS = ("/scan", "/odom", "/tf", "/tf_static", "/clock", "/ground_truth/odom")
Setup = Callable[[Path], None]


def nothing(_work: Path) -> None:
    pass


def steps(*each: Setup) -> Setup:
    def setup(work: Path) -> None:
        for step in each:
            step(work)

    return setup


def copy(source: str, target: str) -> Setup:
    def setup(work: Path) -> None:
        (work / target).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(work / source, work / target)

    return setup


def symlink(target: str, name: str) -> Setup:
    def setup(work: Path) -> None:
        (work / name).parent.mkdir(parents=True, exist_ok=True)
        (work / name).symlink_to(target)

    return setup


def hardlink(source: str, name: str) -> Setup:
    return lambda work: (work / name).hardlink_to(work / source)


def folder(name: str) -> Setup:
    return lambda work: (work / name).mkdir(parents=True, exist_ok=True)


def text(name: str, content: str) -> Setup:
    def setup(work: Path) -> None:
        (work / name).parent.mkdir(parents=True, exist_ok=True)
        (work / name).write_text(content)

    return setup


def cut(source: str, name: str, fraction: float) -> Setup:
    def setup(work: Path) -> None:
        data = (work / source).read_bytes()
        (work / name).write_bytes(data[: int(len(data) * fraction)])

    return setup


def redefined(topic: str, change: Callable[[str], str] | None = None, md5: str = "") -> Setup:
    """in.bag rewritten as ``other.bag`` with ``topic``'s connection definition changed (and stored with the md5
    it hashes to, as a recorder of that definition would) or its md5 replaced."""

    def setup(work: Path) -> None:
        with Reader(work / "in.bag") as reader, Writer(work / "other.bag") as writer:
            out = {}
            for conn in reader.connections:
                definition, digest = conn.msgdef.data, conn.digest
                if conn.topic == topic and change is not None:
                    definition = change(definition)
                    store = get_typestore(Stores.EMPTY)
                    store.register(get_types_from_msg(definition, conn.msgtype))
                    digest = store.generate_msgdef(conn.msgtype)[1]
                    assert digest != conn.digest
                elif conn.topic == topic:
                    digest = md5
                out[conn.id] = writer.add_connection(
                    conn.topic, conn.msgtype, msgdef=definition, md5sum=digest, latching=conn.ext.latching
                )
            for conn, stamp, raw in reader.messages():
                writer.write(out[conn.id], stamp, raw)

    return setup


@dataclass(frozen=True)
class Case:
    id: str
    argv: tuple[str, ...]
    code: int  # the exit expected: 0 (work done) or 1 (refused)
    words: tuple[str, ...] = ()  # each in the ERROR line: what and where
    outputs: tuple[str, ...] = ()  # files, or folders ending in "/", the command may write (on exit 1: whole)
    made: tuple[str, ...] = ()  # files that must be there, whole, on exit 0
    disk: Disk | None = None
    setup: Setup = nothing
    refused_first: bool = False  # refused before the work: nothing on stdout

    def param(self) -> object:
        return pytest.param(self, id=self.id)


BOGUS_MD5 = "0123456789abcdef0123456789abcdef"
NO_ROOM = "No space left on device"
READ_ONLY = "Read-only file system"
DENIED = "Permission denied"
NOT_PERMITTED = "Operation not permitted"

REPLAY = ("replay", "in.bag", "--slam", "--out", "o")
REPLAY_FILES = ("metrics.json", "slam_map.yaml", "slam_map.pgm", "slam_map.png", "trajectory.csv")
C2B = ("carmen2bag", "c.log")
DEMO = ("demo", "--goals=-1.2,-1.5", "--time-budget", "0.05")
DEMO_FILES = ("session.bag", "map.yaml", "map.pgm", "demo.png")
PLANNERS = ("potential_field", "rrt", "rrt_star")


def plan(planner: str, source: str = "world") -> tuple[str, ...]:
    """A quick query of ``planner`` on the simple world, the 2 m map or the circles file."""
    where = {
        "world": ("--world", "simple.world", "--start=-1.5,-1.5", "--goal=1.5,1.5"),
        "map": ("--map", "m.yaml", "--start=0.5,0.5", "--goal=1.5,1.5"),
        "circles": ("--circles", "circles.json", "--start=-1,-1", "--goal=1,1"),
    }[source]
    # Bounded by counts, not time: a loaded machine plans the same query the same way.
    bound = {"potential_field": ("--max-steps", "3000"), "rrt": (), "rrt_star": ("--iterations", "300")}[planner]
    return ("plan", "--planner", planner, *where, *bound)


def collisions() -> list[Case]:
    """Outputs that are an input of the same command, however spelled, and outputs beside inputs that are not."""
    cases = [
        Case("c2b-dot-spelling", (*C2B, "./c.log"), 1, ("c.log", "CARMEN log")),
        Case("c2b-dotdot-spelling", (*C2B, "sub/../c.log"), 1, ("CARMEN log",), setup=folder("sub")),
        Case("c2b-absolute-spelling", ("carmen2bag", "c.log", "{w}/c.log"), 1, ("CARMEN log",)),
        Case("c2b-relative-input", ("carmen2bag", "{w}/c.log", "c.log"), 1, ("CARMEN log",)),
        Case("c2b-symlink-output", (*C2B, "out.bag"), 1, ("CARMEN log",), setup=symlink("c.log", "out.bag")),
        Case(
            "c2b-symlink-input", ("carmen2bag", "l.log", "c.log"), 1, ("CARMEN log",), setup=symlink("c.log", "l.log")
        ),
        Case("c2b-output-is-a-folder", (*C2B, "."), 1, ("folder",)),
        Case("c2b-output-is-input-folder", (*C2B, "sub"), 1, ("sub", "folder"), setup=folder("sub")),
        Case(
            "replay-golden-is-relations",
            (*REPLAY, "--relations", "rel.txt", "--write-golden", "rel.txt"),
            1,
            ("--write-golden", "--relations"),
        ),
        Case(
            "replay-golden-symlink-to-against",
            (*REPLAY, "--against", "g.json", "--write-golden", "gl.json"),
            1,
            ("--write-golden", "--against"),
            setup=symlink("g.json", "gl.json"),
        ),
        Case(
            "replay-out-holds-bag-as-map-image",
            ("replay", "o/slam_map.pgm", "--slam", "--out", "o"),
            1,
            ("slam_map.pgm", "input bag"),
            setup=copy("in.bag", "o/slam_map.pgm"),
        ),
    ]
    spellings = (
        ("dot-spelling", "./in.bag", nothing),
        ("dotdot", "o/../in.bag", nothing),
        ("absolute", "{w}/in.bag", nothing),
        ("symlink", "gl.json", symlink("in.bag", "gl.json")),
        ("hardlink", "gl.json", hardlink("in.bag", "gl.json")),
    )
    cases += [
        Case(f"replay-golden-{why}", (*REPLAY, "--write-golden", path), 1, ("--write-golden", "in.bag"), setup=setup)
        for why, path, setup in spellings
    ]
    held = (
        ("golden-as-metrics", "--against", "g.json", "metrics.json"),
        ("relations-as-trajectory", "--relations", "rel.txt", "trajectory.csv"),
    )
    cases += [
        Case(
            f"replay-out-holds-{why}",
            (*REPLAY, option, f"o/{name}"),
            1,
            (name, option),
            setup=copy(source, f"o/{name}"),
        )
        for why, option, source, name in held
    ]
    cases += [
        Case(
            "replay-golden-is-an-out-file",
            (*REPLAY, "--write-golden", "o/metrics.json"),
            1,
            ("--write-golden", "metrics.json"),
        ),
        Case("replay-out-is-the-bag", ("replay", "in.bag", "--slam", "--out", "in.bag"), 1, ("--out", "in.bag")),
        Case(
            "replay-out-is-bag-folder",
            ("replay", "in.bag", "--slam", "--out", "."),
            0,
            outputs=REPLAY_FILES,
            made=REPLAY_FILES,
        ),
        Case(
            "replay-batch-out-is-bags-folder",
            ("replay", "bags", "--slam", "--out", "bags", "--workers", "1"),
            0,
            outputs=("bags/a/", "bags/b/", "bags/report.json", "bags/report.md"),
            made=("bags/a/metrics.json", "bags/b/metrics.json", "bags/report.json", "bags/report.md"),
            setup=steps(copy("in.bag", "bags/a.bag"), copy("in.bag", "bags/b.bag")),
        ),
        Case(
            "demo-world-is-out-bag",
            (*DEMO, "--world", "d/session.bag", "--out", "d"),
            1,
            ("session.bag", "--world"),
            setup=copy("simple.world", "d/session.bag"),
        ),
        Case(
            "demo-world-is-out-map",
            (*DEMO, "--world", "d/map.yaml", "--out", "d"),
            1,
            ("map.yaml", "--world"),
            setup=copy("simple.world", "d/map.yaml"),
        ),
        Case(
            "demo-out-figure-links-to-world",
            (*DEMO, "--world", "simple.world", "--out", "d"),
            1,
            ("demo.png", "--world"),
            setup=symlink("../simple.world", "d/demo.png"),
        ),
        Case(
            "demo-out-is-world-folder",
            (*DEMO, "--world", "simple.world", "--out", "."),
            0,
            outputs=DEMO_FILES,
            made=DEMO_FILES,
        ),
        Case("demo-out-is-the-world", (*DEMO, "--world", "simple.world", "--out", "simple.world"), 1, ("--out",)),
    ]
    for planner in PLANNERS:
        source = "circles" if planner == "potential_field" else "map"
        named = "circles.json" if source == "circles" else "m.yaml"
        cases += [
            Case(
                f"plan-{planner}-png-links-to-world",
                (*plan(planner), "--png", "p.png"),
                1,
                ("--png", "--world"),
                setup=symlink("simple.world", "p.png"),
            ),
            Case(
                f"plan-{planner}-png-dotdot-hardlink-to-{source}",
                (*plan(planner, source), "--png", "sub/../p.png"),
                1,
                ("--png", named),
                setup=steps(folder("sub"), hardlink(named, "p.png")),
            ),
        ]
    for planner in ("rrt", "rrt_star"):
        cases.append(
            Case(
                f"plan-{planner}-png-is-map-image",
                (
                    "plan",
                    "--planner",
                    planner,
                    "--map",
                    "mi.yaml",
                    "--start=0.5,0.5",
                    "--goal=1.5,1.5",
                    "--png",
                    "mi.png",
                ),
                1,
                ("--png", "mi.png"),
                setup=steps(
                    copy("m.pgm", "mi.png"),
                    lambda work: (work / "mi.yaml").write_text(
                        (work / "m.yaml").read_text().replace("image: m.pgm", "image: mi.png")
                    ),
                ),
            )
        )
    return cases


def disks() -> list[Case]:
    """Outputs on a full, tiny, read-only or closed disk, over an immutable file, onto a device or a folder."""
    full, ro, closed = Disk(fill=True), Disk(read_only=True), Disk(closed=("disk",))
    previous_bag = copy("in.bag", "disk/c.bag")
    cases = [
        Case("c2b-full-disk", (*C2B, "disk/c.bag"), 1, (NO_ROOM, "disk/c.bag"), disk=full),
        Case("c2b-tiny-disk", (*C2B, "disk/c.bag"), 1, (NO_ROOM, "disk/c.bag"), disk=Disk(size="8k")),
        Case("c2b-read-only-keeps-previous", (*C2B, "disk/c.bag"), 1, (READ_ONLY,), disk=ro, setup=previous_bag),
        Case("c2b-closed-folder", (*C2B, "disk/c.bag"), 1, (DENIED, "disk"), disk=closed),
        Case(
            "c2b-immutable-previous",
            (*C2B, "disk/c.bag"),
            1,
            (NOT_PERMITTED, "disk/c.bag"),
            disk=Disk(immutable=("disk/c.bag",)),
            setup=previous_bag,
        ),
        Case("c2b-immutable-folder", (*C2B, "disk/c.bag"), 1, (NOT_PERMITTED, "disk"), disk=Disk(immutable=("disk",))),
        Case("c2b-dev-full", (*C2B, "/dev/full"), 1, ("/dev/full",)),
        Case("c2b-parent-missing", (*C2B, "new/sub/c.bag"), 0, outputs=("new/sub/c.bag",), made=("new/sub/c.bag",)),
        Case("replay-out-full-disk", (*REPLAY[:-1], "disk/o"), 1, (NO_ROOM,), disk=full),
        Case("replay-out-tiny-disk", (*REPLAY[:-1], "disk/o"), 1, (NO_ROOM,), disk=Disk(size="16k")),
        Case("replay-out-read-only", (*REPLAY[:-1], "disk/o"), 1, (READ_ONLY, "disk/o"), disk=ro),
        Case("replay-out-closed", (*REPLAY[:-1], "disk/o"), 1, (DENIED, "disk"), disk=closed),
        Case(
            "replay-out-immutable", (*REPLAY[:-1], "disk"), 1, (NOT_PERMITTED, "disk"), disk=Disk(immutable=("disk",))
        ),
        Case("replay-out-dev-full", (*REPLAY[:-1], "/dev/full"), 1, ("--out", "/dev/full")),
        Case("replay-out-is-a-file", (*REPLAY[:-1], "c.log"), 1, ("--out", "c.log")),
        Case(
            "replay-out-parent-missing",
            (*REPLAY[:-1], "new/sub/o"),
            0,
            outputs=("new/sub/o/",),
            made=tuple(f"new/sub/o/{n}" for n in REPLAY_FILES),
        ),
    ]
    golden = (*REPLAY, "--write-golden")
    previous_golden = copy("g.json", "disk/g.json")
    cases += [
        Case("replay-golden-read-only", (*golden, "disk/g.json"), 1, (READ_ONLY,), disk=ro, setup=previous_golden),
        Case("replay-golden-closed", (*golden, "disk/g.json"), 1, (DENIED,), disk=closed, setup=previous_golden),
        Case(
            "replay-golden-immutable",
            (*golden, "disk/g.json"),
            1,
            (NOT_PERMITTED, "disk/g.json"),
            outputs=("o/",),  # the replay's own files, whole, written before the golden file
            disk=Disk(immutable=("disk/g.json",)),
            setup=previous_golden,
        ),
        Case("replay-golden-is-a-folder", (*golden, "o"), 1, ("--write-golden", "folder"), setup=folder("o")),
        Case(
            "replay-golden-parent-missing",
            (*golden, "new/g.json"),
            0,
            outputs=("o/", "new/g.json"),
            made=("new/g.json", "o/metrics.json"),
        ),
    ]
    for planner in PLANNERS:
        query = (*plan(planner), "--png")
        cases += [
            Case(f"plan-{planner}-png-full-disk", (*query, "disk/p.png"), 1, (NO_ROOM, "disk/p.png"), disk=full),
            Case(f"plan-{planner}-png-read-only", (*query, "disk/p.png"), 1, (READ_ONLY, "disk"), disk=ro),
            Case(f"plan-{planner}-png-closed", (*query, "disk/p.png"), 1, (DENIED, "disk"), disk=closed),
            Case(
                f"plan-{planner}-png-immutable-previous",
                (*query, "disk/p.png"),
                1,
                (NOT_PERMITTED, "disk/p.png"),
                disk=Disk(immutable=("disk/p.png",)),
                setup=text("disk/p.png", "previous"),
            ),
            Case(
                f"plan-{planner}-png-is-a-folder", (*query, "sub.png"), 1, ("--png", "folder"), setup=folder("sub.png")
            ),
            Case(f"plan-{planner}-png-dev-full", (*query, "/dev/full"), 1, ("/dev/full",)),
            Case(
                f"plan-{planner}-png-parent-missing",
                (*query, "new/p.png"),
                0,
                outputs=("new/p.png",),
                made=("new/p.png",),
            ),
        ]
    demo = (*DEMO, "--out")
    cases += [
        Case("demo-full-disk", (*demo, "disk/d"), 1, (NO_ROOM,), disk=full),
        # the recording, whole, may be all that fits
        Case("demo-tiny-disk", (*demo, "disk/d"), 1, (NO_ROOM,), ("disk/d/session.bag",), disk=Disk(size="64k")),
        Case("demo-read-only", (*demo, "disk/d"), 1, (READ_ONLY, "disk/d"), disk=ro),
        Case("demo-closed", (*demo, "disk/d"), 1, (DENIED, "disk"), disk=closed),
        Case(
            "demo-immutable-previous-bag",
            (*demo, "disk"),
            1,
            (NOT_PERMITTED, "session.bag"),
            disk=Disk(immutable=("disk/session.bag",)),
            setup=copy("in.bag", "disk/session.bag"),
        ),
        Case("demo-out-dev-full", (*demo, "/dev/full"), 1, ("--out", "/dev/full")),
        Case("demo-out-is-a-file", (*demo, "c.log"), 1, ("--out", "c.log")),
        Case("figures-read-only", ("figures", "--out", "disk/f"), 1, (READ_ONLY, "disk/f"), disk=ro),
        Case("figures-closed", ("figures", "--out", "disk/f"), 1, (DENIED, "disk"), disk=closed),
        Case("figures-out-dev-full", ("figures", "--out", "/dev/full"), 1, ("--out", "/dev/full")),
        Case("figures-out-is-a-file", ("figures", "--out", "c.log"), 1, ("--out", "c.log")),
    ]
    bench = ("bench", "potential-field", "--seeds", "1", "--results")  # a minute of measuring, never reached
    cases += [
        Case(f"bench-results-{why}", (*bench, path), 1, words, disk=disk, setup=setup, refused_first=True)
        for why, path, words, disk, setup in (
            ("dev-full", "/dev/full", ("--results", "/dev/full"), None, nothing),
            ("is-a-folder", "o", ("--results", "folder"), None, folder("o")),
            ("read-only", "disk/r.md", ("--results", READ_ONLY), ro, text("disk/r.md", "# results\n")),
            ("closed", "disk/r.md", ("--results", DENIED), closed, nothing),
            ("not-text", "r.md", ("r.md", "UTF-8"), None, lambda work: (work / "r.md").write_bytes(b"\xff\xfe")),
        )
    ]
    return cases


def malformed() -> list[Case]:
    """Inputs of the classes issue 43 names: bags defined otherwise than Noetic's, cut or empty files, bad lines
    and values, ``--png`` names that are not PNGs."""
    other = ("replay", "other.bag", "--slam", "--out", "o")
    cases = [
        Case("bag-odom-md5", other, 1, ("/odom", BOGUS_MD5), setup=redefined("/odom", md5=BOGUS_MD5)),
        Case("bag-scan-md5", other, 1, ("/scan", BOGUS_MD5), setup=redefined("/scan", md5=BOGUS_MD5)),
        Case("bag-tf-md5", other, 1, ("/tf", BOGUS_MD5), setup=redefined("/tf", md5=BOGUS_MD5)),
        Case(
            "bag-scan-other-fields",
            other,
            1,
            ("/scan", "LaserScan"),
            setup=redefined("/scan", lambda d: d.replace("float32 angle_min", "float32 angle_start", 1)),
        ),
        Case(
            "bag-odom-other-fields",
            other,
            1,
            ("/odom", "Odometry"),
            setup=redefined("/odom", lambda d: d.replace("float64 x\nfloat64 y\n", "float32 x\nfloat32 y\n", 1)),
        ),
        Case(
            "bag-tf-other-fields",
            other,
            1,
            ("/tf", "TFMessage"),
            setup=redefined("/tf", lambda d: d.replace("string child_frame_id", "string child", 1)),
        ),
        Case("bag-empty", ("replay", "e.bag", "--slam", "--out", "o"), 1, ("e.bag",), setup=text("e.bag", "")),
        Case(
            "bag-truncated-to-header",
            ("replay", "t.bag", "--slam", "--out", "o"),
            1,
            ("t.bag",),
            setup=cut("in.bag", "t.bag", 0.001),
        ),
        Case(
            "bag-truncated-in-batch",
            ("replay", "bags", "--slam", "--out", "o", "--workers", "1"),
            1,
            ("cut",),
            outputs=("o/",),
            setup=steps(copy("in.bag", "bags/a.bag"), cut("in.bag", "bags/cut.bag", 0.5)),
        ),
        Case("golden-empty", (*REPLAY, "--against", "e.json"), 1, ("e.json",), setup=text("e.json", "")),
        Case(
            "golden-malformed", (*REPLAY, "--against", "e.json"), 1, ("e.json",), setup=text("e.json", '{"metrics": ')
        ),
        Case("relations-empty", (*REPLAY, "--relations", "e.txt"), 1, ("e.txt",), setup=text("e.txt", "")),
        Case("relations-bad-line", (*REPLAY, "--relations", "e.txt"), 1, ("e.txt:1",), setup=text("e.txt", "1 2 x\n")),
        Case("carmen-empty", ("carmen2bag", "e.log", "e.bag"), 1, ("e.log",), setup=text("e.log", "")),
        Case(
            "carmen-bad-line",
            ("carmen2bag", "b.log", "b.bag"),
            1,
            ("b.log:3",),
            setup=lambda work: (work / "b.log").write_text(
                "".join(
                    line + ("\n" if i != 2 else " 1 2 nan\n")
                    for i, line in enumerate((work / "c.log").read_text().splitlines())
                )
            ),
        ),
        Case("carmen-cut-mid-line", ("carmen2bag", "t.log", "t.bag"), 1, ("t.log",), setup=cut("c.log", "t.log", 0.5)),
        Case("world-empty", (*plan("rrt"), "--world", "e.world"), 1, ("e.world",), setup=text("e.world", "")),
        Case(
            "world-not-xml",
            (*plan("potential_field"), "--world", "e.world"),
            1,
            ("e.world",),
            setup=text("e.world", "<sdf"),
        ),
        Case(
            "demo-world-empty", (*DEMO, "--world", "e.world", "--out", "d"), 1, ("e.world",), setup=text("e.world", "")
        ),
        Case("map-empty", (*plan("rrt", "map"), "--map", "e.yaml"), 1, ("e.yaml",), setup=text("e.yaml", "")),
        Case(
            "map-image-missing",
            (*plan("rrt_star", "map"), "--map", "e.yaml"),
            1,
            ("gone.pgm", "map image"),
            setup=lambda work: (work / "e.yaml").write_text(
                (work / "m.yaml").read_text().replace("image: m.pgm", "image: gone.pgm")
            ),
        ),
        Case(
            "map-bad-resolution",
            (*plan("rrt", "map"), "--map", "e.yaml"),
            1,
            ("e.yaml", "resolution"),
            setup=lambda work: (work / "e.yaml").write_text(
                (work / "m.yaml").read_text().replace("resolution: 0.05", "resolution: -0.05")
            ),
        ),
        Case(
            "circles-empty",
            (*plan("potential_field", "circles"), "--circles", "e.json"),
            1,
            ("e.json",),
            setup=text("e.json", ""),
        ),
        Case(
            "circles-bad",
            (*plan("potential_field", "circles"), "--circles", "e.json"),
            1,
            ("e.json",),
            setup=text("e.json", "[[0, 0]]"),
        ),
    ]
    for planner in PLANNERS:
        cases += [
            Case(f"plan-{planner}-png-named-{name}", (*plan(planner), "--png", name), 1, ("--png", ".png"))
            for name in ("p.jpg", "p", "p.png.bak")
        ]
        cases.append(
            Case(
                f"plan-{planner}-png-upper-case",
                (*plan(planner), "--png", "P.PNG"),
                0,
                outputs=("P.PNG",),
                made=("P.PNG",),
            )
        )
    return cases


CASES = [*collisions(), *disks(), *malformed()]


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The inputs every case starts from; the golden file is the 3-second bag's own."""
    here = tmp_path_factory.mktemp("template") / "w"
    here.mkdir()
    with Reader(SIMPLE_BAG) as reader, Writer(here / "in.bag") as writer:
        out = {}
        for conn in reader.connections:
            if conn.topic in TOPICS:
                out[conn.id] = writer.add_connection(
                    conn.topic, conn.msgtype, msgdef=conn.msgdef.data, md5sum=conn.digest, latching=conn.ext.latching
                )
        for conn, stamp, raw in reader.messages(stop=3_000_000_000):
            if conn.id in out:
                writer.write(out[conn.id], stamp, raw)
    write_log(here / "c.log", log_lines(drive()[:8], seed=1))
    shutil.copy(REPO / "worlds" / "simple.world", here / "simple.world")
    save_map(OccupancyGrid(np.zeros((40, 40), dtype=np.int8), 0.05), here / "m.yaml")
    (here / "circles.json").write_text("[[0, 0, 0.3]]\n")
    (here / "rel.txt").write_text("0.5 1.0 0.1 0 0 0 0 0\n")
    warm()
    made = run(here, ["replay", "in.bag", "--slam", "--out", "o", "--write-golden", "g.json"])
    assert made.code == 0, made.err
    shutil.rmtree(here / "o")
    return here


def _allowed(name: str, outputs: tuple[str, ...]) -> bool:
    return any(name == o or (o.endswith("/") and name.startswith(o)) for o in outputs)


def assert_clean(case: Case, result: Run) -> None:
    said = result.out + result.err
    assert "Traceback" not in said, said
    errors = [line for line in result.err.splitlines() if line.startswith("ERROR:")]
    assert result.code == case.code, said
    if case.code == 1:
        assert len(errors) == 1, result.err
        for word in case.words:
            assert word in errors[0], errors[0]
        if case.refused_first:
            assert result.out == "", result.out
    else:
        assert not errors, result.err
    for name, digest in result.before.items():  # inputs, and previous outputs unless replaced by a finished run
        if not (case.code == 0 and _allowed(name, case.outputs)):
            assert result.after.get(name) == digest, f"{name} changed or went"
    for name in sorted(set(result.after) - set(result.before)):  # each whole (below), of the command's own
        assert _allowed(name, case.outputs), f"stray file {name}"
    for name, whole in result.whole.items():
        assert whole, f"{name} is not whole"
    for name in case.made:
        assert name in result.after, f"{name} not written"


@pytest.mark.parametrize("case", [c.param() for c in CASES])
def test_command_ends_clean(case: Case, template: Path, tmp_path: Path) -> None:
    work = tmp_path / "w"
    shutil.copytree(template, work, symlinks=True)
    argv = [a.replace("{w}", str(work)) for a in case.argv]
    try:
        result = run(work, argv, case.disk, case.setup)
    except StagingError as why:
        pytest.skip(f"cannot stage {case.id} here: {why}")
    assert_clean(case, result)
