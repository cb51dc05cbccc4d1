"""Tests for foam_mj.smoothing on a real obstacle rosary: hatches, MuJoCo safety, gains, optimality, determinism."""

from __future__ import annotations

import warnings
from dataclasses import replace
from foam_mj.data import model_path

import numpy as np
import pytest
from scipy.optimize import minimize

from foam_mj import paths
from foam_mj.bubbles import BubbleOracle
from foam_mj.foam import FoamParams, plan
from foam_mj.model import RobotModel
from foam_mj.rosary import Rosary
from foam_mj.smoothing import (
    ConvexShortestPath,
    GeneticAlgorithm,
    GradientSmoothing,
    HarmonySearch,
    Hatches,
    MGOASmoother,
    MOPSOSmoother,
    OptimalSmoother,
    RosaryAdjustment,
    SmoothingResult,
    StopCriteria,
    center_path_result,
)

Q_INIT = [0.2, 0.3, 0.08]
Q_GOAL = [0.45, 0.4536, 1.45]
R_MIN = 0.07
SEEDS = (0, 1, 2)

# Small budgets: the benchmark does the long runs.
HS = HarmonySearch(stop=StopCriteria(max_iterations=1500))
GA = GeneticAlgorithm(stop=StopCriteria(max_iterations=300))
GA_UNIFORM = GeneticAlgorithm(beta=None, stop=StopCriteria(max_iterations=300))
GRAD = GradientSmoothing(stop=StopCriteria(max_iterations=1500, stall_iterations=100, stall_tol=1e-5))
STOCHASTIC = {"HS": HS, "GA": GA, "GA-uniform-beta": GA_UNIFORM}


@pytest.fixture(scope="session")
def smoothing_setup():
    robot = RobotModel.from_xml(model_path("obstacle.xml"))
    oracle = BubbleOracle(robot, delta=0.005)
    res = plan(oracle, Q_INIT, Q_GOAL, FoamParams(K=10, r_min=R_MIN, delta=0.005), seed=0)
    return robot, oracle, res.rosary


@pytest.fixture(scope="session")
def rosary(smoothing_setup):
    return smoothing_setup[2]


@pytest.fixture(scope="session")
def adjusted(smoothing_setup):
    _, oracle, rosary = smoothing_setup
    return RosaryAdjustment(r_min=R_MIN).adjust(rosary, oracle)


@pytest.fixture(scope="session")
def stochastic_results(rosary) -> dict[tuple[str, int], SmoothingResult]:
    return {(name, s): sm.smooth(rosary, seed=s) for name, sm in STOCHASTIC.items() for s in SEEDS}


@pytest.fixture(scope="session")
def all_results(rosary, adjusted, stochastic_results) -> dict[str, SmoothingResult]:
    """One result per method (the stochastic ones for every seed), each with the rosary that holds it."""
    out = {f"{name}/{s}": r for (name, s), r in stochastic_results.items()}
    out["T_CA"] = GRAD.smooth(rosary)
    out["T_RA"] = adjusted.path
    out["T_RCA"] = GRAD.smooth(adjusted.rosary)
    out["convex"] = ConvexShortestPath().smooth(rosary)
    out["convex-smooth"] = ConvexShortestPath(smoothness=10.0).smooth(rosary)
    return out


def assert_collision_free(robot: RobotModel, oracle: BubbleOracle, path: np.ndarray) -> None:
    """Dense MuJoCo check: clearance > 0 at every sample 1e-3 apart (max-norm), and mj_collision (independent
    of the clearance code) finds no contact at any of them."""
    dense = paths.densify(path, 1e-3)
    clearance = oracle.clearance.batch(dense)
    assert np.all(clearance > 0), f"clearance {clearance.min():.3g} m at sample {int(np.argmin(clearance))}"
    # Every sample lies in a certified bubble, so the clearance keeps the margin delta too.
    assert clearance.min() >= oracle.delta - 1e-9
    assert not any(robot.in_collision(q) for q in dense)


# -- hatches and safety -------------------------------------------------------------------------------
def test_every_waypoint_in_its_hatch(all_results):
    for name, r in all_results.items():
        assert r.waypoints.shape == (r.rosary.n_hatches, r.rosary.dim), name
        # A centre path (T_RA) has each waypoint on its parent's surface: the rosary's membership tolerance.
        assert r.rosary.all_in_hatches(r.waypoints, tol=1e-12 if name == "T_RA" else 0.0), name
        np.testing.assert_array_equal(r.path[0], r.rosary.q_init)
        np.testing.assert_array_equal(r.path[-1], r.rosary.q_goal)


def test_paths_are_collision_free_under_dense_mujoco_check(smoothing_setup, all_results):
    robot, oracle, _ = smoothing_setup
    for name, r in all_results.items():
        assert_collision_free(robot, oracle, r.path)


def test_convex_waypoints_strictly_inside(all_results):
    for name in ("convex", "convex-smooth"):
        r = all_results[name]
        h = Hatches.of(r.rosary)
        inset = r.info["inset"]
        da = np.linalg.norm(r.waypoints - h.ca, axis=1) - h.ra
        db = np.linalg.norm(r.waypoints - h.cb, axis=1) - h.rb
        assert max(da.max(), db.max()) <= -inset / 2


