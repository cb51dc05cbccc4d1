"""Gradient smoothing (Nascimento and Alsina 2021 section 4.4, Eq. 9) and the analytic gradients of SV and TC.

Eq. 9 moves every interior vertex p_i of the path down the gradient of SV (Nascimento and Alsina 2021 Eq. 7),

    x_j^i <- x_j^i - eta dSV/dx_j^i,     0 < eta <= 1 (Eq. 9's range), eta = 0.005 (section 5.1),

with the ends q_init and q_goal fixed. Here the vertices are the waypoints sigma, and each step is
followed by the Euclidean projection of every waypoint onto its hatch (closed form, see
:meth:`Hatches.project`), i.e. projected gradient descent: the path stays in the rosary, so it stays
safe. (The thesis does not say how it keeps the smoothed vertices in the bubbles; projection keeps the
full step inside the hatch and moves along its boundary when a constraint is active, where step
halving would stall there.) All vertices move at once (Jacobi order: Eq. 9 applied to the gradient at
the current path). The iterate with the lowest SV is returned.

The step. The thesis's eta = 0.005 was tuned on its rosary; SV's gradient grows as 1 / segment length, so
on a rosary of small bubbles (bubbletree's corridors, a corridor of 1 cm bubbles) every step of that size
overshoots, SV never falls below the start's, and T_CA came back equal to T (7 of 8 bubbletree rosaries of
the leg scenes, seeds 0-1). A run that stalls or hits its cap without lowering SV at all is therefore
repeated with eta / 10, at most :data:`ETA_RETRIES` times (``info["eta"]`` is the step used,
``info["eta_retries"]`` the repeats); a run that lowers SV, as on the papers' rosaries, is Eq. 9 with the
given eta, unchanged.

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
    check_rosary,
    check_rosary_type,
    check_seed,
    trivial_result,
)

_EPS = 1e-12


def sv_and_gradient(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SV (Nascimento and Alsina 2021 Eq. 7) of paths (..., L, n) and its gradient with respect to every point (..., L, n).

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
    """TC (Nascimento and Alsina 2021 Eq. 6) = |p_last - p_first| / length of paths (..., L, n), and dTC/dp for the
    interior points (ends held fixed: their entries are 0). dTC/dp_i = -(D_e / D_cam^2) dD_cam/dp_i,
    dD_cam/dp_i = u_(i-1,i) - u_(i,i+1) (unit vectors of the adjacent segments)."""
    p = np.asarray(points, dtype=float)
    seg = np.diff(p, axis=-2)
    ls = np.linalg.norm(seg, axis=-1)
    u = seg / np.maximum(ls, _EPS)[..., None]
    length = ls.sum(axis=-1)
    de = np.linalg.norm(p[..., -1, :] - p[..., 0, :], axis=-1)
    moves = length > _EPS  # a path that does not move has TC 0 (foam_mj.paths.tc) and no gradient
    tc = np.where(moves, de / np.maximum(length, _EPS), 0.0)
    grad = np.zeros_like(p)
    grad[..., 1:-1, :] = -np.where(moves, de / np.maximum(length, _EPS) ** 2, 0.0)[..., None, None] * (u[..., :-1, :] - u[..., 1:, :])
    return tc, grad


# -- the single-path fast path ------------------------------------------------------------------------
# Gradient smoothing takes thousands of steps on one small path (L = k + 1 points of dimension n,
# k ~ 30), where numpy's per-call overhead dominates: the generic code above makes ~100 numpy calls a
# step (~300 us). The two classes below do the same floating-point operations, in the same order, in
# about 50 calls that each run over one or two contiguous blocks, with positional ``out`` buffers
# allocated once:
#
# * the path is stored coordinate-major, P (n, L), and every array is laid out like it, flat; the
#   quantities of a point (lengths, cosines, angles, radii, ...) are repeated on each of the n rows,
#   so that they combine with coordinates without broadcasting;
# * the ends are computed with the waypoints and then held: their step is zeroed and they get a
#   dummy hatch that contains them; the junk that the flat layout produces at the ends (differences
#   across two rows) is kept finite and non-zero, and masked out;
# * the a/b pair of every vertex, and ball a/ball b of every hatch, are stacked views of one buffer;
#   the masks of ``np.where`` become ``where=`` copies or factors.
#
# A dot product adds the coordinate products in the order numpy's einsum uses for the generic code's
# ``einsum("...i,...i->...")`` on x86-64 (even and odd coordinates in two running sums: (x0 y0 + x2 y2)
# + x1 y1 for n = 3), so that the iterates are bit-identical to the generic code's there; on another
# platform they may differ from it by rounding only (tests/test_smoothing_math.py compares both).

_add, _sub, _mul, _div = np.add, np.subtract, np.multiply, np.divide
_sqrt, _maximum, _minimum, _copyto = np.sqrt, np.maximum, np.minimum, np.copyto


def _view(buf: np.ndarray, offset: int, shape: tuple[int, ...], strides: tuple[int, ...]) -> np.ndarray:
    """A strided view of the flat buffer ``buf`` from element ``offset`` (strides in elements)."""
    item = buf.itemsize
    return as_strided(buf[offset:], shape=shape, strides=tuple(s * item for s in strides), writeable=True)


class _RepeatedCoordSum:
    """For prod (B, n, L) (contiguous): out (B, n, L) = the sum over the n coordinate rows of each block,
    repeated on every row, added as numpy's einsum adds a short contiguous axis on x86-64: the even and
    the odd coordinates in two running sums, then their sum ((x0 + x2) + x1 for n = 3)."""

    def __init__(self, prod: np.ndarray, out: np.ndarray) -> None:
        B, n, L = prod.shape
        flat = prod.reshape(-1)
        rows = [_view(flat, i * L, (B, n, L), (n * L, 0, 1)) for i in range(n)]
        self.even, self.odd = rows[0::2], rows[1::2]
        self.out = out
        self.tmp = np.empty_like(out) if n >= 4 else None

    def __call__(self) -> np.ndarray:
        even, odd, out = self.even, self.odd, self.out
        if not odd:  # n = 1 (a one-joint robot)
            _copyto(out, even[0])
            return out
        if len(even) == 1:  # n = 2
            _add(even[0], odd[0], out)
            return out
        _add(even[0], even[1], out)
        for x in even[2:]:
            _add(out, x, out)
        if len(odd) == 1:  # n = 3
            _add(out, odd[0], out)
            return out
        tmp = self.tmp
        assert tmp is not None  # n >= 4
        _add(odd[0], odd[1], tmp)
        for x in odd[2:]:
            _add(tmp, x, tmp)
        _add(out, tmp, out)
        return out


class _PathSV:
    """SV (Nascimento and Alsina 2021 Eq. 7) and its gradient for one coordinate-major path P (n, L), L = m + 2 >= 3.

    ``__call__(P)`` returns SV and the gradient with respect to the points, (n, L), in a buffer that the
    next call overwrites; its two end columns are junk (finite: the ends are fixed, their step is
    zeroed by the caller).
    The operations are those of :func:`sv_and_gradient`; a path with a zero-length segment next to a
    vertex (|a||b| <= _EPS) goes to :func:`sv_and_gradient` itself.
    """

    def __init__(self, m: int, n: int) -> None:
        L = m + 2
        N = n * L
        self.m = m
        # Backward differences D[i, p] = P[i, p] - P[i, p - 1], flat, and one spare element (1.0) at each
        # end. Vertex p (1..m) has a = D[:, p], b = D[:, p + 1]. Column 0 is junk (the previous row's last
        # point); its first element stays 1.0 so that its length is >= 1 (finite quotients everywhere).
        self._dbuf = np.ones(N + 1)
        self._d = self._dbuf[1:N]
        self._dd = (_view(self._dbuf, 0, (2, N), (0, 1)), _view(self._dbuf, 0, (2, N), (1, 1)))  # [D, D], [D, D next]
        self._prod = np.empty((2, n, L))
        self._prod_flat = self._prod.reshape(2, N)
        self._q = np.empty((2, N))  # [|D|^2, a.b], repeated on each row
        self._qsum = _RepeatedCoordSum(self._prod, self._q.reshape(2, n, L))
        self._lsbuf = np.ones(N + 1)  # |D| and a spare 1.0
        self._ls, self._ls_next = self._lsbuf[:N], self._lsbuf[1:]
        self._den = np.empty(N)
        self._den_check = self._den[1 : m + 1]  # the vertices' |a||b| (row 0)
        self._c = np.empty(N)
        self._ones, self._minus_ones, self._tiny = np.ones(N), -np.ones(N), np.full(N, 1e-8)
        self._theta = np.empty(N)
        self._t2 = np.empty(m)
        self._theta_vertices = self._theta[1 : m + 1]
        self._s = np.empty(N)
        self._s_check = self._s[1 : m + 1]
        self._small = np.empty(N, dtype=bool)
        self._ratio = np.empty(N)
        # g = -2 ratio / m = ratio / (-m / 2) exactly (both are 2 ratio / m correctly rounded); dividing by
        # inf at the ends makes their (junk) a/b terms vanish.
        self._g_div: np.ndarray = np.full((n, L), -(m / 2.0))
        self._g_div[:, [0, -1]] = np.inf
        self._g_div = self._g_div.reshape(-1)
        self._g = np.empty(N)
        self._lsqbuf = np.empty(N + 1)
        self._lsq_ab = _view(self._lsqbuf, 0, (2, N), (1, 1))  # [la^2, lb^2]
        self._ab = self._dd[1]  # [a, b] = [D, D next]
        self._ba = _view(self._dbuf, 1, (2, N), (-1, 1))  # [b, a]
        self._cx = np.empty((2, N))
        # [dSV/da, dSV/db] (2, N), zero at the ends (g = 0 there): the gradient of point p is
        # ((ga[p] - gb[p]) - ga[p + 1]) + gb[p - 1], one flat pass (the first point's gb[p - 1] is the
        # last end's ga, and the last point's ga[p + 1] the first end's gb: zeros).
        gab = np.zeros(2 * N + 2)
        self._gab = gab[1 : 2 * N + 1].reshape(2, N)
        self._grad = np.empty((n, L))
        ga, gb, ga_next, gb_prev = gab[1 : N + 1], gab[N + 1 : 2 * N + 1], gab[2 : N + 2], gab[N : 2 * N]
        self._assemble = (ga, gb, ga_next, gb_prev, self._grad.reshape(-1))

    def __call__(self, P: np.ndarray) -> tuple[float, np.ndarray]:
        ls, den, c, theta, s, ratio = self._ls, self._den, self._c, self._theta, self._s, self._ratio
        p = P.reshape(-1)
        _sub(p[1:], p[:-1], self._d)
        _mul(*self._dd, self._prod_flat)
        q = self._qsum().reshape(2, -1)  # [|D|^2, a.b]
        _sqrt(q[0], ls)
        _mul(ls, self._ls_next, den)
        if min(self._den_check.tolist()) <= _EPS:  # a zero-length segment: the generic code's masks matter
            sv_p, g = sv_and_gradient(P.T)
            self._grad[...] = g.T
            return float(sv_p), self._grad
        _div(q[1], den, c)
        _minimum(c, self._ones, out=c)
        _maximum(c, self._minus_ones, out=c)
        np.arccos(c, theta)
        _mul(self._theta_vertices, self._theta_vertices, self._t2)
        sv = float(np.add.reduce(self._t2)) / self.m  # the same IEEE division as numpy's
        np.sin(theta, s)
        # d(theta^2)/dc / (-2) = theta / sin(theta), and 1 where sin(theta) <= 1e-8 (the generic code's rule)
        _maximum(s, self._tiny, out=s)
        _div(theta, s, ratio)
        if min(self._s_check.tolist()) <= 1e-8:  # a straight (or reversed) vertex
            _copyto(ratio, 1.0, where=np.less_equal(s, 1e-8, out=self._small))
        g = _div(ratio, self._g_div, self._g)
        _mul(self._lsbuf, self._lsbuf, self._lsqbuf)
        gab, cx = self._gab, self._cx
        _div(self._ba, den, gab)  # [b, a] / (|a||b|)
        _mul(c, self._ab, cx)  # [c a, c b]
        _div(cx, self._lsq_ab, cx)  # [c a / |a|^2, c b / |b|^2]
        _sub(gab, cx, gab)  # [dc/da, dc/db]
        _mul(g, gab, gab)  # [dSV/da, dSV/db]
        ga, gb, ga_next, gb_prev, grad = self._assemble
        _sub(ga, gb, grad)
        _sub(grad, ga_next, grad)
        _add(grad, gb_prev, grad)
        return sv, self._grad


class _LensProjection:
    """:meth:`Hatches.project` for the waypoints of one coordinate-major path x (n, L), into ``out``.

    Every quantity of the generic code is computed for all points at once (ball a and ball b stacked),
    and the closed form's case selection is done with ``where=`` copies; a point inside both balls is
    copied unchanged, as there. The two ends get a dummy hatch (ball a = ball b = the unit ball about the
    end itself) which holds them, so they are copied unchanged too.
    """

    def __init__(self, h: Hatches, inset: float, q_init: np.ndarray, q_goal: np.ndarray) -> None:
        m, n = h.ca.shape
        L = m + 2
        ra, rb = h.ra - inset, h.rb - inset
        if np.any(ra <= 0) or np.any(rb <= 0):
            raise ValueError(f"inset {inset} is larger than a hatch ball's radius")
        mid, u, rho, alt = h._rim(inset)

        def pad(a, first, last):  # hatch data (m, n) or (m,) -> (n, L): the ends' values added, scalars repeated
            full = np.empty((L,) + a.shape[1:])
            full[0], full[1:-1], full[-1] = first, a, last
            return np.ascontiguousarray(np.broadcast_to(full.T, (n, L)))

        e0, e1 = np.eye(n)[0], np.eye(n)[min(1, n - 1)]  # (n = 1: the ends' rim is never used)
        ca, cb = pad(h.ca, q_init, q_goal), pad(h.cb, q_init, q_goal)
        self._c = np.stack([ca, cb])  # (2, n, L)
        self._c_swap = np.ascontiguousarray(self._c[::-1])
        self._r = np.stack([pad(ra, 1.0, 1.0), pad(rb, 1.0, 1.0)])
        r2 = np.stack([pad(ra * ra, 1.0, 1.0), pad(rb * rb, 1.0, 1.0)])
        self._r2, self._r2_swap = r2, np.ascontiguousarray(r2[::-1])
        # The ends' rim: any finite values with y = x - mid off the axis (|y| > eps there).
        self._mid = pad(mid, q_init + 1.0, q_goal + 1.0)
        self._u, self._rho, self._alt = pad(u, e0, e0), pad(rho, 0.0, 0.0), pad(alt, e1, e1)
        self._cc = np.stack([ca, cb, self._mid])  # x - [ca, cb, mid]
        self._z = np.empty((3, n, L))  # [x - ca, x - cb, x - mid]
        self._d, self._x_mid = self._z[:2], self._z[2]
        self._ye = np.empty((3, n, L))  # [y, pa - cb, pb - ca]
        self._y, self._e = self._ye[0], self._ye[1:]
        self._prod = np.empty((3, n, L))
        self._prod_d, self._prod_t = self._prod[:2], self._prod[2]
        self._q = np.empty((3, n, L))
        self._qsum = _RepeatedCoordSum(self._prod, self._q)
        self._nd = np.empty((2, n, L))
        self._pp = np.empty((2, n, L))
        self._tu = np.empty((n, L))
        self._ny = np.empty((n, L))
        self._ny_check = self._ny[0]
        self._inside = np.empty((2, n, L), dtype=bool)
        self._img_in = np.empty((2, n, L), dtype=bool)
        self._use = np.empty((2, n, L), dtype=bool)
        self._both = np.empty((n, L), dtype=bool)
        self._small = np.empty((n, L), dtype=bool)
        self._eps = np.full((n, L), _EPS)
        self._eps2 = np.full((2, n, L), _EPS)

    def __call__(self, x: np.ndarray, out: np.ndarray) -> np.ndarray:
        d, y, ye, pp, nd = self._d, self._y, self._ye, self._pp, self._nd
        _sub(x, self._cc, self._z)
        _mul(d, d, self._prod_d)
        _mul(self._x_mid, self._u, self._prod_t)
        q = self._qsum()  # |x - ca|^2, |x - cb|^2, (x - mid).u
        inside = np.less_equal(q[:2], self._r2, self._inside)
        # Projections onto each ball: c + d min(1, r / max(|d|, eps)). The min is left out: the
        # projection onto a ball is only used for a point outside it, where r / |d| <= 1 already.
        _sqrt(q[:2], nd)
        _maximum(nd, self._eps2, out=nd)
        _div(self._r, nd, nd)
        _mul(d, nd, pp)
        _add(self._c, pp, pp)  # [pa, pb]
        # The rim point nearest x: y = x - mid without its component along u, scaled to the radius rho.
        _mul(q[2], self._u, self._tu)
        _sub(self._x_mid, self._tu, y)
        _sub(pp, self._c_swap, self._e)
        _mul(ye, ye, self._prod)
        q = self._qsum()  # |y|^2, |pa - cb|^2, |pb - ca|^2
        img_in = np.less_equal(q[1:], self._r2_swap, self._img_in)  # pa in b, pb in a
        ny = _sqrt(q[0], self._ny)
        if min(self._ny_check.tolist()) > _EPS:
            _div(y, ny, out)
        else:  # a point on the axis: any rim point (the fixed normal alt)
            small = np.less_equal(ny, self._eps, self._small)
            _maximum(ny, self._eps, out=ny)
            _div(y, ny, out)
            _copyto(out, self._alt, where=small)
        _mul(self._rho, out, out)
        _add(self._mid, out, out)
        use = np.greater(img_in, inside, self._use)  # outside one ball, its projection inside the other
        _copyto(out, pp[1], where=use[1])
        _copyto(out, pp[0], where=use[0])
        _copyto(out, x, where=np.logical_and(inside[0], inside[1], self._both))
        return out


#: How many times a run that never lowers SV is repeated with a ten times shorter step (see the module docstring).
ETA_RETRIES = 6


@dataclass(frozen=True)
class GradientSmoothing(Smoother):
    """Projected gradient descent of SV over the waypoints (Nascimento and Alsina 2021 Eq. 9, eta = 0.005).

    ``initial`` defaults to the centre path's waypoints (the thesis smooths T into T_CA, and T_RA into
    T_RCA). ``stop`` applies to SV: by default the run stops once SV has fallen by less than 1e-5 over
    100 steps (SV drops by ~95% in the first 200 steps, then creeps), capped at 20,000 steps (a run that never lowers SV
    is repeated with a ten times shorter step; the cap counts the steps of every run); it also
    ends when a step moves no waypoint by more than ``tol``. ``inset`` shrinks the hatches the
    projection uses (configuration units; less in a hatch too thin for it, :meth:`Hatches.fitting_inset`), so
    waypoints end strictly inside. ``seed`` is accepted for the common interface, validated and unused (the
    method is deterministic). The history holds the lowest SV
    after each step; ``info["initial"]`` the SV of the initial path.
    """

    eta: float = 0.005
    tol: float = 1e-12
    inset: float = 1e-10
    stop: StopCriteria = field(default_factory=lambda: StopCriteria(stall_iterations=100, stall_tol=1e-5))

    name: ClassVar[str] = "gradient"

    def __post_init__(self) -> None:
        _check_positive("eta", self.eta)
        if self.eta > 1:  # "0 < eta <= 1" (Eq. 9)
            raise ValueError(f"eta must be in (0, 1] (Nascimento and Alsina 2021 Eq. 9), got {self.eta!r}")
        _check_positive("tol", self.tol, allow_zero=True)
        _check_positive("inset", self.inset, allow_zero=True)
        if not isinstance(self.stop, StopCriteria):
            raise ValueError(f"stop must be a StopCriteria, got {self.stop!r}")

    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> SmoothingResult:
        t_start = time.perf_counter()
        check_seed(seed)
        check_rosary_type(rosary)
        w = check_initial(rosary, initial, default=rosary.center_waypoints())
        if rosary.n_hatches == 0:
            return trivial_result(self.name, rosary, t_start, objective="SV")
        check_rosary(rosary)
        h = Hatches.of(rosary)
        inset = h.fitting_inset(self.inset)
        w = h.project(w, inset)  # a centre waypoint sits on its parent's surface: move it inside
        m, eta, tol, stop = h.m, self.eta, self.tol, self.stop
        sv_grad = _PathSV(m, rosary.dim)
        project = _LensProjection(h, inset, rosary.q_init, rosary.q_goal)
        # Coordinate-major paths (n, k + 1), two buffers: each step projects into the other one, then
        # they swap. The ends' step is zero (eta_pts) and their dummy hatch keeps them: they stay put.
        start = np.ascontiguousarray(rosary.path(w).T)
        trial, diff = np.empty_like(start), np.empty_like(start)
        sv0, grad0 = sv_grad(start)
        grad0 = grad0.copy()  # (sv_grad's buffer is overwritten by its next call)
        best_p, best, initial_sv = start.copy(), sv0, sv0
        hist: list[float] = []
        t = 0
        mul, sub, absolute = np.multiply, np.subtract, np.absolute
        for retry in range(ETA_RETRIES + 1):
            path, other = start.copy(), start.copy()
            sv, grad = sv0, grad0
            eta_pts = np.full_like(path, eta)
            eta_pts[:, [0, -1]] = 0.0
            stall = MeanStall(sv, stop.stall_tol)
            reason = stop.reason(t, sv, 0)  # the cap counts the steps of every run (t): they share it
            while reason is None:
                # Eq. 9 then the projection onto the hatches: w_new = P(w - eta grad)
                mul(eta_pts, grad, trial)
                sub(path, trial, trial)
                new = project(trial, other)
                step = float(absolute(sub(new, path, diff), diff).max())
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
            if best < initial_sv or reason != "stall":  # a run ended by the cap leaves no steps to repeat it with
                break
            eta /= 10  # every step raised SV: eta is too long for this rosary's bubbles (see the docstring)
        best_w = best_p[:, 1:-1].T
        assert reason is not None  # (the loop ends with one)
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
            info={"eta": eta, "eta_retries": retry, "constraint": "projection onto the hatch", "inset": inset,
                  "initial": initial_sv},
        )


def center_path_result(rosary: Rosary, method: str = "centre") -> SmoothingResult:
    """The centre path T (through the bubble centres, Nascimento and Alsina 2021 Fig. 6) as a result record."""
    t0 = time.perf_counter()
    w = rosary.center_waypoints()
    p = rosary.path(w)
    return SmoothingResult.build(
        method, rosary, w, history_best=np.array([float(paths.objective(p))]), iterations=0, evaluations=1,
        wall_time=time.perf_counter() - t0, stop_reason="none",
    )
