"""Tests for foam_mj.scene_edits, foam_mj.anthropometry and foam_mj.obstacles (boxes): what a scenario
changes in its scene through MjSpec, and the robots refused before any planning."""

from __future__ import annotations

import re
from pathlib import Path

import mujoco
import numpy as np
import pytest

from foam_mj.anthropometry import SEGMENTS, segment_length
from foam_mj.errors import FoamError, ModelError, ScenarioError
from foam_mj.model import RobotModel
from foam_mj.scenarios import load_scenario, scenario_from_dict

from conftest import MODELS

OBSTACLE = {"scene": "obstacle.xml", "q_init": [0.2, 0.3, 0.08], "q_goal": [0.45, 0.4536, 1.45]}


def _robot(**tables) -> RobotModel:
    return scenario_from_dict({**OBSTACLE, **tables}, MODELS, check=False).robot


def _leg_copy(tmp_path: Path) -> tuple[Path, str]:
    """The shipped models copied to ``tmp_path`` (the scenes include the leg by name): the copy's ortholeg.xml and its text."""
    for f in MODELS.glob("*.xml"):
        (tmp_path / f.name).write_text(f.read_text())
    leg = tmp_path / "ortholeg.xml"
    return leg, leg.read_text()


def _segment_lengths(robot: RobotModel) -> dict[str, float]:
    """Hip-knee and knee-ankle distances, and the foot box's length, read from the compiled model."""
    m = robot.model
    return {
        "thigh": float(np.linalg.norm(m.body("shank").pos)),
        "leg": float(np.linalg.norm(m.body("foot").pos)),
        "foot": float(2 * m.geom("foot_collision").size[0]),
    }


def test_a_scenario_dict_is_validated_like_a_file():
    s = scenario_from_dict(dict(OBSTACLE), MODELS)
    f = load_scenario("obstacle")
    np.testing.assert_array_equal(s.q_goal, f.q_goal)
    assert s.robot.config.joint_names == f.robot.config.joint_names
    with pytest.raises(ScenarioError, match=r"\[subject\] field 'height'"):
        scenario_from_dict({**OBSTACLE, "subject": {"height": "tall"}}, MODELS)
    with pytest.raises(ScenarioError, match=r"\[obstacle\] field 'size'"):
        scenario_from_dict({**OBSTACLE, "obstacle": {"size": [0.2, 0.5]}}, MODELS)
    with pytest.raises(ScenarioError, match=r"unknown \[obstacle\] field"):
        scenario_from_dict({**OBSTACLE, "obstacle": {"height": 0.2}}, MODELS)


def test_an_obstacle_of_astronomical_size_or_position_is_refused_naming_the_field():
    """[obstacle] size = [1e300, ...] (finite) was refused by MuJoCo's compiler as "size 1 must be positive" after its
    geometry overflowed; sizes and positions beyond 1e6 m are refused naming the field; a box 100 km away still loads."""
    for field, value in (("size", [1e300, 0.5, 0.15]), ("pos", [0.5, 0.0, -2e6])):
        with pytest.raises(ScenarioError, match=rf"\[obstacle\] field '{field}'.* magnitude at most 1e\+06"):
            scenario_from_dict({**OBSTACLE, "obstacle": {field: value}}, MODELS)
    far = scenario_from_dict({**OBSTACLE, "obstacle": {"pos": [1e5, 0.0, 0.075]}}, MODELS)  # far away: still a scene
    assert far.robot.model.ngeom > 0


@pytest.mark.parametrize("height, mass", [(1.62, 58.0), (1.90, 95.0), (1.75, 75.0)])
def test_subject_scaling_sets_segment_lengths_to_winters_fractions(height, mass):
    base = _robot()
    scaled = _robot(subject={"height": height, "mass": mass})
    lengths = _segment_lengths(scaled)
    for seg in ("thigh", "leg", "foot"):
        assert lengths[seg] == pytest.approx(segment_length(seg, height), abs=1e-6)
    # Masses change by Winter's fraction of the mass difference; the orthosis part is kept.
    m0, m1 = base.model, scaled.model
    for body, seg in (("thigh", "thigh"), ("shank", "leg"), ("foot", "foot")):
        assert m1.body(body).mass[0] == pytest.approx(m0.body(body).mass[0] + SEGMENTS[seg].mass * (mass - 75.0), rel=1e-5)
    # Inertia scales as mass ratio times length ratio squared.
    k = segment_length("thigh", height) / 0.43
    ratio = m1.body("thigh").mass[0] / m0.body("thigh").mass[0]
    np.testing.assert_allclose(m1.body("thigh").inertia, m0.body("thigh").inertia * ratio * k**2, rtol=1e-5)
    # The hip's height above the floor scales with the subject's height.
    assert m1.body("pelvis").pos[2] == pytest.approx(1.06 * height / 1.75, rel=1e-5)


