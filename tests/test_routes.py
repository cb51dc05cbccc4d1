"""Tests for foam_mj.planners.routes: bubbletree's option ``routes`` builds the corridor from further chains
that avoid the first one's middle and keeps the shortest, certified like the default corridor."""

from __future__ import annotations

import re

import numpy as np
import pytest

from foam_mj.planners import PlannerError, PlanningProblem, get_planner
from foam_mj.scenarios import ScenarioError, load_scenario


def _plan(oracle, s, routes: int):
    problem = PlanningProblem(oracle, s.q_init, s.q_goal, delta=oracle.delta, time_limit=30.0)
    return get_planner("bubbletree", routes=routes).plan(problem, seed=0)


def test_a_second_route_on_step_down_is_no_longer_certified_and_collision_free(oracles, checkers):
    """step_down seed 0's first chain takes the long route (about 1.80 in qpos); routes = 2 finds the short one
    (about 1.62), and its rosary is certified bubble by bubble and free under MuJoCo's own dense check."""
    s = load_scenario("step_down")
    oracle, checker = oracles["step_down"], checkers["step_down"]
    one, two = _plan(oracle, s, 1), _plan(oracle, s, 2)
    assert "routes" not in one.stats.details  # the default: one corridor, as before
    info = two.stats.details["routes"]
    assert info["lengths"][0] == pytest.approx(one.stats.details["length"])  # the first route is the default's
    assert info["won"] == 2 and two.stats.details["length"] == pytest.approx(min(info["lengths"]))
    assert two.stats.details["length"] <= one.stats.details["length"]
    assert two.stats.details["length"] < 0.95 * one.stats.details["length"]  # the short route, not a variation
    ros = two.rosary
    assert ros.check_structure() == []
    assert np.all(ros.radii <= oracle.radii(ros.centers) + 1e-9)  # every bubble certified
    # The rosary's bubbles are the foam's (ids renumbered from the bubbles the second chain could use).
    np.testing.assert_array_equal(two.foam.centers[ros.bubble_ids], ros.centers)
    assert ros.all_in_hatches(two.waypoints)  # the corridor's shortest path, through every hatch
    path = ros.path(two.waypoints)
    assert checker.first_collision_along(path, step=2e-3) is None
    assert min(checker.distance(q) for q in path) >= oracle.delta - 1e-6


@pytest.mark.parametrize("value", [0, -1, "2", 2.0])
def test_routes_must_be_an_integer_of_at_least_one(value):
    with pytest.raises(PlannerError, match=re.escape(f"planner 'bubbletree': `routes` must be an integer >= 1, got {value!r}")):
        get_planner("bubbletree", routes=value)
    with pytest.raises(PlannerError, match=re.escape("`routes` must be a number, got True")):  # a boolean is no count
        get_planner("bubbletree", routes=True)


def test_a_scenario_file_sets_routes_in_its_planner_table_and_a_bad_value_is_named(tmp_path):
    from foam_mj.scenarios import SCENARIO_DIR

    text = (SCENARIO_DIR / "step_down.toml").read_text()
    head = text[: text.index("[planner]")].replace("../models/", f"{(SCENARIO_DIR / '../models').resolve()}/")

    def write(value: str):
        p = tmp_path / "s.toml"
        p.write_text(head + f'[planner]\nalgorithm = "bubbletree"\nroutes = {value}\n')
        return p

    assert load_scenario(write("2")).params.planner().options.routes == 2
    for value, message in (("0", "`routes` must be an integer >= 1, got 0"), ('"2"', "[planner] field 'routes' must be a number, got '2'")):
        with pytest.raises(ScenarioError, match=re.escape(message)) as err:
            load_scenario(write(value))
        assert "s.toml" in str(err.value) and "\n" not in str(err.value)


def test_a_corridor_refined_in_steps_is_the_corridor_refined_at_once(oracles, monkeypatch):
    """routes = k lets a further route's one-round probe go on with its rounds (CorridorBuild) instead of building it
    again: one round, a corridor taken, then the remaining rounds give build_corridor's corridor array for array, its
    stats (CPU times aside) and the same random numbers drawn; the corridor taken in between changed nothing."""
    import dataclasses

    import foam_mj.planners.bubbletree as bt
    from foam_mj.planners.corridor import CorridorBuild, build_corridor

    seen = []
    real = bt.build_routes

    def capture(routes, problem, centers, radii, link, options, rng):
        seen.append((problem, centers.copy(), radii.copy(), dataclasses.replace(options, deadline=float("inf")), rng.bit_generator.state))
        return real(routes, problem, centers, radii, link, options, rng)

    monkeypatch.setattr(bt, "build_routes", capture)
    _plan(oracles["step_down"], load_scenario("step_down"), 1)
    problem, centers, radii, options, state = seen[0]
    g1, g2 = np.random.default_rng(), np.random.default_rng()
    g1.bit_generator.state = g2.bit_generator.state = state
    whole = build_corridor(problem, centers, radii, None, options, g1)
    build = CorridorBuild(problem, centers, radii, options, g2)
    build.refine(1)
    probe = build.corridor()
    assert probe.stats["refine_rounds"] == 1 and whole.stats["refine_rounds"] >= 2  # rounds left to go on with
    assert probe.length > whole.length
    build.refine(options.refine_rounds - 1)
    steps = build.corridor()
    for a in ("centers", "radii", "ids", "waypoints", "added_centers", "added_radii"):
        np.testing.assert_array_equal(getattr(steps, a), getattr(whole, a))
    assert steps.length == whole.length
    assert {k: v for k, v in steps.stats.items() if k != "cpu_ms"} == {k: v for k, v in whole.stats.items() if k != "cpu_ms"}
    assert g2.bit_generator.state == g1.bit_generator.state
