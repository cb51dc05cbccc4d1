"""Benchmark of MGOA and MOPSO (Elmi and Efe 2018), in two parts.

(a) Elmi and Efe 2018's experiment (foam_mj.planar2d): 1000 x 1000 maps with 80 (environment #1) and 50 (#2)
    random circular obstacles, section III's start and target points, n waypoints (default 8,
    "offsets" parametrization), objectives F1 (length, Eq. 12) and F2 (smoothness, Eq. 13), c_max = 1,
    c_min = 1e-5, 100 iterations. Prints

    * shortest path length, best smoothness and time versus swarm size (paper Figs. 6-9), median over
      ``--sweep-runs`` seeds, for MGOA (Eq. 6 as written), MGOA-r (Eq. 6 with the social term scaled
      by U[0, 1], the paper's remark) and MOPSO;
    * ER (Eq. 18) and SCM (Eq. 19) over ``--runs`` runs with swarm 500 (Table II's columns: average,
      std, median, best, worst) beside the paper's Table II. ER's "actual Pareto set" is the
      non-dominated union of every run's front of every algorithm on that map; SCM(A, B) compares the
      runs of A and B with the same seed. A run without a collision-free path counts as ER = 1 and
      SCM(it, other) = 0 (and is reported). ER is also given against a per-seed reference (the
      non-dominated union of the algorithms' runs with the same seed).

(b) On the obstacle scenario's rosary (planner seed 0): the Pareto smoothers MGOASmoother and
    MOPSOSmoother (defaults; with --full-paper also the paper's 500 x 100, on 2 seeds), front of (length, angle
    term of Nascimento et al. 2020 Eq. 5) over ``--rosary-runs`` seeds, from a random swarm and from one with a particle
    at the convex shortest path ("+convex"): front size, the shortest, knee and smoothest
    members and their length gap to the convex shortest path through the hatches (the lower bound on
    length), the share of the front that the convex path weakly dominates, time.

JSON with ``--json PATH``; ``--quick`` runs small swarms (well under a minute); progress on stderr.
Exit status 1 if a front path leaves its hatches (b) or a front claimed collision-free collides (a).

    python benchmarks/mgoa.py [--quick] [--json out/benchmarks/mgoa.json] [--runs 10] [--waypoints 8]
"""

from __future__ import annotations

import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import check_json, count, parser, run_script, table, write_json  # noqa: E402

from foam_mj.foam import plan  # noqa: E402
from foam_mj.planar2d import PAPER_ENVIRONMENTS, PlanarPathProblem, paper_environment  # noqa: E402
from foam_mj.scenarios import load_scenario  # noqa: E402
from foam_mj.smoothing.convex import ConvexShortestPath  # noqa: E402
from foam_mj.smoothing.goa import MGOA, MGOASmoother  # noqa: E402
from foam_mj.smoothing.pareto import error_ratio, metric_stats, nondominated, set_coverage, weakly_dominates  # noqa: E402
from foam_mj.smoothing.pso import MOPSO, MOPSOSmoother  # noqa: E402

DEFAULT_JSON = Path("out/benchmarks/mgoa.json")
#: Elmi and Efe 2018 Table II (10 runs): average, std, median, best, worst, as printed.
PAPER_TABLE2 = {
    "MGOA (ER)": (0.022, 0.0008, 0.025, 0.0023, 0.022),
    "MPSO (ER)": (0.0101, 0.005, 0.017, 0.0143, 0.028),
    "SCM(MGOA,MPSO)": (0.692, 0.105, 0.58, 0.712, 0.447),
    "SCM(MPSO,MGOA)": (0.221, 0.122, 0.257, 0.339, 0.162),
}
COLS = ("ave", "std", "median", "best", "worst")


class Progress:
    """One line per step on stderr."""

    def __init__(self, total: int) -> None:
        self.total, self.done, self.t0 = max(total, 1), 0, time.perf_counter()

    def step(self, label: str) -> None:
        self.done += 1
        sys.stderr.write(f"[{self.done}/{self.total} {time.perf_counter() - self.t0:6.1f}s] {label}\n")
        sys.stderr.flush()


def planar_algorithms(swarm: int, iterations: int) -> dict:
    return {
        "MGOA": MGOA(swarm_size=swarm, iterations=iterations),
        "MGOA-r": MGOA(swarm_size=swarm, iterations=iterations, random_social=True),
        "MOPSO": MOPSO(swarm_size=swarm, iterations=iterations),
    }


