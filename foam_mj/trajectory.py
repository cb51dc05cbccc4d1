"""Joint trajectories: a safe configuration-space path turned into a timed motion for the MuJoCo model.

Geometry: a C2 curve that stays in the rosary by construction
----------------------------------------------------------------
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

Timing: a smooth time law under joint limits
--------------------------------------------
The curve is traversed with a weight w(u) > 0 (seconds per unit of u) and its integral S(u): the time
law is S(u(t)) = S(L) sigma(t / T) with sigma(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5, the minimum-jerk
profile (Flash & Hogan 1985). Hence du/dt = dS/dt / w(u): rest to rest with zero acceleration at both
ends, and slow where w is large. w starts as the time per unit of u at the velocity limits or with half
the acceleration budget spent on the curve's bending (joint units), dilated and smoothed so the motion
slows before a tight turn; a few rounds then lower w where the limits are not used, which about halves
the duration (:func:`_time_law`). w is piecewise linear on a fine grid, so u(t) and its two derivatives
are exact (a quadratic solve per sample), and the curve is C2, so joint accelerations are continuous.

For a fixed w the joint velocities scale as 1/T and the accelerations as 1/T^2, so the shortest duration
meeting the limits is T = max_j max(V_j / v_j, sqrt(A_j / a_j)) (V_j, A_j the peaks at T = 1, on a dense
grid). T is rounded up to a whole number of timesteps and the limits are checked again on the samples.

Default limits (joint units; :class:`JointLimits`): 5 rad/s and 50 rad/s^2 for the hinges, 1.5 m/s and
10 m/s^2 for the hip slide. A walking swing reaches about 6-7 rad/s at the knee and 3-4 rad/s at the hip
(Winter 2009); an assisting orthosis moves more slowly. With these limits the obstacle scene (seed 0)
gives a 1.2 s swing along the shortest path through the hatches, 2.0 s along the portal path and
2.7 s along the zig-zagging centre path, where the slide's acceleration in the turns is the limit:
smoothing the path buys speed.

Replay notes: the Ortholeg's position servos (``models/ortholeg.xml``, classes ``hinge_servo`` and
``slide_servo``) track these trajectories; see :mod:`foam_mj.replay` for the gains and the error figures.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from math import comb

import mujoco
import numpy as np

from foam_mj.model import RobotModel, _custom_numeric
from foam_mj.rosary import MEMBERSHIP_TOL, Rosary, in_ball

#: Slack (configuration units) allowed when checking that a sample or control point lies in its bubble.
#: Far below the bubbles' safety margin (delta = 5 mm of workspace clearance).
SAFETY_TOL = 1e-9
#: Largest distance (configuration units) between the straight line joining two consecutive samples (one
#: timestep apart) and the certified curve between them: a consumer that interpolates the rows linearly
#: (a checker, a controller) stays this close to the curve. The same step as ``foam-mj verify``'s default.
ROW_TOL = 1e-3
#: Fraction of the feasible tangent/curvature scale used, leaving room inside the ball.
GAMMA = 0.9
#: Tangent-direction blends tried at each waypoint (0 = the spline's own direction).
_BLENDS = np.linspace(0.0, 1.0, 11)
#: Points per segment of the dense grid used to find the peak velocities and accelerations.
_DENSE_PER_SEGMENT = 200
#: Width (configuration units of path length) over which the speed profile looks ahead (see _time_law).
SPEED_WINDOW = 0.2
#: Width (configuration units) over which the reweighting rounds smooth the weight, and their number.
REWEIGHT_WINDOW = 0.2
_REWEIGHTS = 12
#: Bounds on the number of cells of the time law's grid in u.
_GRID_MIN, _GRID_MAX = 4000, 200_000
_DEGREE = 5
# Bernstein -> power basis: p(s) = sum_j s^j (M @ P)_j.
_BERNSTEIN = np.array(
    [[comb(_DEGREE, j) * comb(j, k) * (-1) ** (j - k) if k <= j else 0 for k in range(_DEGREE + 1)] for j in range(_DEGREE + 1)],
    dtype=float,
)


class TrajectoryError(RuntimeError):
    """The trajectory could not be made safe or within limits (a bug: the polyline fallback is always safe)."""


# -- limits ----------------------------------------------------------------------------------------------
#: MJCF custom numeric holding a joint's "velocity acceleration" limits (joint units).
LIMITS_PREFIX = "foam_mj:limits:"


@dataclass(frozen=True)
class JointLimits:
    """Velocity and acceleration limits in joint units: rad/s and rad/s^2 for hinges, m/s and m/s^2 for
    slides. ``per_joint`` overrides them for named joints: ``{"knee_flexion": (4.0, 30.0)}``. Next come
    the model's own limits, a custom numeric ``foam_mj:limits:<joint>`` = "velocity acceleration" in the
    MJCF (the CloudWalker declares walking speeds there); the defaults below apply to the other joints."""

    hinge_velocity: float = 5.0
    hinge_acceleration: float = 50.0
    slide_velocity: float = 1.5
    slide_acceleration: float = 10.0
    per_joint: dict[str, tuple[float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("hinge_velocity", "hinge_acceleration", "slide_velocity", "slide_acceleration"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.floating, np.integer)) and np.isfinite(v) and v > 0):
                raise ValueError(f"`{name}` must be a finite number > 0, got {v!r}")
        for joint, pair in dict(self.per_joint).items():
            try:
                vel, acc = (float(x) for x in pair)
            except (TypeError, ValueError):
                raise ValueError(f"`per_joint[{joint!r}]` must be a pair (velocity, acceleration), got {pair!r}") from None
            if not (np.isfinite(vel) and vel > 0 and np.isfinite(acc) and acc > 0):
                raise ValueError(f"`per_joint[{joint!r}]` limits must be finite and > 0, got {pair!r}")

    def resolve(self, robot: RobotModel) -> tuple[np.ndarray, np.ndarray]:
        """(velocity (n,), acceleration (n,)) for the robot's configuration joints, in joint units."""
        names = robot.config.joint_names
        unknown = sorted(set(self.per_joint) - set(names))
        if unknown:
            raise ValueError(f"`per_joint` names unknown joints {unknown}; configuration joints: {list(names)}")
        vel, acc = [], []
        for name, j in zip(names, robot.config.joint_ids):
            declared = _custom_numeric(robot.model, LIMITS_PREFIX + name)
            if name in self.per_joint:
                v, a = (float(x) for x in self.per_joint[name])
            elif declared is not None:
                if declared.size != 2 or not np.all(np.isfinite(declared) & (declared > 0)):
                    raise ValueError(f"{robot.path}: '{LIMITS_PREFIX + name}' must hold 2 numbers > 0 (velocity acceleration)")
                v, a = float(declared[0]), float(declared[1])
            elif int(robot.model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_SLIDE):
                v, a = self.slide_velocity, self.slide_acceleration
            else:
                v, a = self.hinge_velocity, self.hinge_acceleration
            vel.append(v)
            acc.append(a)
        return np.array(vel), np.array(acc)


