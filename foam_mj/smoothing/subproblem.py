"""The subproblem of the optimal smoother's sequential convex programming (foam_mj.smoothing.scp, whose
module docstring has the model and the reasons for its parts): Clarabel data (P, q, A, b, cones) for the
composite model of F around a path, with or without the trust region's rows, the model's value at a
solution, the vertex data the model is built from, and the solver that solves a sequence of them."""

from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import clarabel
import numpy as np

from foam_mj import paths
from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import Hatches
from foam_mj.smoothing.convex import CSC, ConvexShortestPath, build_socp, csc_lists, socp_cones, to_csc

if TYPE_CHECKING:
    from foam_mj.smoothing.objective import ObjectiveWeights

_TINY = 1e-300
SOLVER_TOL = 1e-9
_S_MAX = 2.0 - 1e-9  # |v| = 2 sin(phi / 2) <= 2; h'(s) blows up at a U-turn
RELATIVE = 0.5  # a segment's vector may change by at most this fraction of its length in one step
PROX = 1e-2  # (PROX max(weights) / 2) |dW|^2 in every subproblem: picks the nearest of equally good steps


@dataclass
class _Vertices:
    """The merged polyline of a path: ``rep[k]`` the point that stands for point k (the first of its
    run of coincident points, or the fixed end in a run that holds one), ``D`` the distinct points,
    v = a^ - b^ at their interior vertices, its Jacobian blocks (Mv, 3, n, n) with respect to
    (Q_(i), Q_(i+1), Q_(i+2)), s0 = |v|."""

    rep: np.ndarray
    D: np.ndarray
    v: np.ndarray
    J: np.ndarray
    s0: np.ndarray
    first: np.ndarray  # the first point of each run


def _vertex_data(p: np.ndarray, close: np.ndarray) -> _Vertices:
    """The merged polyline of p (L, n) where ``close`` marks the segments whose end points are one point."""
    L, n = p.shape
    if not close.any():  # every point its own run (the usual case)
        rep = D = first = np.arange(L)
        Q = p
    else:
        group = np.concatenate(([0], np.cumsum(~close)))
        first = np.flatnonzero(np.concatenate(([True], ~close)))
        rep_of_group = first.copy()
        if close[-1] and len(first) > 1:
            rep_of_group[-1] = L - 1  # a run that ends at q_goal stands on q_goal
        rep = rep_of_group[group]
        D = rep_of_group
        Q = p[D]
    seg = Q[1:] - Q[:-1]
    lens = np.maximum(paths.row_norms(seg), paths._EPS)
    u = seg / lens[:, None]
    G = (np.eye(n) - u[:, :, None] * u[:, None, :]) / lens[:, None, None]  # d u / d seg
    Ga, Gb = G[:-1], G[1:]
    v = u[:-1] - u[1:]
    # dv/dQ_i = -Ga, dv/dQ_(i+1) = Ga + Gb, dv/dQ_(i+2) = -Gb
    J = np.empty((len(v), 3, n, n))
    J[:, 0] = -Ga
    J[:, 1] = Ga + Gb
    J[:, 2] = -Gb
    return _Vertices(rep, D, v, J, paths.row_norms(v), first)


def _h(s):
    return 2.0 * np.arcsin(np.minimum(s, 2.0) / 2.0)


def _dh(s):
    return 1.0 / np.sqrt(np.maximum(1.0 - (np.minimum(s, _S_MAX) / 2.0) ** 2, 1e-18))


def _ddh(s):
    """h''(s) = (s / 4) (1 - s^2 / 4)^(-3/2) >= 0 (h is convex)."""
    sc = np.minimum(s, _S_MAX)
    return 0.25 * sc * np.maximum(1.0 - (sc / 2.0) ** 2, 1e-18) ** -1.5


