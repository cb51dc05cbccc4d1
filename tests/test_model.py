"""Tests for foam_mj.model and foam_mj.clearance: loading, the configuration map, validation, clearance."""

from __future__ import annotations

import ctypes

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foam_mj import clearance
from foam_mj.capsule_box import segment_meets_box
from foam_mj.clearance import FIRST_BATCH, THREADED_BATCH, Clearance
from foam_mj.errors import ConfigurationError, ModelError
from foam_mj.model import RobotModel

from conftest import MODELS

# Leg dimensions from ortholeg.xml, used for hand calculations.
HIP_HEIGHT, THIGH, SHANK, SOLE_BELOW_ANKLE = 1.06, 0.43, 0.43, 0.068
TOE_AHEAD_OF_ANKLE = 0.083 + 0.133


def test_configuration_is_declared_by_the_model(obstacle_robot):
    cfg = obstacle_robot.config
    assert cfg.joint_names == ("hip_flexion", "knee_flexion", "hip_displacement")
    # theta_q = 0 .. pi/2 is the swing's 0.7 m of hip travel (paper 003, section 5.1); the slide's
    # range, -0.1 .. 0.8 m, sets the bounds.
    np.testing.assert_allclose(cfg.lower, [-0.5, 0.0, -0.1 / 0.7 * np.pi / 2])
    np.testing.assert_allclose(cfg.upper, [1.6, 2.1, 0.8 / 0.7 * np.pi / 2])
    q = np.array([0.3, 0.4, np.pi / 4])
    qpos = cfg.to_qpos(q)
    np.testing.assert_allclose(qpos, [0.35, 0.3, 0.4])  # qpos order: slide, hip, knee
    np.testing.assert_allclose(cfg.to_q(qpos), q)


def test_robot_and_obstacle_geoms_come_from_the_model(obstacle_robot):
    names = {obstacle_robot.geom_name(g) for g in obstacle_robot.robot_geoms}
    assert names == {"thigh_collision", "shank_collision", "foot_collision"}
    assert {obstacle_robot.geom_name(g) for g in obstacle_robot.obstacle_geoms} == {"floor", "obstacle_box"}
    assert len(obstacle_robot.pairs) == 6 and not obstacle_robot.self_pair.any()  # the foot is welded to the shank: MuJoCo filters thigh/foot as parent/child


def test_hip_flexion_moves_the_foot_forward_and_knee_flexion_backward(obstacle_robot):
    import mujoco

    m = obstacle_robot.model
    foot = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "foot")
    x0 = obstacle_robot.set_configuration(np.array([0.0, 0.0, 0.0])).xpos[foot][0]
    x_hip = obstacle_robot.set_configuration(np.array([0.3, 0.0, 0.0])).xpos[foot][0]
    x_knee = obstacle_robot.set_configuration(np.array([0.0, 0.3, 0.0])).xpos[foot][0]
    assert x_hip > x0 + 0.1 and x_knee < x0 - 0.05


def test_clearance_matches_a_hand_computed_placement(obstacle_robot):
    c = Clearance(obstacle_robot)
    # Leg straight down, hip at x = 0: the sole is 1.06 - 0.43 - 0.43 - 0.068 = 0.132 m above the floor,
    # and the toe (x = 0.216) is 0.184 m short of the box's near face (x = 0.4).
    straight = np.array([0.0, 0.0, 0.0])
    pairs = c.pairwise(straight)
    sole = HIP_HEIGHT - THIGH - SHANK - SOLE_BELOW_ANKLE
    assert pairs[("foot_collision", "floor")] == pytest.approx(sole, abs=1e-6)
    assert pairs[("foot_collision", "obstacle_box")] == pytest.approx(0.4 - TOE_AHEAD_OF_ANKLE, abs=1e-6)
    assert c(straight) == pytest.approx(sole, abs=1e-6)
    # Hip moved 0.5 m forward: the straight leg's foot sinks 0.15 - 0.132 = 0.018 m into the box.
    over_box = np.array([0.0, 0.0, 0.5 / 0.7 * np.pi / 2])
    assert c(over_box) == pytest.approx(sole - 0.15, abs=1e-6)
    assert obstacle_robot.in_collision(over_box) and not obstacle_robot.in_collision(straight)


def test_batch_clearance_equals_single_clearance(obstacle_robot):
    c = Clearance(obstacle_robot)
    rng = np.random.default_rng(1)
    Q = rng.uniform(obstacle_robot.lower, obstacle_robot.upper, size=(600, 3))  # crosses the threaded batch size
    np.testing.assert_allclose(c.batch(Q), [c(q) for q in Q], atol=1e-12)
    np.testing.assert_allclose(c.batch(Q[:7]), [c(q) for q in Q[:7]], atol=1e-12)
    assert c.batch(np.empty((0, 3))).shape == (0,)


def test_batch_clearance_of_a_model_with_a_singular_inertia_matrix_is_silent_and_exact(tmp_path, monkeypatch, capfd):
    """Two hinges on one axis: the batch's position stage factors the singular inertia matrix, and MuJoCo printed its
    warning once per batch row and appended each to MUJOCO_LOG.TXT in the working folder. The sensors read no inertia."""
    from test_cli import COAXIAL

    monkeypatch.chdir(tmp_path)
    (tmp_path / "coaxial.xml").write_text(COAXIAL)
    with pytest.warns(UserWarning, match="Inertia matrix is too close to singular"):  # the compiler's, once per compile
        robot = RobotModel.from_xml(tmp_path / "coaxial.xml")
        c = Clearance(robot)
    capfd.readouterr()
    Q = np.random.default_rng(3).uniform(robot.lower, robot.upper, size=(300, 3))
    # Where a link's axis runs through the box, one at a time reads at most minus its radius (foam_mj.capsule_box);
    # the batch, which measures only certified bubble centres, keeps MuJoCo's value.
    box = robot.model.geom("box").id
    through = np.array([any(segment_meets_box(robot.model, robot.set_configuration(q), int(g), box) for g in robot.robot_geoms)
                        for q in Q])
    single = np.array([c(q) for q in Q])
    np.testing.assert_allclose(c.batch(Q)[~through], single[~through], atol=1e-12)
    assert 0 < through.sum() < 30 and (single[through] <= -0.02).all()
    assert "WARNING" not in capfd.readouterr().err and not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_the_qpos_block_written_by_a_batch_is_the_coordinates_addresses_in_any_order():
    """Clearance writes q into a batch's qpos rows as one slice and a column order where the coordinates' qpos addresses
    form a block (the obstacle leg's are 1, 2, 0): the same columns as the addresses themselves; none with gaps or repeats."""
    q = np.array([[10.0, 20.0, 30.0]])
    for index in ([1, 2, 0], [0, 1, 2], [4, 2, 3]):
        block, order = clearance._qpos_block(np.array(index))
        by_block, by_index = np.zeros((1, 6)), np.zeros((1, 6))
        by_block[:, block] = q if order is None else q[:, order]
        by_index[:, index] = q
        assert np.array_equal(by_block, by_index)
    assert clearance._qpos_block(np.array([0, 1, 2]))[1] is None
    assert clearance._qpos_block(np.array([0, 2, 3])) is None and clearance._qpos_block(np.array([1, 1, 2])) is None


def test_a_batch_gives_each_configuration_the_distances_of_a_query_of_it_alone(obstacle_robot):
    """batch_pairs (the coordinates written as a permuted qpos block, the simulations called without mujoco.batch's
    per-call check of their ids) reads every pair as pair_distances does for that configuration alone."""
    c = Clearance(obstacle_robot, threads=1)
    assert c._qpos_block is not None and c._qpos_block[1] is not None  # the leg's addresses 1, 2, 0
    Q = np.random.default_rng(5).uniform(obstacle_robot.lower, obstacle_robot.upper, size=(37, 3))
    for rows in (Q, Q[:5], Q[:1]):  # fewer rows than the batch holds: the unchecked call on ids[:n]
        np.testing.assert_allclose(c.batch_pairs(rows), [c.pair_distances(q) for q in rows], atol=1e-12)


def test_a_one_thread_clearance_gives_the_two_thread_batches_values_bit_for_bit(obstacle_robot):
    # benchmarks/planners.py times our planners in one thread, as the single-threaded peers (OMPL).
    Q = np.random.default_rng(4).uniform(obstacle_robot.lower, obstacle_robot.upper, size=(2 * THREADED_BATCH, 3))
    one = Clearance(obstacle_robot, threads=1)
    assert np.array_equal(one.batch_pairs(Q), Clearance(obstacle_robot).batch_pairs(Q))
    assert set(one._state().batches) == {1}  # a batch past THREADED_BATCH stayed in one thread
    with pytest.raises(ValueError, match="threads"):
        Clearance(obstacle_robot, threads=0)