def test_a_shorter_subject_has_a_shorter_reach():
    tall, short = _robot(subject={"height": 1.9}), _robot(subject={"height": 1.5})
    q = np.array([0.6, 0.2, 0.0])
    toe_tall = tall.set_configuration(q).xpos[tall.model.body("foot").id]
    toe_short = short.set_configuration(q).xpos[short.model.body("foot").id]
    assert toe_short[0] < toe_tall[0]


def test_subject_scaling_needs_the_models_declaration(tmp_path):
    p = tmp_path / "arm.xml"
    p.write_text(TWO_LINK)
    with pytest.raises(ModelError, match="foam_mj:subject"):
        scenario_from_dict({"scene": str(p), "q_init": [0, 0], "q_goal": [1, 1], "subject": {"height": 1.6}}, tmp_path, check=False).robot


@pytest.mark.parametrize("segments, message", [
    ("thigh thigh 0", "the length of body 'thigh' must be a positive number of metres, got '0'"),
    ("thigh thigh abc", "the length of body 'thigh' must be a positive number of metres, got 'abc'"),
    ("thigh thigh -0.43", "got '-0.43'"),
    ("thigh thigh nan", "got 'nan'"),
    ("thigh thigh 0.43 thigh thigh 0.43", "names body 'thigh' twice"),
    ("world thigh 0.43", "names the world body 'world'"),
])
def test_a_malformed_segment_declaration_is_refused_naming_the_field(tmp_path, segments, message):
    """A zero length divided by zero (ZeroDivisionError, exit 1), a word failed float() (ValueError, exit 1), a
    negative or NaN length reached MuJoCo's compiler ("size 0 must be positive"), a body named twice was scaled
    twice (its length k^2 times the model's) and the world body was asked for an <inertial>: each is now one
    ModelError naming foam_mj:segments and the body."""
    leg, text = _leg_copy(tmp_path)
    declared = 'data="thigh thigh 0.43 shank leg 0.43 foot foot 0.266"'
    assert declared in text
    leg.write_text(text.replace(declared, f'data="{segments}"'))
    with pytest.raises(ModelError, match=r"'foam_mj:segments'.*" + re.escape(message)) as e:
        scenario_from_dict({**OBSTACLE, "scene": str(tmp_path / "obstacle.xml"), "subject": {"height": 1.6}}, tmp_path, check=False).robot
    assert "\n" not in str(e.value)


def test_a_segment_placed_through_a_frame_gets_winters_length(tmp_path):
    """The shank written inside <frame pos="0 0 -0.2"> at pos="0 0 -0.23" (the same compiled model): the frame's offset
    was not scaled, so a 1.4 m subject's thigh came out 0.3835 m long instead of Winter's 0.245 x 1.4 = 0.343 m."""
    leg, text = _leg_copy(tmp_path)
    i = text.index('<body name="foot"')
    end = text.index("</body>", text.index("</body>", i) + 1) + len("</body>")  # the shank's closing tag
    text = text[:end] + "</frame>" + text[end:]
    text = text.replace('<body name="shank" pos="0 0 -0.43">', '<frame pos="0 0 -0.2"><body name="shank" pos="0 0 -0.23">')
    leg.write_text(text)
    scene = {**OBSTACLE, "scene": str(tmp_path / "obstacle.xml")}
    plain = scenario_from_dict(scene, tmp_path, check=False).robot.model
    assert np.linalg.norm(plain.body("shank").pos) == pytest.approx(0.43)
    robot = scenario_from_dict({**scene, "subject": {"height": 1.4}}, tmp_path, check=False).robot
    lengths = _segment_lengths(robot)
    for seg in ("thigh", "leg", "foot"):
        assert lengths[seg] == pytest.approx(segment_length(seg, 1.4), abs=1e-9)


