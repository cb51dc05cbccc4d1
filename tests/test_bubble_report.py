"""Tests for foam_mj.bubble_report and ``foam-mj bubble``: the bubble at one configuration, checkable from outside."""

from __future__ import annotations

import json
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest

from foam_mj.cli import main

from conftest import MujocoChecker
from test_bubbles import REPRODUCER


def test_the_reproducer_reports_the_sound_radius_and_it_holds(tmp_path, capsys):
    """foam-mj bubble on the hinge + ref-offset slide: rho = (3.05, 1), and turning the hinge by the printed
    radius (or moving anywhere on that sphere) keeps delta, by mj_geomDistance alone."""
    scene, out = tmp_path / "reach.xml", tmp_path / "bubble.json"
    scene.write_text(REPRODUCER)
    assert main(["bubble", "--mjcf", str(scene), "--q=0 1.8", "--delta", "0.005", "--json", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "clearance: 0.500000 m" and lines[1] == "closest pair: ball / wall"
    assert "turn 3.0500, reach 1.0000" in lines[2] and lines[3].startswith("certified radius: 0.154218 ")
    doc = json.loads(out.read_text())
    assert doc["format"] == "foam-mj/bubble" and doc["joints"] == ["turn", "reach"]
    assert doc["rho"] == pytest.approx([3.05, 1.0]) and doc["radius"] == pytest.approx(0.495 / np.hypot(3.05, 1.0))
    assert doc["clearance"] == pytest.approx(0.5) and doc["closest_pair"] == ["ball", "wall"]
    m = mujoco.MjModel.from_xml_path(str(scene))
    d = mujoco.MjData(m)
    ball, wall = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("ball", "wall"))
    for phi in np.linspace(0, 2 * np.pi, 361):
        d.qpos[:] = np.array(doc["q"]) + doc["radius"] * np.array([np.cos(phi), np.sin(phi)])
        mujoco.mj_kinematics(m, d)
        assert mujoco.mj_geomDistance(m, d, ball, wall, 1.0, None) >= doc["delta"] - 1e-9


@pytest.mark.parametrize("q, setter", [("0 2", "the joint bounds (pair ball / wall alone: 0.154218)"),  # the slide at its limit
                                       ("-3.04 1.8", "the joint bounds (pair ball / wall alone: 0.473557)"),  # 0.1 from one
                                       ("0 1.8", "ball / wall;")])
def test_the_report_names_the_joint_bounds_when_they_set_the_radius(tmp_path, capsys, q, setter):
    # On a joint limit (radius 0) it said "set by ball / wall", whose term was 0.154: the bounds set it.
    scene = tmp_path / "reach.xml"
    scene.write_text(REPRODUCER)
    assert main(["bubble", "--mjcf", str(scene), f"--q={q}"]) == 0
    assert f"set by {setter}" in capsys.readouterr().out.splitlines()[3]


def test_a_scene_report_lists_every_pair_and_agrees_with_mujoco(tmp_path, capsys, obstacle_robot):
    out = tmp_path / "b.json"
    q = [0.2, 0.3, 0.08]
    assert main(["bubble", "--scene", "obstacle", f"--q={q[0]} {q[1]} {q[2]}", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["joints"] == ["hip_flexion", "knee_flexion", "hip_displacement"] and doc["delta"] == 0.005
    assert doc["clearance"] == pytest.approx(MujocoChecker(obstacle_robot).distance(np.array(q)), abs=1e-9)
    assert len(doc["pairs"]) == 6 and doc["radius"] == pytest.approx(min(p["radius"] for p in doc["pairs"]))
    limiting = min(doc["pairs"], key=lambda p: p["radius"])
    assert limiting["geoms"] == doc["limiting_pair"] and limiting["rho"] == doc["rho"]
    thigh_floor = next(p for p in doc["pairs"] if p["geoms"] == ["thigh_collision", "floor"])
    assert thigh_floor["rho"][1:] == [0.0, 0.0]  # neither the knee nor the horizontal hip slide moves the thigh off the floor


@pytest.mark.parametrize(
    "argv, message",
    [
        (["bubble", "--q=0 0 0"], "give one of --scene SCENE or --mjcf ROBOT.xml"),
        (["bubble", "--scene", "obstacle", "--mjcf", "x.xml", "--q=0 0 0"], "give one of"),
        (["bubble", "--scene", "obstacle", "--q=0.2 0.3"], "--q must be 3 numbers, one per configuration joint (hip_flexion, knee_flexion, hip_displacement), got 2"),
        (["bubble", "--scene", "obstacle", "--q=0.2 0.3 9"], "--q[2] (hip_displacement) = 9 is outside its bounds"),
        (["bubble", "--scene", "obstacle", "--q=a b c"], "--q must be numbers"),
        (["bubble", "--scene", "nowhere", "--q=0 0 0"], "unknown scenario 'nowhere'"),
        (["bubble", "--scene", "obstacle", "--q=0.2 0.3 0.08", "--delta", "-1"], "--delta must be a margin >= 0"),
        (["bubble", "--scene", "obstacle", "--q=0.2 0.3 0.08", "--json", "/no/such/dir/b.json"], "does not exist"),
        (["bubble", "--scene", "obstacle", "--q=0.2 0.3 0.08", "--robot-root", "nope"], "robot_root 'nope'"),
    ],
)
def test_bad_input_exits_2_with_one_line(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_the_readme_shows_what_bubble_prints(capsys):
    """The README's `foam-mj bubble --scene obstacle --q="0.2 0.3 0.08"` output (Look inside a bubble), line for line."""
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    assert 'foam-mj bubble --scene obstacle --q="0.2 0.3 0.08"' in readme
    block = re.search(r"```\n(clearance: .*?)```", readme, flags=re.S).group(1)
    assert main(["bubble", "--scene", "obstacle", "--q=0.2 0.3 0.08"]) == 0
    assert capsys.readouterr().out == block


def test_an_mjcf_whose_file_name_has_spaces_or_accents_is_reported_as_plan_plans_it(tmp_path, capsys):
    """`bubble --mjcf "ärm ü.xml"` was refused with "scenario: field 'name' must be letters, digits, ..." (a field the user
    never wrote: the file's stem), while `plan --mjcf` of the same file planned; both now name the run "_rm__"."""
    from conftest import TWO_LINK_ARM

    arm = tmp_path / "ärm ü.xml"
    arm.write_text(TWO_LINK_ARM.read_text())
    out = tmp_path / "b.json"
    assert main(["bubble", "--mjcf", str(arm), "--q", "0.3 2", "--json", str(out)]) == 0
    assert capsys.readouterr().out.startswith("clearance: ")
    assert json.loads(out.read_text())["clearance"] > 0


def test_the_printed_pairs_name_the_body_of_an_unnamed_geom(tmp_path, capsys):
    """`foam-mj bubble` printed "closest pair: geom11 / geom15" for MJCF geoms without names (as Menagerie's mostly
    are: two attached Kinova Gen3 arms), which no one can find in the MJCF; plan's messages already said "geom11 (on
    body forearm_link)". The printed pairs now do too; named geoms print as they are, and the JSON keeps the names."""
    scene = tmp_path / "arm.xml"
    scene.write_text(
        '<mujoco><compiler angle="radian"/><worldbody><geom name="wall" type="box" size=".05 .5 .5" pos=".5 0 .5"/>'
        '<body name="upper" pos="0 0 .5"><joint name="j1" axis="0 1 0" range="-1 1"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '</body></worldbody></mujoco>')
    assert main(["bubble", "--mjcf", str(scene), "--q=0.1", "--json", str(tmp_path / "b.json")]) == 0
    out = capsys.readouterr().out
    assert "closest pair: geom1 (on body upper) / wall" in out and "set by geom1 (on body upper) / wall;" in out, out
    doc = json.loads((tmp_path / "b.json").read_text())
    assert doc["closest_pair"] == ["geom1", "wall"] and doc["labels"] == {"geom1": "geom1 (on body upper)"}


def test_a_pair_left_out_of_the_bound_is_printed_with_the_distance_mujoco_measures(tmp_path, capsys):
    """A link turned by a pan joint over a coaxial pedestal cylinder 40 mm below it: no joint changes that distance,
    so the pair is left out of the bound and of the clearance line (0.225 m, to the next link), yet MuJoCo, plan's
    min clear and `foam-mj verify` read 0.040 m there. The report names it with that distance (it printed only the
    0.225 m, which a user choosing an end point above delta took for the robot's clearance); the clearance line
    now gives both."""
    scene, out = tmp_path / "pedestal_arm.xml", tmp_path / "bubble.json"
    scene.write_text('<mujoco><compiler angle="radian"/><worldbody>'
                     '<geom name="base" type="cylinder" pos="0 0 -0.1" size="0.06 0.03"/>'
                     '<body name="l1"><joint name="j1" axis="0 0 1" range="-3 3"/>'
                     '<geom name="g1" type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>'
                     '<body name="l2" pos="0.3 0 0"><joint name="j2" axis="0 1 0" range="-1 1"/>'
                     '<geom name="g2" type="capsule" fromto="0.05 0 0 0.25 0 0" size="0.025"/></body></body>'
                     '</worldbody></mujoco>')
    assert main(["bubble", "--mjcf", str(scene), "--q=0.5 0", "--json", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == ("clearance: %.6f m over the pairs in the bound; 0.040000 m over every pair (g1 / base, left out of "
                        "the bound)" % json.loads(out.read_text())["clearance"])
    assert lines[1] == "closest pair: g2 / base"
    assert lines[4] == "left out of the bound, as no configuration joint changes their distance: g1 / base 0.040000 m"
    doc = json.loads(out.read_text())
    assert doc["fixed_distances"] == [{"geoms": ["g1", "base"], "distance": pytest.approx(0.04)}]
    m = mujoco.MjModel.from_xml_path(str(scene))
    d = mujoco.MjData(m)
    d.qpos[:] = [0.5, 0.0]
    mujoco.mj_kinematics(m, d)
    measured = mujoco.mj_geomDistance(m, d, 1, 0, 1.0, None)  # g1 / base
    assert measured == pytest.approx(0.04) and measured < doc["clearance"]


def test_bubble_holds_the_other_joints_at_the_keyframe_plan_holds_them_at(tmp_path, capsys):
    """`plan --mjcf --start home` holds the joints outside the configuration (an unlimited base yaw) at keyframe home's
    pose, and a start in collision there was refused with "`foam-mj bubble` shows more"; but bubble could only hold
    them at qpos0, where it read the same q 0.35 m clear (seen on a 7-joint arm whose home turns its base 0.8 rad).
    bubble now takes --keyframe NAME (the other joints and mocap bodies at that keyframe) and --q NAME (a keyframe's
    configuration, held there too), reads what plan reads, and plan's refusal names the flag."""
    scene = tmp_path / "yaw.xml"
    scene.write_text(
        '<mujoco><compiler angle="radian"/><worldbody><geom name="post" type="box" size=".05 .05 .5" pos="0 .4 .5"/>'
        '<body name="base" pos="0 0 .5"><joint name="yaw" axis="0 0 1"/><geom name="hub" type="sphere" size=".05"/>'
        '<body name="upper" pos=".06 0 0"><joint name="j1" axis="0 1 0" range="-1 1"/>'
        '<geom name="link" type="capsule" fromto="0 0 0 .4 0 0" size=".02"/></body></body></worldbody>'
        '<keyframe><key name="home" qpos="1.5708 0"/></keyframe></mujoco>')
    assert main(["bubble", "--mjcf", str(scene), "--q", "0"]) == 0
    assert capsys.readouterr().out.startswith("clearance: 0.3")  # the link along x, far from the post
    assert main(["plan", "--mjcf", str(scene), "--start", "home", "--goal", "0.5", "--no-rrd"]) == 2
    err = capsys.readouterr().err
    assert "clearance -0.0" in err and "between link and post" in err and "`foam-mj bubble --keyframe home` shows more" in err, err
    for argv in (["--q", "0", "--keyframe", "home"], ["--q", "home"]):
        assert main(["bubble", "--mjcf", str(scene), *argv]) == 0
        out = capsys.readouterr().out
        assert out.startswith("clearance: -0.0") and "closest pair: link / post" in out, (argv, out)
    assert main(["bubble", "--mjcf", str(scene), "--q", "0", "--keyframe", "nope"]) == 2
    assert "'nope'" in capsys.readouterr().err