# -- improvement -------------------------------------------------------------------------------------
def test_f_and_sv_improve_on_centre_path(rosary, all_results):
    centre = center_path_result(rosary)
    for name, r in all_results.items():
        assert r.f < centre.f, name
        assert r.sv < centre.sv, name
    assert all_results["T_RA"].tc > centre.tc  # Eq. 8 is an ascent of TC


def test_histories_are_consistent(stochastic_results):
    for (name, _), r in stochastic_results.items():
        assert len(r.history_best) == len(r.history_mean) == r.iterations
        assert np.all(np.diff(r.history_best) <= 0), name  # HS memory and GA elitism keep the best
        assert np.all(r.history_mean >= r.history_best - 1e-12)
        assert r.history_best[-1] == pytest.approx(r.f, abs=1e-12)
        assert r.evaluations > r.iterations and r.wall_time > 0


# -- the convex reference ----------------------------------------------------------------------------
def test_convex_length_is_a_lower_bound(rosary, adjusted, all_results):
    best = {id(rosary): all_results["convex"].length,
            id(adjusted.rosary): ConvexShortestPath().smooth(adjusted.rosary).length}
    # Every other path in the same hatches is at least as long, up to the inset's slack (~2e-6 per hatch).
    slack = 2e-6 * rosary.k + 1e-7
    for name, r in all_results.items():
        assert r.length >= best[id(r.rosary)] - slack, name


def _kkt_residual(r: SmoothingResult, inset: float) -> float:
    """Largest stationarity residual of the shortest-path problem at r's waypoints: the length gradient plus
    a non-negative combination of the active ball constraints' gradients (found by NNLS; inactive balls get
    no multiplier) must vanish. Waypoints that coincide (a zero-length segment, whose subgradient is any
    vector of the unit ball) are checked as one point: summing their conditions cancels that subgradient."""
    from scipy.optimize import nnls

    h = Hatches.of(r.rosary)
    p = r.path
    seg = np.diff(p, axis=0)
    lens = np.linalg.norm(seg, axis=1)
    u = seg / np.maximum(lens, 1e-300)[:, None]
    m = h.m
    groups, cur = [], [0]
    for i in range(1, m):
        if lens[i] < 1e-6:  # segment from waypoint i-1 to waypoint i (path indices i, i+1)
            cur.append(i)
        else:
            groups.append(cur)
            cur = [i]
    groups.append(cur)
    worst = 0.0
    for g in groups:
        grad = u[g[0]] - u[g[-1] + 1]  # incoming segment of the first, outgoing of the last
        cols = []
        for i in g:
            w = p[i + 1]
            for c, rad in ((h.ca[i], h.ra[i] - inset), (h.cb[i], h.rb[i] - inset)):
                if np.linalg.norm(w - c) >= rad - 1e-6:  # active
                    cols.append((w - c) / np.linalg.norm(w - c))
        res = nnls(np.array(cols).T, -grad)[1] if cols else float(np.linalg.norm(grad))
        worst = max(worst, res)
    return worst


def test_convex_satisfies_kkt_and_matches_slsqp(rosary, all_results):
    r = all_results["convex"]
    inset = r.info["inset"]
    assert _kkt_residual(r, inset) < 1e-4
    # scipy SLSQP from several starts on the same (shrunk) problem reaches no shorter path.
    h = Hatches.of(rosary)
    m, n = h.m, rosary.dim

    def length(x):
        return float(paths.path_length(rosary.path(x.reshape(m, n))))

    def length_grad(x):
        p = rosary.path(x.reshape(m, n))
        u = np.diff(p, axis=0)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        return (u[:-1] - u[1:]).ravel()

    def cons(x):
        w = x.reshape(m, n)
        return np.concatenate([(h.ra - inset) ** 2 - np.sum((w - h.ca) ** 2, 1),
                               (h.rb - inset) ** 2 - np.sum((w - h.cb) ** 2, 1)])

    rng = np.random.default_rng(0)
    starts = [rosary.portal_waypoints(), rosary.sample_hatches(rng), rosary.sample_hatches(rng)]
    for x0 in starts:
        sol = minimize(length, h.project(x0, inset).ravel(), jac=length_grad, method="SLSQP",
                       constraints=[{"type": "ineq", "fun": cons}], options={"maxiter": 500, "ftol": 1e-12})
        assert sol.success, sol.message
        assert np.all(cons(sol.x) >= -1e-9)
        assert r.length <= sol.fun + 1e-7
        assert sol.fun == pytest.approx(r.length, abs=1e-5)  # convex: every start reaches the optimum


def test_smoothness_weight_trades_length_for_smoothness(all_results):
    short, smooth = all_results["convex"], all_results["convex-smooth"]
    assert smooth.length >= short.length - 1e-9
    assert smooth.sv < short.sv


