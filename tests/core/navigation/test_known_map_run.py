"""The bench's in-process run on a known map (`mrs_nav.bench.navigation.known_map_run`): one seed of the box put
in the way after mapping, and a goal with a heading, with the real simulator and laser."""

from __future__ import annotations

from mrs_nav.bench.navigation import BOX_CASES, XY_TOLERANCE, YAW_TOLERANCE, known_map_run
from mrs_nav.maps.world import load_world
from tests.conftest import WORLDS


def test_the_goal_behind_a_box_the_map_lacks_is_reached_another_way_within_the_tolerances() -> None:
    case = BOX_CASES["arena"]
    (outcome,), contacts = known_map_run(
        load_world(WORLDS / case.world), case.start, (case.goal,), seed=0, time_budget=0.25, box=case.box
    )
    assert outcome.state == "reached"
    assert contacts == 0
    assert outcome.distance_m <= XY_TOLERANCE
    assert outcome.heading_rad <= YAW_TOLERANCE