def test_mujocos_profiler_clock_is_off_while_a_batch_runs_and_back_after_it(obstacle_robot, monkeypatch):
    # The bindings' clock (mjcb_time) is read ~10 times per configuration for mjData.timer: 13 % of a query's time.
    switch = clearance._PROFILER_OFF
    pointer = switch._pointer
    assert pointer is not None and pointer.value  # found, and the bindings' clock is installed
    clock = pointer.value
    seen = []
    forward = mujoco.batch.Batch.forward

    def spy(self, *args, **kwargs):
        seen.append(pointer.value)
        return forward(self, *args, **kwargs)

    monkeypatch.setattr(mujoco.batch.Batch, "forward", spy)
    Q = np.random.default_rng(5).uniform(obstacle_robot.lower, obstacle_robot.upper, size=(2 * THREADED_BATCH, 3))
    c = Clearance(obstacle_robot)
    quiet = c.batch_pairs(Q)
    assert seen == [None] and pointer.value == clock
    monkeypatch.setattr(switch, "_pointer", None)  # the profiler on: the same distances, bit for bit
    assert np.array_equal(quiet, c.batch_pairs(Q)) and seen[-1] == clock


def test_a_profiler_callback_the_user_set_stays_and_runs_during_batches(obstacle_robot):
    ticks = []

    @ctypes.CFUNCTYPE(ctypes.c_double)
    def clock() -> float:  # a C callback (a batch refuses a Python one)
        ticks.append(1)
        return float(len(ticks))

    mujoco.set_mjcb_time(clock)
    try:
        Clearance(obstacle_robot).batch_pairs(np.array([[0.3, 0.5, 0.1], [0.2, 0.4, 0.0]]))
        assert ticks and mujoco.get_mjcb_time() is clock
    finally:
        mujoco.set_mjcb_time(None)


def test_batch_pair_distances_are_every_pairs_distance_and_survive_later_calls(obstacle_robot):
    c = Clearance(obstacle_robot)
    rng = np.random.default_rng(2)
    sizes = (3, 100, 40, 700, 1, 1500, 300)  # small and threaded batches, growing past the batch's capacity and back
    batches = [rng.uniform(obstacle_robot.lower, obstacle_robot.upper, size=(n, 3)) for n in sizes]
    results = [c.batch_pairs(Q) for Q in batches]  # every result is kept while later calls run
    for Q, D in zip(batches, results):
        assert D.shape == (len(Q), len(obstacle_robot.pairs))
        np.testing.assert_allclose(D[:5], [c.pair_distances(q) for q in Q[:5]], rtol=0, atol=1e-12)
        np.testing.assert_allclose(D[-1], c.pair_distances(Q[-1]), rtol=0, atol=1e-12)


def test_a_capped_pair_reads_its_cap_and_a_pair_below_its_cap_the_full_distance_bit_for_bit(obstacle_robot, robots):
    """Per configuration and pair, a cap (the distance sensor's cutoff in that simulation): the uncapped query's
    value d_p to the last bit where |d_p| is below the cap, else the cap with d_p's sign (MuJoCo clamps a
    penetration deeper than the cutoff to minus it); caps above distmax read distmax, and a later query without
    caps measures every pair in full again."""
    for robot in (obstacle_robot, robots["step_down"]):
        c = Clearance(robot, threads=1)
        rng = np.random.default_rng(6)
        Q = rng.uniform(robot.lower, robot.upper, size=(400, robot.dim))
        full = c.batch_pairs(Q)
        cap = rng.uniform(0.0, 1.5, size=full.shape) * full.max()
        capped = c.batch_pairs(Q, cap)
        cap = np.minimum(cap, c.distmax)
        below = np.abs(full) < cap * (1 - 1e-9)
        assert below.any() and (~below).any() and (full < -cap).any()
        assert np.array_equal(capped[below], full[below])
        assert np.array_equal(capped[~below], np.copysign(cap, full)[~below])
        assert np.array_equal(c.batch_pairs(Q), full)


def test_a_threads_first_batch_serves_every_size_up_to_first_batch_and_then_doubles(obstacle_robot, monkeypatch):
    """Making a Batch costs milliseconds (10-14 on a UR5e) whatever its size: one made at FIRST_BATCH serves the growth's
    and the corridor's usual calls; a larger call makes one of twice the size (or of the call's size, if more)."""
    made = []
    init = mujoco.batch.Batch.__init__

    def spy(self, model, nsim, *args, **kwargs):
        made.append(nsim)
        init(self, model, nsim, *args, **kwargs)

    monkeypatch.setattr(mujoco.batch.Batch, "__init__", spy)
    c = Clearance(obstacle_robot, threads=1)
    rng = np.random.default_rng(7)
    for n in (3, 128, 40, FIRST_BATCH, 1, FIRST_BATCH + 1, 5 * FIRST_BATCH):
        c.batch_pairs(rng.uniform(obstacle_robot.lower, obstacle_robot.upper, size=(n, 3)))
    assert made == [FIRST_BATCH, 2 * FIRST_BATCH, 5 * FIRST_BATCH]


def test_the_lean_sensor_model_gives_the_full_models_distances_bit_for_bit(obstacle_robot):
    c = Clearance(obstacle_robot)
    full = Clearance(obstacle_robot)
    full._batch_model = full._compile(lean=False)
    full._batch_model.opt.disableflags = c._batch_model.opt.disableflags
    assert c._batch_model.ngeom < full._batch_model.ngeom and c._batch_model.nu == 0
    Q = np.random.default_rng(3).uniform(obstacle_robot.lower, obstacle_robot.upper, size=(500, 3))
    assert np.array_equal(c.batch_pairs(Q), full.batch_pairs(Q))


# A two-link arm whose tip's only geom collides with nothing: without it the tip, which moves, would have no mass.
MASSLESS_TIP_ARM = """<mujoco><worldbody>
      <geom name="floor" type="plane" size="2 2 0.1"/><geom name="wall" type="box" pos="0.5 0 0.3" size="0.05 0.3 0.3"/>
      <body name="link1" pos="0 0 0.3"><joint name="j1" type="hinge" axis="0 0 1" range="-1 1"/>
        <geom name="arm" type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
        <body name="tip" pos="0.3 0 0"><joint name="j2" type="hinge" axis="0 0 1" range="-1 1"/>
          <geom name="marker" type="sphere" size="0.01" contype="0" conaffinity="0"/></body></body>
    </worldbody>"""


def test_a_model_that_needs_its_other_geoms_keeps_them_in_the_sensor_model(tmp_path):
    # The tip's only geom collides with nothing: without it the tip, which moves, would have no mass.
    (tmp_path / "r.xml").write_text(MASSLESS_TIP_ARM + "</mujoco>")
    robot = RobotModel.from_xml(tmp_path / "r.xml")
    c = Clearance(robot)
    assert c._batch_model.ngeom == robot.model.ngeom
    Q = np.array([[0.0, 0.0], [0.9, -0.5]])
    np.testing.assert_allclose(c.batch_pairs(Q)[:, 0], [c.pair_distances(q)[0] for q in Q], rtol=0, atol=1e-12)


def test_a_models_own_sensors_do_not_take_the_place_of_the_distances(tmp_path):
    """A model that keeps every element in its sensor model (the tip's mass is in a geom of no pair) and has
    sensors of its own: those come first in sensordata, the distance sensors after them, and the batch reads
    the distances, equal to the one-by-one queries (the joint angles it would read first are not)."""
    (tmp_path / "r.xml").write_text(MASSLESS_TIP_ARM + """
    <sensor><jointpos joint="j1"/><jointpos joint="j2"/><jointpos joint="j1"/></sensor></mujoco>""")
    robot = RobotModel.from_xml(tmp_path / "r.xml")
    c = Clearance(robot)
    frames = 2 + 4 if c._capsule_box is not None else 0  # a capsule/box pair's poses (capsule_box guard): 2 + 4 sensors
    assert c._batch_model.nsensor == 3 + frames + len(robot.pairs)
    Q = np.array([[0.0, 0.0], [0.9, -0.5], [-0.7, 0.3]])
    np.testing.assert_allclose(c.batch_pairs(Q), [c.pair_distances(q) for q in Q], rtol=0, atol=1e-12)

