"""The planner benchmark's problems (``benchmarks/planners.py``): the built-in ones by name, a scenario TOML or a
built-in scenario, and ``--mjcf ROBOT.xml --start Q --goal Q`` made into a scenario by ``foam-mj plan``'s own code;
each loaded and checked (its K and r_min for the foam planners, its margin against the fixed pairs) before any run."""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from foam_mj.cli import UsageError
from foam_mj.data import models_dir
from foam_mj.errors import ConfigurationError, ScenarioError
from foam_mj.model import RobotModel
from foam_mj.planners import PLANNERS, PlannerError, get_planner
from foam_mj.planners.base import option_names
from foam_mj.scenarios import available_scenarios, load_scenario, read_scenario_doc, scenario_from_dict

DELTA = 0.005  # m: the built-in problems' margin, and a scenario's without a [planner] delta
DEFAULT_K, DEFAULT_R_MIN = 10, 0.05  # the foam family's K and r_min where a problem does not set them
FOAM_FAMILY = ("pfm", "gbpf", "rbpf", "hpf")
QUICK_PROBLEMS = ("obstacle", "step_up", "step_down")
ALL_PROBLEMS = QUICK_PROBLEMS + ("obstacle5", "arm6", "arm7")
EXTRA_PROBLEMS = ("shelf6",)  # only when named with --problems


@dataclass(frozen=True)
class Problem:
    """One benchmark problem: the compiled scene, start and goal, the foam family's K and r_min, the margin."""

    name: str
    robot: RobotModel
    q_init: np.ndarray
    q_goal: np.ndarray
    K: int
    r_min: float
    delta: float = DELTA
    source: str | None = None  # the scenario TOML a user's problem came from


def problem(name: str) -> Problem:
    """A built-in problem by name, else a scenario (a TOML path or a built-in scenario's name); ScenarioError
    (naming the file and field) when the scenario fails its checks."""
    if name in QUICK_PROBLEMS or name == "obstacle5":
        s = load_scenario(name)
        K, r_min = (int(s.params.K), float(s.params.r_min)) if name in QUICK_PROBLEMS else (DEFAULT_K, DEFAULT_R_MIN)
        return Problem(name, s.robot, s.q_init, s.q_goal, K, r_min)
    if name == "arm6":
        # Mirror poses either side of the box, the tool low beside it; the straight line cuts 42 mm into the box.
        a = np.array([-0.7, 0.87, 1.12, -0.08, 0.0, 0.0])
        return Problem(name, RobotModel.from_xml(models_dir() / "bench_arm6.xml"), a, a * np.array([-1, 1, 1, 1, 1, 1]), DEFAULT_K, DEFAULT_R_MIN)
    if name == "arm7":
        # Mirror poses either side of the box (iiwa-like axes); the straight line cuts 66 mm into the box.
        a = np.array([-0.7, 0.9, 0.0, 1.2, 0.0, 0.2, 0.0])
        return Problem(name, RobotModel.from_xml(models_dir() / "bench_arm7.xml"), a, a * np.array([-1, 1, 1, 1, 1, 1, 1]), DEFAULT_K, DEFAULT_R_MIN)
    if name == "shelf6":
        s = load_scenario(Path(__file__).resolve().parents[1] / "examples" / "industrial_arm" / "reach_shelf.toml")
        return Problem(name, s.robot, s.q_init, s.q_goal, DEFAULT_K, DEFAULT_R_MIN)
    return scenario_problem(name)


def scenario_problem(name_or_path: str) -> Problem:
    """A scenario as a problem: its robot (with the scenario's edits and options), q_init, q_goal, and from its
    [planner] table K and r_min (else the defaults) and delta."""
    raw, path = read_scenario_doc(name_or_path)
    s = scenario_from_dict(raw, path.parent, source=path)
    opts = s.params.options
    return Problem(s.name, s.robot, s.q_init, s.q_goal, int(opts.get("K", DEFAULT_K)), float(opts.get("r_min", DEFAULT_R_MIN)),
                   float(s.params.delta), str(path))


