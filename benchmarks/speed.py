"""Speed of every step that a user waits for, in one run, with its target beside it.

    .venv/bin/python benchmarks/speed.py [--quick] [--repeats 5] [--json out.json]

Rows (obstacle scenario, its default seed, unless named):

* ``optimal``: OptimalSmoother (the default smoother) to its certificate, beside the convex shortest
  path (one SOCP) and the certificate's KKT residual;
* ``GA / generation``, ``HS / improvisation``: Nascimento et al. 2020's GA and HS with their default stop (Table 1's
  criterion, capped at 2 x 10^4; ``--quick``: 200 generations, 4,000 improvisations), wall time divided
  by the generations / improvisations run;
* ``MGOA``, ``MOPSO``: Elmi and Efe 2018's parameters on its planar environment #1 (swarm 500, 100 iterations,
  8 waypoints);
* ``gradient (T_CA)``, ``adjusted (T_RA)``: Nascimento and Alsina 2021's gradient smoothing (Eq. 9) and rosary
  adjustment (Eq. 8) to their stop criteria;
* ``pfm foam growth``: bubbles per second of foam_mj.foam.plan over seeds 0..4;
* ``foam-mj --help``, ``foam-mj plan --scene obstacle``: wall time of the console command in a new
  process (start-up included; plan writes its recording to a temporary folder, through its helper
  process when a core is free for it (foam_mj.recorder): the CPU column then includes the helper's);
* ``walker replay``: the "replay" phase of ``foam-mj plan --scene walker_*`` (time laws, joint loads,
  kinematic and dynamic replays of its paths; ``--quick``: one run per scene).

Every number is a median of ``--repeats`` runs (>= 5; ``--quick``: 3, and smaller GA/HS/MGOA runs). The
JSON (``--json``) holds every row, the raw times, the machine's core count and load average at the start
and at the end: absolute times measured while other work runs are slower, so the table says so when
the load average is above half the core count.

``--quick`` (CI) exits 1 only on ratios that cannot be noise, each measured in the same process
moments apart (:data:`RATIO_LIMITS`): e.g. the optimal smoother more than 40x slower than the convex
SOCP it starts from (CPU time: a loaded machine preempts a 15-subproblem run more than a single solve;
the 20 ms target would be about 5x; it measures 15-25x), a GA generation more than 15x slower than an HS
improvisation.
"""

from __future__ import annotations

import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import check_json, count, parser, run_script, table, write_json  # noqa: E402

#: row -> (target, unit, "<=" or ">="): the targets of the speed issue.
TARGETS = {
    "optimal": (20.0, "ms", "<="),
    "GA / generation": (36.0, "us", "<="),
    "HS / improvisation": (15.0, "us", "<="),
    "MGOA (500 x 100, planar #1)": (0.5, "s", "<="),
    "MOPSO (500 x 100, planar #1)": (0.5, "s", "<="),
    "gradient (T_CA)": (50.0, "ms", "<="),
    "adjusted (T_RA)": (50.0, "ms", "<="),
    "pfm foam growth": (20000.0, "bubbles/s", ">="),
    "foam-mj --help": (0.25, "s", "<="),
    "foam-mj plan --scene obstacle": (1.5, "s", "<="),
    "walker_corridor replay": (2.0, "s", "<="),
    "walker_two_routes replay": (2.0, "s", "<="),
}

#: CI limits on ratios of two timings taken in the same run (name -> (numerator, denominator, limit)).
#: Only gross regressions trip them (CPU times, see :func:`ratios`). Measured on the 2-core machine, idle
#: to a load average of 15: optimal / convex 15-25 (35 before the solver reuse); GA generation / HS
#: improvisation 5-8.5 (so not 10: it would trip on noise; a Python loop over GA's 50 individuals would
#: give about 50); --help / import numpy 0.3-0.7; replay step / mj_step 2-6.
RATIO_LIMITS = {
    "optimal / convex": ("optimal", "convex", 40.0),
    "GA generation / HS improvisation": ("GA / generation", "HS / improvisation", 15.0),
    "foam-mj --help / python -c 'import numpy'": ("foam-mj --help", "python -c 'import numpy'", 2.0),
    "replay step / raw mj_step": ("walker replay per step", "raw mj_step", 10.0),
}


