"""Clearance calls and certified bubble radii per second (median of several runs).

    .venv/bin/python benchmarks/clearance.py [--json out.json]

Single: one configuration per call (mj_kinematics + mj_geomDistance over the 6 leg/obstacle pairs).
Batch: ``Clearance.batch`` on N configurations (distance sensors evaluated by mujoco.batch.Batch, position stage only).
Radii: ``BubbleOracle.radii`` on N configurations (batch clearance plus the radius formula).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import check_json, count, median_time, parser, run_script, table, write_json  # noqa: E402

from foam_mj.scenarios import load_scenario  # noqa: E402


def main(argv: list[str] | None = None) -> dict:
    ap = parser(__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the figures as JSON")
    ap.add_argument("--repeats", type=count(), default=7, help="timed runs per median (default 7)")
    args = ap.parse_args(argv)
    check_json(ap, args.json)
    scen = load_scenario("obstacle")
    oracle = scen.oracle()
    robot = scen.robot
    rng = np.random.default_rng(0)
    Q = rng.uniform(robot.lower, robot.upper, size=(4096, robot.dim))
    rows, out = [], {}
    n_single = 2000
    t = median_time(lambda: [oracle.clearance(q) for q in Q[:n_single]], args.repeats)
    out["single_call"] = {"per_second": n_single / t, "us_per_config": t / n_single * 1e6}
    rows.append(["clearance, one call per configuration", 1, n_single / t, t / n_single * 1e6])
    for n in (16, 64, 256, 1024, 4096):
        t = median_time(lambda: oracle.clearance.batch(Q[:n]), args.repeats)
        out[f"batch_{n}"] = {"per_second": n / t, "us_per_config": t / n * 1e6}
        rows.append(["clearance, batch", n, n / t, t / n * 1e6])
    for n in (64, 1024):
        t = median_time(lambda: oracle.radii(Q[:n]), args.repeats)
        out[f"radii_{n}"] = {"per_second": n / t, "us_per_config": t / n * 1e6}
        rows.append(["bubble radii, batch", n, n / t, t / n * 1e6])
    t = median_time(lambda: [oracle.radius(q) for q in Q[:n_single]], args.repeats)
    out["radius_single"] = {"per_second": n_single / t, "us_per_config": t / n_single * 1e6}
    rows.append(["bubble radius, one call (validated)", 1, n_single / t, t / n_single * 1e6])
    print(f"obstacle scene, {len(robot.pairs)} leg/obstacle geom pairs; median of {args.repeats} runs")
    print(table(["what", "batch", "per second", "us each"], [[a, b, f"{c:,.0f}", f"{d:.2f}"] for a, b, c, d in rows]))
    if args.json:
        write_json(args.json, out)
    oracle.close()
    return out


if __name__ == "__main__":
    run_script(main)
