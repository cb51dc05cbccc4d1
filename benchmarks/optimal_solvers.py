"""Why the optimal smoother uses sequential convex programming: the same problem handed to scipy's solvers.

For the obstacle, step-up and step-down rosaries, minimise f (Nascimento et al. 2020 Eq. 5) and SV (Nascimento and Alsina 2021 Eq. 7)
over the waypoints in their hatches (balls shrunk by 1e-6), from the convex reference's shortest path:

* ``scp``: :class:`foam_mj.smoothing.OptimalSmoother` (Clarabel subproblems, ties, certificate);
* ``slsqp``: scipy SLSQP with the analytic gradient and ball constraints; for f the angle is not
  differentiable at straight vertices, so it runs a continuation on sqrt(phi^2 + eps^2) - eps,
  eps = 1e-1 .. 1e-6 (each stage warm-started, 500 iterations each at most);
* ``trust-constr``: scipy's interior point with the same data (1,000 iterations at most).

Each row: objective reached, its gap to the best of the three, the scaled KKT residual of
:func:`foam_mj.smoothing.kkt_certificate`, the wall and CPU time (medians of 3), every solver in one thread
(``OMP_NUM_THREADS`` and ``OPENBLAS_NUM_THREADS`` are set to 1 unless set already). Prints a table (about two
minutes). Run: ``.venv/bin/python benchmarks/optimal_solvers.py [--json out.json]``.
"""

from __future__ import annotations

import os
import sys
import time
import warnings
from pathlib import Path

# One thread for every solver, as Clarabel (our SCP's) runs: OpenBLAS's default thread per core spun on a busy machine and
# made SLSQP 5x slower in wall time (41 s against 8 s on the obstacle rosary's f, 2 cores). Set before numpy loads.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from scipy.optimize import NonlinearConstraint, minimize  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import check_json, parser, run_script, table, write_json  # noqa: E402

from foam_mj import paths  # noqa: E402
from foam_mj.foam import plan  # noqa: E402
from foam_mj.scenarios import load_scenario  # noqa: E402
from foam_mj.smoothing import ConvexShortestPath, Hatches, ObjectiveWeights, OptimalSmoother, kkt_certificate  # noqa: E402
from foam_mj.smoothing.objective import objective_and_gradient  # noqa: E402

INSET = 1e-6
EPS_SCHEDULE = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6)


def scipy_solve(ros, w: ObjectiveWeights, method: str) -> np.ndarray:
    h = Hatches.of(ros)
    m, n = h.m, ros.dim
    ra2, rb2 = (h.ra - INSET) ** 2, (h.rb - INSET) ** 2
    rows, cols = np.repeat(np.arange(m), n), np.arange(m * n)

    def cfun(x):
        W = x.reshape(m, n)
        return np.concatenate([ra2 - np.sum((W - h.ca) ** 2, 1), rb2 - np.sum((W - h.cb) ** 2, 1)])

    def cjac(x):
        W = x.reshape(m, n)
        J = np.zeros((2 * m, m * n))
        J[rows, cols] = (-2 * (W - h.ca)).ravel()
        J[m + rows, cols] = (-2 * (W - h.cb)).ravel()
        return J

    x = ConvexShortestPath(inset=INSET).smooth(ros).waypoints.ravel()
    for eps in EPS_SCHEDULE if w.angle else (0.0,):
        def fg(x, eps=eps):
            v, g = objective_and_gradient(ros.path(x.reshape(m, n)), w, eps)
            return v, g[1:-1].ravel()

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if method == "slsqp":
                r = minimize(fg, x, jac=True, method="SLSQP", constraints=[{"type": "ineq", "fun": cfun, "jac": cjac}],
                             options={"maxiter": 500, "ftol": 1e-14})
            else:
                r = minimize(fg, x, jac=True, method="trust-constr", constraints=[NonlinearConstraint(cfun, 0, np.inf, jac=cjac)],
                             options={"maxiter": 1000 // len(EPS_SCHEDULE) if w.angle else 1000, "gtol": 1e-10, "xtol": 1e-12})
        x = r.x
    return h.project(x.reshape(m, n), INSET)


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the figures as JSON")
    args = ap.parse_args(argv)
    check_json(ap, args.json)
    out, rows = {}, []
    for scene in ("obstacle", "step_up", "step_down"):
        sc = load_scenario(scene)
        oracle = sc.oracle()
        ros = plan(oracle, sc.q_init, sc.q_goal, sc.params, seed=sc.seed).rosary
        oracle.close()
        for objective in ("f", "sv"):
            w = ObjectiveWeights.named(objective)
            found = {}
            for method in ("scp", "slsqp", "trust-constr"):
                times, cpu, W = [], [], None
                for _ in range(3):
                    t0, c0 = time.perf_counter(), time.process_time()
                    W = (OptimalSmoother(objective=objective).smooth(ros).waypoints if method == "scp"
                         else scipy_solve(ros, w, method))
                    times.append(time.perf_counter() - t0)
                    cpu.append(time.process_time() - c0)
                p = ros.path(W)
                value = float(paths.objective(p)) if objective == "f" else float(paths.sv(p))
                cert = kkt_certificate(ros, W, w, INSET)
                found[method] = {"value": value, "kkt": cert.stationarity, "seconds": float(np.median(times)), "cpu_seconds": float(np.median(cpu)),
                                 "inside": bool(np.all(Hatches.of(ros).inside(W, INSET / 2)))}
            best = min(v["value"] for v in found.values())
            for method, v in found.items():
                v["gap"] = v["value"] - best
                rows.append([scene, ros.k, objective, method, f"{v['value']:.8f}", f"{v['gap']:.2e}", f"{v['kkt']:.1e}",
                             f"{1e3 * v['seconds']:.0f}", f"{1e3 * v['cpu_seconds']:.0f}", "yes" if v["inside"] else "NO"])
            out[f"{scene}/{objective}"] = found
            print(f"{scene} {objective} done", file=sys.stderr)
    print(table(["rosary", "bubbles", "objective", "solver", "value", "gap to best", "scaled KKT", "ms", "cpu ms", "inside"], rows))
    if args.json:
        write_json(args.json, {**out, "threads": {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}})
    return 0


if __name__ == "__main__":
    run_script(main)
