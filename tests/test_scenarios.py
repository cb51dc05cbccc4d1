"""Tests for foam_mj.scenarios: the built-in scenarios and the validation of scenario files."""

from __future__ import annotations

import numpy as np
import pytest

from foam_mj.errors import ScenarioError
from foam_mj.foam import plan
from foam_mj.scenarios import available_scenarios, load_scenario, scenario_from_dict


def test_the_built_in_scenarios():
    assert {"obstacle", "obstacle_thesis", "step_up", "step_down"} <= set(available_scenarios())
    s = load_scenario("obstacle")
    np.testing.assert_allclose(s.q_init, [0.2, 0.3, 0.08])
    np.testing.assert_allclose(s.q_goal, [0.45, 0.4536, 1.45])
    assert (s.params.K, s.params.r_min) == (10, 0.07)
    t = load_scenario("obstacle_thesis")
    assert (t.params.K, t.params.r_min) == (6, 0.045)


@pytest.mark.parametrize("name", ["obstacle", "obstacle_thesis", "step_up", "step_down"])
def test_start_and_goal_are_valid_with_room_for_a_root_bubble(name):
    s = load_scenario(name)
    oracle = s.oracle()
    assert oracle.radius(s.q_init) >= s.params.r_min
    assert oracle.clearance(s.q_goal) > s.params.delta
    res = plan(oracle, s.q_init, s.q_goal, s.params, seed=s.seed)
    assert res.rosary.check_structure() == []


def test_unknown_scenario_lists_the_known_ones():
    with pytest.raises(ScenarioError, match="known scenarios: .*obstacle"):
        load_scenario("moon_walk")


GOOD = """
scene = "{scene}"
q_init = [0.2, 0.3, 0.08]
q_goal = [0.45, 0.4536, 1.45]
[planner]
K = 10
r_min = 0.07
"""


def _write(tmp_path, text, **kw):
    from conftest import MODELS

    p = tmp_path / "s.toml"
    p.write_text(text.format(scene=str(MODELS / "obstacle.xml"), **kw))
    return p


def test_a_scenario_file_loads(tmp_path):
    s = load_scenario(_write(tmp_path, GOOD))
    assert s.name == "s" and s.params.K == 10


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda t: t.replace("K = 10", "K = 0"), "K"),
        (lambda t: t.replace("K = 10", 'K = "ten"'), "'K' must be a number"),
        (lambda t: t.replace("r_min = 0.07", "r_min = 0.07\nspeed = 3"), "unknown \\[planner\\] field"),
        (lambda t: t.replace("r_min = 0.07", "r_min = 0.07\ndelta = -0.01"), r"\[planner\] `delta` must be >= 0"),
        (lambda t: "colour = 1\n" + t, "unknown field"),
        (lambda t: t.replace("q_init = [0.2, 0.3, 0.08]", ""), "missing field 'q_init'"),
        (lambda t: t.replace("[0.2, 0.3, 0.08]", "[0.2, 0.3]"), "q_init.*must be 3 numbers.*got 2"),
        (lambda t: t.replace("[0.2, 0.3, 0.08]", '[0.2, "a", 0.08]'), "q_init' must be a list of numbers"),
        (lambda t: t.replace("[0.45, 0.4536, 1.45]", "[0.45, 0.4536, 3.0]"), "q_goal.*outside its bounds"),
        (lambda t: t.replace("[0.45, 0.4536, 1.45]", "[0.0, 0.0, 1.1219973762820265]"), "q_goal.*in collision: clearance -0.0180 m between foot_collision and obstacle_box"),
        (lambda t: t.replace("q_init =", "q_init = = "), "malformed TOML"),
        (lambda t: "seed = 18446744073709551616\n" + t, r"'seed' must be an integer in \[0, 2\*\*63 - 1\]"),
        (lambda t: t + "[normalize]\nhip_displacment = [0.0, 0.7, 1.5707963267948966]\n",
         r"normalization given for 'hip_displacment' \(did you mean 'hip_displacement'\?\), which are not joints"),
        (lambda t: t + "[normalize]\nhip_displacement = [inf]\n", r"normalize.hip_displacement needs finite numbers"),
        (lambda t: t + "[normalize]\nhip_displacement = [0.0, inf, 1.0]\n", r"normalize.hip_displacement needs finite numbers"),
        # a span of 1e300 planned with overflow warnings (q in units of 1e-300 m: the bubbles' radii were inf/NaN)
        (lambda t: t + "[normalize]\nhip_displacement = [1e300]\n", r"normalize.hip_displacement maps qpos .* 1\.11e\+300 q per qpos unit"),
        (lambda t: t + "[normalize]\nhip_displacement = [1e-300]\n", r"normalize.hip_displacement maps .*the span must be within 1e-9..1e9"),
        (lambda t: t.replace('scene = "', 'scene = "/nowhere/'), "scene.*not found"),
        # inf was planned with as "no time limit" and written to the result as `"time_limit": Infinity`, which is not
        # JSON (jq, JavaScript's JSON.parse refuse it); --time-limit inf was refused already
        (lambda t: t.replace("r_min = 0.07", "r_min = 0.07\ntime_limit = inf"), r"`time_limit` must be > 0 seconds and finite, got inf"),
        (lambda t: t.replace("K = 10\nr_min = 0.07", 'algorithm = "bubbletree"\ntime_limit = inf'), r"`time_limit` must be > 0 seconds and finite, got inf"),
        (lambda t: t.replace("K = 10\nr_min = 0.07", 'algorithm = "bubbletree"\nrefine_time = inf'), r"`refine_time` must be > 0 seconds and finite, got inf"),
    ],
)
def test_bad_scenario_files_name_the_file_and_the_field(tmp_path, edit, message):
    p = _write(tmp_path, edit(GOOD))
    with pytest.raises(ScenarioError, match=message) as err:
        load_scenario(p)
    assert "s.toml" in str(err.value)