def test_sites_cameras_and_lights_of_a_segment_move_with_it(tmp_path):
    """A site given by fromto (an ankle sensor site on the shank), a camera and a light kept their unscaled places,
    0.415 m below the knee, while a 1.4 m subject's shank became 0.3444 m long: the ankle site ended up below the ankle."""
    leg, text = _leg_copy(tmp_path)
    shank = '<body name="shank" pos="0 0 -0.43">'
    assert shank in text
    leg.write_text(text.replace(shank, shank + '<site name="ankle" type="capsule" size="0.01" fromto="0 0 -0.43 0 0 -0.40"/>'
                                '<camera name="ankle_cam" pos="0 0 -0.415"/><light name="ankle_light" pos="0 0 -0.415"/>'))
    robot = scenario_from_dict({**OBSTACLE, "scene": str(tmp_path / "obstacle.xml"), "subject": {"height": 1.4}}, tmp_path, check=False).robot
    m = robot.model
    k = segment_length("leg", 1.4) / 0.43
    np.testing.assert_allclose(m.site("ankle").pos, [0, 0, -0.415 * k], atol=1e-6)  # the scene is saved with 6 digits
    assert m.site("ankle").size[1] == pytest.approx(0.015 * k, abs=1e-6)  # the half-length of the capsule between the fromto ends
    np.testing.assert_allclose(m.cam("ankle_cam").pos, [0, 0, -0.415 * k], atol=1e-6)  # the scene is saved with 6 digits
    np.testing.assert_allclose(m.light("ankle_light").pos, [0, 0, -0.415 * k], atol=1e-6)  # the scene is saved with 6 digits


def test_obstacle_table_resizes_the_box_and_keeps_it_on_the_floor():
    r = _robot(obstacle={"size": [0.3, 0.6, 0.25]})
    g = r.model.geom("obstacle_box")
    np.testing.assert_allclose(g.size, [0.15, 0.3, 0.125])
    np.testing.assert_allclose(g.pos, [0.5, 0.0, 0.125])  # bottom face still at z = 0
    r = _robot(obstacle={"pos": [0.6, 0.0, 0.075]})
    np.testing.assert_allclose(r.model.geom("obstacle_box").pos, [0.6, 0.0, 0.075])


def test_a_turned_box_resized_keeps_its_lowest_point(tmp_path):
    """A box turned 30 degrees about y, resized without pos: its lowest corner stays where it was (it sank 29 mm when
    the axis-aligned bottom face was kept), whichever way the orientation is written."""
    scene = (MODELS / "obstacle.xml").read_text()
    assert 'name="obstacle_box"' in scene
    for orientation in ('euler="0 30 0"', 'axisangle="0 1 0 30"', 'quat="0.9659258 0 0.2588190 0"'):
        path = tmp_path / "turned.xml"
        path.write_text(scene.replace('name="obstacle_box"', f'name="obstacle_box" {orientation}').replace(
            'file="', f'file="{MODELS}/'))

        def lowest(robot: RobotModel) -> float:
            m, d = robot.model, mujoco.MjData(robot.model)
            mujoco.mj_kinematics(m, d)
            g = m.geom("obstacle_box").id
            corners = np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T * m.geom_size[g]
            return float((d.geom_xpos[g] + corners @ d.geom_xmat[g].reshape(3, 3).T)[:, 2].min())

        before = lowest(scenario_from_dict({**OBSTACLE, "scene": str(path)}, MODELS, check=False).robot)
        after = scenario_from_dict({**OBSTACLE, "scene": str(path), "obstacle": {"size": [0.3, 0.5, 0.2]}}, MODELS, check=False).robot
        np.testing.assert_allclose(after.model.geom("obstacle_box").size, [0.15, 0.25, 0.1])
        assert lowest(after) == pytest.approx(before, abs=1e-6), orientation


