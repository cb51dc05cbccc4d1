"""Tests for foam_mj.bubbles: the displacement bound rho and the certified bubble radius (paper 003 Eq. 4)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from foam_mj.bubbles import BubbleOracle, DisplacementBound

from conftest import SCENES

SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def test_rho_from_geometry_matches_hand_computation(obstacle_robot):
    bound = DisplacementBound.from_model(obstacle_robot)
    # Knee: farthest point of shank and foot from the knee axis is the toe's sole corner,
    # (0.216, -0.43 - 0.068) from the knee; hip: thigh length plus that (triangle inequality).
    knee = np.hypot(0.083 + 0.133, 0.43 + 0.068)
    np.testing.assert_allclose(bound.weights, [0.43 + knee, knee, 0.7 / (np.pi / 2)], atol=1e-9)
    assert bound.groups == ((0,), (1,), (2,))


def _geom_points(m, d, robot):
    """Every box corner and capsule end-cap extreme of the leg's collision geoms, in world coordinates."""
    pts = []
    for g in robot.robot_geoms:
        pos, mat, size = d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3), m.geom_size[g]
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            signs = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)])
            pts.append(pos + (signs * size) @ mat.T)
        else:  # capsule: points on the end spheres
            for s in (-1, 1):
                end = pos + s * size[1] * mat[:, 2]
                pts.append(end + size[0] * np.vstack([np.eye(3), -np.eye(3)]))
    return np.vstack(pts)


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_no_leg_point_moves_farther_than_the_bound(obstacle_robot, seed):
    """Paper 003 Eq. 4: along the segment q -> a, no point moves more than sum rho_j |a_j - q_j|."""
    rng = np.random.default_rng(seed)
    bound = DisplacementBound.from_model(obstacle_robot)
    m = obstacle_robot.model
    d = mujoco.MjData(m)
    q = rng.uniform(obstacle_robot.lower, obstacle_robot.upper)
    a = rng.uniform(obstacle_robot.lower, obstacle_robot.upper)
    p0 = _geom_points(m, obstacle_robot.set_configuration(q, d), obstacle_robot)
    worst = 0.0
    for s in np.linspace(0, 1, 11)[1:]:
        ps = _geom_points(m, obstacle_robot.set_configuration(q + s * (a - q), d), obstacle_robot)
        worst = max(worst, float(np.max(np.linalg.norm(ps - p0, axis=1))))
    assert worst <= float(bound(a - q)) + 1e-9


def _uniform_in_ball(rng, center, radius, count):
    u = rng.standard_normal((count, len(center)))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return center + u * radius * rng.random((count, 1)) ** (1 / len(center))


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), scene=st.sampled_from(SCENES))
def test_configurations_inside_a_bubble_never_collide(robots, oracles, checkers, seed, scene):
    """Thousands of points (150 bubbles x 30 points) checked with mj_collision, not the clearance code."""
    rng = np.random.default_rng(seed)
    robot, oracle, check = robots[scene], oracles[scene], checkers[scene]
    q = rng.uniform(robot.lower, robot.upper)
    r = oracle.radius(q)
    if r == 0:
        assert check.distance(q) <= oracle.delta + 1e-9 or np.any(np.isclose(q, robot.lower) | np.isclose(q, robot.upper))
        return
    for a in _uniform_in_ball(rng, q, r, 30):
        assert not check.collides(a), f"collision at {a} inside bubble ({q}, {r})"


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), scene=st.sampled_from(SCENES), delta=st.sampled_from([0.0, 0.01, 0.03]))
def test_the_margin_holds_everywhere_inside_a_bubble(robots, checkers, seed, scene, delta):
    rng = np.random.default_rng(seed)
    robot, check = robots[scene], checkers[scene]
    oracle = BubbleOracle(robot, delta=delta)
    q = rng.uniform(robot.lower, robot.upper)
    r = oracle.radius(q)
    pts = _uniform_in_ball(rng, q, r, 20) if r > 0 else q[None]
    # Points on the sphere itself are the hardest case.
    if r > 0:
        u = rng.standard_normal((10, 3))
        pts = np.vstack([pts, q + r * u / np.linalg.norm(u, axis=1, keepdims=True)])
    for a in pts:
        if r > 0:
            assert check.distance(a) >= delta - 1e-9


def test_the_collision_check_catches_an_unsafe_radius(obstacle_robot, oracles, checkers):
    """The property above could fail: with 3 r(q) the same check finds collisions."""
    rng = np.random.default_rng(7)
    oracle, check = oracles["obstacle"], checkers["obstacle"]
    found = 0
    for _ in range(200):
        q = rng.uniform(obstacle_robot.lower, obstacle_robot.upper)
        r = oracle.radius(q)
        if r == 0:
            continue
        if any(check.collides(a) for a in _uniform_in_ball(rng, q, 3 * r, 30)):
            found += 1
    assert found >= 5