@pytest.mark.parametrize("edit, message", [
    (lambda t: "q_goals = [0.45, 0.4536, 1.45]\n" + t, "unknown field(s) 'q_goals' (did you mean 'q_goal'?)"),
    (lambda t: "self-collision = false\n" + t, "unknown field(s) 'self-collision' (did you mean 'self_collision'?)"),
    (lambda t: t.replace("[planner]", "[planer]"), "unknown field(s) 'planer' (did you mean 'planner'?)"),
    (lambda t: t.replace("r_min = 0.07", "rmin = 0.07"), "unknown [planner] field(s) 'rmin' (did you mean 'r_min'?) for algorithm 'pfm'"),
    (lambda t: t.replace("K = 10", "k = 10"), "unknown [planner] field(s) 'k' (did you mean 'K'?)"),
    (lambda t: t + "seed = 3\n", "unknown [planner] field(s) 'seed' (a top-level field: write it above the first [table])"),
    (lambda t: t + "[limits]\nvelocty = [1, 1, 1]\n", "unknown [limits] field(s) 'velocty' (did you mean 'velocity'?)"),
    (lambda t: t + "[subject]\nhieght = 1.7\n", "unknown [subject] field(s) 'hieght' (did you mean 'height'?)"),
    (lambda t: t + "[obstacle]\nsizes = [0.2, 0.5, 0.1]\n", "unknown [obstacle] field(s) 'sizes' (did you mean 'size'?)"),
])
def test_a_misspelt_field_is_named_with_the_one_it_looks_like(tmp_path, edit, message):
    """An unknown field listed the expected ones only; a misspelling (or a top-level field written under a table, where
    TOML puts it) now also gets the field meant."""
    with pytest.raises(ScenarioError) as err:
        load_scenario(_write(tmp_path, edit(GOOD)))
    assert message in str(err.value)


@pytest.mark.parametrize("q_init, q_goal", [("[1e308, 0.3, 0.08]", "[-1e308, 0.4536, 1.45]"), ("[1e308, 0.3, 0.08]", "[0.45, 0.4536, 1.45]")])
def test_an_end_point_far_outside_the_bounds_is_named_with_no_warning_before_the_error(tmp_path, q_init, q_goal):
    """q_init = [1e308, ...] printed "foam-mj: warning: overflow encountered in dot" (the start/goal distance, taken
    before the bounds were checked) above the error: two lines on stderr for one bad field."""
    import warnings

    p = _write(tmp_path, GOOD.replace("[0.2, 0.3, 0.08]", q_init).replace("[0.45, 0.4536, 1.45]", q_goal))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ScenarioError, match=r"field 'q_init': q_init\[0\] \(hip_flexion\) = 1e\+308 is outside its bounds"):
            load_scenario(p)


