"""Tests foam_mj.trajectory: the safe C2 curve through a rosary and its timing under joint limits."""

from __future__ import annotations

from foam_mj.data import model_path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foam_mj.bubbles import BubbleOracle
from foam_mj.clearance import Clearance
from foam_mj.foam import FoamParams, plan
from foam_mj.model import RobotModel
from foam_mj.rosary import Rosary
from foam_mj.safe_curve import _natural_spline_derivatives, safe_curve
from foam_mj.trajectory import JointLimits, Trajectory, _max_filter, _mean_filter, make_trajectory

Q_INIT = [0.2, 0.3, 0.08]
Q_GOAL = [0.45, 0.4536, 1.45]
DELTA = 0.005


def _in_ball(points, centers, radii, tol=1e-9):
    """Membership computed here, independently of foam_mj.rosary."""
    return np.linalg.norm(np.asarray(points) - np.asarray(centers), axis=-1) <= np.asarray(radii) + tol


def _pulled(rosary: Rosary, rounds: int = 150) -> np.ndarray:
    """A short, smooth-ish path through the hatches (string pulling: each waypoint moves to its neighbours'
    midpoint, projected back into its hatch by alternating projections), like a smoother's output."""
    ca, ra, cb, rb = rosary.hatch_balls()
    ra, rb = ra * (1 - 1e-6), rb * (1 - 1e-6)

    def proj(z, c, r):
        d = z - c
        n = np.linalg.norm(d, axis=1, keepdims=True)
        return np.where(n > r[:, None], c + d * (r[:, None] / np.maximum(n, 1e-300)), z)

    w = rosary.portal_waypoints()
    for _ in range(rounds):
        p = rosary.path(w)
        y = 0.5 * (p[:-2] + p[2:])
        a = np.zeros_like(y)
        b = np.zeros_like(y)
        for _ in range(20):  # Dykstra: projection onto the intersection of the two balls
            z = proj(y + a, ca, ra)
            a = y + a - z
            y = proj(z + b, cb, rb)
            b = z + b - y
        w = y
    assert rosary.all_in_hatches(w)
    return w


@pytest.fixture(scope="module")
def robot() -> RobotModel:
    return RobotModel.from_xml(model_path("obstacle.xml"))


@pytest.fixture(scope="module")
def rosary(robot) -> Rosary:
    oracle = BubbleOracle(robot, delta=DELTA)
    try:
        return plan(oracle, Q_INIT, Q_GOAL, FoamParams(K=10, r_min=0.07, delta=DELTA), seed=0).rosary
    finally:
        oracle.close()


@pytest.fixture(scope="module")
def paths(rosary) -> dict[str, np.ndarray]:
    return {
        "centre": rosary.path(rosary.center_waypoints()),
        "portal": rosary.path(rosary.portal_waypoints()),
        "pulled": rosary.path(_pulled(rosary)),
    }


@pytest.fixture(scope="module")
def trajectories(robot, rosary, paths) -> dict[str, Trajectory]:
    return {name: make_trajectory(robot, p, rosary) for name, p in paths.items()}


NAMES = ("centre", "portal", "pulled")


@pytest.mark.parametrize("name", NAMES)
def test_passes_through_every_waypoint(trajectories, paths, name):
    tr, path = trajectories[name], paths[name]
    q, _, _ = tr.evaluate(tr.waypoint_times)
    assert np.allclose(q, path, atol=1e-9, rtol=0)
    assert np.all(np.diff(tr.waypoint_times) > 0)
    assert np.array_equal(tr.q[0], path[0]) and np.array_equal(tr.q[-1], path[-1])
    # The samples themselves come within one step of every waypoint.
    step = np.abs(np.diff(tr.q, axis=0)).max()
    gaps = np.linalg.norm(path[:, None, :] - tr.q[None, :, :], axis=2).min(axis=1)
    assert gaps.max() <= step * np.sqrt(3) + 1e-12


