"""The regression suite: every bag in tests/data/bags is replayed offline (SLAM + re-planning) and held to its
golden file; replays are byte-for-byte reproducible; a regression makes the command fail naming the metric."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mrs_nav.cli.main import main

BAGS = Path(__file__).resolve().parent / "data" / "bags"
GOLDEN = sorted(BAGS.glob("*.golden.json"))
NAMES = [g.name.removesuffix(".golden.json") for g in GOLDEN]


def _replay(bag: Path, golden: Path, out: Path, *extra: str) -> int:
    options = json.loads(golden.read_text())["options"]
    return main(["replay", str(bag), *options, "--out", str(out), *extra])


@pytest.fixture(scope="module")
def replays(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[int, Path, str]]:
    """Each bag replayed once against its golden file: (exit status, output folder, printed summary)."""
    capture = pytest.MonkeyPatch()
    done = {}
    for name, golden in zip(NAMES, GOLDEN, strict=True):
        out = tmp_path_factory.mktemp(name)
        summary = out / "summary.txt"
        with summary.open("w") as stdout:
            capture.setattr("sys.stdout", stdout)
            code = _replay(BAGS / f"{name}.bag", golden, out / "replay", "--against", str(golden), "--json")
            capture.undo()
        done[name] = (code, out / "replay", summary.read_text())
    return done


def test_suite_has_bags_from_each_world():
    assert set(NAMES) >= {"simple", "office", "cluttered"}
    for name in NAMES:
        assert "--plan" in json.loads((BAGS / f"{name}.golden.json").read_text())["options"]
    total = sum(p.stat().st_size for p in BAGS.glob("*.bag"))
    assert total < 5_000_000, f"regression bags take {total} bytes; keep them to a few MB"


@pytest.mark.parametrize("name", NAMES)
def test_bag_replays_within_its_golden_tolerances(name, replays):
    code, _, printed = replays[name]
    summary = json.loads(printed)
    assert summary["regressions"] == []
    assert code == 0
    metrics = summary["metrics"]
    # The recording and the replay run the same algorithm on the same input: the maps and poses agree.
    assert metrics["map_iou"] >= 0.95
    assert metrics["slam_vs_recorded_rms_m"] <= 0.05
    assert metrics["goals_reachable"] == metrics["goals"] >= 1


def test_replay_is_byte_identical(replays, tmp_path):
    _, first, _ = replays["simple"]
    second = tmp_path / "again"
    assert _replay(BAGS / "simple.bag", BAGS / "simple.golden.json", second) == 0
    names = sorted(p.name for p in first.iterdir())
    assert names == sorted(p.name for p in second.iterdir())
    assert {"metrics.json", "plans.json", "slam_map.pgm", "slam_map.yaml", "trajectory.csv", "slam_map.png"} <= set(
        names
    )
    for name in names:
        assert (first / name).read_bytes() == (second / name).read_bytes(), name


def _slam_only(tmp_path: Path) -> list[str]:
    return ["replay", str(BAGS / "simple.bag"), "--slam", "--out", str(tmp_path / "out")]


def test_regressed_metrics_are_named_and_fail(tmp_path, capsys):
    golden = tmp_path / "strict.golden.json"
    assert main([*_slam_only(tmp_path), "--write-golden", str(golden)]) == 0
    record = json.loads(golden.read_text())
    metrics = record["metrics"]
    metrics["ate_rmse_m"].update(value=metrics["ate_rmse_m"]["value"] / 10, tolerance=0.0)  # now far too good
    metrics["map_iou"]["value"] = 2.0
    metrics["not_produced"] = {"value": 1.0, "tolerance": 0.0, "better": "equal"}
    golden.write_text(json.dumps(record))
    capsys.readouterr()
    assert main([*_slam_only(tmp_path), "--against", str(golden)]) == 2
    err = capsys.readouterr().err
    assert "REGRESSED" in err
    for name in ("ate_rmse_m: ", "map_iou: ", "not_produced: missing"):
        assert name in err
    assert "rpe_trans_mean_m" not in err


def test_written_golden_passes_against_itself(tmp_path):
    golden = tmp_path / "new.golden.json"
    assert main([*_slam_only(tmp_path), "--write-golden", str(golden)]) == 0
    written = json.loads(golden.read_text())
    assert written["bag"] == "simple.bag"
    assert written["options"] == ["--slam"]
    assert "goals_reachable" not in written["metrics"]  # no --plan, no planning metrics
    assert {"ate_rmse_m", "map_iou", "slam_vs_recorded_rms_m"} <= set(written["metrics"])
    assert main([*_slam_only(tmp_path), "--against", str(golden)]) == 0
