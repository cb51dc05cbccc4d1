"""Benchmark of the path smoothers on the obstacle task (Nascimento et al. 2020 Table 1, Nascimento and Alsina 2021 section 5.1).

On one fixed rosary (obstacle scene, q_init = [0.2 0.3 0.08], q_goal = [0.45 0.4536 1.45], K = 10,
r_min = 0.07, planner seed 0) it runs HS and GA 50 times each with Table 1's stop criterion (no
improvement of the population's mean f in 200 consecutive iterations, capped at 2 x 10^4), the
thesis's paths T, T_CA, T_RA, T_RCA and the convex reference, and prints

* Table 1's columns (time, f, iterations: mean, max, min, std) beside the paper's own figures;
* per method: median time, time per iteration and speed-up over the paper's per-iteration time,
  f, length, TC, SV (medians over runs), the length gap to the convex optimum and the f gap to the
  certified optimum of f (the optimal smoother) on the same rosary;
* for the obstacle, step-up and step-down scenarios (their TOMLs and seeds): every method's f gap to
  the optimum (absolute and percent) beside its median time, the optimum's time, KKT residual and
  iterations, the SV optimum beside gradient smoothing's SV, and (not with --quick) whether eight
  random starts find a better optimum than the default start.

The same goes to JSON (``--json PATH``). ``--quick`` does a few runs (for CI, well under a minute).
The exit status is 1 if any returned path has a waypoint outside its hatch, if any method finds a
lower f than the optimal smoother on a scenario's rosary, or if an optimum the gaps are measured to (the optimal
smoother's, of f or SV) is not certified.

    python benchmarks/smoothing.py [--runs 50] [--quick] [--json out/benchmarks/smoothing.json]
"""

from __future__ import annotations

import json
import platform
import sys
import time
from dataclasses import replace
from foam_mj.data import model_path
from pathlib import Path
from typing import TYPE_CHECKING, Callable, cast

from foam_mj.atomic import OutputError, atomic_write_text, check_output

if TYPE_CHECKING:  # numpy, MuJoCo, the planner and the smoothers (scipy, Clarabel) are imported by the runs: `bench --help`
    # and a bad argument load only the standard library
    from foam_mj.bubbles import BubbleOracle
    from foam_mj.rosary import Rosary
    from foam_mj.foam import FoamParams
    from foam_mj.smoothing import SmoothingResult, StopCriteria

Q_INIT = (0.2, 0.3, 0.08)
Q_GOAL = (0.45, 0.4536, 1.45)
PLANNER_SEED = 0
DEFAULT_JSON = Path("out/benchmarks/smoothing.json")

#: Nascimento et al. 2020 Table 1 (50 runs each; 1.8 GHz Core i7): (mean, max, min, std).
PAPER_TABLE1 = {
    "HS": {"time": (17.229, 23.432, 10.207, 4.0113), "f": (4.0198, 4.1505, 3.9115, 0.067772),
           "iterations": (4206.3, 6385, 3034, 962.95)},
    "GA": {"time": (27.112, 39.253, 16.7, 6.3739), "f": (3.9307, 3.985, 3.8576, 0.035699),
           "iterations": (3718.6, 5510, 2287, 935.18)},
}


def foam_params() -> FoamParams:
    """The benchmark rosary's foam: K = 10, r_min = 0.07, delta = 5 mm."""
    from foam_mj.foam import FoamParams

    return FoamParams(K=10, r_min=0.07, delta=0.005)


def table1_stop() -> StopCriteria:
    """Table 1's stop criterion: stall 200, capped at 2 x 10^4 (Nascimento et al. 2019's NI)."""
    from foam_mj.smoothing import StopCriteria

    return StopCriteria()


class Progress:
    """A plain-text progress bar on stderr (redrawn in place on a terminal, a line per 10% otherwise)."""

    def __init__(self, total: int, width: int = 30) -> None:
        self.total, self.done, self.width = max(total, 1), 0, width
        self.tty = sys.stderr.isatty()
        self._last_decile = -1
        self.t0 = time.perf_counter()

    def step(self, label: str) -> None:
        self.done += 1
        frac = self.done / self.total
        bar = "#" * int(frac * self.width) + "." * (self.width - int(frac * self.width))
        msg = f"[{bar}] {self.done}/{self.total} {time.perf_counter() - self.t0:6.1f}s {label}"
        if self.tty:
            sys.stderr.write("\r" + msg[:110].ljust(110))
            if self.done == self.total:
                sys.stderr.write("\n")
        elif int(frac * 10) != self._last_decile or self.done == self.total:
            self._last_decile = int(frac * 10)
            sys.stderr.write(msg + "\n")
        sys.stderr.flush()