@pytest.mark.parametrize(
    "q, message",
    [
        ([0.1, 0.2], "must be 3 numbers, one per configuration joint (hip_flexion, knee_flexion, hip_displacement), got 2"),
        ([[0.1, 0.2, 0.3]], "got an array of shape (1, 3)"),
        ([0.1, float("nan"), 0.3], "finite"),
        ([0.1, 0.2, 2.0], "q[2] (hip_displacement) = 2 is outside its bounds"),
        ([0.1, 0.2, -0.3], "hip_displacement"),
        ([0.1, -0.1, 0.3], "knee_flexion"),
        ("abc", "sequence of 3 real numbers"),
        (np.array([True, False, True]), "sequence of 3 real numbers"),  # was planned as [1.0, 0.0, 1.0]
        (np.array([0.2, 0.3, 0.08]) + 1j, "sequence of 3 real numbers"),  # was planned as its real part (numpy only warned)
        (["0.2", "0.3", "0.08"], "sequence of 3 real numbers"),  # strings were parsed as numbers
        ([None, 0.3, 0.08], "sequence of 3 real numbers"),  # was "must be finite, got [nan, ...]"
    ],
)
def test_bad_configurations_are_refused_with_the_reason(obstacle_robot, q, message):
    with pytest.raises(ConfigurationError) as err:
        obstacle_robot.validate(q)
    assert message in str(err.value)
    assert isinstance(err.value, ValueError)


def test_missing_mjcf_names_the_file(tmp_path):
    missing = tmp_path / "nope.xml"
    with pytest.raises(ModelError, match="nope.xml"):
        RobotModel.from_xml(missing)


def test_malformed_mjcf_names_the_file(tmp_path):
    bad = tmp_path / "broken.xml"
    bad.write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(ModelError, match="broken.xml"):
        RobotModel.from_xml(bad)


def test_a_scene_without_obstacles_is_refused(tmp_path):
    scene = tmp_path / "empty.xml"
    scene.write_text(f'<mujoco><include file="{MODELS / "ortholeg.xml"}"/></mujoco>')
    with pytest.raises(ModelError, match="obstacles"):
        RobotModel.from_xml(scene)


def test_geom_margins_change_no_clearance_and_are_refused_only_when_their_contact_acts_beyond_delta(tmp_path):
    """mj_geomDistance and the distance sensors ignore geom margins (and gaps): a model whose collision geoms carry
    them (a menagerie-style default class with margin="0.01") has the same clearances as without (it was refused
    whatever delta, on the belief that MuJoCo subtracts margins). What a margin does change is MuJoCo's contact: it
    acts from margin - gap, pushing the geoms apart before they touch, so that distance must not exceed delta (a path
    delta from an obstacle would be pushed off in the replay): refused, naming the pair and the delta needed."""
    import mujoco

    def scene(margin: str):
        path = tmp_path / f"margin{margin}.xml"
        path.write_text(
            f'<mujoco><include file="{MODELS / "obstacle.xml"}"/>'
            '<worldbody><geom name="post" type="cylinder" size="0.03 0.2" pos="0.3 0 0.2"/>'
            '</worldbody></mujoco>'
        )
        spec = mujoco.MjSpec.from_file(str(path))
        for g in spec.geoms:
            g.margin, g.gap = float(margin), 0.005
        robot = RobotModel.from_spec(spec, path)
        assert all(robot.model.geom_margin[g] == float(margin) for g in robot.pairs.ravel())
        return robot

    plain, padded = scene("0"), scene("0.02")
    Q = np.random.default_rng(0).uniform(plain.lower, plain.upper, size=(20, plain.dim))
    a, b = Clearance(plain), Clearance(padded)
    try:
        np.testing.assert_array_equal(a.batch_pairs(Q), b.batch_pairs(Q))
        np.testing.assert_array_equal(a.pair_distances(Q[0]), b.pair_distances(Q[0]))
    finally:
        a.close()
        b.close()
    plain.check_margins(0.005)
    padded.check_margins(0.015)  # margin 0.02 less gap 0.005
    with pytest.raises(ConfigurationError, match=r"collision geoms \S+ and \S+ have a contact margin: MuJoCo's contact between "
                                                 r"them acts from 0.015 m .* raise delta to at least 0.015 m"):
        padded.check_margins(0.005)


def test_a_contact_margin_from_an_explicit_pair_or_the_override_is_refused_naming_where_it_is_set(tmp_path):
    """A <contact><pair margin="0.03"> between a link and a post (geoms without margins) was refused saying to set
    margin="0" "on those geoms", which have none: the message now points at the pair, or at <option o_margin> when
    the override flag sets it; a geom's own margin keeps "on those geoms"."""
    arm = ('<mujoco><compiler angle="radian"/>{option}<worldbody><geom name="post" type="cylinder" size=".04 .1" pos=".35 .2 0"{gm}/>'
           '<body name="a"><joint name="s" axis="0 0 1" range="-3 3"/><geom name="link" type="capsule" fromto="0 0 0 .25 0 0" size=".02"/>'
           '</body></worldbody>{pair}</mujoco>')
    scene = tmp_path / "pair.xml"
    cases = ((dict(option="", gm="", pair='<contact><pair geom1="post" geom2="link" margin="0.03"/></contact>'), "their <contact><pair>"),
             (dict(option='<option o_margin="0.03"><flag override="enable"/></option>', gm="", pair=""), "<option o_margin> \\(its override flag is on\\)"),
             (dict(option="", gm=' margin="0.03"', pair=""), "those geoms"))
    for fields, where in cases:
        scene.write_text(arm.format(**fields))
        with pytest.raises(ConfigurationError, match=r"collision geoms \S+ and \S+ have a contact margin: MuJoCo's contact between them "
                                                     rf"acts from 0.03 m .* set margin=\"0\" \(or a gap as large\) on {where}$"):
            RobotModel.from_xml(scene).check_margins(0.005)


@pytest.mark.parametrize("flag", ["contact", "constraint"])
def test_geom_margins_are_accepted_when_the_model_disables_contact_forces(tmp_path, flag):
    """A model with <flag contact="disable"/> (no collision detection) or constraint="disable" (contacts found, no
    force) has no contact that could push the arm off its path, whatever its margins: it was refused as if it had."""
    scene = tmp_path / "nocontact.xml"
    scene.write_text(
        f'<mujoco><include file="{MODELS / "obstacle.xml"}"/><option><flag {flag}="disable"/></option>'
        '<worldbody><geom name="post" type="cylinder" size="0.03 0.2" pos="0.3 0 0.2" margin="0.05"/></worldbody></mujoco>'
    )
    robot = RobotModel.from_xml(scene)
    assert robot.contact_reach == ()
    robot.check_margins(0.005)


def test_a_height_field_obstacle_is_refused_naming_it(tmp_path):
    """MuJoCo's distance sensors do not support height fields: refused (ModelError, exit 2) before any distance query,
    instead of MuJoCo's compile error for the distance sensors (an internal error, exit 1)."""
    scene = tmp_path / "hfield.xml"
    scene.write_text(
        f'<mujoco><include file="{MODELS / "ortholeg.xml"}"/>'
        '<asset><hfield name="terrain" nrow="3" ncol="3" elevation="0 0 0 0 1 0 0 0 0" size="0.5 0.5 0.1 0.05"/></asset>'
        '<worldbody><geom name="hill" type="hfield" hfield="terrain" pos="0.6 0 0"/></worldbody></mujoco>'
    )
    with pytest.raises(ModelError, match=r"\['hill'\] are height fields"):
        RobotModel.from_xml(scene)


def test_a_flex_that_can_collide_is_refused_naming_it_and_one_that_cannot_is_not(tmp_path):
    """A pinned cloth (<flexcomp>, contype 1) hung across an arm's sweep was not seen at all: MuJoCo's distance queries
    (the planner's, and the checkers') measure geoms, not flexes, so `foam-mj bubble` read 0.109 m of clearance with the
    arm through the cloth and a plan would pass through it while MuJoCo's simulation collides with it. A flex that can
    collide is now refused as a height field is (exit 2, naming it); one with contype = conaffinity = 0 is visual only."""
    def scene(bits: str):
        p = tmp_path / f"flex{bits.count('0')}.xml"
        p.write_text(
            '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
            '<flexcomp name="cloth" type="grid" count="3 3 1" spacing=".15 .15 .1" pos=".45 0 .15" dim="2" radius=".01">'
            f'<pin id="0 1 2 3 4 5 6 7 8"/><contact {bits}/></flexcomp>'
            '<body pos="0 0 .5"><joint name="j1" axis="0 1 0" range="-100 100"/><geom type="capsule" fromto="0 0 0 .6 0 0" size=".03"/>'
            '</body></worldbody></mujoco>')
        return p

    with pytest.raises(ModelError, match=r"flex\(es\) \['cloth'\] can collide .* do not measure flexes"):
        RobotModel.from_xml(scene('contype="1" conaffinity="1"'))
    assert RobotModel.from_xml(scene('contype="0" conaffinity="0"')).dim == 1