def test_a_scene_or_scenario_name_too_long_for_the_file_system_is_bad_input(tmp_path):
    """Python 3.11's Path.is_file raised OSError (File name too long): an internal error, exit 1."""
    long = "y" * 300
    p = _write(tmp_path, GOOD.replace('scene = "{scene}"', f'scene = "{long}.xml"'))
    with pytest.raises(ScenarioError, match=r"field 'scene': MJCF file .*yyy\.xml: File name too long"):
        load_scenario(p)
    with pytest.raises(ScenarioError, match=r"scenario file .*yyy\.toml: File name too long"):
        load_scenario(tmp_path / f"{long}.toml")
    with pytest.raises(ScenarioError, match=r"unknown scenario 'yyy"):
        load_scenario(long)


def test_a_missing_scenario_file_is_named(tmp_path):
    with pytest.raises(ScenarioError, match="not found"):
        load_scenario(tmp_path / "none.toml")


def test_a_start_just_inside_the_margin_prints_a_clearance_that_differs_from_it(tmp_path):
    # 4.999 mm of clearance against delta = 5 mm: four decimals would print "clearance 0.0050 m" beside
    # "delta is 0.005 m"; the message shows as many digits as it takes to tell them apart.
    p = _write(tmp_path, GOOD.replace("[0.2, 0.3, 0.08]", "[0.2, 0.3, 0.3174898431332786]"))
    with pytest.raises(ScenarioError, match=r"q_init.*too close to an obstacle: clearance 0\.004999 m between foot_collision "
                                            r"and obstacle_box \(the safety margin delta is 0\.005 m"):
        load_scenario(p)


def test_a_scene_that_is_a_folder_is_named_as_one(tmp_path):
    """scene = "" (the TOML's own folder) or a folder said "MJCF file not found: <an existing folder>"."""
    for value in ("", str(tmp_path)):
        p = _write(tmp_path, GOOD.replace('scene = "{scene}"', f'scene = "{value}"'))
        with pytest.raises(ScenarioError, match=rf"field 'scene' = '{value}' names the folder {tmp_path}, not an MJCF file"):
            load_scenario(p)


def test_a_scenario_saved_with_a_byte_order_mark_loads_and_one_in_latin_1_is_named(tmp_path):
    """Windows editors save UTF-8 with a byte-order mark: tomllib read it as "Invalid statement (at line 1, column 1)"."""
    p = tmp_path / "s.toml"
    text = GOOD.format(scene=load_scenario("obstacle").scene).replace("[planner]", 'description = "stépping"\n[planner]')
    p.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    assert load_scenario(p).description == "stépping"
    p.write_bytes(text.encode("latin-1"))
    with pytest.raises(ScenarioError, match=r"s.toml: not UTF-8 text: byte 0xe9 at offset \d+ \(invalid continuation byte\); save it as UTF-8"):
        load_scenario(p)


def test_a_robot_geom_held_within_the_margin_by_no_joint_is_refused_naming_the_pair(tmp_path):
    """A door on a vertical hinge stands on the floor: no configuration joint changes their distance, so the
    planner leaves the pair out, yet every path would keep the door 0 mm from the floor, which `foam-mj verify`
    and MuJoCo-only checkers count as breaking the margin: refused before planning, naming both geoms."""
    (tmp_path / "door.xml").write_text(
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 0.1"/><geom name="post" type="box" size="0.05 0.05 0.3" pos="0.6 0 0.3"/>'
        '<body name="door" pos="0 0 0.3"><joint name="swing" axis="0 0 1" range="-90 90"/>'
        '<geom name="leaf" type="box" size="0.02 0.2 0.3" pos="0 0.2 {lift}"/></body></worldbody></mujoco>'.replace("{lift}", "0")
    )
    p = tmp_path / "door.toml"
    p.write_text('name = "door"\nscene = "door.xml"\nq_init = [-1.0]\nq_goal = [1.0]\n')
    with pytest.raises(ScenarioError, match=r"door.toml: field 'scene': robot geom leaf and obstacle floor are 0\.0000 m apart, "
                                            r"within the safety margin delta 0\.005 m, and no configuration joint changes that distance"):
        load_scenario(p)
    (tmp_path / "door.xml").write_text((tmp_path / "door.xml").read_text().replace('pos="0 0.2 0"', 'pos="0 0.2 0.01"'))
    assert load_scenario(p).name == "door"  # 1 cm above the floor: planned


