"""First-order optimality (KKT) of a smoothed path for the true, nonsmooth objective.

:func:`kkt_certificate` checks first-order optimality of the true objective on the
merged polyline (exact repeats as one point, constrained by every hatch it stands for): at a straight
vertex (|v| < 1e-3) the subdifferential of phi is {J_i^T g : |g| <= 1}; elsewhere phi is differentiable.
The residual

    min  max_k ell_k || (grad F_smooth + sum_straight (w_angle / M) J_i^T g_i - sum_active lambda_j grad c_j)_k ||_inf
    s.t. |g_i| <= 1,  lambda_j >= 0

(k over the distinct free points, ell_k = min(1, the shorter of k's segments)) is itself a small SOCP
(Clarabel). These are the KKT conditions with their multipliers g_i and lambda_j (Boyd and Vandenberghe, "Convex
Optimization", Cambridge University Press, 2004, section 5.5), with the subdifferential of phi at a straight
vertex in place of its gradient. Why the scaling by ell_k: at two vertices 1e-4 apart the gradient is 1e4 times larger, and a
residual of 1e-4 after a solve to 1e-9 is rounding, not a descent direction; ell_k |r_k| is F's first-order
change when point k moves by its own neighbour distance, the quantity the trust region controls. The
unscaled residual is reported too (``kkt_raw_stationarity``). During the SCP the last subproblem's duals
(vertex cones -> g_i, ball cones -> lambda_j; at the points it kept on a straight run's chord, g_i in closed
form, foam_mj.smoothing.collapse) are tried first as the multipliers: when their residual,
computed exactly as above, already certifies, the SOCP is not solved. Scaled stationarity and complementarity
(max lambda_j * slack_j) below ``KKT_TOL`` (1e-4) certify a local optimum; the angle is not convex, so
the optimal smoother's ``multistart`` looks for better ones (foam_mj.smoothing.optimal).
"""

from __future__ import annotations

from dataclasses import dataclass

import clarabel
import numpy as np

from foam_mj import paths
from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import Hatches
from foam_mj.smoothing.convex import CSC, to_csc
from foam_mj.smoothing.objective import ObjectiveWeights, tie_mask
from foam_mj.smoothing.subproblem import _S_MAX, _TINY, _dh, _h, _lists, _vertex_data

KKT_TOL = 1e-4  # scaled stationarity and complementarity below this: certified (see Certificate)
STRAIGHT = 1e-3  # |v| below this: a straight vertex, where the angle's subdifferential is a ball
ACTIVE = 1e-6  # a ball constraint whose slack (in configuration units) is below this is active


@dataclass(frozen=True)
class Certificate:
    """First-order optimality of waypoints for the true (nonsmooth) objective, see the module docstring.

    ``stationarity``: the smallest inf-norm of grad F_smooth + sum_straight (w_angle/M) J_i^T g_i -
    sum_active lambda_j grad c_j over |g_i| <= 1 and lambda >= 0; ``complementarity``: max lambda_j *
    slack_j over those multipliers; ``gradient_norm``: the inf-norm of the smooth gradient alone (the
    scale to compare with); counts of straight vertices, active constraints and tied waypoints.
    """

    stationarity: float
    raw_stationarity: float
    complementarity: float
    gradient_norm: float
    straight_vertices: int
    active_constraints: int
    tied_waypoints: int

    def certified(self, tol: float) -> bool:
        return self.stationarity <= tol and self.complementarity <= tol

    def as_dict(self) -> dict:
        return {
            "kkt_stationarity": self.stationarity,
            "kkt_raw_stationarity": self.raw_stationarity,
            "kkt_complementarity": self.complementarity,
            "gradient_norm": self.gradient_norm,
            "straight_vertices": self.straight_vertices,
            "active_constraints": self.active_constraints,
            "tied_waypoints": self.tied_waypoints,
        }