def test_an_obstacle_in_another_collision_group_is_still_checked(tmp_path):
    """MuJoCo's contype/conaffinity bits and <exclude> keep a box from colliding with the arm, but the box is
    in the way all the same, and `foam-mj verify` and MuJoCo-only checkers count it: the planner checks it.
    Robot/robot pairs keep MuJoCo's filter (the excluded links stay unchecked)."""
    scene = tmp_path / "groups.xml"
    scene.write_text(
        '<mujoco><worldbody>'
        '<geom name="ghost" type="box" size="0.05 0.05 0.05" pos="0.3 0.2 0" contype="2" conaffinity="2"/>'
        '<body name="shelf" pos="0.3 -0.2 0"><geom name="shelf" type="box" size="0.05 0.05 0.05"/></body>'
        '<body name="l1"><joint name="a" axis="0 0 1" range="-90 90"/>'
        '<geom name="l1" type="capsule" fromto="0.05 0 0 0.4 0 0" size="0.02" contype="1" conaffinity="1"/>'
        '<body name="l2" pos="0.45 0 0"><joint name="b" axis="0 0 1" range="-170 170"/>'
        '<geom name="l2" type="capsule" fromto="0.05 0 0 0.3 0 0" size="0.02"/>'
        '<body name="l3" pos="0.35 0 0"><joint name="c" axis="0 0 1" range="-170 170"/>'
        '<geom name="l3" type="capsule" fromto="0.05 0 0 0.3 0 0" size="0.02"/></body></body></body>'
        '</worldbody><contact><exclude body1="l1" body2="shelf"/><exclude body1="l1" body2="l3"/></contact></mujoco>'
    )
    robot = RobotModel.from_xml(scene)
    names = {(robot.geom_name(a), robot.geom_name(b)) for a, b in robot.pairs}
    assert {("l1", "ghost"), ("l1", "shelf"), ("l2", "ghost"), ("l3", "shelf")} <= names
    assert ("l1", "l3") not in names and ("l3", "l1") not in names
    clearance = Clearance(robot)
    try:
        through = clearance.pairwise(np.radians([34, 0, 0]))  # l1 through the ghost box
        assert through[("l1", "ghost")] < 0
        assert clearance.pairwise(np.radians([-34, 0, 0]))[("l1", "shelf")] < 0  # and through the shelf
    finally:
        clearance.close()


def test_an_equality_that_ties_a_configuration_joint_to_other_motion_is_refused_naming_it(tmp_path):
    """A mimic joint (<equality><joint>) or a closed loop (<connect> on a moved body) would make MuJoCo, and the robot,
    move otherwise than the planner, which moves each configuration joint on its own: refused, naming the constraint.
    An inactive one, one between joints outside the configuration, or a weld of a mocap obstacle is fine."""
    arm = (
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
        '<body name="b1" pos="0 0 .5"><joint name="a" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<body name="b2" pos=".3 0 0"><joint name="b" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<body name="b3" pos=".3 0 0"><joint name="c" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .2 0 0" size=".02"/>'
        '</body></body></body><body name="mocap" mocap="true" pos="1 0 1"><geom type="box" size=".05 .05 .05"/></body>'
        '<body name="loose" pos="1 1 1"><freejoint/><geom type="box" size=".05 .05 .05"/></body></worldbody>{eq}</mujoco>'
    )

    def load(eq: str, joints=None) -> RobotModel:
        scene = tmp_path / "arm.xml"
        scene.write_text(arm.replace("{eq}", eq))
        return RobotModel.from_xml(scene, joints=joints)

    mimic = '<equality><joint name="mimic" joint1="c" joint2="b"/></equality>'
    with pytest.raises(ModelError, match=r"equality constraint 'mimic' \(a <joint> coupling of c to b\) ties configuration joints b, c to other motion"):
        load(mimic, joints=["a", "b", "c"])
    with pytest.raises(ModelError, match=r"'loop' \(a <connect> between b3 and the world\) ties configuration joints a, b, c to"):  # it ties every joint
        load('<equality><connect name="loop" body1="b3" body2="world" anchor="0 0 0"/></equality>')
    with pytest.raises(ModelError, match=r"'loop' \(a <connect> between b3 and the world\) ties configuration joint a to"):
        load('<equality><connect name="loop" body1="b3" body2="world" anchor="0 0 0"/></equality>', joints=["a"])
    assert load(mimic, joints=["a"]).dim == 1  # b and c held where they are: the constraint holds too
    assert load(mimic.replace('joint2="b"', 'joint2="b" active="false"')).dim == 3
    assert load('<equality><weld body1="mocap" body2="loose"/></equality>').dim == 3


def test_the_default_configuration_holds_the_joints_an_equality_ties_to_other_motion(tmp_path):
    """MuJoCo Menagerie's Panda couples its two finger slides (<equality><joint>): `plan --mjcf panda.xml` with seven
    values per end point was refused, as the default configuration (every limited hinge and slide) took the fingers
    too. The default now leaves out the joints an equality ties to other motion, held at their pose like any joint
    left out (and says so), when joints remain; named joints are taken as named and refused as before."""
    from foam_mj.plan_command import held_by_equality_note

    arm = (
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
        '<body name="b1" pos="0 0 .5"><joint name="a" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<body name="b2" pos=".3 0 0"><joint name="b" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<body name="f1" pos=".3 0 .03"><joint name="s1" type="slide" axis="0 0 1" range="0 .04"/><geom type="box" size=".01 .01 .01"/></body>'
        '<body name="f2" pos=".3 0 -.03"><joint name="s2" type="slide" axis="0 0 -1" range="0 .04"/><geom type="box" size=".01 .01 .01"/></body>'
        '</body></body></worldbody><equality><joint name="fingers" joint1="s1" joint2="s2"/></equality></mujoco>'
    )
    scene = tmp_path / "gripper_arm.xml"
    scene.write_text(arm)
    robot = RobotModel.from_xml(scene)
    assert robot.config.joint_names == ("a", "b")
    assert robot.held_by_equality == {"fingers": ["s1", "s2"]}
    assert held_by_equality_note(robot) == (
        "note: s1, s2 held at their pose, not planned: equality constraint 'fingers' (a <joint> coupling of s1 to s2) ties them to other motion "
        "(the planner moves each joint on its own and would not follow it)")
    with pytest.raises(ConfigurationError, match=r"must be 2 numbers, one per configuration joint \(a, b\), got 4; not configuration "
                       r"joints \(tied to other motion by equality constraint 'fingers' \(a <joint> coupling of s1 to s2\), .*\): s1, s2"):
        robot.validate([0, 0, 0, 0])
    with pytest.raises(ModelError, match=r"'fingers' \(a <joint> coupling of s1 to s2\) ties configuration joints s1, s2 to"):
        RobotModel.from_xml(scene, joints=["a", "b", "s1", "s2"])
    assert RobotModel.from_xml(scene, joints=["a", "b"]).held_by_equality == {}
    with pytest.raises(ModelError, match=r"'fingers' \(a <joint> coupling of s1 to s2\) ties configuration joints s1, s2 to"):  # meant to be planned
        RobotModel.from_xml(scene, normalize={"s1": [1.0]})


def test_the_note_on_one_joint_held_by_an_equality_speaks_of_it_in_the_singular(tmp_path):
    """A single joint left out for an equality (a wrist slide tied to an unlimited joint) was "held at their pose ...
    ties them"; one joint is "held at its pose ... ties it"."""
    from foam_mj.plan_command import held_by_equality_note

    scene = tmp_path / "one_tied.xml"
    scene.write_text(
        '<mujoco><compiler angle="radian"/><worldbody><geom name="wall" type="box" pos="0 .5 .5" size=".05 .05 .3"/>'
        '<body pos="0 0 .5"><joint name="j1" axis="0 0 1" range="-1 1"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".03"/>'
        '<body pos=".3 0 0"><joint name="j2" axis="0 0 1" range="-1 1"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".03"/>'
        '<body pos=".3 0 0"><joint name="j3" axis="0 0 1"/><geom type="sphere" size=".03"/></body></body></body></worldbody>'
        '<equality><joint name="tie" joint1="j2" joint2="j3"/></equality></mujoco>')
    robot = RobotModel.from_xml(scene)
    assert robot.held_by_equality == {"tie": ["j2"]}
    assert held_by_equality_note(robot) == (
        "note: j2 held at its pose, not planned: equality constraint 'tie' (a <joint> coupling of j2 to j3) ties it to other motion "
        "(the planner moves each joint on its own and would not follow it)")


