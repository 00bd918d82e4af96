"""Place signatures of laser scans: which older scans were taken near where a scan was, whatever the pose
estimates say.

A scan's signature is a normalised two-dimensional histogram over the pairs of its end points: the distance
between the two points and the distance from the laser to their midpoint. Both stay the same when the laser
turns, so a place is recognised whatever heading the pose estimate has drifted to; the first stays the same when
it moves, the second changes by at most the move, so a scan taken a metre away keeps most of its signature. Two
signatures are compared by the L1 distance between the histograms (0 the same, 2 nothing in common).

It is the shape distribution of Osada et al. ("Shape distributions", ACM Transactions on Graphics 21(4), 2002,
their D2: the distances between random pairs of points of a shape), with the midpoint's range added, because the
pair distances alone are the same anywhere along a corridor.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from mrs_nav.geometry import FloatArray

SIGNATURE_POINTS = 256  # end points at most that a signature is taken from, spread evenly over the scan
PAIR_STEP_M = 0.5  # m, bin width of the distance between the two points
RANGE_STEP_M = 1.0  # m, bin width of the distance from the laser to their midpoint
SIGNATURE_REACH_M = 16.0  # m: pairs farther apart, or farther out, fall into the last bin

_PAIR_BINS = round(SIGNATURE_REACH_M / PAIR_STEP_M)
_RANGE_BINS = round(SIGNATURE_REACH_M / RANGE_STEP_M)
SIGNATURE_SIZE = _PAIR_BINS * _RANGE_BINS  # values in a signature

Signature = npt.NDArray[np.float32]


def signature(points: FloatArray) -> Signature | None:
    """The signature of a scan's end points (N x 2, laser frame); None for fewer than 3 points."""
    n = points.shape[0]
    if n < 3:
        return None
    if n > SIGNATURE_POINTS:
        points = points[np.linspace(0, n - 1, SIGNATURE_POINTS).round().astype(np.int64)]
    first, second = np.triu_indices(points.shape[0], 1)
    a, b = points[first], points[second]
    apart = np.hypot(a[:, 0] - b[:, 0], a[:, 1] - b[:, 1])
    midpoint = np.hypot(a[:, 0] + b[:, 0], a[:, 1] + b[:, 1]) / 2.0
    pair_bin = np.minimum((apart / PAIR_STEP_M).astype(np.int64), _PAIR_BINS - 1)
    range_bin = np.minimum((midpoint / RANGE_STEP_M).astype(np.int64), _RANGE_BINS - 1)
    counts = np.bincount(pair_bin * _RANGE_BINS + range_bin, minlength=_PAIR_BINS * _RANGE_BINS)
    normalised: Signature = (counts / counts.sum()).astype(np.float32)
    return normalised


def differences(one: Signature, others: npt.NDArray[np.float32]) -> FloatArray:
    """L1 distances between the signature ``one`` and each row of ``others`` (0: the same, 2: disjoint)."""
    return np.asarray(np.abs(others - one).sum(axis=1), dtype=np.float64)