def stats(x) -> dict:
    import numpy as np

    a = np.asarray(x, dtype=float)
    return {"mean": float(a.mean()), "max": float(a.max()), "min": float(a.min()),
            "std": float(a.std(ddof=1)) if a.size > 1 else 0.0, "median": float(np.median(a))}


def obstacle_rosary() -> tuple[BubbleOracle, Rosary, float]:
    from foam_mj.bubbles import BubbleOracle
    from foam_mj.foam import plan
    from foam_mj.model import RobotModel

    foam = foam_params()
    robot = RobotModel.from_xml(model_path("obstacle.xml"))
    oracle = BubbleOracle(robot, delta=foam.delta)
    res = plan(oracle, Q_INIT, Q_GOAL, foam, seed=PLANNER_SEED)
    return oracle, res.rosary, res.stats.elapsed


def run_benchmark(runs: int, quick: bool, progress: bool = True) -> dict:
    import numpy as np

    from foam_mj import paths
    from foam_mj.smoothing import (
        ConvexShortestPath,
        GeneticAlgorithm,
        GradientSmoothing,
        HarmonySearch,
        OptimalSmoother,
        RosaryAdjustment,
        center_path_result,
    )

    oracle, rosary, plan_time = obstacle_rosary()
    foam, stop = foam_params(), table1_stop()
    stochastic: dict[str, Callable[[int], SmoothingResult]] = {
        "HS": lambda s: HarmonySearch(stop=stop).smooth(rosary, seed=s),
        "GA": lambda s: GeneticAlgorithm(stop=stop).smooth(rosary, seed=s),
    }
    if not quick:
        stochastic["GA (beta~U[0,1])"] = lambda s: GeneticAlgorithm(beta=None, stop=stop).smooth(rosary, seed=s)
    repeats = 1 if quick else 3  # deterministic methods: median time over repeats
    deterministic = ["T", "T_CA", "T_RA", "T_RCA", "convex", "convex-smooth", "convex (adjusted rosary)",
                     "optimal", "optimal (adjusted rosary)"]
    bar = Progress(runs * len(stochastic) + repeats * len(deterministic)) if progress else None

    results: dict[str, list[SmoothingResult]] = {}
    times: dict[str, list[float]] = {}
    for name, fn in stochastic.items():
        results[name] = []
        for s in range(runs):
            results[name].append(fn(s))
            if bar:
                bar.step(f"{name} run {s + 1}")
        times[name] = [r.wall_time for r in results[name]]

    adjustment = RosaryAdjustment(r_min=foam.r_min)
    grad = GradientSmoothing()
    adjusted: SmoothingResult | None = None  # T_RA's first result (T_RA runs before the methods on its rosary)

    def adjusted_rosary() -> Rosary:
        assert adjusted is not None
        return adjusted.rosary

    det_fns: dict[str, Callable[[], SmoothingResult]] = {
        "T": lambda: center_path_result(rosary, "T"),
        "T_CA": lambda: replace(grad.smooth(rosary), method="T_CA"),
        "T_RA": lambda: adjustment.adjust(rosary, oracle).path,
        "T_RCA": lambda: replace(grad.smooth(adjusted_rosary()), method="T_RCA"),
        "convex": lambda: ConvexShortestPath().smooth(rosary),
        "convex-smooth": lambda: ConvexShortestPath(smoothness=10.0).smooth(rosary),
        "convex (adjusted rosary)": lambda: ConvexShortestPath().smooth(adjusted_rosary()),
        "optimal": lambda: OptimalSmoother().smooth(rosary),
        "optimal (adjusted rosary)": lambda: OptimalSmoother().smooth(adjusted_rosary()),
    }
    for name in deterministic:
        reps = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            r = det_fns[name]()
            reps.append((r, time.perf_counter() - t0))
            if name == "T_RA" and adjusted is None:
                adjusted = r  # the first repetition's result: its rosary is the adjusted one reported
            if bar:
                bar.step(name)
        results[name] = [reps[0][0]]
        times[name] = [float(np.median([t for _, t in reps]))]

    convex_len = {id(rosary): results["convex"][0].length,
                  id(results["T_RA"][0].rosary): results["convex (adjusted rosary)"][0].length}
    optimal_f = {id(rosary): results["optimal"][0].f,
                 id(results["T_RA"][0].rosary): results["optimal (adjusted rosary)"][0].f}

    out: dict = {
        "task": {"scene": "obstacle", "q_init": Q_INIT, "q_goal": Q_GOAL, "K": foam.K, "r_min": foam.r_min,
                 "delta": foam.delta, "planner_seed": PLANNER_SEED, "bubbles_in_rosary": rosary.k,
                 "planning_time": plan_time},
        "stop_criterion": {"stall_iterations": stop.stall_iterations,
                           "max_iterations": stop.max_iterations, "f_threshold": stop.f_threshold},
        "runs": runs,
        "quick": quick,
        "paper_table1": PAPER_TABLE1,
        "environment": {"python": platform.python_version(), "numpy": np.__version__,
                        "machine": platform.machine(), "processor": platform.processor() or platform.machine()},
        "methods": {},
        "hatch_violations": [],
    }
    for name, rs in results.items():
        ok = [r.rosary.all_in_hatches(r.waypoints) for r in rs]
        for i, good in enumerate(ok):
            if not good:
                out["hatch_violations"].append({"method": name, "run": i})
        its = [r.iterations for r in rs]
        tm = times[name]
        per_it = [t / max(i, 1) for t, i in zip(tm, its)]
        entry: dict = {
            "n": len(rs),
            "time": stats(tm),
            "f": stats([r.f for r in rs]),
            "iterations": stats(its),
            "evaluations": stats([r.evaluations for r in rs]),
            "length": stats([r.length for r in rs]),
            "angle_term": stats([r.angle_term for r in rs]),
            "tc": stats([r.tc for r in rs]),
            "sv": stats([r.sv for r in rs]),
            "length_gap_to_convex": stats([r.length - convex_len[id(r.rosary)] for r in rs]),
            "f_gap_to_optimum": stats([r.f - optimal_f[id(r.rosary)] for r in rs]),
            "f_gap_to_optimum_percent": stats([100 * (r.f / optimal_f[id(r.rosary)] - 1) for r in rs]),
            "time_per_iteration": stats(per_it),
            "stop_reasons": {k: int(v) for k, v in zip(*np.unique([r.stop_reason for r in rs], return_counts=True))},
            "objective": rs[0].objective,
            "all_in_hatches": bool(all(ok)),
            "per_run": [r.summary() for r in rs],
        }
        paper_key = name.split(" ")[0]
        if paper_key in PAPER_TABLE1 and name in ("HS", "GA"):
            p = PAPER_TABLE1[paper_key]
            paper_per_it = p["time"][0] / p["iterations"][0]
            entry["speedup_per_iteration_vs_paper"] = paper_per_it / entry["time_per_iteration"]["median"]
        out["methods"][name] = entry
    out["centre_path"] = paths.metrics(rosary.path(rosary.center_waypoints())).as_dict()
    return out


