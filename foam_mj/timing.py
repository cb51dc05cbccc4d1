"""Torque-limited time laws: the certified curve re-timed under joint velocity, acceleration and torque limits.

The geometry does not change
----------------------------
:func:`foam_mj.trajectory.make_trajectory` builds the safe curve q(u) (quintic Bézier segments whose
control points lie in their bubbles, so every point of the curve does) and a first, smooth time law
bounded by joint velocity and acceleration only. Here only u(t) changes: every sample is q(u(t)) on the
same curve, so it stays in the same bubbles (each sample is checked again against its bubble), and the
safety certificate carries over unchanged.

Limits (:class:`Limits`)
------------------------
Joint units: rad/s, rad/s^2, N m for hinges; m/s, m/s^2, N for slides, in configuration-joint order.
Velocity and acceleration default to :class:`~foam_mj.trajectory.JointLimits` (the MJCF's
``foam_mj:limits:<joint>`` or the hinge/slide defaults); torque to the MJCF's actuator force ranges
(:func:`foam_mj.dynamics.torque_limits`). Any of the three may be given as a list (scenario TOML
``[limits] velocity = [...], acceleration = [...], torque = [...]``, or ``Limits(torque=(...))``).

The torque model is MuJoCo's inverse dynamics, tau = M(q) qdd + c(q, qd) + g(q) + B qd (armature in M,
joint damping B from the MJCF). Along the curve, with s the path parameter, qd = q' sd and
qdd = q' sdd + q'' sd^2, so

    tau(s) = a(s) sdd + b(s) sd^2 + g(s) + B q'(s) sd + F,    a = M q',  b = M q'' + c(q, q'),

F the joint friction (MJCF ``frictionloss``), at most its frictionloss while the joint moves: toppra gets each
torque limit less the joint's frictionloss, and the samples are checked with the true ``mj_inverse``.

Two time laws (``method``)
--------------------------
* ``"toppra"`` (the default): time-optimal path parametrization by reachability analysis (Pham and Pham 2018,
  "A new approach to time-optimal path parameterization based on reachability analysis", IEEE T-RO 2018;
  the ``toppra`` package), on a grid of :data:`GRID_POINTS` path positions, with the velocity,
  acceleration and torque constraints above. toppra's constraints are linear in (sdd, sd^2), so the
  damping term (linear in sd) is left out of the constraint and accounted for afterwards: the samples'
  torques are recomputed with ``mj_inverse`` (damping included) and, where a joint exceeds its limit, that
  joint's limit given to toppra is lowered by the excess and the parametrization recomputed (at most
  :data:`REFINE_ROUNDS` rounds); the same rounds absorb the grid's discretization error. toppra's own
  output spline re-interpolates q and would change the geometry, so only its (s, sd, sdd) are used: s(t)
  is piecewise quadratic (constant sdd between grid points) and q(t) = q(s(t)) on the certified curve.
* ``"own"``: the smooth minimum-jerk time law of :mod:`foam_mj.trajectory`, stretched uniformly. For a
  fixed time law with speed factor x = T0 / T (T0 the duration meeting velocity and acceleration limits),
  tau(x) = g + x D + x^2 R at every sample (D the damping torque at T0, R the rest), so the largest x
  meeting |tau_j| <= L_j at every sample is the smallest positive root of R x^2 + D x + g -+ L = 0:
  exact, no search.

``benchmarks/timing.py`` compares them on the same curves (duration, peak torque use, smoothness).

Infeasible limits
-----------------
No timing can help where gravity alone (sd = 0) needs more than a joint's limit: :class:`TimingInfeasible`
names the joint, where along the path, and by how much. Where gravity fits but leaves so little margin
that the timing would last more than :data:`MAX_SLOWDOWN` times the same law's timing without torque
limits, the path is reported the same way (the joint with the least margin over gravity, and where)
rather than slowed to an absurd duration.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from foam_mj.dynamics import inverse_dynamics, joint_units
from foam_mj.errors import PlanningFailed
from foam_mj.limits import Limits, as_limits
from foam_mj.model import RobotModel
from foam_mj.path_kinematics import PathKinematics
from foam_mj.rosary import Rosary, in_ball
from foam_mj.safe_curve import SAFETY_TOL, SafeCurve, TrajectoryError, in_box
from foam_mj.toppra_import import import_toppra
from foam_mj.trajectory import JointLimits, Trajectory, TrajectoryTooLong, _motion, make_trajectory, row_acceleration_cap, whole_steps

#: Time laws accepted by :func:`retime` / :func:`timed_trajectory`.
METHODS = ("toppra", "own")
DEFAULT_METHOD = "toppra"
#: Path positions of toppra's grid (uniform in u, plus the knots).
GRID_POINTS = 800
#: A knot 0.7 % of a grid spacing from a uniform grid point (1.5e-5 apart on a 4-joint arm's convex path) made
#: toppra's seidel solver return NaN controllable sets there and no timing under velocity and acceleration limits
#: alone (the own time law timed it in 0.26 s): where toppra finds none, the uniform points closer than this share
#: of a spacing to a knot are dropped and it is asked once more (the grid is unchanged wherever toppra succeeds).
NEAR_KNOT = 0.05
#: Rounds of limit tightening after toppra (damping and discretization error, module docstring).
REFINE_ROUNDS = 8
#: Relative margins inside the velocity and acceleration (and torque) limits given to toppra, which meets
#: them at its grid points only; samples between grid points overshoot the acceleration by up to about 1 %
#: (measured on the shipped scenes); a sample still over its limit starts another round.
V_MARGIN, A_MARGIN = 2e-3, 1.2e-2
#: A torque limit a sample overshot is lowered by 1.2 x the overshoot, and by at least this fraction of the
#: limit: an overshoot of 1e-8 of the limit would otherwise shrink only a few times per round and never
#: reach zero within REFINE_ROUNDS (seen on a 6-joint arm: exit 3 on a feasible timing).
T_MARGIN = 1e-3
#: A torque-limited timing longer than this multiple of the unlimited one is reported as infeasible.
MAX_SLOWDOWN = 10.0
#: toppra's seidel solver turns a path curvature q'' that is nearly but not exactly zero (rounding noise of 1e-9 on
#: a straight stretch of the curve) into NaN controllable sets and no timing (toppra issues #14 and #17; seen on a
#: 3-joint arm's optimal path: exit 3 on a feasible timing). A joint's q'' whose acceleration term q'' sd^2 stays
#: below this fraction of its acceleration limit at every speed the velocity limits allow is given to toppra as
#: zero; the samples are checked against the true limits afterwards.
CURVATURE_FLOOR = 1e-6


class TimingInfeasible(PlanningFailed):
    """No timing of the (safe) curve meets the limits: ``joint`` the joint, ``excess`` by how much."""

    def __init__(self, message: str, joint: str | None = None, excess: float | None = None) -> None:
        super().__init__(message)
        self.joint = joint
        self.excess = excess


def _held_loads(robot: RobotModel, kin: PathKinematics, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """|gravity| (N, n) at rest along the curve, and the joint friction (frictionloss) each joint must overcome
    where it moves (0 where the curve leaves it still): what no timing can avoid."""
    qpos, qu, _ = kin.at(u)
    zero = np.zeros((len(u), robot.model.nv))
    g = np.abs(inverse_dynamics(robot, qpos, zero, zero)[:, kin.dof])
    return g, np.where(np.abs(qu) > 1e-9, kin.friction, 0.0)


def _amount(x: float) -> str:
    """A torque for a message: one decimal from 0.05 up, two significant digits below (1e-9 N m read "0.0")."""
    return f"{x:.1f}" if 0.05 <= abs(x) < 1e6 or x == 0 else f"{x:.2g}"  # 1e300 printed in 301 digits


def _load_text(g: float, f: float, unit: str) -> str:
    """'gravity (5.4 N m)', or with joint friction 'gravity (5.4 N m) and joint friction (27.0 N m)'."""
    return f"gravity ({_amount(g)} {unit})" + (f" and joint friction ({_amount(f)} {unit})" if f > 0 else "")


def check_gravity(robot: RobotModel, curve: SafeCurve, torque: np.ndarray, samples: int = 2000) -> None:
    """Raise :class:`TimingInfeasible` where gravity alone, with the joint friction of a moving joint, exceeds a
    joint's torque limit on the curve."""
    if not np.any(np.isfinite(torque)):
        return
    kin = PathKinematics(robot, curve)
    u = np.linspace(0.0, curve.length, samples)
    g, f = _held_loads(robot, kin, u)
    over = g + f - torque
    if np.any(over > 0):
        with np.errstate(invalid="ignore"):  # an unlimited joint (inf) is never the one: -inf / inf is NaN
            ratio = np.where(np.isfinite(torque), over / torque, -np.inf)
        i, j = np.unravel_index(int(np.argmax(ratio)), over.shape)
        name, unit = robot.config.joint_names[j], joint_units(robot)[j][3]
        need = (f"gravity alone needs {_amount(g[i, j])} {unit}" if f[i, j] == 0 else f"{_load_text(g[i, j], f[i, j], unit)} need {_amount(g[i, j] + f[i, j])} {unit}")
        raise TimingInfeasible(
            f"no timing fits the torque limit of {name}: {need} at "
            f"{100 * u[i] / curve.length:.0f}% of the path, over its limit {_amount(torque[j])} {unit} by "
            f"{_amount(over[i, j])} {unit} ({_percent(over[i, j] / torque[j])})",
            joint=name, excess=float(over[i, j]),
        )


