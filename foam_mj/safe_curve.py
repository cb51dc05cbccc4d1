"""The safe curve: a C2 curve through a path's waypoints that stays in the rosary by construction.

The input is a path [q_init, w_1, ..., w_(k-1), q_goal] whose interior waypoint w_i lies in hatch
b_(i-1) ∩ b_i of the rosary, so segment j (w_j -> w_(j+1)) lies in bubble b_j
(docs/bubbles-math.md). A spline through the waypoints does not inherit this. Here each
segment j is a *quintic Bézier curve* whose six control points all lie in b_j; a Bézier curve lies in
the convex hull of its control points and a ball is convex, so the whole segment lies in b_j -- for
every parameter value, not only at samples.

The curve is parametrized by the chord length u (configuration units, knots u_j at the waypoints). At
every waypoint it has a tangent t_j = dq/du and a curvature vector kappa_j = d2q/du2 shared by both
adjacent segments, so it is C2 in u. With h the segment's length in u, the control points are

    P0 = w_j,  P1 = w_j + h t_j / 5,  P2 = w_j + 2 h t_j / 5 + h^2 kappa_j / 20,
    P3 = w_(j+1) - 2 h t_(j+1) / 5 + h^2 kappa_(j+1) / 20,  P4 = w_(j+1) - h t_(j+1) / 5,  P5 = w_(j+1).

Each waypoint's (t, kappa) enters only the control points next to it, so the ball constraints decouple
per waypoint. Starting from a natural C2 cubic spline through the waypoints (its t and kappa):

1. the tangent's direction is blended towards a direction that enters both neighbouring balls (needed
   when a waypoint lies on a sphere, as the centre path's waypoints do) where that lets it keep more
   of its length along the spline's tangent;
2. the tangent is scaled by alpha = min(1, GAMMA * alpha_max), alpha_max the largest scale that keeps
   w + 2 h t / 5 in the outgoing ball and w - 2 h t / 5 in the incoming one (exact ray-sphere exits);
3. the curvature is scaled the same way (beta) so that P2 and P3 stay in their balls.

Where the spline fits, the curve is the spline's C2 twin; where it does not, it has less curvature; at
worst (alpha = beta = 0) a segment is the straight polyline segment, which is always safe. The control
points are then checked (the certificate) and so is every time sample (each in the bubble of its
segment, :data:`SAFETY_TOL`); a segment that fails either falls back to a straight line (the tangent
and curvature at both its ends set to zero) and the check is repeated.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb

import numpy as np

from foam_mj.rosary import MEMBERSHIP_TOL, Rosary, in_ball

#: Slack (configuration units) allowed when checking that a sample or control point lies in its bubble.
#: Far below the bubbles' safety margin (delta = 5 mm of workspace clearance).
SAFETY_TOL = 1e-9
#: Segments of a path at most this long (configuration units) are dropped from the curve: a start and goal this
#: close have nothing to move, and every planner refuses them as equal (:func:`coincide`).
MIN_SEGMENT = 1e-12
#: Fraction of the feasible tangent/curvature scale used, leaving room inside the ball.
GAMMA = 0.9
#: Tangent-direction blends tried at each waypoint (0 = the spline's own direction).
_BLENDS = np.linspace(0.0, 1.0, 11)
_DEGREE = 5
# Bernstein -> power basis: p(s) = sum_j s^j (M @ P)_j.
_BERNSTEIN = np.array(
    [[comb(_DEGREE, j) * comb(j, k) * (-1) ** (j - k) if k <= j else 0 for k in range(_DEGREE + 1)] for j in range(_DEGREE + 1)],
    dtype=float,
)


class TrajectoryError(RuntimeError):
    """The trajectory could not be made safe or within limits (a bug: the polyline fallback is always safe)."""


# -- the safe curve ----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SafeCurve:
    """A C2 piecewise-quintic curve q(u) through the path points, u the chord length.

    Segment j is a quintic Bézier curve whose control points lie in ball (centers[j], radii[j]); the
    ball is rosary bubble ``bubble[j]``. ``linear[j]`` marks segments that fell back to a straight line.
    """

    knots: np.ndarray  # (S+1,) u at the path points (zero-length steps removed)
    control_points: np.ndarray  # (S, 6, n)
    centers: np.ndarray  # (S, n)
    radii: np.ndarray  # (S,)
    bubble: np.ndarray  # (S,) rosary index of each segment's bubble
    point_index: np.ndarray  # (S+1,) index into the input path of each knot
    linear: np.ndarray  # (S,) bool

    @property
    def length(self) -> float:
        """The chord length L of the path (configuration units)."""
        return float(self.knots[-1])

    @property
    def coefficients(self) -> np.ndarray:
        """Power-basis coefficients in the local parameter s in [0, 1]: (S, 6, n)."""
        return np.einsum("jk,skn->sjn", _BERNSTEIN, self.control_points)

    def segment_of(self, u: np.ndarray) -> np.ndarray:
        """Segment index of every parameter value (the knot at a segment's start belongs to it)."""
        seg = np.searchsorted(self.knots, np.asarray(u, dtype=float), side="right") - 1
        return np.clip(seg, 0, len(self.radii) - 1)

    def evaluate(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, dq/du and d2q/du2 at parameter values u (N,): three arrays (N, n)."""
        u = np.clip(np.asarray(u, dtype=float), 0.0, self.length)
        seg = self.segment_of(u)
        h = np.diff(self.knots)[seg]
        s = (u - self.knots[seg]) / h
        a = self.coefficients[seg]  # (N, 6, n)
        j = np.arange(_DEGREE + 1)
        pw = s[:, None] ** j  # (N, 6)
        pw1 = np.zeros_like(pw)
        pw1[:, 1:] = j[1:] * pw[:, :-1]
        pw2 = np.zeros_like(pw)
        pw2[:, 2:] = j[2:] * (j[2:] - 1) * pw[:, :-2]
        q = np.einsum("nj,njd->nd", pw, a)
        dq = np.einsum("nj,njd->nd", pw1, a) / h[:, None]
        ddq = np.einsum("nj,njd->nd", pw2, a) / (h * h)[:, None]
        return q, dq, ddq


def _ray_exit(p: np.ndarray, d: np.ndarray, c: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Distance from p (inside ball (c, r)) along unit direction d to the sphere; rows broadcast. >= 0."""
    w = p - c
    b = np.einsum("...i,...i->...", d, w)
    cc = np.einsum("...i,...i->...", w, w) - r * r
    return np.maximum(-b + np.sqrt(np.maximum(b * b - cc, 0.0)), 0.0)


def _box_exit(p: np.ndarray, d: np.ndarray, lower: np.ndarray | None, upper: np.ndarray | None) -> np.ndarray:
    """Distance from p (inside the box [lower, upper]) along direction d to the box's boundary; rows broadcast. >= 0;
    infinite without bounds."""
    if lower is None or upper is None:
        return np.full(np.shape(p)[:-1], np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        step = np.where(d > 0, (upper - p) / d, np.where(d < 0, (lower - p) / d, np.inf))
    return np.maximum(np.min(step, axis=-1), 0.0)


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 1e-15, v / np.where(n > 1e-15, n, 1.0), 0.0)


def _fit_derivatives(w, h, c_in, r_in, c_out, r_out, has_in, has_out, t0, k0, lower=None, upper=None):
    """Scaled tangents and curvatures at the knots so that P1..P4 lie in the neighbouring balls and, given the joint
    bounds, in the box (an in-box ball's exits come first, so the box only binds in an end ball that leaves it)."""
    m = len(w)
    big = np.inf
    h_in = np.concatenate([[0.0], h])  # length of the incoming segment of each knot
    h_out = np.concatenate([h, [0.0]])
    tn = np.linalg.norm(t0, axis=1)
    t_hat = _unit(t0)
    # Directions that enter the outgoing ball forwards and the incoming ball backwards.
    nu_out = np.where(has_out[:, None], _unit(c_out - w), 0.0)
    nu_in = np.where(has_in[:, None], _unit(w - c_in), 0.0)
    safe = _unit(nu_in + nu_out)

    def alpha_max(d: np.ndarray) -> np.ndarray:
        """Largest tangent scale keeping w + 2 h t / 5 (outgoing) and w - 2 h t / 5 (incoming) in their balls."""
        reach_out = 0.4 * h_out * tn
        reach_in = 0.4 * h_in * tn
        exit_out = np.minimum(_ray_exit(w, d, c_out, r_out), _box_exit(w, d, lower, upper))
        exit_in = np.minimum(_ray_exit(w, -d, c_in, r_in), _box_exit(w, -d, lower, upper))
        with np.errstate(divide="ignore", invalid="ignore"):
            a_out = np.where(has_out & (reach_out > 0), exit_out / reach_out, big)
            a_in = np.where(has_in & (reach_in > 0), exit_in / reach_in, big)
        return np.minimum(a_out, a_in)

    best_score = np.full(m, -1.0)
    best_d = t_hat.copy()
    best_alpha = np.zeros(m)
    for lam in _BLENDS:
        d = _unit((1.0 - lam) * t_hat + lam * safe)
        alpha = np.minimum(1.0, GAMMA * alpha_max(d))
        score = alpha * np.maximum(np.einsum("ij,ij->i", d, t_hat), 0.0)
        better = score > best_score + 1e-12
        best_score = np.where(better, score, best_score)
        best_d[better] = d[better]
        best_alpha = np.where(better, alpha, best_alpha)
    t = best_d * (best_alpha * tn)[:, None]

    # Curvature: P2 = w + 0.4 h_out t + h_out^2 kappa / 20 in the outgoing ball, P3 likewise in the incoming.
    kn = np.linalg.norm(k0, axis=1)
    k_hat = _unit(k0)
    p_out, p_in = w + 0.4 * h_out[:, None] * t, w - 0.4 * h_in[:, None] * t
    exit_out = np.minimum(_ray_exit(p_out, k_hat, c_out, r_out), _box_exit(p_out, k_hat, lower, upper))
    exit_in = np.minimum(_ray_exit(p_in, k_hat, c_in, r_in), _box_exit(p_in, k_hat, lower, upper))
    with np.errstate(divide="ignore", invalid="ignore"):
        reach = h_out**2 * kn / 20.0
        b_out = np.where(has_out & (reach > 0), exit_out / reach, big)
        reach = h_in**2 * kn / 20.0
        b_in = np.where(has_in & (reach > 0), exit_in / reach, big)
    beta = np.minimum(1.0, GAMMA * np.minimum(b_out, b_in))
    return t, k0 * beta[:, None]


def _control_points(w: np.ndarray, h: np.ndarray, t: np.ndarray, k: np.ndarray) -> np.ndarray:
    a, b = w[:-1], w[1:]
    hh = h[:, None]
    return np.stack(
        [
            a,
            a + hh * t[:-1] / 5,
            a + 2 * hh * t[:-1] / 5 + hh**2 * k[:-1] / 20,
            b - 2 * hh * t[1:] / 5 + hh**2 * k[1:] / 20,
            b - hh * t[1:] / 5,
            b,
        ],
        axis=1,
    )


def validate_path(path, rosary: Rosary, tol: float = MEMBERSHIP_TOL) -> np.ndarray:
    """Return ``path`` as a float array (k+1, n), or raise ValueError saying which point is not where it
    must be: path[0] in the first bubble, path[i] in hatch i-1 (bubbles i-1 and i), path[k] in the last."""
    if not isinstance(rosary, Rosary):
        raise ValueError(f"`rosary` must be a Rosary, got {type(rosary).__name__}")
    try:
        p = np.asarray(path, dtype=float)
    except (TypeError, ValueError):
        raise ValueError("`path` must be an array of configurations (k+1, n)") from None
    k, n = rosary.k, rosary.dim
    if p.shape != (k + 1, n):
        raise ValueError(f"`path` must have shape ({k + 1}, {n}) for a rosary of {k} bubbles, got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("`path` must be finite")
    c, r = rosary.centers, rosary.radii
    if not in_ball(p[0], c[0], r[0], tol):
        raise ValueError("`path[0]` (the start) is not in the rosary's first bubble")
    if not in_ball(p[-1], c[-1], r[-1], tol):
        raise ValueError(f"`path[{k}]` (the goal) is not in the rosary's last bubble")
    bad = np.flatnonzero(~rosary.in_hatches(p[1:-1], tol))
    if bad.size:
        raise ValueError(f"`path[{bad[0] + 1}]` is not in hatch {bad[0]} (bubbles {bad[0]} and {bad[0] + 1} of the rosary)")
    return p


def coincide(a, b) -> bool:
    """True when configurations ``a`` and ``b`` (of one shape) are at most :data:`MIN_SEGMENT` apart: no curve moves
    between them."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and bool(np.linalg.norm(b - a) <= MIN_SEGMENT)


def apart_text(a, b) -> str:
    """For a refusal of coinciding end points: "" when ``a`` equals ``b``, else how far apart they are."""
    d = float(np.linalg.norm(np.asarray(b, dtype=float) - np.asarray(a, dtype=float)))
    return "" if d == 0 else f" to within {MIN_SEGMENT:g} ({d:.3g} apart: less than any path moves)"


def in_box(points: np.ndarray, lower: np.ndarray | None, upper: np.ndarray | None, tol: float = SAFETY_TOL) -> np.ndarray:
    """Are ``points`` (..., n) within the joint bounds (to ``tol``)? All are when no bounds are given."""
    if lower is None or upper is None:
        return np.ones(np.shape(points)[:-1], dtype=bool)
    return np.all((points >= lower - tol) & (points <= upper + tol), axis=-1)


def safe_curve(path, rosary: Rosary, lower: np.ndarray | None = None, upper: np.ndarray | None = None) -> SafeCurve:
    """The C2 curve through ``path`` (k+1, n) that stays in ``rosary`` by construction (module docstring) and, given
    the joint bounds ``lower`` and ``upper``, in them too: an end bubble about a point on an edge or corner of the joint
    box leaves the box (:meth:`foam_mj.bubbles.BubbleOracle.holding_bubble`), so a segment in it could bulge out past a
    joint limit while its control points stayed in the ball. The box is convex too: the tangents and curvatures are
    scaled to keep the control points in it as in the balls, and the check holds them to it (else the segment is
    straight: its ends are in the box)."""
    p = validate_path(path, rosary)
    seg_len = np.linalg.norm(np.diff(p, axis=0), axis=1)
    keep_seg = seg_len > MIN_SEGMENT
    if not keep_seg.any():
        raise ValueError("`path` has zero length (start and goal coincide): there is nothing to move")
    point_index = np.concatenate([[0], 1 + np.flatnonzero(keep_seg)])
    w = p[point_index]
    bubble = np.flatnonzero(keep_seg)
    c, r = rosary.centers[bubble], rosary.radii[bubble]
    h = seg_len[keep_seg]
    knots = np.concatenate([[0.0], np.cumsum(h)])
    m = len(w)
    if m == 2:
        t0 = np.repeat((w[1:] - w[:1]) / h[0], 2, axis=0)
        k0 = np.zeros_like(w)
    else:
        t0, k0 = _natural_spline_derivatives(knots, w)
    c_in = np.concatenate([c[:1], c])
    r_in = np.concatenate([r[:1], r])
    c_out = np.concatenate([c, c[-1:]])
    r_out = np.concatenate([r, r[-1:]])
    has_in = np.arange(m) > 0
    has_out = np.arange(m) < m - 1
    t, k = _fit_derivatives(w, h, c_in, r_in, c_out, r_out, has_in, has_out, t0, k0, lower, upper)
    linear = np.zeros(m - 1, dtype=bool)
    for _ in range(m):
        cp = _control_points(w, h, t, k)
        ok = (in_ball(cp, c[:, None, :], r[:, None], SAFETY_TOL) & in_box(cp, lower, upper)).all(axis=1)
        if ok.all():
            return SafeCurve(knots, cp, c, r, bubble, point_index, linear)
        bad = np.flatnonzero(~ok)
        linear[bad] = True
        for j in bad:
            t[j] = t[j + 1] = 0.0
            k[j] = k[j + 1] = 0.0
    raise TrajectoryError("the control points left their bubbles even as a polyline")  # pragma: no cover


def _with_linear(curve: SafeCurve, segments: np.ndarray) -> SafeCurve:
    """The curve with the given segments (and so their end derivatives) made straight."""
    cp = curve.control_points.copy()
    linear = curve.linear.copy()
    for j in segments:
        linear[j] = True
        a, b = cp[j, 0], cp[j, 5]
        cp[j, 1:3] = a  # zero tangent and curvature at both ends -> straight, stopping at the knots
        cp[j, 3:5] = b
        if j > 0:
            cp[j - 1, 3:5] = a
        if j + 1 < len(cp):
            cp[j + 1, 1:3] = b
    return SafeCurve(curve.knots, cp, curve.centers, curve.radii, curve.bubble, curve.point_index, linear)


def _natural_spline_derivatives(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and second derivatives at the knots ``x`` (m >= 3) of the natural C2 cubic spline through ``y``
    (m, n): the slopes s solve the tridiagonal system h_i s_(i-1) + 2 (h_(i-1) + h_i) s_i + h_(i-1) s_(i+1)
    = 3 (h_i m_(i-1) + h_(i-1) m_i) (m_i the chord slopes; rows 0 and m-1 encode zero curvature), then the
    Hermite cubic of each interval is differentiated at its left end (at the right end for the last knot).

    The same operations, in the same order, as ``scipy.interpolate.CubicSpline(x, y, bc_type="natural")``
    evaluated with ``(x, 1)`` and ``(x, 2)`` (LAPACK's banded solve included), so the numbers are bit for bit
    those of scipy (tests/test_trajectory.py checks it) without the cost of importing scipy.interpolate.
    """
    from scipy.linalg import solve_banded  # already loaded with scipy.spatial (the planners' k-d trees)

    m = len(x)
    dx = np.diff(x)
    dxr = dx[:, None]
    slope = np.diff(y, axis=0) / dxr
    A = np.zeros((3, m))  # banded storage: superdiagonal, diagonal, subdiagonal
    A[1, 1:-1] = 2 * (dx[:-1] + dx[1:])
    A[0, 2:] = dx[:-1]
    A[-1, :-2] = dx[1:]
    A[1, 0], A[0, 1] = 2 * dx[0], dx[0]
    A[1, -1], A[-1, -2] = 2 * dx[-1], dx[-1]
    b = np.empty_like(y, dtype=float)
    b[1:-1] = 3 * (dxr[1:] * slope[:-1] + dxr[:-1] * slope[1:])
    b[0] = 3 * (y[1] - y[0])
    b[-1] = 0.0 + 3 * (y[-1] - y[-2])  # 0.0 + as scipy (its zero end curvature term): no -0.0
    s = solve_banded((1, 1), A, b, overwrite_ab=True, overwrite_b=True, check_finite=False)
    t = (s[:-1] + s[1:] - 2 * slope) / dxr
    c0, c1, c2 = t / dxr, (slope - s[:-1]) / dxr - t, s[:-1]  # p(z) = c0 z^3 + c1 z^2 + c2 z + y_i
    i = np.minimum(np.arange(m), m - 2)
    z = np.zeros((m, 1))
    z[-1] = x[-1] - x[-2]
    d1 = 0.0 + c2[i] + c1[i] * z * 2.0 + c0[i] * (z * z) * 3.0
    d2 = 0.0 + c1[i] * 2.0 + c0[i] * z * 6.0
    return d1, d2
