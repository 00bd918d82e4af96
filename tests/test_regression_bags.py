"""The regression suite: every bag in tests/data/bags is replayed offline (SLAM + re-planning) and held to its
golden file; replays are byte-for-byte reproducible; a regression makes the command fail naming the metric."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mrs_nav.cli.main import main

BAGS = Path(__file__).resolve().parent / "data" / "bags"
GOLDEN = sorted(BAGS.glob("*.golden.json"))


def _replay(bag: Path, golden: Path, out: Path, *extra: str) -> int:
    options = json.loads(golden.read_text())["options"]
    return main(["replay", str(bag), *options, "--out", str(out), *extra])


def test_suite_has_bags_from_each_world():
    assert {g.name.removesuffix(".golden.json") for g in GOLDEN} >= {"simple", "office", "cluttered"}
    total = sum(p.stat().st_size for p in BAGS.glob("*.bag"))
    assert total < 5_000_000, f"regression bags take {total} bytes; keep them to a few MB"


@pytest.mark.parametrize("golden", GOLDEN, ids=lambda p: p.name.removesuffix(".golden.json"))
def test_bag_replays_within_its_golden_tolerances(golden, tmp_path, capsys):
    bag = BAGS / json.loads(golden.read_text())["bag"]
    assert _replay(bag, golden, tmp_path, "--against", str(golden), "--json") == 0, capsys.readouterr().err
    summary = json.loads(capsys.readouterr().out)
    assert summary["regressions"] == []
    metrics = summary["metrics"]
    # The recording and the replay run the same algorithm on the same input: the maps and poses agree.
    assert metrics["map_iou"] >= 0.95
    assert metrics["slam_vs_recorded_rms_m"] <= 0.05
    assert metrics["goals_reachable"] == metrics["goals"] >= 1


def test_replay_is_byte_identical(tmp_path):
    golden = BAGS / "simple.golden.json"
    first, second = tmp_path / "a", tmp_path / "b"
    assert _replay(BAGS / "simple.bag", golden, first) == 0
    assert _replay(BAGS / "simple.bag", golden, second) == 0
    names = sorted(p.name for p in first.iterdir())
    assert names == sorted(p.name for p in second.iterdir())
    assert {"metrics.json", "plans.json", "slam_map.pgm", "slam_map.yaml", "trajectory.csv", "slam_map.png"} <= set(
        names
    )
    for name in names:
        assert (first / name).read_bytes() == (second / name).read_bytes(), name


def test_regressed_metrics_are_named_and_fail(tmp_path, capsys):
    golden = json.loads((BAGS / "simple.golden.json").read_text())
    metrics = golden["metrics"]
    metrics["ate_rmse_m"].update(value=metrics["ate_rmse_m"]["value"] / 10, tolerance=0.0)  # now far too good
    metrics["map_iou"]["value"] = 2.0
    metrics["not_produced"] = {"value": 1.0, "tolerance": 0.0, "better": "equal"}
    strict = tmp_path / "strict.golden.json"
    strict.write_text(json.dumps(golden))
    assert _replay(BAGS / "simple.bag", strict, tmp_path / "out", "--against", str(strict)) == 2
    err = capsys.readouterr().err
    assert "REGRESSED" in err
    for name in ("ate_rmse_m", "map_iou", "not_produced: missing"):
        assert name in err
    assert "rpe_trans_mean_m" not in err


def test_written_golden_passes_against_itself(tmp_path):
    golden = tmp_path / "new.golden.json"
    args = ["replay", str(BAGS / "cluttered.bag"), "--slam", "--out", str(tmp_path / "a")]
    assert main([*args, "--write-golden", str(golden)]) == 0
    written = json.loads(golden.read_text())
    assert written["bag"] == "cluttered.bag"
    assert written["options"] == ["--slam"]
    assert "goals_reachable" not in written["metrics"]  # no --plan, no planning metrics
    assert main([*args, "--against", str(golden)]) == 0
