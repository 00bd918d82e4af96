"""The relations metric of Kummerle et al., "On measuring the accuracy of SLAM algorithms" (Autonomous Robots
27(4), 2009): the error of a trajectory on manually verified relative poses.

A relations file holds one relation a line, ``t1 t2 x y z roll pitch yaw``: the pose at time ``t2`` in the frame
of the pose at ``t1`` (metres, radians). For each relation the estimated relative pose ``d = inv(P(t1)) P(t2)``
is compared with the reference ``r``: ``e = inv(r) d``; the translational error is ``|e.xy|`` (m) and the
rotational error ``|e.yaw|`` (deg). The metric is their mean and standard deviation over the relations, as in
the published tables (gmapping 0.070 +- 0.083 m on the Intel log; Cartographer 0.0229 +- 0.0239 m).

Time: relation stamps are those of the raw log, a constant offset from the stamps of a corrected log. The offset
is given, or found as the most common difference (to 1 ms) between a relation stamp and a trajectory stamp:
the ends of many relations are scans that the trajectory also has, and only the true offset makes those
differences agree. At least :data:`MIN_OFFSET_VOTES` must agree and no other offset as many (evenly spaced scans
make shifted offsets tie), else the offset must be given.

A relation end between trajectory poses is bridged by odometry, ``P(t) = C(t) O(t)``: ``O(t)`` the odometry
interpolated at ``t`` and ``C(t)`` the correction ``P_k inv(O_k)`` (map -> odom) interpolated linearly (x, y, yaw)
between the trajectory poses before and after ``t``, as a SLAM system's correction moves between its updates.
Relations with an end where there is no odometry (outside its time span) are not scored (counted). Bridging puts a
floor under the metric that depends on the odometry, so :func:`relation_errors` of the reference trajectory itself
is worth reporting beside a result.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.textfiles import bounded_lines, check_regular

MIN_OFFSET_VOTES = 3
MAX_RELATIONS = 1_000_000  # lines; the published files hold a few thousand
_MAX_LINE_CHARS = 4096  # a relation is two stamps and six numbers
OFFSET_RESOLUTION_S = 1e-3


@dataclass(frozen=True)
class Relation:
    """The pose at ``t2`` in the frame of the pose at ``t1`` (s, relation file's clock)."""

    t1: float
    t2: float
    delta: Pose2D


@dataclass(frozen=True)
class RelationErrors:
    """Mean and standard deviation of the translational (m) and rotational (deg) relation errors."""

    trans_mean_m: float
    trans_std_m: float
    rot_mean_deg: float
    rot_std_deg: float
    scored: int
    skipped: int
    offset_s: float

    def as_dict(self) -> dict[str, float | int]:
        return {
            "relations_trans_mean_m": self.trans_mean_m,
            "relations_trans_std_m": self.trans_std_m,
            "relations_rot_mean_deg": self.rot_mean_deg,
            "relations_rot_std_deg": self.rot_std_deg,
            "relations_scored": self.scored,
            "relations_skipped": self.skipped,
            "relations_offset_s": self.offset_s,
        }


def load_relations(path: Path) -> list[Relation]:
    """Read a relations file; a malformed line raises InvalidInputError naming ``file:line``."""
    relations: list[Relation] = []
    check_regular(path, "relations file")
    try:
        with path.open(encoding="utf-8", errors="replace") as handle:
            for number, line in enumerate(bounded_lines(handle, _MAX_LINE_CHARS, str(path)), start=1):
                words = line.split()
                if not words or words[0].startswith("#"):
                    continue
                relations.append(_relation(words, f"{path}:{number}"))
                if len(relations) > MAX_RELATIONS:
                    raise InvalidInputError(f"relations file {path} has more than {MAX_RELATIONS} relations")
    except OSError as err:
        raise InvalidInputError(f"cannot read relations file {path}: {err}") from None
    if not relations:
        raise InvalidInputError(f"relations file {path} holds no relation")
    return relations


def _relation(words: list[str], where: str) -> Relation:
    if len(words) != 8:
        raise InvalidInputError(f"{where}: a relation needs 8 numbers (t1 t2 x y z roll pitch yaw), got {len(words)}")
    try:
        t1, t2, x, y, _z, _roll, _pitch, yaw = (float(w) for w in words)
    except ValueError as err:
        raise InvalidInputError(f"{where}: malformed relation ({err})") from None
    if not all(math.isfinite(v) for v in (t1, t2, x, y, yaw)) or max(abs(x), abs(y)) > 1e5:
        raise InvalidInputError(f"{where}: relation values must be finite and within 100 km")
    return Relation(t1, t2, Pose2D(x, y, yaw))


def find_offset(relations: Sequence[Relation], stamps: Sequence[float]) -> float:
    """The clock offset ``relation stamp - trajectory stamp`` by the module's rule (s)."""
    ends = np.unique(np.array([[r.t1, r.t2] for r in relations]).ravel())
    mine = np.asarray(stamps, dtype=np.float64)
    if mine.size == 0:
        raise InvalidInputError("relations metric: the trajectory is empty")
    votes: dict[int, int] = {}
    # Chunked so that a large file never builds a huge difference matrix at once.
    for chunk in np.array_split(ends, max(1, ends.size * mine.size // 2_000_000)):
        keys, counts = np.unique(np.round((chunk[:, None] - mine[None, :]) / OFFSET_RESOLUTION_S), return_counts=True)
        for key, count in zip(keys[counts > 1].tolist(), counts[counts > 1].tolist(), strict=True):
            votes[int(key)] = votes.get(int(key), 0) + int(count)
    ranked = sorted(votes.items(), key=lambda kv: kv[1], reverse=True)
    best = ranked[0] if ranked else (0, 0)
    if len(ranked) > 1 and ranked[1][1] == best[1]:
        raise InvalidInputError(
            f"relations metric: clock offsets {best[0] * OFFSET_RESOLUTION_S:.3f} s and "
            f"{ranked[1][0] * OFFSET_RESOLUTION_S:.3f} s match equally many stamps (evenly spaced scans); "
            "give it with --relations-offset"
        )
    if best[1] < MIN_OFFSET_VOTES:
        raise InvalidInputError(
            "relations metric: no clock offset between the relations and the trajectory is supported by "
            f"{MIN_OFFSET_VOTES} or more matching stamps; give it with --relations-offset"
        )
    return best[0] * OFFSET_RESOLUTION_S


def relation_errors(
    relations: Sequence[Relation],
    stamps: Sequence[float],
    poses: Sequence[Pose2D],
    odometry: Callable[[float], Pose2D | None],
    odom_at_poses: Sequence[Pose2D],
    *,
    offset: float | None = None,
) -> RelationErrors:
    """Score the trajectory ``poses`` at ``stamps`` on ``relations`` (see the module doc).

    ``odometry(t)`` is the odometry pose at time ``t`` (trajectory clock) or None outside its span, and
    ``odom_at_poses`` the odometry at each trajectory pose.
    """
    if not (len(stamps) == len(poses) == len(odom_at_poses)) or len(stamps) < 2:
        raise InvalidInputError("relations metric needs >= 2 trajectory poses with stamps and odometry")
    if any(b <= a for a, b in itertools.pairwise(stamps)):
        raise InvalidInputError("relations metric needs trajectory stamps in increasing order")
    shift = find_offset(relations, stamps) if offset is None else offset

    corrections = [p.compose(o.inverse()) for p, o in zip(poses, odom_at_poses, strict=True)]

    def pose_at(t: float) -> Pose2D | None:
        odom = odometry(t)
        if odom is None:
            return None
        i = min(max(bisect.bisect_left(stamps, t), 1), len(stamps) - 1)
        f = min(max((t - stamps[i - 1]) / (stamps[i] - stamps[i - 1]), 0.0), 1.0)
        a, b = corrections[i - 1], corrections[i]
        correction = Pose2D(
            a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), wrap_angle(a.yaw + f * wrap_angle(b.yaw - a.yaw))
        )
        return correction.compose(odom)

    trans: list[float] = []
    rot: list[float] = []
    for relation in relations:
        a, b = pose_at(relation.t1 - shift), pose_at(relation.t2 - shift)
        if a is None or b is None:
            continue
        error = relation.delta.inverse().compose(b.relative_to(a))
        trans.append(math.hypot(error.x, error.y))
        rot.append(abs(error.yaw))
    if not trans:
        raise InvalidInputError(
            f"relations metric: no relation falls within the trajectory's time span (offset {shift:.3f} s)"
        )
    t, r = np.asarray(trans), np.degrees(np.asarray(rot))
    return RelationErrors(
        float(t.mean()), float(t.std()), float(r.mean()), float(r.std()), t.size, len(relations) - t.size, shift
    )
