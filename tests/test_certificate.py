"""Tests for the per-pair certificate (foam_mj.bubbles, foam_mj.model's pair lists): MuJoCo's own collision
filters, per-pair rho, pairs no joint can change, self-collision, the robot's root body."""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foam_mj.bubbles import BubbleOracle
from foam_mj.errors import ConfigurationError, ModelError
from foam_mj.foam import FoamParams, plan
from foam_mj.geom_pairs import collision_pairs
from foam_mj.model import RobotModel
from foam_mj.planners import PlanningProblem, get_planner

_INERTIAL = '<inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>'

# A UR5e-like arm: a shoulder capsule 3 mm above the floor, turned only by a vertical pan joint; an upper
# arm and a forearm that can fold back onto the shoulder; a post in front of the arm.
PAN_ARM = f"""<mujoco model="pan arm"><compiler angle="radian"/><worldbody>
  <geom name="floor" type="plane" size="2 2 0.1"/>
  <geom name="post" type="box" pos="0.6 0 0.3" size="0.05 0.05 0.3"/>
  <body name="shoulder" pos="0 0 0.1">{_INERTIAL}
    <joint name="pan" axis="0 0 1" range="-3.14 3.14"/>
    <geom name="shoulder_collision" type="capsule" fromto="0 0 -0.05 0 0 0.05" size="0.047"/>
    <body name="upper_arm" pos="0 0.06 0.05">{_INERTIAL}
      <joint name="lift" axis="0 1 0" range="-3.14 0.5"/>
      <geom name="upper_arm_collision" type="capsule" fromto="0 0 0 0.4 0 0" size="0.05"/>
      <body name="forearm" pos="0.4 0 0">{_INERTIAL}
        <joint name="elbow" axis="0 1 0" range="-3.1 3.1"/>
        <geom name="forearm_collision" type="capsule" fromto="0 0 0 0.35 0 0" size="0.04"/>
      </body>
    </body>
  </body>
</worldbody></mujoco>"""


def _robot(tmp_path, xml: str, name: str = "scene.xml", **kw) -> RobotModel:
    path = tmp_path / name
    path.write_text(xml)
    return RobotModel.from_xml(path, **kw)


def _gid(m, name: str) -> int:
    return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)


# -- MuJoCo's filters -------------------------------------------------------------------------------------------
def _random_filtered_scene(rng: np.random.Generator) -> str:
    """A random chain (some bodies without joints, so welded to their parent) with random contype and
    conaffinity bits, a random <exclude> and a random explicit <pair>."""
    from chains import random_chain_xml

    xml = random_chain_xml(rng, self_collision=True, joints=(2, 5))
    for i in range(40):  # random collision bits on every geom
        xml = xml.replace(f'name="g{i}" ', f'name="g{i}" contype="{rng.integers(0, 4)}" conaffinity="{rng.integers(0, 4)}" ', 1)
    xml = xml.replace(' contype="1" conaffinity="1"/>', "/>")
    m = mujoco.MjModel.from_xml_string(xml)
    extra = []
    if m.nbody > 2:
        a, b = sorted(rng.choice(np.arange(1, m.nbody), 2, replace=False))
        extra.append(f'<exclude body1="b{a - 1}" body2="b{b - 1}"/>')
    if m.ngeom > 1:
        a, b = rng.choice(m.ngeom, 2, replace=False)
        extra.append(f'<pair geom1="{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, a)}" geom2="{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, b)}"/>')
    return xml.replace("<worldbody>", "<contact>" + "".join(extra) + "</contact><worldbody>", 1)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_the_pairs_are_the_ones_mujoco_collides(seed):
    """With every geom inflated by a 10 m margin, mj_collision reports a contact for every pair it tests:
    collision_pairs must name exactly those (contype/conaffinity, welds, parent/child, <exclude>, <pair>)."""
    # Spheres only: the filters do not depend on the shapes, and MuJoCo's box-box collider does not report
    # every separated pair within a margin.
    xml = re.sub(r'(<geom [^>]*?) type="\w+"', r'\1 type="sphere"', _random_filtered_scene(np.random.default_rng(seed)))
    spec = mujoco.MjSpec.from_string(xml)
    for g in spec.geoms:
        g.margin = 10.0
    for p in spec.pairs:
        p.margin = 10.0
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    seen = {tuple(sorted(map(int, g))) for g in d.contact.geom[: d.ncon]}
    assert seen == set(collision_pairs(mujoco.MjModel.from_xml_string(xml)))