def run_planar(args, bar: Progress) -> tuple[dict, list[str]]:
    problems = []
    out: dict = {"maps": {}, "swarm_sweep": {}, "pareto_metrics": {}}
    for env in (1, 2):
        cmap = paper_environment(env)
        prob = PlanarPathProblem(cmap, args.waypoints)
        out["maps"][env] = {"n_obstacles": len(cmap.radii), "start": cmap.start.tolist(), "target": cmap.target.tolist(),
                            "map_seed": env, "radius_range": cmap.info["radius_range"],
                            "straight_line": float(np.linalg.norm(cmap.target - cmap.start)),
                            "straight_line_collision_free": cmap.collision_free(np.array([cmap.start, cmap.target]), prob.clearance),
                            "obstacles": {"centers": cmap.centers.tolist(), "radii": cmap.radii.tolist()}}

        # -- path length, smoothness and time versus swarm size (Figs. 6-9)
        sweep: dict = {}
        for N in args.sizes:
            for name, alg in planar_algorithms(N, args.iterations).items():
                lens, f2s, times, feas = [], [], [], 0
                for seed in range(args.sweep_runs):
                    r = alg.run(prob, seed=seed)
                    times.append(r.wall_time)
                    if r.feasible:
                        feas += 1
                        lens.append(float(r.objectives[:, 0].min()))
                        f2s.append(float(r.objectives[:, 1].min()))
                        problems += _check_planar(prob, r, f"env {env} {name} N={N} seed {seed}")
                    bar.step(f"env {env} sweep {name} N={N}")
                sweep.setdefault(name, []).append({
                    "swarm": N, "runs": args.sweep_runs, "feasible_runs": feas,
                    "length": float(np.median(lens)) if lens else None,
                    "smoothness": float(np.median(f2s)) if f2s else None,
                    "time": float(np.median(times))})
        out["swarm_sweep"][env] = sweep

        # -- ER and SCM over runs (Table II)
        fronts: dict[str, list[np.ndarray | None]] = {}
        times: dict[str, list[float]] = {}
        for name, alg in planar_algorithms(args.swarm, args.iterations).items():
            fronts[name], times[name] = [], []
            for seed in range(args.runs):
                r = alg.run(prob, seed=seed)
                times[name].append(r.wall_time)
                fronts[name].append(np.array(r.objectives) if r.feasible else None)
                if r.feasible:
                    problems += _check_planar(prob, r, f"env {env} {name} seed {seed}")
                bar.step(f"env {env} Table II {name} run {seed + 1}")
        allf = [f for fs in fronts.values() for f in fs if f is not None]
        reference = nondominated(np.concatenate(allf)) if allf else np.empty((0, 2))
        er = {name: [error_ratio(f, reference) if f is not None else 1.0 for f in fs] for name, fs in fronts.items()}
        # Second reading: the reference of run k is the non-dominated union of the algorithms' runs with seed k.
        er_seed: dict[str, list[float]] = {name: [] for name in fronts}
        for k in range(args.runs):
            fk = [fs[k] for fs in fronts.values() if fs[k] is not None]
            ref_k = nondominated(np.concatenate(fk)) if fk else np.empty((0, 2))
            for name, fs in fronts.items():
                er_seed[name].append(error_ratio(fs[k], ref_k) if fs[k] is not None else 1.0)

        def scm(a: str, b: str) -> list[float]:
            vals = []
            for fa, fb in zip(fronts[a], fronts[b]):
                if fb is None:
                    continue  # undefined: nothing to cover
                vals.append(set_coverage(fa, fb) if fa is not None else 0.0)
            return vals

        pairs = [("MGOA", "MOPSO"), ("MOPSO", "MGOA"), ("MGOA-r", "MOPSO"), ("MOPSO", "MGOA-r"),
                 ("MGOA", "MGOA-r"), ("MGOA-r", "MGOA")]
        scms = {f"SCM({a},{b})": scm(a, b) for a, b in pairs}
        out["pareto_metrics"][env] = {
            "swarm": args.swarm, "iterations": args.iterations, "runs": args.runs,
            "reference_front_size": len(reference),
            "ER": {name: metric_stats(v) for name, v in er.items()},
            "ER_per_seed_reference": {name: metric_stats(v) for name, v in er_seed.items()},
            "SCM": {k: metric_stats(v, higher_is_better=True) if v else None for k, v in scms.items()},
            "feasible_runs": {name: sum(f is not None for f in fs) for name, fs in fronts.items()},
            "front_size": {name: float(np.median([len(f) for f in fs if f is not None])) if any(f is not None for f in fs) else 0.0
                           for name, fs in fronts.items()},
            "shortest_length": {name: metric_stats([f[:, 0].min() for f in fs if f is not None]) if any(f is not None for f in fs) else None
                                for name, fs in fronts.items()},
            "time": {name: metric_stats(t) for name, t in times.items()},
            "per_run": {"ER": er, "ER_per_seed_reference": er_seed, "SCM": scms},
        }
    return out, problems


def _check_planar(prob: PlanarPathProblem, r, where: str) -> list[str]:
    return [f"{where}: front path {i} collides" for i, p in enumerate(prob.paths(r.X))
            if not prob.map.collision_free(p, prob.clearance)]


