"""Tests for the CloudWalker (models/cloudwalker.xml, walker_corridor.xml, walker_two_routes.xml): the
double-cone bubble of paper 003 Eq. 5 and its inscribed ball (section 3.1), bubble safety checked with
MuJoCo contacts, and the foam on the thesis's two walker maps (section 5.2) for 20 seeds."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from foam_mj.bubbles import DisplacementBound
from foam_mj.foam import plan
from foam_mj.scenarios import load_scenario

from conftest import MujocoChecker

MAPS = ("walker_corridor", "walker_two_routes")
SETTINGS = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

# r_robot by hand from cloudwalker.xml's collision geoms, in the walker's frame (origin on the rotation
# axis, the drive axle's midpoint). Side boxes: pos (0.25, +-0.295), half sizes (0.35, 0.025), so they
# span x = -0.10 .. 0.60 and |y| = 0.27 .. 0.32. Front bar: pos x 0.575, half sizes (0.025, 0.27): x up to
# 0.60, |y| <= 0.27. User space: vertical capsule of radius 0.20 on the axis. Farthest footprint points:
_FOOTPRINT_EXTREMES = {
    "side box, front outer corner": np.hypot(0.25 + 0.35, 0.295 + 0.025),
    "side box, rear outer corner": np.hypot(0.25 - 0.35, 0.295 + 0.025),
    "front bar, outer corner": np.hypot(0.575 + 0.025, 0.27),
    "user space capsule": 0.20,
}
R_ROBOT = max(_FOOTPRINT_EXTREMES.values())  # sqrt(0.60^2 + 0.32^2) = 0.68 m
WALKER_WIDTH = 2 * (0.295 + 0.025)  # 0.64 m
# Bounds of q by hand from the joint ranges: x, y in [0, 10] m, theta in [-pi, pi].
LOWER = np.array([0.0, 0.0, -np.pi])
UPPER = np.array([10.0, 10.0, np.pi])
# Route test for Map 2 (walker_two_routes.xml): the central block spans x = 3..7, y = 2.2..6.5.
BLOCK_X, SHORT_BELOW, LONG_ABOVE = 5.0, 2.2, 6.5


@pytest.fixture(scope="module")
def scenarios():
    return {name: load_scenario(name) for name in MAPS}


@pytest.fixture(scope="module")
def oracles(scenarios):
    out = {name: s.oracle() for name, s in scenarios.items()}
    yield out
    for o in out.values():
        o.close()


@pytest.fixture(scope="module")
def checkers(scenarios):
    return {name: MujocoChecker(s.robot) for name, s in scenarios.items()}


@pytest.fixture(scope="module")
def twenty_plans(scenarios, oracles):
    return {name: [plan(oracles[name], s.q_init, s.q_goal, s.params, seed=seed) for seed in range(20)] for name, s in scenarios.items()}


def eq5(dq: np.ndarray) -> np.ndarray:
    """Paper 003 Eq. 5's displacement bound: sqrt(dx^2 + dy^2) + r_robot |dtheta|."""
    dq = np.asarray(dq, dtype=float)
    return np.hypot(dq[..., 0], dq[..., 1]) + R_ROBOT * np.abs(dq[..., 2])


def _uniform_in_ball(rng, center, radius, count):
    u = rng.standard_normal((count, len(center)))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return center + u * radius * rng.random((count, 1)) ** (1 / len(center))


# -- the model ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", MAPS)
def test_the_scenes_declare_q_and_split_walker_from_walls(scenarios, name):
    robot = scenarios[name].robot
    m = robot.model
    assert robot.config.joint_names == ("walker_x", "walker_y", "walker_theta")
    np.testing.assert_allclose(robot.lower, LOWER)
    np.testing.assert_allclose(robot.upper, UPPER)
    assert sorted(robot.geom_name(g) for g in robot.robot_geoms) == sorted(
        ["left_side_collision", "right_side_collision", "front_bar_collision", "user_space_collision"]
    )
    obstacles = [robot.geom_name(g) for g in robot.obstacle_geoms]
    assert "floor" not in obstacles and {"wall_south", "wall_north", "wall_west", "wall_east"} <= set(obstacles)
    # The walker rolls on the floor: none of its collision geoms reaches down to it (lowest at 3 cm).
    d = robot.set_configuration(scenarios[name].q_init, mujoco.MjData(m))
    for g in robot.robot_geoms:
        lowest = d.geom_xpos[g][2] - (m.geom_size[g][2] if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX else m.geom_size[g][1] + m.geom_size[g][0])
        assert lowest >= 0.03 - 1e-12


def test_the_servos_hold_the_start_pose_without_warnings(scenarios):
    """Menagerie habit: the model steps for a second under its actuators without a MuJoCo warning."""
    robot = scenarios["walker_two_routes"].robot
    m = robot.model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "start"))
    np.testing.assert_allclose(d.qpos, scenarios["walker_two_routes"].q_init)
    d.ctrl[:] = d.qpos + [0.05, -0.05, 0.1]  # a small step the servos must follow
    for _ in range(int(1.0 / m.opt.timestep)):
        mujoco.mj_step(m, d)
    assert all(w.number == 0 for w in d.warning)
    np.testing.assert_allclose(d.qpos, d.ctrl, atol=2e-3)