def test_an_excluded_body_pair_is_not_checked(tmp_path):
    xml = PAN_ARM.replace("<worldbody>", '<contact><exclude body1="shoulder" body2="forearm"/></contact><worldbody>')
    names = lambda r: {r.pair_name(i) for i in range(len(r.pairs))}  # noqa: E731
    assert ("shoulder_collision", "forearm_collision") in names(_robot(tmp_path, PAN_ARM))
    assert ("shoulder_collision", "forearm_collision") not in names(_robot(tmp_path, xml))


# -- pairs no joint can change, and the per-pair bound ---------------------------------------------------------
@pytest.mark.parametrize("pedestal, fixed", [
    ('type="cylinder" pos="0 0 -0.01" size="0.08 0.02"', True),  # coaxial with the pan joint, 43 mm below the shoulder
    ('type="capsule" fromto="0 0 -0.3 0 0 -0.02" size="0.04"', True),
    ('type="sphere" pos="0 0 -0.03" size="0.05"', True),  # centred on the pan axis
    ('type="cylinder" pos="0.01 0 -0.01" size="0.08 0.02"', False),  # 1 cm off the axis: the pan changes the distance
    ('type="box" pos="0 0 -0.01" size="0.08 0.08 0.02"', False),  # not a solid of revolution
])
def test_a_pedestal_of_revolution_under_the_pan_joint_drops_out_of_the_bound(tmp_path, pedestal, fixed):
    """A fixed cylinder, capsule or sphere whose symmetry axis is the pan joint's: turning the arm about it maps the
    pedestal onto itself, so the pan cannot change any arm geom's distance to it (checked here with MuJoCo over random
    poses), and only the pan moves the shoulder: that pair drops out, and the upper arm's keeps the lift
    but not the pan, as against a floor under a pan. The pan's rho capped every bubble at (gap - delta) / ||rho|| (a
    planar 3-link arm 40 mm above its pedestal: 7,116 bubbles instead of 1,837). Off the axis, or a box, the pan
    changes the distances and counts."""
    xml = PAN_ARM.replace('<geom name="floor" type="plane" size="2 2 0.1"/>', f'<geom name="pedestal" {pedestal}/>')
    robot = _robot(tmp_path, xml.replace('<body name="shoulder" pos="0 0 0.1">', '<body name="shoulder" pos="0 0 0.15">'))
    m, d = robot.model, mujoco.MjData(robot.model)
    shoulder, upper, ped = _gid(m, "shoulder_collision"), _gid(m, "upper_arm_collision"), _gid(m, "pedestal")
    pairs = [tuple(sorted(p)) for p in robot.pairs]
    assert (tuple(sorted((ped, shoulder))) in {tuple(sorted(p)) for p in robot.fixed_pairs}) == fixed
    assert robot.pair_active[pairs.index(tuple(sorted((ped, upper))))].tolist() == [not fixed, True, False]
    rng = np.random.default_rng(0)
    pans = []
    for _ in range(10):
        q = robot.lower + rng.random(3) * (robot.upper - robot.lower)
        dist = []
        for pan in np.linspace(-3.0, 3.0, 7):
            robot.set_configuration(np.array([pan, q[1], q[2]]), d)
            dist.append([mujoco.mj_geomDistance(m, d, g, ped, 1.0, None) for g in (shoulder, upper)])
        pans.append(np.ptp(dist, axis=0).max())
    assert (max(pans) < 1e-9) == fixed