GAP_SCENES = ("obstacle", "step_up", "step_down")


def run_scene_gaps(runs: int, quick: bool, progress: bool = True) -> dict:
    """Every method's f gap to the certified optimum on the obstacle, step-up and step-down rosaries."""
    from foam_mj.foam import plan
    from foam_mj.scenarios import load_scenario
    from foam_mj.smoothing import ConvexShortestPath, GeneticAlgorithm, GradientSmoothing, HarmonySearch, OptimalSmoother, center_path_result

    stop = table1_stop()
    repeats = 1 if quick else 5
    stochastic = ("HS", "GA")
    deterministic = ("T", "T_CA", "convex", "convex-smooth", "optimal")
    per_scene = runs * len(stochastic) + repeats * len(deterministic) + 1 + (0 if quick else 1)
    bar = Progress(per_scene * len(GAP_SCENES)) if progress else None
    out: dict = {}
    for scene in GAP_SCENES:
        sc = load_scenario(scene)
        oracle = sc.oracle()
        try:
            rosary = plan(oracle, sc.q_init, sc.q_goal, cast("FoamParams", sc.params), seed=sc.seed).rosary  # (pfm's options)
        finally:
            oracle.close()
        fns: dict[str, Callable[..., SmoothingResult]] = {  # (each called with the seed)
            "HS": lambda s, r=rosary: HarmonySearch(stop=stop).smooth(r, seed=s),
            "GA": lambda s, r=rosary: GeneticAlgorithm(stop=stop).smooth(r, seed=s),
            "T": lambda s, r=rosary: center_path_result(r, "T"),
            "T_CA": lambda s, r=rosary: GradientSmoothing().smooth(r),
            "convex": lambda s, r=rosary: ConvexShortestPath().smooth(r),
            "convex-smooth": lambda s, r=rosary: ConvexShortestPath(smoothness=10.0).smooth(r),
            "optimal": lambda s, r=rosary: OptimalSmoother().smooth(r),
        }
        results: dict[str, list[SmoothingResult]] = {}
        times: dict[str, list[float]] = {}
        for name in stochastic + deterministic:
            n = runs if name in stochastic else repeats
            results[name], times[name] = [], []
            for s in range(n):
                t0 = time.perf_counter()
                results[name].append(fns[name](s))
                times[name].append(time.perf_counter() - t0)
                if bar:
                    bar.step(f"{scene}: {name}")
        best = results["optimal"][0]
        sv_opt = OptimalSmoother(objective="sv").smooth(rosary)
        if bar:
            bar.step(f"{scene}: optimal SV")
        entry: dict = {
            "bubbles_in_rosary": rosary.k,
            "optimum": {"f": best.f, "certified": bool(best.info["certified"]),
                        "kkt_stationarity": best.info["kkt_stationarity"], "iterations": best.iterations,
                        "time": stats(times["optimal"])},
            "sv_optimum": {"sv": sv_opt.sv, "certified": bool(sv_opt.info["certified"]),
                           "kkt_stationarity": sv_opt.info["kkt_stationarity"], "time": sv_opt.wall_time,
                           "t_ca_sv": results["T_CA"][0].sv},
            "methods": {},
        }
        for name, rs in results.items():
            entry["methods"][name] = {
                "n": len(rs),
                "f": stats([r.f for r in rs]),
                "f_gap": stats([r.f - best.f for r in rs]),
                "f_gap_percent": stats([100 * (r.f / best.f - 1) for r in rs]),
                "time": stats(times[name]),
                "all_in_hatches": bool(all(r.rosary.all_in_hatches(r.waypoints) for r in rs)),
            }
        if not quick:
            ms = OptimalSmoother(multistart=8).smooth(rosary, seed=0)
            starts = ms.info["starts"]
            entry["multistart"] = {
                "starts": len(starts),
                "default_value": starts[0]["value"],
                "best_value": ms.f,
                "best_start": ms.info["best_start"],
                "improvement": starts[0]["value"] - ms.f,
                "time": ms.wall_time,
            }
            if bar:
                bar.step(f"{scene}: multistart")
        out[scene] = entry
    return out


