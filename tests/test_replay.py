"""Tests foam_mj.replay: kinematic and dynamic replay of joint trajectories on the MuJoCo leg."""

from __future__ import annotations

from foam_mj.data import model_path

import re

import mujoco
import numpy as np
import pytest

from foam_mj.bubbles import BubbleOracle
from foam_mj.foam import FoamParams, plan
from foam_mj.model import RobotModel
from foam_mj.replay import DynamicReplay, KinematicReplay, replay_dynamic, replay_kinematic, servo_controls
from foam_mj.servos import SERVO_HZ, effective_inertia, servo_model, servo_omega
from foam_mj.rosary import Rosary
from foam_mj.trajectory import Trajectory, make_trajectory

from conftest import TWO_LINK_ARM, segment_rosary

Q_INIT = [0.2, 0.3, 0.08]
Q_GOAL = [0.45, 0.4536, 1.45]
DELTA = 0.005
#: A bound on the servo tracking of the obstacle centre path: 0.5 mrad on the hinges, 0.5 mm on the hip slide
#: (it is rounding since the feed-forward is exact for MuJoCo's step: test_the_inverse_feedforward_is_exact...).
MAX_ERROR = 0.5e-3


@pytest.fixture(scope="module")
def robot() -> RobotModel:
    return RobotModel.from_xml(model_path("obstacle.xml"))


@pytest.fixture(scope="module")
def rosary(robot) -> Rosary:
    oracle = BubbleOracle(robot, delta=DELTA)
    try:
        return plan(oracle, Q_INIT, Q_GOAL, FoamParams(K=10, r_min=0.07, delta=DELTA), seed=0).rosary
    finally:
        oracle.close()


@pytest.fixture(scope="module")
def centre(robot, rosary) -> Trajectory:
    return make_trajectory(robot, rosary.path(rosary.center_waypoints()), rosary)


@pytest.fixture(scope="module")
def kinematic(robot, centre) -> KinematicReplay:
    return replay_kinematic(robot, centre)


@pytest.fixture(scope="module")
def dynamic(robot, centre) -> DynamicReplay:
    return replay_dynamic(robot, centre)


@pytest.fixture(scope="module")
def through_the_box(robot) -> Trajectory:
    """The straight line from start to goal, which sweeps the foot through the box: a one-bubble 'rosary'
    that is not certified (its radius is made up) lets make_trajectory time it."""
    a, b = np.array(Q_INIT), np.array(Q_GOAL)
    fake = Rosary(((a + b) / 2)[None], np.array([np.linalg.norm(b - a)]), a, b)
    return make_trajectory(robot, fake.path(np.empty((0, 3))), fake)