@pytest.mark.parametrize("name", NAMES)
def test_respects_velocity_and_acceleration_limits(robot, trajectories, name):
    tr = trajectories[name]
    vmax, amax = JointLimits().resolve(robot)
    dof = robot.model.jnt_dofadr[robot.config.joint_ids]
    assert np.all(np.abs(tr.qvel[:, dof]) <= vmax * (1 + 1e-9))
    assert np.all(np.abs(tr.qacc[:, dof]) <= amax * (1 + 1e-9))
    # Independently, from the sampled positions alone (finite differences, O(dt) slack).
    qpos = tr.joint_positions
    v_fd = np.diff(qpos, axis=0) / tr.dt
    a_fd = np.diff(qpos, n=2, axis=0) / tr.dt**2
    assert np.all(np.abs(v_fd) <= vmax * 1.01)
    assert np.all(np.abs(a_fd) <= amax * 1.02)
    # Rest to rest; C2: the acceleration is continuous across the waypoints (where the curve's pieces
    # meet) and changes by less than a quarter of the limit between samples.
    assert np.all(tr.qvel[[0, -1]] == 0) and np.all(tr.qacc[[0, -1]] == 0)
    t = tr.waypoint_times[1:-1]
    _, _, left = tr.evaluate(t - 1e-7)
    _, _, right = tr.evaluate(t + 1e-7)
    scale = robot.config.scale
    assert np.all(np.abs(right - left) * scale <= 1e-3 * amax)
    assert np.all(np.abs(np.diff(tr.qacc[:, dof], axis=0)) <= 0.25 * amax)
    # The limits are reached (the duration is not padded) and the swing lasts a sensible time.
    use = np.maximum(np.abs(tr.qvel[:, dof]).max(0) / vmax, np.sqrt(np.abs(tr.qacc[:, dof]).max(0) / amax))
    assert use.max() > 0.95
    assert 0.5 < tr.duration < 5.0
    assert np.allclose(np.diff(tr.times), robot.model.opt.timestep)



@pytest.mark.parametrize("dense", [5, 10])
def test_the_limits_hold_on_the_samples_when_the_grid_misses_the_peaks(robot, rosary, paths, monkeypatch, dense):
    """The duration comes from the peaks on a dense grid; a grid too coarse to find them (5 or 10 points a segment
    instead of 200) underestimates them by a few per cent, and the samples themselves are then checked and the
    duration stretched until they keep the limits."""
    import foam_mj.trajectory as trajectory

    monkeypatch.setattr(trajectory, "_DENSE_PER_SEGMENT", dense)
    vmax, amax = JointLimits().resolve(robot)
    dof = robot.model.jnt_dofadr[robot.config.joint_ids]
    for name in ("centre", "portal"):
        tr = make_trajectory(robot, paths[name], rosary)
        assert np.all(np.abs(tr.qvel[:, dof]) <= vmax * (1 + 1e-9)), name
        assert np.all(np.abs(tr.qacc[:, dof]) <= amax * (1 + 1e-9)), name

@pytest.mark.parametrize("name", NAMES)
def test_every_sample_lies_in_the_bubble_of_its_segment(rosary, trajectories, name):
    tr = trajectories[name]
    # The segment of each sample from the waypoint times (not from the trajectory's own bookkeeping).
    seg = np.clip(np.searchsorted(tr.waypoint_times, tr.times, side="right") - 1, 0, rosary.k - 1)
    assert np.all(_in_ball(tr.q, rosary.centers[seg], rosary.radii[seg]))
    assert np.all(_in_ball(tr.q, rosary.centers[tr.bubble], rosary.radii[tr.bubble]))


@pytest.mark.parametrize("name", NAMES)
def test_every_sample_is_collision_free_under_mujoco(robot, trajectories, name):
    tr = trajectories[name]
    assert not any(robot.in_collision(q) for q in tr.q)
    clearance = Clearance(robot)
    try:
        # Inside a certified bubble every configuration keeps at least delta of clearance.
        assert clearance.batch(tr.q).min() >= DELTA - 1e-6
    finally:
        clearance.close()


