"""The shortest polyline through a chain of bubbles: a small second-order cone program.

Waypoint i of the polyline lies in the hatch b_i ∩ b_(i+1) of a chain of overlapping balls b_0 .. b_m (each ball
shrunk by INSET); each segment then lies in one ball, so the path keeps the balls' margin. Minimising the sum of
the segments' (weighted) lengths is a second-order cone program (a sum of norms: Lobo, Vandenberghe, Boyd and Lebret,
"Applications of second-order cone programming", Linear Algebra and its Applications, 1998), solved with the
interior-point solver Clarabel (Goulart and Chen, arXiv, 2024). The
program is that of :func:`foam_mj.smoothing.convex.build_socp`; its bubble-independent parts are cached per chain
length (:func:`_socp_template`). The corridor (:mod:`foam_mj.planners.corridor`) solves it for each refinement round's chain.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.lib.stride_tricks import as_strided

from foam_mj.paths import row_norms
from foam_mj.planners.chains import INSET

#: Clarabel's iteration cap for the corridor's cone programs (its default).
SOLVER_MAX_ITER = 200


@lru_cache(maxsize=128)
def _socp_template(m: int, n: int, metric: tuple[float, ...] | None):
    """The parts of :func:`foam_mj.smoothing.convex.build_socp`'s program for m waypoints in R^n that do not depend
    on the bubbles (P, q, A with the segment rows weighted by ``metric``, the cones), and where b takes the
    bubbles and the end points: (P, q, A, cones, rows of q_init, rows of q_goal, ball radius rows, ball centre
    rows, row weights or None). P, q and A are held as Python lists for Clarabel's constructor
    (:func:`foam_mj.smoothing.convex.csc_lists`; the same solutions).

    A is build_socp's own entries (:func:`foam_mj.smoothing.convex.socp_pattern`) written in CSC order directly: the
    column of waypoint coordinate (i, e) holds, rows ascending, -1 and +1 in segment cones i and i + 1 (weighted by
    ``metric``: the vector rows of segment cone j, j (n + 1) + 1 .. j (n + 1) + n) and -1 in its two ball cones; the
    column of t_j holds -1 in row j (n + 1). The same matrix, entry for entry, as sorting the pattern's entries
    (:func:`foam_mj.smoothing.convex.to_csc`, tested), in a third of the time (0.13 -> 0.04 ms at m = 60, n = 3) and
    far less than building the program on a rosary of zeros (0.83-0.86 ms per chain length, m 10-109, n 3). A
    benchmark pays it for most programs: each chain length's first program builds its template."""
    import clarabel

    from foam_mj.smoothing.convex import csc_lists

    cd = n + 1
    d = np.arange(n)
    nw, nt = m * n, m + 1
    off = nt * cd
    nrow = (nt + 2 * m) * cd
    row_w = None
    s = np.ones(n) if metric is None else np.asarray(metric, dtype=float)
    if metric is not None:
        row_w = np.ones(nrow)
        row_w[(np.arange(nt)[:, None] * cd + 1 + d).ravel()] = np.tile(s, nt)
    seg = (np.arange(m)[:, None] * cd + 1 + d).ravel()  # waypoint coordinate (i, e)'s row in segment cone i
    ball = off + (np.arange(m)[:, None] * (2 * cd) + 1 + d).ravel()  # and in its first ball cone
    rows = np.empty((nw, 4), dtype=np.int64)
    rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3] = seg, seg + cd, ball, ball + cd
    vals = np.full((nw, 4), -1.0)
    vals[:, 0], vals[:, 1] = np.tile(-1.0 * s, m), np.tile(1.0 * s, m)  # (as -1 and +1 times the row weights)
    A = csc_lists(np.concatenate([vals.ravel(), np.full(nt, -1.0)]), np.concatenate([rows.ravel(), np.arange(nt) * cd]),
                  np.concatenate([np.arange(0, 4 * nw + 1, 4), 4 * nw + 1 + np.arange(nt)]), (nrow, nw + nt))
    P = csc_lists([], [], [0] * (nw + nt + 1), (nw + nt, nw + nt))
    q = [0.0] * nw + [1.0] * nt
    cones = [clarabel.SecondOrderConeT(cd)] * (nt + 2 * m)
    first = 1 + d  # segment 0: (t_0, w_1 - q_init)
    last = m * cd + 1 + d  # segment m: (t_m, q_goal - w_m)
    bbase = off + (np.arange(m)[:, None] * 2 + np.arange(2)) * cd  # (m, 2): both balls of each waypoint
    brow = bbase[..., None] + 1 + d  # (m, 2, n)
    return P, q, A, cones, first, last, bbase.ravel(), brow.ravel(), row_w