def test_radius_is_zero_in_collision_and_capped_by_the_bounds(obstacle_robot, oracles):
    oracle = oracles["obstacle"]
    assert oracle.radius([0.0, 0.0, 0.5 / 0.7 * np.pi / 2]) == 0.0  # foot inside the box
    # At the start the clearance sets the radius: (d - delta) / ||rho||.
    q = np.array([0.2, 0.3, 0.08])
    expected = (oracle.clearance(q) - 0.005) / oracle.bound.ball_factor
    assert oracle.radius(q) == pytest.approx(expected)
    # Near a bound the radius is the distance to it: the hip 0.02 short of its rearmost position.
    near = np.array([0.2, 0.3, obstacle_robot.lower[2] + 0.02])
    assert oracle.radius(near) == pytest.approx(0.02)


def test_batch_radii_equal_single_radii(obstacle_robot, oracles):
    oracle = oracles["obstacle"]
    Q = np.random.default_rng(3).uniform(obstacle_robot.lower, obstacle_robot.upper, (50, 3))
    np.testing.assert_allclose(oracle.radii(Q), [oracle.radius(q) for q in Q], atol=1e-12)


def test_a_negative_margin_is_refused(obstacle_robot):
    with pytest.raises(ValueError, match="delta"):
        BubbleOracle(obstacle_robot, delta=-0.01)


# -- the bound on any serial chain ----------------------------------------------------------------------

REPRODUCER = """<mujoco><compiler angle="radian"/><worldbody>
  <!-- A hinge about z; 0.5 m out, a slide along x drawn at ref = -0.5 (range -1..2), carrying a 5 cm ball. -->
  <body name="arm"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
    <joint name="turn" axis="0 0 1" range="-3.14 3.14"/>
    <body name="carriage" pos="0.5 0 0">
      <joint name="reach" type="slide" axis="1 0 0" ref="-0.5" range="-1 2"/>
      <geom name="ball" type="sphere" size="0.05"/>
    </body>
  </body>
  <!-- A wall from x = 2 to 3.5 whose near face is 0.55 m from the x axis. -->
  <geom name="wall" type="box" pos="2.75 0.6 0" size="0.75 0.05 0.1"/>
</worldbody></mujoco>"""


def _robot_from_xml(tmp_path, xml: str, name: str = "scene.xml"):
    from foam_mj.model import RobotModel

    path = tmp_path / name
    path.write_text(xml)
    return RobotModel.from_xml(path)


def test_a_slide_reach_is_measured_from_its_ref_pose(tmp_path):
    """The slide carries the ball up to 2.5 m past where the model draws it (qpos - ref, not qpos), so the
    hinge's reach is 0.5 + 2.5 + 0.05 = 3.05 m; with 2.55 the bubble at q = (0, 1.8) reached into the wall."""
    robot = _robot_from_xml(tmp_path, REPRODUCER)
    oracle = BubbleOracle(robot, delta=0.005)
    np.testing.assert_allclose(oracle.bound.weights, [3.05, 1.0], atol=1e-12)
    q = np.array([0.0, 1.8])
    assert oracle.clearance(q) == pytest.approx(0.5)
    r = oracle.radius(q)
    assert r == pytest.approx(0.495 / np.hypot(3.05, 1.0))
    m, d = robot.model, mujoco.MjData(robot.model)
    wall, ball = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("wall", "ball"))
    angles = np.linspace(0, 2 * np.pi, 721)
    for a in np.vstack([q + r * np.c_[np.cos(angles), np.sin(angles)], q + [[r, 0], [-r, 0]]]):
        robot.set_configuration(a, d)
        assert mujoco.mj_geomDistance(m, d, ball, wall, 1.0, None) >= 0.005 - 1e-9
        mujoco.mj_collision(m, d)
        assert d.ncon == 0


class _IndependentCheck:
    """Clearance straight from MuJoCo, sharing no code with foam_mj's pair lists or clearance: the pairs are
    those mj_collision reports on a copy of the model whose geoms are spheres inflated by a 100 m margin
    (MuJoCo's own filters: contype/conaffinity, welds, parent/child, exclusions), their distances come
    from mj_geomDistance on the model itself."""

    def __init__(self, robot) -> None:
        spec = mujoco.MjSpec.from_file(str(robot.path))
        for g in spec.geoms:
            g.type, g.margin = mujoco.mjtGeom.mjGEOM_SPHERE, 100.0
        wide = spec.compile()
        dw = mujoco.MjData(wide)
        mujoco.mj_forward(wide, dw)
        self.pairs = sorted({tuple(sorted(map(int, g))) for g in dw.contact.geom[: dw.ncon]})
        self.m = robot.model
        self.d = mujoco.MjData(self.m)
        self.to_qpos = robot.config.to_qpos

    def clearance(self, q) -> float:
        self.d.qpos[:] = self.to_qpos(q)
        mujoco.mj_kinematics(self.m, self.d)
        return min((mujoco.mj_geomDistance(self.m, self.d, a, b, 1.0, None) for a, b in self.pairs), default=1.0)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much])