def row_acceleration_cap(robot: RobotModel, dt: float) -> np.ndarray:
    """(n,) the joint accelerations (joint units) that keep each chord between samples ``dt`` apart within
    :data:`ROW_TOL` of the curve: a C1 motion with |d2q_j/dt2| <= a_j leaves its chord over one step by at
    most a_j dt^2 / 8 per coordinate, so a_j = 8 ROW_TOL / (sqrt(n) dt^2) in configuration units. Far above
    the default limits at a 2 ms timestep (1,155 rad/s^2 for 3 joints); it binds only for very high limits,
    which would otherwise leap from q_init to q_goal in one step, or a coarse timestep."""
    n = robot.dim
    return 8.0 * ROW_TOL / (np.sqrt(n) * dt * dt) * np.abs(robot.config.scale)


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


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 1e-15, v / np.where(n > 1e-15, n, 1.0), 0.0)


def _fit_derivatives(w, h, c_in, r_in, c_out, r_out, has_in, has_out, t0, k0):
    """Scaled tangents and curvatures at the knots so that P1..P4 lie in the neighbouring balls."""
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
        with np.errstate(divide="ignore", invalid="ignore"):
            a_out = np.where(has_out & (reach_out > 0), _ray_exit(w, d, c_out, r_out) / reach_out, big)
            a_in = np.where(has_in & (reach_in > 0), _ray_exit(w, -d, c_in, r_in) / reach_in, big)
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
    with np.errstate(divide="ignore", invalid="ignore"):
        reach = h_out**2 * kn / 20.0
        b_out = np.where(has_out & (reach > 0), _ray_exit(w + 0.4 * h_out[:, None] * t, k_hat, c_out, r_out) / reach, big)
        reach = h_in**2 * kn / 20.0
        b_in = np.where(has_in & (reach > 0), _ray_exit(w - 0.4 * h_in[:, None] * t, k_hat, c_in, r_in) / reach, big)
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