def test_curve_control_points_certify_each_segment(trajectories, rosary):
    curve = trajectories["centre"].curve
    cp = curve.control_points
    assert np.all(_in_ball(cp, rosary.centers[curve.bubble][:, None], rosary.radii[curve.bubble][:, None]))
    u = np.linspace(0, curve.length, 20001)
    q, _, _ = curve.evaluate(u)
    j = curve.segment_of(u)
    assert np.all(_in_ball(q, rosary.centers[curve.bubble[j]], rosary.radii[curve.bubble[j]]))


def _random_rosary(rng: np.random.Generator, k: int, n: int = 3) -> Rosary:
    """A chain of k balls, each centred on its parent's surface, like the foam's rosaries."""
    r = rng.uniform(0.05, 0.3, k)
    c = np.zeros((k, n))
    for i in range(1, k):
        u = rng.standard_normal(n)
        c[i] = c[i - 1] + r[i - 1] * u / np.linalg.norm(u)
    u = rng.standard_normal(n)
    goal = c[-1] + 0.5 * r[-1] * u / np.linalg.norm(u)
    return Rosary(c, r, c[0].copy(), goal)


@pytest.mark.parametrize("seed", range(12))
def test_random_rosaries_stay_inside_densely(seed):
    rng = np.random.default_rng(seed)
    ros = _random_rosary(rng, k=int(rng.integers(2, 25)))
    for waypoints in (ros.center_waypoints(), ros.sample_hatches(rng)):
        curve = safe_curve(ros.path(waypoints), ros)
        u = np.linspace(0, curve.length, 50001)
        q, _, _ = curve.evaluate(u)
        j = curve.segment_of(u)
        assert np.all(_in_ball(q, ros.centers[curve.bubble[j]], ros.radii[curve.bubble[j]]))
        assert np.allclose(curve.evaluate(curve.knots)[0], ros.path(waypoints)[curve.point_index], atol=1e-12)



@pytest.mark.parametrize("factor", [1.02, 1.1, 1.5, 3.0])
def test_the_control_point_check_alone_keeps_the_curve_in_its_bubbles(monkeypatch, factor):
    """The derivative fit scales the spline's tangents and curvatures to fit the balls; the check of all six control
    points of every segment (to SAFETY_TOL) then falls back to straight segments wherever they do not fit. With a fit
    that overshoots by ``factor`` (control points a little or far outside), the check alone must keep every control
    point, and so the curve, in its bubble."""
    import foam_mj.safe_curve as sc

    fit = sc._fit_derivatives
    monkeypatch.setattr(sc, "_fit_derivatives", lambda *a: tuple(factor * x for x in fit(*a)))
    rng = np.random.default_rng(5)
    for _ in range(6):
        ros = _random_rosary(rng, k=12)
        curve = safe_curve(ros.path(ros.center_waypoints()), ros)
        centers, radii = ros.centers[curve.bubble][:, None], ros.radii[curve.bubble][:, None]
        assert np.all(_in_ball(curve.control_points, centers, radii))
        u = np.linspace(0, curve.length, 20001)
        j = curve.segment_of(u)
        assert np.all(_in_ball(curve.evaluate(u)[0], ros.centers[curve.bubble[j]], ros.radii[curve.bubble[j]]))

def test_repeated_waypoints_and_two_point_paths(robot, rosary):
    # Waypoint i of the centre path is centre i+1; it also lies in hatch i+1 when r_(i+1) <= r_(i+2).
    w = rosary.center_waypoints()
    i = int(np.flatnonzero(rosary.radii[1:-1] <= rosary.radii[2:])[0])
    w[i + 1] = w[i]  # two equal consecutive waypoints: a zero-length segment
    assert rosary.all_in_hatches(w, 1e-12)
    path = rosary.path(w)
    tr = make_trajectory(robot, path, rosary)
    assert tr.waypoint_times[i + 1] == tr.waypoint_times[i + 2]
    assert np.allclose(tr.evaluate(tr.waypoint_times)[0], path, atol=1e-9)
    one = Rosary(np.array([Q_INIT]), np.array([0.08]), np.array(Q_INIT), np.array(Q_INIT) + [0.05, 0.0, 0.0])
    tr1 = make_trajectory(robot, one.path(np.empty((0, 3))), one)
    assert np.allclose(tr1.q[:, 1:], np.array(Q_INIT)[1:])  # a straight line along the first joint