@given(seed=st.integers(0, 2**32 - 1), delta=st.sampled_from([0.0, 0.005, 0.02]), self_collision=st.booleans())
def test_random_chains_keep_the_margin_inside_every_bubble(tmp_path, seed, delta, self_collision):
    """Hinges and slides in random order on random axes with random ref, random primitive geoms and
    obstacles, a floor half the time, robot geoms that collide with each other half the time: every
    configuration sampled inside a certified bubble, in the ball, on its sphere and along segments between
    such points, keeps clearance >= delta on every pair MuJoCo would collide, by MuJoCo's own reckoning."""
    from chains import random_chain_xml

    rng = np.random.default_rng(seed)
    robot = _robot_from_xml(tmp_path, random_chain_xml(rng, self_collision=self_collision), f"chain{seed}.xml")
    oracle = BubbleOracle(robot, delta=delta)
    check = _IndependentCheck(robot)
    n = robot.dim
    Q = rng.uniform(robot.lower, robot.upper, (12, n))
    R = oracle.radii(Q)
    checked = 0
    for q, r in zip(Q, R):
        if r <= 0:
            continue
        inside = _uniform_in_ball(rng, q, r, 12)
        u = rng.standard_normal((6, n))
        on_sphere = q + r * u / np.linalg.norm(u, axis=1, keepdims=True)
        ends = np.vstack([inside, on_sphere])
        segments = [a + s * (b - a) for a, b in zip(ends[:6], ends[6:12]) for s in np.linspace(0, 1, 6)]
        for a in np.vstack([ends, segments]):
            assert check.clearance(a) >= delta - 1e-7, f"clearance below {delta} at {a} in bubble ({q}, {r})"
        checked += 1
    oracle.close()
    assume(checked > 0)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much])
@given(seed=st.integers(0, 2**32 - 1), delta=st.sampled_from([0.0, 0.005, 0.02]), self_collision=st.booleans())
def test_the_radius_is_1_lipschitz_so_a_bubble_bounds_its_neighbours_radii(tmp_path, seed, delta, self_collision):
    """r(a) <= r(q) + |a - q| for configurations of random chains (what BubbleOracle.radii_below is given as an upper
    bound by the planners: a parent's radius plus the step to its child), along the 1-2 radius steps the growth takes."""
    from chains import random_chain_xml

    rng = np.random.default_rng(seed)
    robot = _robot_from_xml(tmp_path, random_chain_xml(rng, self_collision=self_collision), f"chain{seed}.xml")
    oracle = BubbleOracle(robot, delta=delta)
    Q = rng.uniform(robot.lower, robot.upper, (40, robot.dim))
    r = oracle.radii(Q)
    u = rng.standard_normal(Q.shape)
    step = np.where(r > 0, r, 0.05)[:, None] * rng.uniform(0.0, 2.0, (len(Q), 1)) * u / np.linalg.norm(u, axis=1, keepdims=True)
    A = np.clip(Q + step, robot.lower, robot.upper)
    assert np.all(oracle.radii(A) <= r + np.linalg.norm(A - Q, axis=1) + 1e-12)
    oracle.close()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much])
@given(seed=st.integers(0, 2**32 - 1), delta=st.sampled_from([0.0, 0.005, 0.02]), self_collision=st.booleans(),
       scale=st.sampled_from([0.0, 0.5, 1.0, 1.5, 4.0, np.inf]))
def test_radii_below_an_upper_bound_are_the_full_radii_where_they_are_below_it_and_never_more(tmp_path, seed, delta,
                                                                                              self_collision, scale):
    """Pairs measured only as far as they could set the radius (BubbleOracle.radii_below): the full query's radius
    to the last bit wherever it is at most the upper bound, and never more than it anywhere (certified whatever the
    bound), on random chains of primitive geoms, boxes and ellipsoids included (MuJoCo's GJK with its cutoff)."""
    from chains import random_chain_xml

    rng = np.random.default_rng(seed)
    robot = _robot_from_xml(tmp_path, random_chain_xml(rng, self_collision=self_collision), f"chain{seed}.xml")
    oracle = BubbleOracle(robot, delta=delta)
    Q = rng.uniform(robot.lower, robot.upper, (60, robot.dim))
    full = oracle.radii(Q)
    upper = full * scale * rng.uniform(0.8, 1.2, len(Q)) if np.isfinite(scale) else np.full(len(Q), np.inf)
    capped = oracle.radii_below(Q, upper)
    assert np.all(capped <= full)
    assert np.array_equal(capped[full <= upper], full[full <= upper])
    assert np.array_equal(oracle.radii_below(Q, upper, oracle.to_bounds(Q)), capped)  # bounds' terms given: the same bits
    assert np.all(capped >= np.minimum(full, upper))
    oracle.close()


def test_radii_below_match_the_full_radii_on_a_mesh_obstacle(tmp_path):
    """The same with a mesh obstacle (GJK on its vertices; the cutoff ends it early for far configurations)."""
    (tmp_path / "assets").mkdir()
    (tmp_path / "assets" / "rock.obj").write_text(ROCK)
    robot = _robot_from_xml(tmp_path, MESH_ARM)
    oracle = BubbleOracle(robot, delta=0.005)
    rng = np.random.default_rng(1)
    Q = rng.uniform(robot.lower, robot.upper, (500, robot.dim))
    full = oracle.radii(Q)
    for scale in (0.0, 1.0, 1.3, 3.0):
        upper = full * scale
        capped = oracle.radii_below(Q, upper)
        assert np.all(capped <= full) and np.array_equal(capped[full <= upper], full[full <= upper])
    oracle.close()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much])