def test_a_first_link_overlapping_its_fixed_base_is_refused_with_the_way_out(tmp_path):
    """A pan link jointed to a base fixed to the world overlaps it at the joint; MuJoCo's parent/child filter
    exempts the world and robot/obstacle pairs ignore <exclude>, so the start is in collision: the message
    says why the <exclude> did not help and what to change."""
    (tmp_path / "base.xml").write_text(
        '<mujoco><worldbody><geom name="post" type="box" size="0.05 0.05 0.2" pos="0.4 0.3 0.2"/>'
        '<body name="base" pos="0 0 0.3"><geom name="base" type="cylinder" size="0.06 0.3" pos="0 0 -0.05"/>'
        '<body name="link1" pos="0 0 0.25"><joint name="pan" axis="0 0 1" range="-170 170"/>'
        '<geom name="l1" type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/></body></body></worldbody>'
        '<contact><exclude body1="base" body2="link1"/></contact></mujoco>'
    )
    p = tmp_path / "base.toml"
    p.write_text('name = "base"\nscene = "base.xml"\nq_init = [-0.5]\nq_goal = [1.5]\n')
    with pytest.raises(ScenarioError, match=r"q_init.*in collision: clearance -0\.0300 m between l1 and base .*; l1 is on a link "
                                            r"jointed to the fixed body of base: .*<contact><exclude> does not apply\); if that body "
                                            r"is the robot's base, name its root \(--robot-root base; robot_root = \"base\" in a "
                                            r"scenario\).*contype=\"0\""):
        load_scenario(p)
    # The way out it names (MuJoCo Menagerie's iiwa 14, xArm7 and Shadow hand all meet this at their first joint):
    p.write_text('name = "base"\nscene = "base.xml"\nq_init = [-0.5]\nq_goal = [1.5]\nrobot_root = "base"\n')
    assert load_scenario(p).name == "base"


def test_pair_messages_name_the_body_of_an_unnamed_geom_and_the_way_out_of_a_held_base(tmp_path):
    """MuJoCo Menagerie's robots leave collision geoms unnamed: "between geom9 and geom4" (Cassie) or "robot geom geom45
    and obstacle floor" sent a user counting geoms in several included files; the message now adds the body. A planned
    hip link overlapping its floating pelvis, which the planner holds as an obstacle (its free joint is no configuration
    joint) whatever contype/conaffinity say, is refused with the way out: the robot's root body as robot_root."""
    (tmp_path / "hip.xml").write_text(
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 0.1"/>'
        '<body name="pelvis" pos="0 0 1"><freejoint/><geom type="capsule" fromto="0 -0.1 0 0 0.1 0" size="0.08" contype="1" conaffinity="0"/>'
        '<body name="roll" pos="0 0.1 0"><joint name="roll" axis="1 0 0"/><inertial pos="0 0 0" mass="0.1" diaginertia="1e-4 1e-4 1e-4"/><body name="thigh"><joint name="hip" axis="0 1 0" range="-60 60"/>'
        '<geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.05" contype="2" conaffinity="4"/></body></body>'
        '<body name="stance" pos="0 -0.1 0"><joint name="other" axis="0 1 0"/>'
        '<geom type="capsule" fromto="0 0 0 0 0 -0.{drop}" size="0.05" contype="2" conaffinity="4"/></body></body></worldbody></mujoco>'
    )
    xml = (tmp_path / "hip.xml").read_text()
    (tmp_path / "hip.xml").write_text(xml.replace("{drop}", "5"))
    p = tmp_path / "hip.toml"
    p.write_text('name = "hip"\nscene = "hip.xml"\nq_init = [-0.5]\nq_goal = [0.5]\n')
    with pytest.raises(ScenarioError, match=r"in collision: clearance -0\.\d+ m between geom2 \(on body thigh\) and geom1 \(on body pelvis\) "
                                            r".*; geom1 is on a body that a joint outside the configuration moves.*--robot-root; robot_root"):
        load_scenario(p)
    p.write_text('name = "hip"\nscene = "hip.xml"\nrobot_root = "pelvis"\nq_init = [-0.5]\nq_goal = [0.5]\n')
    (tmp_path / "hip.xml").write_text(xml.replace("{drop}", "97"))  # the held stance leg 2 cm into the floor
    with pytest.raises(ScenarioError, match=r"robot geom geom3 \(on body stance\) and obstacle floor are -0\.0\d+ m apart"):
        load_scenario(p)
    (tmp_path / "hip.xml").write_text(xml.replace("{drop}", "5"))
    assert load_scenario(p).name == "hip"  # the pelvis/thigh pair is a robot/robot one, filtered as MuJoCo does


