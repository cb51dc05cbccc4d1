"""MuJoCo's capsule/box distance where the capsule's axis runs through the box (foam_mj.capsule_box)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from foam_mj.capsule_box import geom_distance, segment_meets_box
from foam_mj.clearance import Clearance
from foam_mj.errors import ScenarioError
from foam_mj.model import RobotModel
from foam_mj.scenarios import scenario_from_dict

ARM = (
    '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
    '<geom name="wall" type="box" pos=".45 0 .15" size=".01 .3 .15"/>'
    '<body pos="0 0 .5"><joint name="j1" axis="0 1 0" range="-100 100"/><geom name="g1" type="capsule" fromto="0 0 0 .3 0 0" size=".03"/>'
    '<body pos=".3 0 0"><joint name="j2" axis="0 1 0" range="-150 150"/><geom name="g2" type="capsule" fromto="0 0 0 .25 0 0" size=".025"/>'
    '<body pos=".25 0 0"><joint name="j3" axis="0 1 0" range="-150 150"/><geom name="g3" type="capsule" fromto="0 0 0 .12 0 0" size=".02"/>'
    '</body></body></body></worldbody></mujoco>'
)
THROUGH = [0.3399, 0.7885, -1.05]  # the last link's axis through the 2 cm wall, 3 cm of it on either side


def test_an_end_point_with_a_link_stuck_through_a_wall_is_in_collision(tmp_path):
    """MuJoCo's capsule/box distance read +25 mm at THROUGH, where the last link runs right through the wall: the
    goal was accepted and its bubble certified (0.03), and every planner then searched to its budget for an island.
    The clearance now reads the penetration (at most minus the link's radius) and the goal is refused as in collision."""
    (tmp_path / "arm.xml").write_text(ARM)
    robot = RobotModel.from_xml(tmp_path / "arm.xml")
    clearance = Clearance(robot)
    try:
        assert clearance(np.array(THROUGH)) <= -0.02
        assert clearance.pairwise(np.array(THROUGH))[("g3", "wall")] == -0.02
    finally:
        clearance.close()
    with pytest.raises(ScenarioError, match=r"field 'q_goal' .* is in collision: clearance -0\.0200 m between g3 and wall"):
        scenario_from_dict({"name": "arm", "scene": "arm.xml", "q_init": [-0.5, 0.3, 0.3], "q_goal": THROUGH}, tmp_path)


def _random_poses(box_size: str, capsule_size: str, spread: float, seed: int, count: int = 600):
    """A box at the origin and a capsule on a mocap body, moved to ``count`` random poses (centre uniform in
    [-spread, spread]^3, orientation uniform): (model, data after mj_kinematics, capsule id, box id) for each."""
    m = mujoco.MjModel.from_xml_string(
        f'<mujoco><worldbody><geom name="box" type="box" size="{box_size}"/>'
        f'<body mocap="true"><geom name="cap" type="capsule" size="{capsule_size}"/></body></worldbody></mujoco>')
    d = mujoco.MjData(m)
    box, cap = m.geom("box").id, m.geom("cap").id
    rng = np.random.default_rng(seed)
    for _ in range(count):
        quat = rng.normal(size=4)
        d.mocap_pos[0], d.mocap_quat[0] = rng.uniform(-spread, spread, 3), quat / np.linalg.norm(quat)
        mujoco.mj_kinematics(m, d)
        yield m, d, cap, box


def test_a_capsule_whose_segment_meets_a_box_reads_at_most_minus_its_radius_and_mujocos_value_elsewhere():
    """Random poses of a capsule about a box: where the segment meets the box (checked against points along it), the
    distance is at most minus the capsule's radius; elsewhere it is MuJoCo's to the last bit (plans do not change)."""
    met = 0
    for m, d, cap, box in _random_poses(".04 .2 .15", ".025 .125", 0.25, seed=0):
        axis = d.geom_xmat[cap].reshape(3, 3)[:, 2]
        points = d.geom_xpos[cap] + np.outer(np.linspace(-0.125, 0.125, 2001), axis)
        local = (points - d.geom_xpos[box]) @ d.geom_xmat[box].reshape(3, 3)
        meets = bool(np.all(np.abs(local) <= m.geom_size[box], axis=1).any())
        assert segment_meets_box(m, d, cap, box) == meets or abs(np.abs(local) - m.geom_size[box]).min() < 1e-3
        for a, b in ((cap, box), (box, cap)):
            v = geom_distance(m, d, a, b, 1.0)
            if segment_meets_box(m, d, cap, box):
                assert v <= -0.025
            else:
                assert v == mujoco.mj_geomDistance(m, d, a, b, 1.0, None)
        met += meets
    assert met > 50


def test_verify_reads_a_capsule_through_a_box_as_a_penetration_on_its_own():
    """`foam-mj verify` shares no planner code: its own test (an end inside the box, or MuJoCo's ray along the axis
    meeting it) agrees with the planner's slab test on random poses, and reads at most minus the radius there."""
    from foam_mj.verify import _distance

    met = 0
    for m, d, cap, box in _random_poses(".01 .2 .15", ".02 .06", 0.15, seed=1):
        meets = segment_meets_box(m, d, cap, box)
        met += meets
        v = _distance(m, d, cap, box, 1.0)
        assert (v <= -0.02) if meets else (v == mujoco.mj_geomDistance(m, d, cap, box, 1.0, None))
    assert met > 20


def test_a_capsule_and_box_too_small_for_mujocos_distance_are_refused_naming_them(tmp_path):
    """The arm drawn 1,000 times smaller (delta too): MuJoCo read its last link 0.067 mm from the post as 1 m apart,
    and random bubbles of the plan held poses 0.056 mm deep in the post. A capsule/box pair below MuJoCo's sizes
    (a box under 0.1 mm thick, or both under 1 mm) is now refused before planning, naming both geoms; the same arm
    at full size, and a 0.4 mm sheet, plan."""
    import re

    from foam_mj.errors import ModelError

    def scaled(k: float) -> str:
        return re.sub(r'(pos|size|fromto)="([^"]*)"', lambda g: f'{g[1]}="' + " ".join(str(float(v) * k) for v in g[2].split()) + '"',
                      ARM).replace("<mujoco>", '<mujoco><compiler boundmass="1e-9" boundinertia="1e-15"/>')

    (tmp_path / "tiny.xml").write_text(scaled(0.001))
    with pytest.raises(ModelError, match=r"collision geoms g\d \(capsule, radius .* and wall \(box, half-sizes 1e-05 x 0\.0003 x "
                                         r"0\.00015 m\) are smaller than MuJoCo's capsule/box distance measures"):
        RobotModel.from_xml(tmp_path / "tiny.xml")
    (tmp_path / "arm.xml").write_text(ARM.replace('size=".01 .3 .15"', 'size=".0002 .3 .15"'))
    assert RobotModel.from_xml(tmp_path / "arm.xml").dim == 3


@pytest.fixture
def arm_clearance(tmp_path):
    """The 3-link arm by the 2 cm wall, its robot and a one-thread Clearance (closed afterwards)."""
    (tmp_path / "arm.xml").write_text(ARM)
    robot = RobotModel.from_xml(tmp_path / "arm.xml")
    clearance = Clearance(robot, threads=1)
    yield robot, clearance
    clearance.close()


def test_a_batch_reads_a_link_stuck_through_a_wall_as_one_configuration_does(arm_clearance):
    """Batched candidates are not all inside certified bubbles (bubbletree's extensions reach twice the parent's radius,
    the corridor's chords fill gaps between bubbles), so the batch must not read THROUGH as apart either: it read
    MuJoCo's +25 mm there. Now every row equals the one-at-a-time value, THROUGH among random configurations."""
    robot, clearance = arm_clearance
    rng = np.random.default_rng(1)
    Q = np.vstack([robot.lower + rng.random((300, 3)) * (robot.upper - robot.lower), THROUGH])
    batch = clearance.batch_pairs(Q)
    one = np.array([clearance.pair_distances(q) for q in Q])
    np.testing.assert_array_equal(batch, one)
    assert batch[-1].min() == -0.02 and clearance.batch(Q)[-1] == -0.02


def test_one_configuration_reads_the_guard_and_mujoco_clearance_reads_mujoco(arm_clearance):
    """At THROUGH the single query reads -0.02 (the guard, in Python floats) while ``mujoco_clearance``, a peer's
    validity checker, reads MuJoCo's own value there (+25 mm); elsewhere the two agree to the last bit."""
    robot, clearance = arm_clearance
    assert clearance(np.array(THROUGH)) == -0.02 and clearance.mujoco_clearance(np.array(THROUGH)) > 0.02
    rng = np.random.default_rng(2)
    Q = robot.lower + rng.random((300, 3)) * (robot.upper - robot.lower)
    guarded, raw = np.array([clearance(q) for q in Q]), np.array([clearance.mujoco_clearance(q) for q in Q])
    assert np.all(guarded <= raw) and np.mean(guarded == raw) > 0.9