def test_a_pair_no_joint_can_change_drops_out_and_the_arm_plans(tmp_path):
    """The shoulder is 3 mm above the floor and only the pan joint moves it. With delta = 2 mm, one global
    clearance would make every radius tiny: the pair drops out, the others keep their own rho, and the foam
    reaches the goal on the far side of the post; the path keeps delta on every pair by MuJoCo's reckoning,
    and the shoulder stays 3 mm above the floor all along. With delta = 5 mm every path would break the margin
    on that pair (as `foam-mj verify` counts it): every planner refuses, naming it."""
    robot = _robot(tmp_path, PAN_ARM)
    m, d = robot.model, mujoco.MjData(robot.model)
    shoulder, floor = _gid(m, "shoulder_collision"), _gid(m, "floor")
    assert [tuple(p) for p in robot.fixed_pairs] == [(floor, shoulder)]
    q_init, q_goal = np.array([-1.2, -0.6, 0.5]), np.array([1.2, -0.6, 0.5])
    robot.set_configuration(q_init, d)
    assert mujoco.mj_geomDistance(m, d, shoulder, floor, 1.0, None) == pytest.approx(0.003)
    near = BubbleOracle(robot, delta=0.005)
    refusal = r"robot geom shoulder_collision and obstacle floor are 0\.003\d* m apart, within the safety margin delta 0\.005 m"
    with pytest.raises(ConfigurationError, match=refusal):
        plan(near, q_init, q_goal, FoamParams(K=6, r_min=0.05, delta=0.005), seed=0)
    with pytest.raises(ConfigurationError, match=refusal):
        get_planner("bubbletree").plan(PlanningProblem(near, q_init, q_goal, delta=0.005), seed=0)
    near.close()
    oracle = BubbleOracle(robot, delta=0.002)
    assert oracle.radius(q_init) > 0.1
    res = plan(oracle, q_init, q_goal, FoamParams(K=6, r_min=0.05, delta=0.002, time_limit=60), seed=0)
    path = np.vstack([res.rosary.centers, q_goal])
    checked = {tuple(sorted(p)) for p in robot.pairs}
    dense = np.vstack([a + s * (b - a) for a, b in zip(path[:-1], path[1:]) for s in np.linspace(0, 1, 40)])
    crossed_post = False
    for q in dense:
        robot.set_configuration(q, d)
        mujoco.mj_collision(m, d)
        assert d.ncon == 0
        assert mujoco.mj_geomDistance(m, d, shoulder, floor, 1.0, None) == pytest.approx(0.003, abs=1e-9)
        assert min(mujoco.mj_geomDistance(m, d, a, b, 1.0, None) for a, b in checked) >= 0.002 - 1e-9
        crossed_post |= abs(q[0]) < 0.05
    assert crossed_post
    oracle.close()


def test_each_pair_keeps_its_own_rho(tmp_path):
    """The upper arm's bound leaves out the elbow, which does not move it; the radius is the smallest
    per-pair term, never below the single-bound (d - delta) / max ||rho_p||."""
    robot = _robot(tmp_path, PAN_ARM)
    oracle = BubbleOracle(robot, delta=0.005)
    m = robot.model
    names = [robot.pair_name(i) for i in range(len(robot.pairs))]
    upper = names.index(("upper_arm_collision", "post"))
    fore = names.index(("forearm_collision", "post"))
    assert oracle.pair_rho[upper][2] == 0 and oracle.pair_rho[fore][2] > 0
    # Lift: upper arm reach 0.4 + 0.05 from its axis; forearm: 0.4 + 0.35 + 0.04 (triangle inequality).
    assert oracle.pair_rho[upper][1] == pytest.approx(0.45)
    assert oracle.pair_rho[fore][1] == pytest.approx(0.79)
    Q = np.random.default_rng(0).uniform(robot.lower, robot.upper, (200, 3))
    single = oracle.radius_from_clearance(oracle.clearance.batch(Q), Q)
    R = oracle.radii(Q)
    assert np.all(R >= single - 1e-12) and np.mean(R > single + 1e-6) > 0.3
    assert m.ngeom == 5
    oracle.close()