# -- the rosary adjustment ---------------------------------------------------------------------------
def test_adjusted_rosary_is_certified_and_a_valid_chain(smoothing_setup, adjusted):
    _, oracle, rosary = smoothing_setup
    a = adjusted.rosary
    assert a.k == rosary.k
    assert a.check_structure(tol=0.0) == []
    np.testing.assert_array_equal(a.centers[0], rosary.q_init)
    cert = oracle.radii(a.centers)  # re-certified here with MuJoCo, independently of the adjustment
    assert np.all(a.radii <= cert + 1e-9)
    assert np.all(a.radii >= R_MIN - 1e-12)
    # Every child's centre on its parent's surface.
    np.testing.assert_allclose(np.linalg.norm(np.diff(a.centers, axis=0), axis=1), a.radii[:-1], rtol=0, atol=1e-12)
    assert np.linalg.norm(a.q_goal - a.centers[-1]) <= a.radii[-1]
    assert adjusted.path.tc > paths.tc(rosary.path(rosary.center_waypoints()))
    assert np.all(np.diff(adjusted.path.history_best) >= 0)


def test_adjusted_bubbles_are_free_under_mujoco(smoothing_setup, adjusted):
    """Sample each adjusted bubble (surface and interior): mj_collision finds no contact anywhere."""
    robot, oracle, _ = smoothing_setup
    a = adjusted.rosary
    rng = np.random.default_rng(1)
    u = rng.normal(size=(a.k, 60, a.dim))
    u /= np.linalg.norm(u, axis=2, keepdims=True)
    s = np.concatenate([np.ones((a.k, 30)), rng.random((a.k, 30)) ** (1 / a.dim)], axis=1)
    pts = (a.centers[:, None] + u * (s * a.radii[:, None])[..., None]).reshape(-1, a.dim)
    assert np.all(oracle.clearance.batch(pts) > 0)
    assert not any(robot.in_collision(q) for q in pts)


def test_adjustment_rejects_an_inconsistent_rosary(smoothing_setup, rosary):
    _, oracle, _ = smoothing_setup
    with pytest.raises(ValueError, match="constraints"):
        RosaryAdjustment(r_min=10 * R_MIN).adjust(rosary, oracle)



def test_the_adjustment_names_its_arguments_and_lists_a_few_broken_links(smoothing_setup, rosary):
    """adjust(rosary, robot) was "'RobotModel' object has no attribute 'robot'", adjust(foam, oracle) "'Foam' object has no
    attribute 'dim'"; a rosary that breaks the constraints at every link listed all of them (a screenful on a long one)."""
    robot, oracle, _ = smoothing_setup
    foam = plan(oracle, Q_INIT, Q_GOAL, FoamParams(K=10, r_min=R_MIN, delta=0.005), seed=0).foam
    with pytest.raises(TypeError, match=r"^`oracle` must be a foam_mj.bubbles.BubbleOracle \(BubbleOracle\(robot, delta\)\), got RobotModel$"):
        RosaryAdjustment(r_min=R_MIN).adjust(rosary, robot)
    with pytest.raises(TypeError, match=r"^`rosary` must be a foam_mj.rosary.Rosary \(a plan's result.rosary, not result.foam\), got Foam$"):
        RosaryAdjustment(r_min=R_MIN).adjust(foam, oracle)
    assert rosary.k - 1 > 8
    with pytest.raises(ValueError, match=rf"^the rosary given does not satisfy the adjustment's constraints: links \[0, 1, 2, 3, 4, 5, 6, "
                                         rf"7, \.\.\. \({rosary.k - 1} in all\)\] \(of {rosary.k - 1}\) break r_min"):
        RosaryAdjustment(r_min=100 * R_MIN).adjust(rosary, oracle)
    far = rosary.center_waypoints() + 10.0
    with pytest.raises(ValueError, match=rf"^initial waypoints \[0, 1, 2, 3, 4, 5, 6, 7, \.\.\. \({len(far)} in all\)\] \(of {len(far)}\) "
                                         r"lie outside their hatches$"):
        HS.smooth(rosary, initial=far)


def test_adjustment_rejects_a_rosary_whose_last_bubble_does_not_hold_the_goal(smoothing_setup, rosary):
    """Its constraints include q_goal in the goal bubble: a goal a millimetre (of q) beyond that bubble is refused
    before any move, rather than adjusted into a chain whose last segment leaves the certified bubbles."""
    from foam_mj.rosary import Rosary

    _, oracle, _ = smoothing_setup
    u = (rosary.q_goal - rosary.centers[-1]) / np.linalg.norm(rosary.q_goal - rosary.centers[-1])
    away = Rosary(rosary.centers, rosary.radii, rosary.q_init, rosary.centers[-1] + (rosary.radii[-1] + 1e-3) * u)
    with pytest.raises(ValueError, match="q_goal"):
        RosaryAdjustment(r_min=R_MIN).adjust(away, oracle)

# -- determinism and stopping ------------------------------------------------------------------------
@pytest.mark.parametrize("smoother", [HarmonySearch(), GeneticAlgorithm(), GradientSmoothing(), ConvexShortestPath(),
                                      OptimalSmoother(), MGOASmoother(), MOPSOSmoother()], ids=lambda s: type(s).__name__)
def test_smoothing_something_else_than_a_rosary_names_the_argument(smoothing_setup, smoother):
    """A plan's result.foam (or None) given for the rosary was an AttributeError ('Foam' object has no attribute
    'n_hatches') from inside the smoother."""
    robot, oracle, rosary = smoothing_setup
    foam = plan(oracle, Q_INIT, Q_GOAL, FoamParams(K=10, r_min=R_MIN, delta=0.005), seed=0).foam
    with pytest.raises(TypeError, match=r"`rosary` must be a foam_mj.rosary.Rosary \(a plan's result.rosary, not result.foam\), got Foam"):
        smoother.smooth(foam)
    with pytest.raises(TypeError, match=r"`rosary` must be a foam_mj.rosary.Rosary \(a plan's result.rosary\), got NoneType"):
        smoother.smooth(None)
    with pytest.raises(TypeError, match=r"initial waypoints must be an array of numbers"):
        smoother.smooth(rosary, "centre")