def test_kinematic_replay_keeps_clearance_on_the_centre_path(robot, centre, kinematic):
    assert kinematic.n_frames == len(centre)
    assert kinematic.min_clearance > 0
    assert kinematic.min_clearance >= DELTA - 1e-6  # the bubbles' margin
    assert kinematic.poses.body_names == ("pelvis", "thigh", "shank", "foot")
    assert kinematic.poses.xpos.shape == (len(centre), 4, 3) and kinematic.poses.xquat.shape == (len(centre), 4, 4)
    # Poses agree with MuJoCo's forward kinematics, computed here, at a few frames.
    m = robot.model
    d = mujoco.MjData(m)
    for i in (0, len(centre) // 3, len(centre) - 1):
        d.qpos[:] = centre.qpos[i]
        mujoco.mj_forward(m, d)
        assert np.allclose(kinematic.poses.xpos[i], d.xpos[kinematic.poses.body_ids])
        assert np.allclose(kinematic.poses.xquat[i], d.xquat[kinematic.poses.body_ids])
    # And the clearance agrees with MuJoCo's own contact test: nothing touches.
    assert not any(robot.in_collision(q) for q in robot.config.to_q(kinematic.qpos[::10]))


def test_dynamic_replay_of_the_centre_path_touches_nothing(robot, dynamic):
    assert dynamic.contacts == ()
    assert dynamic.min_clearance > 0
    # Independently: MuJoCo's contact test on every simulated configuration.
    assert not any(robot.in_collision(q) for q in robot.config.to_q(dynamic.qpos))


def test_dynamic_replay_tracks_within_the_stated_error(robot, centre, dynamic):
    assert dynamic.joint_names == robot.config.joint_names
    err = dynamic.qpos[:, robot.config.qpos_index] - centre.joint_positions
    assert np.allclose(err, dynamic.error)
    assert np.all(dynamic.max_error < MAX_ERROR), dynamic.max_error
    assert np.all(dynamic.rms_error < MAX_ERROR / 2), dynamic.rms_error
    assert np.allclose(dynamic.rms_error, np.sqrt(np.mean(err**2, axis=0)))
    # The servos stay inside their force ranges (no saturation hides in the figures).
    lo, hi = robot.model.actuator_forcerange.T
    assert np.all(dynamic.actuator_force > lo) and np.all(dynamic.actuator_force < hi)
    assert np.all(dynamic.saturated_frames == 0)
    assert dynamic.warnings == ()  # no MuJoCo warning (bad qacc, full contact buffers, ...)


def test_feedforward_matters_and_plain_servos_still_run(robot, centre, dynamic):
    plain = replay_dynamic(robot, centre, feedforward="none")
    assert np.all(plain.max_error > dynamic.max_error)
    assert plain.feedforward == "none" and dynamic.feedforward == "inverse"
    ctrl = servo_controls(robot, centre, feedforward="none")
    # Without feed-forward, ctrl is the reference plus the velocity term kv qdot_ref / kp.
    m = robot.model
    kp, kv = m.actuator_gainprm[:, 0], -m.actuator_biasprm[:, 2]
    joint = m.actuator_trnid[:, 0]
    expected = centre.qpos[:, m.jnt_qposadr[joint]] + kv * centre.qvel[:, m.jnt_dofadr[joint]] / kp
    assert np.allclose(ctrl, expected)



def test_the_kinematic_replay_measures_the_clearance_of_every_frame(robot, through_the_box):
    """Frame by frame, the replay's clearance is MuJoCo's smallest pair distance at that frame's qpos (computed here
    with mj_geomDistance), at frames spread over the sweep through the box, not a frame's neighbour's."""
    m, d = robot.model, mujoco.MjData(robot.model)
    kin = replay_kinematic(robot, through_the_box)
    frames = np.linspace(1, len(through_the_box) - 2, 25).astype(int)
    for i in frames:
        d.qpos[:] = through_the_box.qpos[i]
        mujoco.mj_kinematics(m, d)
        here = min(mujoco.mj_geomDistance(m, d, int(a), int(b), 1.0, None) for a, b in robot.pairs)
        assert kin.clearance[i] == pytest.approx(here, abs=1e-9), i

def test_contacts_are_reported_with_names_time_and_depth(robot, through_the_box):
    kin = replay_kinematic(robot, through_the_box)
    assert kin.min_clearance < 0
    dyn = replay_dynamic(robot, through_the_box, feedforward="gravity")
    assert dyn.contacts
    leg = {robot.geom_name(g) for g in robot.robot_geoms}
    obstacles = {robot.geom_name(g) for g in robot.obstacle_geoms}
    for c in dyn.contacts:
        assert c.leg_geom in leg and c.obstacle_geom in obstacles
        assert c.penetration >= 0
        assert c.time == pytest.approx(dyn.times[c.frame])
    assert "obstacle_box" in {c.obstacle_geom for c in dyn.contacts}
    # Independently: MuJoCo reports a collision at the first contact frame.
    assert robot.in_collision(robot.config.to_q(dyn.qpos[dyn.contacts[0].frame]))


def test_bad_inputs_raise_clear_errors(robot, centre):
    with pytest.raises(ValueError, match="`trajectory` must be a Trajectory"):
        replay_kinematic(robot, centre.qpos)
    with pytest.raises(ValueError, match="`robot` must be a RobotModel"):
        replay_dynamic(None, centre)
    with pytest.raises(ValueError, match="`feedforward` must be one of"):
        replay_dynamic(robot, centre, feedforward="pid")
    coarse = Trajectory(times=centre.times[::5], q=centre.q[::5], qpos=centre.qpos[::5], joint_names=centre.joint_names)
    with pytest.raises(ValueError, match="`trajectory.times` must be spaced by the model's timestep"):
        replay_dynamic(robot, coarse, feedforward="none")
    renamed = Trajectory(times=centre.times, q=centre.q, qpos=centre.qpos, joint_names=("a", "b", "c"))
    with pytest.raises(ValueError, match="`trajectory.joint_names`"):
        replay_kinematic(robot, renamed)
    bare = Trajectory(times=centre.times, q=centre.q, qpos=centre.qpos, joint_names=centre.joint_names)
    with pytest.raises(ValueError, match="`trajectory.qvel` and `trajectory.qacc`"):
        replay_dynamic(robot, bare)


#: A 2-hinge arm on a floating base (a free joint) with a ball-jointed hand, neither of which is a
#: configuration joint: the planner holds both at qpos0, so must the dynamic replay.
FLOATING_ARM = """
<mujoco>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="base" pos="0 0 0.6">
      {base_joint}
      <geom type="box" size="0.1 0.1 0.1" mass="5" contype="0" conaffinity="0"/>
      <body pos="0 0 0.14">
        <joint name="sh" axis="0 1 0" range="-90 90"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
        <body pos="0.3 0 0">
          <joint name="el" axis="0 1 0" range="-150 150"/>
          <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.025"/>
          <body pos="0.25 0 0">
            <joint name="hand" type="ball"/>
            <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.02"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _swing(path) -> tuple[RobotModel, Trajectory]:
    arm = RobotModel.from_xml(path)
    a, b = np.array([-1.2, 0.3]), np.array([-0.2, 1.5])
    line = segment_rosary(a, b)
    return arm, make_trajectory(arm, line.path(np.empty((0, 2))), line)


def test_joints_outside_the_configuration_are_held_as_on_a_fixed_mount(tmp_path):
    floating, fixed = tmp_path / "floating.xml", tmp_path / "fixed.xml"
    floating.write_text(FLOATING_ARM.format(base_joint='<freejoint name="root"/>'))
    fixed.write_text(FLOATING_ARM.format(base_joint=""))
    arm, swing = _swing(floating)
    assert arm.config.joint_names == ("sh", "el")
    dyn = replay_dynamic(arm, swing)
    # The base neither falls to the floor nor recoils from the servos; the ball-jointed hand does not flop.
    held = np.r_[0:7, arm.model.jnt_qposadr[3] : arm.model.jnt_qposadr[3] + 4]
    assert np.array_equal(dyn.qpos[:, held], swing.qpos[:, held])
    assert dyn.contacts == () and dyn.warnings == ()
    # The arm tracks as it does on a mount without the free joint (to 5 %).
    mounted = replay_dynamic(*_swing(fixed))
    assert np.allclose(dyn.max_error, mounted.max_error, rtol=0.05)
    assert np.all(dyn.max_error < 5e-3)


def test_a_held_body_resting_on_the_floor_does_not_shake_the_planned_joints(tmp_path):
    """A quadruped's stance feet on the floor (a Go2 of MuJoCo Menagerie, its base and three legs held, a front leg
    planned): MuJoCo's contact pushed the held feet out of the floor by accelerations that no armature resists, and
    the held base's jolts reached the swing leg, 34 mrad of tracking error on a joint that did not move. Contacts
    between bodies no configuration joint moves are left out of the replay's model: the arm tracks as on a mount."""
    stance = ('<body name="stance" pos="0 0 -0.1"><joint name="st" axis="0 1 0"/>'
              '<geom type="capsule" fromto="0 0 0 0 0 -0.473" size="0.03"/></body>')  # its foot 3 mm into the floor
    floating, fixed = tmp_path / "floating.xml", tmp_path / "fixed.xml"
    floating.write_text(FLOATING_ARM.format(base_joint='<freejoint name="root"/>' + stance))
    fixed.write_text(FLOATING_ARM.format(base_joint=""))
    arm, swing = _swing(floating)
    assert arm.config.joint_names == ("sh", "el")
    dyn = replay_dynamic(arm, swing)
    mounted = replay_dynamic(*_swing(fixed))
    assert dyn.contacts == () and dyn.warnings == ()
    assert np.allclose(dyn.max_error, mounted.max_error, rtol=0.05)