@given(seed=st.integers(0, 2**32 - 1), at=st.sampled_from(["lower", "upper", "beside"]))
def test_a_bubble_holding_a_point_on_a_joint_limit_stays_in_the_bounds_and_keeps_the_margin(tmp_path, seed, at):
    """An end point with one joint at (or 1e-9 beside) a limit: the bubble that holds it is certified at its own
    centre, lies inside the joint bounds, holds the point, and every configuration sampled in it and on the
    segments from the point into it keeps delta by MuJoCo's own reckoning."""
    from chains import random_chain_xml

    rng = np.random.default_rng(seed)
    robot = _robot_from_xml(tmp_path, random_chain_xml(rng, self_collision=False), f"limit{seed}.xml")
    oracle = BubbleOracle(robot, delta=0.005)
    check = _IndependentCheck(robot)
    n = robot.dim
    q = rng.uniform(robot.lower, robot.upper)
    j = int(rng.integers(n))
    q[j] = {"lower": robot.lower[j], "upper": robot.upper[j], "beside": robot.lower[j] + 1e-9}[at]
    assume(oracle.clearance(q) > 0.006)
    e = oracle.holding_bubble(q, want=1e-3)
    c, r = e.center, e.radius
    assert e.within_bounds
    oracle_r = oracle.radius(c)
    oracle.close()
    assert r > 0 and not np.array_equal(c, q)  # one joint at its limit: a moved bubble always holds the point
    assert r <= oracle_r + 1e-15 and np.linalg.norm(c - q) <= r
    assert np.all(c - r >= robot.lower - 1e-12) and np.all(c + r <= robot.upper + 1e-12)
    inside = _uniform_in_ball(rng, c, r, 10)
    towards = [q + s * (a - q) for a in inside[:5] for s in np.linspace(0, 1, 5)]
    for a in np.vstack([inside, towards]):
        assert check.clearance(a) >= 0.005 - 1e-7, f"clearance below delta at {a} in the bubble ({c}, {r}) holding {q}"


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much])
@given(seed=st.integers(0, 2**32 - 1))
def test_an_end_bubble_on_an_edge_of_the_joint_box_keeps_the_margin_wherever_it_is_in_the_box(tmp_path, seed):
    """An end point with two joints at their limits: no ball inside the box holds it, so its bubble is the
    clearance's ball about it (it leaves the box); every configuration sampled in that ball and inside the box, and
    on the segments from the point to them, keeps delta by MuJoCo's own reckoning."""
    from chains import random_chain_xml

    rng = np.random.default_rng(seed)
    robot = _robot_from_xml(tmp_path, random_chain_xml(rng, self_collision=False), f"edge{seed}.xml")
    n = robot.dim
    assume(n >= 2)
    oracle = BubbleOracle(robot, delta=0.005)
    check = _IndependentCheck(robot)
    q = rng.uniform(robot.lower, robot.upper)
    for j in rng.choice(n, 2, replace=False):
        q[j] = robot.lower[j] if rng.random() < 0.5 else robot.upper[j]
    assume(oracle.clearance(q) > 0.006)
    e = oracle.holding_bubble(q, want=1e-3)
    oracle.close()
    assert not e.within_bounds and np.array_equal(e.center, q) and e.radius > 0
    pts = _uniform_in_ball(rng, q, e.radius, 400)
    pts = pts[np.all((pts >= robot.lower) & (pts <= robot.upper), axis=1)][:12]
    towards = [q + s * (a - q) for a in pts[:5] for s in np.linspace(0, 1, 5)]
    for a in np.vstack([pts, towards]):
        assert check.clearance(a) >= 0.005 - 1e-7, f"clearance below delta at {a} in the end bubble ({q}, {e.radius})"


def _points_in_geom(m, d, g):
    """Points of geom g (world frame): its centre and, just inside its surface, the ends of its local axes
    (box corners for boxes)."""
    pos, mat, size = d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3), m.geom_size[g]
    t = int(m.geom_type[g])
    gt = mujoco.mjtGeom
    if t == gt.mjGEOM_BOX:
        local = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)]) * size
    elif t == gt.mjGEOM_SPHERE:
        local = np.vstack([np.eye(3), -np.eye(3)]) * size[0]
    elif t == gt.mjGEOM_CAPSULE:
        local = np.vstack([s * np.array([0, 0, size[1]]) + size[0] * e for s in (-1, 1) for e in np.vstack([np.eye(3), -np.eye(3)])])
    elif t == gt.mjGEOM_CYLINDER:
        local = np.array([[x * size[0], y * size[0], z * size[1]] for x, y in ((1, 0), (-1, 0), (0, 1), (0, -1)) for z in (-1, 1)])
    else:  # ellipsoid
        local = np.vstack([np.eye(3), -np.eye(3)]) * size[:3]
    return pos + 0.999 * np.vstack([np.zeros(3), local]) @ mat.T


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1))
def test_no_point_of_a_random_chain_moves_farther_than_its_geoms_bound(tmp_path, seed):
    """Paper 003 Eq. 4 per geom, on random chains: along q -> a no point of geom g moves farther than
    sum_grp rho_(g,grp) ||a_grp - q_grp||, for moves across the whole range (slides to their ends)."""
    from chains import random_chain_xml

    rng = np.random.default_rng(seed)
    robot = _robot_from_xml(tmp_path, random_chain_xml(rng), f"chain{seed}.xml")
    bound = DisplacementBound.from_model(robot)
    m, d = robot.model, mujoco.MjData(robot.model)
    for _ in range(5):
        q = rng.uniform(robot.lower, robot.upper)
        a = np.where(rng.random(robot.dim) < 0.5, robot.lower, robot.upper)  # to the ends of the ranges
        dq = a - q
        allowed = {g: sum(w * np.linalg.norm(dq[list(grp)]) for w, grp in zip(bound.per_geom[g], bound.groups)) for g in robot.robot_geoms}
        robot.set_configuration(q, d)
        p0 = {g: _points_in_geom(m, d, g) for g in robot.robot_geoms}
        for s in np.linspace(0, 1, 9)[1:]:
            robot.set_configuration(q + s * dq, d)
            for g in robot.robot_geoms:
                moved = float(np.max(np.linalg.norm(_points_in_geom(m, d, g) - p0[g], axis=1)))
                assert moved <= allowed[g] + 1e-9, f"geom {robot.geom_name(g)} moved {moved} > bound {allowed[g]}"


