"""The convex reference: the shortest path through the hatches as a second-order cone program.

    minimise    sum_j t_j  (+ lambda sum_i |p_(i-1) - 2 p_i + p_(i+1)|^2)
    subject to  |p_(j+1) - p_j| <= t_j                        j = 0..k-1   (segment lengths)
                |w_i - c_i| <= r_i - eps,  |w_i - c_(i+1)| <= r_(i+1) - eps   i = 1..k-1   (hatches)

with p_0 = q_init, p_i = w_i (the waypoints, Nascimento et al. 2020 Eq. 3), p_k = q_goal. With lambda = 0 it is
the shortest polyline through the hatches; its length bounds from below every path whose waypoints
lie in the (shrunk) hatches, so it is the yardstick for HS, GA and the thesis's methods
(docs/bubbles-math.md). With lambda > 0 the squared second differences (a convex stand-in
for the turning angles of Eq. 4, which are not convex) trade length for smoothness.

A sum of Euclidean norms under norm constraints is a second-order cone program (Lobo, Vandenberghe, Boyd and Lebret,
"Applications of second-order cone programming", Linear Algebra and its Applications, 1998). Solved to optimality by
Clarabel (Goulart and Chen, "Clarabel: an interior-point solver for conic programs with quadratic objectives",
arXiv, 2024; interior point; the problem is convex, so the optimum is global),
with the sparse matrices built in one vectorized pass. The balls are shrunk by ``inset`` (default
1e-6 in configuration units) so that the returned waypoints lie strictly inside the hatches despite
the solver's feasibility tolerance (1e-8); the solution is then projected onto the shrunk hatches
(a no-op up to rounding) and checked to be at least inset/2 inside every ball. The length lost to
the inset is at most about 2 x inset per hatch.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from types import SimpleNamespace
from typing import ClassVar

import clarabel
import numpy as np
import scipy.sparse as sp

from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import (
    Hatches,
    SeedLike,
    SmoothingResult,
    Smoother,
    _check_positive,
    check_initial,
    check_rosary,
    check_seed,
    trivial_result,
)


class ConvexSolveError(RuntimeError):
    """Clarabel did not reach an optimal solution."""


@dataclass(frozen=True)
class ConvexShortestPath(Smoother):
    """Shortest (``smoothness`` = 0) or smoothness-weighted path through the hatches, solved by Clarabel.

    ``initial`` and ``seed`` are accepted for the common interface and unused (the optimum is unique in
    length and found from scratch); both are still validated. The balls are shrunk by ``inset``, or by less
    in a hatch too thin for it (:meth:`Hatches.fitting_inset`; ``info["inset"]`` is the one used).
    """

    smoothness: float = 0.0
    inset: float = 1e-6
    tol: float = 1e-9

    name: ClassVar[str] = "convex"

    def __post_init__(self) -> None:
        _check_positive("smoothness", self.smoothness, allow_zero=True)
        _check_positive("inset", self.inset)
        _check_positive("tol", self.tol)

    @property
    def method(self) -> str:
        return "convex" if self.smoothness == 0 else f"convex-smooth({self.smoothness:g})"

    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> SmoothingResult:
        t_start = time.perf_counter()
        check_seed(seed)
        check_initial(rosary, initial)
        if rosary.n_hatches == 0:
            return trivial_result(self.method, rosary, t_start, objective="length")
        check_rosary(rosary)
        h = Hatches.of(rosary)
        inset = h.fitting_inset(self.inset)
        P, q, A, b, cones, nw = build_socp(rosary, self.smoothness, inset)
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = self.tol
        solver = clarabel.DefaultSolver(P, q, A, b, cones, settings)
        sol = solver.solve()
        status = str(sol.status).rsplit(".", 1)[-1]
        if status not in ("Solved", "AlmostSolved"):
            raise ConvexSolveError(f"Clarabel stopped with status {status} after {sol.iterations} iterations")
        w = np.asarray(sol.x[:nw]).reshape(h.m, rosary.dim)
        w = h.project(w, inset)
        if not np.all(h.inside(w, inset / 2)):  # pragma: no cover - guarded by the projection
            raise ConvexSolveError("the convex solution is not strictly inside the hatches")
        return SmoothingResult.build(
            self.method,
            rosary,
            w,
            history_best=np.array([float(sol.obj_val)]),
            iterations=int(sol.iterations),
            evaluations=int(sol.iterations),
            wall_time=time.perf_counter() - t_start,
            stop_reason=status,
            objective="length" if self.smoothness == 0 else "length + smoothness",
            info={"solver": "clarabel", "status": status, "solve_time": float(sol.solve_time),
                  "obj_val": float(sol.obj_val), "inset": inset, "smoothness": self.smoothness,
                  "x": np.asarray(sol.x), "z": np.asarray(sol.z)},
        )


def build_socp(rosary: Rosary, smoothness: float = 0.0, inset: float = 0.0):
    """Clarabel data (P, q, A, b, cones, number of waypoint variables) for the program above.

    Variables x = [w_1 (n), ..., w_m (n), t_0, ..., t_m] with m = k - 1. Clarabel's form is
    min 1/2 x'Px + q'x subject to Ax + s = b, s in the cones; each cone here is a second-order cone
    (t, v) with |v| <= t, of dimension n + 1: m + 1 segment cones, then two ball cones per waypoint.
    """
    rows, cols, vals, b, nw = socp_cones(rosary, inset)
    m, n = rosary.n_hatches, rosary.dim
    nt = m + 1
    nv = nw + nt
    cd = n + 1  # cone dimension
    A = sp.csc_matrix((vals, (rows, cols)), shape=(len(b), nv))

    q = np.concatenate([np.zeros(nw), np.ones(nt)])
    if smoothness > 0:
        # Second differences at the interior points: D w + e, D = tridiag(1, -2, 1) (x) I_n.
        D1 = sp.diags([np.ones(m - 1), -2.0 * np.ones(m), np.ones(m - 1)], [-1, 0, 1], shape=(m, m))
        D = sp.kron(D1, sp.identity(n), format="csc")
        e = np.zeros((m, n))
        e[0] += rosary.q_init
        e[-1] += rosary.q_goal
        Pw = 2.0 * smoothness * (D.T @ D)
        q[:nw] += 2.0 * smoothness * (D.T @ e.ravel())
        P = sp.block_diag([Pw, sp.csc_matrix((nt, nt))], format="csc")
    else:
        P = sp.csc_matrix((nv, nv))
    P = sp.triu(P, format="csc")
    cones = [clarabel.SecondOrderConeT(cd)] * (m + 1 + 2 * m)
    return P, q, A, b, cones, nw


def socp_pattern(m: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The entries of :func:`build_socp`'s A for m waypoints in R^n, as (rows, cols, values): they do not depend
    on the bubbles (b holds those, :func:`socp_cones`). Segment cone j = 0..m occupies rows j (n + 1) ..
    j (n + 1) + n, (t_j, p_(j+1) - p_j); then the two ball cones of each waypoint, (r - inset, w_i - c)."""
    nw = m * n
    cd = n + 1  # cone dimension
    d = np.arange(n)
    j = np.arange(m + 1)
    rows = [j * cd]
    cols = [nw + j]
    vals = [np.full(m + 1, -1.0)]
    vrow = (j[:, None] * cd + 1 + d).ravel()  # (m+1)*n rows, j-major
    jj = np.repeat(j, n)
    dd = np.tile(d, m + 1)
    nxt = jj < m  # p_(j+1) is waypoint j
    rows.append(vrow[nxt])
    cols.append(jj[nxt] * n + dd[nxt])
    vals.append(np.full(int(nxt.sum()), -1.0))
    prv = jj >= 1  # p_j is waypoint j - 1
    rows.append(vrow[prv])
    cols.append((jj[prv] - 1) * n + dd[prv])
    vals.append(np.full(int(prv.sum()), 1.0))
    i = np.arange(m)
    brow = ((m + 1) * cd + (i[:, None, None] * 2 + np.arange(2)[:, None]) * cd + 1 + d).ravel()  # (m, 2, n)
    rows.append(brow)
    cols.append(np.broadcast_to((i[:, None, None] * n + d), (m, 2, n)).ravel())
    vals.append(np.full(brow.size, -1.0))
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)