_CPU: dict[int, float] = {}  # id(times list) -> median CPU time of the same runs


def _median(fn, repeats: int) -> tuple[float, list[float], object]:
    """Median wall time of fn() over ``repeats`` runs after one warm-up; also the raw times and the last
    result. The median CPU time of this process over the same runs is kept for :func:`cpu_of`."""
    out = fn()
    times, cpu = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        times.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    _CPU[id(times)] = float(np.median(cpu))
    return float(np.median(times)), times, out


def _command(args: list[str], repeats: int, cwd: str) -> tuple[float, list[float]]:
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parent.parent)
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")

    def run():
        subprocess.run(args, cwd=cwd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def child_cpu() -> float:
        t = os.times()
        return t.children_user + t.children_system

    run()
    times, cpu = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), child_cpu()
        run()
        times.append(time.perf_counter() - t)
        cpu.append(child_cpu() - c)
    _CPU[id(times)] = float(np.median(cpu))  # the command's own CPU time (user + system)
    return float(np.median(times)), times


def measure(quick: bool, repeats: int, log=print) -> dict:
    from foam_mj.foam import plan
    from foam_mj.scenarios import load_scenario
    from foam_mj.smoothing import (ConvexShortestPath, GeneticAlgorithm, GradientSmoothing, HarmonySearch,
                                   OptimalSmoother, RosaryAdjustment, StopCriteria)

    rows: dict[str, dict] = {}

    def row(name: str, value: float, unit: str, times=None, **extra) -> None:
        rows[name] = {"value": value, "unit": unit, "times": times, **extra}
        if "cpu" not in extra and times is not None and id(times) in _CPU:  # CPU time in the row's unit (scaled like the value)
            rows[name]["cpu"] = value * _CPU[id(times)] / float(np.median(times))
        target = TARGETS.get(name)
        log(f"  {name}: {value:.4g} {unit}" + (f" (target {target[2]} {target[0]:g})" if target else ""))

    s = load_scenario("obstacle")
    oracle = s.oracle()
    seed = s.seed
    try:
        # -- foam growth
        counts, secs, cpus = [], [], []
        plan(oracle, s.q_init, s.q_goal, s.params, seed=seed)  # warm-up
        for sd in range(repeats):
            t, c = time.perf_counter(), time.process_time()
            res = plan(oracle, s.q_init, s.q_goal, s.params, seed=sd)
            secs.append(time.perf_counter() - t)
            cpus.append(time.process_time() - c)
            counts.append(res.stats.bubbles)
        row("pfm foam growth", float(np.median([n / t for n, t in zip(counts, secs)])), "bubbles/s", secs,
            cpu=float(np.median([n / c for n, c in zip(counts, cpus)])), bubbles=counts)
        rosary = plan(oracle, s.q_init, s.q_goal, s.params, seed=seed).rosary
        # -- smoothers
        med, times, _ = _median(lambda: ConvexShortestPath().smooth(rosary), repeats)
        row("convex", med * 1e3, "ms", times)
        med, times, r = _median(lambda: OptimalSmoother().smooth(rosary, seed=seed), repeats)
        row("optimal", med * 1e3, "ms", times, kkt_stationarity=r.info["kkt_stationarity"], certified=bool(r.info["certified"]),
            f=r.f, subproblems=r.iterations)
        # Full: the papers' runs as `foam-mj plan --smoother hs,ga` makes them (Table 1's stop criterion,
        # capped at 2 x 10^4); quick: fixed short runs (HS's early improvisations cost more: the memory is
        # replaced often, so its speculative blocks are short).
        if quick:
            ga = GeneticAlgorithm(stop=StopCriteria(max_iterations=200, stall_iterations=None))
            hs = HarmonySearch(stop=StopCriteria(max_iterations=4000, stall_iterations=None))
        else:
            ga, hs = GeneticAlgorithm(), HarmonySearch()
        med, times, r = _median(lambda: ga.smooth(rosary, seed=seed), repeats)
        row("GA / generation", med / r.iterations * 1e6, "us", times, generations=r.iterations, f=r.f)
        med, times, r = _median(lambda: hs.smooth(rosary, seed=seed), repeats)
        row("HS / improvisation", med / r.iterations * 1e6, "us", times, improvisations=r.iterations, f=r.f)
        med, times, r = _median(lambda: GradientSmoothing().smooth(rosary), repeats)
        row("gradient (T_CA)", med * 1e3, "ms", times, steps=r.iterations, sv=r.sv)
        adj = RosaryAdjustment(r_min=s.params.r_min)
        med, times, r = _median(lambda: adj.adjust(rosary, oracle), repeats)
        row("adjusted (T_RA)", med * 1e3, "ms", times, tc=r.path.tc)
    finally:
        oracle.close()

    # -- Elmi and Efe 2018's swarms on its planar environment
    from foam_mj.planar2d import PlanarPathProblem, paper_environment
    from foam_mj.smoothing.goa import MGOA
    from foam_mj.smoothing.pso import MOPSO

    prob = PlanarPathProblem(paper_environment(1), 8)
    swarm, iters = (100, 20) if quick else (500, 100)
    for label, alg in (("MGOA", MGOA(swarm_size=swarm, iterations=iters)), ("MOPSO", MOPSO(swarm_size=swarm, iterations=iters))):
        med, times, _ = _median(lambda: alg.run(prob, seed=0), repeats if not quick else 1)
        name = f"{label} ({swarm} x {iters}, planar #1)"
        if name not in TARGETS:
            name = f"{label} ({swarm} x {iters}, planar #1, quick)"
        row(name, med, "s", times)

    # -- replay of the walker scenes (pipeline phase "replay") and the raw cost of a simulation step
    import mujoco

    from foam_mj.pipeline import run

    steps, wall, cpu = 0, 0.0, 0.0
    for scene in ("walker_corridor", "walker_two_routes"):
        # `foam-mj plan --scene walker_*`'s replay phase (pipeline.run's timings["replay"]: time laws, joint
        # loads, kinematic and dynamic replays of every path); its CPU time from the first "replaying" report
        sc = load_scenario(scene)
        walls, cpus = [], []
        for _ in range(1 if quick else repeats):
            marks: list[float] = []
            outcome = run(sc, report=lambda msg, marks=marks: marks.append(time.process_time())
                          if msg.startswith("replaying") and not marks else None)
            cpus.append(time.process_time() - marks[0])
            walls.append(outcome.timings["replay"])
        n_steps = sum(len(po.trajectory) for po in outcome.paths.values())
        t, c = float(np.median(walls)), float(np.median(cpus))
        steps, wall, cpu = steps + n_steps, wall + t, cpu + c
        row(f"{scene} replay", t, "s", walls, cpu=c, simulated_steps=n_steps, paths=list(outcome.paths))
    robot = load_scenario("walker_corridor").robot
    m, d = robot.model, mujoco.MjData(robot.model)
    n_raw = 2000
    t, c = time.perf_counter(), time.process_time()
    for _ in range(n_raw):
        mujoco.mj_step1(m, d)
        mujoco.mj_step2(m, d)
    t, c = (time.perf_counter() - t) / n_raw, (time.process_time() - c) / n_raw
    # a replayed step poses the leg, steps the simulation, runs inverse dynamics and a clearance query
    row("walker replay per step", wall / steps * 1e6, "us", None, cpu=cpu / steps * 1e6)
    row("raw mj_step", t * 1e6, "us", None, cpu=c * 1e6)

    # -- the console command, start-up included
    exe = str(Path(sys.executable).with_name("foam-mj"))
    with tempfile.TemporaryDirectory() as tmp:
        med, times = _command([sys.executable, "-c", "import numpy"], repeats, tmp)
        row("python -c 'import numpy'", med, "s", times)
        med, times = _command([exe, "--help"], repeats, tmp)
        row("foam-mj --help", med, "s", times)
        med, times = _command([exe, "plan", "--scene", "obstacle", "--rrd", str(Path(tmp) / "o.rrd")], repeats, tmp)
        row("foam-mj plan --scene obstacle", med, "s", times)
    return rows