def safe_curve(path, rosary: Rosary) -> SafeCurve:
    """The C2 curve through ``path`` (k+1, n) that stays in ``rosary`` by construction (module docstring)."""
    p = validate_path(path, rosary)
    seg_len = np.linalg.norm(np.diff(p, axis=0), axis=1)
    keep_seg = seg_len > 1e-12
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
    t, k = _fit_derivatives(w, h, c_in, r_in, c_out, r_out, has_in, has_out, t0, k0)
    linear = np.zeros(m - 1, dtype=bool)
    for _ in range(m):
        cp = _control_points(w, h, t, k)
        ok = in_ball(cp, c[:, None, :], r[:, None], SAFETY_TOL).all(axis=1)
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



# -- numerical helpers (numpy; the same numbers as scipy's, without importing scipy.interpolate/ndimage) --------
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


#: A running mean over a window wider than this (samples) and than twice the array is taken in closed form
#: (:func:`_mean_filter`); narrower ones keep scipy's running sum bit for bit.
_WIDE_WINDOW = 1 << 20


def _edge_padded(x: np.ndarray, size: int) -> np.ndarray:
    """``x`` extended by its end values for a centred window of ``size`` (odd) samples."""
    r = size // 2
    return np.concatenate([np.full(r, x[0]), x, np.full(size - 1 - r, x[-1])])