# -- self-collision -------------------------------------------------------------------------------------------
def test_a_folding_chain_is_kept_off_itself(tmp_path):
    """The forearm can fold back onto the shoulder. Its self pair is checked (rho over the lift and elbow
    joints only: the pan turns both), a folded pose has clearance below delta and radius 0, and every point
    sampled in bubbles near the fold keeps delta on the self pair. With self_collision = false the pair is
    gone and the folded pose gets a positive radius."""
    robot = _robot(tmp_path, PAN_ARM)
    m, d = robot.model, mujoco.MjData(robot.model)
    names = [robot.pair_name(i) for i in range(len(robot.pairs))]
    k = names.index(("shoulder_collision", "forearm_collision"))
    assert robot.self_pair[k] and robot.self_pair.sum() == 1
    oracle = BubbleOracle(robot, delta=0.005)
    assert oracle.pair_rho[k][0] == 0 and np.all(oracle.pair_rho[k][1:] > 0)
    folded = np.array([2.0, -0.05, 2.95])
    fa, sh = _gid(m, "forearm_collision"), _gid(m, "shoulder_collision")
    robot.set_configuration(folded, d)
    assert mujoco.mj_geomDistance(m, d, fa, sh, 1.0, None) < 0.005
    assert oracle.radius(folded) == 0.0 and robot.in_collision(folded) == (mujoco.mj_geomDistance(m, d, fa, sh, 1.0, None) <= 0)
    rng = np.random.default_rng(1)
    tested = 0
    for q in np.c_[rng.uniform(-3, 3, 300), rng.uniform(-1.2, 0.3, 300), rng.uniform(2.0, 3.0, 300)]:
        r = oracle.radius(q)
        if r <= 0:
            continue
        tested += 1
        u = rng.standard_normal((20, 3))
        for a in q + r * rng.random((20, 1)) ** (1 / 3) * u / np.linalg.norm(u, axis=1, keepdims=True):
            robot.set_configuration(np.clip(a, robot.lower, robot.upper), d)
            assert mujoco.mj_geomDistance(m, d, fa, sh, 1.0, None) >= 0.005 - 1e-9
    assert tested > 50
    off = BubbleOracle(_robot(tmp_path, PAN_ARM, "off.xml", self_collision=False), delta=0.005)
    assert not off.robot.self_pair.any() and off.radius(folded) > 0
    oracle.close()
    off.close()


# -- the robot's root body ------------------------------------------------------------------------------------
# (the shoulder 1 cm higher: a scenario refuses the pan arm's 3 mm, within delta, that no joint changes)
OTHER_BODIES = PAN_ARM.replace('<body name="shoulder" pos="0 0 0.1">', '<body name="shoulder" pos="0 0 0.11">').replace(
    "</worldbody>",
    f'''<body name="crate" pos="-0.5 0.4 0.2">{_INERTIAL}<freejoint name="crate_free"/>
    <geom name="crate" type="box" size="0.1 0.1 0.1"/></body>
  <body name="door" pos="-0.6 -0.6 0.3">{_INERTIAL}<joint name="door_hinge" axis="0 0 1" range="-1.5 1.5"/>
    <geom name="door" type="box" pos="0.3 0 0" size="0.3 0.02 0.3"/></body>
</worldbody><keyframe><key name="ajar" qpos="-0.5 0.4 0.2 1 0 0 0 0 0 0 0.8"/></keyframe>''',
)


def test_bodies_outside_the_robot_root_are_obstacles_at_their_pose(tmp_path):
    """Without robot_root the door's limited hinge is a coordinate and the door part of the robot; with
    robot_root = "shoulder" the arm's three joints are the coordinates and the door and the loose crate are
    obstacles, held at qpos0 or at a named keyframe's pose."""
    everything = _robot(tmp_path, OTHER_BODIES)
    assert everything.config.joint_names == ("pan", "lift", "elbow", "door_hinge")
    arm = _robot(tmp_path, OTHER_BODIES, "arm.xml", robot_root="shoulder")
    assert arm.config.joint_names == ("pan", "lift", "elbow")
    m = arm.model
    door, crate = _gid(m, "door"), _gid(m, "crate")
    assert {door, crate} <= set(arm.obstacle_geoms.tolist()) and door in everything.robot_geoms
    assert any(door in p for p in arm.pairs) and any(crate in p for p in arm.pairs)
    ajar = _robot(tmp_path, OTHER_BODIES, "ajar.xml", robot_root="shoulder", keyframe="ajar")
    q = np.array([-2.0, -0.3, 0.5])
    d0, d1 = arm.set_configuration(q, mujoco.MjData(m)), ajar.set_configuration(q, mujoco.MjData(ajar.model))
    assert np.linalg.norm(d0.geom_xpos[door] - d1.geom_xpos[door]) > 0.1  # the door turned 0.8 rad in the keyframe
    with pytest.raises(ModelError, match="robot_root 'nope'"):
        _robot(tmp_path, OTHER_BODIES, "bad.xml", robot_root="nope")
    with pytest.raises(ModelError, match="keyframe 'shut'"):
        _robot(tmp_path, OTHER_BODIES, "bad2.xml", robot_root="shoulder", keyframe="shut")