def test_limits_set_the_duration(robot, rosary, paths, trajectories):
    slow = JointLimits(hinge_velocity=2.5, hinge_acceleration=12.5, slide_velocity=0.75, slide_acceleration=2.5)
    tr = make_trajectory(robot, paths["pulled"], rosary, slow)
    assert tr.duration > trajectories["pulled"].duration
    vmax, amax = slow.resolve(robot)
    dof = robot.model.jnt_dofadr[robot.config.joint_ids]
    assert np.all(np.abs(tr.qvel[:, dof]) <= vmax * (1 + 1e-9)) and np.all(np.abs(tr.qacc[:, dof]) <= amax * (1 + 1e-9))
    knee = JointLimits(per_joint={"knee_flexion": (1.0, 5.0)})
    v, a = knee.resolve(robot)
    assert v[robot.config.joint_names.index("knee_flexion")] == 1.0
    tr2 = make_trajectory(robot, paths["pulled"], rosary, knee, dt=0.01)
    assert np.allclose(np.diff(tr2.times), 0.01)
    k = robot.config.joint_names.index("knee_flexion")
    assert np.abs(tr2.qvel[:, robot.model.jnt_dofadr[robot.config.joint_ids[k]]]).max() <= 1.0 + 1e-9


def test_bad_inputs_raise_clear_errors(robot, rosary, paths):
    path = paths["centre"]
    with pytest.raises(ValueError, match="`path` must have shape"):
        make_trajectory(robot, path[:-1], rosary)
    with pytest.raises(ValueError, match="`path` must be finite"):
        make_trajectory(robot, np.where(np.arange(path.size).reshape(path.shape) == 4, np.nan, path), rosary)
    bad = path.copy()
    bad[5] += 1.0
    with pytest.raises(ValueError, match=r"`path\[5\]` is not in hatch 4"):
        make_trajectory(robot, bad, rosary)
    bad = path.copy()
    bad[0] += 1.0
    with pytest.raises(ValueError, match=r"`path\[0\]`"):
        make_trajectory(robot, bad, rosary)
    with pytest.raises(ValueError, match="`rosary` must be a Rosary"):
        make_trajectory(robot, path, None)
    with pytest.raises(ValueError, match="`robot` must be a RobotModel"):
        make_trajectory("robot", path, rosary)
    with pytest.raises(ValueError, match="`dt`"):
        make_trajectory(robot, path, rosary, dt=0.0)
    with pytest.raises(ValueError, match="`limits` must be a JointLimits"):
        make_trajectory(robot, path, rosary, limits={"hinge_velocity": 1})
    with pytest.raises(ValueError, match="`hinge_velocity`"):
        JointLimits(hinge_velocity=-1.0)
    with pytest.raises(ValueError, match="`slide_acceleration`"):
        JointLimits(slide_acceleration=float("inf"))
    with pytest.raises(ValueError, match=r"`per_joint\['knee_flexion'\]`"):
        JointLimits(per_joint={"knee_flexion": (1.0, 0.0)})
    with pytest.raises(ValueError, match="unknown joints"):
        make_trajectory(robot, path, rosary, JointLimits(per_joint={"ankle": (1.0, 1.0)}))
    same = Rosary(np.array([Q_INIT]), np.array([0.08]), np.array(Q_INIT), np.array(Q_INIT))
    with pytest.raises(ValueError, match="zero length"):
        make_trajectory(robot, same.path(np.empty((0, 3))), same)