# -- paper 003 Eq. 5 and its inscribed ball --------------------------------------------------------------
def test_the_displacement_bound_is_eq5_double_cone(scenarios):
    """bubbles.py groups the x and y slides (weight 1) and gives theta the footprint's outer radius."""
    assert R_ROBOT == pytest.approx(0.68, abs=1e-3)
    bound = DisplacementBound.from_model(scenarios["walker_corridor"].robot)
    assert bound.groups == ((0, 1), (2,))
    np.testing.assert_allclose(bound.weights, [1.0, R_ROBOT], atol=1e-12)
    assert bound.ball_factor == pytest.approx(np.sqrt(1 + R_ROBOT**2), abs=1e-12)  # 1.2093
    dq = np.random.default_rng(0).normal(size=(1000, 3))
    np.testing.assert_allclose(bound(dq), eq5(dq), rtol=1e-12)


def test_the_ball_is_the_largest_inside_the_double_cone():
    """Section 3.1: the ball of radius rho / sqrt(1 + r_robot^2) lies in {Eq. 5 <= rho} and touches its
    boundary (so no larger ball about q fits)."""
    rho = 1.0
    r = rho / np.sqrt(1 + R_ROBOT**2)
    u = np.random.default_rng(1).standard_normal((20000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    assert np.all(eq5(r * u) <= rho + 1e-12)
    for phi in np.linspace(0, 2 * np.pi, 7):  # the tangent directions: (cos phi, sin phi, +-r_robot)
        for s in (1, -1):
            t = np.array([np.cos(phi), np.sin(phi), s * R_ROBOT]) / np.sqrt(1 + R_ROBOT**2)
            assert eq5(r * t) == pytest.approx(rho, abs=1e-12)


def _footprint_points(m, d, robot):
    """Box corners and points on the capsule's end spheres, world frame."""
    pts = []
    for g in robot.robot_geoms:
        pos, mat, size = d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3), m.geom_size[g]
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            signs = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)])
            pts.append(pos + (signs * size) @ mat.T)
        else:
            for s in (-1, 1):
                pts.append(pos + s * size[1] * mat[:, 2] + size[0] * np.vstack([np.eye(3), -np.eye(3)]))
    return np.vstack(pts)


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_no_walker_point_moves_farther_than_eq5(scenarios, seed):
    rng = np.random.default_rng(seed)
    robot = scenarios["walker_corridor"].robot
    m, d = robot.model, mujoco.MjData(robot.model)
    q = rng.uniform(LOWER, UPPER)
    a = q + rng.normal(scale=[0.5, 0.5, 1.0])
    p0 = _footprint_points(m, robot.set_configuration(q, d), robot)
    worst = max(
        float(np.max(np.linalg.norm(_footprint_points(m, robot.set_configuration(q + s * (a - q), d), robot) - p0, axis=1)))
        for s in np.linspace(0, 1, 11)[1:]
    )
    assert worst <= eq5(a - q) + 1e-9


@pytest.mark.parametrize("name", MAPS)
def test_the_radius_is_the_inscribed_ball_of_eq5(scenarios, oracles, checkers, name):
    """The paper's single bound r(q) = (d - delta) / sqrt(1 + r_robot^2), with d from mj_geomDistance (the
    checker, not foam_mj's clearance) and r_robot by hand, except where the bounds cap it (or the oracle's
    distmax caps d). The per-pair radius is never smaller: a geom nearer the axis than r_robot has its own,
    smaller rho."""
    oracle, check, delta = oracles[name], checkers[name], scenarios[name].params.delta
    rng = np.random.default_rng(11)
    clearance_limited = 0
    for q in rng.uniform(LOWER, UPPER, (300, 3)):
        d = check.distance(q)
        from_clearance = (min(d, oracle.clearance.distmax) - delta) / np.sqrt(1 + R_ROBOT**2)
        to_bounds = np.min(np.minimum(q - LOWER, UPPER - q))
        expected = max(min(from_clearance, to_bounds), 0.0)
        assert oracle.radius_from_clearance(min(d, oracle.clearance.distmax), q) == pytest.approx(expected, abs=1e-9)
        assert oracle.radius(q) >= expected - 1e-9
        clearance_limited += bool(0 < from_clearance < to_bounds and d < oracle.clearance.distmax)
    assert clearance_limited >= 50


def test_the_radius_on_the_corridor_centre_line_by_hand(scenarios, oracles, checkers):
    """Walker aligned on the centre line: d = (w - 0.64) / 2, all by hand from the MJCF numbers."""
    for name, q, width in (("walker_corridor", [5.0, 5.0, 0.0], 2.0), ("walker_two_routes", [5.0, 1.1, 0.0], 2.2)):
        d = (width - WALKER_WIDTH) / 2
        assert checkers[name].distance(np.array(q)) == pytest.approx(d, abs=1e-9)
        expected = (d - scenarios[name].params.delta) / np.sqrt(1 + R_ROBOT**2)  # 0.521 m and 0.604 m
        assert oracles[name].radius(q) == pytest.approx(expected, abs=1e-9)
        assert expected > scenarios[name].params.r_min