def _percent(fraction: float) -> str:
    """A share as a percentage: whole from 1 % up, two significant digits below (an excess of 0.4 % read "0%")."""
    pct = 100 * fraction
    return f"{pct:.0f}%" if 1 <= pct < 1e6 else f"{pct:.2g}%"  # a limit of 1e-300 printed 300 digits


# -- toppra -----------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PathTiming:
    """A time law u(t) given by path velocities ``sd`` at grid positions ``s`` with constant path
    acceleration between them (toppra's output): s(t) piecewise quadratic. ``native`` is its own duration;
    evaluated for a longer ``duration`` it is stretched uniformly (speeds x native/duration)."""

    s: np.ndarray  # (N+1,)
    sd: np.ndarray  # (N+1,)
    sdd: np.ndarray  # (N,)
    t: np.ndarray  # (N+1,) time at each grid position
    duration: float

    @property
    def native(self) -> float:
        return float(self.t[-1])

    def at_tau(self, tau: np.ndarray, duration: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """u, du/dt, d2u/dt2 at normalized times tau in [0, 1] (same contract as TimeLaw.at_tau)."""
        T = self.duration if duration is None else duration
        k = self.native / T
        tn = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0) * self.native
        i = np.clip(np.searchsorted(self.t, tn, side="right") - 1, 0, len(self.sdd) - 1)
        dt = tn - self.t[i]
        u = np.clip(self.s[i] + self.sd[i] * dt + 0.5 * self.sdd[i] * dt * dt, self.s[i], self.s[i + 1])
        return u, np.maximum(self.sd[i] + self.sdd[i] * dt, 0.0) * k, self.sdd[i] * k * k

    def time_at(self, u: np.ndarray) -> np.ndarray:
        """Times (of this law's ``duration``) at which the path passes positions u."""
        u = np.clip(np.asarray(u, dtype=float), self.s[0], self.s[-1])
        i = np.clip(np.searchsorted(self.s, u, side="right") - 1, 0, len(self.sdd) - 1)
        ds = u - self.s[i]
        a, v = self.sdd[i], self.sd[i]
        with np.errstate(divide="ignore", invalid="ignore"):
            quad = np.where(np.abs(a) > 1e-12, (-v + np.sqrt(np.maximum(v * v + 2 * a * ds, 0.0))) / a, ds / np.maximum(v, 1e-300))
        return (self.t[i] + np.where(ds > 0, quad, 0.0)) * self.duration / self.native