def format_scene_gaps(gaps: dict) -> str:
    lines = ["", "f gap to the certified optimum of f on each scenario's rosary (medians; HS and GA over their runs)"]
    hdr = f"{'rosary':<10} {'bubbles':>7} {'method':<14} {'f':>8} {'f gap':>9} {'f gap %':>8} {'t_med (s)':>10}"
    lines.append(hdr)
    lines.append("-" * len(hdr))
    for scene, e in gaps.items():
        for name, m in e["methods"].items():
            lines.append(f"{scene:<10} {e['bubbles_in_rosary']:>7} {name:<14} {m['f']['median']:8.4f} "
                         f"{m['f_gap']['median']:9.2e} {m['f_gap_percent']['median']:7.2f}% {m['time']['median']:10.4f}")
    lines.append("")
    lines.append("The optimum: time (median), KKT residual, SCP iterations; the SV optimum beside T_CA's SV")
    hdr = (f"{'rosary':<10} {'bubbles':>7} {'t_med (ms)':>10} {'KKT':>8} {'certified':>9} {'iters':>5} "
           f"{'SV opt':>8} {'T_CA SV':>8} {'SV KKT':>8} {'SV ms':>6}")
    lines.append(hdr)
    lines.append("-" * len(hdr))
    for scene, e in gaps.items():
        o, v = e["optimum"], e["sv_optimum"]
        lines.append(f"{scene:<10} {e['bubbles_in_rosary']:>7} {1e3 * o['time']['median']:10.1f} {o['kkt_stationarity']:8.1e} "
                     f"{'yes' if o['certified'] else 'NO':>9} {o['iterations']:5d} {v['sv']:8.5f} {v['t_ca_sv']:8.5f} "
                     f"{v['kkt_stationarity']:8.1e} {1e3 * v['time']:6.0f}")
    if any("multistart" in e for e in gaps.values()):
        lines.append("")
        lines.append("Multistart (default start + 8 random hatch points, seed 0): does any start beat the default?")
        for scene, e in gaps.items():
            ms = e["multistart"]
            better = ms["improvement"] > 1e-7
            lines.append(f"  {scene:<10} default {ms['default_value']:.8f}, best {ms['best_value']:.8f} "
                         f"({ms['best_start']}){'  BETTER by %.2e' % ms['improvement'] if better else ': no'}, {ms['time']:.1f} s")
    return "\n".join(lines)