def test_joints_held_by_a_chain_of_equalities_are_noted_once(tmp_path):
    """The Stretch's telescoping arm, four slides chained by three <joint> couplings, and its gripper, two fingers each
    coupled to one slide, printed five notes, naming three joints twice; constraints that share a joint are one note,
    the joints in model order."""
    from foam_mj.plan_command import held_by_equality_note

    slides = "".join(f'<body name="t{i}" pos="0 0 0"><joint name="l{i}" type="slide" axis="1 0 0" range="0 .1"/>'
                     f'<geom type="box" size=".02 .02 .02" pos=".1 0 0"/>' for i in range(4)) + "</body>" * 4
    scene = tmp_path / "telescope.xml"
    scene.write_text(
        '<mujoco><compiler angle="radian"/><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
        f'<body name="mast" pos="0 0 .5"><joint name="lift" type="slide" axis="0 0 1" range="0 .3"/><geom type="box" size=".03 .03 .03"/>{slides}</body>'
        '</worldbody><equality><joint joint1="l3" joint2="l2"/><joint name="mid" joint1="l1" joint2="l2"/><joint joint1="l1" joint2="l0"/>'
        '</equality></mujoco>')
    robot = RobotModel.from_xml(scene)
    assert robot.config.joint_names == ("lift",)
    assert held_by_equality_note(robot) == (
        "note: l0, l1, l2, l3 held at their pose, not planned: equality constraints 'equality 0' (a <joint> coupling of l3 to l2), "
        "'mid' (a <joint> coupling of l1 to l2), 'equality 2' (a <joint> coupling of l1 to l0) tie them to other motion "
        "(the planner moves each joint on its own and would not follow them)")


def test_a_closed_loop_below_every_configuration_joint_is_not_a_coupling(tmp_path):
    """A gripper's four-bar linkage at the end of an arm (a <connect> between two finger links, as on the xArm7 of
    MuJoCo Menagerie) was refused as tying the arm's joints to other motion: the arm moves the whole loop as one
    piece, so the constraint holds along any path as it does at the held pose. A loop, or a tendon coupling, that a
    configuration joint opens or closes (a finger joint planned too, a loop from the gripper to the world) is refused."""
    arm = (
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
        '<body name="b1" pos="0 0 .5"><joint name="a" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<body name="b2" pos=".3 0 0"><joint name="b" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<body name="f1" pos=".3 0 .03"><joint name="g1" axis="0 1 0" range="-30 30"/><geom type="capsule" fromto="0 0 0 .1 0 0" size=".01"/>'
        '<site name="s1" pos=".1 0 0"/></body>'
        '<body name="f2" pos=".3 0 -.03"><joint name="g2" axis="0 1 0" range="-30 30"/><geom type="capsule" fromto="0 0 0 .1 0 0" size=".01"/>'
        '<site name="s2" pos=".1 0 0"/></body>'
        '</body></body></worldbody>'
        '<tendon><spatial name="span"><site site="s1"/><site site="s2"/></spatial></tendon>{eq}</mujoco>'
    )

    def load(eq: str, joints) -> RobotModel:
        scene = tmp_path / "gripper.xml"
        scene.write_text(arm.replace("{eq}", eq))
        return RobotModel.from_xml(scene, joints=joints)

    loop = '<equality><connect name="linkage" body1="f1" body2="f2" anchor=".1 0 0"/></equality>'
    assert load(loop, ["a", "b"]).dim == 2
    assert load('<equality><tendon name="tied" tendon1="span"/></equality>', ["a", "b"]).dim == 2
    with pytest.raises(ModelError, match=r"'linkage' \(a <connect> between f1 and f2\) ties configuration joint g1 to"):
        load(loop, ["a", "b", "g1"])
    with pytest.raises(ModelError, match=r"'tied' \(a <tendon> held at a fixed value: span\) ties configuration joint g2 to"):
        load('<equality><tendon name="tied" tendon1="span"/></equality>', ["a", "g2"])
    with pytest.raises(ModelError, match=r"'anchored' \(a <connect> between f1 and the world\) ties configuration joint a to"):
        load('<equality><connect name="anchored" body1="f1" body2="world" anchor=".1 0 0"/></equality>', ["a"])


def test_a_refused_coupling_names_the_unnamed_constraint_and_only_the_joints_it_ties(tmp_path):
    """MuJoCo Menagerie's welds and mimic joints are mostly unnamed: the refusal and the notes said "equality
    constraint 'equality 0'", which the MJCF does not contain, and listed every configuration joint (j1, j2) though
    the <joint> coupling ties j2 and j3 only, sending the user to plan without j1. They now say what the constraint
    is and joins, and name only the joints it ties; a weld of a mocap body to a link (the SO-ARM100's scene) reads as
    one."""
    scene = tmp_path / "coupled.xml"
    scene.write_text(
        '<mujoco><compiler angle="radian"/><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
        '<body name="target" mocap="true" pos="1 0 1"/>'
        '<body name="l1" pos="0 0 .3"><joint name="j1" axis="0 0 1" range="-3 3"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".03"/>'
        '<body name="l2" pos=".3 0 0"><joint name="j2" axis="0 1 0" range="-1 1"/><geom type="capsule" fromto="0 0 0 .2 0 0" size=".03"/>'
        '<body name="l3" pos=".2 0 0"><joint name="j3" axis="0 1 0" range="-1 1"/><geom type="capsule" fromto="0 0 0 .1 0 0" size=".02"/>'
        '</body></body></body></worldbody>'
        '<equality><joint joint1="j3" joint2="j2" polycoef="0 .5 0 0 0"/><weld body1="target" body2="l3" active="false"/></equality></mujoco>')
    with pytest.raises(ModelError) as refused:
        RobotModel.from_xml(scene, joints=["j1", "j2"])
    assert ("equality constraint 'equality 0' (a <joint> coupling of j3 to j2) ties configuration joint j2 to other motion"
            in str(refused.value))
    assert "j1" not in str(refused.value)
    scene.write_text(scene.read_text().replace(' active="false"', ""))
    with pytest.raises(ModelError, match=r"equality constraint 'equality 1' \(a <weld> between target and l3\) ties "
                       r"configuration joint j1 to other motion .* deactivate it \(active=\"false\"\)"):
        RobotModel.from_xml(scene, joints=["j1"])


def test_the_constructors_name_an_argument_of_the_wrong_type(obstacle_robot):
    import mujoco

    with pytest.raises(TypeError, match="takes the path of an MJCF file, got MjModel.*cannot be turned back into a spec"):
        RobotModel.from_xml(obstacle_robot.model)
    with pytest.raises(TypeError, match=r"got MjSpec \(for a mujoco.MjSpec use RobotModel.from_spec"):
        RobotModel.from_xml(obstacle_robot.spec_copy())
    with pytest.raises(TypeError, match="from_spec takes a mujoco.MjSpec, got PosixPath"):
        RobotModel.from_spec(MODELS / "obstacle.xml", MODELS / "obstacle.xml")
    # A single name was read letter by letter ("configuration joint 'k' is not in the model").
    with pytest.raises(TypeError, match=r"`joints` must be a sequence of joint names, got the string 'knee_flexion'"):
        RobotModel.from_xml(MODELS / "obstacle.xml", joints="knee_flexion")
    # An integer name was mj_name2id's TypeError listing its overloads; "no" is truthy and kept self-collision on.
    with pytest.raises(TypeError, match=r"`robot_root` must be a name \(a string\) or None, got 5"):
        RobotModel.from_xml(MODELS / "obstacle.xml", robot_root=5)
    with pytest.raises(TypeError, match=r"`keyframe` must be a name \(a string\) or None, got 3"):
        RobotModel.from_xml(MODELS / "obstacle.xml", keyframe=3)
    with pytest.raises(TypeError, match=r"`self_collision` must be True or False, got 'no'"):
        RobotModel.from_xml(MODELS / "obstacle.xml", self_collision="no")
    assert isinstance(obstacle_robot.spec_copy(), mujoco.MjSpec)


def test_joint_names_and_normalizations_of_the_wrong_type_are_named_before_mujoco_sees_them():
    """``joints`` and ``normalize`` from Python, not through a scenario's checks: a None joint name reached
    ``mj_name2id``, which dereferences it (the interpreter died of a segmentation fault); an integer was its TypeError
    listing overloads; a word as a normalization was numpy's "could not convert string to float", a list of joint names
    dict()'s "update sequence element", and True a span of 1."""
    import subprocess
    import sys

    import mujoco

    xml = str(MODELS / "obstacle.xml")
    code = ("from foam_mj.model import RobotModel\ntry:\n    RobotModel.from_xml(%r, joints=['knee_flexion', None])\n"
            "except TypeError as e:\n    print(e)\n" % xml)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, f"the process died (return code {run.returncode}): {run.stderr[-300:]}"
    assert run.stdout.strip() == "`joints` must be joint names (strings), got None at position 1"
    with pytest.raises(TypeError, match=r"^`joints` must be joint names \(strings\), got 3 at position 0$"):
        RobotModel.from_xml(xml, joints=[3])
    with pytest.raises(TypeError, match=r"^`normalize` must be a mapping joint name -> span or \[qpos_lo, qpos_hi, span\], got list$"):
        RobotModel.from_xml(xml, normalize=["hip_displacement"])
    for value, shown in (("abc", "'abc'"), ([0.0, "x", 1.0], r"\[0.0, 'x', 1.0\]"), (True, "True"), (None, "None")):
        with pytest.raises(TypeError, match=rf"^`normalize\['hip_displacement'\]` must be a number \(span\) or 3 numbers "
                                            rf"\(qpos_lo, qpos_hi, span\), got {shown}$"):
            RobotModel.from_xml(xml, normalize={"hip_displacement": value})
    with pytest.raises(TypeError, match=r"^`normalize` keys must be joint names \(strings\), got 0$"):
        RobotModel.from_xml(xml, normalize={0: 1.0})
    with pytest.raises(TypeError, match=r"^`path` \(the MJCF file the spec came from; .*\) must be a path, got None$"):
        RobotModel.from_spec(mujoco.MjSpec.from_file(xml), None)
    # what is right stays right: a number or a list, numpy numbers, a tuple of names
    a = RobotModel.from_xml(xml, joints=("hip_flexion", "hip_displacement"), normalize={"hip_displacement": np.float64(1.5)})
    b = RobotModel.from_xml(xml, joints=["hip_flexion", "hip_displacement"], normalize={"hip_displacement": [1.5]})
    np.testing.assert_array_equal(a.upper, b.upper)
    assert a.upper[1] == 1.5