@pytest.mark.parametrize("name", list(STOCHASTIC))
def test_same_seed_same_result(rosary, stochastic_results, name):
    again = STOCHASTIC[name].smooth(rosary, seed=SEEDS[1])
    first = stochastic_results[(name, SEEDS[1])]
    np.testing.assert_array_equal(again.waypoints, first.waypoints)
    np.testing.assert_array_equal(again.history_mean, first.history_mean)
    other = stochastic_results[(name, SEEDS[2])]
    assert not np.array_equal(other.waypoints, first.waypoints)
    gen = STOCHASTIC[name].smooth(rosary, seed=np.random.default_rng(SEEDS[1]))
    np.testing.assert_array_equal(gen.waypoints, first.waypoints)


def test_deterministic_methods_repeat(smoothing_setup, rosary, adjusted, all_results):
    _, oracle, _ = smoothing_setup
    np.testing.assert_array_equal(GRAD.smooth(rosary).waypoints, all_results["T_CA"].waypoints)
    np.testing.assert_array_equal(ConvexShortestPath().smooth(rosary).waypoints, all_results["convex"].waypoints)
    again = RosaryAdjustment(r_min=R_MIN, stop=StopCriteria(max_iterations=30)).adjust(rosary, oracle)
    again2 = RosaryAdjustment(r_min=R_MIN, stop=StopCriteria(max_iterations=30)).adjust(rosary, oracle)
    np.testing.assert_array_equal(again.rosary.centers, again2.rosary.centers)


def test_harmony_search_speculative_blocks_equal_sequential_run(rosary):
    """A run capped at 400 improvisations is exactly the first 400 of a longer run (the speculative block
    sizes differ near the cap, the result may not)."""
    short = HarmonySearch(stop=StopCriteria(max_iterations=400, stall_iterations=None)).smooth(rosary, seed=7)
    long = HarmonySearch(stop=StopCriteria(max_iterations=900, stall_iterations=None)).smooth(rosary, seed=7)
    np.testing.assert_array_equal(short.history_mean, long.history_mean[:400])
    np.testing.assert_array_equal(short.history_best, long.history_best[:400])


def test_stop_criteria(rosary):
    centre_f = center_path_result(rosary).f
    r = HarmonySearch(stop=StopCriteria(f_threshold=centre_f, max_iterations=5000)).smooth(rosary, seed=0)
    assert r.stop_reason == "f threshold" and r.f < centre_f
    r = GeneticAlgorithm(stop=StopCriteria(stall_iterations=5, max_iterations=5000)).smooth(rosary, seed=0)
    assert r.stop_reason == "stall"
    lowest = np.minimum.accumulate(r.history_mean)
    assert np.all(lowest[-5:] == lowest[-6])  # no new lowest mean in the last 5 generations
    r = HarmonySearch(stop=StopCriteria(max_iterations=123, stall_iterations=None)).smooth(rosary, seed=0)
    assert r.stop_reason == "iteration cap" and r.iterations == 123 and r.evaluations == 50 + 123


def test_initial_path_is_validated_and_used(rosary):
    centre = rosary.center_waypoints()
    with pytest.raises(ValueError, match="shape"):
        HS.smooth(rosary, initial=centre[:-1])
    bad = centre.copy()
    bad[3] += 10.0
    with pytest.raises(ValueError, match=r"outside their hatches"):
        GA.smooth(rosary, initial=bad)
    # Seeded with the convex optimum, GA's elitism never returns anything worse. (The optimum may have two
    # coincident waypoints; the angles next to a ~1e-9 segment are ill-conditioned, hence the tolerance.)
    opt = ConvexShortestPath().smooth(rosary)
    r = replace(GA, stop=StopCriteria(max_iterations=5)).smooth(rosary, initial=opt.waypoints, seed=0)
    assert r.f <= opt.f + 1e-9


def test_single_bubble_rosary_needs_no_smoothing(smoothing_setup):
    _, oracle, _ = smoothing_setup
    q = np.array(Q_INIT)
    r0 = oracle.radius(q)
    one = Rosary(q[None], np.array([r0]), q, q + np.array([r0 / 2, 0, 0]))
    for sm in (HS, GA, GRAD, ConvexShortestPath()):
        r = sm.smooth(one, seed=0)
        assert r.waypoints.shape == (0, 3) and r.stop_reason == "nothing to smooth"
        np.testing.assert_array_equal(r.path, [one.q_init, one.q_goal])
    a = RosaryAdjustment(r_min=R_MIN).adjust(one, oracle)
    assert a.rosary is one


# -- the fast implementations make the generic code's iterates -------------------------------------
# GradientSmoothing, GeneticAlgorithm and RosaryAdjustment run specialised, preallocated code (see their
# modules). The references below are the straightforward implementations of the same algorithms with the
# generic functions; the runs must agree step for step (bit for bit on x86-64; the tolerances only allow
# for a platform whose einsum adds a short axis in another order).
from foam_mj.smoothing import coordinate_major_objective, sv_and_gradient  # noqa: E402
from foam_mj.smoothing.base import MeanStall, as_generator  # noqa: E402
from foam_mj.smoothing.genetic import CHUNK  # noqa: E402