def test_a_box_written_in_a_frame_is_placed_and_kept_on_the_floor_in_world_coordinates(tmp_path):
    """A box written inside a turned, shifted <frame> (a generated scene, a menagerie-style assembly): its `pos` in
    MJCF is in the frame's coordinates, and [obstacle] pos = [0.45, 0, 0.125] put its centre at world (0.3, 0.45,
    0.125) under a frame at (0.3, 0, 0) turned 90 degrees about z. pos is the world centre, as the README says, and a
    resize without pos keeps the lowest point in the world, also under a tilted frame."""
    def scene(frame: str) -> str:
        path = tmp_path / "framed.xml"
        path.write_text(
            f'<mujoco><compiler angle="radian"/><worldbody><geom type="plane" size="2 2 0.1"/><frame {frame}>'
            '<geom name="post" type="box" pos="0.1 0 0.125" size="0.04 0.2 0.125"/></frame><body pos="0 0 0.5">'
            '<joint name="shoulder" type="hinge" axis="0 1 0" range="-1.7 1.7"/><geom type="capsule" fromto="0 0 0 0.35 0 0" '
            'size="0.03"/></body></worldbody></mujoco>')
        return str(path)

    def world(robot: RobotModel) -> tuple[np.ndarray, float]:
        m, d = robot.model, mujoco.MjData(robot.model)
        mujoco.mj_kinematics(m, d)
        g = m.geom("post").id
        corners = np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T * m.geom_size[g]
        return d.geom_xpos[g].copy(), float((d.geom_xpos[g] + corners @ d.geom_xmat[g].reshape(3, 3).T)[:, 2].min())

    task = {"q_init": [0.3], "q_goal": [-0.3]}
    moved = scenario_from_dict({**task, "scene": scene('pos="0.3 0 0" euler="0 0 1.5707963"'),
                                "obstacle": {"pos": [0.45, 0.0, 0.125]}}, tmp_path, check=False).robot
    np.testing.assert_allclose(world(moved)[0], [0.45, 0.0, 0.125], atol=1e-6)
    tilted = scene('pos="0.2 0.1 0.05" euler="0.3 0.2 0.5"')
    before = world(scenario_from_dict({**task, "scene": tilted}, tmp_path, check=False).robot)
    after = world(scenario_from_dict({**task, "scene": tilted, "obstacle": {"size": [0.1, 0.3, 0.4]}}, tmp_path, check=False).robot)
    np.testing.assert_allclose(after[0][:2], before[0][:2], atol=1e-6)  # the same centre in x and y (MJCF's 6 digits)
    assert after[1] == pytest.approx(before[1], abs=1e-6)  # and the same lowest point


def _box_pose(robot: RobotModel) -> tuple[np.ndarray, np.ndarray, float]:
    """The obstacle box's world centre, rotation matrix and lowest point (z of its lowest corner)."""
    m, d = robot.model, mujoco.MjData(robot.model)
    mujoco.mj_kinematics(m, d)
    g = m.geom("obstacle_box").id
    R = d.geom_xmat[g].reshape(3, 3)
    corners = np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T * m.geom_size[g]
    return d.geom_xpos[g].copy(), R.copy(), float((d.geom_xpos[g] + corners @ R.T)[:, 2].min())


def test_obstacle_euler_turns_the_box_in_the_world_and_keeps_its_lowest_point(tmp_path):
    """[obstacle] euler (degrees, extrinsic x-y-z in the world, as a [[mesh]]'s) turns the box, whatever orientation the
    file wrote (axis-aligned, euler, axisangle) and inside a turned <frame>; without pos it keeps its centre's x, y and
    its lowest point, with pos it is centred there. It was refused ('unknown [obstacle] field(s) 'euler'') though a
    turned kerb or box is a change a user makes: the way round was a scene file of one's own."""
    from foam_mj.obstacles import _euler_quat

    scene = (MODELS / "obstacle.xml").read_text().replace('file="', f'file="{MODELS}/')
    for i, (orientation, frame) in enumerate([("", None), ('euler="0.2 0.5 0"', None), ('axisangle="0 0 1 0.7"', None),
                                              ("", 'pos="0.1 0 0" euler="0 0 0.4"')]):
        box = f'name="obstacle_box" {orientation}'
        xml = scene.replace('name="obstacle_box"', box)
        if frame:
            xml = xml.replace('<geom name="obstacle_box"', f'<frame {frame}><geom name="obstacle_box"').replace(
                'size="0.1 0.25 0.075"/>', 'size="0.1 0.25 0.075"/></frame>')
        path = tmp_path / f"turned{i}.xml"
        path.write_text(xml)
        before = _box_pose(scenario_from_dict({**OBSTACLE, "scene": str(path)}, MODELS, check=False).robot)
        for euler in ([0, 30, 0], [10, -20, 45]):
            R = np.zeros(9)
            mujoco.mju_quat2Mat(R, _euler_quat(euler))
            turned = _box_pose(scenario_from_dict({**OBSTACLE, "scene": str(path), "obstacle": {"euler": euler}}, MODELS, check=False).robot)
            np.testing.assert_allclose(turned[1], R.reshape(3, 3), atol=1e-6)
            np.testing.assert_allclose(turned[0][:2], before[0][:2], atol=1e-6)
            assert turned[2] == pytest.approx(before[2], abs=1e-6), (orientation, frame, euler)
            placed = _box_pose(scenario_from_dict({**OBSTACLE, "scene": str(path), "obstacle": {"euler": euler, "pos": [0.6, 0.1, 0.2],
                                                                                             "size": [0.1, 0.4, 0.2]}}, MODELS, check=False).robot)
            np.testing.assert_allclose(placed[0], [0.6, 0.1, 0.2], atol=1e-6)
            np.testing.assert_allclose(placed[1], R.reshape(3, 3), atol=1e-6)
    with pytest.raises(ScenarioError, match=r"\[obstacle\] field 'euler' \(degrees\) must have 3 numbers, got 2"):
        _robot(obstacle={"euler": [0, 30]})


