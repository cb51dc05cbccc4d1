"""Straight runs collapsed onto their chords: a smaller subproblem for the optimal smoother's curvature SCP
(foam_mj.smoothing.scp, Speed), and the multipliers of the collapsed vertices in closed form.

At the optimum of f most interior vertices are straight (obstacle: 55 of 68), and their vertex cones and
segment cones are most of a subproblem's rows. A *run* is a maximal sequence of merged points Q_a .. Q_b
(foam_mj.smoothing.subproblem._vertex_data) each of which is a straight vertex (|v| < ``STRAIGHT``), a single
free waypoint (not tied) and at least ``tie`` inside both of its balls; its ends A = Q_(a-1) and B = Q_(b+1)
are the other points (bent vertices, points near a sphere, ties, q_init, q_goal). The collapsed subproblem
keeps the run's points on the chord at their present arclength fractions,

    Q_k = (1 - tau_k) A + tau_k B,   tau_k = (arclength from A to Q_k) / (arclength from A to B),

so its variables are the chord points only: on that set the run's angles are 0 and its length is |B - A|
exactly, and F is F of the chord polyline (whose vertices, segments and curvature form the usual composite
model, foam_mj.smoothing.scp), while every waypoint's balls (those the trust region reaches) constrain its
affine point. Why no first-order loss: bending a straight vertex whose balls are inactive never decreases
F at first order (the triangle inequality for the length and, on the sphere, for the angles); in KKT
terms, the multipliers below always satisfy |g| <= 1, so a stationary point of the collapsed problem is one
of the full problem (the certificate checks it, computed exactly as always).

Multipliers of the collapsed vertices (the certificate's g, scaled y = (w_angle / M) g). At a free point
Q_k inside a run no ball is active and the length's gradient u_(k-1) - u_k is 0, so stationarity at Q_k is,
with P = I - u u^T (u the run's direction) and l the segment lengths,

    P (y_k - y_(k-1)) / l_(k-1) = P (y_(k+1) - y_k) / l_k        (k = a .. b),

a discrete Laplace equation along the run: P y is linear in arclength between its values at the run's
ends, y_(a-1) (the multiplier of vertex A) and y_(b+1) (vertex B's); at q_init or q_goal (no vertex) it is 0.
So y_k = P ((1 - tau_k) y_A + tau_k y_B), and the component along u is free (J_k^T u = 0), taken as 0. At a
bent end y_A = (w_angle / M) h'(|v_A|) v_A / |v_A| and |P y_A| = (w_angle / M) sin(theta) / (2 sin(theta/2)
cos(theta/2)) = w_angle / M exactly; at a straight end the subproblem's dual of its vertex cone, |y| <=
w_angle h'(|v|) / M; so |g_k| <= 1 (a convex combination), up to the factor h'(|v|) <= 1 + 1.3e-7 of a
straight end, which the certificate's clip to |g| <= 1 absorbs.

Why this way. The straight vertices' cones cannot simply leave the full subproblem: they model the angle there,
and their duals were the certificate's multipliers (without them, least-squares multipliers had |g| > 1, or,
regularised, certified one obstacle corridor of ten; the certificate's SOCP, the fallback, costs about 12 ms,
more than half an obstacle run). On the chord the angles are exactly 0 and the multipliers exact, so the
collapsed model loses nothing the certificate needs, and the subproblems have 21 to 41 % of the rows (per
problem; foam_mj.smoothing.scp, Speed, for the measurements). Only a curvature run's first solves are collapsed: a solution outside the trust
region goes to the full subproblem with the region's rows, as without the collapse.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import clarabel
import numpy as np

from foam_mj import paths
from foam_mj.smoothing.certificate import STRAIGHT
from foam_mj.smoothing.convex import to_csc
from foam_mj.smoothing.subproblem import (
    _S_MAX, _ddh, _dh, _h, _segment_curvature, _Structure, _vertex_data, _Vertices,
)


@dataclass
class Collapse:
    """Which merged points of a path are collapsed onto their run's chord, and the map back to the waypoints."""

    kept: np.ndarray  # indices into Q = p[vx.D] of the chord polyline's points
    interior: np.ndarray  # (len(Q),) the collapsed points
    pos: np.ndarray  # (len(Q),) for a collapsed point, the index in ``kept`` of its run's first end A
    tau: np.ndarray  # (len(Q),) its arclength fraction from A to B (0 for the kept points)
    T: np.ndarray  # (m, len(kept)): waypoint k = sum_c T[k, c] Qc[c]
    var: np.ndarray  # (len(kept),) the variable block of each chord point (-1: fixed end)
    Qc: np.ndarray  # the chord polyline now
    Dc: np.ndarray  # the path index of each chord point


