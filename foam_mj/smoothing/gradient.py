"""Gradient smoothing (paper 003 section 4.4, Eq. 9) and the analytic gradients of SV and TC.

Eq. 9 moves every interior vertex p_i of the path down the gradient of SV (paper 003 Eq. 7),

    x_j^i <- x_j^i - eta dSV/dx_j^i,     eta = 0.005 (section 5.1),

with the ends q_init and q_goal fixed. Here the vertices are the waypoints sigma, and each step is
followed by the Euclidean projection of every waypoint onto its hatch (closed form, see
:meth:`Hatches.project`), i.e. projected gradient descent: the path stays in the rosary, so it stays
safe. (The thesis does not say how it keeps the smoothed vertices in the bubbles; projection keeps the
full step inside the hatch and moves along its boundary when a constraint is active, where step
halving would stall there.) All vertices move at once (Jacobi order: Eq. 9 applied to the gradient at
the current path). The iterate with the lowest SV is returned.

Gradients (per interior vertex i, a = p_i - p_(i-1), b = p_(i+1) - p_i, c = cos of the turn theta_i):

    dc/da = b / (|a||b|) - c a / |a|^2,   dc/db = a / (|a||b|) - c b / |b|^2,
    d(theta^2)/dc = -2 theta / sin(theta)   (-> -2 as theta -> 0; no singularity at a straight vertex).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.lib.stride_tricks import as_strided

from foam_mj import paths
from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import (
    Hatches,
    MeanStall,
    SeedLike,
    SmoothingResult,
    Smoother,
    StopCriteria,
    _check_positive,
    check_initial,
    trivial_result,
)

_EPS = 1e-12


def sv_and_gradient(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SV (paper 003 Eq. 7) of paths (..., L, n) and its gradient with respect to every point (..., L, n).

    The gradient of the end points is returned too (callers keep them fixed). A vertex next to a
    zero-length segment has no defined turn: it contributes 0 to SV and to the gradient.
    """
    p = np.asarray(points, dtype=float)
    seg = np.diff(p, axis=-2)
    a, b = seg[..., :-1, :], seg[..., 1:, :]
    ls = np.sqrt(np.einsum("...i,...i->...", seg, seg))
    la, lb = ls[..., :-1], ls[..., 1:]
    den = la * lb
    ok = den > _EPS
    safe = np.where(ok, den, 1.0)
    c = np.clip(np.where(ok, np.einsum("...i,...i->...", a, b) / safe, 1.0), -1.0, 1.0)
    theta = np.arccos(c)
    n_ang = theta.shape[-1]
    sv = (theta**2).sum(axis=-1) / n_ang if n_ang else np.zeros(theta.shape[:-1])
    s = np.sin(theta)
    # d(theta^2)/dc = -2 theta / sin theta, with its limit -2 at theta = 0 (and a cap near theta = pi).
    ratio = np.where(s > 1e-8, theta / np.maximum(s, 1e-8), 1.0)
    g = np.where(ok, -2.0 * ratio, 0.0) / max(n_ang, 1)
    la_s = np.where(ok, la, 1.0)[..., None]
    lb_s = np.where(ok, lb, 1.0)[..., None]
    dc_da = b / (la_s * lb_s) - c[..., None] * a / la_s**2
    dc_db = a / (la_s * lb_s) - c[..., None] * b / lb_s**2
    ga = g[..., None] * dc_da  # d SV / d a_i
    gb = g[..., None] * dc_db  # d SV / d b_i
    grad = np.zeros_like(p)
    # a_i = p_i - p_(i-1), b_i = p_(i+1) - p_i with i the vertex index 1..L-2
    grad[..., 1:-1, :] += ga - gb
    grad[..., :-2, :] -= ga
    grad[..., 2:, :] += gb
    return sv, grad