def _toppra_law(kin: PathKinematics, vmax, amax, tmax, x0: np.ndarray | None = None, grid: np.ndarray | None = None) -> PathTiming:
    """toppra's time-optimal law under the limits; damping enters the torque constraint through the
    tangent bound sd <= (x + x0) / (2 sqrt(x0)) (x = sd^2, any x0 > 0; equality at x = x0), on the side
    of each bound where it adds torque: a conservative linear constraint, exact where x = x0. ``x0`` (at
    :func:`_grid`'s points) defaults to the square of the path speed at the velocity limits."""
    toppra = import_toppra()
    tc = toppra.constraint
    AbstractGeometricPath: Any = toppra.interpolator.AbstractGeometricPath
    LinearConstraint: Any = tc.LinearConstraint

    class CurvePath(AbstractGeometricPath):
        def __call__(self, s, order=0):
            arr = np.atleast_1d(np.asarray(s, dtype=float))
            qpos, qu, quu = kin.at(arr)
            quu = np.where(np.abs(quu) < quu_floor, 0.0, quu)  # CURVATURE_FLOOR
            out = (qpos[:, kin.robot.config.qpos_index], qu, quu)[order]
            return out if np.ndim(s) else out[0]

        @property
        def dof(self):
            return kin.robot.dim

        @property
        def path_interval(self):
            return np.array([0.0, kin.curve.length])

    class TorqueConstraint(LinearConstraint):
        """-lim <= a sdd + b sd^2 + g + D sd <= lim, damping bounded by the tangent at x0 (docstring)."""

        def __init__(self, lim, x0):
            super().__init__()
            self.lim, self.x0 = lim, x0
            self.identical = True
            self.set_discretization_type(tc.DiscretizationType.Interpolation)

        def get_dof(self):
            return 2 * len(self.lim)

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
            a, b, c, D = kin.coefficients(gridpoints)
            r = np.sqrt(self.x0)[:, None]
            up, lo = np.maximum(D, 0.0), np.minimum(D, 0.0)
            A = np.hstack([a, a])
            B = np.hstack([b + up / (2 * r), b + lo / (2 * r)])
            C = np.hstack([c + up * r / 2, c + lo * r / 2])
            n = len(self.lim)
            F = np.block([[np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), -np.eye(n)]])
            g = np.concatenate([self.lim, self.lim])
            return tc.canlinear_colloc_to_interpolate(A, B, C, F, g, None, None, gridpoints, identical=True)

    grid = _grid(kin.curve) if grid is None else grid
    x_v = _speed_bound(kin, grid, vmax)
    quu_floor = CURVATURE_FLOOR * np.asarray(amax, dtype=float) / max(float(x_v.max()), 1e-300)
    if x0 is None:
        x0 = x_v
    constraints = [
        tc.JointVelocityConstraint(np.stack([-vmax, vmax], axis=1)),
        tc.JointAccelerationConstraint(np.stack([-amax, amax], axis=1), discretization_scheme=tc.DiscretizationType.Interpolation),
    ]
    limited = np.isfinite(tmax)
    if np.any(limited):  # joint friction takes up to its frictionloss of the limit (class PathKinematics)
        room = np.maximum(tmax - kin.friction, 1e-9 * np.where(limited, tmax, 1.0))
        constraints.append(TorqueConstraint(np.where(limited, room, 1e12), np.maximum(x0, 1e-12)))
    algo = toppra.algorithm.TOPPRA(constraints, CurvePath(), gridpoints=grid, solver_wrapper="seidel")
    sdd, sd, _ = algo.compute_parameterization(0.0, 0.0)
    if sd is None or np.any(~np.isfinite(sd)):
        keep = _apart(grid, kin.curve)
        if not keep.all():  # NEAR_KNOT: the same law on the grid without the points crowding a knot
            return _toppra_law(kin, vmax, amax, tmax, None if x0 is None else np.asarray(x0)[keep], grid[keep])
        raise TimingInfeasible("toppra found no timing of the path under the limits")
    sd = np.sqrt(np.maximum(np.asarray(sd, dtype=float) ** 2, 0.0))
    ds = np.diff(grid)
    sdd = (sd[1:] ** 2 - sd[:-1] ** 2) / (2 * ds)  # consistent with sd exactly
    dt = 2 * ds / np.maximum(sd[1:] + sd[:-1], 1e-300)
    t = np.concatenate([[0.0], np.cumsum(dt)])
    return PathTiming(grid, sd, sdd, t, float(t[-1]))