def shortest_path(
    centers: np.ndarray, radii: np.ndarray, q_init: np.ndarray, q_goal: np.ndarray, metric: np.ndarray | None = None,
    tol: float = 1e-8, status: list | None = None,
) -> tuple[np.ndarray, float]:
    """Waypoints (k-1, n) of the shortest polyline through the chain's hatches, and its length.

    ``metric``: per-coordinate weights s (length sum_j |s * (p_(j+1) - p_j)|, e.g. the configuration map's
    qpos units per q unit: the length in MuJoCo's qpos); None is the Euclidean length in q. The balls stay
    balls in q (the weights scale only the segment cones' rows), so the program stays a small SOCP: the
    program of :func:`foam_mj.smoothing.convex.build_socp` (balls shrunk by INSET), its bubble-independent
    parts cached per chain length (:func:`_socp_template`). ``status``: a list that gets Clarabel's status appended
    (the waypoints are its last iterate whatever the status: :func:`held` tells whether they lie in their balls)."""
    centers = np.asarray(centers, dtype=float)
    radii = np.asarray(radii, dtype=float)
    q_init = np.asarray(q_init, dtype=float)
    q_goal = np.asarray(q_goal, dtype=float)
    k, n = centers.shape
    sw = 1.0 if metric is None else np.asarray(metric, dtype=float)
    m = k - 1
    if m == 0:
        return np.empty((0, n)), float(np.linalg.norm((q_goal - q_init) * sw))
    P, q, A, cones, first, last, bbase, brow, row_w = _socp_template(m, n, None if metric is None else tuple(np.asarray(sw).tolist()))
    b = np.zeros(A.shape[0])
    b[first] = -q_init
    b[last] = q_goal
    # Both balls of each waypoint, (r_i, r_(i+1)) and (c_i, c_(i+1)): overlapping windows of the arrays (views).
    b[bbase] = as_strided(radii, (m, 2), (radii.strides[0],) * 2).ravel() - INSET
    b[brow] = -as_strided(centers, (m, 2, n), (centers.strides[0], *centers.strides)).ravel()
    if row_w is not None:
        b *= row_w
    import clarabel

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    # Without presolve (nothing to remove) and iterative refinement: 40 % less time for the same path to 1e-8. With refinement
    # on 5-7 joints every program is Solved (1-6 a plan end InsufficientProgress without), 20-25 % fewer iterations, no faster.
    settings.presolve_enable = False
    settings.iterative_refinement_enable = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = tol
    settings.max_iter = SOLVER_MAX_ITER
    sol = clarabel.DefaultSolver(P, q, A, b.tolist(), cones, settings).solve()
    if status is not None:
        status.append(str(sol.status).rsplit(".", 1)[-1])
    pts = np.empty((m + 2, n))
    pts[0], pts[1:-1], pts[-1] = q_init, np.reshape(sol.x[: m * n], (m, n)), q_goal
    d = (pts[1:] - pts[:-1]) * sw
    return pts[1:-1], float(np.sum(row_norms(d)))


__all__ = ["SOLVER_MAX_ITER", "shortest_path"]