# -- bubble safety, checked with MuJoCo contacts ------------------------------------------------------------
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), name=st.sampled_from(MAPS))
def test_configurations_inside_a_walker_bubble_never_collide(scenarios, oracles, checkers, seed, name):
    """150 points per bubble (inside and on the sphere) checked with mj_collision; the margin delta holds
    on the sphere (mj_geomDistance)."""
    rng = np.random.default_rng(seed)
    oracle, check, delta = oracles[name], checkers[name], scenarios[name].params.delta
    q = rng.uniform(LOWER, UPPER)
    r = oracle.radius(q)
    if r == 0:
        assert check.distance(q) <= delta + 1e-9 or np.any(np.isclose(q, LOWER) | np.isclose(q, UPPER))
        return
    u = rng.standard_normal((20, 3))
    surface = q + r * u / np.linalg.norm(u, axis=1, keepdims=True)
    for a in np.vstack([_uniform_in_ball(rng, q, r, 130), surface]):
        assert not check.collides(a), f"collision at {a} inside bubble ({q}, {r})"
    for a in surface[:5]:
        assert check.distance(a) >= delta - 1e-9


def test_the_collision_check_catches_an_unsafe_radius(oracles, checkers):
    """The property above could fail: with 3 r(q) the same check finds collisions."""
    rng = np.random.default_rng(7)
    tried = found = 0
    for name in MAPS:
        for _ in range(100):
            q = rng.uniform(LOWER, UPPER)
            r = oracles[name].radius(q)
            if r > 0:
                tried += 1
                found += any(checkers[name].collides(a) for a in _uniform_in_ball(rng, q, 3 * r, 30))
    assert tried >= 50 and found >= tried // 2  # measured: 98 of 106


# -- the foam on the thesis's two maps ------------------------------------------------------------------
def route_crossings(path: np.ndarray, x: float = BLOCK_X) -> np.ndarray:
    """y where the path's (x, y) polyline crosses the vertical line at x (every crossing)."""
    a, b = path[:-1, :2], path[1:, :2]
    cross = (a[:, 0] - x) * (b[:, 0] - x) < 0
    t = (x - a[cross, 0]) / (b[cross, 0] - a[cross, 0])
    return a[cross, 1] + t * (b[cross, 1] - a[cross, 1])


def route_taken(path: np.ndarray) -> str:
    """'short' (south of the central block), 'long' (north of it), or 'mixed'."""
    ys = route_crossings(path)
    if len(ys) and np.all(ys < SHORT_BELOW):
        return "short"
    if len(ys) and np.all(ys > LONG_ABOVE):
        return "long"
    return "mixed"


@pytest.mark.parametrize("name", MAPS)
def test_both_maps_plan_for_twenty_seeds_with_sound_rosaries(scenarios, twenty_plans, name):
    scen = scenarios[name]
    for res in twenty_plans[name]:
        ros, foam = res.rosary, res.foam
        assert res.stats.outcome == "reached"
        assert ros.check_structure() == []
        d = np.linalg.norm(np.diff(ros.centers, axis=0), axis=1)
        np.testing.assert_allclose(d, ros.radii[:-1], rtol=1e-12)  # each child on its parent's surface
        np.testing.assert_array_equal(ros.centers[0], scen.q_init)
        assert np.all(foam.parents[ros.bubble_ids[1:]] == ros.bubble_ids[:-1])
        assert ros.all_in_hatches(ros.center_waypoints())
        assert np.all(foam.radii >= scen.params.r_min)


@pytest.mark.parametrize("name", MAPS)
def test_walker_centre_paths_are_collision_free_under_a_dense_check(scenarios, checkers, twenty_plans, name):
    """mj_collision every 1e-3 in q (max-norm; no footprint point moves more than (sqrt(2) + 0.68) mm
    between samples, against the bubbles' 50 mm margin)."""
    for res in twenty_plans[name]:
        path = res.rosary.path(res.rosary.center_waypoints())
        assert checkers[name].first_collision_along(path, step=1e-3) is None
        if name == "walker_corridor":  # the only way east is the corridor, y = 4.0 .. 6.0
            ys = route_crossings(path)
            assert len(ys) and np.all((ys > 4.0) & (ys < 6.0))


def test_the_two_routes_map_offers_both_routes(twenty_plans, capsys):
    routes = [route_taken(res.rosary.path(res.rosary.center_waypoints())) for res in twenty_plans["walker_two_routes"]]
    counts = {k: routes.count(k) for k in ("short", "long", "mixed")}
    with capsys.disabled():
        print(f"\nwalker_two_routes, seeds 0-19: {counts['short']} short (narrow) route, {counts['long']} long (wide) route")
    assert counts["mixed"] == 0
    # Both routes are taken: the map poses the choice the thesis's Map 2 was built for (over seeds 0-199
    # the short route is taken 75 times; all 20 seeds on one route would have odds below 1e-4).
    assert counts["short"] >= 1 and counts["long"] >= 1
