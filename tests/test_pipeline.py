"""foam_mj.pipeline.run, the Python form of ``foam-mj plan``: its arguments are checked before any planning."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foam_mj.errors import FoamError
from foam_mj.pipeline import PATH_NAMES, run
from foam_mj.scenarios import load_scenario
from foam_mj.limits import Limits


@pytest.fixture
def no_planning(monkeypatch):
    """Fail the test if run() reaches the planner."""

    def planned(*_args, **_kwargs):
        raise AssertionError("run() planned before refusing its arguments")

    monkeypatch.setattr("foam_mj.pipeline.plan_scenario", planned)


@pytest.mark.parametrize(
    ("kwargs", "error", "names"),
    [
        ({"time_law": "fast"}, ValueError, "`time_law` must be one of ('toppra', 'own'), got 'fast'"),
        ({"limits": Limits(torque=(150, 60))}, ValueError, "limits `torque` must have 3 numbers"),
        ({"smoothers": ("optimal", "hs_typo")}, FoamError, "unknown path name(s) ['hs_typo']"),
        ({"smoothers": "convex,nope"}, FoamError, "unknown smoother 'nope'"),
        ({"seed": np.random.default_rng(0)}, FoamError, "`seed` must be an integer in [0, 2**63 - 1] (the result records it"),
        ({"seed": -1}, FoamError, "`seed` must be an integer in [0, 2**63 - 1]"),
        # "no" is truthy: the replays ran (and took their time) where the caller asked for none
        ({"replay": "no"}, TypeError, "`replay` must be True or False, got 'no'"),
        ({"dynamic": "false"}, TypeError, "`dynamic` must be True or False, got 'false'"),
        ({"require_timing": None}, TypeError, "`require_timing` must be True or False, got None"),
    ],
)
def test_bad_arguments_are_named_before_any_planning(no_planning, kwargs, error, names):
    with pytest.raises(error) as exc:
        run(load_scenario("obstacle"), **kwargs)
    assert names in str(exc.value)


def test_smoothers_take_path_names_or_a_smoother_value():
    scenario = load_scenario("step_up")
    by_value = run(scenario, None, "adjust", replay=False)
    by_names = run(scenario, None, ("centre", "adjusted", "adjusted_gradient"), replay=False)
    assert list(by_value.paths) == list(by_names.paths) == ["centre", "adjusted", "adjusted_gradient"]
    assert set(by_value.paths) <= set(PATH_NAMES)


def test_progress_says_how_long_each_replay_runs():
    """A slow timing (a velocity limit of 1e-3 rad/s gave 1,679 s of motion) made a replay of minutes behind a bare
    "replaying" line: the progress now says how many seconds of motion and simulation steps each replay has."""
    messages: list[str] = []
    out = run(load_scenario("step_up"), None, ("optimal",), dynamic=False, report=messages.append)
    for name in ("centre", "optimal"):
        times = out.paths[name].trajectory.times
        assert any(m.startswith("replaying: ") and f"({times[-1]:,.1f} s of motion, {len(times):,} steps)" in m
                   for m in messages), messages


def test_rosary_adjustment_runs_on_a_variant_rosary_whose_root_is_below_r_min():
    """gbpf grows from a start whose bubble (0.039) is below r_min = 0.07; the adjustment asked every bubble for
    r_min, refused the rosary and plan left T_RA and T_RCA out with a note blaming the planner ('gbpf's chain is
    not one, use --planner pfm', which refuses that start). The bound is now the smaller of r_min and the rosary's
    smallest radius; every adjusted bubble is still within its certified radius."""
    from foam_mj.data import model_path
    from foam_mj.scenarios import scenario_from_dict

    doc = {"name": "near_box", "scene": str(model_path("obstacle.xml")), "q_init": [0.219375, 0.311904, 0.186175],
           "q_goal": [0.45, 0.4536, 1.45], "planner": {"algorithm": "gbpf", "r_min": 0.07}}
    scenario = scenario_from_dict(doc, ".")
    out = run(scenario, 0, "adjust", replay=False)
    assert out.plan.rosary.radii[0] < 0.07
    adjusted = out.paths["adjusted"].rosary
    oracle = scenario.oracle()
    assert (adjusted.radii <= oracle.radii(adjusted.centers) + 1e-12).all()
    assert out.paths["adjusted"].metrics.tc > out.paths["centre"].metrics.tc
    assert "adjusted_gradient" in out.paths


def test_a_registered_planner_runs_through_the_pipeline_and_an_uncertified_rosary_is_refused(monkeypatch):
    # The pipeline (and so `foam-mj plan`) trusted any registered planner's rosary: one whose bubble was larger than
    # the certified radius was smoothed, timed and written with paths 70 mm inside an obstacle. Now it is refused,
    # naming the planner and the bubble, before any smoothing.
    import dataclasses

    import numpy as np

    from foam_mj.planners import PLANNERS, get_planner, register
    from foam_mj.planners.base import Planner, PlanResult
    from foam_mj.rosary import Rosary

    monkeypatch.setattr("foam_mj.planners.PLANNERS", dict(PLANNERS))

    @dataclasses.dataclass(frozen=True)
    class WrappedOptions:
        inflate: float = 1.0

    @register
    class Wrapped(Planner):
        name = "wrapped"
        Options = WrappedOptions

        def plan(self, problem, seed=0, progress=None):
            res = get_planner("bubbletree").plan(problem, seed)
            r = res.rosary
            radii = r.radii.copy()
            radii[len(radii) // 2] *= self.options.inflate
            return PlanResult(res.foam, Rosary(r.centers, radii, r.q_init, r.q_goal), res.stats)

    s = load_scenario("obstacle")
    s = dataclasses.replace(s, params=s.params.with_algorithm("wrapped"))
    out = run(s, smoothers="convex", replay=False)
    assert out.plan.stats.outcome == "reached" and set(out.paths) == {"centre", "convex"}
    s = dataclasses.replace(s, params=dataclasses.replace(s.params, options={"inflate": 1.5}))
    with pytest.raises(RuntimeError, match=r"planner 'wrapped' returned an uncertified rosary: bubble \d+ has radius"):
        run(s, smoothers="convex", replay=False)
    assert np.isfinite(out.paths["convex"].metrics.length)


def test_the_replays_measure_a_margin_above_one_metre(tmp_path):
    # The replays' clearance was capped at 1 m: a path 2.6 m clear of the wall, planned with delta = 1.2 m, was reported
    # as "min clearance 1000.0 mm" below its margin (foam-mj replay: exit 4 on a correct result).
    from test_planners import FAR_WALL

    from foam_mj.scenarios import scenario_from_dict

    (tmp_path / "far.xml").write_text(FAR_WALL)
    s = scenario_from_dict({"scene": "far.xml", "q_init": [-0.5], "q_goal": [0.5], "planner": {"delta": 1.2}}, tmp_path)
    out = run(s, smoothers="convex")
    for po in out.paths.values():
        assert po.kinematic.min_clearance > 1.2 and po.dynamic.min_clearance > 1.2


def test_a_path_that_no_timing_fits_fails_alone_and_the_others_keep_their_results():
    """With the hip's torque limit at 52 N m, gravity alone asks 56 N m along obstacle's centre path, and less along the
    convex and optimal paths. One path's TimingInfeasible ended the whole run: the other smoothers' timed, replayed
    paths were lost. Now that path keeps its error and no trajectory, and the others are timed and replayed."""
    out = run(load_scenario("obstacle"), 0, ("convex", "optimal"), dynamic=False, limits=Limits(torque=(52.0, 400.0, 3000.0)))
    centre = out.paths["centre"]
    assert centre.trajectory is None and centre.kinematic is None
    assert "no timing fits the torque limit of hip_flexion" in str(centre.timing_error) and centre.timing_error.joint == "hip_flexion"
    for name in ("convex", "optimal"):
        po = out.paths[name]
        assert po.timing_error is None and po.trajectory is not None and po.kinematic.min_clearance > 0.005


def test_when_no_path_has_a_timing_the_run_fails():
    """Limits that fit no path leave nothing to replay: run raises the first path's TimingInfeasible, as before."""
    from foam_mj.timing import TimingInfeasible

    with pytest.raises(TimingInfeasible, match=r"path 'centre': no timing fits the torque limit of hip_flexion"):
        run(load_scenario("obstacle"), 0, ("optimal",), dynamic=False, limits=Limits(torque=(40.0, 400.0, 3000.0)))


@settings(max_examples=4, deadline=None)
@given(
    planner=st.sampled_from(["bubbletree", "pfm", "gbpf", "hpf"]),
    depth=st.one_of(st.floats(0.002, 0.006), st.floats(0.05, 0.35)), width=st.floats(0.1, 0.9), height=st.floats(0.003, 0.25),
    x=st.floats(0.35, 0.65), y=st.floats(-0.1, 0.1), z=st.floats(0.0, 0.3),
    turn=st.tuples(*[st.sampled_from([0.0, -35.0, -10.0, 20.0, 40.0])] * 3),
    delta=st.sampled_from([0.0, 0.001, 0.005, 0.02]), seed=st.integers(0, 2**31 - 1),
)
def test_every_smoothed_path_and_its_timed_trajectory_keep_delta_around_a_moved_turned_resized_box(
    planner, depth, width, height, x, y, z, turn, delta, seed
):
    """The obstacle scene's box moved up to 15 cm along the walk, 10 cm sideways and up to 30 cm off the floor, 2 mm
    (a plate) to 35 cm deep, turned about any of x, y, z (the scenario's [obstacle] edits), at margins 0-20 mm, planned
    by the default or a PFM variant and smoothed by optimal, gradient and convex: an end point closer than delta is
    refused naming its clearance (pfm's r_min rule, or a variant's failure, is its own); else MuJoCo alone finds every
    returned path, sampled every 2 mrad, and every row of its timed trajectory at least delta from the box and the floor.
    (An outside sweep of 50 such scenes x 5 planners x every smoother found none closer; this keeps it so.)"""
    import mujoco

    from conftest import MODELS, MujocoChecker
    from foam_mj.errors import ConfigurationError, PlanningFailed, ScenarioError
    from foam_mj.scenarios import scenario_from_dict

    doc = {"name": "moved_box", "scene": "obstacle.xml", "q_init": [0.2, 0.3, 0.08], "q_goal": [0.45, 0.4536, 1.45],
           "obstacle": {"size": [depth, width, height], "pos": [x, y, z], "euler": list(turn)},
           "planner": {"algorithm": planner, "delta": delta, "time_limit": 20.0}}
    try:
        s = scenario_from_dict(doc, MODELS)
    except ScenarioError as exc:
        assert re.search(r"field 'q_(init|goal)' = .* (is in collision|is too close to an obstacle): clearance -?\d", str(exc)), exc
        return
    try:
        out = run(s, seed=seed, smoothers=("optimal", "gradient", "convex"), dynamic=False)
    except (ConfigurationError, PlanningFailed) as exc:
        assert planner != "bubbletree" or "too close to an obstacle" in str(exc), exc
        return
    checker = MujocoChecker(s.robot)
    m, d = checker.m, checker.d
    for name, po in out.paths.items():
        path = np.asarray(po.result.path)
        for a, b in zip(path[:-1], path[1:]):
            for q in a + (b - a) * np.linspace(0.0, 1.0, int(np.ceil(np.max(np.abs(b - a)) / 2e-3)) + 1)[:, None]:
                assert checker.distance(q) >= delta - 1e-9, (name, q)
        for row in po.trajectory.qpos:
            d.qpos[:] = row
            mujoco.mj_kinematics(m, d)
            assert min(mujoco.mj_geomDistance(m, d, g, o, 10.0, None) for g in checker.leg for o in checker.obs) >= delta - 1e-9, name