def test_a_scenario_names_the_robot_root_and_turns_self_collision_off(tmp_path):
    from foam_mj.errors import ScenarioError
    from foam_mj.scenarios import load_scenario

    (tmp_path / "arm.xml").write_text(OTHER_BODIES)
    base = 'scene = "arm.xml"\nq_init = [-1.2, -0.6, 0.5]\nq_goal = [1.2, -0.6, 0.5]\nrobot_root = "shoulder"\n'
    (tmp_path / "a.toml").write_text(base + "self_collision = false\n")
    sc = load_scenario(tmp_path / "a.toml")
    assert sc.robot.config.joint_names == ("pan", "lift", "elbow") and not sc.robot.self_pair.any()
    (tmp_path / "b.toml").write_text(base)
    assert load_scenario(tmp_path / "b.toml").robot.self_pair.any()
    for extra, message in (
        ("self_collision = 0\n", "field 'self_collision' must be true or false"),
        ('keyframe = ""\n', "field 'keyframe' must be a name"),
    ):
        (tmp_path / "c.toml").write_text(base + extra)
        with pytest.raises(ScenarioError, match=message):
            load_scenario(tmp_path / "c.toml")
    (tmp_path / "d.toml").write_text(base.replace('"shoulder"', '"nope"'))
    with pytest.raises(ScenarioError, match="robot_root 'nope'"):
        load_scenario(tmp_path / "d.toml")



# A tilt about x, 0.6 m above the floor, and below it a spin about z (parallel to the floor's normal in the drawn
# pose) carrying a ball 0.4 m out.
TILT_SPIN = f"""<mujoco><compiler angle="radian"/><worldbody>
  <geom name="floor" type="plane" size="2 2 0.1"/>
  <body name="tilt" pos="0 0 0.6">{_INERTIAL}
    <joint name="tilt" axis="1 0 0" range="-1.6 1.6"/>
    <body name="spin">{_INERTIAL}
      <joint name="spin" axis="0 0 1" range="-3 3"/>
      <geom name="ball" type="sphere" size="0.05" pos="0.4 0 0"/>
    </body>
  </body>
</worldbody></mujoco>"""


def test_a_hinge_parallel_to_the_floor_normal_below_a_crossed_hinge_still_changes_the_distance(tmp_path):
    """The spin cannot change the ball's height in the drawn pose, but once the tilt turns its axis level it swings
    the ball up and down: the pair (ball, floor) keeps the spin's rho, and a spin-only move changes the distance by
    no more than the pair's bound (the rule drops a hinge parallel to a plane's normal only when every hinge above
    it is parallel too)."""
    robot = _robot(tmp_path, TILT_SPIN)
    oracle = BubbleOracle(robot, delta=0.005)
    p = [robot.pair_name(i) for i in range(len(robot.pairs))].index(("ball", "floor"))
    assert robot.pair_active[p].tolist() == [True, True]
    q = np.array([np.pi / 2, 0.0])  # the spin's axis level: the ball swings in a vertical plane
    for spin in (-1.0, -0.5, 0.5, 1.0):
        a = q + [0.0, spin]
        change = abs(oracle.clearance.pair_distances(a)[p] - oracle.clearance.pair_distances(q)[p])
        assert change > 0.1 and change <= oracle.pair_rho[p] @ np.abs(a - q) + 1e-9
