"""Outputs never destroy an input and are never left half-written: each reproducer ends with exit 1 and one
``ERROR:`` line, no traceback, its inputs unchanged (sha256) and no file under a final name that is not whole.

A full disk is a tmpfs of a few KiB, a read-only folder a read-only tmpfs, and a folder without write permission
one that the command, run as ``nobody``, may not write (root ignores mode bits): each mounted in a private mount
namespace of its own (``unshare -m``), so nothing outside the test sees it.
"""

import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.core.bag.carmen_fixture import drive, log_lines, write_log

REPO = Path(__file__).resolve().parents[3]
SIMPLE_BAG = REPO / "tests" / "data" / "bags" / "simple.bag"
WORLD = REPO / "worlds" / "simple.world"
PLAN = ["plan", "--world", str(WORLD), "--planner", "rrt", "--start=-1.5,-1.5", "--goal=1.5,1.5"]


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def mrs_nav(*args: str, setup: str = "", user: str = "") -> subprocess.CompletedProcess[str]:
    """Run ``mrs-nav ARGS`` in a process of its own; with ``setup`` (shell lines, e.g. mounts) in a private mount
    namespace; as ``nobody`` with ``user="nobody"``."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO / "src"), os.environ.get("PYTHONPATH", "")])}
    command = [sys.executable, "-m", "mrs_nav", *args]
    if user:
        command = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", *command]
    if setup:
        command = ["unshare", "-m", "sh", "-ec", f'{setup}\nexec "$@"', "sh", *command]
    return subprocess.run(command, capture_output=True, text=True, env=env, timeout=300, check=False)


def assert_one_error(result: subprocess.CompletedProcess[str], *words: str) -> str:
    assert result.returncode == 1, result.stderr
    assert "Traceback" not in result.stderr, result.stderr
    errors = [line for line in result.stderr.splitlines() if line.startswith("ERROR:")]
    assert len(errors) == 1, result.stderr
    for word in words:
        assert word in errors[0]
    return errors[0]


def no_partial(folder: Path) -> None:
    assert not [p.name for p in folder.iterdir() if p.name.endswith(".partial")]


@pytest.fixture(scope="module")
def namespaces() -> None:
    probe = subprocess.run(["unshare", "-m", "true"], capture_output=True, check=False)
    if probe.returncode != 0 or shutil.which("setpriv") is None:
        pytest.skip("needs root's unshare -m (private mounts) and setpriv")


@pytest.fixture
def carmen_log(tmp_path: Path) -> Path:
    return write_log(tmp_path / "c.log", log_lines(drive(), seed=1))


def test_replay_refuses_a_golden_file_over_its_input_bag(tmp_path):
    bag = tmp_path / "in.bag"
    shutil.copy(SIMPLE_BAG, bag)
    before = sha256(bag)
    result = mrs_nav("replay", str(bag), "--slam", "--out", str(tmp_path / "out"), "--write-golden", str(bag))
    assert_one_error(result, "--write-golden", "input")
    assert sha256(bag) == before
    assert not (tmp_path / "out").exists()  # refused before any work


def test_replay_refuses_a_golden_file_over_the_one_it_is_held_to(tmp_path):
    golden = tmp_path / "g.json"
    shutil.copy(SIMPLE_BAG.with_name("simple.golden.json"), golden)
    before = sha256(golden)
    out = tmp_path / "out"
    result = mrs_nav(
        "replay", str(SIMPLE_BAG), "--out", str(out), "--against", str(golden), "--write-golden", str(golden)
    )
    assert_one_error(result, "--against")
    assert sha256(golden) == before


def test_replay_refuses_an_input_bag_that_is_one_of_its_outputs(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    bag = out / "metrics.json"
    shutil.copy(SIMPLE_BAG, bag)
    before = sha256(bag)
    assert_one_error(mrs_nav("replay", str(bag), "--slam", "--out", str(out)), "metrics.json")
    assert sha256(bag) == before


def test_carmen2bag_refuses_to_write_over_its_log(carmen_log):
    before = sha256(carmen_log)
    assert_one_error(mrs_nav("carmen2bag", str(carmen_log), str(carmen_log)), "CARMEN log")
    assert sha256(carmen_log) == before


def test_carmen2bag_refuses_the_same_file_by_another_name(carmen_log, tmp_path):
    link = tmp_path / "hard.bag"
    os.link(carmen_log, link)
    before = sha256(carmen_log)
    assert_one_error(mrs_nav("carmen2bag", str(carmen_log), str(link)), "CARMEN log")
    assert sha256(carmen_log) == before


@pytest.mark.parametrize("planner", ["potential_field", "rrt", "rrt_star"])
def test_plan_png_with_another_suffix_is_refused_before_planning(tmp_path, planner):
    plan = [*PLAN[:4], planner, *PLAN[5:]]
    result = mrs_nav(*plan, "--png", str(tmp_path / "x.pgm"), "--json")
    assert_one_error(result, ".png")
    assert result.stdout == ""  # nothing planned
    assert not (tmp_path / "x.pgm").exists()


@pytest.mark.parametrize("planner", ["potential_field", "rrt", "rrt_star"])
def test_plan_png_is_drawn_by_every_planner(tmp_path, planner):
    png = tmp_path / "plan.png"
    plan = [*PLAN[:4], planner, *PLAN[5:]]
    result = mrs_nav(*plan, "--png", str(png), "--time-budget", "0.2", "--max-steps", "3000")
    assert result.returncode == 0, result.stderr
    assert png.read_bytes().startswith(b"\x89PNG")


def test_plan_png_onto_a_device_is_refused():
    assert_one_error(mrs_nav(*PLAN, "--png", "/dev/full"), "/dev/full")


def test_replay_golden_onto_a_device_is_refused(tmp_path):
    result = mrs_nav("replay", str(SIMPLE_BAG), "--slam", "--out", str(tmp_path), "--write-golden", "/dev/full")
    assert_one_error(result, "/dev/full")
    assert not (tmp_path / "metrics.json").exists()  # refused before the replay


def mounted(tmp_path: Path, args: list[str], setup: str, listed: Path, user: str = ""):
    """Run ``mrs-nav ARGS`` after ``setup`` in a private mount namespace; its result (with the command's own exit
    code) and the names in folder ``listed`` as the command left them, before the namespace goes."""
    report = tmp_path / "report"
    report.mkdir(exist_ok=True)
    script = f'{setup}\nset +e\n"$@"\necho $? > {report}/code\nls -A {listed} > {report}/listing\nexit 0\n'
    result = mrs_nav(*args, setup=script, user=user)
    code = int((report / "code").read_text())
    return subprocess.CompletedProcess(result.args, code, result.stdout, result.stderr), (
        report / "listing"
    ).read_text().split()


def tmpfs(folder: Path, options: str) -> str:
    return f"mkdir -p {folder}\nmount -t tmpfs -o {options} tmpfs {folder}\n"


def fill(folder: Path) -> str:
    """Shell lines that leave no room in the tmpfs at ``folder`` (dd stops at the full disk)."""
    return f"dd if=/dev/zero of={folder}/filler bs=1k 2>/dev/null || true\n"


def test_plan_png_on_a_full_disk(tmp_path, namespaces):
    disk = tmp_path / "disk"
    result, listing = mounted(tmp_path, [*PLAN, "--png", str(disk / "plan.png")], tmpfs(disk, "size=16k"), disk)
    assert_one_error(result, "No space left on device")
    assert listing == []


def test_replay_golden_on_a_full_disk_keeps_the_previous_golden(tmp_path, namespaces):
    disk = tmp_path / "disk"
    previous = SIMPLE_BAG.with_name("simple.golden.json")
    setup = tmpfs(disk, "size=64k") + f"cp {previous} {disk}/g.json\n" + fill(disk)
    setup_check = f"\ntrap 'sha256sum {disk}/g.json > {tmp_path}/report/sum' EXIT"
    args = ["replay", str(SIMPLE_BAG), "--slam", "--out", str(tmp_path / "out"), "--write-golden", str(disk / "g.json")]
    result, listing = mounted(tmp_path, args, setup + setup_check, disk)
    assert_one_error(result, "No space left on device")
    assert sorted(listing) == ["filler", "g.json"]
    assert (tmp_path / "report" / "sum").read_text().split()[0] == sha256(previous)


def test_carmen2bag_into_a_read_only_folder_names_the_real_error(carmen_log, tmp_path, namespaces):
    folder = tmp_path / "ro"
    before = sha256(carmen_log)
    result, listing = mounted(
        tmp_path, ["carmen2bag", str(carmen_log), str(folder / "c.bag")], tmpfs(folder, "ro"), folder
    )
    assert_one_error(result, "Read-only file system")
    assert listing == []
    assert sha256(carmen_log) == before


def test_carmen2bag_into_a_folder_it_may_not_write(carmen_log, tmp_path, namespaces):
    # nobody cannot reach pytest's folders (root's, mode 0700): the log goes to a tmpfs over /mnt, private to the
    # namespace, beside a folder nobody may not write into
    shared = Path("/mnt")
    setup = tmpfs(shared, "mode=0755") + f"cp {carmen_log} {shared}/c.log\nmkdir -m 0555 {shared}/closed\n"
    setup += f"mkdir -m 0777 {shared}/numba\nexport NUMBA_CACHE_DIR={shared}/numba\n"  # numba caches its kernels
    args = ["carmen2bag", str(shared / "c.log"), str(shared / "closed" / "c.bag")]
    result, listing = mounted(tmp_path, args, setup, shared / "closed", user="nobody")
    assert_one_error(result, "Permission denied")
    assert listing == []


def test_figures_on_a_full_disk_leave_only_whole_pngs(tmp_path, namespaces):
    disk = tmp_path / "disk"
    report = tmp_path / "report"
    keep = f"\ntrap 'cp -r {disk} {report}/left' EXIT"  # the files as the command left them
    result, listing = mounted(tmp_path, ["figures", "--out", str(disk)], tmpfs(disk, "size=96k") + keep, disk)
    assert_one_error(result, "No space left on device")
    assert listing  # the disk held the first figures: each one whole
    for name in listing:
        assert name.endswith(".png")
        assert (report / "left" / name).read_bytes().endswith(b"IEND\xaeB`\x82")