def test_two_links_overlapping_at_a_universal_joint_are_refused_with_both_ways_out(tmp_path, capsys):
    """Links meeting at a two-body universal joint overlap by design (grandparent and grandchild, which MuJoCo's
    parent/child filter does not exempt): the message names the <exclude> to add and the flag that drops
    self-collision (it named only the scenario field, while `plan --mjcf` takes --no-self-collision), with
    which the same start plans."""
    from foam_mj.cli import main

    scene = tmp_path / "ujoint.xml"
    scene.write_text(
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 0.1"/>'
        '<body name="A" pos="0 0 0.5"><joint name="a" axis="0 1 0" range="-90 90"/>'
        '<geom name="gA" type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>'
        '<body name="B" pos="0.3 0 0"><joint name="u1" axis="0 1 0" range="-90 90"/>'
        '<inertial pos="0 0 0" mass="0.1" diaginertia="1e-4 1e-4 1e-4"/>'
        '<body name="C"><joint name="u2" axis="0 0 1" range="-90 90"/>'
        '<geom name="gC" type="capsule" fromto="0 0 0 0.25 0 0" size="0.025"/></body></body></body></worldbody></mujoco>'
    )
    argv = ["plan", "--mjcf", str(scene), "--start", "0 0 0", "--goal", "0.5 0.5 0.5", "--no-rrd", "--no-replay"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "between gA and gC" in err and '<contact><exclude body1="A" body2="C"/>' in err and "--no-self-collision" in err
    assert main(argv + ["--no-self-collision"]) == 0


@pytest.mark.parametrize("data", ["3", "-3 30"])
def test_a_bad_limits_field_in_the_mjcf_is_refused_at_load_naming_it(tmp_path, capsys, data):
    """A <numeric name="foam_mj:limits:<joint>"> without two positive numbers ended `plan` with exit 1 (an
    internal ValueError) after the whole planning; it is a model error, named when the scenario is loaded."""
    from foam_mj.cli import main

    (tmp_path / "arm.xml").write_text(
        f'<mujoco><custom><numeric name="foam_mj:limits:sh" data="{data}"/></custom><worldbody>'
        '<geom name="floor" type="plane" size="2 2 0.1"/><body pos="0 0 0.5"><joint name="sh" axis="0 1 0" range="-90 90"/>'
        '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/></body></worldbody></mujoco>'
    )
    (tmp_path / "arm.toml").write_text('name = "arm"\nscene = "arm.xml"\nq_init = [-0.5]\nq_goal = [0.5]\n')
    with pytest.raises(ScenarioError, match=r"arm.toml: field 'scene': .*arm.xml: 'foam_mj:limits:sh' must hold 2 numbers > 0 "
                                            r"\(velocity acceleration\), got \["):
        load_scenario(tmp_path / "arm.toml")
    argv = ["plan", "--mjcf", str(tmp_path / "arm.xml"), "--start", "-0.5", "--goal", "0.5", "--no-rrd", "--no-replay"]
    assert main(argv) == 2
    assert "'foam_mj:limits:sh' must hold 2 numbers" in capsys.readouterr().err


def test_scenario_from_dict_takes_numpy_values_as_a_python_user_has_them(tmp_path):
    # q_init as a numpy array, a tuple, numpy numbers for seed and planner options were refused ("must be a list of
    # numbers, got array(...)"); np.int64 options that got through made the JSON result fail in json.dumps.
    import json

    from foam_mj.data import models_dir
    from foam_mj.pipeline import run
    from foam_mj.results import write_outcome
    from foam_mj.scenarios import scenario_from_dict

    ref = load_scenario("obstacle")
    s = scenario_from_dict({"name": "np", "scene": "obstacle.xml", "q_init": np.array(ref.q_init),
                            "q_goal": tuple(np.float64(v) for v in ref.q_goal), "seed": np.int64(2), "joints": ("hip_flexion", "knee_flexion", "hip_displacement"),
                            "planner": {"algorithm": "pfm", "K": np.int64(10), "r_min": np.float32(0.07), "max_bubbles": np.int64(100_000)}},
                           models_dir())
    assert s.seed == 2 and type(s.seed) is int and s.params.max_bubbles == 100_000 and type(s.params.options["K"]) is int
    np.testing.assert_array_equal(s.q_goal, ref.q_goal)
    doc = json.loads(write_outcome(tmp_path / "np.json", run(s, smoothers="none", replay=False)).read_text())
    assert doc["planner"]["K"] == 10 and doc["planner"]["max_bubbles"] == 100_000 and doc["seed"] == 2
    for bad in (np.array([[0.0, 0.0, 0.0]]), np.array([True, False, True])):
        with pytest.raises(ScenarioError, match="field 'q_init' must be a list of numbers"):
            scenario_from_dict({"scene": "obstacle.xml", "q_init": bad, "q_goal": [0.3, 0.1, 1.5]}, models_dir())


def test_the_python_entry_points_name_an_argument_of_the_wrong_type():
    from foam_mj.pipeline import run
    from foam_mj.scenarios import scenario_from_dict

    with pytest.raises(TypeError, match="a scenario is a built-in name or a TOML path, got dict"):
        load_scenario({"scene": "obstacle.xml"})
    with pytest.raises(TypeError, match="`base_dir` .* must be a path, got NoneType"):
        scenario_from_dict({"scene": "obstacle.xml", "q_init": [0, 0, 0], "q_goal": [0.3, 0.1, 1.5]}, None)
    with pytest.raises(TypeError, match=r"run\(\) takes a Scenario"):
        run("obstacle")
    with pytest.raises(TypeError, match="`smoothers` must be path names"):
        run(load_scenario("obstacle"), smoothers=None)
    with pytest.raises(TypeError, match="`report` must be None or a callable"):
        run(load_scenario("obstacle"), report="planning")


def test_an_end_point_named_after_a_keyframe_holds_the_other_joints_at_that_keyframe(tmp_path):
    """A Kinova Gen3 (MuJoCo Menagerie) planned from --start home over its three limited joints kept its continuous
    joints at qpos0 (joint_3 at 0, not home's pi): the plan started from another pose than home, silently. Without a
    scenario keyframe, the first end point's keyframe now holds the other joints; a second keyframe that puts them
    elsewhere is refused (they stay at one pose along a path), and a scenario's own keyframe still decides."""
    (tmp_path / "arm.xml").write_text(
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
        '<body pos="0 0 .5"><joint name="a" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<body pos=".3 0 0"><joint name="b" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<body pos=".3 0 0"><joint name="c" axis="1 0 0"/><geom type="capsule" fromto="0 0 0 .2 0 0" size=".02"/>'
        '</body></body></body></worldbody><keyframe><key name="home" qpos="0.1 0.2 0.5"/><key name="reach" qpos="0.3 0.4 0.5"/>'
        '<key name="twist" qpos="0.3 0.4 0.9"/></keyframe></mujoco>'
    )
    base = {"name": "arm", "scene": "arm.xml", "joints": ["a", "b"]}
    s = scenario_from_dict({**base, "q_init": "home", "q_goal": [-0.5, -0.6]}, tmp_path)
    assert s.keyframe == "home" and s.robot.config.qpos0.tolist() == [0.1, 0.2, 0.5]
    np.testing.assert_allclose(s.q_init, [0.1, 0.2])
    assert scenario_from_dict({**base, "q_init": [-0.5, -0.6], "q_goal": "reach"}, tmp_path).robot.config.qpos0[2] == 0.5
    with pytest.raises(ScenarioError, match=r"field 'q_goal' = 'twist': that keyframe puts joints outside the configuration "
                                            r"elsewhere than keyframe 'home', .*\(c 0\.9 \(not 0\.5\)\)"):
        scenario_from_dict({**base, "q_init": "home", "q_goal": "twist"}, tmp_path)
    s = scenario_from_dict({**base, "keyframe": "twist", "q_init": "home", "q_goal": "reach"}, tmp_path)
    assert s.keyframe == "twist" and s.robot.config.qpos0[2] == 0.9
    assert scenario_from_dict({**base, "q_init": [0.1, 0.2], "q_goal": [-0.5, -0.6]}, tmp_path).keyframe is None


def test_a_second_keyframe_that_moves_a_mocap_obstacle_elsewhere_is_refused_as_one_that_moves_a_held_joint(tmp_path):
    """Keyframes 'a' and 'b' put a mocap post at x = 0.52 and x = 0.9: --start a --goal b planned around the post at
    0.52 (the first end point's pose) and said nothing of b's, while a second keyframe that moved a held joint was
    refused. An obstacle stays at one pose along a path as a held joint does: the same refusal now names the mocap
    body and both poses; keyframes that agree on it, or a scenario's own keyframe, still plan."""
    (tmp_path / "arm.xml").write_text(
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
        '<body name="post" mocap="true" pos=".45 0 .15"><geom type="box" size=".04 .2 .15"/></body>'
        '<body pos="0 0 .5"><joint name="a" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '</body></worldbody><keyframe><key name="a" qpos="0.1" mpos=".52 0 .2"/><key name="b" qpos="0.6" mpos=".9 0 .2"/>'
        '<key name="c" qpos="0.6" mpos=".52 0 .2"/></keyframe></mujoco>'
    )
    base = {"name": "arm", "scene": "arm.xml"}
    with pytest.raises(ScenarioError, match=r"field 'q_goal' = 'b': that keyframe puts mocap bodies elsewhere than keyframe "
                                            r"'a', .*\(post at \[0\.9, 0, 0\.2\] \(not \[0\.52, 0, 0\.2\]\)\)"):
        scenario_from_dict({**base, "q_init": "a", "q_goal": "b"}, tmp_path)
    s = scenario_from_dict({**base, "q_init": "a", "q_goal": "c"}, tmp_path)
    np.testing.assert_allclose(s.robot.model.body_pos[1], [0.52, 0, 0.2])
    s = scenario_from_dict({**base, "keyframe": "a", "q_init": "a", "q_goal": "b"}, tmp_path)
    np.testing.assert_allclose(s.robot.model.body_pos[1], [0.52, 0, 0.2])


def test_q_init_or_q_goal_may_name_a_keyframe_of_the_scene(tmp_path):
    """A scenario's end point may be a keyframe's name: its qpos of the configuration joints, as q (hip displacement
    normalized); a scene without such a keyframe is refused before any work, naming those it has."""
    from foam_mj.data import models_dir
    from foam_mj.scenarios import scenario_from_dict

    scene = str(models_dir() / "obstacle.xml")
    s = scenario_from_dict({"scene": scene, "q_init": "home", "q_goal": [0.45, 0.4536, 1.45]}, tmp_path)
    np.testing.assert_allclose(s.q_init, [0.2, 0.3, 0.0])
    with pytest.raises(ScenarioError, match=r"field 'q_goal' = 'stand' is no keyframe of the scene \(its named keyframes: home\)"):
        scenario_from_dict({"scene": scene, "q_init": "home", "q_goal": "stand"}, tmp_path)
    with pytest.raises(ScenarioError, match=r"its named keyframes: none"):
        scenario_from_dict({"scene": str(models_dir() / "bench_arm6.xml"), "q_init": "home", "q_goal": "home"}, tmp_path)


def test_scenarios_compare_by_value_whether_or_not_their_scene_is_compiled():
    """`==` on two scenarios raised numpy's "truth value of an array ... is ambiguous" (the generated __eq__ compares
    q_init and q_goal inside field tuples); like the results (foam_mj.rosary.fields_equal) they compare by value, the
    compiled robot each caches left out, and stay unhashable (mutable, holding arrays)."""
    import dataclasses
    import pickle

    checked, unchecked = load_scenario("obstacle"), load_scenario("obstacle", check=False)
    assert checked._robot is not None and unchecked._robot is None  # one compiled its scene, the other not
    assert checked == unchecked and not (checked != unchecked)
    assert pickle.loads(pickle.dumps(unchecked)) == checked
    moved = dataclasses.replace(unchecked, q_goal=unchecked.q_goal + 1e-9)
    assert moved != unchecked and dataclasses.replace(unchecked, seed=1) != unchecked
    assert checked != load_scenario("step_up") and checked != "obstacle"  # another scenario, another type
    with pytest.raises(TypeError, match="unhashable"):
        hash(checked)
