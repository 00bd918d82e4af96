"""The clock offset between a relations file and a trajectory, found by the relations' own geometry.

Relation stamps are those of the raw log, a constant offset (``relation stamp - trajectory stamp``) from the
stamps of a corrected log. Matching stamps cannot be relied on to find it: a corrected log may carry its scans
with stamps of its own (Freiburg 079's do not share one stamp with its relations, and the most common difference
there is noise that scored a good trajectory 5.3 m). What every relation does carry is a relative pose over a
time: at the true offset the reference trajectory (the ground truth when there is one, else the odometry) moves
between ``t1`` and ``t2`` as the relation says, and at a wrong one it does not.

Every offset that puts relations in the trajectory's span is tried, :data:`COARSE_STEP_S` apart, and scored by
its *support*: each relation counts ``(1 - e/AGREE_M)(1 - r/AGREE_RAD)`` where its translational error ``e`` and
rotational error ``r`` are within those bounds, nothing otherwise. The best offset and the best one at least
:data:`SEPARATION_S` from it are refined (to :data:`FINE_STEP_S` / 10); the best must have :data:`MARGIN` times the
other's support and at least :data:`MIN_SUPPORT_FRACTION` of the relations' worth, else the evidence is called
weak and the offset must be given.

The offset found this way agrees with the stamps where the files share them: on the Intel log, 976052857.3373 s
against 976052857.337 s, the difference most relation ends and scans share to the millisecond.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray
from mrs_nav.slam.eval.bridging import BoolArray, BridgedTrajectory, relation_residuals

AGREE_M = 0.1
AGREE_RAD = math.radians(5.0)
COARSE_STEP_S = 0.25
SAMPLE_STEP_S = 0.05  # the reference is sampled this finely for the coarse sweep (COARSE_STEP_S a multiple)
FINE_STEP_S = 0.005
SEPARATION_S = 2.0
MARGIN = 2.0
MIN_SUPPORT_FRACTION = 0.1
COARSE_RELATIONS = 500  # at most this many relations, spread over the file, score the coarse sweep
_CHUNK = 256  # candidate offsets scored at once


@dataclass(frozen=True)
class RelationArrays:
    """Relations as arrays: the ``(n, 2)`` start and end stamps (s, relation clock) and the ``(n, 3)`` relative
    poses."""

    stamps: FloatArray
    delta: FloatArray

    @property
    def t1(self) -> FloatArray:
        return self.stamps[:, 0]

    @property
    def t2(self) -> FloatArray:
        return self.stamps[:, 1]


@dataclass(frozen=True)
class OffsetChoice:
    """The offset used (s) and how it was found (``given`` or ``geometry``); the support of the best and of the
    runner-up offset (relations' worth, see the module)."""

    offset_s: float
    rule: str
    support: float = math.nan
    runner_up_s: float = math.nan
    runner_up_support: float = math.nan


def _support(trans: FloatArray, rot: FloatArray, valid: BoolArray) -> FloatArray:
    weight = np.clip(1.0 - trans / AGREE_M, 0.0, None) * np.clip(1.0 - rot / AGREE_RAD, 0.0, None)
    return np.asarray(np.where(valid, weight, 0.0).sum(axis=-1), dtype=np.float64)


def _support_at(relations: RelationArrays, reference: BridgedTrajectory, offsets: FloatArray) -> FloatArray:
    """Support of each offset, with poses interpolated exactly."""
    start, valid1 = reference.poses_at(relations.t1[None, :] - offsets[:, None])
    end, valid2 = reference.poses_at(relations.t2[None, :] - offsets[:, None])
    return _support(*relation_residuals(start, end, relations.delta), valid1 & valid2)


def _coarse(relations: RelationArrays, reference: BridgedTrajectory) -> tuple[FloatArray, FloatArray]:
    """Every offset putting a relation in the span, :data:`COARSE_STEP_S` apart, and its support, with the
    reference sampled every :data:`SAMPLE_STEP_S` (the nearest sample taken)."""
    first, last = reference.span
    lowest = float(relations.t1.min()) - last
    offsets = np.arange(lowest, float(relations.t2.max()) - first + COARSE_STEP_S, COARSE_STEP_S)
    samples, _ = reference.poses_at(np.arange(first, last + SAMPLE_STEP_S, SAMPLE_STEP_S))
    stride = round(COARSE_STEP_S / SAMPLE_STEP_S)
    index1 = np.rint((relations.t1 - lowest - first) / SAMPLE_STEP_S).astype(np.int64)
    index2 = np.rint((relations.t2 - lowest - first) / SAMPLE_STEP_S).astype(np.int64)
    support = np.empty(offsets.size)
    for begin in range(0, offsets.size, _CHUNK):
        shift = stride * np.arange(begin, min(begin + _CHUNK, offsets.size))[:, None]
        i1, i2 = index1[None, :] - shift, index2[None, :] - shift
        valid = (i1 >= 0) & (i1 < len(samples)) & (i2 >= 0) & (i2 < len(samples))
        i1, i2 = np.clip(i1, 0, len(samples) - 1), np.clip(i2, 0, len(samples) - 1)
        residuals = relation_residuals(samples[i1], samples[i2], relations.delta)
        support[begin : begin + shift.shape[0]] = _support(*residuals, valid)
    return offsets, support


def _refine(relations: RelationArrays, reference: BridgedTrajectory, around: float) -> tuple[float, float]:
    """The best offset within a coarse step of ``around``, to :data:`FINE_STEP_S` / 10, and its support."""
    best, support = around, 0.0
    for step, reach in ((FINE_STEP_S, COARSE_STEP_S), (FINE_STEP_S / 10, FINE_STEP_S)):
        offsets = np.arange(best - reach, best + reach + step / 2, step)
        scores = _support_at(relations, reference, offsets)
        best, support = float(offsets[int(np.argmax(scores))]), float(scores.max())
    return best, support


def find_offset(relations: RelationArrays, reference: BridgedTrajectory) -> OffsetChoice:
    """The clock offset ``relation stamp - trajectory stamp`` (s) by the module's rule, or InvalidInputError
    asking for it when the evidence is weak."""
    # The coarse sweep on a sample of the relations (spread over the file) keeps it to a few seconds on any file;
    # both candidates are refined and compared on all of them.
    sample = np.linspace(0, relations.t1.size - 1, min(COARSE_RELATIONS, relations.t1.size)).astype(np.int64)
    offsets, coarse = _coarse(RelationArrays(relations.stamps[sample], relations.delta[sample]), reference)
    best_s, best = _refine(relations, reference, float(offsets[int(np.argmax(coarse))]))
    apart = np.abs(offsets - best_s) > SEPARATION_S
    runner_s, runner = math.nan, 0.0
    if apart.any():
        runner_s, runner = _refine(relations, reference, float(offsets[int(np.argmax(np.where(apart, coarse, -1)))]))
    needed = MIN_SUPPORT_FRACTION * relations.t1.size
    if best < needed or best < MARGIN * runner:
        raise InvalidInputError(
            f"relations metric: the relations' geometry does not single out a clock offset (best {best_s:.3f} s "
            f"with {best:.0f} relations' worth of support, next {runner_s:.3f} s with {runner:.0f}; needed "
            f"{MARGIN:g}x the next and at least {needed:.0f}); give it with --relations-offset SECONDS"
        )
    return OffsetChoice(best_s, "geometry", best, runner_s, runner)