def test_a_normalized_hinge_has_its_reach_times_its_scale(obstacle_robot):
    """A hinge whose q is normalized ([normalize] knee_flexion = [0.5]: its 2.1 rad range onto [0, 0.5]) turns
    4.2 rad per unit of q, so its rho is its reach times 4.2 (not the reach alone), and no leg point moves farther
    than the bound along any move in q."""
    from foam_mj.model import RobotModel

    robot = RobotModel.from_xml(obstacle_robot.path, normalize={"knee_flexion": [0.5]})
    knee = list(robot.config.joint_names).index("knee_flexion")
    assert robot.config.scale[knee] == pytest.approx(4.2)
    plain = DisplacementBound.from_model(obstacle_robot)
    bound = DisplacementBound.from_model(robot)
    np.testing.assert_allclose(bound.rho[:, knee], 4.2 * plain.rho[:, knee], atol=1e-12)
    rng = np.random.default_rng(7)
    m, d = robot.model, mujoco.MjData(robot.model)
    for _ in range(20):
        q, a = rng.uniform(robot.lower, robot.upper, (2, robot.dim))
        p0 = _geom_points(m, robot.set_configuration(q, d), robot)
        for s in np.linspace(0, 1, 9)[1:]:
            ps = _geom_points(m, robot.set_configuration(q + s * (a - q), d), robot)
            assert float(np.max(np.linalg.norm(ps - p0, axis=1))) <= float(bound(s * (a - q))) + 1e-9


PAN_TILT = """<mujoco><compiler angle="radian"/><worldbody>
  <!-- A pan about z and, below it, a tilt about x carrying a 5 cm ball 0.5 m up: drawn on the pan axis. -->
  <body name="pan"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
    <joint name="pan" axis="0 0 1" range="-3 3"/>
    <body name="tilt"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
      <joint name="tilt" axis="1 0 0" range="-1.6 1.6"/>
      <geom name="ball" type="sphere" size="0.05" pos="0 0 0.5"/>
    </body>
  </body>
  <geom name="wall" type="box" pos="2 0 0" size="0.1 1 1"/>
</worldbody></mujoco>"""


def test_a_hinge_reach_holds_where_a_crossed_hinge_below_swings_the_geom_off_its_axis(tmp_path):
    """The pan's reach is the farthest the ball can be from the pan axis in any configuration, 0.5 + 0.05 m once the
    tilt (not parallel to the pan) swings it out, not its 0.05 m in the drawn pose (measured in the plane normal to
    the pan axis, which is only right when every hinge below is parallel); a pan-only move stays within the bound."""
    robot = _robot_from_xml(tmp_path, PAN_TILT)
    bound = DisplacementBound.from_model(robot)
    m, d = robot.model, mujoco.MjData(robot.model)
    ball = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "ball")
    assert bound.rho[ball, 0] >= 0.55 - 1e-9
    for tilt in np.linspace(-1.6, 1.6, 9):
        q = np.array([-0.5, tilt])
        p0 = robot.set_configuration(q, d).geom_xpos[ball].copy()
        p1 = robot.set_configuration(q + [1.0, 0.0], d).geom_xpos[ball]
        assert np.linalg.norm(p1 - p0) <= bound.per_geom[ball] @ [1.0, 0.0] + 1e-9


UR_WRIST = """<mujoco><compiler angle="radian"/><worldbody>
  <!-- A UR-like wrist: wrist_1 about y; wrist_2, about z, 0.127 m from it along wrist_1's own axis; on wrist_2 a
       capsule from its anchor 0.1 m up (radius 4 cm). -->
  <body name="w1"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
    <joint name="wrist_1" axis="0 1 0" range="-3 3"/>
    <body name="w2" pos="0 0.127 0"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
      <joint name="wrist_2" axis="0 0 1" range="-3 3"/>
      <geom name="cap" type="capsule" fromto="0 0 0 0 0 0.1" size="0.04"/>
    </body>
  </body>
  <geom name="wall" type="box" pos="1 0 0" size="0.1 1 1"/>
</worldbody></mujoco>"""


