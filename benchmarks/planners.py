"""Planners x problems x seeds: success, time, bubbles, distance queries, path length, f and clearance,
beside OMPL's RRTConnect (+ PathSimplifier) and RRT* (10x the time) on the same MJCF.

    python benchmarks/planners.py [--seeds 10] [--planners pfm gbpf ...] [--problems obstacle arm6 my_robot.toml ...]
                                  [--scenario FILE.toml ...] [--mjcf ROBOT.xml --start Q --goal Q [--joints a,b]]
                                  [--delta M] [--time-limit 10] [--no-ompl] [--bitstar] [--ompl-resolution 0.01] [--json out.json]
    python benchmarks/planners.py --quick      # CI: 3 seeds, the 3-joint leg scenes, OMPL only if installed
    python benchmarks/planners.py --scenario my_robot.toml --seeds 3   # your robot beside OMPL
    python benchmarks/planners.py --mjcf examples/two_link_arm/arm.xml --start "0.3 2.0" --goal "0.1 0.6" --seeds 3

Problems: the Ortholeg's ``obstacle``, ``step_up`` and ``step_down`` scenarios (their paper parameters
K and r_min for the foam planners), ``obstacle5`` (the 5-joint leg of ``models/ortholeg5.xml``, hip
ab/adduction and ankle added, over the same box; K = 10, r_min = 0.05 for the foam planners) and
``arm6`` (``models/bench_arm6.xml``: a 6-joint arm reaching around a tall box; K = 10, r_min = 0.05) and
``arm7`` (``models/bench_arm7.xml``: a 7-joint arm with iiwa-like axes z y z y z y z around the same box).
``--problems shelf6`` adds the example UR-like arm reaching into a shelf
(``examples/industrial_arm/reach_shelf.toml``).

Your own problem: ``--scenario FILE`` (repeatable; ``--problems`` takes them too) names a scenario, a TOML file as ``foam-mj plan --scene`` reads
(its scene with the scenario's edits, ``joints``, ``robot_root``, ``self_collision``, ``keyframe``;
``q_init`` and ``q_goal``; format in :mod:`foam_mj.scenarios`) or a built-in scenario's name
(``obstacle_thesis``, ``walker_corridor``, ...). Its row is named by the scenario's ``name``. K and r_min
for the foam family come from its ``[planner]`` table when it sets them (else K = 10, r_min = 0.05, as for
obstacle5 and arm6), the margin from its ``delta`` (else 5 mm); its ``algorithm``, ``time_limit`` and other
options are not used (``--planners`` and ``--time-limit`` decide). ``--mjcf ROBOT.xml --start Q --goal Q`` (with
``--joints``, ``--robot-root``, ``--no-self-collision``) is a problem without a scenario file, made into one by
``foam-mj plan``'s own code (the same parsing, keyframe names and messages); its row is named after the file,
K = 10, r_min = 0.05, delta 5 mm. ``--delta M`` sets the margin of every problem of the run. With ``--scenario`` or
``--mjcf`` only those problems run unless ``--problems`` names more. A file that is missing or fails the
scenario's checks is refused (one line, exit 2) before any run.

Every planner of :data:`foam_mj.planners.PLANNERS` runs; the foam family (pfm, gbpf, rbpf, hpf) gets
the problem's K and r_min, any other planner its own default options. The margin delta is the
problem's (5 mm for the built-in problems; ``delta`` in the JSON and the table), for every planner, for
OMPL's validity checker (MuJoCo clearance > delta at each checked state) and for the dense check.

Fairness: both sides plan on the same compiled MJCF, within the same joint bounds (OMPL in qpos units, so that
RRT* minimizes the ``len qpos`` it is compared in; :class:`ompl_peer.OMPLRunner`), against
the same checked geom pairs (robot/obstacle and the robot/robot pairs of self-collision: OMPL's validity
checker is our certificate's clearance function, ``BubbleOracle.clearance``) with the same margin. Our
distance queries run in one thread here (``Clearance.threads = 1``; ``foam-mj plan`` splits large batches
over two), as OMPL does. OMPL's checks are a Python callback per state, ours batched MuJoCo calls: that is
part of what the times compare. The joint bounds are the configuration joints' ranges for both sides (an
unlimited joint is never a configuration joint: it stays at qpos0 for both). OMPL checks motions every
``--ompl-resolution`` (default 0.01, OMPL's own) x the joint box's diagonal in qpos units, set explicitly and written to
the JSON with the step it gives (``ompl.longest_valid_segment``: 0.063 rad on the two-link arm, 0.134 on arm6), so
its paths can come closer than delta between checked states (``below delta``); they still count as solved (a finer
resolution makes OMPL slower and safer: the choice is the user's, the default OMPL's). Each OMPL run seeds OMPL's
generators with its own seed (``RNG.setSeed(seed + 1)``, :class:`ompl_peer.OMPLRunner`), so an RRTConnect row repeats
whatever ran before it in the process; RRT*'s budget is 10 x RRTConnect's wall time, so its iterations vary with
the load. Ours depend on the seed alone (unless a run meets the wall-time limit). A run of either side that fails
or raises counts as a failure (``ok`` is successes out of seeds; the failures are listed after the table by
outcome); medians are over each side's successful runs and the ratio table shows both success counts. The JSON
holds what a rerun needs: the command line, versions, thread settings, every problem's joints, bounds, start,
goal, margin, model fingerprint and options, OMPL's resolution and bounds, and every run's seed.

Columns (medians over the successful seeds; ``ok`` counts them):

* ``first ms``: wall time from the planner's call to the first certified chain q_init -> q_goal
  (``PlanStats.time_to_first_path`` and the planner's set-up before its clock starts); for OMPL, the time
  to its first solution (``solve``, its set-up included).
* ``total ms``: planning plus the default smoother (``optimal``, the certified optimum of f in the
  rosary's hatches); for OMPL, solve plus simplification (RRTConnect) or the whole budget (RRT*).
* ``plan ms``: the planner alone (wall); ``cpu ms``: planning plus the smoother in CPU time of this
  process (comparable across loads on a shared machine, unlike wall times); ``chain``: the rosary's
  bubble count (the smoother's time grows with it).
* ``bubbles``, ``queries``: bubbles grown and configurations whose clearance MuJoCo evaluated
  (for OMPL: states checked by the validity checker, counted in the checker).
* ``len q``, ``len qpos``: the final path's length in the planner's coordinates q and in MuJoCo's qpos
  (radians and metres: the leg's normalized hip displacement counted in metres). Our final path is the
  default smoother's optimum of f (length in q + mean turning angle), not the shortest path.
* ``sp qpos``: for our planners, the length in qpos of the shortest path through the rosary's hatches
  (the cone program with qpos weights: our shortest certified path); "-" for OMPL.
* ``f``: Nascimento et al. 2020 Eq. 5 (mean turning angle + length in q) of the final path.
* ``clear mm``: the smallest MuJoCo distance between robot and obstacle geoms along the final path,
  sampled every 1 mrad (max-norm in q) by this script's own mj_geomDistance loop over the pairs of
  :func:`foam_mj.verify.collision_pairs` (independent of the planner's model and clearance code: a geom
  moved by a configuration joint against every other collision geom). Below delta means the path breaks the
  margin between checked states. ``worst mm``: the smallest over seeds; ``self mm``: the same dense check
  over the robot/robot pairs MuJoCo's collision detection tests (when the problem checks self-collision),
  smallest over seeds.
* ``below delta``: successful runs whose path comes closer than delta under the dense check (listed after
  the table; for ours it is a safety failure, exit 1).

OMPL 2.0.1 is an optional peer (``pip install -e ".[peers]"``): without it the OMPL rows are skipped, with a
note on stderr (``--bitstar`` without OMPL is refused, exit 2).
``--quick`` runs 3 seeds of the 3-joint scenes and finishes in well under a minute (CI runs it); there a run of
ours that fails (no path, refused, error) also fails the benchmark, exit 1, after the table and the JSON (a
study's failures are data: without ``--quick`` they are listed and the exit status is 0).
Timings are wall times on whatever machine runs it; on a shared 2-core machine they vary by 2x.
The planners and OMPL are single-threaded, so the script sets ``OMP_NUM_THREADS`` and ``OPENBLAS_NUM_THREADS``
to 1 unless they are set already: otherwise a BLAS product of the checks between runs leaves OpenBLAS threads
spinning into the next timed run (measured: ``cpu ms`` 78-87 against a wall ``total ms`` of 51-54 on obstacle;
with one thread both 51-54).
Exit status 1 when a path of ours comes closer than delta to an obstacle (or, with self-collision, to
itself) under the dense check (a safety failure); 2 for bad arguments (one line, before any run: unknown
planner or problem, a scenario or --mjcf problem that fails its checks, --start/--goal/--joints/--robot-root/--no-self-collision without --mjcf,
--seeds outside [1, 10000], --time-limit or --delta not a finite number > 0, --ompl-resolution outside (0, 0.5],
a --json that cannot be written or does not end in .json); 130 when interrupted (Ctrl-C:
no JSON is written; the JSON is written once, atomically, after the last run).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import sys
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):  # before numpy loads its BLAS (module docstring)
    os.environ.setdefault(_var, "1")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from _common import progress, table  # noqa: E402

from foam_mj.atomic import OutputError, atomic_write_text, check_output  # noqa: E402
from foam_mj.bubbles import BubbleOracle  # noqa: E402
from foam_mj.cli import Parser, UsageError  # noqa: E402
from foam_mj.errors import ConfigurationError, FoamError, PlanningFailed  # noqa: E402
from foam_mj.paths import metrics  # noqa: E402
from foam_mj.planners import PLANNERS, PlanningProblem, get_planner  # noqa: E402
from foam_mj.planners.base import smoother_start  # noqa: E402
from foam_mj.planners.corridor import shortest_path  # noqa: E402
from foam_mj.smoothing import OptimalSmoother  # noqa: E402

# The concepts of this benchmark, one module each: its problems, the dense check of a final path, the OMPL peer.
from dense_check import CHECK_STEP, DenseChecker, qpos_length  # noqa: E402
from ompl_peer import NO_OMPL, OMPL_RESOLUTION, OMPLRunner, finish_ompl, have_ompl  # noqa: E402
from planner_problems import (  # noqa: E402
    ALL_PROBLEMS, EXTRA_PROBLEMS, QUICK_PROBLEMS, Problem, check_margins, check_options, load_problems, mjcf_problem, planner_options,
)
from planner_problems import DEFAULT_K, DEFAULT_R_MIN, DELTA, problem  # noqa: E402,F401  (planners.problem etc., as before the split)

MAX_SEEDS = 10_000  # a typo of a few zeros would run for days


def run_ours(name: str, pb: Problem, oracle: BubbleOracle, checker: DenseChecker, seed: int, time_limit: float) -> dict:
    planner = get_planner(name, **planner_options(name, pb))
    prob = PlanningProblem(oracle, pb.q_init, pb.q_goal, delta=pb.delta, time_limit=time_limit)
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        res = planner.plan(prob, seed=seed)
    except PlanningFailed as exc:
        st = exc.stats
        return {"ok": False, "outcome": getattr(st, "outcome", "failed"), "bubbles": getattr(st, "bubbles", None),
                "queries": getattr(st, "distance_queries", None), "time": time.perf_counter() - t0}
    except ConfigurationError as exc:  # a planner's own rule refuses the problem (pfm: root radius, Eq. 2's bound)
        return {"ok": False, "outcome": f"refused: {exc}", "bubbles": 0, "queries": 0, "time": time.perf_counter() - t0}
    except Exception as exc:  # a planner's crash is a finding (listed with the failed runs), not a reason to lose every other run
        return {"ok": False, "outcome": f"planner error: {type(exc).__name__}: {exc}", "time": time.perf_counter() - t0}
    t_plan = time.perf_counter() - t0
    try:
        sm = OptimalSmoother().smooth(res.rosary, initial=smoother_start(res.rosary, res.waypoints), seed=seed)
    except Exception as exc:  # a smoother failure is a finding, not a reason to lose the whole run
        return {"ok": False, "outcome": f"smoother error: {type(exc).__name__}: {exc}", "first": res.stats.time_to_first_path,
                "bubbles": res.stats.bubbles, "queries": res.stats.distance_queries, "rosary": res.rosary.k, "time": t_plan}
    total, total_cpu = time.perf_counter() - t0, time.process_time() - c0
    path = sm.path
    m = metrics(path)
    ros = res.rosary
    _, len_sp = shortest_path(ros.centers, ros.radii, ros.q_init, ros.q_goal, oracle.robot.config.scale)
    st = res.stats
    # From this call, as OMPL's solve: the planner's set-up before its own clock started counts too.
    first = t_plan - (st.elapsed - st.time_to_first_path) if st.time_to_first_path is not None else t_plan
    return {
        "ok": True, "outcome": st.outcome, "first": first, "plan": t_plan, "total": total, "total_cpu": total_cpu,
        "bubbles": st.bubbles, "queries": st.distance_queries, "rosary": res.rosary.k,
        "len_q": m.length, "len_qpos": qpos_length(oracle.robot, path), "len_sp": len_sp, "f": m.f, **checker.record(path),
        "certified": bool(sm.info.get("certified", False)),
    }



def reproduce_info(args, planners: list[str], use_ompl: bool) -> dict:
    """What the JSON needs to repeat the run: the command line, the versions, the thread settings, the seeds' rule."""
    import platform
    from importlib.metadata import PackageNotFoundError, version

    def ver(pkg: str) -> str | None:
        try:
            return version(pkg)
        except PackageNotFoundError:
            return None

    return {"argv": [Path(sys.argv[0]).name, *sys.argv[1:]] if sys.argv and sys.argv[0].endswith("planners.py") else None,
            "planners": planners, "ompl_used": use_ompl, "ompl_resolution": args.ompl_resolution if use_ompl else None,
            "seed_rule": "our planners and smoother: seed s; OMPL: RNG.setSeed(s + 1) before each run",
            "versions": {k: ver(k) for k in ("foam-mj", "mujoco", "numpy", "scipy", "ompl")} | {"python": platform.python_version()},
            "threads": {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}, "machine": platform.machine(),
            "cpus": os.cpu_count(), "cpu_model": cpu_model(), "load_average_start": list(os.getloadavg())}