def plan(p: np.ndarray, vx: _Vertices, slack: np.ndarray, tie: float) -> Collapse | None:
    """The runs of p (module docstring) -> their collapse, or None when nothing collapses (or no free point is
    left). ``slack`` (m, 2): each waypoint's distance inside its two shrunk balls."""
    D = vx.D
    nq, m = len(D), len(p) - 2
    if nq < 3:
        return None
    owner = np.searchsorted(D, vx.rep[1:-1])  # the merged point of each waypoint
    single = np.bincount(owner, minlength=nq) == 1
    inner = D[1:-1]
    ok = (vx.s0 < STRAIGHT) & (inner >= 1) & (inner <= m) & single[1:-1]
    ok &= slack.min(axis=1)[np.clip(inner - 1, 0, m - 1)] > tie
    if not ok.any():
        return None
    interior = np.zeros(nq, dtype=bool)
    interior[1:-1] = ok
    kept = np.flatnonzero(~interior)
    Dc = D[kept]
    var = np.full(len(kept), -1)
    free = (Dc >= 1) & (Dc <= m)
    if not free.any():
        return None
    var[free] = np.arange(int(free.sum()))
    Q = p[D]
    arc = np.concatenate(([0.0], np.cumsum(paths.row_norms(Q[1:] - Q[:-1]))))
    pos = np.cumsum(~interior) - 1
    tau = np.zeros(nq)
    ends = pos[interior]
    tau[interior] = (arc[interior] - arc[kept[ends]]) / (arc[kept[ends + 1]] - arc[kept[ends]])
    T = np.zeros((m, len(kept)))
    k = np.arange(m)
    T[k, pos[owner]] = 1.0 - tau[owner]
    inner_wp = interior[owner]
    T[k[inner_wp], pos[owner[inner_wp]] + 1] = tau[owner[inner_wp]]
    return Collapse(kept, interior, pos, tau, T, var, Q[kept], Dc)


