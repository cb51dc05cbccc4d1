"""Crowded scenes (tests/crowded.py): many small obstacles around a robot, obstacles on several bodies, thin plates,
a door barely wider than the robot plus its margins. Plans keep the margin by MuJoCo alone; memory stays bounded."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from crowded import crowded_spec


@pytest.fixture(scope="module")
def boxes_arm():
    """bench_arm6 among 60 random boxes: 240 capsule/box pairs for the batch's capsule/box guard."""
    from foam_mj.model import RobotModel

    return RobotModel.from_spec(crowded_spec(60, 0, kinds=("box",)), "crowded.xml")


def test_the_capsule_box_guard_of_a_large_batch_in_a_crowded_scene_takes_bounded_memory(boxes_arm):
    # Its slab test gathered 27 values per capsule/box pair and configuration at once, three such arrays: for 240 pairs
    # and 1,000 configurations 155 MB of temporaries beside a 2.5 MB result (bubbletree's corridor asks for batches
    # of 3,781 configurations among 200 obstacles: 490 MB). It now works through the rows in blocks.
    from foam_mj.clearance import Clearance

    c = Clearance(boxes_arm)
    rows, pairs = c._capsule_box_rows[0], len(boxes_arm.pairs)
    assert len(rows) >= 200
    Q = np.random.default_rng(0).uniform(boxes_arm.lower, boxes_arm.upper, (1000, boxes_arm.dim))
    whole = c.batch_pairs(Q)  # makes the batch (MuJoCo's memory, not numpy's)
    tracemalloc.start()
    try:
        again = c.batch_pairs(Q)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert np.array_equal(whole, again)
    assert peak < 12 * whole.nbytes + 16 * 2**20, f"{peak / 2**20:.0f} MB for a {whole.nbytes / 2**20:.1f} MB result ({pairs} pairs)"
    c.close()


def test_a_robot_among_400_spheres_builds_about_as_fast_as_among_400_boxes():
    # A fixed sphere, capsule or cylinder is tested for joints that turn the robot about its axis (foam_mj.geom_pairs),
    # at a reference pose; that MjData was made anew for each pair, twice: 2,016 pairs took 1.64 s against 0.04 s among
    # boxes (a room of 1,000 mixed obstacles: 3.7 s). Now one per model: 0.17 s, the same coordinates per pair.
    import time

    from foam_mj.geom_pairs import pair_coordinates
    from foam_mj.model import RobotModel

    took = {}
    for kind in ("sphere", "box"):
        spec = crowded_spec(400, 0, kinds=(kind,), keep=None, radius=(1.5, 3.0))
        start = time.process_time()
        robot = RobotModel.from_spec(spec, f"{kind}s.xml")
        took[kind] = (robot, time.process_time() - start)
    robot, spheres = took["sphere"]
    assert len(robot.pairs) > 2000
    assert spheres < 4 * took["box"][1] + 0.3, took
    for p in range(0, len(robot.pairs), 97):  # each pair's own reference pose gives the same coordinates
        a, b = robot.pairs[p]
        assert np.array_equal(pair_coordinates(robot.model, robot.config, robot.moves, int(a), int(b)), robot.pair_active[p])