def cpu_model() -> str | None:
    """The processor's name (Linux's /proc/cpuinfo, else the platform's): wall times compare only on one machine."""
    import platform

    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or None


def problem_info(pb: Problem, checker: DenseChecker) -> dict:
    """A problem's own description in the JSON: joints, bounds, start and goal, the model's fingerprint, the pairs
    the dense check used, and a scenario file's text (the file may change after the run)."""
    from foam_mj.fingerprint import model_fingerprint

    r, m = pb.robot, pb.robot.model
    return {"joints": [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, int(j)) for j in r.config.joint_ids],
            "lower": r.lower.tolist(), "upper": r.upper.tolist(), "q_init": pb.q_init.tolist(), "q_goal": pb.q_goal.tolist(),
            "self_collision": bool(r.self_collision), "model_sha256": model_fingerprint(m)["sha256"],
            "dense_pairs": len(checker.pairs), "dense_self_pairs": len(checker.self_pairs),
            "scenario_toml": Path(pb.source).read_text() if pb.source and pb.source.endswith(".toml") else None}



KEYS = ("first", "plan", "total", "total_cpu", "rosary", "bubbles", "queries", "len_q", "len_qpos", "len_sp", "f", "clearance", "self_clearance")


def below(run: dict, delta: float) -> bool:
    """Does a successful run's path come closer than delta under the dense check (either pair kind)?"""
    return bool(run.get("ok")) and min(run["clearance"], run.get("self_clearance") or np.inf) < delta - 1e-6