def test_a_box_in_a_static_body_is_moved_resized_and_turned_in_world_coordinates(tmp_path):
    """A scene that groups its obstacle in a body without joints (<body name="crate" pos=...>, turned, the box inside a
    <frame> of it or not) was refused: "box 'obstacle_box' sits in body 'crate'; only boxes in <worldbody> can be
    moved", though the box is as static as one of <worldbody> and the planner treats it so. pos and euler are the
    world's, and a resize without pos keeps the centre's x, y and the lowest point, as for a box of <worldbody>."""
    from foam_mj.obstacles import _euler_quat

    scene = (MODELS / "obstacle.xml").read_text().replace('file="', f'file="{MODELS}/')
    box = '<geom name="obstacle_box" class="obstacle" type="box" pos="0.5 0 0.075" size="0.1 0.25 0.075"/>'
    assert box in scene
    inner = '<geom name="obstacle_box" class="obstacle" type="box" pos="0.05 0 0.1" size="0.1 0.25 0.075" euler="0 0.2 0"/>'
    for i, body in enumerate([f'<body name="crate" pos="0.45 0 0">{inner}</body>',
                              f'<body name="crate" pos="0.4 0.05 0.02" euler="0 0 0.5"><frame pos="0 0.02 0" euler="0.1 0 0">{inner}</frame></body>']):
        path = tmp_path / f"crate{i}.xml"
        path.write_text(scene.replace(box, body))
        before = _box_pose(scenario_from_dict({**OBSTACLE, "scene": str(path)}, MODELS, check=False).robot)
        resized = _box_pose(scenario_from_dict({**OBSTACLE, "scene": str(path), "obstacle": {"size": [0.3, 0.4, 0.2]}}, MODELS, check=False).robot)
        np.testing.assert_allclose(resized[0][:2], before[0][:2], atol=1e-6)
        np.testing.assert_allclose(resized[1], before[1], atol=1e-6)
        assert resized[2] == pytest.approx(before[2], abs=1e-6)
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, _euler_quat([0, 0, 30]))
        placed = _box_pose(scenario_from_dict({**OBSTACLE, "scene": str(path), "obstacle": {"pos": [0.6, 0.0, 0.1], "euler": [0, 0, 30]}},
                                         MODELS, check=False).robot)
        np.testing.assert_allclose(placed[0], [0.6, 0.0, 0.1], atol=1e-6)
        np.testing.assert_allclose(placed[1], R.reshape(3, 3), atol=1e-6)