def format_tables(res: dict) -> str:
    lines = []
    task = res["task"]
    lines.append(
        f"Obstacle rosary: {task['bubbles_in_rosary']} bubbles (K={task['K']}, r_min={task['r_min']}, "
        f"planner seed {task['planner_seed']}); {res['runs']} runs per stochastic method; stop: no better "
        f"population mean in {res['stop_criterion']['stall_iterations']} iterations, cap "
        f"{res['stop_criterion']['max_iterations']}."
    )
    lines.append("")
    lines.append("Table 1 (Nascimento et al. 2020) columns: mean / max / min / std")
    hdr = f"{'method':<26} {'time (s)':^36} {'f':^36} {'iterations':^36}"
    lines.append(hdr)
    lines.append("-" * len(hdr))

    def four(t):
        return " ".join(f"{v:8.5g}" if abs(v) < 1e5 else f"{v:8.3g}" for v in t)

    for name, m in res["methods"].items():
        row = [m[k] for k in ("time", "f", "iterations")]
        lines.append(f"{name:<26} " + "  ".join(f"{four((s['mean'], s['max'], s['min'], s['std'])):<34}" for s in row))
        if name in res["paper_table1"]:
            p = res["paper_table1"][name]
            cells = "  ".join(f"{four(p[k]):<34}" for k in ("time", "f", "iterations"))
            lines.append(f"{'  Nascimento et al. 2020 ' + name:<26} " + cells)
    lines.append("")
    lines.append("Paths (medians over runs); gap = length - convex optimum; f gap = f - certified optimum of f;")
    lines.append("both on the same rosary (T_RA and T_RCA: the adjusted one)")
    hdr2 = (f"{'method':<26} {'t_med (s)':>10} {'us/iter':>9} {'x paper':>8} {'f':>8} {'length':>8} "
            f"{'TC':>7} {'SV':>8} {'gap':>9} {'gap %':>7} {'f gap':>9} {'f gap %':>8}  stop")
    lines.append(hdr2)
    lines.append("-" * len(hdr2))
    for name, m in res["methods"].items():
        gap = m["length_gap_to_convex"]["median"]
        conv = m["length"]["median"] - gap
        speed = m.get("speedup_per_iteration_vs_paper")
        per_it = f"{m['time_per_iteration']['median'] * 1e6:9.1f}" if m["iterations"]["median"] > 0 else f"{'-':>9}"
        stops = ", ".join(f"{k}: {v}" for k, v in m["stop_reasons"].items())
        lines.append(
            f"{name:<26} {m['time']['median']:10.4f} {per_it} {('%7.0fx' % speed) if speed else '       -':>8} "
            f"{m['f']['median']:8.4f} {m['length']['median']:8.4f} {m['tc']['median']:7.4f} {m['sv']['median']:8.4f} "
            f"{gap:9.2e} {100 * gap / conv:6.2f}% {m['f_gap_to_optimum']['median']:9.2e} "
            f"{m['f_gap_to_optimum_percent']['median']:7.2f}%  {stops}"
        )
    c = res["centre_path"]
    lines.append("")
    lines.append(f"Centre path T: f {c['f']:.4f}, length {c['length']:.4f}, TC {c['tc']:.4f}, SV {c['sv']:.4f}")
    v = res["hatch_violations"]
    lines.append("All waypoints in their hatches." if not v else f"HATCH VIOLATIONS: {v}")
    return "\n".join(lines)


