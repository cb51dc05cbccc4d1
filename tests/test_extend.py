"""Tests for foam_mj.planners.extend: bubbletree's extension step."""

from __future__ import annotations

import numpy as np
import pytest

import foam_mj.planners.extend as extend


@pytest.mark.parametrize("scene", ["obstacle", "step_down"])
def test_sizing_the_candidates_a_step_at_a_time_grows_the_same_trees_with_fewer_queries(monkeypatch, scene):
    """Above BY_STEP_PAIRS checked pairs (where a query is dear: MuJoCo Menagerie's arms) the candidates of an
    extension are sized the farthest step first, a nearer one only where no farther candidate is good. The child is the
    farthest good candidate either way, so the foam, the rosary and the path are the same to the last bit, and the
    queries saved are those of the nearer candidates of extensions whose farthest one is good."""
    from foam_mj.bubbles import BubbleOracle
    from foam_mj.planners import PlanningProblem, get_planner
    from foam_mj.scenarios import load_scenario

    s = load_scenario(scene)
    oracle = BubbleOracle(s.robot, delta=0.005)
    assert len(s.robot.pairs) < extend.BY_STEP_PAIRS  # the leg is sized in one batch by default

    def plan():
        return get_planner("bubbletree").plan(PlanningProblem(oracle, s.q_init, s.q_goal, delta=0.005), seed=3)

    whole = plan()
    monkeypatch.setattr(extend, "BY_STEP_PAIRS", 0)
    stepped = plan()
    for a, b in ((whole.foam.centers, stepped.foam.centers), (whole.foam.radii, stepped.foam.radii),
                 (whole.rosary.centers, stepped.rosary.centers), (whole.rosary.radii, stepped.rosary.radii),
                 (whole.waypoints, stepped.waypoints)):
        assert np.array_equal(a, b)
    saved = whole.stats.details["candidates"] - stepped.stats.details["candidates"]
    assert saved > 0.05 * whole.stats.details["candidates"]
    assert whole.stats.distance_queries - stepped.stats.distance_queries == saved
