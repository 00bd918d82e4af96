"""mrs-nav replay on bad and unusual bags and options: one ERROR line naming the bag and what is wrong, or a
NOTE and a replay for a recording that was cut short."""

import json
import struct
from pathlib import Path

import pytest
from rosbags.rosbag1 import Reader, Writer

from mrs_nav.bag.io import typestore
from mrs_nav.bag.salvage import MAGIC
from mrs_nav.cli.main import main

SIMPLE = Path(__file__).resolve().parents[2] / "data" / "bags" / "simple.bag"


def _lines(capsys):
    return capsys.readouterr().err.strip().splitlines()


@pytest.fixture
def truncated(tmp_path):
    path = tmp_path / "cut.bag"
    path.write_bytes(SIMPLE.read_bytes()[: SIMPLE.stat().st_size // 2])
    return path


@pytest.fixture
def killed(tmp_path):
    """simple.bag as a killed recording would leave it: no index position, cut inside its third chunk."""
    data = bytearray(SIMPLE.read_bytes())
    pos = data.index(b"index_pos=", len(MAGIC)) + len(b"index_pos=")
    struct.pack_into("<Q", data, pos, 0)
    path = tmp_path / "session.bag.active"
    path.write_bytes(bytes(data[: len(data) * 3 // 5]))
    return path


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["{cut}", "--slam"], "ERROR: bag {cut} is truncated: its index should start at byte"),
        (["{bag}", "--plan", "--plan-iterations", "0"], "ERROR: mrs-nav replay: argument --plan-iterations: must"),
        (["{bag}"], "ERROR: nothing to do: give --slam and/or --plan"),
        (["{bag}", "--slam", "--against", "{missing}"], "ERROR: {missing}: cannot read golden file: No such file"),
    ],
)
def test_bad_input_is_one_error_line(args, message, truncated, tmp_path, capsys):
    values = {"cut": truncated, "bag": SIMPLE, "missing": tmp_path / "none.json"}
    args = ["replay", *(a.format(**values) for a in args), "--out", str(tmp_path / "out")]
    assert main(args) == 1
    err = _lines(capsys)
    assert len(err) == 1
    assert err[0].startswith(message.format(**values))


def test_killed_recording_replays_with_a_note(killed, tmp_path, capsys):
    before = killed.read_bytes()
    assert main(["replay", str(killed), "--slam", "--out", str(tmp_path / "out")]) == 0
    err = _lines(capsys)
    assert len(err) == 1
    assert err[0].startswith(f"NOTE: bag {killed} has no index (recording cut short): read ")
    assert killed.read_bytes() == before
    assert (tmp_path / "out" / "metrics.json").is_file()


def test_bag_without_session_topics_gives_null_metrics(tmp_path, capsys):
    """A bag with only /scan, /odom and /tf_static (e.g. from carmen2bag or a robot) replays; the comparisons
    with a recording it does not hold are null, not errors."""
    bag = tmp_path / "sensors.bag"
    with Reader(SIMPLE) as reader:
        writer = Writer(bag)
        writer.open()
        keep = {c.topic: c for c in reader.connections if c.topic in {"/scan", "/odom", "/tf_static"}}
        added = {t: writer.add_connection(t, c.msgtype, typestore=typestore()) for t, c in keep.items()}
        for conn, stamp, raw in reader.messages(connections=list(keep.values())):
            writer.write(added[conn.topic], stamp, raw)
        writer.close()
    assert main(["replay", str(bag), "--plan", "--out", str(tmp_path / "out"), "--json"]) == 0
    metrics = json.loads(capsys.readouterr().out)["metrics"]
    assert metrics["scans_processed"] > 10
    assert metrics["ate_rmse_m"] is None
    assert metrics["map_iou"] is None
    assert (metrics["goals"], metrics["goals_reachable"]) == (0, 0)


def test_one_bag_with_a_cluster_says_it_is_replayed_here(tmp_path, capsys):
    # --cluster fans several bags out; with one bag it was ignored without a word
    out = tmp_path / "out"
    assert main(["replay", str(SIMPLE), "--slam", "--out", str(out), "--cluster", "tcp://127.0.0.1:9"]) == 0
    assert _lines(capsys) == [f"NOTE: --cluster fans out several bags; the one bag {SIMPLE} is replayed here"]
    assert (out / "metrics.json").is_file()