def socp_cones(rosary: Rosary, inset: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """The segment and ball cones of :func:`build_socp` as (rows, cols, values) of A (:func:`socp_pattern`), b and
    the number of waypoint variables (the smoother's subproblems reuse them without building A)."""
    h = Hatches.of(rosary)
    m, n = h.m, rosary.dim
    cd = n + 1
    d = np.arange(n)
    b = np.zeros((m + 1 + 2 * m) * cd)
    b[m * cd + 1 + d] += rosary.q_goal  # segment m: (t_m, q_goal - w_m)
    b[1 + d] -= rosary.q_init  # segment 0: (t_0, w_1 - q_init)
    bbase = (m + 1) * cd + (np.arange(m)[:, None] * 2 + np.arange(2)) * cd  # (m, 2): both balls of each waypoint
    b[bbase.ravel()] = (np.stack([h.ra, h.rb], axis=1) - inset).ravel()
    b[(bbase[..., None] + 1 + d).ravel()] = -np.stack([h.ca, h.cb], axis=1).ravel()
    return (*socp_pattern(m, n), b, m * n)


@dataclass
class CSC:
    """A matrix in canonical CSC form (row indices sorted in each column, no duplicates), as Clarabel reads it:
    the smoother's subproblems are built as these arrays directly (an obstacle subproblem's A: 36 us by
    :func:`to_csc`, 86 us by scipy's COO to CSC conversion, whose checks also cost each P 15-20 us)."""

    data: np.ndarray
    indices: np.ndarray
    indptr: np.ndarray
    shape: tuple[int, int]


def to_csc(rows: np.ndarray, cols: np.ndarray, vals: np.ndarray, shape: tuple[int, int]) -> CSC:
    """The CSC form of entries (rows, cols, vals) that name every (row, column) at most once: by column, then row,
    as scipy's COO -> CSC conversion orders them, entry for entry."""
    order = np.argsort(cols * shape[0] + rows, kind="stable")  # (the entries come in runs: half the time of quicksort)
    indptr = np.zeros(shape[1] + 1, dtype=np.int64)
    np.cumsum(np.bincount(cols, minlength=shape[1]), out=indptr[1:])
    return CSC(vals[order], rows[order], indptr, shape)


def csc_lists(data, indices, indptr, shape: tuple[int, int], canonical: bool = True) -> SimpleNamespace:
    """A CSC matrix with its arrays as Python lists, for Clarabel's constructor: it reads a matrix (data, indices,
    indptr, nnz, shape, has_canonical_format) element by element, which costs a fifth of the build from numpy
    arrays (a numpy scalar per element) and less from lists (the smoother's obstacle subproblems: 0.75-1.15 ms ->
    0.55-0.90 ms, the same solutions)."""
    as_list = (lambda a: a.tolist() if isinstance(a, np.ndarray) else list(a))
    data = as_list(data)
    return SimpleNamespace(data=data, indices=as_list(indices), indptr=as_list(indptr), nnz=len(data), shape=shape,
                           has_canonical_format=canonical)