def test_the_configuration_map_says_when_it_is_given_qpos_for_q_or_q_for_qpos(tmp_path):
    """An arm on a floating base: q holds its 2 hinges, qpos 9 numbers (7 of the free joint). qpos given to to_qpos was
    numpy's "operands could not be broadcast together with shapes (2,) (9,)", q given to to_q "index 7 is out of bounds
    for axis 0 with size 2": neither named q, qpos or the method that was meant."""
    scene = tmp_path / "floating.xml"
    scene.write_text(
        '<mujoco><worldbody><geom name="floor" type="plane" size="3 3 0.1"/><body name="base" pos="0 0 0.5"><freejoint/>'
        '<geom type="box" size="0.1 0.1 0.1"/><body pos="0 0 0.1"><joint name="s1" axis="0 1 0" range="-90 90"/>'
        '<geom type="capsule" fromto="0 0 0.02 0 0 0.3" size="0.03"/><body pos="0 0 0.3"><joint name="s2" axis="0 1 0" '
        'range="-150 150"/><geom type="capsule" fromto="0 0 0.02 0 0 0.25" size="0.025"/></body></body></body>'
        '</worldbody></mujoco>')
    cfg = RobotModel.from_xml(scene).config
    q = np.array([[0.1, -0.2], [0.3, 0.4]])
    qpos = cfg.to_qpos(q)
    assert qpos.shape == (2, 9)
    np.testing.assert_allclose(cfg.to_q(qpos), q)
    with pytest.raises(ConfigurationError, match=r"^to_qpos takes configurations q of shape \(2,\) or \(N, 2\) \(n = 2 configuration "
                                                 r"joints: s1, s2; nq = 9 qpos entries\), got shape \(2, 9\): qpos's width; to_q\(\) "
                                                 r"maps that one$"):
        cfg.to_qpos(qpos)
    with pytest.raises(ConfigurationError, match=r"^to_q takes qpos rows of shape \(9,\) or \(N, 9\) .*, got shape \(2,\): q's width; "
                                                 r"to_qpos\(\) maps that one$"):
        cfg.to_q(q[0])
    with pytest.raises(ConfigurationError, match=r"got shape \(3,\)$"):
        cfg.to_qpos([0.1, 0.2, 0.3])


def test_configurations_given_to_the_model_are_validated_with_the_reason(obstacle_robot):
    with pytest.raises(ConfigurationError, match=r"q must be 3 numbers, one per configuration joint \(hip_flexion, knee_flexion, "
                                                 r"hip_displacement\), got 2$"):
        obstacle_robot.in_collision([0.2, 0.3])  # was numpy's "operands could not be broadcast", then "must have shape (3,)"
    with pytest.raises(ConfigurationError, match=r"got an array of shape \(2, 3\)$"):
        obstacle_robot.validate([[0.2, 0.3, 0.08]] * 2)
    with pytest.raises(ConfigurationError, match=r"Q must be an \(N, 3\) array of real numbers"):
        obstacle_robot.validate_batch([["a", 0.3, 0.08]])  # was numpy's "could not convert string to float"
    with pytest.raises(ConfigurationError, match=r"Q must be an \(N, 3\) array of real numbers"):
        obstacle_robot.validate_batch(np.ones((2, 3), dtype=bool))
    from fractions import Fraction

    np.testing.assert_array_equal(obstacle_robot.validate([Fraction(1, 5), np.float32(0.25), 0]), [0.2, 0.25, 0.0])


def test_a_limited_tendon_that_can_bind_within_the_joint_ranges_is_refused_naming_it(tmp_path):
    """MuJoCo holds a limited tendon within its range as it holds a joint within its own: a fixed tendon coupling
    shoulder + elbow, or a spatial leash from the world to the hand, makes part of the joint box unreachable. The
    planner keeps each joint within its own range only, so its path could leave the tendon's range (the time law then
    failed with 'gravity alone needs 1578 N m', the limit's constraint force): refused before planning, naming it.
    A limit the joint ranges can never reach, an unlimited tendon, or one over joints outside the configuration is fine."""
    arm = (
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/><site name="anchor" pos="0 0 1"/>'
        '<body name="b1" pos="0 0 .5"><joint name="a" axis="0 1 0" range="-90 90"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<body name="b2" pos=".3 0 0"><joint name="b" axis="0 1 0" range="0 120"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<site name="tip" pos=".3 0 0"/></body></body></worldbody><tendon>{tendon}</tendon></mujoco>'
    )

    def load(tendon: str, joints=None) -> RobotModel:
        scene = tmp_path / "arm.xml"
        scene.write_text(arm.replace("{tendon}", tendon))
        return RobotModel.from_xml(scene, joints=joints)

    coupling = '<fixed name="coupling" limited="true" range="-0.5 1.5"><joint joint="a" coef="1"/><joint joint="b" coef="1"/></fixed>'
    # a + b spans [-pi/2, pi/2 + 2 pi/3] within the ranges (degrees, converted by MuJoCo)
    with pytest.raises(ModelError, match=r"limited tendon\(s\) 'coupling' \(1 a \+ 1 b ranges over \[-1.5708, 3.66519\] .*"
                                         r"its range is \[-0.5, 1.5\]\).*limited=\"false\""):
        load(coupling)
    with pytest.raises(ModelError, match=r"'coupling' \(1 a \+ 1 b \(held at 0\) ranges over \[-1.5708, 1.5708\]"):
        load(coupling, joints=["a"])  # b held at 0: a alone still leaves [-0.5, 1.5]
    assert load(coupling.replace('range="-0.5 1.5"', 'range="-1.6 3.7"')).dim == 2  # never reached
    assert load(coupling.replace('limited="true"', 'limited="false"')).dim == 2
    leash = '<spatial name="leash" limited="true" range="0 0.8"><site site="anchor"/><site site="tip"/></spatial>'
    with pytest.raises(ModelError, match=r"'leash' \(a spatial tendon of length 1\.\d+ at qpos .* of a, b, within the joint ranges"):
        load(leash)
    assert load(leash.replace('range="0 0.8"', 'range="0 1.2"')).dim == 2  # the hand is never 1.2 m from the anchor


