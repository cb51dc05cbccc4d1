"""Tests for the five-joint Ortholeg (models/ortholeg5.xml) and its scenes obstacle5, step_up5, step_down5."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from foam_mj.anthropometry import SEGMENTS, segment_inertia, segment_length, segment_mass
from foam_mj.model import RobotModel
from foam_mj.scenarios import load_scenario, scenario_from_dict

from conftest import MODELS

SCENES5 = ("obstacle5", "step_up5", "step_down5")
JOINTS5 = ("hip_flexion", "knee_flexion", "hip_displacement", "hip_adduction", "ankle_dorsiflexion")


@pytest.fixture(scope="module")
def leg5() -> RobotModel:
    return RobotModel.from_xml(MODELS / "obstacle5.xml")


def _sole_pitch(robot: RobotModel, q) -> float:
    """The foot's pitch (toe up positive, rad) from its world rotation."""
    d = robot.set_configuration(np.asarray(q, float))
    R = d.xmat[robot.model.body("foot").id].reshape(3, 3)
    x = R[:, 0]  # the foot's long axis
    return float(np.arctan2(x[2], x[0]))


def test_five_joints_in_order_and_the_sagittal_leg_is_ortholeg(leg5, obstacle_robot):
    assert leg5.config.joint_names == JOINTS5
    rng = np.random.default_rng(0)
    for _ in range(20):
        q3 = rng.uniform(obstacle_robot.lower, obstacle_robot.upper)
        q5 = np.r_[q3, 0.0, 0.0]
        for body in ("thigh", "shank", "foot"):
            a = obstacle_robot.set_configuration(q3).xpos[obstacle_robot.model.body(body).id].copy()
            b = leg5.set_configuration(q5).xpos[leg5.model.body(body).id]
            np.testing.assert_allclose(b, a, atol=1e-12)


def test_joint_signs(leg5):
    foot = leg5.model.body("foot").id
    base = leg5.set_configuration(np.zeros(5)).xpos[foot].copy()
    adducted = leg5.set_configuration(np.array([0, 0, 0, 0.2, 0])).xpos[foot].copy()
    assert adducted[1] > base[1] + 0.1  # adduction moves the right foot towards the midline (+y)
    assert _sole_pitch(leg5, [0, 0, 0, 0, 0.2]) == pytest.approx(0.2, abs=1e-9)  # dorsiflexion lifts the toe


def test_inertials_follow_winters_table_plus_the_orthosis(leg5):
    m = leg5.model
    orthosis = {"thigh": 2.0, "leg": 1.5, "foot": 0.5}
    for body, seg in (("thigh", "thigh"), ("shank", "leg"), ("foot", "foot")):
        assert m.body(body).mass[0] == pytest.approx(segment_mass(seg, 75) + orthosis[seg], abs=0.01)
    # Transverse inertia of the thigh: Winter's segment plus a 0.34 m brace, both about the common CoM.
    com_h = SEGMENTS["thigh"].com * segment_length("thigh", 1.75)
    com = (7.5 * com_h + 2 * 0.2) / 9.5
    expected = segment_inertia("thigh", 1.75, 75) + 7.5 * (com - com_h) ** 2 + 2 * 0.34**2 / 12 + 2 * (0.2 - com) ** 2
    assert m.body("thigh").inertia[0] == pytest.approx(expected, rel=0.01)
    assert -m.body("thigh").ipos[2] == pytest.approx(com, abs=1e-3)


@pytest.mark.parametrize("name", SCENES5)
def test_start_and_goal_come_from_a_normal_swing(name):
    s = load_scenario(name)
    robot = s.robot
    assert robot.dim == 5
    # No hip ab/adduction at either end; the ankle plantarflexed after toe-off; the foot flat at the goal.
    assert s.q_init[3] == 0 and s.q_goal[3] == 0
    assert s.q_init[4] < 0
    assert abs(_sole_pitch(robot, s.q_goal)) < 0.01
    oracle = s.oracle()
    assert oracle.radius(s.q_init) >= 0.07  # room for a root bubble of pfm's default r_min
    assert oracle.clearance(s.q_goal) > s.params.delta


def test_subject_scaling_on_the_five_joint_leg():
    s = scenario_from_dict(
        {"scene": "obstacle5.xml", "q_init": [0.2, 1.05, 0.08, 0, -0.2], "q_goal": [0.45, 0.4536, 1.45, 0, 0.0036], "subject": {"height": 1.62, "mass": 58}},
        MODELS,
    )
    m = s.robot.model
    assert np.linalg.norm(m.body("shank").pos) == pytest.approx(segment_length("thigh", 1.62), abs=1e-6)
    assert np.linalg.norm(m.body("foot").pos) == pytest.approx(segment_length("leg", 1.62), abs=1e-6)
    assert 2 * m.geom("foot_collision").size[0] == pytest.approx(segment_length("foot", 1.62), abs=1e-6)
    # The added joints keep their axes and ranges.
    j = m.joint("ankle_dorsiflexion")
    np.testing.assert_allclose(j.range, [-0.52, 0.35])
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "hip_adduction") >= 0


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES5)
def test_the_five_joint_scenes_plan_on_ten_seeds(name):
    from conftest import MujocoChecker
    from foam_mj.pipeline import plan_scenario
    from foam_mj.smoothing.gradient import center_path_result

    s = load_scenario(name)
    checker = MujocoChecker(s.robot)
    for seed in range(10):
        res = plan_scenario(s, seed)
        assert res.rosary.check_structure() == [], (name, seed)
        path = center_path_result(res.rosary).path
        np.testing.assert_array_equal(path[[0, -1]], [s.q_init, s.q_goal])
        assert checker.first_collision_along(path, step=2e-3) is None, (name, seed)
