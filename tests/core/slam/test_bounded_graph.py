"""The pose graph is bounded by the mapped extent, not by time: a seeded drive of eight laps of the course arena
with the core simulator (wheel odometry and laser noise, no ROS) adds almost no node after the first laps have
covered the arena, and the map still matches the world."""

import dataclasses

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import load_world
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.sim.simulator import SimulatorConfig
from mrs_nav.slam.eval.consistency import BROKEN_FRACTION, doubled_wall_fraction, free_endpoint_fraction
from mrs_nav.slam.eval.sim_drive import drive_with_slam
from mrs_nav.slam.keyframes import KeyframeConfig, NodeTable, ProcessedScan

CORNERS = ((1.5, -1.5), (1.5, 1.5), (-1.5, 1.5), (-1.5, -1.5))
LAP_M = 12.0  # m, once round the four corners
LAPS = 8


def test_eight_laps_of_the_arena_keep_the_graph_bounded_and_the_map_right() -> None:
    result = drive_with_slam(
        load_world(WORLDS_DIR / "simple.world"),
        Pose2D(-1.5, -1.5, 0.0),
        CORNERS * LAPS,
        sim_config=SimulatorConfig(odom_noise=0.01, seed=1),
        timeout=2000.0,
    )
    slam = result.slam
    travelled = slam.processed[-1].travelled
    assert travelled >= (LAPS - 0.5) * LAP_M
    after_two = sum(node.travelled <= 2 * LAP_M for node in slam.nodes)
    print(f"nodes after lap 2: {after_two}, after lap {LAPS}: {len(slam.nodes)}, processed {len(slam.processed)}")
    # Six more laps add at most a few nodes where noise put a pose farther than the keyframe gates from every node.
    assert len(slam.nodes) <= after_two + 5
    assert len(slam.processed) >= 3 * len(slam.nodes)  # most scans were matched and mapped, not made nodes
    # and of those, a bounded number per node is kept for rebuilding the map
    assert slam.stored_scans <= (1 + KeyframeConfig().scans_kept_per_node) * len(slam.nodes) < len(slam.processed)
    assert result.iou >= 0.9
    assert doubled_wall_fraction(slam) < BROKEN_FRACTION
    assert free_endpoint_fraction(slam) < 0.05  # nothing moves here: every stray end point is the map's


def test_the_node_table_follows_appends_and_a_replaced_list():
    table = NodeTable()
    nodes = [
        ProcessedScan(float(i), Pose2D(i, -i, 0.0), Pose2D(0.0, 0.0, 0.0), None, travelled=0.5 * i) for i in range(3)
    ]
    xy, travel = table.of(nodes)
    assert xy.tolist() == [[0.0, 0.0], [1.0, -1.0], [2.0, -2.0]]
    assert travel.tolist() == [0.0, 0.5, 1.0]
    for i in range(3, 40):  # past the rows it had to spare
        nodes.append(_node(i))
        xy, travel = table.of(nodes)
        assert xy.shape == (i + 1, 2)
        assert xy[-1].tolist() == [i, -i]
    assert travel.tolist() == [0.5 * i for i in range(40)]
    # A loop closure replaces the list with moved poses: the table is taken anew
    moved = [dataclasses.replace(n, pose=Pose2D(n.pose.x + 1.0, n.pose.y, 0.0)) for n in nodes]
    xy, travel = table.of(moved)
    assert xy[:, 0].tolist() == [i + 1.0 for i in range(40)]
    assert travel.tolist() == [0.5 * i for i in range(40)]


def _node(i: int) -> ProcessedScan:
    """Node ``i`` of a straight drive: at (i, -i) m, i / 2 m of travel."""
    return ProcessedScan(float(i), Pose2D(i, -i, 0.0), Pose2D(0.0, 0.0, 0.0), None, travelled=0.5 * i)