def _chain(links: int, length: float) -> str:
    """A chain of ``links`` capsules, each ``length`` long, on parallel hinges, high above a floor."""
    body, close = "", ""
    for i in range(links):
        body += (f'<body name="l{i}" pos="{0 if i == 0 else length} 0 0"><joint name="j{i}" axis="0 1 0" range="-150 150"/>'
                 f'<geom type="capsule" fromto="{length / 6} 0 0 {length * 5 / 6} 0 0" size="{length / 8}"/>')
        close += "</body>"
    return (f'<mujoco><worldbody><geom type="plane" size="1 1 0.1" pos="0 0 {-2 * links * length}"/>'
            f'<body>{body}{close}</body></worldbody></mujoco>')


@pytest.mark.parametrize("links, length", [(2, 0.004), (8, 0.12)], ids=["millimetre arm", "8-link chain"])
def test_added_servos_are_stable_on_small_robots_and_long_chains(tmp_path, links, length):
    """Added servos' kp comes from the inertia each joint drives with the others free (1 / (M^-1)_jj): from
    the diagonal M_jj, a millimetre arm's or a long chain's proximal servo was far above 10 Hz and the
    simulation blew up at the 2 ms timestep (NaN accelerations)."""
    scene = tmp_path / "chain.xml"
    scene.write_text(_chain(links, length))
    chain = RobotModel.from_xml(scene)
    a, b = np.zeros(links), np.full(links, 0.5)
    line = segment_rosary(a, b)
    dyn = replay_dynamic(chain, make_trajectory(chain, line.path(np.empty((0, links))), line))
    assert dyn.warnings == () and np.all(np.isfinite(dyn.qpos))
    assert np.all(dyn.max_error < 0.05)  # rad


KEYFRAME_ARM = """<mujoco model="arm with a wrist held at a keyframe">
  <compiler angle="radian"/>
  <option timestep="0.002"/>
  <worldbody>
    <geom type="plane" size="2 2 0.1"/>
    <geom name="post" type="box" pos="0.45 0 0.125" size="0.04 0.2 0.125"/>
    <body pos="0 0 0.5">
      <joint name="shoulder" axis="0 1 0" range="-1.7 1.7" damping="0.5"/>
      <geom type="capsule" fromto="0 0 0 0.35 0 0" size="0.03" mass="1.2"/>
      <body pos="0.35 0 0">
        <joint name="elbow" axis="0 1 0" range="-2.6 2.6" damping="0.3"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.025" mass="0.6"/>
        <body pos="0.3 0 0">
          <joint name="wrist" axis="0 1 0" range="-2 2"/>
          <geom type="capsule" fromto="0 0 0 0.15 0 0" size="0.02" mass="0.3"/>
        </body>
      </body>
    </body>
  </worldbody>
  <keyframe><key name="home" qpos="0 0 1.2"/></keyframe>
</mujoco>
"""