@dataclass
class _Structure:
    """The parts of the subproblem that do not change between iterations."""

    A0: tuple[np.ndarray, np.ndarray, np.ndarray]  # (rows, cols, values): segment and ball cones over x = [W, t]
    b0: np.ndarray
    nw: int
    nt: int
    M: int
    n: int
    P_pattern: tuple | None = None  # (indptr, indices, diag rows, super rows, tail) of the block-tridiagonal P
    vertex_pattern: tuple | None = None  # (vx.D, and the vertex cones' entries for it: see _subproblem)
    a0_cone: np.ndarray = field(init=False)  # the cone of each entry of A0
    a0_within: np.ndarray = field(init=False)  # ... and its row in that cone

    def __post_init__(self) -> None:
        self.a0_cone, self.a0_within = np.divmod(self.A0[0], self.n + 1)

    def p_pattern(self) -> tuple:
        """The upper triangle of a block-tridiagonal P over W (n x n blocks: waypoint k with itself and with
        k + 1) and a diagonal over [t, s], as CSC arrays, and where each block's entries sit in ``data``."""
        if self.P_pattern is None:
            m, n, nw = self.M, self.n, self.nw
            nx = nw + self.nt + self.M
            a, b = np.triu_indices(n)
            # Column (k, e) of W holds block (k - 1, k)'s column e (rows (k - 1) n .. k n - 1; none for k = 0),
            # then diagonal block k's rows k n .. k n + e; each column of [t, s] its diagonal entry.
            count = np.ones(nx, dtype=np.int64)
            count[:nw] = (np.arange(n) + 1 + n * (np.arange(m) > 0)[:, None]).ravel()
            indptr = np.zeros(nx + 1, dtype=np.int64)
            np.cumsum(count, out=indptr[1:])
            start = indptr[:nw].reshape(m, n)
            k = np.arange(m)[:, None]
            upos = start[1:, None, :] + np.arange(n)[:, None]  # (m - 1, n, n): entry (aa, bb) of block (k, k + 1)
            dpos = start[:, b] + n * (k > 0) + a  # (m, n (n + 1) / 2): entry (a, b) of diagonal block k
            tpos = indptr[nw:nx]
            indices = np.empty(indptr[-1], dtype=np.int64)
            indices[upos] = k[:-1, :, None] * n + np.arange(n)[:, None]
            indices[dpos] = k * n + a
            indices[tpos] = np.arange(nw, nx)
            self.P_pattern = (indptr, indices, dpos, upos, tpos, (a, b))
        return self.P_pattern


def _structure(rosary: Rosary, inset: float, socp: tuple | None = None) -> _Structure:
    m = rosary.n_hatches
    if socp is None:
        rows, cols, vals, b0, nw = socp_cones(rosary, inset)
    else:
        _, _, A, b0, _, nw = socp
        A = A.tocoo()
        rows, cols, vals = A.row, A.col, A.data
    return _Structure((rows, cols, vals), b0, nw, m + 1, m, rosary.dim)


def _shortest_start(rosary: Rosary, h: Hatches, inset: float) -> tuple[np.ndarray, _Structure]:
    """The shortest path through the shrunk hatches (foam_mj.smoothing.convex's program, whose segment
    and ball cones the subproblems reuse), solved to 1e-8 without presolve: a start for the SCP, whose
    first step moves it by far more than that; projected onto the shrunk hatches."""
    socp = build_socp(rosary, 0.0, inset)
    P, q, A, b, cones, nw = socp
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.presolve_enable = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-8  # (1e-6 costs 4x the subproblems on obstacle: the corners)
    sol = clarabel.DefaultSolver(P, q, A, b, cones, settings).solve()
    status = str(sol.status).rsplit(".", 1)[-1]
    if status not in ("Solved", "AlmostSolved"):  # pragma: no cover - the program is always feasible
        w = np.array(ConvexShortestPath(inset=inset).smooth(rosary).waypoints)
    else:
        w = h.project(np.asarray(sol.x[:nw]).reshape(h.m, rosary.dim), inset)
    return w, _structure(rosary, inset, socp)


