"""Tests for foam_mj.foam: propagation (paper 000 section 3.1), the rosary, budgets and failure."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from foam_mj.bubbles import BubbleOracle
from foam_mj.coverage import CoverageIndex, accept_in_order
from foam_mj.errors import ConfigurationError, PlanningFailed
from foam_mj.foam import FoamParams, plan
from foam_mj.model import RobotModel
from foam_mj.scenarios import load_scenario

from conftest import MODELS, MujocoChecker

OBSTACLE = load_scenario("obstacle")
THESIS = load_scenario("obstacle_thesis")


@pytest.fixture(scope="module")
def oracle():
    return OBSTACLE.oracle()


@pytest.fixture(scope="module")
def twenty_plans(oracle):
    return [plan(oracle, OBSTACLE.q_init, OBSTACLE.q_goal, OBSTACLE.params, seed=s) for s in range(20)]


def test_obstacle_plans_for_twenty_seeds_with_a_sound_rosary(twenty_plans):
    for res in twenty_plans:
        ros, foam = res.rosary, res.foam
        assert res.stats.outcome == "reached"
        assert ros.check_structure() == []
        # Each child's centre lies on its parent's surface.
        d = np.linalg.norm(np.diff(ros.centers, axis=0), axis=1)
        np.testing.assert_allclose(d, ros.radii[:-1], rtol=1e-12)
        # Consecutive bubbles overlap; first holds q_init (it is centred there), last holds q_goal.
        assert np.all(d < ros.radii[:-1] + ros.radii[1:])
        np.testing.assert_array_equal(ros.centers[0], OBSTACLE.q_init)
        assert np.linalg.norm(ros.centers[-1] - OBSTACLE.q_goal) <= ros.radii[-1]
        # The rosary follows parents in the foam.
        assert np.all(foam.parents[ros.bubble_ids[1:]] == ros.bubble_ids[:-1])
        assert ros.all_in_hatches(ros.center_waypoints())


def test_centre_paths_are_collision_free_under_a_dense_mujoco_check(twenty_plans, obstacle_robot):
    check = MujocoChecker(obstacle_robot)
    for res in twenty_plans:
        path = res.rosary.path(res.rosary.center_waypoints())
        assert check.first_collision_along(path, step=1e-3) is None


def test_same_seed_same_foam_and_different_seeds_differ(oracle, twenty_plans):
    again = plan(oracle, OBSTACLE.q_init, OBSTACLE.q_goal, OBSTACLE.params, seed=3)
    np.testing.assert_array_equal(again.foam.centers, twenty_plans[3].foam.centers)
    np.testing.assert_array_equal(again.foam.parents, twenty_plans[3].foam.parents)
    assert twenty_plans[0].foam.size != twenty_plans[1].foam.size or not np.array_equal(
        twenty_plans[0].foam.centers[:50], twenty_plans[1].foam.centers[:50]
    )
    gen = plan(oracle, OBSTACLE.q_init, OBSTACLE.q_goal, OBSTACLE.params, seed=np.random.default_rng(3))
    np.testing.assert_array_equal(gen.foam.centers, again.foam.centers)


def test_child_counts_follow_eq_2(oracle):
    """N = K floor(r / r_min)^(n-1): the candidates drawn equal the sum over expanded parents."""
    res = plan(oracle, OBSTACLE.q_init, OBSTACLE.q_goal, OBSTACLE.params, seed=0)
    p = OBSTACLE.params
    expanded = res.foam.radii[: res.stats.parents_expanded]
    assert res.stats.candidates == int(np.sum(p.K * np.floor(expanded / p.r_min) ** 2))
    accounted = (
        res.stats.dropped_out_of_bounds + res.stats.dropped_covered + res.stats.dropped_small + res.stats.bubbles - 1
    )
    assert accounted <= res.stats.candidates


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**31 - 1), thesis=st.booleans())
def test_every_bubble_is_certified_and_none_grew_inside_an_older_one(seed, thesis):
    scen = THESIS if thesis else OBSTACLE
    oracle = scen.oracle()
    try:
        foam = plan(oracle, scen.q_init, scen.q_goal, scen.params, seed=seed).foam
    except PlanningFailed as exc:  # a rare seed misses the goal (the paper's probabilistic method): its foam is checked too
        foam = exc.foam
    fresh = BubbleOracle(RobotModel.from_xml(scen.scene), delta=scen.params.delta)
    certified = fresh.radii(foam.centers)
    assert np.all(foam.radii <= certified + 1e-12)
    assert np.all(foam.radii >= scen.params.r_min)
    assert np.all((foam.centers >= scen.robot.lower) & (foam.centers <= scen.robot.upper))
    # No centre lies strictly inside a bubble that existed before it (its parent's surface is allowed).
    d2 = np.sum((foam.centers[:, None, :] - foam.centers[None, :, :]) ** 2, axis=2)
    inside = d2 < foam.radii[None, :] ** 2 * (1 - 1e-9)
    older = np.tril(np.ones_like(inside), -1)
    assert not np.any(inside & older)


def _tall_wall_scene(tmp_path, height: float = 1.5):
    """A wall taller than the hip between the start's toe (x = 0.24) and the goal's thigh (x > 0.57)."""
    scene = tmp_path / "tall_wall.xml"
    scene.write_text(
        f'<mujoco><include file="{MODELS / "ortholeg.xml"}"/><worldbody>'
        '<geom name="floor" type="plane" size="3 3 0.1"/>'
        f'<geom name="wall" type="box" pos="0.46 0 {height / 2}" size="0.04 0.25 {height / 2}"/>'
        "</worldbody></mujoco>"
    )
    return scene


def test_an_unreachable_goal_fails_within_budget_with_statistics(tmp_path):
    robot = RobotModel.from_xml(_tall_wall_scene(tmp_path))
    oracle = BubbleOracle(robot, delta=0.005)
    params = FoamParams(K=10, r_min=0.07, max_bubbles=50_000, time_limit=30.0)
    with pytest.raises(PlanningFailed) as err:
        plan(oracle, OBSTACLE.q_init, OBSTACLE.q_goal, params, seed=0)
    stats, foam = err.value.stats, err.value.foam
    assert stats.outcome in ("queue empty", "bubble budget", "time budget")
    assert stats.bubbles == foam.size > 1
    assert stats.elapsed < 30.0 + 5.0


def test_the_bubble_budget_stops_the_foam(oracle):
    params = FoamParams(K=10, r_min=0.07, max_bubbles=100)
    with pytest.raises(PlanningFailed) as err:
        plan(oracle, OBSTACLE.q_init, OBSTACLE.q_goal, params, seed=0)
    assert err.value.stats.outcome == "bubble budget"
    assert err.value.foam.size == 100


def test_the_time_budget_stops_the_foam(oracle):
    params = FoamParams(K=10, r_min=0.07, time_limit=1e-4)
    with pytest.raises(PlanningFailed) as err:
        plan(oracle, OBSTACLE.q_init, OBSTACLE.q_goal, params, seed=0)
    assert err.value.stats.outcome == "time budget"


def test_a_start_without_room_for_a_root_bubble_is_refused(oracle):
    with pytest.raises(ConfigurationError, match="root bubble of radius"):
        plan(oracle, [0.2, 0.3, -0.2], OBSTACLE.q_goal, OBSTACLE.params, seed=0)


def test_a_goal_in_collision_is_refused(oracle):
    with pytest.raises(ConfigurationError, match="q_goal"):
        plan(oracle, OBSTACLE.q_init, [0.0, 0.0, 0.5 / 0.7 * np.pi / 2], OBSTACLE.params, seed=0)



def test_a_goal_just_beyond_the_root_bubble_is_not_taken_as_reached(oracle):
    """q_goal half a radius beyond the root bubble: the root does not hold it, so the rosary needs more bubbles and its
    last one holds q_goal (a one-bubble rosary would send the straight path out of the certified ball)."""
    q0 = np.asarray(OBSTACLE.q_init)
    r0 = oracle.radius(q0)
    q_goal = q0 + [0.0, 1.5 * r0, 0.0]  # the knee bent further: free, with room for bubbles above r_min
    assert oracle.radius(q_goal) > OBSTACLE.params.r_min
    res = plan(oracle, q0, q_goal, OBSTACLE.params, seed=0)
    assert res.rosary.k >= 2 and res.rosary.check_structure() == []

PLATE = """<mujoco><compiler angle="radian"/><worldbody>
  <!-- A 1 mm plate 0.58-0.98 m out along y = 0.3: the two-link arm folds its elbow to pass it, with a gap of a few cm. -->
  <geom name="plate" type="box" pos="0.7 0.3 0.1" size="0.2 0.0005 0.2"/>
  <body name="l1" pos="0 0 0.1"><joint name="j1" axis="0 0 1" range="-3 3"/>
    <geom name="c1" type="capsule" fromto="0 0 0 0.5 0 0" size="0.03"/>
    <body name="l2" pos="0.5 0 0"><joint name="j2" axis="0 0 1" range="-2.5 2.5"/>
      <geom name="c2" type="capsule" fromto="0 0 0 0.4 0 0" size="0.025"/></body></body>