def test_a_start_out_of_bounds_says_radians_when_degrees_were_meant_and_a_wrong_length_names_unlimited_joints(tmp_path):
    """A user of an MJCF in degrees (MuJoCo's default) who gives --start in degrees read only 'outside its bounds
    [-1.74533, 1.74533]'; a user whose shoulder has no range (so it is not a coordinate) read 'must have shape (1,)'.
    Both messages now say why."""
    scene = tmp_path / "arm.xml"
    scene.write_text(
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
        '<body pos="0 0 .5"><joint name="shoulder" axis="0 1 0" {range}/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '<body pos=".3 0 0"><joint name="elbow" axis="0 1 0" range="-150 150"/><geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>'
        '</body></body></worldbody></mujoco>'.replace("{range}", 'range="-100 100"')
    )
    robot = RobotModel.from_xml(scene)
    with pytest.raises(ConfigurationError, match=r"q\[0\] \(shoulder\) = 17 is outside its bounds \[-1.74533, 1.74533\] radians "
                                                 r"\(hinge angles are radians .* 17 degrees is 0.296706\)"):
        robot.validate([17, 1.0])
    with pytest.raises(ConfigurationError, match=r"= 300 is outside its bounds \[-1.74533, 1.74533\]$"):
        robot.validate([300, 1.0])  # not an angle in degrees either: no hint
    # A radian value just past a limit (a goal 0.2 rad beyond it) is no angle in degrees: the hint ("1.94478 degrees is
    # 0.0339") read as if the user had typed degrees, on models written in radians too.
    with pytest.raises(ConfigurationError, match=r"= 1.94533 is outside its bounds \[-1.74533, 1.74533\]$"):
        robot.validate([1.94533, 1.0])
    # A range written in radians in an MJCF without <compiler angle="radian"/> is compiled as degrees ([-3, 3] degrees:
    # +-0.052 rad), and --start -1 read only "outside its bounds [-0.0523599, 0.0523599]", as if the bound were meant.
    scene.write_text(scene.read_text().replace('range="-100 100"', 'range="-3 3"'))
    with pytest.raises(ConfigurationError, match=r"q\[0\] \(shoulder\) = -1 is outside its bounds \[-0.0523599, 0.0523599\] radians "
                                                 r"\(the MJCF's range of hinge shoulder is \[-3, 3\], compiled as degrees: .* add "
                                                 r"<compiler angle=\"radian\"/> to the MJCF\)$"):
        RobotModel.from_xml(scene).validate([-1, 1.0])
    with pytest.raises(ConfigurationError, match=r"= 2.7 is outside its bounds \[-2.61799, 2.61799\]$"):
        RobotModel.from_xml(scene).validate([0.0, 2.7])  # the elbow's [-150, 150] degrees: meant as degrees, no hint
    scene.write_text(scene.read_text().replace('range="-3 3"', 'range="-100 100"'))
    scene.write_text(scene.read_text().replace('range="-100 100"', ""))
    with pytest.raises(ConfigurationError, match=r"must be 1 number, one per configuration joint \(elbow\), got 2; not configuration joints "
                                                 r"\(no range: held at qpos0\): shoulder$"):
        RobotModel.from_xml(scene).validate([0.3, 1.0])
    # A range that limited="false" switches off was listed as "no range", which the MJCF contradicts.
    scene.write_text(scene.read_text().replace('name="shoulder"', 'name="shoulder" range="-1 1" limited="false"', 1))
    with pytest.raises(ConfigurationError, match=r"not configuration joints \(no range: held at qpos0\): shoulder \(its range is not "
                                                 r"applied: limited=\"false\"\)$"):
        RobotModel.from_xml(scene).validate([0.3, 1.0])


def test_a_keyframe_places_the_mocap_obstacles_where_mujoco_puts_them_and_the_saved_scene_does_too(tmp_path):
    """MuJoCo loads a keyframe's mocap poses (mpos/mquat) into mjData.mocap_pos, but a distance query of qpos alone sees
    a mocap body at its MJCF pose: with keyframe "scene" placing a block across the arm's sweep, the planner swept the
    arm through it (25 mm deep at that pose) and both checkers, also reading qpos alone, said clean. The planned scene,
    and the one saved with a result (robot.xml), now carry the keyframe's pose; a keyframe that moves no mocap body
    changes nothing."""
    import mujoco

    from foam_mj.fingerprint import model_fingerprint

    scene = tmp_path / "arm.xml"
    scene.write_text(
        '<mujoco><worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
        '<body name="blocker" mocap="true" pos="2 0 2"><geom name="block" type="box" size=".05 .3 .05"/></body>'
        '<frame pos="1 0 0" euler="0 0 90"><body name="framed" mocap="true" pos="1 0 1" euler="0 30 0">'
        '<geom name="slab" type="box" size=".1 .1 .01"/></body></frame>'
        '<body pos="0 0 .5"><joint name="shoulder" axis="0 1 0" range="-100 100"/><geom name="arm" type="capsule" fromto="0 0 0 .6 0 0" size=".03"/>'
        '</body></worldbody><keyframe><key name="scene" qpos="0" mpos=".45 0 .5 -1 0 1" mquat="1 0 0 0 .9659 0 0 .2588"/>'
        '<key name="same" qpos="0.1"/></keyframe></mujoco>'
    )
    plain = RobotModel.from_xml(scene)
    placed = RobotModel.from_xml(scene, keyframe="scene")
    a, b = Clearance(plain), Clearance(placed)
    try:
        assert a.pairwise(np.zeros(1))[("arm", "block")] > 0.5
        assert b.pairwise(np.zeros(1))[("arm", "block")] < 0  # the arm through the block, where MuJoCo has it
    finally:
        a.close()
        b.close()
    saved = mujoco.MjModel.from_xml_string(placed.xml)
    assert model_fingerprint(saved) == model_fingerprint(placed.model)  # `foam-mj verify` accepts the saved scene
    np.testing.assert_allclose(saved.body_pos[1], [0.45, 0, 0.5])
    original = mujoco.MjModel.from_xml_path(str(scene))
    d, d0 = mujoco.MjData(placed.model), mujoco.MjData(original)
    mujoco.mj_resetDataKeyframe(original, d0, 0)
    mujoco.mj_kinematics(placed.model, d)
    mujoco.mj_kinematics(original, d0)
    np.testing.assert_allclose(d.geom_xpos, d0.geom_xpos, atol=1e-9)  # also the body in a rotated <frame>, with euler
    np.testing.assert_allclose(d.geom_xmat, d0.geom_xmat, atol=1e-6)
    same = RobotModel.from_xml(scene, keyframe="same")
    assert same.xml is None and same.config.qpos0[0] == 0.1


def test_a_collision_with_a_non_convex_mesh_says_that_mujoco_measures_its_hull(tmp_path):
    """MuJoCo measures distances to a mesh's convex hull: an arm whose hand sits in the notch of a U-shaped mesh reads
    'in collision, clearance -0.13 m', which looks wrong to the user who sees room there. The message now says why
    (and how to split the mesh); a convex mesh gets no such hint."""
    from foam_mj.errors import ScenarioError
    from foam_mj.scenarios import scenario_from_dict

    def box(c, h):
        return [[c[0] + sx * h[0], c[1] + sy * h[1], c[2] + sz * h[2]] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]

    u = box([0, 0, 0.05], [0.25, 0.1, 0.05]) + box([-0.2, 0, 0.3], [0.05, 0.1, 0.25]) + box([0.2, 0, 0.3], [0.05, 0.1, 0.25])
    verts = " ".join(f"{v:g}" for p in u for v in p)
    scene = tmp_path / "u.xml"
    scene.write_text(
        f'<mujoco><asset><mesh name="u" vertex="{verts}"/><mesh name="tet" vertex="0 0 0 .1 0 0 0 .1 0 0 0 .1"/></asset>'
        '<worldbody><geom name="notch" type="mesh" mesh="u" pos=".55 0 0"/><geom name="rock" type="mesh" mesh="tet" pos="-.5 0 0"/>'
        '<body pos="0 0 .4"><joint name="shoulder" axis="0 1 0" range="-90 60"/>'
        '<geom name="hand" type="capsule" fromto="0 0 0 .6 0 0" size=".02"/></body></worldbody></mujoco>'
    )
    robot = RobotModel.from_xml(scene)
    ids = {robot.geom_name(g): int(g) for g in range(robot.model.ngeom)}
    assert robot.hull_hint(ids["rock"], ids["hand"]) == ""
    assert robot.hull_hint(ids["notch"]).startswith("; notch is a non-convex mesh: MuJoCo measures distances to its convex hull")
    with pytest.raises(ScenarioError, match=r"'q_init' = \[0.0\] is in collision: .* between hand and notch .*; notch is a "
                                            r"non-convex mesh: MuJoCo measures distances to its convex hull, which fills notches"):
        scenario_from_dict({"scene": str(scene), "q_init": [0.0], "q_goal": [-1.0]}, tmp_path)


def test_collision_pairs_of_a_scene_of_many_static_obstacles_are_the_robot_against_each():
    """A study's scene of hundreds of boxes: the pairs were found by a Python loop over every geom pair (1.3 s for
    1,000 boxes, before any planning); geom against geom in numpy now. Static boxes never pair with each other."""
    import mujoco

    from foam_mj.geom_pairs import collision_pairs

    boxes = "".join(f'<geom type="box" size="0.05 0.05 0.05" pos="{0.2 * (i % 20)} {0.2 * (i // 20)} -1"/>' for i in range(500))
    m = mujoco.MjModel.from_xml_string(
        f'<mujoco><worldbody>{boxes}<body name="arm"><joint type="hinge"/><geom name="link" type="capsule" size="0.05" '
        'fromto="0 0 0 1 0 0"/><body><joint type="hinge"/><geom name="tip" type="sphere" size="0.05" pos="1 0 0"/>'
        '</body></body></worldbody><contact><exclude body1="world" body2="arm"/></contact></mujoco>'
    )
    link, tip = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("link", "tip"))
    assert collision_pairs(m) == [(g, tip) for g in range(500)]  # the link's pairs excluded; link/tip are parent and child