def test_a_saved_result_is_replayed_as_the_robot_it_was_planned_as(tmp_path):
    """``foam-mj replay`` rebuilds the robot with the result's ``robot`` options: a wrist held at its keyframe
    pose (1.2 rad, folded up) stays there, so the replay shows the planned, clean motion (at qpos0 the
    straight wrist hits the post: contacts, exit 4)."""
    from foam_mj.pipeline import run
    from foam_mj.results import outcome_from_result, read_result, write_outcome
    from foam_mj.scenarios import load_scenario

    (tmp_path / "arm.xml").write_text(KEYFRAME_ARM)
    (tmp_path / "kf.toml").write_text(
        'name = "kf"\nscene = "arm.xml"\njoints = ["shoulder", "elbow"]\nkeyframe = "home"\n'
        "q_init = [0.3, 2.0]\nq_goal = [0.1, 0.6]\n"
    )
    planned = run(load_scenario(tmp_path / "kf.toml"), 0, ("centre",), dynamic=False)
    js = write_outcome(tmp_path / "kf.json", planned)
    back = outcome_from_result(read_result(js), js, dynamic=True)
    assert back.scenario.robot.config.qpos0[2] == pytest.approx(1.2)
    before, after = planned.paths["centre"], back.paths["centre"]
    assert np.array_equal(after.trajectory.qpos, before.trajectory.qpos)
    assert after.kinematic.min_clearance == pytest.approx(before.kinematic.min_clearance, rel=1e-9)
    assert after.kinematic.min_clearance >= 0.005 and after.dynamic.contacts == ()


def test_a_servo_that_cannot_follow_is_named_with_its_ctrl_or_force_range(tmp_path):
    """A position servo whose ctrlrange is narrower than the motion is clamped by MuJoCo: the replay counts
    the clamped frames and names the servo, its joint and its range in ``limit_note`` (which plan and replay
    print), so a large tracking error is never left unexplained; servos within their ranges say nothing."""

    xml = TWO_LINK_ARM.read_text()
    servos = '<position name="sh" joint="shoulder" kp="300" kv="10" gear="2"/><position name="el" joint="elbow" kp="100" kv="3"{}/>'
    for limited, narrow in ((False, ""), (True, ' ctrlrange="-1.5 1.5"')):
        path = tmp_path / f"arm{int(limited)}.xml"
        path.write_text(xml.replace("</worldbody>", f"</worldbody><actuator>{servos.format(narrow)}</actuator>"))
        arm = RobotModel.from_xml(path)
        a, b = np.array([-0.3, 0.6]), np.array([-1.2, 2.0])  # raising the arm and folding the elbow past 1.5 rad
        line = segment_rosary(a, b)
        dyn = replay_dynamic(arm, make_trajectory(arm, line.path(np.empty((0, 2))), line))
        if not limited:
            assert dyn.limit_note == "" and not dyn.clamped_frames.any() and dyn.max_error.max() < 0.01
            continue
        assert dyn.clamped_frames[0] == 0 and dyn.clamped_frames[1] > 0
        assert dyn.max_error[1] > 0.3  # the elbow stops at 1.5 rad (plus what the servo's gravity offset gives)
        assert dyn.limit_note.startswith(f"servo 'el' (elbow): ctrl clamped to its ctrlrange [-1.5, 1.5] in {dyn.clamped_frames[1]} of {len(dyn.times)} frames")


def test_a_joint_whose_actuatorfrcrange_caps_its_servo_is_named(tmp_path):
    """MuJoCo also caps the total actuator force on a joint at the joint's ``actuatorfrcrange``: a shoulder capped
    at 2 N m, below gravity, sagged 0.87 rad below the swing, and ``limit_note`` said nothing (the same servo capped
    by its own forcerange was named). Now the joint, its range and the frames are named."""
    xml = TWO_LINK_ARM.read_text().replace('damping="0.5"', 'damping="0.5" actuatorfrcrange="-2 2"')
    (tmp_path / "arm.xml").write_text(xml.replace(
        "</worldbody>", '</worldbody><actuator><position joint="shoulder" kp="300" kv="10"/><position joint="elbow" kp="100" kv="3"/></actuator>'))
    arm = RobotModel.from_xml(tmp_path / "arm.xml")
    a, b = np.array([-0.3, 0.6]), np.array([-1.2, 2.0])
    line = segment_rosary(a, b)
    dyn = replay_dynamic(arm, make_trajectory(arm, line.path(np.empty((0, 2))), line))
    assert dyn.max_error[0] > 0.05 and not dyn.saturated_frames.any()
    n = int(dyn.joint_saturated_frames[0])
    assert n > 0 and dyn.joint_saturated_frames[1] == 0
    assert re.search(rf"joint 'shoulder': actuator force at its actuatorfrcrange \[-2, 2\] in {n} of {len(dyn.times)} frames: "
                     "the tracking error and any contacts there are the servo's", dyn.limit_note), dyn.limit_note


