"""CloudWalker maps over 20 seeds: median bubbles, planning time, TC and SV of the centre path, and which
route the foam took on Map 2, beside the thesis's figures (Nascimento and Alsina 2021, section 5.2).

    .venv/bin/python benchmarks/walker_routes.py [--seeds 20] [--json out.json]

The thesis reports one run per map: Map 1 (narrow corridor, r_min = 0.2, K = 6) 1,544 bubbles in
16.05 s, TC 0.7048, SV 0.8051; Map 2 (two routes, r_min = 0.25, K = 6) 1,795 bubbles in 13.2 s,
TC 0.4220, SV 0.7308. Its maps' dimensions are not given, so ours (models/walker_corridor.xml,
models/walker_two_routes.xml) are designed, not copied: compare orders of magnitude, not digits.

Route on Map 2: where the centre path's (x, y) polyline crosses the vertical line through the central
block's centre, read from the MJCF geom ``central_block``: below the block (short, narrow route), above
it (long, wide route), or both ("mixed").
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import check_json, count, parser, progress, run_script, table, write_json  # noqa: E402

from foam_mj.errors import PlanningFailed  # noqa: E402
from foam_mj.foam import plan  # noqa: E402
from foam_mj.model import RobotModel  # noqa: E402
from foam_mj.paths import metrics  # noqa: E402
from foam_mj.scenarios import load_scenario  # noqa: E402

MAPS = ("walker_corridor", "walker_two_routes")
#: Nascimento and Alsina 2021, section 5.2 (one run per map).
THESIS = {
    "walker_corridor": {"map": "Map 1 (narrow corridor)", "bubbles": 1544, "time": 16.0517, "tc": 0.7048, "sv": 0.8051},
    "walker_two_routes": {"map": "Map 2 (two routes)", "bubbles": 1795, "time": 13.2180, "tc": 0.4220, "sv": 0.7308},
}
ROUTE_GEOM = "central_block"


def block_extent(robot: RobotModel, name: str = ROUTE_GEOM) -> tuple[float, float, float]:
    """(x of the block's centre, y of its south face, y of its north face) for an axis-aligned box geom."""
    m = robot.model
    g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)
    if g < 0:
        raise ValueError(f"{robot.path}: no geom named '{name}'")
    pos, size = m.geom_pos[g], m.geom_size[g]
    return float(pos[0]), float(pos[1] - size[1]), float(pos[1] + size[1])


def route_taken(path: np.ndarray, x: float, south: float, north: float) -> str:
    """'short' when every crossing of the line at x is south of the block, 'long' when every one is north."""
    a, b = path[:-1, :2], path[1:, :2]
    cross = (a[:, 0] - x) * (b[:, 0] - x) < 0
    t = (x - a[cross, 0]) / (b[cross, 0] - a[cross, 0])
    ys = a[cross, 1] + t * (b[cross, 1] - a[cross, 1])
    if len(ys) and np.all(ys < south):
        return "short"
    if len(ys) and np.all(ys > north):
        return "long"
    return "mixed"


def run_map(name: str, seeds: int) -> dict:
    scen = load_scenario(name)
    oracle = scen.oracle()
    extent = block_extent(scen.robot) if name == "walker_two_routes" else None
    plan(oracle, scen.q_init, scen.q_goal, scen.params, seed=0)  # warm-up (thread pools, caches)
    rec: dict = {"bubbles": [], "rosary": [], "time": [], "tc": [], "sv": [], "length": [], "route": [], "failed": []}
    for s in range(seeds):
        progress(s, seeds, f"{name:>18}")
        t = time.perf_counter()
        try:
            res = plan(oracle, scen.q_init, scen.q_goal, scen.params, seed=s)
        except PlanningFailed:
            rec["failed"].append(s)
            continue
        elapsed = time.perf_counter() - t
        path = res.rosary.path(res.rosary.center_waypoints())
        m = metrics(path)
        rec["bubbles"].append(res.stats.bubbles)
        rec["rosary"].append(res.rosary.k)
        rec["time"].append(elapsed)
        rec["tc"].append(m.tc)
        rec["sv"].append(m.sv)
        rec["length"].append(m.length)
        if extent is not None:
            rec["route"].append(route_taken(path, *extent))
    progress(seeds, seeds, f"{name:>18}")
    oracle.close()
    return rec


def main(argv: list[str] | None = None) -> dict:
    ap = parser(__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=count(), default=20, help="seeds per map (default 20)")
    ap.add_argument("--json", help="write the figures as JSON")
    args = ap.parse_args(argv)
    check_json(ap, args.json)
    out, rows = {}, []
    for name in MAPS:
        rec = run_map(name, args.seeds)
        med = {k: float(np.median(rec[k])) for k in ("bubbles", "rosary", "time", "tc", "sv", "length") if rec[k]}
        routes = {k: rec["route"].count(k) for k in ("short", "long", "mixed")} if rec["route"] else None
        out[name] = {"median": med, "routes": routes, "failed": rec["failed"], "seeds": args.seeds, "thesis": THESIS[name], "raw": rec}
        th = THESIS[name]
        rows.append([f"{name} (ours)", f"{med.get('bubbles', 0):,.0f}", f"{med.get('time', 0):.3f}", f"{med.get('tc', 0):.4f}",
                     f"{med.get('sv', 0):.4f}", f"{len(rec['failed'])}/{args.seeds}"])
        rows.append([f"  thesis {th['map']}", f"{th['bubbles']:,}", f"{th['time']:.3f}", f"{th['tc']:.4f}", f"{th['sv']:.4f}", "1 run"])
    print(f"\nCloudWalker maps, medians over {args.seeds} seeds (K = 6; r_min 0.2 / 0.25 m; delta 0.05 m)")
    print(table(["map", "bubbles", "plan s", "TC", "SV", "failed"], rows))
    r = out["walker_two_routes"]["routes"]
    if r:
        raw = out["walker_two_routes"]["raw"]
        by_route = {}
        for want in ("short", "long"):
            tcs = [v for v, rt in zip(raw["tc"], raw["route"]) if rt == want]
            by_route[want] = float(np.median(tcs)) if tcs else float("nan")
        out["walker_two_routes"]["median_tc_by_route"] = by_route
        print(f"\nwalker_two_routes: short (narrow, 2.2 m) route {r['short']}, long (wide, 3.5 m) route {r['long']}, "
              f"mixed {r['mixed']} of {args.seeds - len(out['walker_two_routes']['failed'])} plans; "
              f"median TC short {by_route['short']:.3f}, long {by_route['long']:.3f}")
    if args.json:
        write_json(args.json, out)
    return out


if __name__ == "__main__":
    run_script(main)