def rosary_methods(args) -> dict:
    """Name -> smoother; a name ending in "+convex" seeds one particle with the convex shortest path."""
    if args.quick:
        return {"MGOA": MGOASmoother(swarm_size=30, iterations=300), "MOPSO": MOPSOSmoother(swarm_size=50, iterations=300)}
    methods = {"MGOA": MGOASmoother(), "MOPSO": MOPSOSmoother(),
               "MGOA +convex": MGOASmoother(), "MOPSO +convex": MOPSOSmoother()}
    if args.full_paper:
        methods["MGOA (500x100, Eq. 6)"] = MGOASmoother(swarm_size=500, iterations=100, random_social=False)
        methods["MGOA-r (500x100)"] = MGOASmoother(swarm_size=500, iterations=100)
        methods["MOPSO (500x100)"] = MOPSOSmoother(swarm_size=500, iterations=100)
    return methods


def run_rosary(args, bar: Progress) -> tuple[dict, list[str]]:
    s = load_scenario("obstacle")
    oracle = s.oracle()
    try:
        rosary = plan(oracle, s.q_init, s.q_goal, s.params, seed=0).rosary
    finally:
        oracle.close()
    cv = ConvexShortestPath().smooth(rosary)
    convex_point = np.array([cv.length, cv.angle_term])
    out: dict = {"scenario": "obstacle", "planner_seed": 0, "bubbles": rosary.k, "dim": rosary.dim,
                 "convex": {"length": cv.length, "angle_term": cv.angle_term, "f": cv.f}, "methods": {}}
    problems = []
    for name, sm in rosary_methods(args).items():
        runs = []
        n_runs = min(args.rosary_runs, 2) if "500x100" in name else args.rosary_runs  # ~25 s per MGOA run
        initial = cv.waypoints if name.endswith("+convex") else None
        for seed in range(n_runs):
            pr = sm.front(rosary, initial, seed=seed)
            if not pr.all_in_hatches():
                problems.append(f"rosary {name} seed {seed}: a waypoint leaves its hatch")
            summ = pr.summary(cv.length)
            summ["share_dominated_by_convex"] = float(np.mean(weakly_dominates(convex_point, pr.front_objectives)))
            runs.append(summ)
            bar.step(f"rosary {name} seed {seed}")

        def med(key, sub=None):
            return float(np.median([r[key][sub] if sub else r[key] for r in runs]))

        out["methods"][name] = {
            "params": {"swarm_size": sm.swarm_size, "iterations": sm.iterations},
            "runs": len(runs),
            "front_size": med("front_size"),
            **{k: {"length": med(k, "length"), "angle_term": med(k, "angle_term"),
                   "length_ratio_to_convex": med(k, "length_ratio_to_convex")} for k in ("shortest", "knee", "smoothest")},
            "min_f": med("min_f"),
            "share_dominated_by_convex": med("share_dominated_by_convex"),
            "time": med("wall_time"),
            "per_run": runs,
        }
    return out, problems


def print_report(out: dict) -> None:
    a = out["planar"]
    for env, sweep in a["swarm_sweep"].items():
        m = a["maps"][env]
        print(f"\n(a) environment #{env}: {m['n_obstacles']} obstacles, SP {m['start']}, TP {m['target']}, "
              f"straight line {m['straight_line']:.1f} ({'free' if m['straight_line_collision_free'] else 'blocked'}); "
              f"median over {sweep[next(iter(sweep))][0]['runs']} run(s)")
        rows = []
        for name, pts in sweep.items():
            for p in pts:
                rows.append([name, p["swarm"], f"{p['feasible_runs']}/{p['runs']}",
                             p["length"] if p["length"] is not None else "-",
                             p["smoothness"] if p["smoothness"] is not None else "-", p["time"]])
        print(table(["algorithm", "swarm", "feasible", "shortest F1", "best F2", "time [s]"], rows))
    print("\nTable II, Elmi and Efe 2018 (as printed):")
    print(table(["metric"] + list(COLS), [[k] + list(v) for k, v in PAPER_TABLE2.items()]))
    for env, pm in a["pareto_metrics"].items():
        print(f"\nTable II, ours, environment #{env} (swarm {pm['swarm']}, {pm['iterations']} iterations, {pm['runs']} runs; "
              f"reference front {pm['reference_front_size']} points; feasible runs {pm['feasible_runs']}):")
        rows = [[f"{name} (ER)"] + [st[c] for c in COLS] for name, st in pm["ER"].items()]
        rows += [[f"{name} (ER, per-seed ref.)"] + [st[c] for c in COLS] for name, st in pm["ER_per_seed_reference"].items()]
        rows += [[k] + ([st[c] for c in COLS] if st else ["-"] * 5) for k, st in pm["SCM"].items()]
        print(table(["metric"] + list(COLS), rows))
        rows = [[name, pm["front_size"][name], (pm["shortest_length"][name] or {}).get("median", "-"),
                 pm["time"][name]["median"]] for name in pm["ER"]]
        print(table(["algorithm", "front size (median)", "shortest F1 (median)", "time [s] (median)"], rows))
    b = out["rosary"]
    c = b["convex"]
    print(f"\n(b) obstacle rosary ({b['bubbles']} bubbles, n = {b['dim']}): convex shortest path length {c['length']:.4f}, "
          f"angle term {c['angle_term']:.4f} (the length's lower bound); medians over runs")
    rows = []
    for name, mth in b["methods"].items():
        rows.append([name, f"{mth['params']['swarm_size']}x{mth['params']['iterations']}", mth["runs"], mth["front_size"],
                     *[f"{mth[k]['length']:.4f} / {mth[k]['angle_term']:.4f} ({100 * (mth[k]['length_ratio_to_convex'] - 1):+.2f}%)"
                       for k in ("shortest", "knee", "smoothest")],
                     mth["share_dominated_by_convex"], mth["time"]])
    print(table(["method", "swarm x it", "runs", "front", "shortest: length / angle (gap)", "knee", "smoothest",
                 "dominated by convex", "time [s]"], rows))


