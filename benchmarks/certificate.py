"""How much the per-pair certificate grows the bubbles: the paper's single bound beside the per-pair one.

    .venv/bin/python benchmarks/certificate.py [--samples 2000] [--seeds 10] [--json out.json] [--scenarios obstacle ...]

Single bound (Nascimento and Alsina 2021, Eq. 4; what foam-mj computed before): r = (d(q) - delta) / ||rho||_2 with
d(q) = min over pairs and one rho over every robot geom. Per pair (foam_mj.bubbles now):
r = min_p (d_p(q) - delta) / ||rho_p||_2. Both are capped by the distance to the joint bounds. For each
scenario: the mean radius over ``--samples`` configurations drawn uniformly in the bounds (those with a
positive radius under either bound), and pfm's bubbles to the goal (median over ``--seeds`` seeds, and
how many seeds reach it) with either bound, for the scenarios whose planner is pfm. Times are wall times on a shared machine.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import check_json, check_scenarios, count, parser, progress, run_script, table, write_json  # noqa: E402

from foam_mj.bubbles import BubbleOracle  # noqa: E402
from foam_mj.errors import PlanningFailed  # noqa: E402
from foam_mj.foam import FoamParams, plan  # noqa: E402
from foam_mj.scenarios import available_scenarios, load_scenario  # noqa: E402


class SingleBoundOracle(BubbleOracle):
    """The paper's single bound: one clearance, one rho over every robot geom (the old BubbleOracle)."""

    def _single(self, d: np.ndarray, Q: np.ndarray) -> np.ndarray:
        to_bounds = np.minimum(Q - self.robot.lower, self.robot.upper - Q).min(axis=-1)
        return np.maximum(np.minimum((d - self.delta) / self.bound.ball_factor, to_bounds), 0.0)

    def radius(self, q) -> float:
        q = self.robot.validate(q)
        return float(self._single(np.asarray(self.clearance(q)), q))

    def radii(self, Q: np.ndarray) -> np.ndarray:
        Q = self.robot.validate_batch(Q)
        return self._single(self.clearance.batch(Q), Q)


def run_scenario(name: str, samples: int, seeds: int) -> dict:
    scen = load_scenario(name)
    robot = scen.robot
    p = scen.params
    pfm = p.algorithm == "pfm"
    params = FoamParams(K=p.K, r_min=p.r_min, delta=p.delta, max_bubbles=p.max_bubbles, time_limit=p.time_limit) if pfm else None
    rec: dict = {}
    Q = np.random.default_rng(0).uniform(robot.lower, robot.upper, (samples, robot.dim))
    oracles = {"single": SingleBoundOracle(robot, delta=scen.params.delta), "pair": BubbleOracle(robot, delta=scen.params.delta)}
    R = {k: o.radii(Q) for k, o in oracles.items()}
    free = (R["single"] > 0) | (R["pair"] > 0)
    assert np.all(R["pair"] >= R["single"] - 1e-12), "the per-pair radius is never below the single bound"
    for k in oracles:
        rec[f"mean_radius_{k}"] = float(R[k][free].mean())
    rec["radius_gain_median"] = float(np.median(R["pair"][free] / np.maximum(R["single"][free], 1e-12)))
    for k, oracle in oracles.items():
        bubbles, times, reached = [], [], 0
        for s in range(seeds if pfm else 0):
            progress(s, seeds, f"{name:>18} {k:>6}")
            t = time.perf_counter()
            try:
                res = plan(oracle, scen.q_init, scen.q_goal, params, seed=s)
            except PlanningFailed:
                continue
            reached += 1
            bubbles.append(res.stats.bubbles)
            times.append(time.perf_counter() - t)
        if pfm:
            progress(seeds, seeds, f"{name:>18} {k:>6}")
        rec[f"bubbles_{k}"] = float(np.median(bubbles)) if bubbles else float("nan")
        rec[f"time_{k}"] = float(np.median(times)) if times else float("nan")
        rec[f"reached_{k}"] = reached
        rec[f"raw_bubbles_{k}"] = bubbles
        oracle.close()
    rec["samples"], rec["seeds"], rec["free_samples"], rec["pfm"] = samples, seeds, int(free.sum()), pfm
    return rec


def main(argv: list[str] | None = None) -> dict:
    ap = parser(__doc__.splitlines()[0])
    ap.add_argument("--samples", type=count(1, 1_000_000), default=2000, help="random configurations per scenario for the mean radius")
    ap.add_argument("--seeds", type=count(), default=10, help="pfm seeds per scenario and bound")
    ap.add_argument("--scenarios", nargs="+", default=None, help="default: every built-in scenario (pfm runs only on those whose planner is pfm)")
    ap.add_argument("--json", help="write the figures as JSON")
    args = ap.parse_args(argv)
    check_json(ap, args.json)
    names = args.scenarios or available_scenarios()
    check_scenarios(ap, names)
    out, rows = {}, []
    for name in names:
        rec = run_scenario(name, args.samples, args.seeds)
        out[name] = rec
        rows.append(
            [
                name,
                f"{rec['mean_radius_single']:.4f}",
                f"{rec['mean_radius_pair']:.4f}",
                f"{rec['mean_radius_pair'] / rec['mean_radius_single'] - 1:+.1%}",
                *(
                    [
                        f"{rec['bubbles_single']:,.0f} ({rec['reached_single']}/{args.seeds})",
                        f"{rec['bubbles_pair']:,.0f} ({rec['reached_pair']}/{args.seeds})",
                        f"{rec['time_single'] * 1000:.0f}",
                        f"{rec['time_pair'] * 1000:.0f}",
                    ]
                    if rec["pfm"]
                    else ["-", "-", "-", "-"]
                ),
            ]
        )
    print(f"mean certified radius over {args.samples} uniform configurations (those with room); pfm bubbles to the goal, median over {args.seeds} seeds (seeds reaching it)")
    print(table(["scenario", "r single", "r per pair", "gain", "bubbles single", "bubbles per pair", "ms single", "ms per pair"], rows))
    if args.json:
        write_json(args.json, out)
    return out


if __name__ == "__main__":
    run_script(main)
