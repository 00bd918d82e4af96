"""Golden metrics of a replay: writing them with per-metric tolerances, and finding the ones that regressed.

A golden file is JSON ``{"bag": NAME, "options": [...], "metrics": {NAME: {"value": v, "tolerance": t,
"better": "lower" | "higher" | "equal"}}}``. A metric regressed when it is missing, or when it is worse than the
golden value by more than its tolerance: above ``value + tolerance`` for ``lower``, below
``value - tolerance`` for ``higher``, off by more than ``tolerance`` either way for ``equal``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mrs_nav.errors import InvalidInputError
from mrs_nav.textfiles import DESCRIPTION_LIMIT, read_text

#: name -> (which way is better, tolerance in the metric's unit) used by :func:`make_golden`.
DEFAULT_TOLERANCES: dict[str, tuple[str, float]] = {
    "scans_processed": ("higher", 2.0),
    "ate_rmse_m": ("lower", 0.02),
    "ate_rmse_deg": ("lower", 1.0),
    "rpe_trans_mean_m": ("lower", 0.01),
    "rpe_rot_mean_deg": ("lower", 0.5),
    "map_iou": ("higher", 0.05),
    "map_iou_1cell": ("higher", 0.03),
    "slam_vs_recorded_rms_m": ("lower", 0.05),
    "goals": ("equal", 0.0),
    "goals_reachable": ("higher", 0.0),
    "goals_reachable_recorded_map": ("higher", 0.0),
    "plan_length_ratio_mean": ("lower", 0.15),
}
_BETTER = ("lower", "higher", "equal")


@dataclass(frozen=True)
class Regression:
    """A metric worse than its golden value by more than the tolerance (``value`` None when missing)."""

    name: str
    value: float | None
    golden: float
    tolerance: float
    better: str

    def describe(self) -> str:
        if self.value is None:
            return f"{self.name}: missing (golden {self.golden:g})"
        limits = f"tolerance {self.tolerance:g}, {self.better} is better"
        return f"{self.name}: {self.value:g} vs golden {self.golden:g} ({limits})"


def make_golden(bag_name: str, options: Sequence[str], metrics: Mapping[str, float | int | None]) -> dict[str, Any]:
    """A golden record of ``metrics`` (None values and metrics without a default tolerance are left out)."""
    entries = {}
    for name, value in metrics.items():
        if value is None or name not in DEFAULT_TOLERANCES:
            continue
        better, tolerance = DEFAULT_TOLERANCES[name]
        entries[name] = {"value": value, "tolerance": tolerance, "better": better}
    return {"bag": bag_name, "options": list(options), "metrics": entries}


def read_golden(path: Path) -> dict[str, Any]:
    """A golden file, validated: ``options`` (a list of strings) and ``metrics`` (see :func:`load_golden`)."""
    try:
        data = json.loads(read_text(path, DESCRIPTION_LIMIT, "golden file"))
    except json.JSONDecodeError as err:
        raise InvalidInputError(f"golden file {path} is not JSON: {err}") from None
    except RecursionError:
        raise InvalidInputError(f"golden file {path} is not JSON: nested too deeply") from None
    if not isinstance(data, dict):
        raise InvalidInputError(f"golden file {path} is not a JSON object")
    options = data.setdefault("options", [])
    if not isinstance(options, list) or not all(isinstance(o, str) for o in options):
        raise InvalidInputError(f"golden file {path}: 'options' must be a list of strings")
    _check_metrics(path, data.get("metrics"))
    return data


def load_golden(path: Path) -> dict[str, dict[str, Any]]:
    """The ``metrics`` table of a golden file, validated."""
    metrics: dict[str, dict[str, Any]] = read_golden(path)["metrics"]
    return metrics


def _check_metrics(path: Path, metrics: object) -> None:
    if not isinstance(metrics, dict):
        raise InvalidInputError(f"golden file {path} has no 'metrics' object")
    for name, entry in metrics.items():
        ok = (
            isinstance(entry, dict)
            and isinstance(entry.get("value"), int | float)
            and isinstance(entry.get("tolerance"), int | float)
            and entry["tolerance"] >= 0
            and entry.get("better") in _BETTER
        )
        if not ok:
            raise InvalidInputError(
                f"golden file {path}: metric {name!r} needs a number 'value', a 'tolerance' >= 0 and 'better' in "
                f"{', '.join(_BETTER)}"
            )


def regressions(metrics: Mapping[str, float | int | None], golden: Mapping[str, Mapping[str, Any]]) -> list[Regression]:
    """Every golden metric that is missing from ``metrics`` or worse than its tolerance allows."""
    found = []
    for name, entry in sorted(golden.items()):
        gold, tol, better = float(entry["value"]), float(entry["tolerance"]), str(entry["better"])
        value = metrics.get(name)
        if value is None or not math.isfinite(float(value)):
            found.append(Regression(name, None, gold, tol, better))
            continue
        v = float(value)
        worse = {"lower": v > gold + tol, "higher": v < gold - tol, "equal": abs(v - gold) > tol}[better]
        if worse:
            found.append(Regression(name, v, gold, tol, better))
    return found


def dump_json(payload: Mapping[str, Any]) -> str:
    """Stable JSON text (sorted keys, fixed indentation, trailing newline): equal inputs give equal bytes."""
    return json.dumps(payload, indent=2, sort_keys=True, allow_nan=False) + "\n"
