"""Replaying many bags at once: local worker processes and a two-worker Dask cluster on loopback give the
same per-bag files and the same report as a serial run; verdicts come from the golden files beside the bags."""

from __future__ import annotations

import json
import shutil
import threading
from pathlib import Path

import pytest

from mrs_nav.cli.main import main
from mrs_nav.replay.batch import BagJob, longest_first

BAGS = Path(__file__).resolve().parents[2] / "data" / "bags"


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The simple session twice (once held to its golden file, once with a stricter one) and a broken bag."""
    here = tmp_path_factory.mktemp("bags")
    shutil.copy(BAGS / "simple.bag", here / "simple.bag")
    shutil.copy(BAGS / "simple.golden.json", here / "simple.golden.json")
    shutil.copy(BAGS / "simple.bag", here / "strict.bag")
    golden = json.loads((BAGS / "simple.golden.json").read_text())
    golden["options"] = ["--slam"]  # SLAM only: quicker, and a different job from simple's
    golden["metrics"] = {"scans_processed": {"value": 10_000, "tolerance": 0, "better": "higher"}}
    (here / "strict.golden.json").write_text(json.dumps(golden))
    (here / "broken.bag").write_bytes(b"#ROSBAG V2.0\n" + b"\0" * 64)
    return here


def _files(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def _batch(folder: Path, out: Path, *extra: str) -> int:
    return main(["replay", str(folder), "--slam", "--out", str(out), *extra])


@pytest.fixture(scope="module")
def serial(folder: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[int, Path]:
    out = tmp_path_factory.mktemp("serial")
    return _batch(folder, out, "--workers", "1"), out


def test_report_holds_each_bag_to_its_golden(serial: tuple[int, Path]) -> None:
    code, out = serial
    report = json.loads((out / "report.json").read_text())
    verdicts = {b["bag"]: b["verdict"] for b in report["bags"]}
    assert verdicts == {"broken": "error", "simple": "passed", "strict": "regressed"}
    assert code == 1  # a bag failed
    strict = next(b for b in report["bags"] if b["bag"] == "strict")
    assert strict["regressions"][0].startswith("scans_processed:")
    assert "simple" in (out / "report.md").read_text()
    # simple replays with its golden file's options (--plan included), strict with its own (SLAM only)
    assert (out / "simple" / "plans.json").is_file()
    assert not (out / "strict" / "plans.json").exists()


@pytest.mark.parametrize("other_thread", [False, True], ids=["forked", "fork server"])
def test_local_workers_give_byte_identical_outputs(
    folder: Path, serial: tuple[int, Path], tmp_path: Path, other_thread: bool
) -> None:
    """Forked from a single-threaded parent, or through a fork server when the parent holds another thread."""
    code, out = serial
    stop = threading.Event()
    waiter = threading.Thread(target=stop.wait)
    if other_thread:
        waiter.start()
    try:
        assert _batch(folder, tmp_path / "pool", "--workers", "2") == code
    finally:
        stop.set()
        if other_thread:
            waiter.join()
    assert _files(tmp_path / "pool") == _files(out)


def test_a_two_worker_dask_cluster_gives_the_serial_result(
    folder: Path, serial: tuple[int, Path], tmp_path: Path
) -> None:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        preload=["mrs_nav.replay.batch"],  # as the README tells users to start workers (its dask_setup runs)
    ) as cluster:
        code = _batch(folder, tmp_path / "dask", "--cluster", cluster.scheduler_address)
    assert code == serial[0]
    assert _files(tmp_path / "dask") == _files(serial[1])


def test_no_scheduler_is_one_error_line(folder: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tests.rosharness import free_port

    address = f"tcp://127.0.0.1:{free_port()}"
    assert _batch(folder, tmp_path / "none", "--cluster", address) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"ERROR: --cluster {address}: no Dask scheduler answered")


def test_workers_start_with_the_largest_bag(tmp_path: Path) -> None:
    sizes = {"short.bag": 10, "long.bag": 300, "middle.bag": 50}
    for name, size in sizes.items():
        (tmp_path / name).write_bytes(b"x" * size)
    jobs = [BagJob(tmp_path / name, tmp_path / "out") for name in (*sizes, "missing.bag")]
    assert [job.name for job in longest_first(jobs)] == ["long", "middle", "short", "missing"]