def summarize(runs: list[dict], delta: float) -> dict:
    ok = [r for r in runs if r.get("ok")]
    med = {}
    for k in KEYS:
        vals = [r[k] for r in ok if r.get(k) is not None and np.isfinite(r[k])]
        med[k] = float(np.median(vals)) if vals else None
    failures: dict[str, int] = {}
    for r in runs:
        if not r.get("ok"):
            failures[str(r.get("outcome"))] = failures.get(str(r.get("outcome")), 0) + 1
    self_clear = [r["self_clearance"] for r in ok if r.get("self_clearance") is not None]
    return {"ok": len(ok), "runs": len(runs), "median": med, "min_clearance": min((r["clearance"] for r in ok), default=None),
            "min_self_clearance": min(self_clear, default=None), "below_delta": sum(below(r, delta) for r in runs), "failures": failures}


def _fmt(v, scale=1.0, fmt="{:.0f}") -> str:
    return "-" if v is None else fmt.format(v * scale)


def parse(argv: list[str] | None) -> tuple:
    """(args, planners, problems, seeds), every argument checked and every problem loaded before any run;
    UsageError (one line) otherwise."""
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=None, help=f"seeds per planner and problem (default 10, --quick 3; at most {MAX_SEEDS:,})")
    ap.add_argument("--planners", nargs="+", default=None, help=f"default: every registered planner ({', '.join(sorted(PLANNERS))})")
    ap.add_argument("--problems", nargs="+", default=None,
                    help=f"default: {' '.join(ALL_PROBLEMS)} (none when --scenario or --mjcf is given); also {' '.join(EXTRA_PROBLEMS)}, "
                         "a scenario TOML file or a built-in scenario's name")
    ap.add_argument("--scenario", action="append", default=[], metavar="FILE.toml",
                    help="your own problem: a scenario TOML file (as `foam-mj plan --scene` reads) or a built-in scenario's name; repeatable")
    ap.add_argument("--mjcf", metavar="ROBOT.xml", help="your own problem without a scenario file, as `foam-mj plan --mjcf` takes it (needs --start and --goal)")
    ap.add_argument("--start", metavar="Q", help="with --mjcf: the start, one number per configuration joint (spaces or commas), or a keyframe's name")
    ap.add_argument("--goal", metavar="Q", help="with --mjcf: the goal (numbers or a keyframe's name)")
    ap.add_argument("--joints", metavar="a,b,c", help="with --mjcf: the configuration joints, in order")
    ap.add_argument("--robot-root", metavar="BODY", help="with --mjcf: the body whose subtree is the robot")
    ap.add_argument("--no-self-collision", action="store_true", help="with --mjcf: do not check robot/robot pairs")
    ap.add_argument("--delta", type=float, metavar="M", help="the margin in metres for every problem of the run, ours, OMPL's and the dense "
                                                              "check's (default: each problem's own: a scenario's delta, else 0.005)")
    ap.add_argument("--time-limit", type=float, default=10.0, help="seconds per planning run before it counts as failed (default 10)")
    ap.add_argument("--no-ompl", action="store_true", help="skip the OMPL peers")
    ap.add_argument("--bitstar", action="store_true", help="also run OMPL's BIT* with 10x RRTConnect's time")
    ap.add_argument("--ompl-resolution", type=float, default=OMPL_RESOLUTION, metavar="F",
                    help=f"OMPL's state validity checking resolution, a fraction of the joint box's diagonal in qpos units (default {OMPL_RESOLUTION:g}, OMPL's own)")
    ap.add_argument("--quick", action="store_true", help="CI: 3 seeds, the 3-joint scenes; a failed run of ours is exit 1")
    ap.add_argument("--no-progress", action="store_true")
    ap.add_argument("--json", help="write every run and the medians as JSON (written once, atomically, after the last run)")
    args = ap.parse_args(argv)
    seeds = args.seeds if args.seeds is not None else (3 if args.quick else 10)
    if not 1 <= seeds <= MAX_SEEDS:
        ap.error(f"--seeds must be in [1, {MAX_SEEDS}] (runs per planner and problem), got {seeds}")
    if not (math.isfinite(args.time_limit) and args.time_limit > 0):
        ap.error(f"--time-limit must be a finite number of seconds > 0, got {args.time_limit:g}")
    if args.delta is not None and not (math.isfinite(args.delta) and args.delta > 0):
        ap.error(f"--delta must be a finite margin > 0 in metres, got {args.delta:g}")
    if not (math.isfinite(args.ompl_resolution) and 0 < args.ompl_resolution <= 0.5):
        ap.error(f"--ompl-resolution must be a fraction in (0, 0.5] of the joint box's diagonal, got {args.ompl_resolution:g}")
    if args.bitstar and args.no_ompl:
        ap.error("--bitstar runs an OMPL planner: not with --no-ompl")
    if args.bitstar and not have_ompl():
        ap.error("--bitstar runs OMPL's BIT*, but OMPL is not installed (pip install -e \".[peers]\", or leave out --bitstar)")
    if args.mjcf is None:
        for flag in ("start", "goal", "joints", "robot_root", "no_self_collision"):
            if getattr(args, flag):
                ap.error(f"--{flag.replace('_', '-')} goes with --mjcf (a scenario names its own)")
    try:
        check_output(args.json, "--json", suffix=".json")
    except OutputError as exc:
        ap.error(str(exc))
    planners = args.planners or sorted(PLANNERS)
    for p in planners:
        if p not in PLANNERS:
            ap.error(f"--planners: unknown planner '{p}'; known: {', '.join(sorted(PLANNERS))}")
    own = bool(args.scenario) or args.mjcf is not None
    names = args.problems if args.problems is not None else ([] if own else list(QUICK_PROBLEMS if args.quick else ALL_PROBLEMS))
    try:
        try:
            extra = (mjcf_problem(args),) if args.mjcf is not None else ()
        except FoamError as exc:
            raise UsageError(str(exc)) from None
        problems = load_problems(names + args.scenario, ["--problems"] * len(names) + ["--scenario"] * len(args.scenario), extra)
        if args.delta is not None:
            problems = [dataclasses.replace(pb, delta=float(args.delta)) for pb in problems]
        check_margins(problems)
        check_options(planners, problems)
    except UsageError as exc:
        ap.error(str(exc))
    return args, planners, problems, seeds


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark (module docstring): exit 2 on a bad argument, 130 when interrupted, 1 when a path of
    ours breaks its margin or, with ``--quick`` (CI), when a run of ours fails."""
    try:
        args, planners, problems, seeds = parse(argv)
    except UsageError as exc:
        print(exc, file=sys.stderr)
        raise SystemExit(2) from None
    use_ompl = not args.no_ompl and have_ompl()
    if not args.no_ompl and not use_ompl:
        print(f"{NO_OMPL}: running our planners only (--no-ompl says so and skips this note)", file=sys.stderr)
    try:
        out, broken = run(args, planners, problems, seeds, use_ompl)
    except KeyboardInterrupt:
        print("\ninterrupted: no JSON written" if args.json else "\ninterrupted", file=sys.stderr)
        leave(130, use_ompl)
    if args.json:
        atomic_write_text(args.json, json.dumps(out, indent=1, default=float))
        print(f"wrote {args.json}")
    for p, n, c in broken:
        print(f"MARGIN BROKEN: {n} on {p}: {c * 1e3:.3f} mm < delta = {out['problems'][p]['delta'] * 1e3:g} mm", file=sys.stderr)
    lost = [(p, n, why, k) for p, v in out["problems"].items() for n in planners
            for why, k in v["planners"][n]["summary"]["failures"].items()] if args.quick else []
    for p, n, why, k in lost:
        print(f"FAILED (--quick): {n} on {p}: {k} x {why}", file=sys.stderr)
    if use_ompl or broken or lost:
        leave(1 if broken or lost else 0, use_ompl)
    return out


def leave(status: int, use_ompl: bool) -> None:
    """Exit with ``status``. OMPL 2.0.1's nanobind bindings report leaked references at interpreter exit
    (harmless noise on stderr); with OMPL loaded, leave without running the finalizers."""
    sys.stdout.flush()
    sys.stderr.flush()
    if use_ompl:
        os._exit(status)
    raise SystemExit(status)


def run(args, planners: list[str], problems: list[Problem], seeds: int, use_ompl: bool) -> tuple[dict, list]:
    """Every planner on every problem and seed: (the JSON document, our runs that break their margin as
    (problem, planner, clearance)); prints the tables."""
    # Our planners import their solvers (scipy's k-d tree and graph search, Clarabel: 0.3-0.9 s) on their first call,
    # before their own clocks start but inside this script's: the first timed run of ours paid for them (seed 0 on
    # obstacle 716 ms against 149-251 ms for seeds 1-4), while OMPL's modules are imported here, before any run.
    from foam_mj.foam import load_kd_tree
    from foam_mj.planners.corridor import load_solvers

    load_kd_tree()
    load_solvers()
    if use_ompl:
        from ompl import util as ou

        ou.setLogLevel(ou.LogLevel.LOG_WARN)  # each run seeds OMPL's generators with its seed (OMPLRunner)

    out: dict = {"seeds": seeds, "time_limit": args.time_limit, "check_step": CHECK_STEP, "reproduce": reproduce_info(args, planners, use_ompl),
                 "problems": {}}
    rows, ratio_rows = [], []
    t_start = time.perf_counter()
    for pb in problems:
        pname, robot = pb.name, pb.robot
        oracle = BubbleOracle(robot, delta=pb.delta)
        oracle.clearance.threads = 1  # one thread, as OMPL (module docstring)
        checker = DenseChecker(robot)
        res: dict = {}
        jobs = len(planners) * seeds + (seeds * (2 + args.bitstar) if use_ompl else 0)
        done = 0
        # Seed by seed, ours and then OMPL's runs of that seed: this machine's speed drifts by up to half over minutes,
        # and running every seed of ours before every seed of OMPL's gave that drift to one side.
        ours: dict[str, list] = {name: [] for name in planners}
        rc, opt, bit = [], [], []
        runner = OMPLRunner(pb, oracle, args.ompl_resolution) if use_ompl else None
        for s in range(seeds):
            for name in planners:
                if not args.no_progress:
                    progress(done, jobs, f"{pname:>10}")
                ours[name].append({"seed": s, **run_ours(name, pb, oracle, checker, s, args.time_limit)})
                done += 1
            if runner is not None:
                if not args.no_progress:
                    progress(done, jobs, f"{pname:>10}")
                r = finish_ompl(runner.rrtconnect(args.time_limit, s), robot, checker)
                rc.append(r)
                budget = 10 * r["total"] if r.get("ok") else args.time_limit
                opt.append(finish_ompl(runner.optimizing(budget, s, "rrtstar"), robot, checker))
                if args.bitstar:
                    bit.append(finish_ompl(runner.optimizing(budget, s, "bitstar"), robot, checker))
                done += 2 + args.bitstar
        for name in planners:
            res[name] = {"summary": summarize(ours[name], pb.delta), "runs": ours[name]}
        if use_ompl:
            res["ompl:rrtconnect+simplify"] = {"summary": summarize(rc, pb.delta), "runs": rc}
            res["ompl:rrtstar(10x)"] = {"summary": summarize(opt, pb.delta), "runs": opt}
            if args.bitstar:
                res["ompl:bitstar(10x)"] = {"summary": summarize(bit, pb.delta), "runs": bit}
        if not args.no_progress:
            progress(jobs, jobs, f"{pname:>10}")
        oracle.close()
        out["problems"][pname] = {"K": pb.K, "r_min": pb.r_min, "delta": pb.delta, "dim": len(pb.q_init), "source": pb.source,
                                  "scene": str(robot.path), "scene_edited": robot.xml is not None, **problem_info(pb, checker),
                                  "options": {n: planner_options(n, pb) for n in planners},
                                  "ompl": ({"resolution": runner.resolution, "longest_valid_segment": runner.longest_valid_segment,
                                            "bounds_qpos_units": [runner.bounds[0].tolist(), runner.bounds[1].tolist()],
                                            "seed_rule": "RNG.setSeed(seed + 1) before each run"} if use_ompl else None),
                                  "planners": res}
        for name, r in res.items():
            m, sm = r["summary"]["median"], r["summary"]
            rows.append([
                pname, _fmt(pb.delta, 1e3, "{:g}"), name, f"{sm['ok']}/{sm['runs']}", _fmt(m["first"], 1e3), _fmt(m["plan"], 1e3), _fmt(m["total"], 1e3),
                _fmt(m["total_cpu"], 1e3), _fmt(m["rosary"], 1, "{:.0f}"), _fmt(m["bubbles"], 1, "{:,.0f}"),
                _fmt(m["queries"], 1, "{:,.0f}"), _fmt(m["len_q"], 1, "{:.3f}"), _fmt(m["len_qpos"], 1, "{:.3f}"), _fmt(m["len_sp"], 1, "{:.3f}"),
                _fmt(m["f"], 1, "{:.3f}"),
                _fmt(m["clearance"], 1e3, "{:.1f}"), _fmt(sm["min_clearance"], 1e3, "{:.1f}"), _fmt(sm["min_self_clearance"], 1e3, "{:.1f}"),
            ])
        if use_ompl:
            peer = res["ompl:rrtconnect+simplify"]["summary"]["median"]
            star = res["ompl:rrtstar(10x)"]["summary"]["median"]
            for name in planners:
                m = res[name]["summary"]["median"]

                def ratio(a, b):
                    return f"{a / b:.2f}" if a is not None and b else "-"

                ok = "/".join(str(res[k]["summary"]["ok"]) for k in (name, "ompl:rrtconnect+simplify", "ompl:rrtstar(10x)", "ompl:bitstar(10x)") if k in res)
                ratio_rows.append([pname, name, ok, ratio(m["total"], peer["total"]), ratio(m["len_qpos"], peer["len_qpos"]),
                                   ratio(m["len_qpos"], star["len_qpos"]), ratio(m["len_sp"], star["len_qpos"]),
                                   ratio(m["clearance"], peer["clearance"])]
                                  + ([ratio(m["len_qpos"], res["ompl:bitstar(10x)"]["summary"]["median"]["len_qpos"])] if args.bitstar else []))
    out["elapsed"] = time.perf_counter() - t_start
    out["reproduce"]["load_average_end"] = list(os.getloadavg())
    print(f"\nmedians over {seeds} seeds (successful runs), time limit {args.time_limit:g} s per run")
    print(table(["problem", "delta mm", "planner", "ok", "first ms", "plan ms", "total ms", "cpu ms", "chain", "bubbles", "queries", "len q",
                 "len qpos", "sp qpos", "f", "clear mm", "worst mm", "self mm"], rows))
    print("total: planning + the default smoother (optimal) for ours; solve + simplify (RRTConnect) or the whole budget (RRT*) for OMPL.")
    print(f"clear mm: median over seeds of the smallest MuJoCo distance robot/obstacle along the final path, checked every {CHECK_STEP * 1e3:g} mrad; "
          "worst mm: the smallest over seeds; self mm: robot/robot, the smallest over seeds.")
    failed = [(p, n, why, k) for p, v in out["problems"].items() for n, r in v["planners"].items() for why, k in r["summary"]["failures"].items()]
    if failed:
        print("\nfailed runs: " + "; ".join(f"{p} {n}: {k} x {why}" for p, n, why, k in failed))
    close = [(p, n, r["summary"]) for p, v in out["problems"].items() for n, r in v["planners"].items() if r["summary"]["below_delta"]]
    if close:
        print("\nbelow delta (paths closer than the margin under the dense check): "
              + "; ".join(f"{p} {n}: {sm['below_delta']} of {sm['ok']}" for p, n, sm in close))
    if use_ompl:
        print("\nratios ours / OMPL (medians)")
        print(table(["problem", "planner", "ok ours/RRTC/RRT*" + ("/BIT*" if args.bitstar else ""), "total time / RRTConnect", "len qpos / RRTConnect", "len qpos / RRT*", "sp qpos / RRT*", "clearance / RRTConnect"]
                    + (["len qpos / BIT*"] if args.bitstar else []), ratio_rows))
        print("ratios of medians over each side's successful runs (ok: successes of ours / RRTConnect / RRT*" + (" / BIT*" if args.bitstar else "") + " out of "
              f"{seeds}); OMPL checks motions every {args.ompl_resolution:g} x the joint box's diagonal (qpos units): "
              + ", ".join(f"{p} {v['ompl']['longest_valid_segment']:.3g}" for p, v in out["problems"].items()))
    elif not args.no_ompl:
        print(f"\n{NO_OMPL}: no peer rows")
    r = out["reproduce"]
    print(f"benchmark time {out['elapsed']:.1f} s on {r['cpus']} x {r['cpu_model'] or 'an unnamed CPU'}, load average "
          f"{r['load_average_start'][0]:.2f} at the start, {r['load_average_end'][0]:.2f} at the end")
    # Safety is the product: any path of ours closer than delta (to an obstacle or, with self-collision, to itself)
    # fails the benchmark (exit 1).
    broken = [(p, n, min(r["clearance"], r.get("self_clearance") or np.inf)) for p, v in out["problems"].items() for n in planners
              for r in v["planners"][n]["runs"] if below(r, v["delta"])]
    out["margin_violations"] = [{"problem": p, "planner": n, "clearance": c} for p, n, c in broken]
    return out, broken


if __name__ == "__main__":
    main()