def test_trajectory_dataclass_validates_its_fields():
    t = np.arange(3) * 0.1
    q = np.zeros((3, 2))
    with pytest.raises(ValueError, match="`times`"):
        Trajectory(times=t[::-1], q=q, qpos=q, joint_names=("a", "b"))
    with pytest.raises(ValueError, match=r"`q` must have shape \(3, 2\)"):
        Trajectory(times=t, q=q[:, :1], qpos=q, joint_names=("a", "b"))
    with pytest.raises(ValueError, match="`qvel`"):
        Trajectory(times=t, q=q, qpos=q, joint_names=("a", "b"), qvel=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="`qpos` must be finite"):
        Trajectory(times=t, q=q, qpos=np.full((3, 2), np.nan), joint_names=("a", "b"))
    with pytest.raises(ValueError, match="`qpos_index`"):
        Trajectory(times=t, q=q, qpos=q, joint_names=("a", "b"), qpos_index=np.array([0, 5]))
    tr = Trajectory(times=t, q=q, qpos=q, joint_names=["a", "b"])
    assert tr.joint_names == ("a", "b") and tr.duration == pytest.approx(0.2)
    with pytest.raises(ValueError, match="no `curve`"):
        tr.evaluate(0.1)


# -- the numpy helpers give scipy's numbers bit for bit (scipy.interpolate/ndimage stay out of `plan`'s start-up) --
@settings(max_examples=60, deadline=None)
@given(st.integers(3, 40), st.integers(1, 6), st.integers(0, 2**32 - 1))
def test_natural_spline_derivatives_are_scipys_bit_for_bit(m, n, seed):
    from scipy.interpolate import CubicSpline

    rng = np.random.default_rng(seed)
    h = rng.random(m - 1) ** 3 * 10 ** rng.uniform(-3, 1) + 1e-9  # uneven steps, some tiny
    x = np.concatenate([[0.0], np.cumsum(h)])
    y = rng.normal(size=(m, n)) * 10 ** rng.uniform(-3, 2)
    spline = CubicSpline(x, y, bc_type="natural")
    d1, d2 = _natural_spline_derivatives(x, y)
    assert np.array_equal(d1, spline(x, 1)) and np.array_equal(d2, spline(x, 2))


@settings(max_examples=80, deadline=None)
@given(st.integers(1, 3000), st.integers(0, 200), st.integers(0, 2**32 - 1))
def test_window_filters_are_scipys_bit_for_bit(length, half, seed):
    from scipy.ndimage import maximum_filter1d, uniform_filter1d

    rng = np.random.default_rng(seed)
    x = np.abs(np.cumsum(rng.normal(size=length))) * 10 ** rng.uniform(-6, 3)  # windows longer than x included
    size = 2 * half + 1
    assert np.array_equal(_max_filter(x, size), maximum_filter1d(x, size, mode="nearest"))
    assert np.array_equal(_mean_filter(x, size), uniform_filter1d(x, size, mode="nearest"))


def test_importing_trajectories_loads_no_scipy_interpolate_or_ndimage():
    import subprocess
    import sys

    code = "import sys, foam_mj.trajectory; print(sorted(m for m in ('scipy.interpolate', 'scipy.ndimage') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_windows_far_wider_than_the_path_take_no_memory_and_keep_their_values(monkeypatch):
    """A move of 1e-7 rad has smoothing windows of 1e9 samples: the filters must not materialise them."""
    from scipy.ndimage import maximum_filter1d, uniform_filter1d

    import foam_mj.trajectory as trajectory

    rng = np.random.default_rng(5)
    x = rng.random(40)
    for size in (81, 101, 1001):                       # wider than twice the array: the closed forms
        monkeypatch.setattr(trajectory, "_WIDE_WINDOW", 0)
        assert np.array_equal(_max_filter(x, size), maximum_filter1d(x, size, mode="nearest"))
        assert np.allclose(_mean_filter(x, size), uniform_filter1d(x, size, mode="nearest"), rtol=1e-13, atol=0)
    assert _mean_filter(x, 2_000_000_001).shape == (40,)  # a 16 GB window, evaluated in closed form
    assert np.all(_max_filter(x, 2_000_000_001) == x.max())


def test_a_goal_a_tenth_of_a_microradian_from_the_start_plans():
    """A legitimate tiny move (only q_goal == q_init is refused) plans, instead of a MemoryError."""
    from pathlib import Path

    from foam_mj.cli import main

    arm = Path(__file__).resolve().parents[1] / "examples" / "two_link_arm" / "arm.xml"
    assert main(["plan", "--mjcf", str(arm), "--start", "0.3 2.0", "--goal", "0.3 2.0000001", "--no-rrd"]) == 0