def _segment_curvature(Q: np.ndarray, y: np.ndarray, length: np.ndarray | float = 0.0) -> np.ndarray:
    """PSD part of the Hessian of sum_i y_i . v_i with respect to each segment of the polyline Q, where
    v_i = u_i - u_(i+1) at interior vertex i and y (Mv, n) are fixed multipliers -> (segments, n, n).

    Segment j enters as +u_j in v_j and -u_j in v_(j-1), so the term is z_j . u(a) with z_j = y_j - y_(j-1)
    and a = Q_(j+1) - Q_j; with u = a/|a| and G = (I - u u^T)/|a| (= du/da),

        d^2 (z . u) / da^2 = -(u (G z)^T + (G z) u^T + (u . z) G) / |a|,

    indefinite in general; its negative eigenvalues are clipped (the model must stay convex). With
    g = |G z|, e = G z / g, alpha = (length - u . z / |a|) / |a| and beta = -g / |a| (``length`` the weight of
    the segment's own length curvature, length G), the matrix is beta (u e^T + e u^T) + alpha (I - u u^T):
    alpha on the directions normal to u and e, and [[0, beta], [beta, alpha]] on (u, e), whose eigenvalues are
    (alpha -+ sqrt(alpha^2 + 4 beta^2)) / 2 with the eigenvector beta u + lambda e; so the clip is in closed
    form (a third of the time of a batched eigh on 70 segments)."""
    seg = Q[1:] - Q[:-1]
    r = np.maximum(paths.row_norms(seg), paths._EPS)
    u = seg / r[:, None]
    n = Q.shape[1]
    z = np.zeros((len(seg), n))
    z[:-1] += y
    z[1:] -= y
    uz = np.einsum("jd,jd->j", u, z)
    Gz = (z - uz[:, None] * u) / r[:, None]
    g = paths.row_norms(Gz)
    e = Gz / np.maximum(g, _TINY)[:, None]
    alpha = (np.asarray(length, dtype=float) - uz / r) / r
    beta = -g / r
    lam = 0.5 * (alpha + np.sqrt(alpha**2 + 4.0 * beta**2))  # the non-negative eigenvalue on (u, e)
    v = beta[:, None] * u + lam[:, None] * e
    coef = np.where(lam > 0, lam / np.maximum(beta**2 + lam**2, _TINY), 0.0)
    return (coef[:, None, None] * v[:, :, None] * v[:, None, :]
            + np.maximum(alpha, 0.0)[:, None, None] * (np.eye(n) - u[:, :, None] * u[:, None, :] - e[:, :, None] * e[:, None, :]))


def _short_segments(p: np.ndarray, vx: _Vertices, delta: float, rel: float) -> tuple[np.ndarray, np.ndarray]:
    """The segments under the relative trust region (shorter than delta / rel, not tied) and all lengths."""
    lens = paths.row_norms(p[1:] - p[:-1])
    tied_seg = vx.rep[1:] == vx.rep[:-1]
    return np.flatnonzero((rel * lens < delta) & ~tied_seg & (len(p) > 2)), lens


def _within_trust(x: np.ndarray, p: np.ndarray, vx: _Vertices, delta: float, rel: float) -> bool:
    """Whether the step to x = [W, ...] meets the trust region that :func:`_subproblem` omits with ``trust=False``."""
    step = np.zeros_like(p)
    step[1:-1] = x[:p[1:-1].size].reshape(p[1:-1].shape) - p[1:-1]
    if not np.max(np.abs(step)) <= delta:
        return False
    short, lens = _short_segments(p, vx, delta, rel)
    return bool(np.all(np.abs(step[short + 1] - step[short]) <= rel * lens[short][:, None]))


