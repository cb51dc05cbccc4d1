"""Foam propagation over 20 seeds per scenario: median bubbles, rosary length, planning time, bubbles/s.

    .venv/bin/python benchmarks/foam.py [--seeds 20] [--json out.json] [--scenarios obstacle step_up ...]

The thesis (Nascimento and Alsina 2021, section 5.2) reports 1,544 bubbles in 16.05 s and 1,795 in 13.2 s for its
walker maps, about 100-140 bubbles/s. TC and SV are given for the centre path and after gradient
smoothing (Nascimento and Alsina 2021 Eq. 9; ``--no-smooth`` skips it).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import check_json, check_scenarios, count, parser, progress, run_script, table, write_json  # noqa: E402

from foam_mj.errors import PlanningFailed  # noqa: E402
from foam_mj.foam import plan  # noqa: E402
from foam_mj.paths import metrics  # noqa: E402
from foam_mj.scenarios import available_scenarios, load_scenario  # noqa: E402
from foam_mj.smoothing import GradientSmoothing  # noqa: E402

#: Nascimento and Alsina 2021, section 5.2: bubbles, search time (s), TC and SV of the walker maps' (unsmoothed) paths.
THESIS = {"walker_corridor": (1544, 16.0517, 0.7048, 0.8051), "walker_two_routes": (1795, 13.2180, 0.4220, 0.7308)}

DEFAULT = ["obstacle", "obstacle_thesis", "step_up", "step_down"]
#: The table's median columns: key, scale, format ("-" where every seed failed).
FOAM_COLUMNS = (("bubbles", 1, ",.0f"), ("rosary", 1, ".0f"), ("time", 1000, ".0f"), ("rate", 1, ",.0f"), ("tc", 1, ".4f"), ("sv", 1, ".4f"))


def run_scenario(name: str, seeds: int, smooth: bool = True) -> dict:
    scen = load_scenario(name)
    oracle = scen.oracle()
    try:
        plan(oracle, scen.q_init, scen.q_goal, scen.params, seed=0)  # warm-up
    except PlanningFailed:
        pass  # seed 0's failure is counted below
    rec = {"bubbles": [], "rosary": [], "time": [], "rate": [], "tc": [], "sv": [], "failed": 0, "mujoco_share": []}
    for s in range(seeds):
        progress(s, seeds, f"{name:>18}")
        calls0 = oracle.clearance.calls
        t = time.perf_counter()
        try:
            res = plan(oracle, scen.q_init, scen.q_goal, scen.params, seed=s)
        except PlanningFailed:
            rec["failed"] += 1
            continue
        el = time.perf_counter() - t
        m = metrics(res.rosary.path(res.rosary.center_waypoints()))
        rec["bubbles"].append(res.stats.bubbles)
        rec["rosary"].append(res.rosary.k)
        rec["time"].append(el)
        rec["rate"].append(res.stats.bubbles / el)
        rec["tc"].append(m.tc)
        rec["sv"].append(m.sv)
        if smooth:
            g = GradientSmoothing().smooth(res.rosary)
            rec.setdefault("tc_smoothed", []).append(g.tc)
            rec.setdefault("sv_smoothed", []).append(g.sv)
        rec["clearance_calls"] = rec.get("clearance_calls", 0) + oracle.clearance.calls - calls0
    progress(seeds, seeds, f"{name:>18}")
    oracle.close()
    return rec


def main(argv: list[str] | None = None) -> dict:
    ap = parser(__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=count(), default=20, help="seeds per scenario (default 20)")
    ap.add_argument("--scenarios", nargs="+", default=None, help=f"default: {' '.join(DEFAULT)} and any walker scenarios")
    ap.add_argument("--json", help="write the figures as JSON")
    ap.add_argument("--no-smooth", action="store_true", help="skip the gradient smoothing columns")
    args = ap.parse_args(argv)
    check_json(ap, args.json)
    names = args.scenarios or DEFAULT + [n for n in available_scenarios() if n.startswith("walker")]
    check_scenarios(ap, names)
    for name in names:
        algorithm = load_scenario(name, check=False).params.algorithm
        if algorithm != "pfm":
            ap.error(f"--scenarios: {name} plans with '{algorithm}'; this benchmark measures pfm (K, r_min): name a pfm scenario")
    out, rows = {}, []
    for name in names:
        rec = run_scenario(name, args.seeds, smooth=not args.no_smooth)
        med = {k: float(np.median(v)) for k, v in rec.items() if isinstance(v, list) and v}
        out[name] = {"median": med, "failed": rec["failed"], "seeds": args.seeds, "raw": {k: v for k, v in rec.items() if isinstance(v, list)}}
        rows.append(
            [name, *(f"{med[k] * scale:{fmt}}" if k in med else "-" for k, scale, fmt in FOAM_COLUMNS),
             f"{med['tc_smoothed']:.4f}" if "tc_smoothed" in med else "-", f"{med['sv_smoothed']:.4f}" if "sv_smoothed" in med else "-",
             f"{rec['failed']}/{args.seeds}"]
        )
        if name in THESIS:
            b, t, tc_, sv_ = THESIS[name]
            rows.append([f"  thesis {name}", f"{b:,}", "-", f"{t * 1000:.0f}", f"{b / t:,.0f}", f"{tc_:.4f}", f"{sv_:.4f}", "-", "-", "1 run"])
    print(f"\nmedians over {args.seeds} seeds")
    print(table(["scenario", "bubbles", "rosary", "plan ms", "bubbles/s", "TC", "SV", "TC smoothed", "SV smoothed", "failed"], rows))
    if args.json:
        write_json(args.json, out)
    return out


if __name__ == "__main__":
    run_script(main)