def test_own_servos_that_euler_makes_unstable_are_named_with_the_way_out(tmp_path):
    """Two Kinova Gen3 arms <attach>ed to a parent whose <option> is Euler's default (the arm's own MJCF asks for
    implicitfast) tracked with 3,378 mrad of error, and the note blamed only the servos' force ranges. Euler is explicit
    in actuator damping: a servo whose kv dt / I exceeds 2 grows a mode each step. The note now names that servo, the
    ratio and <option integrator="implicitfast"/>; under implicitfast the same servos track and nothing is noted."""
    servos = '<position name="sh" joint="shoulder" kp="300" kv="10"/><position name="el" joint="elbow" kp="400" kv="40" forcerange="-8 8"/>'
    for integrator in ("Euler", "implicitfast"):
        path = tmp_path / f"arm_{integrator}.xml"
        path.write_text(TWO_LINK_ARM.read_text().replace("</worldbody>", f"</worldbody><actuator>{servos}</actuator>")
                        .replace("<worldbody>", f'<option integrator="{integrator}"/><worldbody>', 1))
        arm = RobotModel.from_xml(path)
        line = segment_rosary(np.array([-0.3, 0.6]), np.array([-1.0, 1.2]))
        dyn = replay_dynamic(arm, make_trajectory(arm, line.path(np.empty((0, 2))), line))
        if integrator == "implicitfast":
            assert dyn.limit_note == "" and dyn.max_error.max() < 0.01
            continue
        assert dyn.max_error[1] > 0.01 or dyn.diverged  # the elbow shakes (24 mrad within its force range)
        assert re.match(r"servo 'el' \(elbow\) is unstable under MuJoCo's Euler integrator, explicit in actuator damping: kv 40 x "
                        r"timestep [0-9.e-]+ s / the joint's least effective inertia [0-9.e-]+ = [0-9.e+]+ > 2, .* step it with "
                        r'<option integrator="implicitfast"/>', dyn.limit_note), dyn.limit_note


def test_an_actuator_the_replay_does_not_drive_is_never_named_as_clamped(tmp_path):
    """Only the servos of the configuration joints are driven; another actuator (a motor on the held wrist whose
    ctrlrange [0.5, 1] excludes the 0 it is left at) is no servo that failed to follow, nor is the held wrist's own
    position servo, which, left at ctrl 0 while the wrist is held at the keyframe's 1.2 rad, sits at its forcerange
    (a Kinova Gen3 held at home was noted as 'servo joint_3: force at its forcerange in 266 of 266 frames')."""
    actuators = ('<actuator><position joint="shoulder" kp="300" kv="10"/><position joint="elbow" kp="100" kv="3"/>'
                 '<motor name="grip" joint="wrist" ctrlrange="0.5 1"/><position name="hold" joint="wrist" kp="50" forcerange="-1 1"/></actuator>')
    (tmp_path / "arm.xml").write_text(KEYFRAME_ARM.replace("</worldbody>", "</worldbody>" + actuators))
    arm = RobotModel.from_xml(tmp_path / "arm.xml", ["shoulder", "elbow"], keyframe="home")
    a, b = np.array([-0.3, 0.6]), np.array([-1.0, 1.2])
    line = segment_rosary(a, b)
    dyn = replay_dynamic(arm, make_trajectory(arm, line.path(np.empty((0, 2))), line))
    assert not dyn.clamped_frames.any() and not dyn.saturated_frames.any() and dyn.limit_note == ""


def test_a_joint_held_beyond_its_range_stays_a_fixed_mount(tmp_path):
    """A keyframe may hold a joint outside its range (a wrist at 1.2 rad, range +-0.5: a range written in radians
    under MuJoCo's default degrees, or the reverse). The planner holds it there; MuJoCo's limit pushed it back every
    step and the planned elbow lagged 67 mrad (the shoulder 9), with no note. The replay tracks as with the wrist in range."""
    a, b = np.array([-0.3, 0.6]), np.array([-1.0, 1.2])
    line = segment_rosary(a, b)
    errors = []
    for wrist_range in ("-2 2", "-0.5 0.5"):
        (tmp_path / "arm.xml").write_text(KEYFRAME_ARM.replace('range="-2 2"', f'range="{wrist_range}"'))
        arm = RobotModel.from_xml(tmp_path / "arm.xml", ["shoulder", "elbow"], keyframe="home")
        dyn = replay_dynamic(arm, make_trajectory(arm, line.path(np.empty((0, 2))), line))
        assert np.all(dyn.qpos[:, 2] == 1.2) and dyn.warnings == () and dyn.limit_note == ""
        errors.append(dyn.max_error)
    assert np.all(errors[1] < 1e-9), errors  # rounding, as in range
    assert np.allclose(errors[1], errors[0], atol=1e-12)