def kkt_certificate(rosary: Rosary, waypoints: np.ndarray, weights: ObjectiveWeights, inset: float = 0.0,
                    multipliers: tuple[np.ndarray, np.ndarray] | None = None, tol: float = KKT_TOL,
                    solve: bool = True, guess_tol: float | None = None) -> Certificate:
    """The KKT residual of ``waypoints`` for min F subject to the hatch balls shrunk by ``inset``.

    Coincident waypoints (closer than 1e-12, as foam_mj.paths) are one point: the variables are the
    distinct free points of the merged polyline, each constrained by the balls of every hatch it stands
    for. Constraints c_j = (r_j - inset)^2 - |x - c_j|^2 >= 0; active when the point is within ``ACTIVE``
    of the shrunk sphere.

    ``multipliers`` (y (points, n), lambda (waypoints, 2)): a guess, e.g. the duals of the SCP's last
    subproblem: g_i = y_i M / w_angle at the straight vertex on point i (scaled into |g_i| <= 1) and
    lambda for the two balls of every waypoint. When the residual of these multipliers (computed exactly,
    as for the solver's) is below ``guess_tol`` (default ``tol``), that certificate is returned without
    solving the SOCP; so it is when ``solve`` is False (a quick check: the SOCP is only solved when it is True).
    """
    h = Hatches.of(rosary)
    n, m = rosary.dim, h.m
    p = rosary.path(np.asarray(waypoints, dtype=float))
    vx = _vertex_data(p, tie_mask(p, h, inset / 2, paths._EPS))
    Q = p[vx.D]
    nq = len(Q)
    free = np.flatnonzero((vx.D >= 1) & (vx.D <= m))  # indices into Q of the distinct free points
    col = -np.ones(nq, dtype=int)
    col[free] = np.arange(free.size)
    nv = free.size * n
    # Smooth gradient over the merged polyline: length, SV, and the angle at bent vertices.
    M = m
    grad_q = np.zeros_like(Q)
    seg = Q[1:] - Q[:-1]
    qlens = paths.row_norms(seg)
    lens = np.maximum(qlens, paths._EPS)
    u = seg / lens[:, None]
    grad_q[:-1] -= weights.length * u
    grad_q[1:] += weights.length * u
    straight = np.zeros(len(vx.s0), dtype=bool)
    if len(vx.s0) and (weights.angle or weights.sv):
        sc = np.minimum(vx.s0, _S_MAX)
        straight = (sc < STRAIGHT) & (weights.angle > 0)
        unit_v = np.where(sc[:, None] > 0, vx.v / np.maximum(sc, _TINY)[:, None], 0.0)
        # d/dv of w_angle h(|v|) + w_sv h(|v|)^2 = (w_angle h' + 2 w_sv h h') v/|v|, zero where straight (angle part)
        dh0 = _dh(sc)
        coef = np.where(straight, 0.0, weights.angle * dh0)
        if weights.sv:
            coef = coef + 2.0 * weights.sv * _h(sc) * dh0
        coef = coef / M
        gv = coef[:, None] * unit_v  # (Mv, n)
        for j in range(3):
            grad_q[j:j + len(gv)] += np.einsum("fde,fd->fe", vx.J[:, j], gv)
    grad = grad_q[free].ravel()
    # Active constraints: for every waypoint, its two balls, at its merged point.
    ca, ra, cb, rb = h.ca, h.ra - inset, h.cb, h.rb - inset
    owner = np.searchsorted(vx.D, vx.rep[1:-1])  # index into Q of each waypoint's point
    x = Q[owner]
    centres = np.concatenate([ca, cb])
    radii = np.concatenate([ra, rb])
    xx = np.concatenate([x, x])
    own = np.concatenate([owner, owner])
    slack = radii - paths.row_norms(xx - centres)
    active = np.flatnonzero((slack <= ACTIVE) & (col[own] >= 0))
    na = active.size
    st_idx = np.flatnonzero(straight)
    ns = st_idx.size
    # The residual's terms (module docstring): -grad c_j = 2 (x - c_j) at the point of active constraint j, and
    # (w_angle / M) J_ij^T g_i at the free points i + j of straight vertex i.
    lam_point = col[own[active]]
    lam_dir = 2.0 * (xx[active] - centres[active])
    g_terms = []
    for j in range(3):
        c = col[st_idx + j]
        ok = c >= 0
        g_terms.append((c[ok], np.flatnonzero(ok), weights.angle / M * vx.J[st_idx[ok], j]))
    # Row scaling: the residual at a point times its neighbour distance ell (<= 1), see Certificate.
    ell = np.minimum(1.0, np.minimum(np.concatenate(([np.inf], qlens)), np.concatenate((qlens, [np.inf]))))[free]
    scale = np.repeat(ell, n)

    def residual(lam_v: np.ndarray, g: np.ndarray) -> np.ndarray:
        # grad + sum_j lambda_j (-grad c_j) + sum_i (w_angle / M) J_i^T g_i, point by point (no dense matrix:
        # a certificate checked with the SCP's multipliers needs no more).
        R = grad.reshape(-1, n).copy()
        if na:
            np.add.at(R, lam_point, lam_v[:, None] * lam_dir)
        for c, i, Jc in g_terms:
            R[c] += np.einsum("kde,kd->ke", Jc, g[i])  # (each point once per j)
        return R.ravel()

    def certificate(lam_v: np.ndarray, g: np.ndarray) -> Certificate:
        # The residual of given multipliers (lambda >= 0, |g_i| <= 1), computed exactly.
        resid = residual(lam_v, g)
        return Certificate(
            stationarity=float(np.max(np.abs(resid * scale))) if nv else 0.0,
            raw_stationarity=float(np.max(np.abs(resid))) if nv else 0.0,
            complementarity=float(np.max(lam_v * np.maximum(slack[active], 0.0))) if na else 0.0,
            gradient_norm=float(np.max(np.abs(grad))) if nv else 0.0,
            straight_vertices=int(ns),
            active_constraints=int(na),
            tied_waypoints=int(np.sum(vx.rep[1:-1] != np.arange(1, m + 1))),
        )

    if multipliers is not None:
        y_pt, lam_ball = multipliers
        g = y_pt[vx.D[st_idx + 1]] * (M / weights.angle) if ns else np.zeros((0, n))
        g = g / np.maximum(paths.row_norms(g), 1.0)[:, None]
        lam_v = np.maximum(np.concatenate([lam_ball[:, 0], lam_ball[:, 1]])[active], 0.0)
        cert = certificate(lam_v, g)
        if cert.certified(tol if guess_tol is None else min(tol, guess_tol)) or not solve:
            return cert
    # SOCP in z = [t, lambda (na), g (ns n)]: min t, |grad + B g - C lambda|_inf <= t, lambda >= 0, |g_i| <= 1.
    nz = 1 + na + ns * n
    Gm = np.zeros((nv, nz - 1))
    dd = np.arange(n)
    if na:  # -grad c_j in lambda_j's column, at the rows of its point
        Gm[(lam_point * n)[:, None] + dd, np.arange(na)[:, None]] = lam_dir
    for c, i, Jc in g_terms:
        Gm[(c * n)[:, None, None] + dd[None, :, None], (na + i * n)[:, None, None] + dd[None, None, :]] = np.swapaxes(Jc, 1, 2)
    Gs, grad_s = Gm * scale[:, None], grad * scale
    # Rows: t >= +-(Gs z + grad_s) (2 nv), lambda >= 0 (na), then the cones (1, g_i) (1 + n each).
    r, c = np.nonzero(Gs)
    v = Gs[r, c]
    iv, ia, soc = np.arange(nv), np.arange(na), 2 * nv + na + (np.arange(ns * n) // n) * (1 + n) + 1 + np.arange(ns * n) % n
    rows = np.concatenate([iv, r, nv + iv, nv + r, 2 * nv + ia, soc])
    cols = np.concatenate([np.zeros(nv, dtype=int), 1 + c, np.zeros(nv, dtype=int), 1 + c, 1 + ia, 1 + na + np.arange(ns * n)])
    vals = np.concatenate([-np.ones(nv), v, -np.ones(nv), -v, -np.ones(na), -np.ones(ns * n)])
    b_soc = np.zeros((ns, 1 + n))
    b_soc[:, 0] = 1.0
    cones = [clarabel.NonnegativeConeT(2 * nv + na)] + [clarabel.SecondOrderConeT(1 + n)] * ns
    A = to_csc(rows, cols, vals, (2 * nv + na + ns * (1 + n), nz))
    q = np.zeros(nz)
    q[0] = 1.0
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.presolve_enable = False  # nothing to remove; saves a fifth of the certificate's time
    settings.iterative_refinement_enable = False  # a third of the rest; the residual is recomputed below
    b = np.concatenate([-grad_s, grad_s, np.zeros(na), b_soc.ravel()])
    P = CSC(np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros(nz + 1, dtype=np.int64), (nz, nz))
    sol = clarabel.DefaultSolver(_lists(P), q.tolist(), _lists(A), b.tolist(), cones, settings).solve()
    z = np.asarray(sol.x)
    lam_v = np.maximum(z[1:1 + na], 0.0)
    # Recompute the residual from the multipliers found (not the solver's t), so the number is exact.
    g = z[1 + na:].reshape(ns, n) if ns else np.zeros((0, n))
    norms = np.linalg.norm(g, axis=1)
    g = g / np.maximum(norms, 1.0)[:, None]
    return certificate(lam_v, g)
