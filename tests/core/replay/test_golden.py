import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mrs_nav.errors import InvalidInputError
from mrs_nav.replay.golden import DEFAULT_TOLERANCES, load_golden, make_golden, read_golden, regressions

finite = st.floats(-1e3, 1e3, allow_nan=False)
tolerance = st.floats(0.0, 10.0, allow_nan=False)


@given(finite, tolerance, st.floats(0.0, 1.0))
def test_within_tolerance_never_regresses(golden, tol, fraction):
    for better in ("lower", "higher", "equal"):
        entry = {"m": {"value": golden, "tolerance": tol, "better": better}}
        for value in (golden + fraction * tol, golden - fraction * tol):
            assert regressions({"m": value}, entry) == []


@given(finite, tolerance, st.floats(1e-3, 100.0))
def test_worse_than_tolerance_regresses_and_better_never_does(golden, tol, excess):
    lower = {"m": {"value": golden, "tolerance": tol, "better": "lower"}}
    higher = {"m": {"value": golden, "tolerance": tol, "better": "higher"}}
    equal = {"m": {"value": golden, "tolerance": tol, "better": "equal"}}
    up, down = golden + tol + excess, golden - tol - excess
    assert [r.name for r in regressions({"m": up}, lower)] == ["m"]
    assert regressions({"m": down}, lower) == []
    assert [r.name for r in regressions({"m": down}, higher)] == ["m"]
    assert regressions({"m": up}, higher) == []
    assert len(regressions({"m": up}, equal)) == len(regressions({"m": down}, equal)) == 1


def test_missing_and_null_metrics_regress():
    golden = make_golden("a.bag", ["--slam"], {"ate_rmse_m": 0.01, "map_iou": 0.9, "unlisted": 3.0, "goals": None})
    assert set(golden["metrics"]) == {"ate_rmse_m", "map_iou"}
    assert golden["metrics"]["map_iou"] == {
        "value": 0.9,
        "tolerance": DEFAULT_TOLERANCES["map_iou"][1],
        "better": "higher",
    }
    found = regressions({"ate_rmse_m": None}, golden["metrics"])
    assert [r.describe() for r in found] == ["ate_rmse_m: missing (golden 0.01)", "map_iou: missing (golden 0.9)"]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("{", "is not JSON"),
        ("[]", "is not a JSON object"),
        ("{}", "has no 'metrics' object"),
        # options are read before any replay of a bag with its golden file beside it: these were tracebacks
        ('{"options": 5, "metrics": {}}', "'options' must be a list of strings"),
        ('{"options": [1], "metrics": {}}', "'options' must be a list of strings"),
        ("[" * 100_000, "nested too deeply"),
        ('{"metrics": {"x": {"value": 1, "tolerance": -1, "better": "lower"}}}', "metric 'x' needs"),
        ('{"metrics": {"x": {"value": 1, "tolerance": 0, "better": "sideways"}}}', "metric 'x' needs"),
    ],
)
def test_malformed_golden_file_is_named(text, message, tmp_path):
    path = tmp_path / "g.json"
    path.write_text(text)
    with pytest.raises(InvalidInputError, match=rf"golden file .*g\.json.*{message}"):
        read_golden(path)


def test_missing_golden_file(tmp_path):
    with pytest.raises(InvalidInputError, match=r"nope\.json: cannot read golden file: No such file"):
        load_golden(tmp_path / "nope.json")
    with pytest.raises(InvalidInputError, match="cannot read golden file: not a regular file"):
        load_golden(tmp_path)
    assert json.loads(json.dumps(make_golden("b", [], {})))["metrics"] == {}