def test_a_step_along_the_hinge_axis_before_any_crossed_hinge_is_no_lever(tmp_path):
    """wrist_1 turns the step to wrist_2 about that step itself: it stays on wrist_1's axis whatever wrist_2 does, so
    the capsule is at most 0.1 + 0.04 m from wrist_1's axis (reached with wrist_2 anywhere: the capsule points along
    z), not 0.127 + 0.14 m as with the step counted whole; the bound holds and is reached in every configuration."""
    robot = _robot_from_xml(tmp_path, UR_WRIST)
    bound = DisplacementBound.from_model(robot)
    m, d = robot.model, mujoco.MjData(robot.model)
    cap = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "cap")
    np.testing.assert_allclose(bound.rho[cap], [0.14, 0.04], atol=1e-12)
    for q in np.random.default_rng(8).uniform(robot.lower, robot.upper, (50, 2)):
        robot.set_configuration(q, d)
        u, a = d.xaxis[0], d.xanchor[0]
        v = _points_in_geom(m, d, cap) - a
        off_axis = np.linalg.norm(v - np.outer(v @ u, u), axis=1)
        assert off_axis.max() <= 0.14 and off_axis.max() >= 0.999 * 0.14 - 1e-9


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1))
def test_no_point_of_a_random_chain_is_farther_from_a_hinge_axis_than_its_reach(tmp_path, seed):
    """The hinge reach rho_(g, k) / |scale| (module docstring: a segment turned only by hinges parallel to k's axis
    measured normal to it, the others whole) bounds the distance from k's axis of every point of geom g in every
    configuration of random chains (half of their axes coordinate axes: parallel runs of hinges, crossed ones after)."""
    from chains import random_chain_xml

    rng = np.random.default_rng(seed)
    robot = _robot_from_xml(tmp_path, random_chain_xml(rng, joints=(2, 5)), f"chain{seed}.xml")
    bound = DisplacementBound.from_model(robot)
    m, d, cfg = robot.model, mujoco.MjData(robot.model), robot.config
    hinges = [i for i, j in enumerate(cfg.joint_ids) if int(m.jnt_type[int(j)]) == mujoco.mjtJoint.mjJNT_HINGE]
    for q in rng.uniform(robot.lower, robot.upper, (20, robot.dim)):
        robot.set_configuration(q, d)
        for g in robot.robot_geoms:
            for i in hinges:
                if bound.rho[g, i] == 0.0:
                    continue
                j = int(cfg.joint_ids[i])
                u, a = d.xaxis[j] / np.linalg.norm(d.xaxis[j]), d.xanchor[j]
                v = _points_in_geom(m, d, g) - a
                off_axis = float(np.linalg.norm(v - np.outer(v @ u, u), axis=1).max())
                assert off_axis <= bound.rho[g, i] / abs(cfg.scale[i]) + 1e-9, f"geom {robot.geom_name(g)}, joint {i}"


SLIDE_HINGE_SLIDE = """<mujoco><compiler angle="radian"/><worldbody>
  <!-- One body with three joints in this order: a slide along x, a hinge about z, a slide along y. MuJoCo turns the
       second slide's axis by the hinge: at 90 degrees both slides move the 5 cm ball along x. -->
  <body name="base"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
    <joint name="sx" type="slide" axis="1 0 0" range="-1 1"/>
    <joint name="hz" axis="0 0 1" range="-3 3"/>
    <joint name="sy" type="slide" axis="0 1 0" range="-0.5 0.5"/>
    <geom name="ball" type="sphere" size="0.05"/>
  </body>
  <!-- A wall whose near face is at x = 0.3. -->
  <geom name="wall" type="box" pos="0.35 0 0" size="0.05 2 0.5"/>
</worldbody></mujoco>"""


def test_slides_with_a_hinge_between_them_on_one_body_are_not_one_euclidean_group(tmp_path):
    """Two orthogonal slides form one group (their 2-norm bounds the motion) only while no hinge turns one against
    the other: with the hinge at 90 degrees, dx = -dy moves the ball |dx| + |dy| along x, sqrt(2) times that norm.
    The bubble at q = (0, 90 degrees, 0), 0.25 m from the wall, keeps delta along that diagonal (as a group, its
    radius was 0.215 and the ball went 4 cm into the wall)."""
    robot = _robot_from_xml(tmp_path, SLIDE_HINGE_SLIDE)
    oracle = BubbleOracle(robot, delta=0.005)
    assert oracle.bound.groups == ((0,), (1,), (2,))
    q = np.array([0.0, np.pi / 2, 0.0])
    assert oracle.clearance(q) == pytest.approx(0.25)
    r = oracle.radius(q)
    for u in (np.array([1.0, 0.0, -1.0]), np.array([-1.0, 0.0, 1.0])):
        for s in np.linspace(0.0, 1.0, 21):
            assert oracle.clearance(q + s * r * u / np.linalg.norm(u)) >= 0.005 - 1e-9
    oracle.close()


# -- one oracle, many plans: threads, pickling, edited scenes -------------------------------------------

def _bubbletree_rosary(problem, seed: int):
    from foam_mj.planners import get_planner

    r = get_planner("bubbletree").plan(problem, seed=seed).rosary
    return r.centers, r.radii