def test_an_rk4_model_replays_dynamically(tmp_path):
    """mj_step1/mj_step2 have no RK4 form: a user's RK4 model ended `foam-mj plan` with an internal error after
    the planning. A model with its own servos keeps RK4 (added servos step with implicitfast): it is stepped whole by
    mj_step and tracks within a few mrad, as the same arm under Euler does (explicit RK4 tracks the inverse-dynamics
    feed-forward less closely than MuJoCo's semi-implicit Euler: 4-5 mrad against rounding here)."""
    servos = '<actuator><position joint="sh" kp="400" dampratio="1"/><position joint="el" kp="100" dampratio="1"/></actuator>'
    xml = FLOATING_ARM.format(base_joint="").replace("</mujoco>", servos + "</mujoco>")
    euler, rk4 = tmp_path / "euler.xml", tmp_path / "rk4.xml"
    euler.write_text(xml)
    rk4.write_text(xml.replace("<mujoco>", '<mujoco><option integrator="RK4"/>', 1))
    arm, swing = _swing(rk4)
    assert arm.model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    assert servo_model(arm)[0].opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    dyn = replay_dynamic(arm, swing)
    twin = replay_dynamic(*_swing(euler))
    assert dyn.contacts == () and dyn.warnings == () and np.all(np.isfinite(dyn.qpos))
    assert np.all(twin.max_error < 3e-3) and np.all(dyn.max_error < 1e-2), (dyn.max_error, twin.max_error)
    assert np.allclose(dyn.qpos[-1, arm.config.qpos_index], swing.qpos[-1, arm.config.qpos_index], atol=1e-2)


def test_added_servos_have_a_gain_when_two_hinges_share_an_axis(tmp_path):
    """Two coaxial hinges on one body make the configuration's inertia matrix singular (either joint turns the
    body, so with the other free a joint drives nothing): 1 / (M^-1)_jj was 0 or infinite, the added servo's kp
    not a positive number, and `plan` ended in an internal error (exit 1) after planning. Such a joint's servo is
    sized from M_jj, the inertia it drives with the others held."""
    scene = tmp_path / "coaxial.xml"
    scene.write_text(
        '<mujoco><worldbody><geom type="plane" size="1 1 0.1" pos="0 0 -1"/><body>'
        '<joint name="a" axis="0 1 0" range="-90 90"/><joint name="b" axis="0 1 0" range="-90 90"/>'
        '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>'
        '<body pos="0.3 0 0"><joint name="c" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/>'
        "</body></body></worldbody></mujoco>"
    )
    robot = RobotModel.from_xml(scene)
    m, note = servo_model(robot)
    assert "added position servo" in note
    kp = m.actuator_gainprm[:, 0]
    held = robot.model.dof_M0 * (2 * np.pi * SERVO_HZ) ** 2  # kp sized from M_jj, the others held
    assert m.nu == 3 and np.all(np.isfinite(kp)) and np.all(kp > 1e-6 * held)  # each servo drives its joint
    a, b = np.zeros(3), np.array([0.3, 0.2, 0.4])
    line = segment_rosary(a, b)
    dyn = replay_dynamic(robot, make_trajectory(robot, line.path(np.empty((0, 3))), line))
    assert np.all(np.isfinite(dyn.qpos))


def test_servos_replace_motors_that_sensors_refer_to(tmp_path):
    """Cassie (MuJoCo Menagerie) reads its motors with <actuatorpos> sensors: replacing the motors by position servos
    for the replay left the sensors naming deleted actuators, the copy did not compile, and `plan` ended in an internal
    error (exit 1) after planning. The copy drops the actuator sensors (the others stay)."""
    scene = tmp_path / "sensed.xml"
    scene.write_text(
        '<mujoco><worldbody><geom type="plane" size="1 1 0.1" pos="0 0 -1"/><body>'
        '<joint name="a" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>'
        '<body pos="0.3 0 0"><joint name="b" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/>'
        '</body></body></worldbody><actuator><motor name="ma" joint="a"/><motor name="mb" joint="b"/><motor name="mx" joint="b"/></actuator>'
        '<sensor><actuatorpos name="pa" actuator="ma"/><jointpos name="jb" joint="b"/></sensor>'
        '</mujoco>'
    )
    robot = RobotModel.from_xml(scene)
    m, note = servo_model(robot)
    assert "added position servo" in note and m.nu == 2 and m.nsensor == 1
    line = segment_rosary(np.zeros(2), np.array([0.3, 0.4]))
    dyn = replay_dynamic(robot, make_trajectory(robot, line.path(np.empty((0, 2))), line))
    assert dyn.warnings == () and np.all(dyn.max_error < 5e-3)