def test_a_robot_whose_geoms_are_all_visual_is_refused_saying_so(tmp_path):
    """An arm whose links take contype = conaffinity = 0 from a default class (a "visual" childclass on its first
    body) was refused with "no collision geom is attached to the robot", though the robot had geoms: the message now
    says they are visual only and how to make them collide; a robot without any geom keeps the short message."""
    scene = tmp_path / "visual_arm.xml"
    arm = ('<mujoco><compiler angle="radian"/><default><default class="vis"><geom contype="0" conaffinity="0"/></default></default>'
           '<worldbody><geom name="floor" type="plane" size="2 2 .1"/>'
           '<body name="l1" pos="0 0 .3" childclass="vis"><joint name="j1" axis="0 0 1" range="-2 2"/>{geoms}</body>'
           '</worldbody></mujoco>')
    scene.write_text(arm.replace("{geoms}", '<geom type="capsule" fromto="0 0 0 .3 0 0" size=".03"/><geom type="sphere" size=".05"/>'))
    with pytest.raises(ModelError, match=r"no collision geom is attached to the robot \(a body moved by a configuration joint\): its "
                                         r"2 geoms are all visual only \(contype = conaffinity = 0, maybe from a default class\): "
                                         r"give the collision ones contype=\"1\" conaffinity=\"1\"$"):
        RobotModel.from_xml(scene)
    scene.write_text(arm.replace("{geoms}", '<inertial pos="0 0 0" mass="1" diaginertia=".01 .01 .01"/>'))
    with pytest.raises(ModelError, match=r"no collision geom is attached to the robot \(a body moved by a configuration joint\)$"):
        RobotModel.from_xml(scene)


def _mesh_heavy_arm(folder, meshes=10, points=20_000):
    """A one-joint capsule arm beside a box post, carrying ``meshes`` visual meshes (OBJ point clouds of ``points``
    vertices each, as a scanned robot's visual meshes are heavy) and an unnamed collision geom; the scene's path."""
    rng = np.random.default_rng(0)
    for i in range(meshes):
        pts = rng.normal(size=(points, 3)) * 0.02
        (folder / f"v{i}.obj").write_text("".join(f"v {a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in pts))
    assets = "".join(f'<mesh name="v{i}" file="v{i}.obj"/>' for i in range(meshes))
    visuals = "".join(f'<geom type="mesh" mesh="v{i}" contype="0" conaffinity="0" pos="{0.03 * i} 0 0"/>' for i in range(meshes))
    path = folder / "arm.xml"
    path.write_text(f"""<mujoco><compiler angle="radian"/><asset>{assets}</asset><worldbody>
      <geom name="post" type="box" size="0.05 0.05 0.3" pos="0.6 0 0.3"/>
      <body name="link" pos="0 0 0.2"><joint name="j" axis="0 0 1" range="-2 2"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>{visuals}</body>
    </worldbody></mujoco>""")
    return path


def test_spec_copy_deletes_elements_as_fast_as_a_spec_never_compiled(tmp_path):
    # The lean distance model (foam_mj.clearance) deletes every geom of no checked pair from robot.spec_copy(); from a
    # spec that has been compiled (or a copy of one) MuJoCo deletes an element at a cost that grows with the scene's
    # mesh data: 12x a never-compiled spec's here, 8-14 ms a geom on MuJoCo Menagerie's Panda (1.7 s per distance model).
    import time

    from foam_mj.mjcf import load_spec

    path = _mesh_heavy_arm(tmp_path)
    robot = RobotModel.from_xml(path)

    def per_delete(make) -> float:
        best = np.inf
        for _ in range(3):
            spec = make()
            visual = [g for g in spec.geoms if g.contype == 0 and g.conaffinity == 0]
            t = time.process_time()
            for g in visual:
                spec.delete(g)
            best = min(best, (time.process_time() - t) / len(visual))
        return best

    fresh = per_delete(lambda: load_spec(path))
    assert per_delete(robot.spec_copy) < 3 * fresh + 2e-5
    # ... and it is the model's spec: the unnamed collision geom carries the name the model gave it.
    copy = robot.spec_copy()
    names = [mujoco.mj_id2name(robot.model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in range(robot.model.ngeom)]
    assert [g.name for g in copy.geoms] == names[1:] or [g.name for g in copy.geoms] == names
    assert copy.compile().ngeom == robot.model.ngeom


# A free block whose frame MuJoCo puts at its centre of mass (alignfree), which a heavy visual sphere 0.6 m away sets:
# a sensor model without that sphere would move the frame, and the full model's qpos would carry the block off its place.
ALIGNFREE_SCENE = """<mujoco><compiler alignfree="true" angle="radian"/><worldbody>
      <body name="arm" pos="0 0 0.5"><joint name="j" type="hinge" axis="0 0 1" range="-3 3"/>
        <geom name="link" type="capsule" fromto="0 0 0 1 0 0" size="0.03"/></body>
      <body name="loose" pos="0.8 0.3 0.5"><freejoint name="free"/>
        <geom name="block" type="box" size="0.05 0.05 0.05"/>
        <geom name="weight" type="sphere" size="0.1" pos="0 0.6 0" density="20000" contype="0" conaffinity="0"/></body>
    </worldbody></mujoco>"""


@settings(max_examples=40, deadline=None)
@given(q=st.floats(-3.0, 3.0))
def test_a_batch_reads_the_models_distance_where_dropping_geoms_would_move_a_free_bodys_frame(tmp_path_factory, q):
    """The batch's distances are the model's own where the lean sensor model would place a body elsewhere
    (``<compiler alignfree>``): before, the arm read 0.53 m clear of the block at q = 0.3, where it is 34 mm inside."""
    path = tmp_path_factory.getbasetemp() / "alignfree.xml"
    path.write_text(ALIGNFREE_SCENE)
    robot = RobotModel.from_xml(path)
    c = Clearance(robot)
    assert c.batch_pairs(np.array([[q], [0.3]]))[:, 0] == pytest.approx([c.pair_distances(np.array([q]))[0], c(np.array([0.3]))], abs=1e-12)
    assert c(np.array([0.3])) < 0  # the arm is inside the block there


def _sphere_mesh_scene(cap: str) -> str:
    """A 1-joint arm beside a 200-vertex unit-sphere mesh obstacle; ``cap``: its maxhullvert attribute (or none)."""
    points = np.random.default_rng(0).normal(size=(200, 3))
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    return f"""<mujoco><compiler angle="radian"/><asset><mesh name="ball" vertex="{' '.join(map(str, points.ravel()))}" {cap}/>
      </asset><worldbody><geom name="rock" type="mesh" mesh="ball" pos="2 0 0.5"/>
      <body pos="0 0 0.5"><joint name="j" type="hinge" axis="0 0 1" range="-3 3"/>
        <geom name="link" type="capsule" fromto="0 0 0 0.5 0 0" size="0.03"/></body></worldbody></mujoco>"""


@pytest.mark.parametrize("cap, refused", [("", False), ('maxhullvert="8"', True), ('maxhullvert="1000"', False)])
def test_a_mesh_whose_collision_hull_leaves_out_some_of_its_vertices_is_refused_by_name(tmp_path, cap, refused):
    """maxhullvert below the hull's vertex count makes MuJoCo collide a smaller hull (8 of 200 vertices: points 2 %
    inside the other 192 read up to 0.40 m apart); such a checked mesh geom is refused, naming it and the cap. A cap
    the hull does not reach changes nothing and loads."""
    (tmp_path / "r.xml").write_text(_sphere_mesh_scene(cap))
    if not refused:
        assert len(RobotModel.from_xml(tmp_path / "r.xml").pairs) == 1
        return
    with pytest.raises(ModelError, match=r"collision geom 'rock': its mesh 'ball' sets maxhullvert=\"8\", so MuJoCo collides a hull of 8 vertices that leaves 192 of its 200 vertices outside \(up to 0.4"):
        RobotModel.from_xml(tmp_path / "r.xml")


def test_loading_robots_from_several_threads_leaves_the_processs_warning_filters_alone():
    """A service that builds RobotModels in a thread pool found ('always', Warning) added for good to the front of
    warnings.filters (every warning of the whole application then shown at each call): each load held MuJoCo's
    warnings with warnings.catch_warnings, which saves and restores process-wide state, so overlapping loads restored
    each other's changed filters. 200 loads over 8 threads added it in every run before the fix."""
    import warnings
    from concurrent.futures import ThreadPoolExecutor

    RobotModel.from_xml(MODELS / "obstacle.xml")
    before, shown = list(warnings.filters), warnings.showwarning
    with ThreadPoolExecutor(8) as pool:
        dims = set(pool.map(lambda _: RobotModel.from_xml(MODELS / "obstacle.xml").dim, range(200)))
    assert dims == {3}
    assert warnings.filters == before and warnings.showwarning is shown