</worldbody></mujoco>"""


@pytest.mark.parametrize("variant", ["pfm", "rbpf", "hpf"])
def test_a_foam_that_cannot_pass_a_narrow_way_says_where_it_stopped_and_why(tmp_path, variant):
    """The way past the plate is narrower than bubbles of r_min = 0.07 (bubbletree plans it): the failure named only
    the outcome ("queue empty after 157 bubbles"); it now names the bubble that came nearest q_goal, what blocks the
    way there, and that r_min keeps every bubble larger than the way. The clearance it prints is at the bubble's surface
    point toward q_goal, and so is the q it names beside it (it named the bubble's centre, 0.104 m clear, beside the
    surface's 0.0116 m "there"). Its queue emptied with room left (each bubble draws its candidates once): the failure
    also says where a bubble of r_min still fits, and that point is checked here (on a bubble's surface, in the joint
    box, in no other bubble, a certified radius >= r_min)."""
    from foam_mj.planners import PlanningProblem, get_planner

    (tmp_path / "plate.xml").write_text(PLATE)
    oracle = BubbleOracle(RobotModel.from_xml(tmp_path / "plate.xml"))
    problem = PlanningProblem(oracle, np.array([-0.2, 0.3]), np.array([1.2, 0.3]), delta=oracle.delta, time_limit=20.0)
    with pytest.raises(PlanningFailed, match=r"did not reach q_goal \(queue empty\) after \d+ bubbles in [0-9.]+ s: it came "
                       r"nearest with the bubble at q = \[.*\] \(radius [0-9.]+, its surface [0-9.]+ from q_goal\); at its surface "
                       r"point toward q_goal, q = \[.*\], the clearance is 0\.0\d+ m between c2 and plate; every bubble has radius >= r_min = 0.07, so a way narrower than "
                       r"that stays closed to it: lower r_min, or plan with bubbletree; but the foam is not closed: its random "
                       r"candidates missed room for a bubble of radius [0-9.]+ >= r_min at q = \[.*\], on the surface of the bubble "
                       r"at q = \[.*\] \(each bubble is expanded once, with K floor\(r / r_min\)\^\(n-1\) = 10 floor\(r / 0.07\)\^1 "
                       r"random candidates\): raise K, or plan with bubbletree$") as err:
        get_planner(variant).plan(problem, seed=0)
    m = re.search(r"nearest with the bubble at q = \[([^]]+)\] \(radius ([0-9.]+), .* toward q_goal, q = \[([^]]+)\], the "
                  r"clearance is ([0-9.]+) m", str(err.value))
    centre, surface = (np.array([float(v) for v in m.group(k).split(",")]) for k in (1, 3))
    assert abs(np.linalg.norm(surface - centre) - float(m.group(2))) < 2e-4  # printed to 4 decimals and 3 digits
    assert oracle.explain(surface).clearance == pytest.approx(float(m.group(4)), abs=3e-4)  # q to 4 decimals, links < 1.5 m
    assert oracle.explain(centre).clearance > float(m.group(4)) + 0.05  # the centre is far clearer: not what is printed
    x, c = (np.array([float(v) for v in g.split(",")]) for g in re.search(
        r"missed room for a bubble of radius [0-9.]+ >= r_min at q = \[([^]]+)\], on the surface of the bubble at q = \[([^]]+)\]",
        str(err.value)).groups())
    foam = err.value.foam
    i = int(np.argmin(np.linalg.norm(foam.centers - c, axis=1)))
    assert np.linalg.norm(foam.centers[i] - c) < 1e-4 and abs(np.linalg.norm(x - c) - foam.radii[i]) < 2e-4  # printed to 4 decimals
    assert np.all((x >= oracle.robot.lower) & (x <= oracle.robot.upper)) and oracle.radii(x[None])[0] >= 0.07 - 2e-4
    others = np.arange(len(foam.radii)) != i
    assert np.all(np.linalg.norm(foam.centers[others] - x, axis=1) >= foam.radii[others] - 2e-4)
    assert get_planner("bubbletree").plan(problem, seed=0).rosary.check_structure() == []
    oracle.close()


@pytest.mark.parametrize("field, value", [("K", 0), ("K", 2.5), ("r_min", 0.0), ("delta", -1.0), ("max_bubbles", 0), ("time_limit", 0)])
def test_bad_planner_parameters_name_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        FoamParams(**{field: value})


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n_balls=st.integers(1, 700))
def test_coverage_index_agrees_with_brute_force(seed, n_balls):
    rng = np.random.default_rng(seed)
    idx = CoverageIndex(3, capacity=8)
    centers = rng.uniform(0, 1, (n_balls, 3))
    radii = rng.uniform(0.01, 0.2, n_balls)
    for c, r in zip(centers, radii):
        idx.add(c, r)
    pts = rng.uniform(0, 1, (300, 3))
    exclude = rng.integers(-1, n_balls, 300)
    inside = np.sum((pts[:, None] - centers[None]) ** 2, axis=2) < radii[None] ** 2
    rows = np.flatnonzero(exclude >= 0)
    inside[rows, exclude[rows]] = False
    np.testing.assert_array_equal(idx.covered(pts, exclude), inside.any(axis=1))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), m=st.integers(0, 300), dim=st.integers(1, 5), chain=st.booleans())
def test_siblings_are_accepted_exactly_as_one_by_one(seed, m, dim, chain):
    rng = np.random.default_rng(seed)
    if chain:  # long chains of overlaps: centres along a line, each just inside the previous one's bubble
        cand = np.cumsum(rng.uniform(0.05, 0.1, (m, 1)) * np.ones((1, dim)), axis=0)
        r = np.full(m, 0.1 * np.sqrt(dim) * 1.01)
    else:
        cand = rng.uniform(0, 1, (m, dim))
        r = rng.uniform(0.01, 0.4, m)
    accepted = []
    for i in range(m):  # the rule, one candidate at a time
        accepted.append(not any(np.sum((cand[i] - cand[j]) ** 2) < r[j] ** 2 for j in range(i) if accepted[j]))
    np.testing.assert_array_equal(accept_in_order(cand, r), np.array(accepted, dtype=bool))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), rounds=st.integers(1, 12), dim=st.integers(2, 5))
def test_coverage_index_agrees_with_brute_force_as_the_foam_queries_it(seed, rounds, dim):
    """Balls added in batches between queries (tree, recent buffer and the largest balls all in play), each
    query point on the surface of the ball it excludes, as a candidate on its parent's surface."""
    rng = np.random.default_rng(seed)
    idx = CoverageIndex(dim, capacity=16)
    centers, radii = np.empty((0, dim)), np.empty(0)
    for _ in range(rounds):
        k = int(rng.integers(1, 120))
        c = rng.uniform(0, 1, (k, dim))
        r = np.where(rng.random(k) < 0.05, rng.uniform(0.2, 0.5, k), rng.uniform(0.02, 0.1, k))
        idx.add(c, r)
        centers, radii = np.vstack([centers, c]), np.concatenate([radii, r])
        parent = rng.integers(0, len(radii), 400)
        u = rng.standard_normal((400, dim))
        pts = centers[parent] + radii[parent, None] * (u / np.linalg.norm(u, axis=1, keepdims=True))
        inside = np.sum((pts[:, None] - centers[None]) ** 2, axis=2) < radii[None] ** 2
        inside[np.arange(400), parent] = False
        np.testing.assert_array_equal(idx.covered(pts, parent), inside.any(axis=1))