def _subproblem(st: _Structure, p: np.ndarray, weights: ObjectiveWeights, delta: float, vx: _Vertices,
                y: np.ndarray | None = None, rel: float = RELATIVE, keep: np.ndarray | None = None,
                long_seg: np.ndarray | None = None, trust: bool = True):
    """Clarabel data for one step. Variables x = [W (m n), t (m + 1), s (M)]; cones in the order
    ties (zero cone), trust region (box; left out with ``trust=False``), segment and ball cones, vertex cones."""
    n, nw, nt, M = st.n, st.nw, st.nt, st.M
    m = M
    nx = nw + nt + M
    prox = PROX * max(weights.as_tuple) if weights.sv == 0 else 0.0
    rows, cols, vals, b_parts, cones = [], [], [], [], []
    dd = np.arange(n)
    off = 0
    # Ties: w_k = w_rep(k) (or = the fixed end) for every waypoint that is not its run's representative.
    k = np.arange(1, m + 1)
    tied = k[vx.rep[k] != k]
    if tied.size:
        r = off + (np.arange(tied.size)[:, None] * n + dd).ravel()
        rows.append(r)
        cols.append(((tied - 1)[:, None] * n + dd).ravel())
        vals.append(np.ones(r.size))
        rp = vx.rep[tied]
        free_rep = (rp >= 1) & (rp <= m)
        rr = off + (np.flatnonzero(free_rep)[:, None] * n + dd).ravel()
        rows.append(rr)
        cols.append(((rp[free_rep] - 1)[:, None] * n + dd).ravel())
        vals.append(-np.ones(rr.size))
        bt = np.zeros((tied.size, n))
        bt[~free_rep] = p[rp[~free_rep]]
        b_parts.append(bt.ravel())
        cones.append(clarabel.ZeroConeT(tied.size * n))
        off += tied.size * n
    if trust:
        # Box trust region: |W - W0|_inf <= delta.
        w0 = p[1:-1].ravel()
        idx = np.arange(nw)
        rows += [off + idx, off + nw + idx]
        cols += [idx, idx]
        vals += [np.ones(nw), -np.ones(nw)]
        b_parts += [w0 + delta, -(w0 - delta)]
        off += 2 * nw
        # Relative trust region on the segments: |d(p_(j+1) - p_j)|_inf <= RELATIVE |p_(j+1) - p_j| for the
        # segments shorter than delta / RELATIVE (not tied), so a short segment's direction, to which the angles
        # are most sensitive, stays within the model's reach while its two points may still move together.
        short, lens = _short_segments(p, vx, delta, rel)
        n_rel = 0
        if short.size:
            r = (np.arange(short.size)[:, None] * n + dd).ravel()
            jj = np.repeat(short, n)
            ee = np.tile(dd, short.size)
            hi = jj + 1 <= m  # p_(j+1) is waypoint j (free)
            lo = jj >= 1  # p_j is waypoint j - 1 (free)
            for sign, base in ((1.0, off), (-1.0, off + r.size)):
                rows += [base + r[hi], base + r[lo]]
                cols += [jj[hi] * n + ee[hi], (jj[lo] - 1) * n + ee[lo]]
                vals += [np.full(int(hi.sum()), sign), np.full(int(lo.sum()), -sign)]
            pw = p.copy()
            pw[0] = 0.0
            pw[-1] = 0.0
            dw0 = pw[short + 1] - pw[short]  # D W0 (only the free points)
            rad = np.repeat(rel * lens[short], n)
            b_parts += [dw0.ravel() + rad, -dw0.ravel() + rad]
            n_rel = 2 * r.size
            off += n_rel
        cones.append(clarabel.NonnegativeConeT(2 * nw + n_rel))
    # Segment and ball cones (constant), only the balls in ``keep`` (the others are out of reach, or left out
    # of a first solve: foam_mj.smoothing.scp, Speed).
    a0_rows, a0_cols, a0_vals = st.A0
    a0_row = off
    seg_keep = np.ones(nt, dtype=bool) if long_seg is None or y is None else ~long_seg
    if (keep is None or keep.all()) and seg_keep.all():
        rows.append(off + a0_rows)
        cols.append(a0_cols)
        vals.append(a0_vals)
        b_parts.append(st.b0)
        n_cones = nt + 2 * m
    else:
        cd = n + 1
        cone_keep = np.concatenate((seg_keep, np.ones(2 * m, dtype=bool) if keep is None else keep.ravel()))
        new_cone = np.cumsum(cone_keep) - 1
        cone = st.a0_cone
        e = cone_keep[cone]
        rows.append(off + new_cone[cone[e]] * cd + st.a0_within[e])
        cols.append(a0_cols[e])
        vals.append(a0_vals[e])
        b_parts.append(st.b0.reshape(-1, cd)[cone_keep].ravel())
        n_cones = int(cone_keep.sum())
    cones += [clarabel.SecondOrderConeT(n + 1)] * n_cones
    off += n_cones * (n + 1)
    ball_row = a0_row + int(seg_keep.sum()) * (n + 1)  # the first ball cone's row
    q = np.zeros(nx)
    q[nw:nw + nt] = weights.length * seg_keep
    Pdiag = np.zeros(nx)
    Pdiag[nw:nw + nt][~seg_keep] = 1.0  # pins a t without cone
    Mv = len(vx.s0)
    Pdiag[nw + nt + Mv:] = 1.0  # pins the unused s at 0
    if Mv and (weights.angle or weights.sv):
        # Vertex cones (s_i, v_i + sum_j J_ij (Q_(i+j) - Q0_(i+j))) for the waypoints among the three points.
        # Their entries depend only on the merged points D (the same at every step of a run without new ties).
        if st.vertex_pattern is None or not np.array_equal(st.vertex_pattern[0], vx.D):
            i = np.arange(Mv)
            point = vx.D[i[:, None] + np.arange(3)]  # (Mv, 3): the vertex's three points
            free = (point >= 1) & (point <= m)  # the waypoints among them
            fi, fj = np.nonzero(free)
            shape = (fi.size, n, n)  # rows d, cols e of each J_ij
            J_rows = np.broadcast_to((i[fi] * (n + 1) + 1)[:, None, None] + dd[None, :, None], shape).ravel()
            J_cols = np.broadcast_to(((point[fi, fj] - 1) * n)[:, None, None] + dd[None, None, :], shape).ravel()
            st.vertex_pattern = (vx.D, i * (n + 1), nw + nt + i, np.full(Mv, -1.0), point, free, fi, fj, J_rows, J_cols)
        _, s_rows, s_cols, s_vals, point, free, fi, fj, J_rows, J_cols = st.vertex_pattern
        rows += [off + s_rows, off + J_rows]
        cols += [s_cols, J_cols]
        vals += [s_vals, -vx.J[fi, fj].ravel()]
        bv = np.zeros((Mv, n + 1))
        bv[:, 1:] = vx.v
        for j in range(3):  # v_i - sum_j J_ij Q0_(i+j) over the waypoints
            bv[:, 1:] -= np.einsum("ide,ie->id", vx.J[:, j], p[point[:, j]] * free[:, j, None])
        b_parts.append(bv.ravel())
        cones += [clarabel.SecondOrderConeT(n + 1)] * Mv
        sc = np.minimum(vx.s0, _S_MAX)
        q[nw + nt:nw + nt + Mv] = weights.angle * _dh(sc) / M
        if weights.sv:
            Pdiag[nw + nt:nw + nt + Mv] = 2.0 * weights.sv * _kappa(sc) / M
    else:
        Pdiag[nw + nt:] = 1.0
    b = np.concatenate(b_parts)
    A = to_csc(np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), (len(b), nx))
    if y is None:
        # P is diagonal (every diagonal entry stored, zeros too, so that the pattern is the same at every step)
        ix = np.arange(nx + 1)
        Pdiag[:nw] = prox
        q[:nw] -= prox * p[vx.rep[1:-1]].ravel()
        return CSC(Pdiag, ix[:-1], ix, (nx, nx)), q, A, b, cones, None, ball_row
    # Curvature (SQP): 1/2 dW^T H dW with H the PSD part of sum_i y_i . d^2 v_i (see _segment_curvature), and
    # 1/2 h''(s0) (s - s0)^2 for the angle's outer function; the segment of the merged polyline from group g
    # to group g + 1 is put on the adjacent waypoints (last of group g, first of group g + 1), which the tie
    # equalities make equal to the group's point.
    indptr, indices, dpos, upos, tpos, (ta, tb) = st.p_pattern()
    kb = vx.first[1:] - 1  # waypoint index of each segment's b end (point first[j + 1]); also the path segment's index
    ka = kb - 1
    Q = p[vx.D]
    lin = ~seg_keep[kb]  # merged segments whose length is modelled to second order (no cone)
    Hs = _segment_curvature(Q, y, weights.length * lin)
    fa, fb = (ka >= 0) & (ka < m), (kb >= 0) & (kb < m)
    qW = np.zeros((m, n))
    lin_const = 0.0
    if lin.any():
        # Length of a long segment: w_len (|a| + u . da) + w_len da^T G da / 2 (the last in Hs, before the clip).
        a = (Q[1:] - Q[:-1])[lin]
        r = paths.row_norms(a)
        wu = weights.length * a / r[:, None]
        qW[kb[lin & fb]] += wu[fb[lin]]  # (ka and kb are increasing: no repeats in one update)
        qW[ka[lin & fa]] -= wu[fa[lin]]
        lin_const = weights.length * float(r.sum())
    Dblk = np.zeros((m, n, n))
    Sblk = np.zeros((max(m - 1, 0), n, n))
    Dblk[ka[fa]] += Hs[fa]
    Dblk[kb[fb]] += Hs[fb]
    both = fa & fb
    Sblk[ka[both]] = -Hs[both]
    W0 = p[vx.rep[1:-1]]  # the model's centre: every tied point at its group's point
    PW0 = np.einsum("kde,ke->kd", Dblk, W0)
    if m > 1:
        PW0[:-1] += np.einsum("kde,ke->kd", Sblk, W0[1:])
        PW0[1:] += np.einsum("kde,kd->ke", Sblk, W0[:-1])
    q[:nw] += qW.ravel() - PW0.ravel()
    if Mv and weights.angle:
        sc = np.minimum(vx.s0, _S_MAX)
        hpp = weights.angle * _ddh(sc) / M
        Pdiag[nw + nt:nw + nt + Mv] += hpp
        q[nw + nt:nw + nt + Mv] -= hpp * sc
    data = np.empty(indices.size)
    data[dpos] = Dblk[:, ta, tb] + prox * (ta == tb)
    q[:nw] -= prox * W0.ravel()
    data[upos] = Sblk
    data[tpos] = Pdiag[nw:]
    return (CSC(data, indices, indptr, (nx, nx)), q, A, b, cones,
            (Dblk, Sblk, Pdiag[nw + nt:nw + nt + Mv], lin_const, qW), ball_row)


