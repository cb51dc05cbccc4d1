"""Joint trajectories: a safe configuration-space path turned into a timed motion for the MuJoCo model.

Geometry: the C2 curve through the waypoints that stays in the rosary by construction is :mod:`foam_mj.safe_curve`.

Timing: a smooth time law under joint limits
--------------------------------------------
The curve is traversed with a weight w(u) > 0 (seconds per unit of u) and its integral S(u): the time
law is S(u(t)) = S(L) sigma(t / T) with sigma(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5, the minimum-jerk
profile (Flash and Hogan 1985). Hence du/dt = dS/dt / w(u): rest to rest with zero acceleration at both
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

import mujoco
import numpy as np

from foam_mj.errors import ModelError
from foam_mj.mjcf import _custom_numeric
from foam_mj.model import RobotModel, require_robot_model
from foam_mj.rosary import Rosary, in_ball
from foam_mj.safe_curve import SAFETY_TOL, SafeCurve, TrajectoryError, _with_linear, in_box, safe_curve, validate_path

#: Largest distance (configuration units) between the straight line joining two consecutive samples (one
#: timestep apart) and the certified curve between them: a consumer that interpolates the rows linearly
#: (a checker, a controller) stays this close to the curve. The same step as ``foam-mj verify``'s default.
ROW_TOL = 1e-3
#: Points per segment of the dense grid used to find the peak velocities and accelerations.
_DENSE_PER_SEGMENT = 200
#: Width (configuration units of path length) over which the speed profile looks ahead (see _time_law).
SPEED_WINDOW = 0.2
#: Width (configuration units) over which the reweighting rounds smooth the weight, and their number.
REWEIGHT_WINDOW = 0.2
_REWEIGHTS = 12
#: Bounds on the number of cells of the time law's grid in u.
_GRID_MIN, _GRID_MAX = 4000, 200_000


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
                    raise ModelError(f"{robot.path}: '{LIMITS_PREFIX + name}' must hold 2 numbers > 0 (velocity acceleration), "
                                     f"got {declared.tolist()}")
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


# -- numerical helpers (numpy; the same numbers as scipy's, without importing scipy.interpolate/ndimage) --------
_WIDE_WINDOW = 1 << 20


def _edge_padded(x: np.ndarray, size: int) -> np.ndarray:
    """``x`` extended by its end values for a centred window of ``size`` (odd) samples."""
    r = size // 2
    return np.concatenate([np.full(r, x[0]), x, np.full(size - 1 - r, x[-1])])


def _max_filter(x: np.ndarray, size: int) -> np.ndarray:
    """Running maximum over a centred window of ``size`` (odd) samples, ends extended by their values
    (``scipy.ndimage.maximum_filter1d(x, size, mode="nearest")``): the block prefix/suffix maxima of van Herk 1992, O(len)."""
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


#: :meth:`TimeLaw.at_tau` works on the weight scaled by a power of two when its largest value is outside
#: [2**-_WEIGHT_EXP, 2**_WEIGHT_EXP] s per unit of u (a velocity limit of 1e-300 gave 1e300: its cube overflowed).
_WEIGHT_EXP = 64


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
        law = self
        k = int(np.frexp(self.weight.max())[1])
        if abs(k) > _WEIGHT_EXP:  # w0 * w0, sd * sd and w**3 below would overflow (or underflow): scale the weight
            law = TimeLaw(self.grid, np.ldexp(self.weight, -k), T)  # by 2**-k (exact): u, du/dt, d2u/dt2 are unchanged
        S = law.cumulative
        sig, dsig, ddsig = _min_jerk(tau)
        target = S[-1] * sig
        cell = np.clip(np.searchsorted(S, target, side="right") - 1, 0, len(S) - 2)
        du = np.diff(self.grid)[cell]
        w0 = law.weight[cell]
        g = (law.weight[cell + 1] - w0) / du  # w' in the cell
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


#: The most timesteps one timed trajectory may have: 2,000,000 (4,000 s at MuJoCo's default 2 ms; its samples are a few
#: hundred MB). Limits asking for a longer motion were internal errors: [limits] velocity = 1e-6 a MemoryError,
#: 1e-300 an OverflowError (an infinite duration).
MAX_STEPS = 2_000_000


def check_trajectory(robot: RobotModel, trajectory: Trajectory) -> None:
    """ValueError naming the argument unless ``trajectory`` is a :class:`Trajectory` of ``robot``'s configuration joints and
    qpos width (what the replays and the joint loads read it with)."""
    require_robot_model(robot)
    if not isinstance(trajectory, Trajectory):
        raise ValueError(f"`trajectory` must be a Trajectory, got {type(trajectory).__name__}")
    if tuple(trajectory.joint_names) != tuple(robot.config.joint_names):
        raise ValueError(
            f"`trajectory.joint_names` {list(trajectory.joint_names)} do not match the robot's configuration "
            f"joints {list(robot.config.joint_names)}"
        )
    if trajectory.qpos.shape[1] != robot.model.nq:
        raise ValueError(f"`trajectory.qpos` has {trajectory.qpos.shape[1]} columns, the model has nq = {robot.model.nq}")


class TrajectoryTooLong(ValueError):
    """A timing needs more than :data:`MAX_STEPS` timesteps; ``duration`` in seconds (may be inf)."""

    def __init__(self, duration: float, dt: float) -> None:
        super().__init__(f"its timing under these limits lasts {duration:.3g} s, {duration / dt:,.3g} timesteps of {dt:g} s: "
                         f"more than the {MAX_STEPS:,} a trajectory may have")
        self.duration = duration


def whole_steps(duration: float, dt: float) -> int:
    """The timesteps of a motion of ``duration`` (rounded up, at least 1); :class:`TrajectoryTooLong` past MAX_STEPS."""
    if not duration / dt <= MAX_STEPS:  # inf and NaN too
        raise TrajectoryTooLong(duration, dt)
    return max(1, int(np.ceil(duration / dt - 1e-9)))


def _check_within_bounds(robot: RobotModel, path: np.ndarray, tol: float = 1e-6) -> None:
    """ValueError naming the first point of ``path`` beyond ``robot``'s joint bounds: every planned path keeps to them, so
    such a path was planned for another robot (the curve's check then failed with "the control points left their
    bubbles even as a polyline", which pointed at the library)."""
    span = np.maximum(robot.upper - robot.lower, 1.0)
    out = (path < robot.lower - tol * span) | (path > robot.upper + tol * span)
    if out.any():
        i, j = (int(v) for v in np.argwhere(out)[0])
        raise ValueError(f"`path[{i}]` has {robot.config.joint_names[j]} = {path[i, j]:.6g}, outside `robot`'s joint bounds "
                         f"[{robot.lower[j]:.6g}, {robot.upper[j]:.6g}] ({robot.path.name}): every planned path keeps to them; was "
                         "it planned for another robot?")


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
    require_robot_model(robot)
    limits = JointLimits() if limits is None else limits
    if not isinstance(limits, JointLimits):
        raise ValueError(f"`limits` must be a JointLimits, got {type(limits).__name__}")
    dt = float(robot.model.opt.timestep) if dt is None else dt
    if not (isinstance(dt, (int, float, np.floating)) and np.isfinite(dt) and dt > 0):
        raise ValueError(f"`dt` must be a finite number of seconds > 0, got {dt!r}")
    if isinstance(rosary, Rosary) and rosary.dim != robot.dim:
        raise ValueError(f"`rosary` has dimension {rosary.dim}, the robot's configuration has {robot.dim}")
    _check_within_bounds(robot, validate_path(path, rosary))
    curve = safe_curve(path, rosary, robot.lower, robot.upper)
    vmax, amax = limits.resolve(robot)
    amax = np.minimum(amax, row_acceleration_cap(robot, dt))  # rows dense enough to interpolate
    scale = robot.config.scale  # joint units per configuration unit

    for _ in range(len(curve.radii) + 1):
        # The duration at which the peaks (dense grid) meet the limits: velocities scale as 1/T,
        # accelerations as 1/T^2.
        law, duration = _time_law(curve, scale, vmax, amax)
        duration = max(duration, dt)
        for _ in range(20):  # round up to whole timesteps; check the limits on the samples themselves
            steps = whole_steps(duration, dt)
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
        inside = in_ball(q, curve.centers[seg], curve.radii[seg], SAFETY_TOL) & in_box(q, robot.lower, robot.upper)
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