def reference_gradient_smoothing(sm: GradientSmoothing, rosary: Rosary):
    h = Hatches.of(rosary)
    w = h.project(rosary.center_waypoints(), sm.inset)
    path = rosary.path(w)
    sv, grad = sv_and_gradient(path)
    best_w, best = w.copy(), float(sv)
    stall = MeanStall(best, sm.stop.stall_tol)
    hist, t, reason = [], 0, sm.stop.reason(0, best, 0)
    while reason is None:
        new = h.project(w - sm.eta * grad[1:-1], sm.inset)
        step = float(np.max(np.abs(new - w)))
        w = new
        path[1:-1] = w
        sv, grad = sv_and_gradient(path)
        t += 1
        if float(sv) < best:
            best, best_w = float(sv), w.copy()
        stall.update(float(sv))
        hist.append(best)
        reason = sm.stop.reason(t, best, stall.count)
        if reason is None and step <= sm.tol:
            reason = "converged"
    return best_w, np.array(hist), t, reason


def test_gradient_smoothing_makes_the_reference_iterates(rosary, adjusted, all_results):
    for name, ros in (("T_CA", rosary), ("T_RCA", adjusted.rosary)):
        w, hist, t, reason = reference_gradient_smoothing(GRAD, ros)
        r = all_results[name]
        assert (r.iterations, r.stop_reason) == (t, reason)
        np.testing.assert_allclose(r.history_best, hist, rtol=1e-12, atol=0)
        np.testing.assert_allclose(r.waypoints, w, rtol=0, atol=1e-12)


def reference_ga(ga: GeneticAlgorithm, rosary: Rosary, seed: int):
    rng = as_generator(seed)
    h = Hatches.of(rosary)
    m, n, P = h.m, rosary.dim, ga.pop_size
    pop = np.empty((n, P, m + 2))
    pop[:, :, 0] = rosary.q_init[:, None]
    pop[:, :, -1] = rosary.q_goal[:, None]
    pop[:, :, 1:-1] = h.sample(rng, np.broadcast_to(np.arange(m), (P, m))).transpose(2, 0, 1)
    fit = coordinate_major_objective(pop)
    cum_rank = np.cumsum(1.0 / np.sqrt(np.arange(1, P + 1)))
    cum_rank /= cum_rank[-1]
    means, cpos = [], CHUNK
    for _ in range(ga.stop.max_iterations):
        if cpos >= CHUNK:
            sel_u, no_cross, beta, mut_gen, mut_pos, mut_alpha = ga._draw(rng, P, m)
            mut_bounds = np.searchsorted(mut_gen, np.arange(CHUNK + 1))
            cpos = 0
        if ga.selection == "rank":
            ranks = np.minimum(np.searchsorted(cum_rank, sel_u[cpos], side="right"), P - 1)
            parents = np.argsort(fit, kind="stable")[ranks]
        else:
            w = 1.0 / np.maximum(fit, 1e-300) if ga.selection == "inverse" else fit.max() - fit + 1e-12
            cw = np.cumsum(w)
            parents = np.minimum(np.searchsorted(cw, sel_u[cpos] * cw[-1], side="right"), P - 1)
        a, b = parents[:P], parents[P:]
        better = fit[a] <= fit[b]
        x1 = pop[:, np.where(better, a, b)]
        child = x1 + beta[cpos] * (x1 - pop[:, np.where(better, b, a)])
        bi, bw = h.outside_cm(child[:, :, 1:-1]).nonzero()
        child[:, bi, bw + 1] = x1[:, bi, bw + 1]
        nc = no_cross[cpos]
        child[:, nc] = pop[:, a[nc]]
        lo, hi = mut_bounds[cpos], mut_bounds[cpos + 1]
        ind, wp = np.divmod(mut_pos[lo:hi], m)
        mutated = child[:, ind, wp + 1] * mut_alpha[lo:hi]
        ok = ((np.sum((mutated.T - h.ca[wp]) ** 2, axis=1) <= h.ra[wp] ** 2)
              & (np.sum((mutated.T - h.cb[wp]) ** 2, axis=1) <= h.rb[wp] ** 2))
        child[:, ind[ok], wp[ok] + 1] = mutated[:, ok]
        f = coordinate_major_objective(child)
        if ga.elitism:
            i_old, i_worst = int(fit.argmin()), int(f.argmax())
            child[:, i_worst] = pop[:, i_old]
            f[i_worst] = fit[i_old]
        pop, fit = child, f
        means.append(float(fit.sum()) / P)
        cpos += 1
    return pop[:, int(fit.argmin()), 1:-1].T, np.array(means)


@pytest.mark.parametrize(
    "options", [{}, {"beta": None}, {"selection": "rank"}, {"selection": "linear", "mut_prob": 0.01}]
)
def test_genetic_algorithm_makes_the_reference_generations(rosary, options):
    ga = GeneticAlgorithm(stop=StopCriteria(max_iterations=300, stall_iterations=None), **options)
    r = ga.smooth(rosary, seed=5)
    w, means = reference_ga(ga, rosary, seed=5)
    np.testing.assert_allclose(r.history_mean, means, rtol=1e-12, atol=0)
    np.testing.assert_allclose(r.waypoints, w, rtol=0, atol=1e-12)


