"""Sweep throughput: plans per second in this process, on 1 and 2 local workers and on a local Ray instance
with 2 workers; the overhead per task and the start-up of each engine; what a 1-million-plan study costs.

Every engine runs the same tasks (the obstacle scenario, ``--plans`` seeds, the convex smoother, the
kinematic replay with joint torques unless ``--replay`` says otherwise) into a fresh output folder.

* ``in-process``: :func:`foam_mj.sweep.run_task` called in a loop here after one warm-up: the compute
  time of a plan, with no engine at all.
* ``wall``: the whole ``run_sweep`` call (start-up, every plan, writing Parquet).
* ``steady plans/s``: (plans - 1) / (time between the first and the last finished plan): the rate once
  the workers are up, which is what a long study sees.
* ``overhead/task``: steady time per plan times workers, minus the mean time of a plan measured inside
  its worker (the rows' ``task_time``): what the engine adds to each plan (pickling, scheduling, result
  transfer, Parquet), measured under the same load as the plans themselves.
* ``start-up``: wall minus the steady part: spawning workers (and starting Ray).
* ``driver CPU/task``: CPU time of this process (the driver: sending tasks, receiving rows, writing
  Parquet, and for Ray its client) per plan; CPU time, unlike wall time, hardly grows with the load.

On a machine shared with other work the wall times and the rates grow with the load (the load average
is printed); the in-process CPU time per plan does not, and gives the second 1-million-plan estimate.

Usage: python benchmarks/sweep.py [--plans 16] [--quick] [--replay kinematic] [--no-ray] [--json out.json]
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import check_json, count, parser, run_script, table, write_json  # noqa: E402

from foam_mj.sweep import run_task  # noqa: E402
from foam_mj.sweep_file import load_sweep  # noqa: E402
from foam_mj.sweep_run import run_sweep  # noqa: E402


def sweep_file(folder: Path, plans: int, replay: str) -> Path:
    p = folder / "bench.toml"
    p.write_text(f'scenario = "obstacle"\nseeds = {plans}\nsmoothers = "convex"\nreplay = "{replay}"\n')
    return p


def measure(sweep, out: Path, engine: str, workers: int) -> dict:
    stamps: list[float] = []
    inside: list[float] = []  # each plan's own time, measured in its worker (the rows' task_time)

    def got(rows: list[dict]) -> None:
        stamps.append(time.perf_counter())
        inside.append(rows[0]["task_time"])

    t0, c0 = time.perf_counter(), time.process_time()
    s = run_sweep(sweep, out, engine=engine, workers=workers, progress=False, on_rows=got)
    wall, driver_cpu = time.perf_counter() - t0, time.process_time() - c0
    n = s.run
    steady = (n - 1) / (stamps[-1] - stamps[0]) if n > 1 and stamps[-1] > stamps[0] else float("nan")
    startup = wall - n / steady if np.isfinite(steady) else float("nan")
    return {"engine": engine, "workers": workers, "plans": n, "failed": s.failed, "wall_s": wall, "plans_per_s": n / wall,
            "steady_plans_per_s": steady, "startup_s": startup, "task_in_worker_s": float(np.mean(inside)),
            "overhead_per_task_ms": 1000 * (workers / steady - float(np.mean(inside))),
            "driver_cpu_per_task_ms": 1000 * driver_cpu / max(n, 1)}


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__.split("\n\n")[0])
    ap.add_argument("--plans", type=count(2), default=16, help="plans per engine (default 16; at least 2: the rates need two)")
    ap.add_argument("--quick", action="store_true", help="6 plans, no Ray")
    ap.add_argument("--replay", default="kinematic", choices=["dynamic", "kinematic", "none"])
    ap.add_argument("--no-ray", action="store_true", help="skip the Ray engine")
    ap.add_argument("--json", metavar="OUT.json")
    args = ap.parse_args(argv)
    check_json(ap, args.json)
    plans = 6 if args.quick else args.plans
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        sweep = load_sweep(sweep_file(tmp, plans, args.replay))
        tasks = list(sweep.tasks())
        run_task(tasks[0])  # warm-up: imports, first model
        times, cpu = [], []
        for t in tasks:
            t0, c0 = time.perf_counter(), time.process_time()
            rows = run_task(t)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            assert all(r["outcome"] == "reached" for r in rows), rows[0].get("reason")
        task_s, cpu_s = float(np.median(times)), float(np.median(cpu))
        results = [{"engine": "in-process", "workers": 1, "plans": len(tasks), "failed": 0, "wall_s": float(np.sum(times)),
                    "plans_per_s": 1 / task_s, "steady_plans_per_s": 1 / task_s, "startup_s": 0.0,
                    "task_in_worker_s": float(np.mean(times)), "overhead_per_task_ms": 0.0, "driver_cpu_per_task_ms": 0.0}]
        runs = [("local", 1), ("local", 2)]
        if not (args.no_ray or args.quick):
            try:
                import ray  # noqa: F401

                runs.append(("ray", 2))
            except ImportError:
                print("ray is not installed: skipping the Ray engine (pip install 'foam-mj[cluster]')", file=sys.stderr)
        for i, (engine, workers) in enumerate(runs):
            print(f"running {plans} plans on {engine} with {workers} worker(s)...", file=sys.stderr)
            results.append(measure(sweep, tmp / f"out{i}", engine, workers))
    load = os.getloadavg()[0]
    print(f"obstacle scenario, convex smoother, {args.replay} replay; median plan in-process {task_s * 1000:.0f} ms wall, "
          f"{cpu_s * 1000:.0f} ms CPU; {os.cpu_count()} cores, load average {load:.1f} when done")
    print(table(["engine", "workers", "plans", "wall s", "start-up s", "plans/s", "steady plans/s", "overhead/task ms", "driver CPU/task ms"],
                [[r["engine"], r["workers"], r["plans"], r["wall_s"], r["startup_s"], r["plans_per_s"], r["steady_plans_per_s"],
                  r["overhead_per_task_ms"], r["driver_cpu_per_task_ms"]] for r in results], floatfmt=".3g"))
    one = next(r for r in results if r["engine"] == "local" and r["workers"] == 1)
    rates = {"measured": one["steady_plans_per_s"], "cpu": 1 / (cpu_s + max(one["overhead_per_task_ms"], 0.0) / 1000)}
    print(f"\n1,000,000 plans on N cores: at the 1-worker steady rate measured here ({rates['measured']:.2f} plans/s per core), "
          f"and at one plan per in-process CPU time plus the 1-worker overhead ({rates['cpu']:.2f} plans/s per core: an unloaded core)")
    cost = []
    for cores in (2, 16, 64, 256, 1024):
        cost.append({"cores": cores, "hours_measured": 1e6 / (rates["measured"] * cores) / 3600, "hours_cpu": 1e6 / (rates["cpu"] * cores) / 3600})
    print(table(["cores", "hours (measured rate)", "hours (CPU-time rate)"], [[c["cores"], c["hours_measured"], c["hours_cpu"]] for c in cost], floatfmt=".3g"))
    if args.json:
        write_json(args.json, {"replay": args.replay, "plans": plans, "task_s": task_s, "cpu_s": cpu_s, "load_average": load,
                               "engines": results, "rates_per_core": rates, "million": cost})
    return 0


if __name__ == "__main__":
    run_script(main)