#: A turntable whose heavy ball slides in along its arm while it turns: at qpos0, the path's start, the ball is 0.5 m
#: out, at its end 0.1 m, so the turntable's inertia there is 20 times below the one the added servo is sized at.
REACHING_TURNTABLE = """<mujoco><option timestep="0.005"{integrator}/><worldbody><geom type="box" pos="0 -0.8 0" size="0.1 0.1 0.1"/>
  <body><joint name="turn" axis="0 0 1" range="-90 90"/><geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.01" mass="0.1"/>
    <body><joint name="reach" type="slide" axis="1 0 0" range="-0.45 0"/><geom type="sphere" pos="0.5 0 0" size="0.05" mass="5"/>
  </body></body></worldbody></mujoco>"""


def _turn_with_the_ball_pulled_in(tmp_path, integrator: str = "") -> tuple[RobotModel, Trajectory]:
    (tmp_path / "turntable.xml").write_text(REACHING_TURNTABLE.format(integrator=integrator))
    table = RobotModel.from_xml(tmp_path / "turntable.xml")
    line = segment_rosary(np.array([0.0, 0.0]), np.array([1.0, -0.4]))
    return table, make_trajectory(table, line.path(np.empty((0, 2))), line)


def test_added_servos_stay_stable_where_the_inertia_is_far_below_the_one_at_qpos0(tmp_path):
    """Added servos are sized for the largest inertia along the path, which may also run where the robot's inertia is
    far smaller (generated 6-joint arms: 1.15 against 5.87 kg m^2): their damping, explicit under Euler, made eig(M^-1 kv) dt exceed 2, and every
    replay diverged (mjWARN_BADQACC, "track err unstable"). An Euler model's copy is stepped with implicitfast,
    implicit in the servos' damping: it tracks, and the robot's own model keeps its integrator."""
    table, turn = _turn_with_the_ball_pulled_in(tmp_path)
    dyn = replay_dynamic(table, turn)
    assert dyn.warnings == () and np.all(dyn.max_error < 0.01)
    m, note = servo_model(table, turn.qpos)
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST and "implicitfast integrator" in note
    assert table.model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER


@pytest.mark.parametrize("integrator", ["Euler", "RK4", "implicit", "implicitfast"])
def test_added_servos_stay_stable_under_every_integrator(tmp_path, integrator):
    """An RK4 model kept RK4 for its added servos, explicit in their damping, and the turntable's replay diverged (or
    ran off by radians without a warning, on a generated arm) where the inertia is far below the servos' largest: the
    copy is stepped with implicitfast (implicit kept), so every integrator tracks alike, and the model keeps its own."""
    table, turn = _turn_with_the_ball_pulled_in(tmp_path, f' integrator="{integrator}"')
    dyn = replay_dynamic(table, turn)
    assert dyn.warnings == () and not dyn.diverged and np.all(dyn.max_error < 0.01), (dyn.warnings, dyn.max_error)
    m, _ = servo_model(table, turn.qpos)
    kept = mujoco.mjtIntegrator.mjINT_IMPLICIT if integrator == "implicit" else mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert m.opt.integrator == kept
    assert table.model.opt.integrator == getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")


#: The turntable with its ball 0.1 m out at qpos0 and 0.35 m out on the path: the turntable's inertia on the path is
#: about 10 times the one at qpos0.
SPREADING_TURNTABLE = REACHING_TURNTABLE.replace('range="-0.45 0"', 'range="0 0.3"').replace('pos="0.5 0 0" size="0.05"', 'pos="0.1 0 0" size="0.05"')


@pytest.mark.parametrize("integrator", ["Euler", "RK4", "implicit", "implicitfast"])
def test_added_servos_are_sized_for_the_largest_inertia_along_the_path(tmp_path, integrator):
    """Added servos were sized at qpos0: where the path's inertia is far larger, they were weak (a generated arm's
    second joint: 0.03 kg m^2 at qpos0, 2.1 on its path, 30 mrad of lag). Each servo now has kp = I omega^2 and
    kv = 2 I omega with I its joint's largest effective inertia over the trajectory's frames, so it is at least as
    stiff as 10 Hz everywhere on the path, and tracks the turntable within 4.5 mrad under every integrator (5.2 mrad
    under Euler and 12.5 under RK4 with the servos sized at qpos0)."""
    scene = tmp_path / "spreading.xml"
    scene.write_text(SPREADING_TURNTABLE.format(integrator=f' integrator="{integrator}"'))
    table = RobotModel.from_xml(scene)
    line = segment_rosary(np.array([0.0, 0.25]), np.array([1.0, 0.25]))
    turn = make_trajectory(table, line.path(np.empty((0, 2))), line)
    at_start, on_path = effective_inertia(table), effective_inertia(table, turn.qpos)
    assert on_path[0] > 5 * at_start[0]
    m, note = servo_model(table, turn.qpos)
    omega = 2 * np.pi * SERVO_HZ
    np.testing.assert_allclose(m.actuator_gainprm[:, 0], on_path * omega**2, rtol=1e-9)
    np.testing.assert_allclose(-m.actuator_biasprm[:, 2], 2 * on_path * omega, rtol=1e-9)
    assert "largest effective inertia along the path" in note
    dyn = replay_dynamic(table, turn)
    assert dyn.warnings == () and np.all(dyn.max_error < 4.5e-3), dyn.max_error


