"""Tests for foam_mj.bubbles: the displacement bound rho and the certified bubble radius (paper 003 Eq. 4)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
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