#: The most runs per stochastic method ``--runs`` takes (a typo of a few zeros would run for days).
MAX_RUNS = 10_000
#: Runs per stochastic method without ``--runs`` (Table 1's 50), and with ``--quick``.
RUNS, QUICK_RUNS = 50, 3


def build_parser():
    """``foam-mj bench``'s own parser (:class:`foam_mj.arguments.Parser`: one-line errors)."""
    from foam_mj.arguments import whole_number
    from foam_mj.cli import Parser

    ap = Parser(prog="foam-mj bench", description=__doc__.splitlines()[0],
                epilog="exit codes: 0 done; 1 a smoothed path left its hatches, a method found a lower f than the optimal "
                "smoother, an optimum is not certified, or an internal error; 2 bad argument or --json location; 130 interrupted.")
    ap.add_argument("--runs", type=whole_number, default=None, metavar="N",
                    help=f"runs per stochastic method, 1-{MAX_RUNS:,} (default: {RUNS}; with --quick, {QUICK_RUNS})")
    ap.add_argument("--quick", action="store_true", help="a few runs, for CI")
    ap.add_argument("--json", default=str(DEFAULT_JSON), metavar="OUT.json", help=f"where to write the JSON (default: {DEFAULT_JSON})")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    return ap


def main(argv: list[str] | None = None) -> int:
    from foam_mj.cli import UsageError  # one-line argument errors, exit 2

    ap = build_parser()
    try:
        args = ap.parse_args(argv)
        runs = args.runs if args.runs is not None else (QUICK_RUNS if args.quick else RUNS)
        if not 1 <= runs <= MAX_RUNS:
            ap.error(f"--runs must be in [1, {MAX_RUNS}] (runs per stochastic method; 50 take minutes), got {runs}")
    except UsageError as exc:
        print(exc, file=sys.stderr)
        return 2
    try:  # checked before any work: the default folder is created, anything else must exist and be writable
        if args.json == str(DEFAULT_JSON):
            DEFAULT_JSON.parent.mkdir(parents=True, exist_ok=True)
        check_output(args.json, "--json", suffix=".json")  # a str: '' is an empty name, not the folder '.'
        args.json = Path(args.json)
    except OutputError as exc:
        print(f"foam-mj: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"foam-mj: error: --json output {args.json}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    res = run_benchmark(runs, args.quick, progress=not args.no_progress)
    res["scene_gaps"] = run_scene_gaps(min(runs, 2) if args.quick else min(runs, 10), args.quick, progress=not args.no_progress)
    for scene, e in res["scene_gaps"].items():
        for name, m in e["methods"].items():
            if not m["all_in_hatches"]:
                res["hatch_violations"].append({"method": name, "scene": scene})
    beaten = [(scene, name) for scene, e in res["scene_gaps"].items() for name, m in e["methods"].items()
              if m["f_gap"]["min"] < -1e-6]
    uncertified = not_certified(res)
    print(format_tables(res))
    print(format_scene_gaps(res["scene_gaps"]))
    if beaten:
        print(f"\nA METHOD BEAT THE OPTIMUM OF f (a better local optimum; try OptimalSmoother(multistart=...)): {beaten}")
    if uncertified:
        print(f"\nAN OPTIMUM IS NOT CERTIFIED (the gaps above are to an uncertified point): {'; '.join(uncertified)}")
    try:
        atomic_write_text(args.json, json.dumps(res, indent=1))
    except OutputError as exc:
        print(f"foam-mj: error: {exc}", file=sys.stderr)
        return 2
    print(f"\nJSON written to {args.json}")
    return 1 if res["hatch_violations"] or beaten or uncertified else 0


def not_certified(res: dict) -> list[str]:
    """Where the benchmark's optimum, which every gap is measured to, is not a certified local optimum: the optimal
    smoother's runs on the benchmark rosary (and its adjusted one), and the f and SV optima on each scenario's rosary.
    A regression of the optimal smoother (exit 1), which the tables showed only as a 'NO' in one column."""
    out = [f"{name} run {i}: {run.get('stop_reason')}" for name, m in res.get("methods", {}).items() if name.startswith("optimal")
           for i, run in enumerate(m.get("per_run", [])) if not str(run.get("stop_reason", "")).startswith("certified")]
    for scene, e in res.get("scene_gaps", {}).items():
        out += [f"{scene} {which}" for which in ("optimum", "sv_optimum") if not e.get(which, {}).get("certified", False)]
    return out


if __name__ == "__main__":
    sys.exit(main())
