"""The whole job behind ``foam-mj plan``: plan the foam, smooth, time-parametrize, replay, record.

Path names (used in the summary, the JSON result and the Rerun recording):

==================  ==========================================================  ==================================
name                what it is                                                  paper
==================  ==========================================================  ==================================
centre              the polyline through the rosary's centres                   T (Nascimento and Alsina 2021)
gradient            the centre path smoothed by gradient descent of SV (Eq. 9)  T_CA (Nascimento and Alsina 2021)
adjusted            centre path of the rosary adjusted by TC ascent (Eq. 8)     T_RA (Nascimento and Alsina 2021)
adjusted_gradient   the adjusted path smoothed by Eq. 9                         T_RCA (Nascimento and Alsina 2021)
hs                  Harmony Search on f (Eq. 5)                                 Nascimento et al. 2020, 5.1
ga                  the genetic algorithm on f (Eq. 5)                          Nascimento et al. 2020, 5.2
convex              the shortest path through the hatches (SOCP)                reference
optimal             f (Eq. 5) minimised in the hatches, KKT-certified           Nascimento et al. 2020 (Eq. 5)
mgoa                knee of MGOA's Pareto front (length, angle term)            Elmi and Efe 2018
mopso               knee of MOPSO's Pareto front (length, angle term)           Elmi and Efe 2018
==================  ==========================================================  ==================================


``foam-mj plan`` makes the centre path and, unless told otherwise, the optimal one
(:data:`DEFAULT_SMOOTHER`); ``--smoother all`` runs every method of the papers beside it, and the convex
reference (not mgoa or mopso). The optimal path's certificate (KKT residuals, ``certified``) is in its
``result.info``.

For mgoa and mopso the whole front is in ``result.info["front"]`` (waypoints (F, k-1, n), paths
(F, k+1, n), objectives (F, 2), objective_names, knee, extremes = (shortest, smoothest)) and the
:class:`~foam_mj.smoothing.multiobjective.ParetoResult` in ``result.info["pareto"]``.

Every path keeps its waypoints in its rosary's hatches; the trajectory built on it is certified to
stay inside the same bubbles (foam_mj.trajectory), and the kinematic replay measures its clearance
with MuJoCo.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np

from foam_mj.errors import ConfigurationError, FoamError
from foam_mj.planners import PlanResult
from foam_mj.planners.base import check_result, smoother_start
from foam_mj.paths import PathMetrics, metrics
from foam_mj.replay import DynamicReplay, KinematicReplay, replay_clearance, replay_dynamic, replay_kinematic
from foam_mj.rosary import Rosary
from foam_mj.scenarios import Scenario
from foam_mj.smoothing import (
    ConvexShortestPath,
    GeneticAlgorithm,
    GradientSmoothing,
    HarmonySearch,
    MGOASmoother,
    MOPSOSmoother,
    OptimalSmoother,
    RosaryAdjustment,
    SmoothingResult,
    StopCriteria,
)
from foam_mj.smoothing.gradient import center_path_result
from foam_mj.smoother_names import DEFAULT_SMOOTHER, LABELS, PATH_NAMES, SMOOTHERS, parse_smoothers
from foam_mj.dynamics import JointLoads, joint_loads
from foam_mj.limits import Limits, as_limits
from foam_mj.timing import DEFAULT_METHOD as DEFAULT_TIME_LAW, METHODS as TIME_LAWS, TimingInfeasible, time_path
from foam_mj.trajectory import JointLimits, Trajectory

if TYPE_CHECKING:
    from foam_mj.clearance import Clearance
    from foam_mj.model import RobotModel

@dataclass
class PathOutcome:
    """One path: its smoothing result, trajectory and replays."""

    name: str
    result: SmoothingResult
    metrics: PathMetrics
    trajectory: Trajectory | None = None
    kinematic: KinematicReplay | None = None
    dynamic: DynamicReplay | None = None
    loads: JointLoads | None = None  # torques, power and work along the trajectory (foam_mj.dynamics)
    timing_error: TimingInfeasible | None = None  # why no timing of this path fits the limits (then no trajectory)

    @property
    def label(self) -> str:
        return LABELS.get(self.name, self.name)

    @property
    def rosary(self) -> Rosary:
        return self.result.rosary


@dataclass
class Outcome:
    """Everything ``foam-mj plan`` computed."""

    scenario: Scenario
    seed: int
    plan: PlanResult
    paths: dict[str, PathOutcome] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    limits: Limits = field(default_factory=Limits)  # the time law's limits (foam_mj.timing)
    time_law: str = DEFAULT_TIME_LAW
    rosary_distances: np.ndarray | None = None  # (k, P) d_p at the rosary's centres (plan's capping-pair note)


Report = Callable[[str], None]


def plan_scenario(scenario: Scenario, seed: int, report: Report | None = None) -> PlanResult:
    """Plan with the scenario's planner (``scenario.params.algorithm``, from :data:`foam_mj.planners.PLANNERS`); its
    result is checked certified (:func:`~foam_mj.planners.base.check_result`) before anything uses it.

    Raises PlanningFailed with every bubble grown when the goal is not reached."""
    planner = scenario.params.planner()
    oracle = scenario.oracle()
    try:
        problem = scenario.params.problem(oracle, scenario.q_init, scenario.q_goal)
        result = planner.plan(
            problem,
            seed=seed,
            progress=None if report is None else (lambda st: report(
                f"planning ({planner.name}): {st.bubbles:,} of at most {problem.max_bubbles:,} bubbles, "
                f"{st.elapsed:.1f} s of {problem.time_limit:g} s{f'; {st.note}' if st.note else ''}")),
        )
        return check_result(result, problem, planner.name)
    finally:
        oracle.close()


def _iterations(report: Report | None, method: str, unit: str, stop: StopCriteria) -> Callable[[int, float], None] | None:
    """A progress callback for HS or the GA that tells ``report`` the iterations done, their cap and the best f."""
    if report is None:
        return None
    cap = f" of at most {stop.max_iterations:,}" if stop.max_iterations is not None else ""
    return lambda t, best: report(f"smoothing: {method}, {unit} {t:,}{cap}, best f {best:.4f}")


@contextmanager
def _stage(say: Report, text: str) -> Iterator[None]:
    """``say`` ``text`` as a stage starts, and that it is done with its time when it ends (a line of its own off a terminal)."""
    say(text)
    t0 = time.perf_counter()
    yield
    say(f"{text} done in {time.perf_counter() - t0:.1f} s")


def smooth_paths(scenario: Scenario, rosary: Rosary, names: tuple[str, ...], seed: int, report: Report | None = None,
                 start: np.ndarray | None = None) -> dict[str, SmoothingResult]:
    """Run the smoothers that produce ``names`` (the centre path always comes first). ``start``: the
    planner's shortest path through the rosary (``PlanResult.waypoints``), the ``optimal`` smoother's start
    when valid (it saves that smoother's own start program)."""
    out: dict[str, SmoothingResult] = {"centre": center_path_result(rosary, "centre")}
    say = report or (lambda _s: None)
    if "gradient" in names:
        with _stage(say, "smoothing: gradient (T_CA)"):
            out["gradient"] = GradientSmoothing().smooth(rosary)
    if "adjusted" in names or "adjusted_gradient" in names:
        say("smoothing: rosary adjustment (T_RA)")
        t0 = time.perf_counter()
        oracle = scenario.oracle()
        try:
            # Nascimento and Alsina 2021 keeps every adjusted bubble at least r_min; a planner without r_min keeps the rosary's
            # smallest, and so does a root bubble below r_min (gbpf, rbpf and hpf grow from a start that close to an obstacle).
            smallest = float(np.min(rosary.radii))
            r_min = min(getattr(scenario.params.planner().options, "r_min", None) or smallest, smallest)
            adj = RosaryAdjustment(r_min=r_min).adjust(rosary, oracle)
        except ValueError as exc:
            # T_RA moves the centres of a foam's rosary (each child on its parent's surface, radius >= r_min);
            # a chain from another planner (bubbletree) is not one: those two paths are left out.
            if "does not satisfy the adjustment's constraints" not in str(exc):
                raise
            adj = None
            say(f"smoothing: rosary adjustment skipped ({exc})")
        finally:
            oracle.close()
        if adj is not None:
            say(f"smoothing: rosary adjustment (T_RA) done in {time.perf_counter() - t0:.1f} s")
            out["adjusted"] = adj.path
            if "adjusted_gradient" in names:
                with _stage(say, "smoothing: adjusted + gradient (T_RCA)"):
                    out["adjusted_gradient"] = GradientSmoothing().smooth(adj.rosary)
    if "hs" in names:
        with _stage(say, "smoothing: harmony search"):
            hs = HarmonySearch()
            out["hs"] = hs.smooth(rosary, seed=seed, progress=_iterations(report, "harmony search", "improvisation", hs.stop))
    if "ga" in names:
        with _stage(say, "smoothing: genetic algorithm"):
            ga = GeneticAlgorithm()
            out["ga"] = ga.smooth(rosary, seed=seed, progress=_iterations(report, "genetic algorithm", "generation", ga.stop))
    if "convex" in names:
        with _stage(say, "smoothing: convex shortest path"):
            out["convex"] = ConvexShortestPath().smooth(rosary)
    if "optimal" in names:
        with _stage(say, "smoothing: optimal f (sequential convex programming)"):
            out["optimal"] = OptimalSmoother().smooth(rosary, initial=smoother_start(rosary, start), seed=seed)
    if "mgoa" in names:
        with _stage(say, "smoothing: multi-objective grasshopper optimisation (MGOA)"):
            out["mgoa"] = MGOASmoother().smooth(rosary, seed=seed)
    if "mopso" in names:
        with _stage(say, "smoothing: multi-objective particle swarm (MOPSO)"):
            out["mopso"] = MOPSOSmoother().smooth(rosary, seed=seed)
    for name, res in out.items():
        if not res.rosary.all_in_hatches(res.waypoints):  # the smoothers guarantee it; a last guard
            raise RuntimeError(f"path '{name}' has a waypoint outside its hatch")
    return out


def run(
    scenario: Scenario,
    seed: int | None = None,
    smoothers: str | Sequence[str] = SMOOTHERS[DEFAULT_SMOOTHER],
    *,
    replay: bool = True,
    dynamic: bool = True,
    limits: Limits | JointLimits | None = None,
    time_law: str | None = None,
    report: Report | None = None,
    require_timing: bool = True,
) -> Outcome:
    """Plan, smooth, build trajectories and replay them (kinematically, and dynamically when asked).

    ``smoothers`` are path names of :data:`PATH_NAMES`, or a ``--smoother`` value (:func:`parse_smoothers`);
    by default those of :data:`DEFAULT_SMOOTHER`, as ``foam-mj plan``. The centre path is always there; every
    path is time-parametrized and replayed; a path that no timing fits keeps its ``timing_error`` (and no trajectory)
    while the others are replayed, and TimingInfeasible is raised only when no path has a timing (without
    ``require_timing``, the outcome is returned then too, every path with its ``timing_error``: a sweep's rows). Unknown path names,
    a ``time_law`` not in ("toppra", "own") and ``limits`` of the wrong length are refused before any planning, by an
    error that names the argument.
    """
    if not isinstance(scenario, Scenario):
        raise TypeError(f"run() takes a Scenario (load_scenario(name) or scenario_from_dict(...)), got {type(scenario).__name__}")
    seed = scenario.seed if seed is None else seed
    if not (isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and 0 <= seed <= 2**63 - 1):
        raise ConfigurationError(f"`seed` must be an integer in [0, 2**63 - 1] (the result records it; a planner's plan() "
                                 f"also takes a numpy Generator), got {seed!r}")
    seed = int(seed)
    if isinstance(smoothers, str):
        smoothers = parse_smoothers(smoothers)
    if not (isinstance(smoothers, (tuple, list)) and all(isinstance(name, str) for name in smoothers)):
        raise TypeError(f"`smoothers` must be path names or a --smoother value such as 'convex,optimal', got {smoothers!r}")
    smoothers = tuple(smoothers)
    for name, flag in (("replay", replay), ("dynamic", dynamic), ("require_timing", require_timing)):
        if not isinstance(flag, (bool, np.bool_)):  # "no" is truthy: the replays would run
            raise TypeError(f"`{name}` must be True or False, got {flag!r}")
    if report is not None and not callable(report):
        raise TypeError(f"`report` must be None or a callable taking a message (str), got {type(report).__name__}")
    unknown = [name for name in smoothers if name not in PATH_NAMES]
    if unknown:
        raise FoamError(f"`smoothers`: unknown path name(s) {unknown}; known: {', '.join(PATH_NAMES)} (or a --smoother value such as 'all')")
    time_law = time_law or getattr(scenario, "time_law", None) or DEFAULT_TIME_LAW
    if time_law not in TIME_LAWS:
        raise ValueError(f"`time_law` must be one of {TIME_LAWS}, got {time_law!r}")
    lim = as_limits(limits if limits is not None else getattr(scenario, "limits", None))
    lim.resolve(scenario.robot)  # a limit list of the wrong length is named before any planning
    t0 = time.perf_counter()
    result = plan_scenario(scenario, seed, report)
    outcome = Outcome(scenario, seed, result, limits=lim, time_law=time_law)
    outcome.timings["plan"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    smoothed = smooth_paths(scenario, result.rosary, smoothers, seed, report, start=result.waypoints)
    outcome.timings["smooth"] = time.perf_counter() - t1
    robot = scenario.robot
    t2 = time.perf_counter()
    clearance = replay_clearance(robot, scenario.params.delta)
    try:
        outcome.rosary_distances = clearance.batch_pairs(np.asarray(result.rosary.centers, dtype=float))
        for name, res in smoothed.items():
            po = PathOutcome(name, res, metrics(res.path))
            outcome.paths[name] = po
            if replay:
                time_and_replay(po, robot, res.path, lim, time_law, clearance, dynamic, report)
    finally:
        clearance.close()
    if require_timing:
        require_a_timing(outcome.paths)
    outcome.timings["replay"] = time.perf_counter() - t2
    outcome.timings["total"] = time.perf_counter() - t0
    return outcome


def time_and_replay(po: PathOutcome, robot: RobotModel, path: np.ndarray, limits: Limits, time_law: str, clearance: Clearance,
                    dynamic: bool, report: Report | None = None, where: str = "", trajectory: Trajectory | None = None) -> None:
    """Time ``path`` (po's waypoints with its ends) under ``limits``, then its joint loads (the robot's mass: a scaled
    model's) and its kinematic and, with ``dynamic``, servo replay, into ``po``; a TimingInfeasible is kept in
    ``po.timing_error`` (this path only: the caller times and replays the others). ``where`` ("2 of 5") goes into the
    progress messages; ``trajectory``, when given, is that timing already done."""
    say = report or (lambda _s: None)
    label = LABELS.get(po.name, po.name)
    say(f"replaying: {label}{f' ({where})' if where else ''}")
    try:
        po.trajectory = trajectory if trajectory is not None else time_path(robot, po.name, path, po.rosary, limits, time_law)
    except TimingInfeasible as exc:
        po.timing_error = exc
        return
    times = po.trajectory.times  # a slow timing makes a long replay: say how long, so a wait of minutes is expected
    say(f"replaying: {label} ({f'{where}; ' if where else ''}{times[-1]:,.1f} s of motion, {len(times):,} steps)")
    po.loads = joint_loads(robot, po.trajectory, limit=limits.resolve(robot)[2])
    po.kinematic = replay_kinematic(robot, po.trajectory, clearance)
    if dynamic:
        po.dynamic = replay_dynamic(robot, po.trajectory, clearance=clearance)


def require_a_timing(paths: dict[str, PathOutcome]) -> None:
    """Raise the first path's TimingInfeasible when no path has a timing (the limits fit none of them: nothing
    was replayed). A path that no timing fits among timed ones keeps its ``timing_error``, and the others their results."""
    failed = [po.timing_error for po in paths.values() if po.timing_error is not None]
    if failed and len(failed) == len(paths):
        raise failed[0]


def untimed_paths(outcome: Outcome) -> list[str]:
    """One line per path that no timing fits (``PathOutcome.timing_error``), for the failure message of ``plan`` and ``replay``."""
    return [" ".join(str(po.timing_error).split()) for po in outcome.paths.values() if po.timing_error is not None]