def test_one_oracle_plans_from_several_threads_as_it_does_alone(oracles):
    # Each thread queries through its own MjData and batches; shared ones gave rosaries through obstacles.
    import threading

    from foam_mj.planners import PlanningProblem

    s = oracles["obstacle"]
    problem = PlanningProblem(s, [0.0, 0.0, 0.0], [0.3, 0.1, 1.5], delta=s.delta, time_limit=30)
    alone = {seed: _bubbletree_rosary(problem, seed) for seed in range(3)}
    together: dict = {}
    threads = [threading.Thread(target=lambda k=seed: together.__setitem__(k, _bubbletree_rosary(problem, k))) for seed in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for seed in range(3):
        np.testing.assert_array_equal(together[seed][0], alone[seed][0])
        np.testing.assert_array_equal(together[seed][1], alone[seed][1])


MESH_ARM = """<mujoco><compiler angle="radian" meshdir="assets"/>
  <asset><mesh name="rock" file="rock.obj"/></asset>
  <worldbody>
    <geom name="rock" type="mesh" mesh="rock" pos="0.25 -0.2 0"/>
    <body name="link" pos="0 0 0.5"><joint name="pan" axis="0 0 1" range="-3 3"/><joint name="tilt" axis="0 1 0" range="-1.2 1.2"/>
      <geom name="arm" type="capsule" fromto="0 0 0 0.5 0 0" size="0.03"/></body>
  </worldbody></mujoco>"""
ROCK = "v 0 0 0\nv 0.4 0 0\nv 0.2 0.35 0\nv 0.2 0.12 0.3\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n"


def test_a_problem_pickles_with_its_oracle_and_plans_the_same_elsewhere(tmp_path, monkeypatch):
    # For process pools and Ray: the MjSpec, which does not pickle, travels as MJCF text whose mesh folder is
    # absolute, so the copy loads from another working directory.
    import pickle

    from foam_mj.planners import PlanningProblem

    (tmp_path / "assets").mkdir()
    (tmp_path / "assets" / "rock.obj").write_text(ROCK)
    robot = _robot_from_xml(tmp_path, MESH_ARM)
    oracle = BubbleOracle(robot, delta=0.01)
    problem = PlanningProblem(oracle, [-1.0, 0.6], [0.3, 0.7], delta=0.01, time_limit=30)
    monkeypatch.chdir(tmp_path / "assets")
    copy = pickle.loads(pickle.dumps(problem))
    for a, b in zip(_bubbletree_rosary(problem, 0), _bubbletree_rosary(copy, 0)):
        np.testing.assert_array_equal(a, b)
    assert copy.oracle.robot.spec_copy().compile().ngeom == robot.model.ngeom


def test_an_edit_of_the_compiled_model_is_refused_before_it_is_half_used(tmp_path):
    # The bubble bound and the batched queries' model are built once: an obstacle moved in robot.model was seen
    # by single queries and not by batches (a silent mix of two scenes). Now every entry point names the edit.
    from foam_mj.errors import ModelError
    from foam_mj.model import RobotModel
    from foam_mj.planners import PlanningProblem, get_planner

    from conftest import MODELS

    robot = RobotModel.from_xml(MODELS / "obstacle.xml")
    oracle = BubbleOracle(robot, delta=0.005)
    q0, q1 = [0.0, 0.0, 0.0], [0.3, 0.1, 1.5]
    problem = PlanningProblem(oracle, q0, q1, delta=0.005)
    box = mujoco.mj_name2id(robot.model, mujoco.mjtObj.mjOBJ_GEOM, "obstacle_box")
    robot.model.geom_pos[box, 2] -= 0.05
    for call in (lambda: oracle.radius(q0), lambda: oracle.explain(q0), lambda: BubbleOracle(robot, 0.005),
                 lambda: PlanningProblem(oracle, q0, q1, delta=0.005), *(lambda n=n: get_planner(n).plan(problem) for n in ("bubbletree", "pfm", "gbpf"))):
        with pytest.raises(ModelError, match=r"edited after its RobotModel was built \(geom_pos changed\).*spec_copy"):
            call()
    # The documented way: edit a copy of the spec and build a new model and oracle; single and batched agree.
    spec = robot.spec_copy()
    spec.geom("obstacle_box").pos[2] -= 0.05
    moved = BubbleOracle(RobotModel.from_spec(spec, robot.path), delta=0.005)
    Q = np.array([q0, q1, [0.5, 0.8, 0.7]])
    np.testing.assert_allclose(moved.radii(Q), [moved.radius(q) for q in Q], atol=1e-12)


def test_a_spec_edited_after_from_spec_does_not_reach_the_model_it_built(tmp_path):
    from foam_mj.model import RobotModel

    from conftest import MODELS

    spec = mujoco.MjSpec.from_file(str(MODELS / "obstacle.xml"))
    robot = RobotModel.from_spec(spec, MODELS / "obstacle.xml")
    spec.geom("obstacle_box").pos[2] -= 0.05  # after the model was built: not part of it
    oracle = BubbleOracle(robot, delta=0.005)
    Q = np.array([[0.0, 0.0, 0.0], [0.5, 0.8, 0.7]])
    np.testing.assert_allclose(oracle.radii(Q), [oracle.radius(q) for q in Q], atol=1e-12)


@pytest.mark.parametrize("args, message", [
    (("obstacle.xml",), "BubbleOracle takes a foam_mj.model.RobotModel"),
    ((None, "0.01"), "`delta` must be a number"),
    ((None, None), "`delta` must be a number"),
])
def test_an_oracle_names_a_wrong_argument_type(obstacle_robot, args, message):
    args = (obstacle_robot if args[0] is None else args[0], *args[1:])
    with pytest.raises(TypeError, match=message):
        BubbleOracle(*args)


def test_a_margin_beyond_any_float_is_refused_by_name(obstacle_robot):
    """A Python integer beyond numpy's int64 (2**70 m) was numpy's "ufunc 'isfinite' not supported for the input types"."""
    with pytest.raises(ValueError, match=r"`delta` \(safety margin, metres\) must be >= 0, got 1000000"):
        BubbleOracle(obstacle_robot, delta=10**400, distmax=1.0)  # no float holds it
    with pytest.raises(ValueError, match=r"`distmax` .* must be > delta = 1180591620717411303424, got 1.0"):
        BubbleOracle(obstacle_robot, delta=2**70, distmax=1.0)  # a finite float: checked as any margin


def test_a_distance_cap_at_or_below_the_margin_is_refused(obstacle_robot):
    # Every distance then read distmax, so a start 0.11 m clear was refused as "too close to an obstacle: clearance 0.0050 m".
    for distmax in (0.005, 0.004):
        with pytest.raises(ValueError, match=r"`distmax` \(the cap of every measured distance, metres\) must be > delta = 0.005"):
            BubbleOracle(obstacle_robot, delta=0.005, distmax=distmax)
    assert BubbleOracle(obstacle_robot, delta=0.005, distmax=0.5).clearance.distmax == 0.5


def test_a_margin_above_the_default_distance_cap_measures_far_enough(tmp_path):
    # With delta = 1.2 m every distance was capped at 1 m: a start 2.6 m clear read "too close to an obstacle".
    from foam_mj.scenarios import scenario_from_dict

    xml = """<mujoco><compiler angle="radian"/><worldbody><geom name="wall" type="box" pos="3 0 0.5" size="0.1 2 0.5"/>
      <body name="arm" pos="0 0 0.5"><joint name="yaw" axis="0 0 1" range="-1 1"/>
        <geom name="link" type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/></body></worldbody></mujoco>"""
    robot = _robot_from_xml(tmp_path, xml)
    oracle = BubbleOracle(robot, delta=1.2)
    assert oracle.clearance.distmax == 2.4 and oracle.radius([0.0]) > 0.5
    s = scenario_from_dict({"scene": "scene.xml", "q_init": [-0.5], "q_goal": [0.5], "planner": {"delta": 1.2}}, tmp_path)
    assert s.oracle().radius([0.0]) == oracle.radius([0.0])


def _two_link_arm(scale: float) -> str:
    """A two-link planar arm (0.5 m and 0.4 m links at scale 1) beside a post, every length times ``scale``."""
    s = scale
    return f"""<mujoco><compiler angle="radian"/><worldbody>
      <geom name="post" type="box" pos="{0.7 * s} {0.5 * s} {0.1 * s}" size="{0.1 * s} {0.1 * s} {0.5 * s}"/>
      <body name="l1" pos="0 0 {0.1 * s}"><joint name="j1" axis="0 0 1" range="-3 3"/>
        <geom name="c1" type="capsule" fromto="0 0 0 {0.5 * s} 0 0" size="{0.03 * s}"/>
        <body name="l2" pos="{0.5 * s} 0 0"><joint name="j2" axis="0 0 1" range="-2.5 2.5"/>
          <geom name="c2" type="capsule" fromto="0 0 0 {0.4 * s} 0 0" size="{0.025 * s}"/></body></body>
    </worldbody></mujoco>"""


def test_a_robot_drawn_in_kilometres_gets_the_bubbles_of_its_copy_in_metres(tmp_path):
    """The distance cap grows with the robot (half its reach, above 2 m): the 900 m arm, 0.44 km from the post, gets the
    bubble its 0.9 m copy gets 0.44 m from it (margins scaled alike). With a cap of 1 m (10 m: twice its 5 m margin) it
    read every distance as 10 m and got a bubble of 0.005 rad where the copy has 0.43 rad: every planner but bubbletree
    refused the start, and bubbletree ran out of time."""
    small = BubbleOracle(_robot_from_xml(tmp_path, _two_link_arm(1.0), "m.xml"), delta=0.005)
    large = BubbleOracle(_robot_from_xml(tmp_path, _two_link_arm(1000.0), "km.xml"), delta=5.0)
    assert small.bound.reach == pytest.approx(0.925) and large.bound.reach == pytest.approx(925.0)
    assert small.clearance.distmax == 1.0 and large.clearance.distmax == pytest.approx(462.5)
    q = np.array([-0.2, 0.3])
    assert large.clearance(q) == pytest.approx(1000 * small.clearance(q))
    assert large.radius(q) == pytest.approx(small.radius(q)) and small.radius(q) > 0.4
    small.close()
    large.close()