def main(argv: list[str] | None = None) -> int:
    p = parser(__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="small swarms and few runs (well under a minute)")
    p.add_argument("--json", default=None, help=f"write the results as JSON (e.g. {DEFAULT_JSON})")
    p.add_argument("--runs", type=count(), default=None, help="runs per algorithm for Table II (default 10; quick 3)")
    p.add_argument("--sweep-runs", type=count(), default=None, help="runs per swarm size (default 3; quick 1)")
    p.add_argument("--waypoints", type=count(1, 1000), default=8, help="waypoints between start and target (default 8)")
    p.add_argument("--rosary-runs", type=count(), default=None, help="seeds per rosary smoother (default 5; quick 1)")
    p.add_argument("--full-paper", action="store_true",
                   help="also run the paper's 500 x 100 on the rosary (2 seeds each, ~2 min)")
    args = p.parse_args(argv)
    q = args.quick
    args.runs = args.runs if args.runs is not None else (3 if q else 10)
    args.sweep_runs = args.sweep_runs if args.sweep_runs is not None else (1 if q else 3)
    args.rosary_runs = args.rosary_runs if args.rosary_runs is not None else (1 if q else 5)
    args.sizes = (50, 100) if q else (50, 100, 200, 300, 500)
    args.swarm = 100 if q else 500
    args.iterations = 40 if q else 100
    if args.json is not None:  # checked before any run; the default folder out/benchmarks is made, as `foam-mj bench` makes
        if args.json and Path(args.json).parent == DEFAULT_JSON.parent:  # its own (--json /nowhere/x.json made /nowhere)
            DEFAULT_JSON.parent.mkdir(parents=True, exist_ok=True)
        check_json(p, args.json)

    n_planar = 2 * 3 * (len(args.sizes) * args.sweep_runs + args.runs)
    n_rosary = sum(min(args.rosary_runs, 2) if "500x100" in k else args.rosary_runs for k in rosary_methods(args))
    bar = Progress(n_planar + n_rosary)
    t0 = time.perf_counter()
    planar, problems = run_planar(args, bar)
    rosary, problems_b = run_rosary(args, bar)
    out = {
        "settings": {"quick": q, "waypoints": args.waypoints, "parametrization": "offsets", "smoothness": "turning",
                     "delta": 0.0, "clearance": 1.0, "c_max": 1.0, "c_min": 1e-5, "iterations": args.iterations,
                     "swarm_sizes": list(args.sizes), "table2_swarm": args.swarm, "runs": args.runs,
                     "sweep_runs": args.sweep_runs, "rosary_runs": args.rosary_runs,
                     "environments": {k: {kk: list(vv) if isinstance(vv, tuple) else vv for kk, vv in v.items()}
                                      for k, v in PAPER_ENVIRONMENTS.items()}},
        "paper_table2": {k: dict(zip(COLS, v)) for k, v in PAPER_TABLE2.items()},
        "planar": planar,
        "rosary": rosary,
        "problems": problems + problems_b,
        "environment": {"python": platform.python_version(), "numpy": np.__version__, "machine": platform.machine()},
        "total_time": time.perf_counter() - t0,
    }
    print_report(out)
    print(f"\ntotal {out['total_time']:.1f} s")
    for msg in out["problems"]:
        print(f"PROBLEM: {msg}")
    if args.json:
        write_json(args.json, out)
    return 1 if out["problems"] else 0


if __name__ == "__main__":
    run_script(main)
