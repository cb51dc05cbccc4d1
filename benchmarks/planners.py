"""Planners x problems x seeds: success, time, bubbles, distance queries, path length, f and clearance,
beside OMPL's RRTConnect (+ PathSimplifier) and RRT* (10x the time) on the same MJCF.

    python benchmarks/planners.py [--seeds 10] [--planners pfm gbpf ...] [--problems obstacle arm6 ...]
                                  [--time-limit 10] [--no-ompl] [--bitstar] [--json out.json]
    python benchmarks/planners.py --quick      # CI: 3 seeds, the 3-joint leg scenes, OMPL only if installed

Problems: the Ortholeg's ``obstacle``, ``step_up`` and ``step_down`` scenarios (their paper parameters
K and r_min for the foam planners), ``obstacle5`` (the 5-joint leg of ``models/ortholeg5.xml``, hip
ab/adduction and ankle added, over the same box; K = 10, r_min = 0.05 for the foam planners) and
``arm6`` (``models/bench_arm6.xml``: a 6-joint arm reaching around a tall box; K = 10, r_min = 0.05) and
``arm7`` (``models/bench_arm7.xml``: a 7-joint arm with iiwa-like axes z y z y z y z around the same box).
``--problems shelf6`` adds the example UR-like arm reaching into a shelf
(``examples/industrial_arm/reach_shelf.toml``).
Every planner of :data:`foam_mj.planners.PLANNERS` runs; the foam family (pfm, gbpf, rbpf, hpf) gets
the problem's K and r_min, any other planner its own default options. The margin is delta = 5 mm
for every planner and for OMPL's validity checker (MuJoCo clearance > delta at each checked state).

Columns (medians over the successful seeds; ``ok`` counts them):

* ``first ms``: wall time to the first certified chain q_init -> q_goal (``PlanStats.time_to_first_path``);
  for OMPL, the time to its first solution.
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
  sampled every 1 mrad (max-norm in q) by this script's own mj_geomDistance loop (independent of
  foam_mj.clearance). Below delta = 5 mm means the path breaks the margin between checked states.

OMPL 2.0.1 is an optional peer (``pip install -e ".[peers]"``): without it the OMPL rows are skipped.
``--quick`` runs 3 seeds of the 3-joint scenes and finishes in well under a minute (CI runs it).
Timings are wall times on whatever machine runs it; on a shared 2-core machine they vary by 2x.
The planners and OMPL are single-threaded, so the script sets ``OMP_NUM_THREADS`` and ``OPENBLAS_NUM_THREADS``
to 1 unless they are set already: otherwise a BLAS product of the checks between runs leaves OpenBLAS threads
spinning into the next timed run (measured: ``cpu ms`` 78-87 against a wall ``total ms`` of 51-54 on obstacle;
with one thread both 51-54).
Exit status 1 when a path of ours comes closer than delta to an obstacle under the dense check (a
safety failure), 2 for bad arguments.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):  # before numpy loads its BLAS (module docstring)
    os.environ.setdefault(_var, "1")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from _common import progress, table  # noqa: E402

from foam_mj.bubbles import BubbleOracle  # noqa: E402
from foam_mj.data import models_dir  # noqa: E402
from foam_mj.errors import ConfigurationError, PlanningFailed  # noqa: E402
from foam_mj.model import RobotModel  # noqa: E402
from foam_mj.paths import metrics  # noqa: E402
from foam_mj.planners import PLANNERS, PlanningProblem, get_planner  # noqa: E402
from foam_mj.planners.base import option_names, smoother_start  # noqa: E402
from foam_mj.planners.corridor import shortest_path  # noqa: E402
from foam_mj.scenarios import load_scenario  # noqa: E402
from foam_mj.smoothing import OptimalSmoother  # noqa: E402

DELTA = 0.005
FOAM_FAMILY = ("pfm", "gbpf", "rbpf", "hpf")
QUICK_PROBLEMS = ("obstacle", "step_up", "step_down")
ALL_PROBLEMS = QUICK_PROBLEMS + ("obstacle5", "arm6", "arm7")
EXTRA_PROBLEMS = ("shelf6",)  # only when named with --problems
CHECK_STEP = 1e-3  # rad (max-norm in q) between densely checked configurations


@dataclass(frozen=True)
class Problem:
    name: str
    mjcf: Path
    q_init: np.ndarray
    q_goal: np.ndarray
    K: int
    r_min: float


def problem(name: str) -> Problem:
    if name in QUICK_PROBLEMS or name == "obstacle5":
        s = load_scenario(name)
        K, r_min = (int(s.params.K), float(s.params.r_min)) if name in QUICK_PROBLEMS else (10, 0.05)
        return Problem(name, Path(s.scene), s.q_init, s.q_goal, K, r_min)
    if name == "arm6":
        # Mirror poses either side of the box, the tool low beside it; the straight line cuts 42 mm into the box.
        a = np.array([-0.7, 0.87, 1.12, -0.08, 0.0, 0.0])
        return Problem(name, models_dir() / "bench_arm6.xml", a, a * np.array([-1, 1, 1, 1, 1, 1]), 10, 0.05)
    if name == "arm7":
        # Mirror poses either side of the box (iiwa-like axes); the straight line cuts 66 mm into the box.
        a = np.array([-0.7, 0.9, 0.0, 1.2, 0.0, 0.2, 0.0])
        return Problem(name, models_dir() / "bench_arm7.xml", a, a * np.array([-1, 1, 1, 1, 1, 1, 1]), 10, 0.05)
    if name == "shelf6":
        s = load_scenario(Path(__file__).resolve().parents[1] / "examples" / "industrial_arm" / "reach_shelf.toml")
        return Problem(name, Path(s.scene), s.q_init, s.q_goal, 10, 0.05)
    raise SystemExit(f"unknown problem '{name}'; known: {', '.join(ALL_PROBLEMS + EXTRA_PROBLEMS)}")


class DenseChecker:
    """min over robot/obstacle geom pairs of mj_geomDistance, own code: robot geoms are collision geoms on
    bodies moved by a joint, obstacles the other collision geoms (as foam-mj verify)."""

    def __init__(self, robot: RobotModel) -> None:
        m = self.m = robot.model
        self.d = mujoco.MjData(m)
        self.to_qpos = robot.config.to_qpos

        def moving(b: int) -> bool:
            while b != 0:
                if m.body_jntnum[b] > 0:
                    return True
                b = int(m.body_parentid[b])
            return False

        colliding = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
        leg = [g for g in colliding if moving(int(m.geom_bodyid[g]))]
        obs = [g for g in colliding if not moving(int(m.geom_bodyid[g]))]
        self.pairs = [(g, o) for g in leg for o in obs]

    def min_clearance(self, path: np.ndarray) -> float:
        best = np.inf
        m, d, gd = self.m, self.d, mujoco.mj_geomDistance
        for a, b in zip(path[:-1], path[1:]):
            n = max(1, int(np.ceil(np.max(np.abs(b - a)) / CHECK_STEP)))
            for qpos in self.to_qpos(a + (b - a) * np.linspace(0.0, 1.0, n + 1)[:, None]):
                d.qpos[:] = qpos
                mujoco.mj_kinematics(m, d)
                best = min(best, min(gd(m, d, g, o, 1.0, None) for g, o in self.pairs))
        return float(best)


def qpos_length(robot: RobotModel, path: np.ndarray) -> float:
    qp = robot.config.to_qpos(path)[:, robot.config.qpos_index]
    return float(np.sum(np.linalg.norm(np.diff(qp, axis=0), axis=1)))


def run_ours(name: str, pb: Problem, oracle: BubbleOracle, checker: DenseChecker, seed: int, time_limit: float) -> dict:
    cls = PLANNERS[name]
    opts = {k: getattr(pb, k) for k in ("K", "r_min") if name in FOAM_FAMILY and k in option_names(cls)}
    planner = get_planner(name, **opts)
    prob = PlanningProblem(oracle, pb.q_init, pb.q_goal, delta=DELTA, time_limit=time_limit)
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        res = planner.plan(prob, seed=seed)
    except PlanningFailed as exc:
        st = exc.stats
        return {"ok": False, "outcome": getattr(st, "outcome", "failed"), "bubbles": getattr(st, "bubbles", None),
                "queries": getattr(st, "distance_queries", None), "time": time.perf_counter() - t0}
    except ConfigurationError as exc:  # a planner's own rule refuses the problem (pfm: root radius, Eq. 2's bound)
        return {"ok": False, "outcome": f"refused: {exc}", "bubbles": 0, "queries": 0, "time": time.perf_counter() - t0}
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
    return {
        "ok": True, "outcome": res.stats.outcome, "first": res.stats.time_to_first_path or t_plan, "plan": t_plan, "total": total, "total_cpu": total_cpu,
        "bubbles": res.stats.bubbles, "queries": res.stats.distance_queries, "rosary": res.rosary.k,
        "len_q": m.length, "len_qpos": qpos_length(oracle.robot, path), "len_sp": len_sp, "f": m.f, "clearance": checker.min_clearance(path),
        "certified": bool(sm.info.get("certified", False)),
    }


class OMPLRunner:
    """OMPL on the same MJCF: RealVectorStateSpace over q's bounds, valid when MuJoCo's clearance > delta."""

    def __init__(self, pb: Problem, oracle: BubbleOracle) -> None:
        from ompl import base as ob
        from ompl import geometric as og

        self.ob, self.og = ob, og
        r = oracle.robot
        n = self.n = r.dim
        self.space = ob.RealVectorStateSpace(n)
        bounds = ob.RealVectorBounds(n)
        for i in range(n):
            bounds.setLow(i, float(r.lower[i]))
            bounds.setHigh(i, float(r.upper[i]))
        self.space.setBounds(bounds)
        self.clearance = oracle.clearance
        self.checks = 0
        self.pb = pb

    def _setup(self):
        og = self.og
        ss = og.SimpleSetup(self.space)
        n, clearance = self.n, self.clearance

        def valid(state) -> bool:
            self.checks += 1
            return bool(clearance(np.array([state[i] for i in range(n)])) > DELTA)

        ss.setStateValidityChecker(valid)
        start, goal = self.space.allocState(), self.space.allocState()
        for i in range(n):
            start[i], goal[i] = float(self.pb.q_init[i]), float(self.pb.q_goal[i])
        ss.setStartAndGoalStates(start, goal)
        return ss

    def _path(self, p) -> np.ndarray:
        return np.array([[p.getState(k)[i] for i in range(self.n)] for k in range(p.getStateCount())])

    def rrtconnect(self, time_limit: float) -> dict:
        ss = self._setup()
        si = ss.getSpaceInformation()
        ss.setPlanner(self.og.RRTConnect(si))
        self.checks = 0
        t0, c0 = time.perf_counter(), time.process_time()
        solved = ss.solve(time_limit)
        first = time.perf_counter() - t0
        if not ss.haveExactSolutionPath():
            return {"ok": False, "outcome": str(solved), "time": first}
        p = ss.getSolutionPath()
        self.og.PathSimplifier(si).simplifyMax(p)
        total, total_cpu = time.perf_counter() - t0, time.process_time() - c0
        return {"ok": True, "first": first, "total": total, "total_cpu": total_cpu, "queries": self.checks, "path": self._path(p)}

    def optimizing(self, budget: float, which: str = "rrtstar") -> dict:
        ss = self._setup()
        si = ss.getSpaceInformation()
        ss.setOptimizationObjective(self.ob.PathLengthOptimizationObjective(si))
        ss.setPlanner(self.og.RRTstar(si) if which == "rrtstar" else self.og.BITstar(si))
        self.checks = 0
        t0 = time.perf_counter()
        ss.solve(budget)
        total = time.perf_counter() - t0
        if not ss.haveExactSolutionPath():
            return {"ok": False, "outcome": "no exact solution", "time": total}
        return {"ok": True, "first": float("nan"), "total": total, "queries": self.checks, "path": self._path(ss.getSolutionPath())}


def finish_ompl(rec: dict, robot: RobotModel, checker: DenseChecker) -> dict:
    if rec.get("ok"):
        path = rec.pop("path")
        m = metrics(path)
        rec.update(len_q=m.length, len_qpos=qpos_length(robot, path), f=m.f, clearance=checker.min_clearance(path), bubbles=None)
    return rec


def have_ompl() -> bool:
    try:
        import ompl.geometric  # noqa: F401
    except ImportError:
        return False
    return True


KEYS = ("first", "plan", "total", "total_cpu", "rosary", "bubbles", "queries", "len_q", "len_qpos", "len_sp", "f", "clearance")


def summarize(runs: list[dict]) -> dict:
    ok = [r for r in runs if r.get("ok")]
    med = {}
    for k in KEYS:
        vals = [r[k] for r in ok if r.get(k) is not None and np.isfinite(r[k])]
        med[k] = float(np.median(vals)) if vals else None
    failures: dict[str, int] = {}
    for r in runs:
        if not r.get("ok"):
            failures[str(r.get("outcome"))] = failures.get(str(r.get("outcome")), 0) + 1
    return {"ok": len(ok), "runs": len(runs), "median": med, "min_clearance": min((r["clearance"] for r in ok), default=None),
            "failures": failures}


def _fmt(v, scale=1.0, fmt="{:.0f}") -> str:
    return "-" if v is None else fmt.format(v * scale)


def write_json_atomic(path: str, data: dict) -> None:
    target = Path(path).resolve()
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    with os.fdopen(fd, "w") as fh:
        json.dump(data, fh, indent=1, default=float)
    os.replace(tmp, target)
    print(f"wrote {target}")


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10, help="seeds per planner and problem (default 10)")
    ap.add_argument("--planners", nargs="*", default=None, help=f"default: every registered planner ({', '.join(sorted(PLANNERS))})")
    ap.add_argument("--problems", nargs="*", default=None, help=f"default: {' '.join(ALL_PROBLEMS)}; also {' '.join(EXTRA_PROBLEMS)}")
    ap.add_argument("--time-limit", type=float, default=10.0, help="seconds per planning run before it counts as failed (default 10)")
    ap.add_argument("--no-ompl", action="store_true", help="skip the OMPL peers")
    ap.add_argument("--bitstar", action="store_true", help="also run OMPL's BIT* with 10x RRTConnect's time")
    ap.add_argument("--quick", action="store_true", help="CI: 3 seeds, the 3-joint scenes")
    ap.add_argument("--no-progress", action="store_true")
    ap.add_argument("--json", help="write every run and the medians as JSON")
    args = ap.parse_args(argv)
    if args.json and not Path(args.json).resolve().parent.is_dir():
        ap.error(f"--json: folder {Path(args.json).resolve().parent} does not exist")
    if args.seeds < 1:
        ap.error("--seeds must be >= 1")
    if not args.time_limit > 0:
        ap.error("--time-limit must be > 0")
    planners = args.planners or sorted(PLANNERS)
    for p in planners:
        if p not in PLANNERS:
            ap.error(f"unknown planner '{p}'; known: {', '.join(sorted(PLANNERS))}")
    names = args.problems or list(QUICK_PROBLEMS if args.quick else ALL_PROBLEMS)
    for p in names:
        if p not in ALL_PROBLEMS + EXTRA_PROBLEMS:
            ap.error(f"unknown problem '{p}'; known: {', '.join(ALL_PROBLEMS + EXTRA_PROBLEMS)}")
    seeds = 3 if args.quick and args.seeds == 10 else args.seeds
    use_ompl = not args.no_ompl and have_ompl()
    if use_ompl:
        from ompl import util as ou

        ou.setLogLevel(ou.LogLevel.LOG_WARN)
        ou.RNG.setSeed(1)  # once per process (OMPL's rule); runs then differ by the generator's state

    out: dict = {"seeds": seeds, "delta": DELTA, "time_limit": args.time_limit, "check_step": CHECK_STEP, "problems": {}}
    rows, ratio_rows = [], []
    t_start = time.perf_counter()
    for pname in names:
        pb = problem(pname)
        robot = RobotModel.from_xml(pb.mjcf)
        oracle = BubbleOracle(robot, delta=DELTA)
        checker = DenseChecker(robot)
        res: dict = {}
        jobs = len(planners) * seeds + (seeds * (2 + args.bitstar) if use_ompl else 0)
        done = 0
        for name in planners:
            runs = []
            for s in range(seeds):
                if not args.no_progress:
                    progress(done, jobs, f"{pname:>10}")
                runs.append(run_ours(name, pb, oracle, checker, s, args.time_limit))
                done += 1
            res[name] = {"summary": summarize(runs), "runs": runs}
        if use_ompl:
            runner = OMPLRunner(pb, oracle)
            rc, opt, bit = [], [], []
            for s in range(seeds):
                if not args.no_progress:
                    progress(done, jobs, f"{pname:>10}")
                r = finish_ompl(runner.rrtconnect(args.time_limit), robot, checker)
                rc.append(r)
                budget = 10 * r["total"] if r.get("ok") else args.time_limit
                opt.append(finish_ompl(runner.optimizing(budget, "rrtstar"), robot, checker))
                if args.bitstar:
                    bit.append(finish_ompl(runner.optimizing(budget, "bitstar"), robot, checker))
                done += 2 + args.bitstar
            res["ompl:rrtconnect+simplify"] = {"summary": summarize(rc), "runs": rc}
            res["ompl:rrtstar(10x)"] = {"summary": summarize(opt), "runs": opt}
            if args.bitstar:
                res["ompl:bitstar(10x)"] = {"summary": summarize(bit), "runs": bit}
        if not args.no_progress:
            progress(jobs, jobs, f"{pname:>10}")
        oracle.close()
        out["problems"][pname] = {"K": pb.K, "r_min": pb.r_min, "dim": len(pb.q_init), "planners": res}
        for name, r in res.items():
            m, sm = r["summary"]["median"], r["summary"]
            rows.append([
                pname, name, f"{sm['ok']}/{sm['runs']}", _fmt(m["first"], 1e3), _fmt(m["plan"], 1e3), _fmt(m["total"], 1e3),
                _fmt(m["total_cpu"], 1e3), _fmt(m["rosary"], 1, "{:.0f}"), _fmt(m["bubbles"], 1, "{:,.0f}"),
                _fmt(m["queries"], 1, "{:,.0f}"), _fmt(m["len_q"], 1, "{:.3f}"), _fmt(m["len_qpos"], 1, "{:.3f}"), _fmt(m["len_sp"], 1, "{:.3f}"),
                _fmt(m["f"], 1, "{:.3f}"),
                _fmt(m["clearance"], 1e3, "{:.1f}"), _fmt(sm["min_clearance"], 1e3, "{:.1f}"),
            ])
        if use_ompl:
            peer = res["ompl:rrtconnect+simplify"]["summary"]["median"]
            star = res["ompl:rrtstar(10x)"]["summary"]["median"]
            for name in planners:
                m = res[name]["summary"]["median"]

                def ratio(a, b):
                    return f"{a / b:.2f}" if a is not None and b else "-"

                ratio_rows.append([pname, name, ratio(m["total"], peer["total"]), ratio(m["len_qpos"], peer["len_qpos"]),
                                   ratio(m["len_qpos"], star["len_qpos"]), ratio(m["len_sp"], star["len_qpos"]),
                                   ratio(m["clearance"], peer["clearance"])])
    out["elapsed"] = time.perf_counter() - t_start
    print(f"\nmedians over {seeds} seeds (successful runs), delta = {DELTA * 1e3:.0f} mm, time limit {args.time_limit:g} s per run")
    print(table(["problem", "planner", "ok", "first ms", "plan ms", "total ms", "cpu ms", "chain", "bubbles", "queries", "len q", "len qpos", "sp qpos", "f", "clear mm", "worst mm"], rows))
    print("total: planning + the default smoother (optimal) for ours; solve + simplify (RRTConnect) or the whole budget (RRT*) for OMPL.")
    print(f"clear mm: median over seeds of the smallest MuJoCo distance along the final path, checked every {CHECK_STEP * 1e3:g} mrad; worst mm: the smallest over seeds.")
    failed = [(p, n, why, k) for p, v in out["problems"].items() for n, r in v["planners"].items() for why, k in r["summary"]["failures"].items()]
    if failed:
        print("\nfailed runs: " + "; ".join(f"{p} {n}: {k} x {why}" for p, n, why, k in failed))
    if use_ompl:
        print("\nratios ours / OMPL (medians)")
        print(table(["problem", "planner", "total time / RRTConnect", "len qpos / RRTConnect", "len qpos / RRT*", "sp qpos / RRT*", "clearance / RRTConnect"], ratio_rows))
    elif not args.no_ompl:
        print("\nOMPL is not installed (pip install -e \".[peers]\"): no peer rows")
    print(f"benchmark time {out['elapsed']:.1f} s")
    # Safety is the product: any path of ours closer than delta to an obstacle fails the benchmark (exit 1).
    broken = [(p, n, r["clearance"]) for p, v in out["problems"].items() for n in planners for r in v["planners"][n]["runs"]
              if r.get("ok") and r["clearance"] < DELTA - 1e-6]
    out["margin_violations"] = [{"problem": p, "planner": n, "clearance": c} for p, n, c in broken]
    if args.json:
        write_json_atomic(args.json, out)
    for p, n, c in broken:
        print(f"MARGIN BROKEN: {n} on {p}: {c * 1e3:.3f} mm < delta = {DELTA * 1e3:g} mm", file=sys.stderr)
    if use_ompl:
        # OMPL 2.0.1's nanobind bindings report leaked references at interpreter exit (harmless noise on
        # stderr); the results are written, so leave without running the finalizers.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(1 if broken else 0)
    if broken:
        raise SystemExit(1)
    return out


if __name__ == "__main__":
    main()