def _max_filter(x: np.ndarray, size: int) -> np.ndarray:
    """Running maximum over a centred window of ``size`` (odd) samples, ends extended by their values
    (``scipy.ndimage.maximum_filter1d(x, size, mode="nearest")``): van Herk's block prefix/suffix maxima, O(len)."""
    n = len(x)
    if size >= 2 * n - 1:  # every window holds the whole array (a path far shorter than the window): exact
        return np.full(n, x.max())
    p = _edge_padded(x, size)
    blocks = -(-len(p) // size)
    p = np.concatenate([p, np.full(blocks * size - len(p), p[-1])]).reshape(blocks, size)
    prefix = np.maximum.accumulate(p, axis=1).ravel()
    suffix = np.maximum.accumulate(p[:, ::-1], axis=1)[:, ::-1].ravel()
    return np.maximum(suffix[:n], prefix[size - 1:size - 1 + n])


def _mean_filter(x: np.ndarray, size: int) -> np.ndarray:
    """Running mean over a centred window of ``size`` (odd) samples, ends extended by their values: a running
    sum updated sample by sample and divided by ``size``, as ``scipy.ndimage.uniform_filter1d(x, size,
    mode="nearest")`` computes it (cumsum adds in order, so the numbers are bit for bit scipy's)."""
    n = len(x)
    if size > max(2 * n + 1, _WIDE_WINDOW):
        # Every window holds the whole array plus copies of its end values: the sums in closed form, without
        # materialising a padded array of `size` samples (a path of 1e-7 rad has windows of 1e9 samples).
        j = np.arange(n)
        r = size // 2
        return ((r - j) * x[0] + x.sum() + (size - r - n + j) * x[-1]) / size
    p = _edge_padded(x, size)
    steps = np.concatenate([np.cumsum(p[:size])[-1:], p[size:size + n - 1] - p[:n - 1]])
    return np.cumsum(steps) / size


# -- the time law ---------------------------------------------------------------------------------------------
def _min_jerk(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """sigma, dsigma/dtau, d2sigma/dtau2 of the minimum-jerk profile."""
    t2 = tau * tau
    return t2 * tau * (10 - 15 * tau + 6 * t2), 30 * t2 * (1 - tau) ** 2, 60 * tau * (1 - tau) * (1 - 2 * tau)


def _invert_min_jerk(s: np.ndarray) -> np.ndarray:
    """tau with sigma(tau) = s (sigma is strictly increasing on [0, 1]): bisection to machine precision."""
    lo, hi = np.zeros_like(s), np.ones_like(s)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        below = _min_jerk(mid)[0] < s
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class TimeLaw:
    """u(t) on [0, duration]: S(u(t)) = S(L) sigma(t / duration), with S(u) the integral of a positive,
    piecewise-linear weight w (seconds per unit of u at the limits, smoothed). Exact derivatives:
    du/dt = dS/dt / w(u), d2u/dt2 = d2S/dt2 / w - (dS/dt)^2 w' / w^3."""

    grid: np.ndarray  # (G,) u values
    weight: np.ndarray  # (G,) w > 0 at the grid values
    duration: float

    @property
    def cumulative(self) -> np.ndarray:
        """S at the grid values (exact integral of the piecewise-linear weight)."""
        return np.concatenate([[0.0], np.cumsum(0.5 * (self.weight[1:] + self.weight[:-1]) * np.diff(self.grid))])

    def at_tau(self, tau: np.ndarray, duration: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """u, du/dt, d2u/dt2 at normalized times tau in [0, 1] for a traversal of ``duration`` seconds."""
        T = self.duration if duration is None else duration
        tau = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
        S = self.cumulative
        sig, dsig, ddsig = _min_jerk(tau)
        target = S[-1] * sig
        cell = np.clip(np.searchsorted(S, target, side="right") - 1, 0, len(S) - 2)
        du = np.diff(self.grid)[cell]
        w0 = self.weight[cell]
        g = (self.weight[cell + 1] - w0) / du  # w' in the cell
        dS = np.maximum(target - S[cell], 0.0)
        delta = np.minimum(2 * dS / (w0 + np.sqrt(np.maximum(w0 * w0 + 2 * g * dS, 0.0))), du)
        u = self.grid[cell] + delta
        w = w0 + g * delta
        sd = S[-1] * dsig / T
        sdd = S[-1] * ddsig / T**2
        return u, sd / w, sdd / w - sd * sd * g / w**3


def _utilization(curve: SafeCurve, law: TimeLaw, tau: np.ndarray, scale, vmax, amax) -> tuple[np.ndarray, np.ndarray]:
    """Per time sample of a traversal lasting 1 s: the duration it alone would need to meet the limits,
    max_j max(|dq_j/dt| / v_j, sqrt(|d2q_j/dt2| / a_j)) (joint units); and the u of each sample."""
    _, qd, qdd, u = _motion(curve, law, tau, 1.0)
    need = np.maximum(np.abs(qd * scale) / vmax, np.sqrt(np.abs(qdd * scale) / amax)).max(axis=1)
    return need, u


def _time_law(curve: SafeCurve, scale: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> tuple[TimeLaw, float]:
    """The weight w(u) of the time law, and the duration it needs to meet the limits.

    Start: w = the larger of |dq_j/du| / v_j and sqrt(|d2q_j/du2| / (a_j / 2)) over the joints (joint
    units): the time per unit of u at the velocity limit, or with half the acceleration budget spent on
    curvature; dilated and smoothed over :data:`SPEED_WINDOW` so that the motion slows down before a tight
    turn, not in it. Then :data:`_REWEIGHTS` rounds of local rescaling: where a sample uses only a fraction
    eta of the limits the weight is multiplied by eta^0.7 (eta clipped to [0.3, 1], then smoothed), so
    slack parts speed up; the best round (shortest duration) is kept. Every round is a valid, smooth time
    law; the rounds only shorten it (about 2x on the obstacle scene's paths).
    """
    L = curve.length
    step = min(L / _GRID_MIN, float(np.diff(curve.knots).min()) / 8)
    G = int(np.clip(np.ceil(L / step), _GRID_MIN, _GRID_MAX)) + 1
    grid = np.linspace(0.0, L, G)
    du = L / (G - 1)
    _, qu, quu = curve.evaluate(grid)
    wv = np.max(np.abs(qu) * scale / vmax, axis=1)
    wa = np.max(np.sqrt(np.abs(quu) * scale / (0.5 * amax)), axis=1)
    w = np.maximum(wv, wa)
    half = max(1, int(round(0.5 * SPEED_WINDOW / du)))
    w = _max_filter(w, 4 * half + 1)
    for _ in range(2):
        w = _mean_filter(w, 2 * half + 1)
    floor = 1e-9 * max(float(w.max()), 1e-300)
    law = TimeLaw(grid, np.maximum(w, floor), 1.0)

    tau = np.linspace(0.0, 1.0, _DENSE_PER_SEGMENT * len(curve.radii) + 1)
    best, best_T = law, np.inf
    h2 = max(1, int(round(0.5 * REWEIGHT_WINDOW / du)))
    for _ in range(_REWEIGHTS + 1):
        need, u = _utilization(curve, law, tau, scale, vmax, amax)
        T = float(need.max())
        if T < best_T:
            best, best_T = law, T
        eta = np.interp(grid, u, need / T)
        eta = _max_filter(eta, 2 * h2 + 1)
        w = _mean_filter(law.weight * np.clip(eta, 0.3, 1.0) ** 0.7, 2 * h2 + 1)
        law = TimeLaw(grid, np.maximum(w, floor), 1.0)
    return best, best_T


def _motion(curve: SafeCurve, law: TimeLaw, tau: np.ndarray, duration: float):
    """q, dq/dt, d2q/dt2 (configuration units) at normalized times tau."""
    u, ud, udd = law.at_tau(tau, duration)
    q, qu, quu = curve.evaluate(u)
    return q, qu * ud[:, None], quu * (ud * ud)[:, None] + qu * udd[:, None], u


# -- the trajectory ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Trajectory:
    """Samples of a joint trajectory at a fixed timestep, from rest to rest.

    ``q`` is in the planner's configuration units; ``qpos``/``qvel``/``qacc`` are MuJoCo's (metres for the
    hip slide, radians for the hinges; qvel and qacc have nv columns, equal to nq for hinge/slide models).
    ``bubble[i]`` is the rosary bubble that sample i must lie in (the bubble of its path segment).
    """

    times: np.ndarray  # (T,) seconds, 0 .. duration, spacing dt
    q: np.ndarray  # (T, n)
    qpos: np.ndarray  # (T, nq)
    joint_names: tuple[str, ...]  # the configuration joints, in q's order
    qvel: np.ndarray | None = None  # (T, nv)
    qacc: np.ndarray | None = None  # (T, nv)
    bubble: np.ndarray | None = None  # (T,) rosary bubble of each sample
    waypoint_times: np.ndarray | None = None  # (k+1,) when the curve passes each path point
    qpos_index: np.ndarray | None = None  # (n,) qpos column of each configuration joint
    curve: SafeCurve | None = field(default=None, repr=False)
    time_law: TimeLaw | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        if t.ndim != 1 or len(t) < 2:
            raise ValueError(f"`times` must have shape (T,) with T >= 2, got {t.shape}")
        if not (np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)):
            raise ValueError("`times` must be finite and strictly increasing")
        n, T = len(self.joint_names), len(t)
        if n == 0:
            raise ValueError("`joint_names` must name the configuration joints")
        for name, cols in (("q", n), ("qpos", None), ("qvel", None), ("qacc", None)):
            a = getattr(self, name)
            if a is None:
                if name in ("q", "qpos"):
                    raise ValueError(f"`{name}` is required")
                continue
            a = np.asarray(a, dtype=float)
            if a.ndim != 2 or a.shape[0] != T or (cols is not None and a.shape[1] != cols):
                want = f"({T}, {cols})" if cols is not None else f"({T}, columns)"
                raise ValueError(f"`{name}` must have shape {want}, got {a.shape}")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"`{name}` must be finite")
            object.__setattr__(self, name, a)
        if self.bubble is not None and np.shape(self.bubble) != (T,):
            raise ValueError(f"`bubble` must have shape ({T},), got {np.shape(self.bubble)}")
        if self.qpos_index is not None:
            idx = np.asarray(self.qpos_index)
            if idx.shape != (n,) or not np.issubdtype(idx.dtype, np.integer) or idx.min() < 0 or idx.max() >= self.qpos.shape[1]:
                raise ValueError(f"`qpos_index` must be {n} integer columns of qpos, got {self.qpos_index!r}")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "joint_names", tuple(self.joint_names))

    @property
    def dt(self) -> float:
        return float(self.times[1] - self.times[0])

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    def __len__(self) -> int:
        return len(self.times)

    @property
    def joint_positions(self) -> np.ndarray:
        """(T, n) the configuration joints in joint units (qpos columns); q when ``qpos_index`` is unknown."""
        return self.q if self.qpos_index is None else self.qpos[:, self.qpos_index]

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, dq/dt, d2q/dt2 (configuration units) at any times in [0, duration], from the exact curve."""
        if self.curve is None or self.time_law is None:
            raise ValueError("this trajectory has no `curve`/`time_law` to evaluate (it was built from samples)")
        tau = np.atleast_1d(np.asarray(t, dtype=float) - self.times[0]) / self.duration
        return _motion(self.curve, self.time_law, tau, self.duration)[:3]


def make_trajectory(
    robot: RobotModel,
    path,
    rosary: Rosary,
    limits: JointLimits | None = None,
    dt: float | None = None,
) -> Trajectory:
    """A safe, C2, rest-to-rest joint trajectory along ``path`` (k+1, n), sampled every ``dt`` seconds
    (default: the model's timestep). Raises ValueError for bad inputs (naming the field) and
    :class:`TrajectoryError` if the result could not be verified (it always can: see the module docstring).
    """
    if not isinstance(robot, RobotModel):
        raise ValueError(f"`robot` must be a RobotModel, got {type(robot).__name__}")
    limits = JointLimits() if limits is None else limits
    if not isinstance(limits, JointLimits):
        raise ValueError(f"`limits` must be a JointLimits, got {type(limits).__name__}")
    dt = float(robot.model.opt.timestep) if dt is None else dt
    if not (isinstance(dt, (int, float, np.floating)) and np.isfinite(dt) and dt > 0):
        raise ValueError(f"`dt` must be a finite number of seconds > 0, got {dt!r}")
    curve = safe_curve(path, rosary)
    if rosary.dim != robot.dim:
        raise ValueError(f"`rosary` has dimension {rosary.dim}, the robot's configuration has {robot.dim}")
    vmax, amax = limits.resolve(robot)
    amax = np.minimum(amax, row_acceleration_cap(robot, dt))  # rows dense enough to interpolate
    scale = robot.config.scale  # joint units per configuration unit

    for _ in range(len(curve.radii) + 1):
        # The duration at which the peaks (dense grid) meet the limits: velocities scale as 1/T,
        # accelerations as 1/T^2.
        law, duration = _time_law(curve, scale, vmax, amax)
        duration = max(duration, dt)
        for _ in range(20):  # round up to whole timesteps; check the limits on the samples themselves
            steps = int(np.ceil(duration / dt - 1e-9))
            times = np.arange(steps + 1) * dt
            tau = times / times[-1]
            q, qd, qdd, u = _motion(curve, law, tau, times[-1])
            ratio = max(
                float(np.max(np.abs(qd * scale).max(axis=0) / vmax)),
                float(np.sqrt(np.max(np.abs(qdd * scale).max(axis=0) / amax))),
            )
            if ratio <= 1.0 + 1e-12:
                break
            duration = times[-1] * ratio * (1 + 1e-9)
        else:  # pragma: no cover
            raise TrajectoryError("could not meet the joint limits on the samples")
        q[0], q[-1] = curve.control_points[0, 0], curve.control_points[-1, 5]  # exact end points
        seg = curve.segment_of(u)
        inside = in_ball(q, curve.centers[seg], curve.radii[seg], SAFETY_TOL)
        if inside.all():
            break
        curve = _with_linear(curve, np.unique(seg[~inside]))
    else:  # pragma: no cover
        raise TrajectoryError("trajectory samples left the rosary even with straight segments")

    law = TimeLaw(law.grid, law.weight, float(times[-1]))
    cfg, m = robot.config, robot.model
    dof = m.jnt_dofadr[cfg.joint_ids]
    qvel = np.zeros((len(times), m.nv))
    qacc = np.zeros((len(times), m.nv))
    qvel[:, dof] = qd * scale
    qacc[:, dof] = qdd * scale
    qvel[[0, -1]] = 0.0  # rest to rest (exact: sigma' = sigma'' = 0 at both ends)
    qacc[[0, -1]] = 0.0
    # When each path point is passed: S(u_knot) = S(L) sigma(tau). A point dropped as a repeat of its
    # predecessor shares the predecessor's knot.
    S = law.cumulative
    knot_S = _S_at(law, curve.knots)
    knot_tau = _invert_min_jerk(knot_S / S[-1])
    knot_of_point = np.searchsorted(curve.point_index, np.arange(rosary.k + 1), side="right") - 1
    return Trajectory(
        times=times,
        q=q,
        qpos=cfg.to_qpos(q),
        joint_names=cfg.joint_names,
        qvel=qvel,
        qacc=qacc,
        bubble=curve.bubble[seg],
        waypoint_times=knot_tau[knot_of_point] * times[-1],
        qpos_index=cfg.qpos_index.copy(),
        curve=curve,
        time_law=law,
    )


def _S_at(law: TimeLaw, u: np.ndarray) -> np.ndarray:
    """S(u) exactly (the integral of the piecewise-linear weight up to u)."""
    S = law.cumulative
    cell = np.clip(np.searchsorted(law.grid, u, side="right") - 1, 0, len(S) - 2)
    d = u - law.grid[cell]
    g = (law.weight[cell + 1] - law.weight[cell]) / np.diff(law.grid)[cell]
    return S[cell] + law.weight[cell] * d + 0.5 * g * d * d
