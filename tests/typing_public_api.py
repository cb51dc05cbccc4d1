"""What a type checker sees of foam-mj's public API, as the README uses it: checked by mypy in CI (.ci/run), never
run (pytest does not collect it: no test_ prefix). Each ``assert_type`` fails the check when a name or a result
loses its type (the package's own attributes, imported on first use, were all ``Any`` to mypy and pyright)."""

from __future__ import annotations

from typing import assert_type

import numpy as np

import foam_mj
from foam_mj.bubbles import BubbleOracle
from foam_mj.errors import PlanningFailed
from foam_mj.foam import Foam
from foam_mj.pipeline import Outcome, PathOutcome, run
from foam_mj.planners import Planner, PlanningProblem, PlanResult, PlanStats, get_planner, register
from foam_mj.planners.base import NoOptions
from foam_mj.rosary import Rosary
from foam_mj.scenarios import Scenario, load_scenario
from foam_mj.smoothing import SmoothingResult, Smoother, get_smoother
from foam_mj.trajectory import Trajectory


def readme_seam() -> None:
    s = load_scenario("obstacle")
    oracle = s.oracle()
    problem = PlanningProblem(oracle, s.q_init, s.q_goal, delta=oracle.delta, time_limit=10.0)
    result = get_planner("bubbletree").plan(problem, seed=0)
    assert_type(result, PlanResult)
    assert_type(result.rosary, Rosary)
    assert_type(result.foam, Foam)
    assert_type(result.stats, PlanStats)
    assert_type(result.stats.time_to_first_path, float | None)
    smoothed = get_smoother("optimal").smooth(result.rosary, seed=0)
    assert_type(smoothed, SmoothingResult)
    assert_type(smoothed.waypoints, np.ndarray)
    assert_type(smoothed.length, float)


def readme_run() -> None:
    out = run(load_scenario("step_up"), smoothers="convex")
    assert_type(out, Outcome)
    po = out.paths["convex"]
    assert_type(po, PathOutcome)
    assert_type(po.metrics.length, float)
    assert_type(po.trajectory, Trajectory | None)  # None: no timing fits the limits (po.timing_error says why)
    if po.trajectory is not None:
        assert_type(po.trajectory.times, np.ndarray)


def package_attributes() -> None:
    s = foam_mj.load_scenario("obstacle")
    assert_type(s, Scenario)
    oracle = s.oracle()
    assert_type(oracle, BubbleOracle)
    problem = foam_mj.PlanningProblem(oracle, s.q_init, s.q_goal, delta=oracle.delta)
    planner = foam_mj.get_planner("bubbletree")
    assert_type(planner, Planner)
    result = planner.plan(problem, seed=0)
    assert_type(result, foam_mj.PlanResult)
    assert_type(foam_mj.get_smoother("optimal"), Smoother)
    assert_type(foam_mj.get_smoother("optimal").smooth(result.rosary, seed=0), SmoothingResult)
    assert_type(foam_mj.run(s), Outcome)
    assert_type(foam_mj.PLANNERS, dict[str, type[Planner]])
    assert_type(foam_mj.available_scenarios(), list[str])
    try:
        foam_mj.run(s)
    except foam_mj.PlanningFailed as exc:
        assert_type(exc, PlanningFailed)
    # A misspelt name is an error (this ignore is then used: warn_unused_ignores holds for this file in pyproject.toml)
    foam_mj.get_planer  # type: ignore[attr-defined]


class MyPlanner(Planner):
    """A planner of one's own, as the README adds one: register() gives the class back with its own type."""

    name = "mine"
    Options = NoOptions

    def plan(self, problem: PlanningProblem, seed: int | np.random.Generator = 0, progress: object = None) -> PlanResult:
        raise PlanningFailed("not today")


assert_type(register(MyPlanner), type[MyPlanner])