def _kappa(sc: np.ndarray) -> np.ndarray:
    """h(s) h'(s) / s (-> 1 at 0): the SV model's curvature in s."""
    return np.where(sc > 1e-8, _h(sc) * _dh(sc) / np.maximum(sc, 1e-8), 1.0)


def _model_value(x: np.ndarray, st: _Structure, weights: ObjectiveWeights, vx: _Vertices, p: np.ndarray | None = None,
                 curv: tuple | None = None) -> float:
    """The subproblem's model of F at its solution x (equals F at the current point p when x = x0)."""
    nw, nt, M = st.nw, st.nt, st.M
    value = weights.length * float(x[nw:nw + nt].sum())
    Mv = len(vx.s0)
    if Mv and (weights.angle or weights.sv):
        s = np.maximum(x[nw + nt:nw + nt + Mv], 0.0)
        sc = np.minimum(vx.s0, _S_MAX)
        h0, dh0 = _h(sc), _dh(sc)
        value += weights.angle * float(np.sum(h0 + dh0 * (s - sc))) / M
        if weights.sv:
            value += weights.sv * float(np.sum(h0**2 + _kappa(sc) * (s**2 - sc**2))) / M
        if curv is not None:
            value += 0.5 * float(np.sum(curv[2] * (x[nw + nt:nw + nt + Mv] - sc) ** 2))
    if curv is not None:
        assert p is not None  # given with curv
        Dblk, Sblk = curv[0], curv[1]
        dW = x[:nw].reshape(p[1:-1].shape) - p[vx.rep[1:-1]]
        value += curv[3] + float(np.sum(curv[4] * dW))  # long segments' lengths to first order
        value += 0.5 * float(np.einsum("kd,kde,ke->", dW, Dblk, dW))
        if len(Sblk):
            value += float(np.einsum("kd,kde,ke->", dW[:-1], Sblk, dW[1:]))
    return value