class ReferenceAdjustment(RosaryAdjustment):
    """Eq. 8 with the plain constrained step: every trial position's radius fetched, every round."""

    def _constrained_step(self, c, cert, step, q_goal, r_min, oracle, hint=None):
        k = len(c)
        scale = np.ones(k - 1)
        for rnd in range(self.max_halvings + 1):
            cand = c.copy()
            cand[1:] += scale[:, None] * step
            cand_cert = cert.copy()
            cand_cert[1:] = oracle.radii(cand[1:])
            bad = self._bad_centres(cand, cand_cert, q_goal, r_min)
            if not bad.any():
                return cand, cand_cert, True
            if rnd < self.max_halvings:
                scale[bad] /= 2
        for _ in range(k):
            bad = self._bad_centres(cand, cand_cert, q_goal, r_min) & (scale > 0)
            if not bad.any():
                break
            scale[bad] = 0.0
            back = np.flatnonzero(bad) + 1
            cand[back], cand_cert[back] = c[back], cert[back]
        moved = bool(np.any(scale > 0))
        return (cand, cand_cert, True) if moved else (c, cert, False)


def test_rosary_adjustment_makes_the_reference_steps(smoothing_setup, rosary):
    _, oracle, _ = smoothing_setup
    stop = StopCriteria(max_iterations=40, stall_iterations=None)
    got = RosaryAdjustment(r_min=R_MIN, stop=stop).adjust(rosary, oracle)
    want = ReferenceAdjustment(r_min=R_MIN, stop=stop).adjust(rosary, oracle)
    np.testing.assert_array_equal(got.rosary.centers, want.rosary.centers)
    np.testing.assert_array_equal(got.rosary.radii, want.rosary.radii)
    np.testing.assert_array_equal(got.certified_radii, want.certified_radii)
    np.testing.assert_array_equal(got.path.history_mean, want.path.history_mean)
    assert got.path.iterations == want.path.iterations == 40
    assert got.oracle_calls < want.oracle_calls  # radii fetched only when a decision needs them


def test_rosary_adjustment_survives_a_wrong_lipschitz_bound(smoothing_setup, rosary, monkeypatch):
    """The radius bounds that spare MuJoCo calls are checked: with every reference radius overstated (so
    that links are wrongly taken to hold), the returned chain still carries the radii MuJoCo gives at its
    centres and is the chain of fetching every radius (the run is redone)."""
    import foam_mj.smoothing.adjust as adjust_module

    _, oracle, _ = smoothing_setup
    stop = StopCriteria(max_iterations=40, stall_iterations=None)
    want = ReferenceAdjustment(r_min=R_MIN, stop=stop).adjust(rosary, oracle)

    class Overstated(adjust_module._RadiusMemory):
        def __init__(self, c, cert, margin=adjust_module._LIPSCHITZ_MARGIN, exact=False):
            super().__init__(c, cert, margin, exact)
            if np.isfinite(self.margin):
                self.r = self.r + 1.0

    monkeypatch.setattr(adjust_module, "_RadiusMemory", Overstated)
    got = RosaryAdjustment(r_min=R_MIN, stop=stop).adjust(rosary, oracle)
    np.testing.assert_array_equal(got.certified_radii, oracle.radii(got.rosary.centers))
    np.testing.assert_array_equal(got.rosary.centers, want.rosary.centers)
    np.testing.assert_array_equal(got.path.history_mean, want.path.history_mean)


def test_a_seed_outside_the_planners_range_is_named():
    """seed=-1 failed inside numpy ("expected non-negative integer"), naming no argument; True was seed 1; and 2**63
    or 2**64 - 1 were taken, where a planner, a scenario and --seed take [0, 2**63 - 1] (a seed one of them refuses
    could not be recorded and repeated by the others)."""
    from foam_mj.smoothing.base import as_generator

    for seed in (-1, True, 1.5, "0", 2**63, np.uint64(2**64 - 1)):
        with pytest.raises(ValueError, match=r"^`seed` must be an integer in \[0, 2\*\*63 - 1\], a numpy Generator or None, got"):
            as_generator(seed)
    for sm in EDGE_SMOOTHERS:  # also those that draw nothing (convex, gradient)
        with pytest.raises(ValueError, match=r"^`seed` must be an integer in \[0, 2\*\*63 - 1\]"):
            sm.smooth(_chain([1.0, 1.0]), seed=2**63)
    g = np.random.default_rng(0)
    assert as_generator(g) is g and as_generator(np.int64(3)).integers(1 << 30) == np.random.default_rng(3).integers(1 << 30)
    assert as_generator(2**63 - 1).integers(1 << 30) == np.random.default_rng(2**63 - 1).integers(1 << 30)


# -- rosaries at the edges: bubbles far below the insets, one joint, seeds of the deterministic methods --------
from foam_mj.smoothing import MGOASmoother, MOPSOSmoother, OptimalSmoother  # noqa: E402


