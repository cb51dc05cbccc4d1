"""Tests for planning on a user's own MJCF (README "Bring your own robot"): `foam-mj plan --mjcf`, servos
added to a model without actuators (foam_mj.servos.servo_model), and bad robots refused before planning."""

from __future__ import annotations

import json
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest

from foam_mj.cli import main
from foam_mj.model import RobotModel
from foam_mj.servos import SERVO_HZ, servo_model

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
ARM = EXAMPLES / "two_link_arm" / "arm.xml"
START, GOAL = "0.3 2.0", "0.1 0.6"


def _independent_clearance(mjcf: str, qpos_rows: np.ndarray) -> float:
    """min mj_geomDistance between geoms on moving bodies and static geoms, over qpos rows (MuJoCo alone)."""
    m = mujoco.MjModel.from_xml_path(mjcf)
    d = mujoco.MjData(m)

    def moving(b: int) -> bool:
        while b:
            if m.body_jntnum[b]:
                return True
            b = int(m.body_parentid[b])
        return False

    coll = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
    leg = [g for g in coll if moving(int(m.geom_bodyid[g]))]
    obs = [g for g in coll if not moving(int(m.geom_bodyid[g]))]
    worst = np.inf
    for row in qpos_rows:
        d.qpos[:] = row
        mujoco.mj_kinematics(m, d)
        worst = min(worst, min(mujoco.mj_geomDistance(m, d, g, o, 1.0, None) for g in leg for o in obs))
    return float(worst)


def test_plan_on_an_unmodified_mjcf_from_the_command_line(tmp_path, capsys):
    js = tmp_path / "arm.json"
    assert main(["plan", "--mjcf", str(ARM), "--start", START, "--goal", GOAL, "--delta", "0.01", "--no-rrd", "--json", str(js)]) == 0
    out = capsys.readouterr().out
    assert "note: dynamic replay:" in out and "added position servo" in out
    # The servos are sized per path: one note for all paths, each joint's kp (or its range over them) in it.
    assert out.count("added position servo") == 1 and ": kp shoulder " in out
    assert "mm for slides); contacts: robot/obstacle contacts" in out  # not the Ortholeg's "hip slide" and "leg"
    doc = json.loads(js.read_text())
    assert doc["mjcf"] == str(ARM.resolve()) and doc["planner"]["delta"] == 0.01
    for name, entry in doc["paths"].items():
        assert _independent_clearance(doc["mjcf"], np.asarray(entry["qpos"])) >= 0.01 - 1e-9, name
        assert entry["replay"]["contacts"] == 0
    assert main(["replay", str(js)]) == 0