def _settings(refine: bool = True, tol: float = SOLVER_TOL) -> clarabel.DefaultSettings:
    """Clarabel's settings for the subproblems. ``refine=False`` turns off iterative refinement of the
    linear solves, about a third of each solve's time: the f subproblems reach 1e-9 without it in the
    same number of interior-point iterations and the SCP the same points (to 1e-9 in F); the SV
    subproblems (near-duplicate vertices, ill-conditioned) keep it: without it they took up to three
    times as many subproblems on the six built-in scenes, and so do the f subproblems of more than 3 coordinates
    (most of their first solves failed without it: foam_mj.smoothing.scp.REFINE_ABOVE)."""
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = tol
    settings.iterative_refinement_enable = refine
    for key, value in _EXTRA.items():
        setattr(settings, key, value)
    return settings


#: Presolve off: the subproblems have no redundant rows to remove, and with it off Clarabel allows
#: :meth:`_Solver.solve`'s data updates (measured: about a quarter less time per subproblem).
_EXTRA: dict = {"presolve_enable": False}


def _lists(M: CSC) -> SimpleNamespace:
    """M for Clarabel's constructor, its arrays as Python lists (:func:`foam_mj.smoothing.convex.csc_lists`)."""
    return csc_lists(M.data, M.indices, M.indptr, M.shape)