def test_a_box_given_by_fromto_is_moved_and_resized(tmp_path):
    """A box written with fromto (MuJoCo derives its centre, orientation and length from the segment): [obstacle] set
    its pos beside the fromto, which MuJoCo refuses, and the plan failed with "could not load MJCF file ...: both pos
    and fromto defined", blaming a file that loads. The box is written out by pos, quat and size, then edited."""
    path = tmp_path / "fromto.xml"
    path.write_text(
        '<mujoco><worldbody><geom type="plane" size="2 2 0.1"/><frame pos="0.1 0 0" euler="0 0 30">'
        '<geom name="post" type="box" fromto="0.35 0 0 0.35 0 0.25" size="0.04 0.2 0.125"/></frame><body pos="0 0 0.5">'
        '<joint name="shoulder" type="hinge" axis="0 1 0" range="-100 100"/><geom type="capsule" fromto="0 0 0 0.35 0 0" '
        'size="0.03"/></body></worldbody></mujoco>')
    task = {"q_init": [0.3], "q_goal": [-0.3], "scene": str(path)}

    def box(**obstacle) -> tuple[np.ndarray, np.ndarray, float]:
        m = scenario_from_dict({**task, **({"obstacle": obstacle} if obstacle else {})}, tmp_path, check=False).robot.model
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        g = m.geom("post").id
        corners = np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T * m.geom_size[g]
        return d.geom_xpos[g].copy(), m.geom_size[g].copy(), float((d.geom_xpos[g] + corners @ d.geom_xmat[g].reshape(3, 3).T)[:, 2].min())

    before = box()
    moved = box(pos=[0.6, 0.1, 0.1], size=[0.1, 0.1, 0.2])
    np.testing.assert_allclose(moved[0], [0.6, 0.1, 0.1], atol=1e-6)
    np.testing.assert_allclose(moved[1], [0.05, 0.05, 0.1], atol=1e-6)
    taller = box(size=[0.08, 0.08, 0.4])
    np.testing.assert_allclose(taller[0][:2], before[0][:2], atol=1e-6)
    assert taller[2] == pytest.approx(before[2], abs=1e-6) and taller[1][2] == pytest.approx(0.2, abs=1e-6)


def test_an_obstacle_name_is_checked_even_when_the_table_changes_nothing_else():
    """A misspelt box name alone is refused (it was ignored: the scene planned on was not the one meant);
    the right name alone leaves the box as it is."""
    with pytest.raises(ScenarioError, match=r"\[obstacle\] name 'obstacle_bx': no static collision box of that name"):
        _robot(obstacle={"name": "obstacle_bx"})
    g = _robot(obstacle={"name": "obstacle_box"}).model.geom("obstacle_box")
    np.testing.assert_allclose(g.size, [0.1, 0.25, 0.075])
    np.testing.assert_allclose(g.pos, [0.5, 0.0, 0.075])


def test_a_taller_obstacle_puts_the_goal_in_collision():
    with pytest.raises(ScenarioError, match="q_goal"):
        scenario_from_dict({**OBSTACLE, "obstacle": {"size": [0.3, 0.5, 0.3], "pos": [0.85, 0.0, 0.15]}}, MODELS)


# A user's 2-link arm: unnamed geoms, no actuators, angles in degrees (MuJoCo's default).
TWO_LINK = """
<mujoco>
  <worldbody>
    <geom type="plane" size="2 2 0.1"/>
    <geom type="box" pos="0.7 0 0.5" size="0.05 0.2 0.05"/>
    <body pos="0 0 0.5">
      <joint name="shoulder" type="hinge" axis="0 -1 0" range="-90 90"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
      <body pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 -1 0" range="-120 120"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.025" mass="0.5"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_unnamed_geoms_and_degrees_work(tmp_path):
    p = tmp_path / "arm.xml"
    p.write_text(TWO_LINK)
    r = RobotModel.from_xml(p)
    assert r.config.joint_names == ("shoulder", "elbow")
    np.testing.assert_allclose(r.upper, np.radians([90, 120]))
    assert all(r.geom_name(g).startswith("geom") for g in r.pairs.ravel())
    from foam_mj.clearance import Clearance

    c = Clearance(r)
    # Arm straight out along x at z = 0.5: its tip (x = 0.55 + 0.025) is 0.075 m short of the box's face (x = 0.65).
    assert c(np.zeros(2)) == pytest.approx(0.075, abs=1e-6)
    np.testing.assert_allclose(c.batch(np.zeros((1, 2))), [c(np.zeros(2))])
    c.close()


BAD_JOINTS = """
<mujoco>
  <worldbody>
    <geom type="plane" size="2 2 0.1"/>
    <body name="a" pos="0 0 1">
      <joint name="swivel" type="ball"/>
      <geom type="sphere" size="0.05"/>
      <body name="b" pos="0 0 -0.3">
        <joint name="spin" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/>
        <site name="s1"/>
      </body>
    </body>
    <body name="c" pos="1 0 1">
      <freejoint name="float"/>
      <geom type="box" size="0.1 0.1 0.1"/>
      <site name="s2"/>
    </body>
  </worldbody>
  <tendon>
    <spatial name="cable" limited="true" range="0 2"><site site="s1"/><site site="s2"/></spatial>
  </tendon>