@pytest.mark.parametrize("method", ["toppra", "own"])
def test_rows_stay_close_to_the_curve_however_high_the_limits(robot, rosary, paths, method):
    """Limits of 1e6 rad/s and 1e9 rad/s^2 timed the swing in one 2 ms step: two rows, q_init and q_goal, whose
    straight line (what a checker or a controller interpolates) ran 65 mm into the box. The joint accelerations
    are now also held to row_acceleration_cap, so every chord between consecutive rows stays within ROW_TOL of
    the certified curve, and MuJoCo finds the rows and the chords between them clear of the margin."""
    from foam_mj.limits import Limits
    from foam_mj.timing import timed_trajectory
    from foam_mj.trajectory import ROW_TOL, row_acceleration_cap

    assert np.all(row_acceleration_cap(robot, 0.002) > 10 * np.array([50.0, 50.0, 10.0]))  # default limits: no change
    limits = Limits(velocity=(1e6,) * 3, acceleration=(1e9,) * 3, torque=(1e12,) * 3)
    tr = timed_trajectory(robot, paths["centre"], rosary, limits, method)
    assert len(tr) > 20
    t = tr.times
    for s in (0.25, 0.5, 0.75):
        between = tr.evaluate(t[:-1] + s * np.diff(t))[0]
        assert np.linalg.norm(between - ((1 - s) * tr.q[:-1] + s * tr.q[1:]), axis=1).max() <= ROW_TOL
    chords = np.concatenate([(1 - s) * tr.q[:-1] + s * tr.q[1:] for s in np.linspace(0.0, 1.0, 11)])
    clearance = Clearance(robot)
    try:
        assert clearance.batch(chords).min() >= DELTA
    finally:
        clearance.close()


TWO_LINK_ARM = """<mujoco><compiler angle="radian"/><worldbody>
  <geom name="post" type="box" pos="0.7 0.5 0.1" size="0.1 0.1 0.5"/>
  <body name="l1" pos="0 0 0.1"><joint name="j1" axis="0 0 1" range="-3 3"/>
    <geom name="c1" type="capsule" fromto="0 0 0 0.5 0 0" size="0.03"/>
    <body name="l2" pos="0.5 0 0"><joint name="j2" axis="0 0 1" range="-2.5 2.5"/>
      <geom name="c2" type="capsule" fromto="0 0 0 0.4 0 0" size="0.025"/></body></body>
</worldbody></mujoco>"""


@pytest.mark.parametrize("method", ["toppra", "own"])
def test_a_trajectory_from_a_corner_of_the_joint_box_stays_within_the_joint_ranges(tmp_path, method):
    """A start at a corner of the joint box (both joints at a limit) has an end bubble that leaves the box (no ball in
    the box holds a corner). The curve's first segment, in that bubble, turned sharply into the next waypoint and bent
    the elbow 0.062 rad past its limit (j2 down to -2.562 of -2.5) with every control point in the ball; its control
    points must lie in the box too, so every sample of the timed trajectory is within the ranges. The box scales the
    tangents and curvatures as the balls do, so no segment falls back to a straight one that stops at its knots (a
    stop beside a short segment left toppra without a timing: exit 3 on a feasible path)."""
    from foam_mj.planners import PlanningProblem, get_planner
    from foam_mj.timing import timed_trajectory

    (tmp_path / "arm.xml").write_text(TWO_LINK_ARM)
    robot = RobotModel.from_xml(tmp_path / "arm.xml")
    oracle = BubbleOracle(robot)
    problem = PlanningProblem(oracle, np.array([3.0, -2.5]), np.array([-2.75415886, -2.41736182]), delta=oracle.delta)
    rosary = get_planner("bubbletree").plan(problem, seed=0).rosary
    oracle.close()
    path = rosary.path(rosary.center_waypoints())
    traj = timed_trajectory(robot, path, rosary, method=method)
    assert np.all(traj.q >= robot.lower - 1e-9) and np.all(traj.q <= robot.upper + 1e-9)
    assert not traj.curve.linear.any()
    assert np.all(make_trajectory(robot, path, rosary).q >= robot.lower - 1e-9)