@lru_cache(maxsize=None)
def _triu(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.triu_indices(n)


def subproblem(cp: Collapse, st: _Structure, p: np.ndarray, weights, y_pt: np.ndarray | None, keep: np.ndarray | None,
               prox: float):
    """Clarabel data (P, q, A, b, cones) of the collapsed model (module docstring) and what reads its solution.
    Variables [Z (free chord points), t (chord segments), s (chord vertices)]; cones: segment cones, the balls in
    ``keep`` (all with None), vertex cones. ``y_pt`` (path points, n): the multipliers for the curvature (None:
    the linear model of the first step). Objectives without SV only."""
    n, m, M = st.n, st.M, st.M
    cd = n + 1
    Qc, var, T = cp.Qc, cp.var, cp.T
    nc = len(Qc)
    nf = int((var >= 0).sum())
    nz, nt, Mc = nf * n, nc - 1, nc - 2
    nx = nz + nt + Mc
    dd = np.arange(n)
    fixed = var < 0
    rows, cols, vals, b_parts = [], [], [], []
    # Segment cones (t_j, Qc_(j+1) - Qc_j).
    j = np.arange(nt)
    rows.append(j * cd)
    cols.append(nz + j)
    vals.append(np.full(nt, -1.0))
    bs = np.zeros((nt, cd))
    for shift, sign in ((1, -1.0), (0, 1.0)):
        c = j + shift
        f = var[c] >= 0
        rows.append((j[f, None] * cd + 1 + dd).ravel())
        cols.append((var[c[f], None] * n + dd).ravel())
        vals.append(np.full(int(f.sum()) * n, sign))
        bs[~f, 1:] -= sign * Qc[c[~f]]
    b_parts.append(bs.ravel())
    off = nt * cd
    # Ball cones (R, W_k - c) with W_k = sum_c T[k, c] Qc_c.
    b0 = st.b0.reshape(-1, cd)[st.nt:].reshape(m, 2, cd)
    kk, side = np.nonzero(np.ones((m, 2), dtype=bool) if keep is None else keep)
    nb = kk.size
    bb = b0[kk, side].copy()
    Tk = T[kk]  # (nb, nc)
    bi, ci = np.nonzero(Tk)
    fc = var[ci] >= 0
    rows.append((off + (bi[fc] * cd + 1)[:, None] + dd).ravel())
    cols.append((var[ci[fc], None] * n + dd).ravel())
    vals.append(np.repeat(-Tk[bi[fc], ci[fc]], n))
    np.add.at(bb[:, 1:], bi[~fc], Tk[bi[~fc], ci[~fc], None] * Qc[ci[~fc]])
    b_parts.append(bb.ravel())
    ball_row = off
    off += nb * cd
    # Vertex cones (s_i, v_i + sum_j J_ij (Qc_(i+j) - Qc0_(i+j))) of the chord polyline.
    vc = _vertex_data(Qc, np.zeros(nt, dtype=bool))
    i = np.arange(Mc)
    rows.append(off + i * cd)
    cols.append(nz + nt + i)
    vals.append(np.full(Mc, -1.0))
    bv = np.zeros((Mc, cd))
    bv[:, 1:] = vc.v
    zero = np.zeros((1, 1, n), dtype=np.int64)
    for jj in range(3):
        c = i + jj
        f = var[c] >= 0
        fi = i[f]
        rows.append(((off + fi * cd + 1)[:, None, None] + dd[None, :, None] + zero).ravel())
        cols.append(((var[c[f]] * n)[:, None, None] + dd + zero.reshape(1, n, 1)).ravel())
        vals.append(-vc.J[fi, jj].ravel())
        bv[fi, 1:] -= np.einsum("ide,ie->id", vc.J[fi, jj], Qc[c[f]])
    b_parts.append(bv.ravel())
    off += Mc * cd
    b = np.concatenate(b_parts)
    A = to_csc(np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), (len(b), nx))
    cones = [clarabel.SecondOrderConeT(cd)] * (nt + nb + Mc)
    # Objective: w_len sum t + (w_angle / M) sum h'(s0) s, the curvature (with y), and (prox / 2) sum_k |W_k - p_k|^2.
    q = np.zeros(nx)
    q[nz:nz + nt] = weights.length
    sc = np.minimum(vc.s0, _S_MAX)
    q[nz + nt:] = weights.angle * _dh(sc) / M
    Tf = T[:, ~fixed]
    e = T[:, fixed] @ Qc[fixed] - p[1:-1]
    TtT = Tf.T @ Tf
    Dblk = np.zeros((nf, n, n))
    Sblk = np.zeros((max(nf - 1, 0), n, n))
    Dblk += prox * np.diagonal(TtT)[:, None, None] * np.eye(n)
    Sblk += prox * np.diagonal(TtT, 1)[:, None, None] * np.eye(n)
    qZ = prox * (Tf.T @ e)
    Z0 = Qc[~fixed]
    curv = None
    sdiag = np.zeros(Mc)
    if y_pt is not None:
        yc = y_pt[cp.Dc[1:-1]].copy()
        bent = vc.s0 >= STRAIGHT
        sb = np.minimum(vc.s0[bent], _S_MAX)
        yc[bent] = (weights.angle * _dh(sb) / M / sb)[:, None] * vc.v[bent]
        Hs = _segment_curvature(Qc, yc)
        Hd = np.zeros((nf, n, n))
        Hu = np.zeros_like(Sblk)
        fa, fb = var[:-1] >= 0, var[1:] >= 0
        Hd[var[:-1][fa]] += Hs[fa]  # (each index once per update)
        Hd[var[1:][fb]] += Hs[fb]
        both = fa & fb
        Hu[var[:-1][both]] = -Hs[both]
        HZ0 = np.einsum("kde,ke->kd", Hd, Z0)
        if nf > 1:
            HZ0[:-1] += np.einsum("kde,ke->kd", Hu, Z0[1:])
            HZ0[1:] += np.einsum("kde,kd->ke", Hu, Z0[:-1])
        qZ = qZ - HZ0
        Dblk += Hd
        Sblk += Hu
        sdiag = weights.angle * _ddh(sc) / M
        q[nz + nt:] -= sdiag * sc
        curv = (Hd, Hu, sdiag)
    q[:nz] = qZ.ravel()
    # P's upper triangle: the diagonal blocks' (a <= b), the blocks (k, k + 1), the s diagonal.
    ta, tb = _triu(n)
    kf = np.arange(nf)
    pr = [(kf[:, None] * n + ta).ravel(), (kf[:-1, None, None] * n + dd[:, None] + 0 * dd).ravel(), nz + nt + i]
    pc = [(kf[:, None] * n + tb).ravel(), ((kf[:-1, None, None] + 1) * n + 0 * dd[:, None] + dd).ravel(), nz + nt + i]
    pv = [Dblk[:, ta, tb].ravel(), Sblk.ravel(), sdiag]
    P = to_csc(np.concatenate(pr), np.concatenate(pc), np.concatenate(pv), (nx, nx))
    return P, q, A, b, cones, (vc, curv, ball_row, nb, kk, side)