def tc_and_gradient(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """TC (paper 003 Eq. 6) = |p_last - p_first| / length of paths (..., L, n), and dTC/dp for the
    interior points (ends held fixed: their entries are 0). dTC/dp_i = -(D_e / D_cam^2) dD_cam/dp_i,
    dD_cam/dp_i = u_(i-1,i) - u_(i,i+1) (unit vectors of the adjacent segments)."""
    p = np.asarray(points, dtype=float)
    seg = np.diff(p, axis=-2)
    ls = np.linalg.norm(seg, axis=-1)
    u = seg / np.maximum(ls, _EPS)[..., None]
    length = ls.sum(axis=-1)
    de = np.linalg.norm(p[..., -1, :] - p[..., 0, :], axis=-1)
    tc = de / np.maximum(length, _EPS)
    grad = np.zeros_like(p)
    grad[..., 1:-1, :] = -(de / np.maximum(length, _EPS) ** 2)[..., None, None] * (u[..., :-1, :] - u[..., 1:, :])
    return tc, grad


# -- the single-path fast path ------------------------------------------------------------------------
# Gradient smoothing takes thousands of steps on one small path (L = k + 1 points of dimension n,
# k ~ 30), where numpy's per-call overhead (about 1 us) dominates: the generic code above costs about
# 300 us a step. The two classes below do the same floating-point operations with about a third of
# the numpy calls: the path is stored coordinate-major, (n, L), so that most operations run over one
# contiguous block (ends included: their gradient is zeroed, their "hatch" holds them in place); the
# a/b pair of every vertex is one stacked view; the masks of ``np.where`` become ``where=``/``out=``
# arguments; the dot products of a step share calls. For n = 3 a dot product adds the coordinate
# products in the order numpy's einsum uses for the generic code's ``einsum("...i,...i->...")`` on
# x86-64 ((x0 y0 + x2 y2) + x1 y1), so that the iterates are bit-identical to the generic code's; on
# another platform, and for n != 3, they may differ from it by rounding only (tests/test_smoothing_math.py
# compares both on random inputs).


def _view(buf: np.ndarray, offset: int, shape: tuple[int, ...], strides: tuple[int, ...]) -> np.ndarray:
    """A strided view of the 1-D buffer ``buf`` from element ``offset`` (strides in elements)."""
    item = buf.itemsize
    return as_strided(buf[offset:], shape=shape, strides=tuple(s * item for s in strides), writeable=True)


class _CoordSum:
    """``out`` = the sum over the coordinates of ``prod`` (n, ...) (n blocks): for n = 3 as (x0 + x2) + x1,
    the order of numpy's einsum over a length-3 axis."""

    def __init__(self, prod: np.ndarray, out: np.ndarray) -> None:
        self.prod, self.out, self.n = prod, out, len(prod)

    def __call__(self) -> np.ndarray:
        p, out = self.prod, self.out
        if self.n == 3:
            np.add(p[0], p[2], out=out)
            np.add(out, p[1], out=out)
        else:
            np.add.reduce(p, axis=0, out=out)
        return out


class _PathSV:
    """SV (paper 003 Eq. 7) and its gradient for one coordinate-major path P (n, L), L = m + 2 >= 3.

    ``__call__(P)`` returns SV and the gradient with respect to every point, (n, L), with exact zeros
    at both ends (they are fixed), in a buffer that the next call overwrites. The operations are those
    of :func:`sv_and_gradient`; a path with a zero-length segment next to a vertex (|a||b| <= _EPS)
    goes to :func:`sv_and_gradient` itself.
    """

    def __init__(self, m: int, n: int) -> None:
        L = m + 2
        self.m, self.L, self.n = m, L, n
        self.neg_half_m = -(m / 2.0)  # (-2 r) / m == r / (-m / 2) exactly: both are 2 r / m correctly rounded
        # Backward differences D[:, p] = P[:, p] - P[:, p - 1] as one flat (n L) array (column 0 is junk:
        # the previous row's last point), one spare element at the end. Vertex p (1..m) has a = D[:, p],
        # b = D[:, p + 1].
        self._dbuf = np.zeros(n * L + 1)
        self._d_flat = self._dbuf[1 : n * L]
        # prod[i] = [D[i]^2, D[i, p] D[i, p + 1]] (2, L) for every coordinate i
        self._mul = (_view(self._dbuf, 0, (n, 2, L), (L, 0, 1)), _view(self._dbuf, 0, (n, 2, L), (L, 1, 1)))
        self._prod = np.empty((n, 2, L))
        self._q = np.empty((2, L))  # [|D[:, p]|^2, a.b of vertex p]
        self._qsum = _CoordSum(self._prod, self._q)
        self._dot = self._q[1, 1 : m + 1]
        self._ls = np.empty(L)
        self._la, self._lb = self._ls[1 : m + 1], self._ls[2 : m + 2]
        self._lsq = np.empty(L)  # |D| squared again (la_s ** 2 and lb_s ** 2 of the generic code)
        self._lsq_ab = _view(self._lsq, 1, (2, 1, m), (1, 0, 1))  # [la^2, lb^2] (2, 1, m)
        self._ab = _view(self._dbuf, 1, (2, n, m), (1, L, 1))  # [a, b] (2, n, m)
        self._ba = self._ab[::-1]  # [b, a]
        self._den = np.empty(m)
        self._c = np.empty(m)
        self._ones, self._minus_ones = np.ones(m), -np.ones(m)
        self._tiny = np.full(m, 1e-8)
        self._theta = np.empty(m)
        self._t2 = np.empty(m)
        self._s = np.empty(m)
        self._big = np.empty(m, dtype=bool)
        self._ratio = np.empty(m)
        self._g = np.empty(m)
        self._cx = np.empty((2, n, m))
        # [dSV/da, dSV/db] per point (2, n, L), zero at both ends (never written): the gradient of point p
        # is ((ga[p] - gb[p]) - ga[p + 1]) + gb[p - 1], one flat pass (the shifted ends read zeros).
        self._gab = np.zeros((2, n, L))
        self._num = self._gab[:, :, 1 : m + 1]
        gab = self._gab.reshape(-1)
        N = n * L
        self._grad = np.empty((n, L))
        self._assemble = (gab[:N], gab[N:], gab[1 : N + 1], gab[N - 1 : 2 * N - 1], self._grad.reshape(-1))
        self._interior = np.ones((n, L))
        self._interior[:, [0, -1]] = 0.0

    def __call__(self, P: np.ndarray) -> tuple[float, np.ndarray]:
        m = self.m
        ls, den, c, theta = self._ls, self._den, self._c, self._theta
        p_flat = P.reshape(-1)
        np.subtract(p_flat[1:], p_flat[:-1], out=self._d_flat)
        np.multiply(*self._mul, out=self._prod)
        q = self._qsum()  # [|D|^2, a.b]
        np.sqrt(q[0], out=ls)
        np.multiply(self._la, self._lb, out=den)
        if min(den.tolist()) <= _EPS:  # a zero-length segment: the generic code's masks matter
            sv, g = sv_and_gradient(P.T)
            self._grad[...] = g.T
            self._grad[:, [0, -1]] = 0.0
            return float(sv), self._grad
        np.divide(self._dot, den, out=c)
        np.minimum(c, self._ones, out=c)
        np.maximum(c, self._minus_ones, out=c)
        np.arccos(c, out=theta)
        np.multiply(theta, theta, out=self._t2)
        sv = float(np.add.reduce(self._t2) / m)
        s = np.sin(theta, out=self._s)
        # d(theta^2)/dc / (-2) = theta / sin(theta), 1 where sin(theta) <= 1e-8 (as the generic code)
        ratio = self._ratio
        ratio.fill(1.0)
        np.divide(theta, s, out=ratio, where=np.greater(s, self._tiny, out=self._big))
        g = np.divide(ratio, self.neg_half_m, out=self._g)
        np.multiply(ls, ls, out=self._lsq)
        num, cx = self._num, self._cx
        np.divide(self._ba, den, out=num)  # [b, a] / (|a||b|)
        np.multiply(c, self._ab, out=cx)  # [c a, c b]
        np.divide(cx, self._lsq_ab, out=cx)  # [c a / |a|^2, c b / |b|^2]
        np.subtract(num, cx, out=num)  # [dc/da, dc/db]
        np.multiply(g, num, out=num)  # [dSV/da, dSV/db]
        ga, gb, ga_next, gb_prev, grad = self._assemble
        np.subtract(ga, gb, out=grad)
        np.subtract(grad, ga_next, out=grad)
        np.add(grad, gb_prev, out=grad)
        np.multiply(self._grad, self._interior, out=self._grad)  # the ends are fixed
        return sv, self._grad


class _LensProjection:
    """:meth:`Hatches.project` for the waypoints of one coordinate-major path x (n, L), into ``out``.

    Every quantity of the generic code is computed for all points at once (ball a and ball b stacked),
    and the closed form's case selection is done with ``where=`` copies; a point inside both balls is
    copied unchanged, as there. The two ends get a dummy hatch (a unit ball about the point itself, for
    both balls) which holds them, so they are copied unchanged too.
    """

    def __init__(self, h: Hatches, inset: float, q_init: np.ndarray, q_goal: np.ndarray) -> None:
        m, n = h.ca.shape
        L = m + 2
        ra, rb = h.ra - inset, h.rb - inset
        if np.any(ra <= 0) or np.any(rb <= 0):
            raise ValueError(f"inset {inset} is larger than a hatch ball's radius")
        mid, u, rho, alt = h._rim(inset)

        def pad(a, first, last):  # (m, ...) hatch data -> (n or 1, L) coordinate-major, with the ends' values
            full = np.empty((L,) + a.shape[1:])
            full[0], full[1:-1], full[-1] = first, a, last
            return np.ascontiguousarray(full.T)

        e0, e1 = np.eye(n)[0], np.eye(n)[1]
        ca, cb = pad(h.ca, q_init, q_goal), pad(h.cb, q_init, q_goal)
        self._c = np.stack([ca, cb])  # (2, n, L)
        self._c_swap = np.ascontiguousarray(self._c[::-1])
        r = np.stack([pad(ra, 1.0, 1.0), pad(rb, 1.0, 1.0)])
        self._r = r[:, None, :]  # (2, 1, L)
        r2 = np.stack([pad(ra * ra, 1.0, 1.0), pad(rb * rb, 1.0, 1.0)])
        self._r2, self._r2_swap = r2, np.ascontiguousarray(r2[::-1])
        # The ends' rim: any finite values (y = x - mid must not vanish there, see __call__).
        self._mid = pad(mid, q_init + 1.0, q_goal + 1.0)
        self._u, self._rho, self._alt = pad(u, e0, e0), pad(rho, 0.0, 0.0), pad(alt, e1, e1)
        self._cc = np.stack([ca, cb, self._mid])  # x - [ca, cb, mid]
        # z = [x - ca, x - cb, y, pa - cb, pb - ca] (5, n, L); prod (n, 3, L): the coordinate products
        self._z = np.empty((5, n, L))
        self._d, self._y, self._e = self._z[:2], self._z[2], self._z[3:]
        self._prod = np.empty((n, 3, L))
        self._prod_t = self._prod.transpose(1, 0, 2)  # (3, n, L)
        self._q = np.empty((3, L))
        self._qsum = _CoordSum(self._prod, self._q)
        self._nd = np.empty((2, 1, L))
        self._pp = np.empty((2, n, L))
        self._tu = np.empty((n, L))
        self._ny = np.empty(L)
        self._inside = np.empty((2, L), dtype=bool)
        self._img_in = np.empty((2, L), dtype=bool)
        self._use = np.empty((2, L), dtype=bool)
        self._both = np.empty(L, dtype=bool)
        self._small = np.empty(L, dtype=bool)

    def __call__(self, x: np.ndarray, out: np.ndarray) -> np.ndarray:
        z, d, y, e, prod_t = self._z, self._d, self._y, self._e, self._prod_t
        np.subtract(x, self._cc, out=z[:3])
        np.multiply(d, d, out=prod_t[:2])
        np.multiply(y, self._u, out=prod_t[2])
        q = self._qsum()  # |x - ca|^2, |x - cb|^2, y.u
        inside = np.less_equal(q[:2], self._r2, out=self._inside)
        # Projections onto each ball: c + d min(1, r / max(|d|, eps)). The min is left out: the
        # projection onto a ball is only used for a point outside it, where r / |d| <= 1 already.
        nd = self._nd
        np.sqrt(q[:2, None, :], out=nd)
        np.maximum(nd, _EPS, out=nd)
        np.divide(self._r, nd, out=nd)
        pp = np.multiply(d, nd, out=self._pp)
        np.add(self._c, pp, out=pp)  # [pa, pb]
        # The rim point nearest x: y = x - mid without its component along u, scaled to the radius rho.
        np.multiply(q[2], self._u, out=self._tu)
        np.subtract(y, self._tu, out=y)
        np.subtract(pp, self._c_swap, out=e)
        np.multiply(z[2:], z[2:], out=prod_t)
        q = self._qsum()  # |y|^2, |pa - cb|^2, |pb - ca|^2
        img_in = np.less_equal(q[1:], self._r2_swap, out=self._img_in)  # pa in b, pb in a
        ny = np.sqrt(q[0], out=self._ny)
        if min(ny.tolist()) > _EPS:
            np.divide(y, ny, out=out)
        else:  # a point on the axis: any rim point (the fixed normal alt)
            small = np.less_equal(ny, _EPS, out=self._small)
            np.maximum(ny, _EPS, out=ny)
            np.divide(y, ny, out=out)
            np.copyto(out, self._alt, where=small)
        np.multiply(self._rho, out, out=out)
        np.add(self._mid, out, out=out)
        use = np.greater(img_in, inside, out=self._use)  # outside one ball, its projection inside the other
        np.copyto(out, pp[1], where=use[1])
        np.copyto(out, pp[0], where=use[0])
        np.copyto(out, x, where=np.logical_and(inside[0], inside[1], out=self._both))
        return out


@dataclass(frozen=True)
class GradientSmoothing(Smoother):
    """Projected gradient descent of SV over the waypoints (paper 003 Eq. 9, eta = 0.005).

    ``initial`` defaults to the centre path's waypoints (the thesis smooths T into T_CA, and T_RA into
    T_RCA). ``stop`` applies to SV: by default the run stops once SV has fallen by less than 1e-5 over
    100 steps (SV drops by ~95% in the first 200 steps, then creeps), capped at 20,000 steps; it also
    ends when a step moves no waypoint by more than ``tol``. ``inset`` shrinks the hatches the
    projection uses (configuration units), so waypoints end strictly inside. ``seed`` is accepted for
    the common interface and unused (the method is deterministic). The history holds the lowest SV
    after each step; ``info["initial"]`` the SV of the initial path.
    """

    eta: float = 0.005
    tol: float = 1e-12
    inset: float = 1e-10
    stop: StopCriteria = field(default_factory=lambda: StopCriteria(stall_iterations=100, stall_tol=1e-5))

    name: ClassVar[str] = "gradient"

    def __post_init__(self) -> None:
        _check_positive("eta", self.eta)
        _check_positive("tol", self.tol, allow_zero=True)
        _check_positive("inset", self.inset, allow_zero=True)
        if not isinstance(self.stop, StopCriteria):
            raise ValueError(f"stop must be a StopCriteria, got {self.stop!r}")

    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> SmoothingResult:
        t_start = time.perf_counter()
        w = check_initial(rosary, initial, default=rosary.center_waypoints())
        if rosary.n_hatches == 0:
            return trivial_result(self.name, rosary, t_start, objective="SV")
        h = Hatches.of(rosary)
        w = h.project(w, self.inset)  # a centre waypoint sits on its parent's surface: move it inside
        m, eta, tol, stop = h.m, self.eta, self.tol, self.stop
        sv_grad = _PathSV(m, rosary.dim)
        project = _LensProjection(h, self.inset, rosary.q_init, rosary.q_goal)
        # Coordinate-major paths (n, k + 1), two buffers: each step projects into the other one, then
        # they swap. The gradient is zero at the ends and their dummy hatch keeps them: they stay put.
        path = np.ascontiguousarray(rosary.path(w).T)
        other = path.copy()
        trial, diff = np.empty_like(path), np.empty_like(path)
        sv, grad = sv_grad(path)
        best_p, best, initial_sv = path.copy(), sv, sv
        stall = MeanStall(sv, stop.stall_tol)
        hist: list[float] = []
        t, reason = 0, stop.reason(0, sv, 0)
        while reason is None:
            # Eq. 9 then the projection onto the hatches: w_new = P(w - eta grad)
            np.multiply(eta, grad, out=trial)
            np.subtract(path, trial, out=trial)
            new = project(trial, out=other)
            np.subtract(new, path, out=diff)
            step = float(np.abs(diff, out=diff).max())
            path, other = new, path
            sv, grad = sv_grad(path)
            t += 1
            if sv < best:
                best = sv
                np.copyto(best_p, path)
            stall.update(sv)
            hist.append(best)
            reason = stop.reason(t, best, stall.count)
            if reason is None and step <= tol:
                reason = "converged"
        best_w = best_p[:, 1:-1].T
        return SmoothingResult.build(
            self.name,
            rosary,
            best_w,
            history_best=np.array(hist),
            iterations=t,
            evaluations=t + 1,
            wall_time=time.perf_counter() - t_start,
            stop_reason=reason,
            objective="SV",
            info={"eta": self.eta, "constraint": "projection onto the hatch", "inset": self.inset,
                  "initial": initial_sv},
        )


def center_path_result(rosary: Rosary, method: str = "centre") -> SmoothingResult:
    """The centre path T (through the bubble centres, paper 003 Fig. 6) as a result record."""
    t0 = time.perf_counter()
    w = rosary.center_waypoints()
    p = rosary.path(w)
    return SmoothingResult.build(
        method, rosary, w, history_best=np.array([float(paths.objective(p))]), iterations=0, evaluations=1,
        wall_time=time.perf_counter() - t0, stop_reason="none",
    )