def test_joints_flag_picks_the_configuration(tmp_path, capsys):
    # Only the elbow moves; the shoulder stays at its qpos0 (arm horizontal, above the post).
    js = tmp_path / "elbow.json"
    assert main(["plan", "--mjcf", str(ARM), "--joints", "elbow", "--start", "-0.5", "--goal", "0.5", "--no-rrd", "--no-replay", "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    assert doc["configuration"]["joints"] == ["elbow"]
    # A scenario's joints are written into the saved scene copy, which "mjcf" points to.
    again = RobotModel.from_xml(doc["mjcf"])
    assert again.config.joint_names == ("elbow",)


def test_every_smoother_plans_for_a_one_joint_robot(tmp_path, capsys):
    """With one configuration joint, gradient smoothing (T_CA) ended in an IndexError (exit 1): its
    coordinate sums and the hatch projection's normals assumed at least two coordinates."""
    js = tmp_path / "elbow.json"
    argv = ["plan", "--mjcf", str(ARM), "--joints", "elbow", "--start", "-0.5", "--goal", "0.5", "--smoother", "all",
            "--no-rrd", "--no-replay", "--json", str(js)]
    assert main(argv) == 0
    assert "RuntimeWarning" not in capsys.readouterr().err
    doc = json.loads(js.read_text())
    assert {"gradient", "hs", "ga", "convex", "optimal"} <= set(doc["paths"])
    for name, entry in doc["paths"].items():
        assert _independent_clearance(doc["mjcf"], np.asarray(entry["qpos"])) >= 0.005 - 1e-9, name


def test_servos_added_to_a_model_without_actuators_have_gains_from_the_joint_inertia():
    robot = RobotModel.from_xml(ARM)
    m, note = servo_model(robot)
    assert m is not robot.model and m.nu == 2 and note.startswith("dynamic replay:")
    # kp = the inertia each joint drives with the other free, 1 / (M^-1)_jj, times (2 pi f)^2: at qpos0 without a path
    d = mujoco.MjData(robot.model)
    mujoco.mj_forward(robot.model, d)
    M = np.zeros((2, 2))
    mujoco.mj_fullM(robot.model, d, M)
    np.testing.assert_allclose(m.actuator_gainprm[:, 0], (2 * np.pi * SERVO_HZ) ** 2 / np.diag(np.linalg.inv(M)), rtol=1e-9)
    assert np.all(m.actuator_biasprm[:, 2] < 0)  # damped
    # A model that has its servos keeps them, with no note.
    from conftest import MODELS

    leg = RobotModel.from_xml(MODELS / "obstacle.xml")
    assert servo_model(leg) == (leg.model, "")


BAD = """
<mujoco>
  <worldbody>
    <geom type="plane" size="2 2 0.1"/>
    <body name="a" pos="0 0 1">
      <joint name="swivel" type="ball"/>
      <geom type="sphere" size="0.05"/>
      <body name="b" pos="0 0 -0.3">
        <joint name="spin" type="hinge" axis="0 1 0"/>
        <joint name="lift" type="slide" axis="0 0 1" range="-0.1 0.1"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/>
        <site name="s1"/>
      </body>
    </body>
    <site name="s2" pos="1 0 1"/>
  </worldbody>
  <tendon>
    <spatial name="cable" limited="true" range="0 2"><site site="s1"/><site site="s2"/></spatial>
  </tendon>
</mujoco>
"""


@pytest.mark.parametrize("joint, reason", [("swivel", "ball joint"), ("spin", "has no range"), ("cable", "is a tendon")])
def test_bad_robots_exit_2_with_one_line_before_planning(tmp_path, capsys, joint, reason):
    p = tmp_path / "bad.xml"
    p.write_text(BAD)
    code = main(["plan", "--mjcf", str(p), "--joints", joint, "--start", "0", "--goal", "0.05", "--no-rrd"])
    cap = capsys.readouterr()
    assert code == 2
    assert cap.out == ""  # nothing planned
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and f"'{joint}'" in lines[0] and reason in lines[0]


@pytest.mark.parametrize("where", ["joint", "default class"])
def test_a_range_that_mujoco_ignores_is_named_as_such(tmp_path, capsys, where):
    """A joint with range="-0.5 1.4" and limited="false" was refused as having 'no range' and told to add
    range="lo hi", which it has: the message now says why MuJoCo ignores that range and what to set."""
    if where == "joint":
        xml = BAD.replace('name="spin"', 'name="spin" range="-0.5 1.4" limited="false"')
    else:
        xml = BAD.replace('name="spin"', 'name="spin" range="-0.5 1.4"').replace(
            "<mujoco>", '<mujoco><default><joint limited="false"/></default>', 1)
    p = tmp_path / "bad.xml"
    p.write_text(xml)
    assert main(["plan", "--mjcf", str(p), "--joints", "spin", "--start", "0", "--goal", "0.05", "--no-rrd"]) == 2
    err = capsys.readouterr().err
    assert "'spin' has range=\"-0.5 1.4\" but limited=\"false\"" in err and 'set limited="true"' in err


def test_default_configuration_skips_unlimited_and_ball_joints(tmp_path, capsys):
    p = tmp_path / "bad.xml"
    p.write_text(BAD)
    robot = RobotModel.from_xml(p)
    assert robot.config.joint_names == ("lift",)


def test_subject_flags_scale_the_leg_and_the_result_names_the_scaled_scene(tmp_path):
    from foam_mj.anthropometry import segment_length

    js = tmp_path / "small.json"
    assert main(["plan", "--scene", "step_up5", "--subject-height", "1.62", "--subject-mass", "58", "--no-rrd", "--no-replay", "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    assert doc["scene_edits"]["subject"] == {"height": 1.62, "mass": 58.0}
    assert Path(doc["mjcf"]).name == "small.scene.xml" and Path(doc["scene_source"]).name == "step_up5.xml"
    m = mujoco.MjModel.from_xml_path(doc["mjcf"])  # MuJoCo alone loads the scene that was planned on
    assert np.linalg.norm(m.body("shank").pos) == pytest.approx(segment_length("thigh", 1.62), abs=1e-6)
    for entry in doc["paths"].values():
        assert _independent_clearance(doc["mjcf"], np.asarray(entry["qpos"])) >= doc["planner"]["delta"] - 1e-9


OVERLAPPING_LINKS = """<mujoco model="short wrist">
  <compiler angle="radian"/>
  <worldbody>
    <geom name="post" type="box" pos="0.6 0 0.5" size="0.05 0.05 0.5"/>
    <body name="upper" pos="0 0 0.5"><joint name="a" axis="0 0 1" range="-2 2"/>
      <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.035"/>
      <body name="wrist" pos="0.25 0 0"><joint name="b" axis="1 0 0" range="-2 2"/>
        <geom type="capsule" fromto="0 0 0 0.05 0 0" size="0.03"/>
        <body name="fore" pos="0.05 0 0"><joint name="c" axis="0 0 1" range="-2 2"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.03"/>
        </body></body></body>
  </worldbody>
  {contact}
</mujoco>
"""


def test_links_that_overlap_by_design_are_named_with_the_way_out(tmp_path, capsys):
    """Capsules of a grandparent and a grandchild that overlap at every pose (MuJoCo filters only parent and
    child): the start is refused (exit 2) naming the pair and how to exclude it; with that exclude it plans."""
    xml = tmp_path / "arm.xml"
    xml.write_text(OVERLAPPING_LINKS.replace("{contact}", ""))
    argv = ["plan", "--mjcf", str(xml), "--start", "-0.5 0 0.3", "--goal", "0.5 0 0.3", "--smoother", "none",
            "--no-replay", "--no-rrd"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "in collision" in err
    assert 'robot/robot pair' in err and '<contact><exclude body1="upper" body2="fore"/>' in err
    xml.write_text(OVERLAPPING_LINKS.replace("{contact}", '<contact><exclude body1="upper" body2="fore"/></contact>'))
    assert main(argv) == 0


def test_robot_flags_reach_the_plan_and_its_result(tmp_path, capsys):
    js = tmp_path / "arm.json"
    argv = ["plan", "--mjcf", str(ARM), "--start", START, "--goal", GOAL, "--no-self-collision", "--smoother", "none",
            "--no-rrd", "--no-replay", "--json", str(js)]
    assert main(argv) == 0
    assert json.loads(js.read_text())["robot"]["self_collision"] is False
    capsys.readouterr()
    # a robot root that the model does not have is a one-line bad input, before any planning
    assert main([*argv[:-2], "--robot-root", "no_such_body", "--json", str(tmp_path / "bad.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert "no_such_body" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "bad.json").exists()


def test_a_base_exactly_delta_above_the_floor_is_refused_and_its_distance_is_the_plans_min_clearance(tmp_path, capsys):
    """MuJoCo Menagerie's Sawyer: its base capsule, turned by a vertical axis, ends 0.2025 - 0.1275 - 0.07 = 5 mm above
    the floor, the default delta. That pair's distance, measured once (no configuration joint changes it), read 4e-18 m
    above delta and passed; turned along the path it read 1e-18 m below on hundreds of verify's samples (UNSAFE), while
    plan's summary said min clear 41 mm, leaving the pair out. Now such a pair is refused at delta (a smaller delta
    plans), and the summary's min clear, as verify's, counts it."""
    xml = tmp_path / "sawyer_like.xml"
    xml.write_text(
        '<mujoco><compiler angle="radian"/><worldbody><geom name="floor" type="plane" size="2 2 .1"/><geom name="post" type="box" size=".05 .05 .3" pos=".5 .3 .3"/>'
        '<body name="l0"><joint name="j0" axis="0 0 1" range="-3 3"/><geom name="base" type="capsule" size=".07 .1275" pos="0 0 .2025"/>'
        '<body name="l1" pos="0 0 .4"><joint name="j1" axis="0 1 0" range="-1 1"/>'
        '<geom name="arm" type="capsule" fromto="0 0 0 .6 0 0" size=".03"/></body></body></worldbody></mujoco>')
    args = ["plan", "--mjcf", str(xml), "--start", "-1 0", "--goal", "1.5 0", "--smoother", "none", "--no-rrd", "--no-replay"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "robot geom base and obstacle floor are 0.005000000000 m apart, at the safety margin delta 0.005 m" in err
    assert "or plan with a smaller delta" in err and len(err.strip().splitlines()) == 1
    out = tmp_path / "out.json"
    assert main([*args[:-1], "--delta", "0.004", "--json", str(out)]) == 0
    summary = capsys.readouterr().out
    assert "     5.0 mm " in summary.split("centre (T)")[1].splitlines()[0]  # the base's 5 mm, not the arm's clearance
    assert main(["verify", str(out)]) == 0


def test_a_held_stance_foot_on_the_floor_under_robot_root_is_refused_with_the_keyframe_way_out(tmp_path, capsys):
    """MuJoCo Menagerie's Cassie planned over one hip with --robot-root on its floating pelvis: the other foot, held
    where qpos0 puts it (4.8 mm into the floor), was refused with 'make a joint between them a configuration joint',
    no help for a stance foot. The message now says the foot is held and names the way out, a keyframe that lifts it,
    and that way plans."""
    xml = tmp_path / "biped.xml"
    xml.write_text(
        '<mujoco><compiler angle="radian"/><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
        '<body name="pelvis" pos="0 0 .5"><freejoint/><geom type="box" size=".1 .15 .05"/>'
        '<body name="swing" pos="0 .1 -.05"><joint name="hip" axis="0 1 0" range="-1 1"/>'
        '<geom type="capsule" fromto="0 0 -.02 0 0 -.3" size=".03"/></body>'
        '<body name="stance" pos="0 -.1 -.05"><joint name="other" axis="0 1 0" range="-1 1"/>'
        '<geom name="stance_foot" type="capsule" fromto="0 0 -.1 0 0 -.45" size=".03"/></body></body></worldbody>'
        '<keyframe><key name="lifted" qpos="0 0 .55 1 0 0 0 0 0"/></keyframe></mujoco>')
    args = ["plan", "--mjcf", str(xml), "--joints", "hip", "--robot-root", "pelvis", "--goal", "0.8",
            "--smoother", "none", "--no-rrd", "--no-replay"]
    assert main([*args, "--start", "-0.5"]) == 2  # the foot 30 mm into the floor at qpos0
    err = capsys.readouterr().err
    assert "robot geom stance_foot and obstacle floor are -0.0300 m apart" in err
    assert "; stance_foot is held where qpos0 or the keyframe puts it (a floating base's stance foot): lift it clear " \
           "with a keyframe (keyframe = \"NAME\" in a scenario, or --start NAME), or leave robot_root out: held bodies " \
           "outside the robot stay where they stand as obstacles, with a note" in err
    assert main([*args, "--start", "lifted"]) == 0  # 20 mm above the floor


def test_a_pair_that_caps_every_bubble_is_named_with_the_exclude_that_frees_the_planner(tmp_path, capsys):
    """MuJoCo Menagerie's H1 leg planned with 2,903 bubbles where OMPL's RRTConnect took 0.2 s, without a word why: its
    hip-yaw cylinder stays 11.7 mm from the hip-pitch link at every hip angle, which caps every bubble at (d - delta) /
    ||rho||. plan now names such a pair (most of the rosary sized by it, its distance nearly constant along it) and the
    <exclude> that leaves it out; here a ball on the thigh, centred on its three hip axes, 12 mm below a collar."""
    xml = ('<mujoco><compiler angle="radian"/><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
           '<body name="pelvis" pos="0 0 1"><geom name="pelvis" type="box" size=".1 .1 .05" pos="0 0 .2"/>'
           '<body name="yaw_link"><joint name="yaw" axis="0 0 1" range="-.5 .5"/><geom name="collar" type="cylinder" size=".04 .03" pos="0 0 .1"/>'
           '<body name="roll_link"><joint name="roll" axis="1 0 0" range="-.5 .5"/><inertial pos="0 0 0" mass=".5" diaginertia="1e-3 1e-3 1e-3"/>'
           '<body name="thigh"><joint name="pitch" axis="0 1 0" range="-1.5 1.5"/><geom name="ball" type="sphere" size=".058"/>'
           '<geom name="thigh" type="capsule" fromto="0 0 -.1 0 0 -.45" size=".04"/></body></body></body></body></worldbody>{extra}</mujoco>')
    args = ["--robot-root", "pelvis", "--start", "-0.3 -0.3 -1.2", "--goal", "0.3 0.3 1.2", "--smoother", "none", "--no-rrd", "--no-replay"]
    bubbles = {}
    for name, extra in (("close", ""), ("excluded", '<contact><exclude body1="yaw_link" body2="thigh"/></contact>')):
        (tmp_path / f"{name}.xml").write_text(xml.replace("{extra}", extra))
        assert main(["plan", "--mjcf", str(tmp_path / f"{name}.xml"), *args]) == 0
        out = capsys.readouterr().out
        bubbles[name] = int(out.split("): ")[1].split(" bubbles")[0].replace(",", ""))
        notes = [line for line in out.splitlines() if "bubbles are sized by" in line]
        if name == "close":
            assert len(notes) == 1 and " bubbles are sized by collar / ball, 12.0-12.0 mm apart all along the path: a pair that stays so close caps every bubble" in notes[0]
            assert notes[0].endswith('<contact><exclude body1="yaw_link" body2="thigh"/> leaves the pair out')
        else:
            assert not notes
    assert bubbles["excluded"] * 4 < bubbles["close"]  # 101 against 1,025 (seed 0)
    # A pair whose distance varies (the ball 6 mm off the axes: 12.4-18.0 mm) but stays within 3 margins all along
    # (MuJoCo Menagerie's Shadow hand: forearm and palm 2.6-5.5 mm apart at delta 2 mm) is named too.
    (tmp_path / "varying.xml").write_text(xml.replace("{extra}", "").replace('size=".058"/>', 'size=".058" pos="0 0 -.006"/>'))
    assert main(["plan", "--mjcf", str(tmp_path / "varying.xml"), "--delta", "0.007", *args[:2], "--start", "-0.5 -0.5 -1.5",
                 "--goal", "0.5 0.5 1.5", *args[6:]]) == 0
    assert re.search(r"note: \d+ of the rosary's \d+ bubbles are sized by collar / ball, 12\.\d-18\.0 mm apart", capsys.readouterr().out)


def test_an_end_point_too_close_to_the_robot_itself_does_not_say_obstacle(tmp_path, capsys):
    """MuJoCo Menagerie's Shadow hand, its index finger bent 2.05 mm from the palm at delta 2 mm... or here a forearm
    link 3 mm from the upper arm: the start was 'too close to an obstacle' though the pair is the robot's own; it is
    now 'too close to itself', with the <exclude> way out."""
    xml = tmp_path / "arm.xml"
    xml.write_text(OVERLAPPING_LINKS.replace("{contact}", "").replace('<body name="fore" pos="0.05 0 0">', '<body name="fore" pos="0.068 0 0">'))
    assert main(["plan", "--mjcf", str(xml), "--start", "-0.5 0 0", "--goal", "0.5 0 0.3", "--smoother", "none", "--no-replay", "--no-rrd"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--start = [-0.5, 0.0, 0.0] is too close to itself: clearance 0.0030 m between " in err
    assert 'robot/robot pair' in err and '<contact><exclude body1="upper" body2="fore"/>' in err


def test_an_end_point_keyframe_of_a_robot_without_joints_to_plan_is_refused_under_the_flag(tmp_path, capsys):
    """MuJoCo Menagerie's Skydio X2 (a free joint only) with --start hover --goal hover: the error read
    'scenario: --mjcf: ...', 'scenario' being no file or flag of the user's; it now starts with the flag."""
    xml = tmp_path / "drone.xml"
    xml.write_text('<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/><body name="x2" pos="0 0 .3"><freejoint/>'
                   '<geom type="box" size=".1 .1 .02"/></body></worldbody><keyframe><key name="hover" qpos="0 0 .5 1 0 0 0"/>'
                   '</keyframe></mujoco>')
    assert main(["plan", "--mjcf", str(xml), "--start", "hover", "--goal", "hover", "--no-rrd"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"foam-mj: error: --mjcf: {xml}: the model has no limited hinge or slide joint to plan over (give joints a range)"


def test_a_robot_with_nothing_to_collide_with_is_told_how_to_time_a_free_motion(tmp_path, capsys):
    """A two-link arm in an empty world (no obstacle; its links meet only at their joint) has no geom pair to certify
    against, so plan refuses it; the message said why but not what to do to time and replay a free motion (a floor
    plane does not help: no joint of a horizontal arm changes its distance). It now names the way out, which plans."""
    arm = ('<mujoco><compiler angle="radian"/><worldbody>{far}<body name="l1"><joint name="a" axis="0 0 1" range="-3 3"/>'
           '<geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/><body name="l2" pos=".3 0 0"><joint name="b" axis="0 0 1" '
           'range="-2.5 2.5"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/></body></body></worldbody></mujoco>')
    args = ["--start", "0 0.3", "--goal", "2 -1", "--smoother", "none", "--no-rrd", "--no-replay"]
    (tmp_path / "empty.xml").write_text(arm.replace("{far}", ""))
    assert main(["plan", "--mjcf", str(tmp_path / "empty.xml"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no robot geom can collide with any obstacle geom or with itself" in err
    assert err.endswith("to time a free motion, add a small obstacle beyond the robot's reach (a sphere the links turn about)")
    (tmp_path / "far.xml").write_text(arm.replace("{far}", '<geom name="far" type="sphere" pos="3 0 0" size=".1"/>'))
    assert main(["plan", "--mjcf", str(tmp_path / "far.xml"), *args]) == 0


def test_a_plan_whose_hinge_ranges_are_all_a_few_degrees_says_they_may_be_radians_read_as_degrees(tmp_path, capsys):
    """An arm written with radian ranges (range="-3 3", "-1.5 1.5") and no <compiler angle="radian"/> compiles to
    +-3 and +-1.5 degrees; end points inside them planned a motion of a few degrees without a word. plan now notes
    that every hinge range spans only a few degrees and names the compiler option; with the option, or with ranges
    meant in degrees (the two-link example's), nothing is noted."""
    arm = ('<mujoco>{compiler}<worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
           '<body pos="0 0 .3"><joint name="j1" axis="0 0 1" range="-3 3"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".03"/>'
           '<body pos=".3 0 0"><joint name="j2" axis="0 1 0" range="-1.5 1.5"/><geom type="capsule" fromto="0 0 0 .2 0 0" size=".03"/>'
           '</body></body></worldbody></mujoco>')
    scene = tmp_path / "arm.xml"
    args = ["plan", "--mjcf", str(scene), "--start", "-0.02 0", "--goal", "0.02 0.01", "--no-rrd", "--no-replay", "--smoother", "none"]
    scene.write_text(arm.format(compiler=""))
    assert main(args) == 0
    out = capsys.readouterr().out
    assert ("note: every hinge range spans only a few degrees (j1 [-3, 3], j2 [-1.5, 1.5] degrees): MJCF reads angles in degrees "
            'unless <compiler angle="radian"/>; if these ranges are meant in radians, add it to the MJCF') in out, out
    scene.write_text(arm.format(compiler='<compiler angle="radian"/>'))
    assert main(args) == 0
    assert "spans only a few degrees" not in capsys.readouterr().out
    example = Path(__file__).resolve().parents[1] / "examples" / "two_link_arm" / "arm.xml"
    assert main(["plan", "--mjcf", str(example), "--start", "0.3 2.0", "--goal", "0.1 0.6", "--no-rrd", "--no-replay", "--smoother", "none"]) == 0
    assert "spans only a few degrees" not in capsys.readouterr().out


def test_a_pan_only_arm_whose_one_pair_no_joint_changes_is_refused_naming_that_pair_and_its_distance(tmp_path, capsys):
    """A one-joint pan arm whose link overlaps the pedestal cylinder it turns about (2.8 cm): that pair is the only
    one, and no joint changes it, so no pair is left to certify. The refusal said 'no robot geom can collide with any
    obstacle geom', which a user read as the arm being clear of its pedestal; it now names the pair and its distance."""
    (tmp_path / "pan.xml").write_text(
        '<mujoco><compiler angle="radian"/><worldbody><geom name="base" type="cylinder" pos="0 0 -0.032" size="0.06 0.03"/>'
        '<body name="l1"><joint name="j1" axis="0 0 1" range="-3 3"/><geom name="g1" type="capsule" fromto="0 0 0 0.3 0 0" '
        'size="0.03"/></body></worldbody></mujoco>')
    assert main(["plan", "--mjcf", str(tmp_path / "pan.xml"), "--start", "0", "--goal", "2", "--no-rrd"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no robot geom can collide with any obstacle geom" in err
    assert "no configuration joint moves the geoms of a pair: g1 / base -0.0280 m, whose distance no configuration joint changes)" in err


def test_an_unknown_robot_root_lists_the_named_bodies_and_counts_the_unnamed(tmp_path, capsys):
    """`--robot-root nope` on an MJCF whose bodies have no names listed them as "(bodies: [None])"."""
    xml = tmp_path / "arm.xml"
    xml.write_text('<mujoco><worldbody><geom type="sphere" pos="0.3 0 0" size="0.05"/><body name="upper"><joint type="hinge" '
                   'axis="0 0 1" range="-170 170"/><geom type="capsule" fromto="0.05 0 0 0.2 0 0" size="0.02"/><body pos="0.2 0 0">'
                   '<joint type="hinge" axis="0 0 1" range="-90 90"/><geom type="capsule" fromto="0.05 0 0 0.2 0 0" size="0.02"/>'
                   '</body></body></worldbody></mujoco>')
    assert main(["plan", "--mjcf", str(xml), "--robot-root", "nope", "--start", "-1 0", "--goal", "-2 0", "--no-rrd"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("robot_root 'nope' is not a body of the model (bodies: ['upper']; 1 unnamed: name the root in the MJCF)"), err
    assert "None" not in err and list(tmp_path.iterdir()) == [xml]


def test_the_foam_mj_fields_of_an_attached_robot_are_read_under_its_prefix(tmp_path):
    """MuJoCo prefixes every name of an <attach>ed model, its <custom> fields' too: an arm declaring its configuration
    "j2 j1" (and j1's time-law limits) attached with prefix "a_" gave the texts 'a_foam_mj:configuration' and
    'a_foam_mj:limits:j1', which foam-mj did not read: the configuration fell back silently to every limited joint in
    model order (a_j1, a_j2), so end points given in the arm's declared order went to the other joints. The fields are
    now read under the prefix, the names they hold prefixed as MuJoCo prefixed the joints; two arms attached under two
    prefixes plan over both declarations, in model order, and the scene's own declaration still decides."""
    from foam_mj.trajectory import JointLimits

    (tmp_path / "arm.xml").write_text(
        '<mujoco><custom><text name="foam_mj:configuration" data="j2 j1"/><numeric name="foam_mj:limits:j1" data="2 5"/>'
        '<numeric name="foam_mj:normalize:j2" data="2"/></custom><worldbody><body name="l1" pos="0 0 .5">'
        '<joint name="j1" axis="0 1 0" range="-100 100"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".03"/>'
        '<body pos=".3 0 0"><joint name="j2" axis="0 1 0" range="-150 150"/><geom type="capsule" fromto="0 0 0 .25 0 0" size=".025"/>'
        '</body></body></worldbody></mujoco>')

    def scene(attach: str, custom: str = "") -> Path:
        p = tmp_path / f"scene{len(list(tmp_path.iterdir()))}.xml"
        p.write_text(f'<mujoco><asset><model name="arm" file="arm.xml"/></asset>{custom}<worldbody>'
                     f'<geom name="floor" type="plane" size="2 2 .1"/>{attach}</worldbody></mujoco>')
        return p

    one = RobotModel.from_xml(scene('<body name="mount"><attach model="arm" body="l1" prefix="a_"/></body>'))
    assert one.config.joint_names == ("a_j2", "a_j1")
    np.testing.assert_allclose(one.upper, [2.0, np.radians(100)])  # normalize:j2 read under the prefix
    velocity, acceleration = JointLimits().resolve(one)
    assert velocity[1] == 2 and acceleration[1] == 5
    two = RobotModel.from_xml(scene('<frame pos="0 .3 0"><attach model="arm" body="l1" prefix="L/"/></frame>'
                                    '<frame pos="0 -.3 0"><attach model="arm" body="l1" prefix="R/"/></frame>'))
    assert two.config.joint_names == ("L/j2", "L/j1", "R/j2", "R/j1")
    own = RobotModel.from_xml(scene('<body name="mount"><attach model="arm" body="l1" prefix="a_"/></body>',
                                    '<custom><text name="foam_mj:configuration" data="a_j1"/></custom>'))
    assert own.config.joint_names == ("a_j1",)