def _chain(radii, n: int = 3) -> Rosary:
    """A zig-zag chain: each centre on its parent's surface, q_goal inside the last bubble."""
    step = np.zeros(n)
    step[0] = 1.0
    side = np.zeros(n)
    side[-1] = 1.0 if n > 1 else 0.0
    c = [np.zeros(n)]
    for i, r in enumerate(radii[:-1]):
        d = step + (side if i % 2 else 0.0)
        c.append(c[-1] + r * d / np.linalg.norm(d))
    c = np.array(c)
    return Rosary(c, np.array(radii, dtype=float), c[0].copy(), c[-1] + 0.5 * radii[-1] * step)


EDGE_SMOOTHERS = (HS, GA, GRAD, ConvexShortestPath(), OptimalSmoother(),
                  MGOASmoother(iterations=5, swarm_size=20), MOPSOSmoother(iterations=5, swarm_size=20))


@pytest.mark.parametrize("radii", [[1e-6] * 3, [1e-9] * 5, [1.0, 1e-7, 1.0, 1e-4]])
def test_bubbles_smaller_than_the_insets_are_smoothed(radii):
    """A start a micrometre beyond delta gets a bubble of that size (gbpf and its variants accept it as the root):
    the convex and optimal smoothers refused such a rosary ('inset 1e-06 is too large for the rosary's smallest
    ball', exit 1 after planning), MGOA and MOPSO one below 2e-9. The insets now shrink to fit the hatches."""
    ros = _chain(radii)
    for sm in EDGE_SMOOTHERS:
        r = sm.smooth(ros, seed=0)
        assert r.in_hatches() and np.all(np.isfinite(r.path)), type(sm).__name__
        np.testing.assert_array_equal(r.path[[0, -1]], [ros.q_init, ros.q_goal])


def test_a_run_without_a_seed_records_the_seed_it_drew_and_that_seed_repeats_it():
    """seed=None drew fresh entropy and kept none of it, so a run worth keeping could not be repeated: every smoother
    that draws random numbers records the integer seed of its run in info["seed"] (the given one, or one drawn in
    [0, 2**63 - 1]), None for a Generator, whose seed it does not know."""
    ros = _chain([1.0, 0.8, 1.0, 0.7, 1.0])
    for sm in (HS, GA, OptimalSmoother(multistart=2), MGOASmoother(iterations=5, swarm_size=20),
               MOPSOSmoother(iterations=5, swarm_size=20)):
        a, b = sm.smooth(ros, seed=None), sm.smooth(ros, seed=None)
        drawn = a.info["seed"]
        assert type(drawn) is int and 0 <= drawn <= 2**63 - 1 and drawn != b.info["seed"], type(sm).__name__
        again = sm.smooth(ros, seed=drawn)
        assert again.info["seed"] == drawn and sm.smooth(ros, seed=7).info["seed"] == 7
        np.testing.assert_array_equal(again.path, a.path)
        np.testing.assert_array_equal(again.history_best, a.history_best)
        assert sm.smooth(ros, seed=np.random.default_rng(drawn)).info["seed"] is None


@pytest.mark.parametrize(
    "centers, radii, q_goal, problem",
    [
        ([[0.0, 0.0], [3.0, 0.0]], [1.0, 1.0], [3.0, 0.0], r"bubbles \[0\] do not overlap their successors"),
        ([[0.0, 0.0], [1.0, 0.0]], [1.0, 1.0], [5.0, 0.0], r"q_goal is not in the last bubble"),
        ([[0.0, 0.0]], [1.0], [5.0, 0.0], r"q_goal is not in the last bubble"),
    ],
)
def test_a_rosary_that_is_not_a_chain_is_refused_by_every_smoother(centers, radii, q_goal, problem):
    """A hand-made rosary whose q_goal lay outside its last bubble was smoothed: every method returned a path whose
    last segment left the bubbles (the optimal smoother's straight line to q_goal), uncertified."""
    ros = Rosary(np.array(centers), np.array(radii), np.zeros(2), np.array(q_goal))
    for sm in EDGE_SMOOTHERS:
        with pytest.raises(ValueError, match=r"the rosary is not a chain from q_init to q_goal: " + problem):
            sm.smooth(ros, seed=0)