class _Solver:
    """Clarabel for a sequence of subproblems: when a subproblem has the previous one's sparsity pattern and
    cones (the usual case between SCP steps: only the numbers change), its data replace the previous data
    in the same solver (``DefaultSolver.update``), which keeps the symbolic factorisation and the
    workspace; otherwise a new solver is made."""

    def __init__(self, refine: bool) -> None:
        self.refine = refine
        self._solver: Any = None  # a clarabel.DefaultSolver
        self._key: tuple | None = None
        self.reused = 0

    def solve(self, P: CSC, q: np.ndarray, A: CSC, b: np.ndarray, cones: list, tol: float = SOLVER_TOL):
        # The cones are the zero cone of the ties (if any), the trust region's, then second-order cones of
        # one size: their count and the first two fix them all.
        key = (A.shape, len(cones), tuple((type(c).__name__, c.dim) for c in cones[:2]), A.indptr.tobytes(),
               A.indices.tobytes(), P.indptr.tobytes(), P.indices.tobytes(), tol)
        if self._solver is not None and key == self._key and self._solver.is_data_update_allowed():
            self._solver.update(P=P.data, q=q, A=A.data, b=b)
            self.reused += 1
        else:
            self._solver = clarabel.DefaultSolver(_lists(P), q.tolist(), _lists(A), b.tolist(), cones, _settings(self.refine, tol))
            self._key = key
        return self._solver.solve()
