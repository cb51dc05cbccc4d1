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


def _mujoco_min_clearance(result: dict) -> float:
    """The smallest mj_geomDistance between a geom on a moving body and a static one over every path's qpos rows of a
    ``plan --json`` result (MuJoCo alone, as shared/tools/verify_result.py)."""
    from tests.test_bring_your_own_robot import _independent_clearance

    return min(_independent_clearance(result["mjcf"], np.asarray(path["qpos"])) for path in result["paths"].values())


def test_a_plan_among_30_obstacles_and_thin_plates_on_six_bodies_keeps_the_margin(tmp_path):
    # bench_arm6 from one side of its box to the other among 30 random boxes, capsules, cylinders, spheres and plates
    # 1-4 mm thick, five to a static body: plan (bubbletree, optimal smoother), then verify, then MuJoCo alone.
    import json

    from crowded import KINDS, write_crowded

    from foam_mj.cli import main

    scene = write_crowded(tmp_path / "crowd.xml", 30, 2, kinds=KINDS + ("plate",), bodies=5)
    out = tmp_path / "crowd.json"
    start, goal = "-0.7 0.87 1.12 -0.08 0 0", "0.7 0.87 1.12 -0.08 0 0"
    assert main(["plan", "--mjcf", str(scene), "--start", start, "--goal", goal, "--no-rrd", "--json", str(out), "--quiet",
                 "--time-limit", "30"]) == 0
    assert main(["verify", str(out)]) == 0
    result = json.loads(out.read_text())
    assert set(result["paths"]) == {"centre", "optimal"}
    assert _mujoco_min_clearance(result) >= result["planner"]["delta"] - 1e-9


def test_the_walker_passes_a_door_5_cm_wider_than_itself_and_its_margins_and_not_one_narrower(tmp_path, capsys):
    # The CloudWalker (0.64 m wide, delta 5 cm) through a 0.1 m wall: a 0.84 m door leaves 5 cm on each side beyond the
    # margin, and bubbletree passes it (1.2 s); a 0.73 m door cannot be passed with the margin kept, and the plan fails
    # (exit 3) within its time limit, saying where the trees came nearest and which geoms block the way.
    import json
    import time

    from crowded import write_door

    from foam_mj.cli import main

    args = ["--start", "2 2 0", "--goal", "8 8 0", "--delta", "0.05", "--no-rrd", "--quiet", "--no-replay"]
    out = tmp_path / "door.json"
    assert main(["plan", "--mjcf", str(write_door(tmp_path / "wide.xml", 0.84)), *args, "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    q = np.array(result["paths"]["optimal"]["waypoints"])
    assert q[:, 0].min() < 4.5 and q[:, 0].max() > 5.5
    assert main(["verify", str(out)]) == 0
    capsys.readouterr()
    start = time.perf_counter()
    assert main(["plan", "--mjcf", str(write_door(tmp_path / "narrow.xml", 0.73)), *args, "--time-limit", "2"]) == 3
    assert time.perf_counter() - start < 2 + 10
    err = capsys.readouterr().err
    assert "planning failed: the trees did not meet" in err and "came nearest at q = [" in err and "wall_" in err