def test_a_one_joint_rosary_is_smoothed_by_every_method():
    """Gradient smoothing ended in an IndexError with one coordinate, and the hatch projection warned
    (a division by zero for the normal of its rim, which one coordinate does not have)."""
    ros = _chain([0.5, 0.4, 0.3], n=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for sm in EDGE_SMOOTHERS:
            r = sm.smooth(ros, seed=0)
            assert r.in_hatches() and r.f == pytest.approx(abs(ros.q_goal[0] - ros.q_init[0])), type(sm).__name__


@pytest.mark.parametrize("smoother", [GRAD, ConvexShortestPath()])
def test_deterministic_methods_still_refuse_a_bad_seed(rosary, smoother):
    """They draw nothing, but seed='a' or -1 was silently accepted where the other methods refuse it."""
    for seed in (-1, True, "a", 2**63):
        with pytest.raises(ValueError, match=r"`seed` must be an integer in \[0, 2\*\*63 - 1\]"):
            smoother.smooth(rosary, seed=seed)


def test_gradient_smoothing_shortens_its_step_for_small_bubbles():
    """Eq. 9's eta = 0.005 overshoots on a chain of 1 cm bubbles (SV's gradient grows as 1 / segment length):
    every step raised SV and T_CA came back equal to T (a 1 cm corridor planned by gbpf, seen in QA). A run that
    never lowers SV is repeated with a ten times shorter step; on the papers' rosaries eta stays 0.005."""
    ros = _chain([0.01] * 60, n=2)
    r = GradientSmoothing().smooth(ros)
    assert r.sv < 1e-2 * center_path_result(ros).sv and r.in_hatches()
    assert r.info["eta"] < 0.005 and r.info["eta_retries"] >= 1
    assert len(r.history_best) == r.iterations and np.all(np.diff(r.history_best) <= 0)



def test_gradient_smoothings_iteration_cap_counts_every_step_of_its_shorter_step_runs():
    """StopCriteria(max_iterations=50) on the chain of 1 cm bubbles: the run with eta = 0.005 used its 50 steps without
    lowering SV and each shorter-step run got 50 more, 150 steps in all (up to 7 x the cap: 140,000 under the default
    20,000). The cap is the smoother's budget of steps: the runs share it, so no result has more steps than the cap, and
    a run that ends on it is not repeated."""
    ros = _chain([0.01] * 60, n=2)
    for cap in (50, 120):
        r = GradientSmoothing(stop=StopCriteria(max_iterations=cap, stall_iterations=None)).smooth(ros)
        assert r.iterations <= cap and len(r.history_best) == r.iterations, (cap, r.iterations, r.info)
        assert r.stop_reason == "iteration cap" and r.in_hatches()


def test_gradient_smoothing_keeps_the_thesis_step_where_it_works(all_results):
    for name in ("T_CA", "T_RCA"):
        assert all_results[name].info["eta"] == 0.005 and all_results[name].info["eta_retries"] == 0


@pytest.mark.parametrize("name", ["HS", "GA"])
def test_long_runs_report_progress_without_changing_the_result(rosary, monkeypatch, name):
    """The GA took 23 s on a 166-bubble rosary with nothing on the screen (2 x 10^4 generations at most, each
    linear in the rosary's length); HS and the GA now tell a ``progress`` callback the iterations and best f."""
    from foam_mj.smoothing import genetic, harmony

    monkeypatch.setattr(genetic, "PROGRESS_INTERVAL", 0.0)
    monkeypatch.setattr(harmony, "PROGRESS_INTERVAL", 0.0)
    sm = STOCHASTIC[name]
    heard: list[tuple[int, float]] = []
    r = sm.smooth(rosary, seed=1, progress=lambda t, best: heard.append((t, best)))
    t, best = np.array(heard).T
    assert t[-1] == r.iterations and np.all(np.diff(t) > 0) and np.all(np.diff(best) <= 0)
    np.testing.assert_array_equal(best, r.history_best[t.astype(int) - 1])
    np.testing.assert_array_equal(r.path, sm.smooth(rosary, seed=1).path)


def test_plan_reports_the_generations_of_the_genetic_algorithm(smoothing_setup, monkeypatch):
    from foam_mj import pipeline
    from foam_mj.scenarios import load_scenario
    from foam_mj.smoothing import genetic

    monkeypatch.setattr(genetic, "PROGRESS_INTERVAL", 0.0)
    monkeypatch.setattr(pipeline, "GeneticAlgorithm", lambda: GA)
    said: list[str] = []
    pipeline.smooth_paths(load_scenario("obstacle"), smoothing_setup[2], ("ga",), 0, report=said.append)
    assert "smoothing: genetic algorithm, generation 300 of at most 300, best f " in said[-2]
    assert said[-1].startswith("smoothing: genetic algorithm done in ")


def test_a_script_picks_a_smoother_by_its_smoother_flag_name_as_a_planner_by_name(rosary):
    """`get_smoother(name, **params)` is to smoothers what `get_planner` is to planners: every `--smoother` name
    that smooths a rosary alone has a class, the same parameters give the same path as the class itself, and an
    unknown name or parameter is named with what there is (the rosary adjustment needs the oracle: said so)."""
    from foam_mj.smoother_names import SMOOTHERS
    from foam_mj.smoothing import SMOOTHER_CLASSES, get_smoother

    assert set(SMOOTHER_CLASSES) == set(SMOOTHERS) - {"none", "all", "adjust"}
    hs = get_smoother("hs", stop=StopCriteria(max_iterations=200))
    assert isinstance(hs, HarmonySearch) and hs.stop.max_iterations == 200
    a = get_smoother("optimal").smooth(rosary, seed=0)
    b = OptimalSmoother().smooth(rosary, seed=0)
    assert np.array_equal(a.waypoints, b.waypoints) and rosary.all_in_hatches(a.waypoints)
    with pytest.raises(ValueError, match=r"unknown smoother 'optimum' \(did you mean 'optimal'\?\); known smoothers: hs, ga, "):
        get_smoother("optimum")
    with pytest.raises(ValueError, match=r"needs the oracle: RosaryAdjustment"):
        get_smoother("adjust")
    with pytest.raises(TypeError, match=r"smoother 'ga' \(GeneticAlgorithm\) has no parameter 'popsize'.*its parameters: pop_size, "):
        get_smoother("ga", popsize=10)
    with pytest.raises(ValueError, match="HMCR"):
        get_smoother("hs", HMCR=1.5)
