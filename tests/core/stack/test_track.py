"""The bounded track keeps a short run whole and a long run evenly thinned, in fixed memory."""

from __future__ import annotations

import numpy as np

from mrs_nav.stack.track import BoundedTrack


def test_a_short_run_is_kept_whole() -> None:
    track = BoundedTrack(2, capacity=8)
    for i in range(8):
        track.append((i, -i))
    assert np.array_equal(track.array(), np.array([[i, -i] for i in range(8)]))


def test_a_long_run_is_thinned_evenly_within_the_capacity() -> None:
    track = BoundedTrack(1, capacity=8)
    for i in range(100):
        track.append((i,))
    kept = track.array()[:, 0]
    assert len(track) <= 8
    assert kept[0] == 0
    steps = np.diff(kept)
    assert np.all(steps == steps[0])  # evenly spaced samples of the whole run
    assert kept[-1] >= 100 - steps[0]  # up to the latest stride