def _grid(curve: SafeCurve) -> np.ndarray:
    """toppra's grid: :data:`GRID_POINTS` uniform path positions plus the knots."""
    return np.unique(np.concatenate([np.linspace(0.0, curve.length, GRID_POINTS + 1), curve.knots]))


def _apart(grid: np.ndarray, curve: SafeCurve) -> np.ndarray:
    """The grid points to keep when toppra found no timing: all but the uniform ones within :data:`NEAR_KNOT` of a
    grid spacing of a knot."""
    near = np.abs(grid[:, None] - np.asarray(curve.knots)[None, :]).min(axis=1)
    return (near == 0.0) | (near > NEAR_KNOT * curve.length / GRID_POINTS) | (grid == 0.0) | (grid == curve.length)


def _speed_bound(kin: PathKinematics, grid: np.ndarray, vmax: np.ndarray) -> np.ndarray:
    """The largest x = sd^2 the velocity limits allow at each grid position."""
    _, qu, _ = kin.at(grid)
    with np.errstate(divide="ignore"):
        sd = np.min(vmax / np.maximum(np.abs(qu), 1e-12), axis=1)
    return np.minimum(sd, 1e6) ** 2


# -- sampling a time law on the curve ----------------------------------------------------------------------------
def _sample(robot: RobotModel, rosary: Rosary, curve: SafeCurve, law, duration: float, dt: float, waypoint_times) -> Trajectory:
    whole_steps(duration, dt)  # past MAX_STEPS: TrajectoryTooLong
    steps = max(1, int(round(duration / dt)))
    times = np.arange(steps + 1) * dt
    q, qd, qdd, u = _motion(curve, law, times / times[-1], times[-1])
    q[0], q[-1] = curve.control_points[0, 0], curve.control_points[-1, 5]
    seg = curve.segment_of(u)
    if not (in_ball(q, curve.centers[seg], curve.radii[seg], SAFETY_TOL) & in_box(q, robot.lower, robot.upper)).all():  # pragma: no cover - the curve is certified
        raise TrajectoryError("a re-timed sample left its bubble or the joint bounds")
    cfg, m = robot.config, robot.model
    dof = m.jnt_dofadr[cfg.joint_ids]
    qvel = np.zeros((len(times), m.nv))
    qacc = np.zeros((len(times), m.nv))
    qvel[:, dof] = qd * cfg.scale
    qacc[:, dof] = qdd * cfg.scale
    qvel[[0, -1]] = 0.0
    return Trajectory(times=times, q=q, qpos=cfg.to_qpos(q), joint_names=cfg.joint_names, qvel=qvel, qacc=qacc,
                      bubble=curve.bubble[seg], waypoint_times=np.asarray(waypoint_times, float), qpos_index=cfg.qpos_index.copy(),
                      curve=curve, time_law=law)