def model_value(x: np.ndarray, cp: Collapse, weights, M: int, info) -> float:
    """The collapsed model of F at its solution x (without the prox term, as the full model's)."""
    vc, curv = info[0], info[1]
    n = cp.Qc.shape[1]
    nf = int((cp.var >= 0).sum())
    nz, nt = nf * n, len(cp.Qc) - 1
    s = np.maximum(x[nz + nt:], 0.0)
    sc = np.minimum(vc.s0, _S_MAX)
    value = weights.length * float(x[nz:nz + nt].sum()) + weights.angle * float(np.sum(_h(sc) + _dh(sc) * (s - sc))) / M
    if curv is not None:
        Hd, Hu, sdiag = curv
        dZ = x[:nz].reshape(nf, n) - cp.Qc[cp.var >= 0]
        value += 0.5 * float(np.sum(sdiag * (x[nz + nt:] - sc) ** 2))
        value += 0.5 * float(np.einsum("kd,kde,ke->", dZ, Hd, dZ))
        if nf > 1:
            value += float(np.einsum("kd,kde,ke->", dZ[:-1], Hu, dZ[1:]))
    return value


def expand(x: np.ndarray, cp: Collapse) -> tuple[np.ndarray, np.ndarray]:
    """The chord points of the solution x, and the waypoints (m, n) they stand for."""
    n = cp.Qc.shape[1]
    Qn = cp.Qc.copy()
    f = cp.var >= 0
    Qn[f] = x[:int(f.sum()) * n].reshape(-1, n)
    return Qn, cp.T @ Qn


def multipliers(z, cp: Collapse, Qn: np.ndarray, weights, M: int, info, D: np.ndarray, y_pt: np.ndarray,
                z0: np.ndarray) -> None:
    """Fill y_pt (path points, n) from the solution's duals at the chord vertices and, at the collapsed points, by
    the closed form (module docstring) at the new chord polyline Qn; z0 (m, 2) with the balls' duals."""
    n = Qn.shape[1]
    cd = n + 1
    vc, _, ball_row, nb, kk, side = info
    Mc = len(Qn) - 2
    zz = np.asarray(z)
    y_pt[:] = 0.0
    yv = -zz[len(zz) - Mc * cd:].reshape(Mc, cd)[:, 1:]
    y_pt[cp.Dc[1:-1]] = yv
    z0[:] = 0.0
    z0[kk, side] = zz[ball_row:ball_row + nb * cd:cd]
    y_pt[D[cp.interior]] = run_multipliers(cp, Qn, yv, weights, M)


def run_multipliers(cp: Collapse, Qn: np.ndarray, y_chord: np.ndarray, weights, M: int) -> np.ndarray:
    """The multipliers y of the collapsed points (in the order of Q) by the closed form of the module docstring:
    P ((1 - tau) y_A + tau y_B), with y_A, y_B those of the run's ends on the chord polyline Qn: exact at its bent
    vertices ((w_angle / M) h'(|v|) v / |v|), ``y_chord`` (the vertex cones' duals) at its straight ones, 0 at
    q_init and q_goal."""
    n = Qn.shape[1]
    vn = _vertex_data(Qn, np.zeros(len(Qn) - 1, dtype=bool))
    ye = np.zeros((len(Qn), n))
    ye[1:-1] = y_chord
    bent = vn.s0 >= STRAIGHT
    sb = np.minimum(vn.s0[bent], _S_MAX)
    ye[1:-1][bent] = (weights.angle * _dh(sb) / M / sb)[:, None] * vn.v[bent]
    inner = np.flatnonzero(cp.interior)
    a = cp.pos[inner]
    t = cp.tau[inner][:, None]
    chord = Qn[a + 1] - Qn[a]
    u = chord / np.maximum(paths.row_norms(chord), paths._EPS)[:, None]
    y = (1.0 - t) * ye[a] + t * ye[a + 1]
    return y - np.einsum("kd,kd->k", y, u)[:, None] * u