</mujoco>
"""


@pytest.mark.parametrize(
    "joint, reason",
    [("swivel", "is a ball joint"), ("float", "is a free joint"), ("spin", "has no range"), ("cable", "is a tendon"), ("nope", "not in the model")],
)
def test_bad_configuration_joints_are_named_before_planning(tmp_path, joint, reason):
    p = tmp_path / "bad.xml"
    p.write_text(BAD_JOINTS)
    with pytest.raises(FoamError, match=f"'{joint}' {reason}" if joint != "nope" else reason) as info:
        scenario_from_dict({"scene": str(p), "q_init": [0.0], "q_goal": [0.1], "joints": [joint]}, tmp_path)
    assert "\n" not in str(info.value)


def test_a_model_without_limited_joints_is_refused(tmp_path):
    p = tmp_path / "bad.xml"
    p.write_text(BAD_JOINTS)
    with pytest.raises(FoamError, match="no limited hinge or slide joint"):
        scenario_from_dict({"scene": str(p), "q_init": [0.0], "q_goal": [0.1]}, tmp_path)


def test_scenario_joints_and_normalization_override_the_model():
    r = _robot(joints=["knee_flexion", "hip_flexion"], normalize={"knee_flexion": [1.0]})
    assert r.config.joint_names == ("knee_flexion", "hip_flexion")
    np.testing.assert_allclose([r.lower[0], r.upper[0]], [0.0, 1.0])  # knee range 0..2.1 rad onto 0..1
    # The edited scene is self-describing: loading its MJCF gives the same configuration.
    again = RobotModel.from_spec(mujoco.MjSpec.from_string(r.xml), "copy.xml")
    assert again.config.joint_names == r.config.joint_names
    np.testing.assert_allclose(again.upper, r.upper)


def test_a_hinge_normalization_written_in_degrees_is_refused_saying_qpos_is_radians():
    """A user of a model in degrees (MuJoCo's default) who normalizes the knee as qpos -90..90 got a silent map of
    -90..90 radians onto [0, S] (bounds of q a sliver [0.77, 0.80] of it, then 'q_init outside its bounds'): refused,
    naming the field and the radians meant. A map in radians, or one wider than a turn on a multi-turn range, is fine."""
    with pytest.raises(ScenarioError, match=r"normalize.knee_flexion maps qpos -90..140 onto \[0, 1\], but a hinge's qpos is in "
                                            r"radians .* -90..140 degrees is -1.5708..2.44346 radians"):
        scenario_from_dict({**OBSTACLE, "normalize": {"knee_flexion": [-90.0, 140.0, 1.0]}}, MODELS)
    ok = scenario_from_dict({**OBSTACLE, "q_init": [0.2, 0.466, 0.08], "q_goal": [0.45, 0.504, 1.45],
                             "normalize": {"knee_flexion": [-1.5707963, 2.443461, 1.0]}}, MODELS)
    np.testing.assert_allclose([ok.robot.lower[1], ok.robot.upper[1]], [0.391304, 0.91444], atol=1e-6)


def test_a_normalization_of_a_joint_outside_the_configuration_is_refused():
    """[normalize] for a joint the scenario's `joints` leave out would change nothing (it was silently ignored, as
    in the README's own example table): refused, naming the joint and the configuration."""
    with pytest.raises(ScenarioError, match=r"normalization given for \['hip_displacement'\], which are not configuration joints"):
        scenario_from_dict({**OBSTACLE, "q_init": [0.2, 0.3], "q_goal": [0.45, 0.4536], "joints": ["hip_flexion", "knee_flexion"],
                            "normalize": {"hip_displacement": [0.0, 0.7, 1.5707963267948966]}}, MODELS)