def _peaks(robot: RobotModel, traj: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per configuration joint: peak |qd|, |qdd| (joint units) and |tau| (mj_inverse) over the samples."""
    dof = robot.model.jnt_dofadr[robot.config.joint_ids]
    assert traj.qvel is not None and traj.qacc is not None  # (_sample's)
    tau = inverse_dynamics(robot, traj.qpos, traj.qvel, traj.qacc)[:, dof]
    return np.abs(traj.qvel[:, dof]).max(axis=0), np.abs(traj.qacc[:, dof]).max(axis=0), np.abs(tau).max(axis=0)


def _retime_toppra(robot, rosary, base: Trajectory, vmax, amax, tmax, dt) -> Trajectory:
    """toppra's law, checked on the samples with mj_inverse; rounds re-solve with the damping bound's
    tangent at the last solution's speeds (tighter) and limits lowered where a sample overshot (toppra
    meets the limits at its grid points only); the fastest timing meeting every limit is kept."""
    curve = base.curve
    assert curve is not None  # (retime checked it)
    kin = PathKinematics(robot, curve)
    knots_of_points = np.searchsorted(curve.point_index, np.arange(rosary.k + 1), side="right") - 1
    limited = np.isfinite(tmax)
    # A lower bound of the unlimited timing: every joint's total travel at its velocity limit.
    qpos, _, _ = kin.at(np.linspace(0.0, curve.length, 2001))
    travel = np.abs(np.diff(qpos[:, robot.config.qpos_index], axis=0)).sum(axis=0)
    lower_bound = float(np.max(travel / vmax))
    # Start a little inside the limits: toppra meets them at its grid points, the samples fall between.
    v_eff, a_eff = vmax * (1 - V_MARGIN), amax * (1 - A_MARGIN)
    t_eff = np.where(limited, tmax, np.inf)
    grid = _grid(curve)
    x_v = _speed_bound(kin, grid, vmax)
    x0, best = x_v, None
    last_over = (np.zeros_like(vmax), np.zeros_like(vmax), np.zeros_like(vmax))
    law = None
    for round_ in range(REFINE_ROUNDS):
        try:
            law = _toppra_law(kin, v_eff, a_eff, t_eff, x0, grid)
            grid = law.s  # the grid toppra used (NEAR_KNOT), which the next round's x0 follows
        except TimingInfeasible:
            if best is not None or law is not None:  # a tightened round found none: keep the best, or stretch the last law
                break
            if round_ == 0 and np.any(limited):  # near rest the velocity-limit tangent overstates damping
                x0 = x_v * 1e-4
                continue
            _report_margin(robot, kin, tmax, "toppra found no timing under the limits")
            raise
        if np.any(limited) and law.native > MAX_SLOWDOWN * lower_bound:
            free = _toppra_law(kin, vmax, amax, np.full_like(tmax, np.inf))
            if law.native > MAX_SLOWDOWN * free.native:
                _report_slowdown(robot, kin, law, free, tmax)
        T = whole_steps(law.native, dt) * dt
        law = PathTiming(law.s, law.sd, law.sdd, law.t, T)
        traj = _sample(robot, rosary, curve, law, T, dt, law.time_at(curve.knots)[knots_of_points])
        pv, pa, pt = _peaks(robot, traj)
        over_v, over_a = pv / vmax, pa / amax
        with np.errstate(invalid="ignore"):
            over_t = np.where(limited, pt / tmax, 0.0)
        ok = max(over_v.max(), over_a.max(), over_t.max()) <= 1.0 + 1e-9
        if ok and (best is None or traj.duration < best.duration - 0.5 * dt):
            best = traj
        elif ok or (best is not None and round_ >= 2):
            break  # no faster timing than the best found
        if ok and over_t.max() < 0.95:
            break  # the torque limits do not bind: a tighter damping bound would change nothing
        v_eff = np.where(over_v > 1, v_eff / over_v * (1 - V_MARGIN), v_eff)
        a_eff = np.where(over_a > 1, a_eff / over_a * (1 - A_MARGIN), a_eff)
        with np.errstate(invalid="ignore"):  # an unlimited joint (inf) is never over; np.where evaluates both sides
            t_eff = np.where(over_t > 1, t_eff - np.maximum((pt - tmax) * 1.2, T_MARGIN * tmax), t_eff)
        last_over = (over_v, over_a, over_t)
        x0 = np.maximum(law.sd**2, 1e-9 * float(x_v.max()))
    if best is not None:
        return best
    if law is not None:
        stretched = _stretch_to_limits(robot, rosary, curve, law, vmax, amax, tmax, dt, knots_of_points)
        if stretched is not None:
            return stretched
    # Name the joint and the limit that stayed exceeded (the worst ratio of the last round).
    kinds = (("velocity", vmax), ("acceleration", amax), ("torque", tmax))
    k, j = max(((k, int(np.argmax(o))) for k, o in enumerate(last_over)), key=lambda kj: last_over[kj[0]][kj[1]])
    name, ratio = robot.config.joint_names[j], float(last_over[k][j])
    raise TimingInfeasible(  # pragma: no cover - has not happened on the shipped scenes
        f"toppra's timing still exceeds the {kinds[k][0]} limit of {name} by {100 * (ratio - 1):.2g}% "
        f"after {REFINE_ROUNDS} refinements (try --time-law own)",
        joint=name, excess=float((ratio - 1) * kinds[k][1][j]),
    )


def _report_slowdown(robot, kin: PathKinematics, law: PathTiming, free: PathTiming, tmax) -> None:
    """The torque limits only fit with an absurd slowdown: name the joint with the least margin over gravity."""
    _report_margin(robot, kin, tmax, f"the timing would take {law.native:.1f} s, over {MAX_SLOWDOWN:g} times the "
                   f"{free.native:.2f} s without torque limits")


def _report_margin(robot, kin: PathKinematics, tmax, what: str) -> None:
    """Raise TimingInfeasible naming the joint whose torque limit leaves the least room above gravity (and the
    friction of a moving joint)."""
    u = np.linspace(0.0, kin.curve.length, 2001)
    g, f = _held_loads(robot, kin, u)
    with np.errstate(invalid="ignore", divide="ignore"):
        margin = np.where(np.isfinite(tmax), (tmax - g - f) / tmax, np.inf)
    i, j = np.unravel_index(int(np.argmin(margin)), margin.shape)
    if not np.isfinite(margin[i, j]):
        raise TimingInfeasible(f"no timing fits the limits: {what}")
    name, unit = robot.config.joint_names[j], joint_units(robot)[j][3]
    raise TimingInfeasible(
        f"the torque limit of {name} ({tmax[j]:.1f} {unit}) leaves only {tmax[j] - g[i, j] - f[i, j]:.2f} {unit} above "
        f"{_load_text(g[i, j], f[i, j], unit)} at {100 * u[i] / kin.curve.length:.0f}% of the path: {what}",
        joint=name, excess=float(g[i, j] + f[i, j] - tmax[j]),
    )


def _stretch_to_limits(robot, rosary, curve, law: PathTiming, vmax, amax, tmax, dt, knots_of_points) -> Trajectory | None:
    """toppra meets the limits at its grid points; where its refinements still left a sample over a limit (1.5 %
    over an acceleration limit on one rbpf path, 35 % over a torque limit on a jagged path of the xArm7), the last law
    stretched uniformly by lam meets it: speeds scale by x = 1 / lam and accelerations by x^2, exactly, so every
    sample's torque is g + x D + x^2 R (gravity, damping, the rest: as the own law's stretch) and the largest x that
    fits is a root (aimed A_MARGIN inside the limit), as are the velocity and acceleration ones. Up to three stretches (the torque model leaves out
    joint friction's change with speed); None when they do not fit the limits within the 10x slowdown."""
    limited = np.isfinite(tmax)
    dof = robot.model.jnt_dofadr[robot.config.joint_ids]
    L = np.where(limited, tmax, np.inf)
    traj = _sample(robot, rosary, curve, law, law.duration, dt, law.time_at(curve.knots)[knots_of_points])
    for stretch in range(4):
        assert traj.qvel is not None and traj.qacc is not None  # (_sample's)
        qd, qdd = np.abs(traj.qvel[:, dof]), np.abs(traj.qacc[:, dof])
        g, tau, damped = _torque_terms(robot, traj)
        if np.all(qd <= vmax * (1 + 1e-9)) and np.all(qdd <= amax * (1 + 1e-9)) and np.all(np.abs(tau) <= L * (1 + 1e-9)):
            return traj
        if stretch == 3:
            return None
        x_tau = 1.0
        if np.any(limited):
            D = damped[:, limited]
            R = tau[:, limited] - g[:, limited] - D
            gl, lim = g[:, limited], L[limited] * (1 - A_MARGIN)  # aimed inside: the samples fall elsewhere on the curve
            x_tau = float(np.min(np.minimum(_smallest_positive_root(R, D, gl - lim), _smallest_positive_root(R, D, gl + lim)), initial=1.0))
        lam = max(1.0, float((qd / vmax).max()), float(np.sqrt((qdd / amax).max())), 1.0 / x_tau)
        T = whole_steps(law.duration * lam * (1 + 1e-3), dt) * dt
        if T > MAX_SLOWDOWN * law.native:
            return None
        law = PathTiming(law.s, law.sd, law.sdd, law.t, T)
        traj = _sample(robot, rosary, curve, law, T, dt, law.time_at(curve.knots)[knots_of_points])
    return None  # pragma: no cover - the loop returns


def _retime_own(robot, rosary, base: Trajectory, tmax, dt) -> Trajectory:
    """The min-jerk law stretched to meet the torque limits (exact roots, module docstring)."""
    T0 = base.duration
    assert base.curve is not None and base.time_law is not None and base.waypoint_times is not None  # (make_trajectory's)
    if not np.any(np.isfinite(tmax)):
        return base
    x_max = 1.0
    traj = base
    for _ in range(REFINE_ROUNDS):
        g, tau, damped = _torque_terms(robot, traj)
        x0 = T0 / traj.duration  # speed factor of these samples relative to T0
        D = damped / x0
        R = (tau - g - damped) / x0**2
        L = np.where(np.isfinite(tmax), tmax, np.inf)
        if np.all(np.abs(tau) <= L * (1 + 1e-9)):
            return traj
        roots = [_smallest_positive_root(R, D, g - L), _smallest_positive_root(R, D, g + L)]
        x_max = min(x_max, float(np.min(np.minimum(*roots)))) * (1 - 1e-6)
        if T0 / x_max > MAX_SLOWDOWN * T0:
            _report_margin(robot, PathKinematics(robot, base.curve), tmax,
                           f"the smooth timing would take {T0 / x_max:.1f} s, over {MAX_SLOWDOWN:g} times its "
                           f"{T0:.2f} s without torque limits")
        T = whole_steps(T0 / x_max, dt) * dt
        law = type(base.time_law)(base.time_law.grid, base.time_law.weight, T)
        traj = _sample(robot, rosary, base.curve, law, T, dt, base.waypoint_times * T / T0)
    raise TimingInfeasible("the stretched time law still exceeds the torque limits")  # pragma: no cover


def _torque_terms(robot: RobotModel, traj: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """At every sample of ``traj`` (N, n, configuration joints): gravity g, the torque tau (``mj_inverse``) and the
    damping torque B qd, so that a uniform stretch to speed factor x gives g + x (B qd) + x^2 (tau - g - B qd)."""
    dof = robot.model.jnt_dofadr[robot.config.joint_ids]
    assert traj.qvel is not None and traj.qacc is not None  # (_sample's)
    zero = np.zeros_like(traj.qvel)
    g = inverse_dynamics(robot, traj.qpos, zero, zero)[:, dof]
    tau = inverse_dynamics(robot, traj.qpos, traj.qvel, traj.qacc)[:, dof]
    return g, tau, robot.model.dof_damping[dof] * traj.qvel[:, dof]


def _smallest_positive_root(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Elementwise smallest root x > 0 of a x^2 + b x + c = 0 (inf when none)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = b * b - 4 * a * c
        sq = np.sqrt(np.maximum(disc, 0.0))
        r1 = np.where(np.abs(a) > 1e-300, (-b - sq) / (2 * a), -c / b)
        r2 = np.where(np.abs(a) > 1e-300, (-b + sq) / (2 * a), -c / b)
        ok = disc >= 0
        r1 = np.where(ok & (r1 > 0), r1, np.inf)
        r2 = np.where(ok & (r2 > 0), r2, np.inf)
    return np.minimum(r1, r2)


def retime(robot: RobotModel, trajectory: Trajectory, rosary: Rosary, limits: Limits | JointLimits | None = None,
           method: str = DEFAULT_METHOD, dt: float | None = None) -> Trajectory:
    """``trajectory`` (from :func:`make_trajectory`, same curve) re-timed under velocity, acceleration and
    torque limits by ``method`` ("toppra" or "own"); raises :class:`TimingInfeasible` (module docstring)."""
    if method not in METHODS:
        raise ValueError(f"`method` must be one of {METHODS}, got {method!r}")
    if trajectory.curve is None or trajectory.time_law is None:
        raise ValueError("`trajectory` must come from make_trajectory (it needs its curve and time law)")
    lim = as_limits(limits)
    vmax, amax, tmax = lim.resolve(robot)
    dt = trajectory.dt if dt is None else float(dt)
    amax = np.minimum(amax, row_acceleration_cap(robot, dt))  # consecutive samples stay close to the curve
    check_gravity(robot, trajectory.curve, tmax)
    if method == "own":
        return _retime_own(robot, rosary, trajectory, tmax, dt)
    try:
        return _retime_toppra(robot, rosary, trajectory, vmax, amax, tmax, dt)
    except TimingInfeasible:
        if not _within_one_step(robot, trajectory.curve, vmax, amax, dt):
            raise
        # toppra's solver works to absolute tolerances in path position and speed: on a motion of 1e-8 rad (a goal
        # that close to the start) it finds no timing at all. Any law then moves in one sample step: the own law's.
        return _retime_own(robot, rosary, trajectory, tmax, dt)


def _within_one_step(robot: RobotModel, curve: SafeCurve, vmax: np.ndarray, amax: np.ndarray, dt: float) -> bool:
    """True when every joint's travel along ``curve`` fits in one step ``dt`` at its velocity limit and, accelerating
    and braking at its acceleration limit, its travel is at most amax dt^2 / 4."""
    qpos, _, _ = PathKinematics(robot, curve).at(np.linspace(0.0, curve.length, 201))
    travel = np.abs(np.diff(qpos[:, robot.config.qpos_index], axis=0)).sum(axis=0)
    return bool(np.all(travel <= vmax * dt) and np.all(travel <= amax * dt**2 / 4))


def timed_trajectory(robot: RobotModel, path, rosary: Rosary, limits: Limits | JointLimits | None = None,
                     method: str = DEFAULT_METHOD, dt: float | None = None) -> Trajectory:
    """The safe curve through ``path`` (:func:`make_trajectory`) timed under velocity, acceleration and
    torque ``limits`` by ``method``."""
    lim = as_limits(limits)
    try:
        base = make_trajectory(robot, path, rosary, lim.joint_limits(robot), dt)
        return retime(robot, base, rosary, lim, method, dt)
    except TrajectoryTooLong as exc:
        raise TimingInfeasible(str(exc)) from None


def time_path(robot: RobotModel, name: str, path, rosary: Rosary, limits: Limits, time_law: str = DEFAULT_METHOD) -> Trajectory:
    """:func:`timed_trajectory` of the path ``name`` (what plan and export time); a TimingInfeasible names the path."""
    try:
        return timed_trajectory(robot, path, rosary, limits, time_law)
    except TimingInfeasible as exc:
        raise TimingInfeasible(f"path '{name}': {exc}", exc.joint, exc.excess) from None
