"""The two time laws on the same certified curves: toppra (time-optimal) versus our own (minimum-jerk,
stretched to fit the torque limits).

    .venv/bin/python benchmarks/timing.py [--json out.json] [--scenarios obstacle step_up step_down] [--repeats 3]

For each scene (seed 0) and path (centre, convex, optimal) the safe curve is built once
(``make_trajectory``) and re-timed by both laws under two sets of limits: the model's (velocity and
acceleration limits bind; actuator force ranges of 400 N m / 3000 N) and a tight torque limit (hip and
knee 60 N m, hip slide 400 N, where torque binds). Reported per case: duration (s), peak torque use
(max over the joints of peak |tau| / limit, tau from ``mj_inverse`` on the samples), peak |tau| per joint,
the largest jump of a joint acceleration between consecutive samples (rad/s^2 or m/s^2: 0 for a
continuous acceleration, the bang-bang switches for toppra), and the median time to compute the timing.
Medians over the cases are printed at the end.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import check_json, check_scenarios, count, median_time, parser, run_script, table, write_json  # noqa: E402

from foam_mj.dynamics import joint_loads  # noqa: E402
from foam_mj.pipeline import PATH_NAMES, plan_scenario, smooth_paths  # noqa: E402
from foam_mj.scenarios import load_scenario  # noqa: E402
from foam_mj.limits import Limits  # noqa: E402
from foam_mj.timing import retime  # noqa: E402
from foam_mj.trajectory import make_trajectory  # noqa: E402

LIMITS = {"model": Limits(), "tight": Limits(torque=(60.0, 60.0, 400.0))}
METHODS = ("toppra", "own")


def measure(robot, base, rosary, limits: Limits, method: str, repeats: int) -> dict:
    traj = retime(robot, base, rosary, limits, method)
    loads = joint_loads(robot, traj, limit=limits.resolve(robot)[2])
    dof = robot.model.jnt_dofadr[robot.config.joint_ids]
    jump = float(np.max(np.abs(np.diff(traj.qacc[:, dof], axis=0))))
    seconds = median_time(lambda: retime(robot, base, rosary, limits, method), repeats) if repeats else float("nan")
    return {
        "duration": traj.duration,
        "peak_use": float(np.max(loads.use)),
        "peak_torque": loads.peak.tolist(),
        "rms_torque": loads.rms.tolist(),
        "acc_jump": jump,
        "positive_work": float(np.sum(loads.positive_work)),
        "seconds": seconds,
    }


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__.split("\n\n")[0])
    ap.add_argument("--scenarios", nargs="+", default=["obstacle", "step_up", "step_down"])
    ap.add_argument("--paths", nargs="+", default=["centre", "convex", "optimal"], choices=PATH_NAMES, metavar="PATH",
                    help=f"paths to time (default centre convex optimal; any of {', '.join(PATH_NAMES)})")
    ap.add_argument("--repeats", type=count(0), default=3, help="timing repeats per case (0: skip the compute times)")
    ap.add_argument("--json", help="write the results as JSON")
    args = ap.parse_args(argv)
    check_json(ap, args.json)
    check_scenarios(ap, args.scenarios)

    rows, records = [], []
    for name in args.scenarios:
        scen = load_scenario(name)
        robot = scen.robot
        result = plan_scenario(scen, scen.seed)
        smoothed = smooth_paths(scen, result.rosary, tuple(p for p in args.paths if p != "centre"), scen.seed)
        for path_name in args.paths:
            res = smoothed[path_name]
            base = make_trajectory(robot, res.path, res.rosary)
            for lim_name, lim in LIMITS.items():
                out = {m: measure(robot, base, res.rosary, lim, m, args.repeats) for m in METHODS}
                t, o = out["toppra"], out["own"]
                records.append({"scenario": name, "path": path_name, "limits": lim_name, **{m: out[m] for m in METHODS}})
                rows.append([
                    name, path_name, lim_name,
                    f"{t['duration']:.3f}", f"{o['duration']:.3f}", f"{100 * (t['duration'] / o['duration'] - 1):+.0f}%",
                    f"{100 * t['peak_use']:.0f}%", f"{100 * o['peak_use']:.0f}%",
                    f"{t['acc_jump']:.1f}", f"{o['acc_jump']:.2f}",
                    f"{1e3 * t['seconds']:.0f}", f"{1e3 * o['seconds']:.0f}",
                ])
                print(f"{name} {path_name} {lim_name}: toppra {t['duration']:.3f} s, own {o['duration']:.3f} s", file=sys.stderr)
    headers = ["scene", "path", "limits", "T toppra s", "T own s", "toppra vs own", "use toppra", "use own",
               "acc jump toppra", "acc jump own", "ms toppra", "ms own"]
    print(table(headers, rows))
    summary = {}
    for lim_name in LIMITS:
        sel = [r for r in records if r["limits"] == lim_name]
        ratio = np.median([r["toppra"]["duration"] / r["own"]["duration"] for r in sel])
        summary[lim_name] = {
            "median_duration_ratio_toppra_over_own": float(ratio),
            "median_peak_use_toppra": float(np.median([r["toppra"]["peak_use"] for r in sel])),
            "median_peak_use_own": float(np.median([r["own"]["peak_use"] for r in sel])),
            "median_ms_toppra": float(1e3 * np.median([r["toppra"]["seconds"] for r in sel])),
            "median_ms_own": float(1e3 * np.median([r["own"]["seconds"] for r in sel])),
        }
        s = summary[lim_name]
        print(f"{lim_name} limits, median over {len(sel)} curves: toppra's duration is {s['median_duration_ratio_toppra_over_own']:.2f} x own's; "
              f"peak torque use {100 * s['median_peak_use_toppra']:.0f}% (toppra) vs {100 * s['median_peak_use_own']:.0f}% (own); "
              f"{s['median_ms_toppra']:.0f} ms vs {s['median_ms_own']:.0f} ms to compute")
    print("acc jump: largest change of a joint acceleration between consecutive 2 ms samples (0 = continuous); "
          "use: max over joints of peak |tau| / limit (tau by mj_inverse).")
    if args.json:
        write_json(args.json, {"limits": {k: {"torque": v.torque} for k, v in LIMITS.items()}, "cases": records, "summary": summary})
    return 0


if __name__ == "__main__":
    run_script(main)