def mjcf_problem(args) -> Problem:
    """``--mjcf FILE --start Q --goal Q`` (with ``--joints``, ``--robot-root``, ``--no-self-collision``) as a problem,
    made into a scenario by ``foam-mj plan``'s own code (:func:`foam_mj.plan_command.plan_scenario`: the same parsing,
    keyframe names, checks and one-line messages naming the flag); K and r_min the defaults, delta 5 mm unless
    ``--delta``."""
    from foam_mj.plan_command import plan_scenario

    s = plan_scenario(plan_namespace(args))
    return Problem(s.name, s.robot, s.q_init, s.q_goal, DEFAULT_K, DEFAULT_R_MIN, float(s.params.delta), str(Path(args.mjcf).resolve()))


#: The flags ``--mjcf`` problems share with ``foam-mj plan`` (argparse dests).
MJCF_FLAGS = ("mjcf", "start", "goal", "joints", "robot_root", "no_self_collision")


def plan_namespace(args) -> argparse.Namespace:
    """``foam-mj plan --mjcf ...``'s own parsed arguments: every field of plan's parser at its default, the
    :data:`MJCF_FLAGS` from ``args``. A Namespace naming the fields :func:`foam_mj.plan_command.plan_scenario`
    read by hand broke (AttributeError) whenever plan gained one."""
    from foam_mj.cli import build_parser

    ns = build_parser().parse_args(["plan"])
    for flag in MJCF_FLAGS:
        setattr(ns, flag, getattr(args, flag))
    return ns


def load_problems(names: list[str], flags: list[str] | None = None, extra: tuple[Problem, ...] = ()) -> list[Problem]:
    """Every problem of ``names`` (each given with the flag of ``flags``: --problems or --scenario) and ``extra``
    (--mjcf's), loaded and checked before any run; UsageError (one line) for a bad one or a name given twice."""
    out: list[Problem] = []
    flags = flags or ["--problems"] * len(names)
    for name, flag in [*zip(names, flags), *((pb, "--mjcf") for pb in extra)]:
        if isinstance(name, Problem):
            pb, name = name, name.source
        else:
            try:
                pb = problem(name) if flag == "--problems" else scenario_problem(name)
            except ScenarioError as exc:
                p = Path(name)
                if p.suffix != ".toml" and len(p.parts) == 1 and not p.exists():
                    raise UsageError(f"{flag}: unknown {'problem' if flag == '--problems' else 'scenario'} '{name}'; "
                                     + (f"built-in problems: {', '.join(ALL_PROBLEMS + EXTRA_PROBLEMS)}; or " if flag == "--problems" else "")
                                     + f"a scenario TOML file, or a built-in scenario: {', '.join(available_scenarios())}") from None
                raise UsageError(f"{flag}: {exc}") from None
        same = [o.source or o.name for o in out if o.name == pb.name]
        if same and same[0] == (pb.source or name):
            raise UsageError(f"{flag}: '{name}' is given twice")
        if same:
            raise UsageError(f"{flag}: two problems are named '{pb.name}' ({same[0]} and {pb.source or name}): "
                             "give each once (a scenario's row is named by its 'name' field)")
        out.append(pb)
    return out



def planner_options(name: str, pb: Problem) -> dict:
    """The options planner ``name`` gets on ``pb``: the problem's K and r_min for the foam family, else none."""
    return {k: getattr(pb, k) for k in ("K", "r_min") if name in FOAM_FAMILY and k in option_names(PLANNERS[name])}


def check_options(planners: list[str], problems: list[Problem]) -> None:
    """UsageError (one line) when a problem's K or r_min is not valid for a planner of the run (a scenario's
    ``r_min = 0``, bubbletree's "derive it from delta", is no resolution for pfm)."""
    for pb in problems:
        for name in planners:
            try:
                get_planner(name, **planner_options(name, pb))
            except PlannerError as exc:
                raise UsageError(f"--problems: {pb.source or pb.name}: [planner] K / r_min do not suit the foam planners: {exc}") from None


def check_margins(problems: list[Problem]) -> None:
    """UsageError (one line) when a robot/obstacle pair that no configuration joint moves is within a problem's delta (``RobotModel.check_fixed_pairs``: left out of every clearance
    query, ours and OMPL's, so OMPL would plan where every path breaks the margin while our planners refuse)."""
    for pb in problems:
        try:
            pb.robot.check_fixed_pairs(pb.delta)
        except ConfigurationError as exc:
            raise UsageError(f"{pb.source or pb.name}: {exc}") from None