def ratios(rows: dict) -> dict:
    out = {}
    for name, (a, b, limit) in RATIO_LIMITS.items():
        # CPU time where both rows have it (a busy machine preempts a long run more than a short one;
        # CPU time is what the code costs), else wall time
        key = "cpu" if "cpu" in rows[a] and "cpu" in rows[b] else "value"
        value = rows[a][key] / rows[b][key]
        out[name] = {"value": value, "limit": limit, "ok": bool(value <= limit), "of": "cpu" if key == "cpu" else "wall"}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="3 repeats and smaller GA/HS/MGOA/MOPSO runs (CI)")
    ap.add_argument("--repeats", type=count(), default=None, help="runs per median (default 5; --quick: 3)")
    ap.add_argument("--json", metavar="OUT.json", help="write every row, the ratios and the machine's load")
    args = ap.parse_args(argv)
    check_json(ap, args.json)
    repeats = args.repeats if args.repeats is not None else (3 if args.quick else 5)
    cores = os.cpu_count() or 1
    load0 = os.getloadavg()
    print(f"speed benchmark ({'quick' if args.quick else 'full'}; median of {repeats}); {cores} cores, "
          f"load average {load0[0]:.2f} at the start", flush=True)
    rows = measure(args.quick, repeats, log=lambda s: print(s, file=sys.stderr, flush=True))
    load1 = os.getloadavg()
    busy = max(load0[0], load1[0]) > cores / 2
    print()
    table_rows = []
    for name, r in rows.items():
        target = TARGETS.get(name)
        if target:
            ok = r["value"] <= target[0] if target[2] == "<=" else r["value"] >= target[0]
            verdict = "met" if ok else "NOT met"
            tgt = f"{target[2]} {target[0]:g}"
        else:
            verdict, tgt = "", "(reference)"
        cpu = f"{r['cpu']:.4g}" if "cpu" in r else ""
        table_rows.append([name, f"{r['value']:.4g}", cpu, r["unit"], tgt, verdict])
    print(table(["step", "median", "CPU", "unit", "target", ""], table_rows))
    print("median: wall time (or its rate); CPU: the same runs in CPU time of this process (of the command's\n"
          "process for foam-mj ...), which a busy machine inflates less; verdicts compare the median")
    rq = ratios(rows)
    print()
    print(table(["ratio (same run)", "value", "of", "CI limit", ""],
                [[k, f"{v['value']:.3g}", v["of"], f"<= {v['limit']:g}", "ok" if v["ok"] else "FAIL"] for k, v in rq.items()]))
    if busy:
        print(f"\nmeasured under load (load average {load0[0]:.2f} -> {load1[0]:.2f} on {cores} cores): absolute times are "
              "slower than on an idle machine; the ratios compare timings taken moments apart")
    if args.json:
        write_json(args.json, {
            "benchmark": "speed", "quick": args.quick, "repeats": repeats,
            "machine": {"cores": cores, "load_average_start": list(load0), "load_average_end": list(load1),
                        "under_load": busy, "platform": platform.platform(), "python": platform.python_version()},
            "targets": {k: {"value": v[0], "unit": v[1], "sense": v[2]} for k, v in TARGETS.items()},
            "rows": rows, "ratios": rq,
        })
    failed = [k for k, v in rq.items() if not v["ok"]]
    if failed and args.quick:
        print(f"FAIL: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    run_script(main)