def test_added_servos_stay_stable_at_a_coarse_timestep(tmp_path):
    """The implicit step of servos damped in proportion to their stiffness is stable for any inertia while
    omega dt < 4: at a 100 ms timestep (2 pi 10 Hz x 100 ms = 6.3) the added servos' frequency is capped at 2 / dt."""
    scene = tmp_path / "coarse.xml"
    scene.write_text(REACHING_TURNTABLE.format(integrator="").replace('timestep="0.005"', 'timestep="0.1"'))
    table = RobotModel.from_xml(scene)
    assert servo_omega(0.1) == pytest.approx(20.0) and servo_omega(0.005) == pytest.approx(2 * np.pi * SERVO_HZ)
    line = segment_rosary(np.array([0.0, 0.0]), np.array([1.0, -0.4]))
    dyn = replay_dynamic(table, make_trajectory(table, line.path(np.empty((0, 2))), line))
    assert dyn.warnings == () and np.all(dyn.max_error < 0.01), dyn.max_error  # uncapped: 16 rad, no warning


def test_the_inverse_feedforward_is_exact_for_mujocos_discrete_step(robot, centre, tmp_path):
    """The feed-forward is mj_inverse (discrete: MuJoCo's invdiscrete flag) at the velocities and accelerations
    with which MuJoCo's semi-implicit step lands on every row (foam_mj.replay.discrete_rates), so a servo replay
    without model error tracks the rows to rounding, both on the Ortholeg (Euler, its own servos) and on an arm
    whose servos are added (implicitfast). The continuous reference's (qvel, qacc) left 0.4-0.7 mrad on the
    Ortholeg and 1-7 mrad on generated arms: the semi-implicit step runs dt/2 ahead of it, about v dt / 2."""
    dyn = replay_dynamic(robot, centre)
    assert np.all(dyn.max_error < 1e-6), dyn.max_error
    assert robot.model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_INVDISCRETE == 0  # the caller's model untouched
    arm = RobotModel.from_xml(TWO_LINK_ARM)
    a, b = np.array(arm.config.lower) * 0.5, np.array(arm.config.upper) * 0.5
    line = segment_rosary(a, b)
    added = replay_dynamic(arm, make_trajectory(arm, line.path(np.empty((0, len(a)))), line))
    assert added.servo_note and np.all(added.max_error < 1e-6), added.max_error


def test_a_servo_saturated_only_by_its_implicit_damping_says_the_planned_torque_fits(robot, rosary):
    """Under MuJoCo's implicit integrators a position servo's force (``actuator_force``, what ``forcerange``
    clamps) carries its damping kv dt qacc, which the step takes back: the joint receives less. Timed by toppra at
    4x the default accelerations, the obstacle centre path uses the hip's 400 N m (its servo's forcerange) to
    within 0.2 % by ``mj_inverse``, and the servo sat at that range in 205 of 659 frames while ``limit_note``
    blamed the servo alone: a reader concluded the motor could not make the planned torque. The note now says
    how much of the clamped force is the servo's implicit damping and that the planned torque is within range."""
    from foam_mj.dynamics import joint_loads
    from foam_mj.limits import Limits
    from foam_mj.timing import timed_trajectory

    traj = timed_trajectory(robot, rosary.path(rosary.center_waypoints()), rosary,
                            Limits(velocity=(10, 10, 3), acceleration=(200, 200, 40)), "toppra")
    loads = joint_loads(robot, traj)
    hip = robot.config.joint_names.index("hip_flexion")
    assert loads.peak[hip] <= 400.0 + 1e-6 and loads.use[hip] > 0.99  # the plan fits the servo's range, just
    dyn = replay_dynamic(robot, traj)
    servo = mujoco.mj_name2id(robot.model, mujoco.mjtObj.mjOBJ_ACTUATOR, "hip_flexion_servo")
    assert dyn.saturated_frames[servo] > 0
    m = re.search(r"servo 'hip_flexion_servo' \(hip_flexion\): force at its forcerange \[-400, 400\] in \d+ of \d+ frames "
                  r"\(its implicit damping kv dt qacc, up to ([\d.]+) N m, is in that force; the joint torque asked peaks "
                  r"at ([\d.]+) N m\)", dyn.limit_note)
    assert m, dyn.limit_note
    share, asked = float(m.group(1)), float(m.group(2))
    kv = -robot.model.actuator_biasprm[servo, 2]
    assert 0.5 * kv * robot.model.opt.timestep * 200 < share <= 1.01 * kv * robot.model.opt.timestep * 200
    assert asked == pytest.approx(loads.peak[hip], abs=0.05 * 400)  # the discrete step's torque, near mj_inverse's
