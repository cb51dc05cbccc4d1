"""Tests for issue 7: GOA / PSO, their multi-objective versions MGOA / MOPSO (paper 004), the Pareto archive
and metrics, the planar experiment, and the Pareto smoothers on a real obstacle rosary."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from foam_mj import paths
from foam_mj.foam import plan
from foam_mj.planar2d import CircleMap, PlanarPathProblem, paper_environment, path_length, smoothness
from foam_mj.scenarios import load_scenario
from foam_mj.smoothing.base import SmoothingResult
from foam_mj.smoothing.convex import ConvexShortestPath
from foam_mj.smoothing.goa import GOA, MGOA, MGOASmoother, c_schedule, s_function, social_interaction
from foam_mj.smoothing.multiobjective import ParetoResult, RosaryProblem, length_and_angle
from foam_mj.smoothing.pareto import (
    Archive,
    crowding_distance,
    dominance_matrix,
    dominates,
    error_ratio,
    hypervolume_2d,
    knee_index,
    nondominated_mask,
    prune_by_crowding,
    set_coverage,
)
from foam_mj.smoothing.pso import MOPSO, PSO, MOPSOSmoother

SETTINGS = settings(max_examples=150, deadline=None)

# Small swarms: the benchmark does the paper's 500 x 100.
MGOA_S = MGOASmoother(swarm_size=30, iterations=40, archive_size=20)
MOPSO_S = MOPSOSmoother(swarm_size=30, iterations=40, archive_size=20)
SMOOTHERS = {"MGOA": MGOA_S, "MOPSO": MOPSO_S}


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("obstacle")


@pytest.fixture(scope="module")
def rosary(scenario):
    oracle = scenario.oracle()
    try:
        return plan(oracle, scenario.q_init, scenario.q_goal, scenario.params, seed=0).rosary
    finally:
        oracle.close()


@pytest.fixture(scope="module")
def fronts(rosary) -> dict[str, ParetoResult]:
    return {name: sm.front(rosary, seed=0) for name, sm in SMOOTHERS.items()}


# -- GOA's ingredients ----------------------------------------------------------------------------------
def test_s_function_matches_eq3():
    f, l = 0.5, 1.5
    for r in (0.0, 0.5, 1.0, 2.079, 4.0, 10.0):
        assert s_function(r) == pytest.approx(f * math.exp(-r / l) - math.exp(-r), abs=1e-15)
    assert s_function(0.0) == pytest.approx(-0.5)  # f - 1
    assert abs(s_function(2.079)) < 1e-3  # the comfort zone (paper 004: "2.079")
    r = np.linspace(0.01, 2.07, 50)
    assert np.all(s_function(r) < 0)  # repulsion
    r = np.linspace(2.09, 15.0, 50)
    assert np.all(s_function(r) > 0)  # attraction
    assert s_function(12.0) < 1e-3  # "close to zero ... greater than 10"
    assert s_function(1.0, f=1.0, l=2.0) == pytest.approx(math.exp(-0.5) - math.exp(-1.0))


def test_c_schedule_matches_eq7():
    c = c_schedule(1.0, 1e-5, 100)
    l = np.arange(1, 101)
    np.testing.assert_allclose(c, 1.0 - l * (1.0 - 1e-5) / 100, rtol=0, atol=1e-15)
    assert c[-1] == pytest.approx(1e-5, abs=1e-15)
    assert c[49] == pytest.approx(1.0 - 50 * (1 - 1e-5) / 100)
    assert np.all(np.diff(c) < 0)
    np.testing.assert_allclose(c_schedule(2.0, 0.5, 3), [1.5, 1.0, 0.5])
    with pytest.raises(ValueError, match="c_min"):
        c_schedule(1e-5, 1.0, 10)
    with pytest.raises(ValueError, match="iterations"):
        c_schedule(1.0, 0.1, 0)


def _eq6_naive(X, lb, ub, a=1.0, b=4.0, f=0.5, l=1.5):
    """Eq. 6's sum written out pair by pair (positions scaled to the unit box, per-dimension distances mapped
    onto [a, b])."""
    N, D = X.shape
    U = (X - lb) / (ub - lb)
    S = np.zeros((N, D))
    for i in range(N):
        for j in range(N):
            if i == j:
                continue
            du = U[j] - U[i]
            dij = math.sqrt(float(du @ du))
            for d in range(D):
                S[i, d] += (ub[d] - lb[d]) / 2 * s_function(a + (b - a) * abs(du[d]), f, l) * du[d] / dij
    return S


@pytest.mark.parametrize("l", [1.5, 1.0, 1.7])
def test_social_interaction_is_eq6_in_any_block_size(l):
    rng = np.random.default_rng(3)
    lb, ub = np.array([-1.0, 0.0, 2.0, 0.0]), np.array([1.0, 5.0, 3.0, 0.5])
    X = lb + (ub - lb) * rng.random((23, 4))
    ref = _eq6_naive(X, lb, ub, l=l)
    for block in (1, 7, 100, 1 << 16):
        S = social_interaction(X, lb, ub, l=l, block_elements=block)
        np.testing.assert_allclose(S, ref, atol=1e-12)
        # blocks computed by threads, their sums added in block order: the same numbers
        np.testing.assert_array_equal(social_interaction(X, lb, ub, l=l, block_elements=block, threads=3), S)
    np.testing.assert_allclose(social_interaction(X, lb, ub, l=l, mean=True), ref / 22, atol=1e-12)
    # Two grasshoppers push each other apart or pull together by opposite forces.
    S2 = social_interaction(X[:2], lb, ub, l=l)
    np.testing.assert_allclose(S2[0], -S2[1], atol=1e-15)


def test_goa_update_is_eq6():
    """One MGOA move from a known swarm is c^2 S + T clipped to the box."""
    rng = np.random.default_rng(0)
    lb, ub = np.zeros(3), np.ones(3)
    X = rng.random((10, 3))
    T = np.array([0.4, 0.5, 0.6])
    c = 0.3
    moved = MGOA(swarm_size=10, iterations=5).move(X, T, c, lb, ub)
    np.testing.assert_allclose(moved, np.clip(c * c * _eq6_naive(X, lb, ub) + T, lb, ub), atol=1e-12)


def test_single_objective_goa_and_pso_minimise_a_sphere():
    def sphere(X):
        return np.sum((X - 0.3) ** 2, axis=1)

    lb, ub = -np.ones(4), np.ones(4)
    g = GOA(swarm_size=40, iterations=60, random_social=True).minimize(sphere, lb, ub, seed=1)
    p = PSO(swarm_size=30, iterations=100).minimize(sphere, lb, ub, seed=1)
    for r in (g, p):
        assert r.fun < 1e-3
        assert r.fun == pytest.approx(sphere(r.x[None])[0])
        assert np.all(np.diff(r.history_best) <= 0)
        assert len(r.history_best) == len(r.history_mean) == r.iterations + 1
    assert GOA(swarm_size=40, iterations=60).minimize(sphere, lb, ub, seed=1).fun < 0.05
    # Deterministic
    assert GOA(swarm_size=20, iterations=10).minimize(sphere, lb, ub, seed=4).fun == \
        GOA(swarm_size=20, iterations=10).minimize(sphere, lb, ub, seed=4).fun



def test_an_unseeded_goa_or_pso_run_records_the_seed_that_repeats_it():
    """With seed=None a run draws fresh entropy; it did not say which, so it could not be repeated. Its result now
    holds the integer seed it used (the given one when seeded, None for a Generator), as the smoothers' info["seed"]."""
    def sphere(X):
        return np.sum((X - 0.3) ** 2, axis=1)

    lb, ub = -np.ones(3), np.ones(3)
    for opt in (GOA(swarm_size=10, iterations=5), PSO(swarm_size=10, iterations=5)):
        free = opt.minimize(sphere, lb, ub, seed=None)
        assert isinstance(free.seed, int) and 0 <= free.seed <= 2**63 - 1
        again = opt.minimize(sphere, lb, ub, seed=free.seed)
        assert again.seed == free.seed and np.array_equal(again.x, free.x) and np.array_equal(again.history_best, free.history_best)
        assert opt.minimize(sphere, lb, ub, seed=7).seed == 7
        assert opt.minimize(sphere, lb, ub, seed=np.random.default_rng(7)).seed is None

def test_pso_inertia_schedule_and_validation():
    np.testing.assert_allclose(PSO(iterations=4, inertia=(0.9, 0.5)).weights(), [0.8, 0.7, 0.6, 0.5])
    np.testing.assert_allclose(PSO(iterations=3, inertia=0.4).weights(), [0.4] * 3)
    for kwargs, name in [({"inertia": -0.1}, "inertia"), ({"inertia": (0.9,)}, "inertia"), ({"c1": -1.0}, "c1"),
                         ({"c2": float("nan")}, "c2"), ({"v_max": 0.0}, "v_max"), ({"swarm_size": 0}, "swarm_size"),
                         ({"iterations": 1.5}, "iterations"), ({"archive_size": 0}, "archive_size")]:
        with pytest.raises(ValueError, match=name):
            MOPSO(**kwargs)
    for kwargs, name in [({"c_min": 2.0}, "c_min"), ({"c_max": 0.0}, "c_max"), ({"l": 0.0}, "l"),
                         ({"distance_range": (4.0, 1.0)}, "distance_range"), ({"social": "avg"}, "social"),
                         ({"swarm_size": 1}, "swarm_size"), ({"niche_radius": -1.0}, "niche_radius"),
                         ({"random_social": 1}, "random_social"), ({"threads": 0}, "threads")]:
        with pytest.raises(ValueError, match=name):
            MGOA(**kwargs)
    with pytest.raises(ValueError, match="select"):
        MGOASmoother(select="middle")
    with pytest.raises(ValueError, match="inset"):
        MOPSOSmoother(inset=-1.0)


# -- the archive ---------------------------------------------------------------------------------------
def _assert_archive_invariants(arch: Archive) -> None:
    F, V = arch.F, arch.V
    K = len(F)
    for i in range(K):
        for j in range(K):
            if i != j:
                assert not (V[i] <= 0 and V[j] <= 0 and dominates(F[i], F[j])), (F[i], F[j])
                assert not np.array_equal(F[i], F[j])
    if K:
        assert np.all(V <= 0) or np.all(V == V.min())


objective_batches = st.lists(
    arrays(np.float64, st.tuples(st.integers(1, 25), st.just(2)),
           elements=st.integers(0, 12).map(float)),  # small integers: many ties and duplicates
    min_size=1, max_size=6,
)


@SETTINGS
@given(objective_batches, st.integers(1, 8))
def test_archive_never_holds_a_dominated_pair(batches, capacity):
    arch = Archive(capacity)
    unbounded = Archive(10_000)
    seen = []
    for k, F in enumerate(batches):
        X = np.column_stack([F, np.full(len(F), k)])  # positions carry the objectives
        arch.update(X, F)
        unbounded.update(X, F)
        seen.append(F)
        _assert_archive_invariants(arch)
        _assert_archive_invariants(unbounded)
        assert len(arch) <= capacity
        np.testing.assert_array_equal(arch.X[:, :2], arch.F)
        allF = np.concatenate(seen)
        # Without a bound, every point offered is weakly dominated by a member (the archive is the front).
        assert np.all(np.any(np.all(unbounded.F[None] <= allF[:, None], axis=-1), axis=1))
        # Both extremes (lexicographic minima) survive the crowding pruning.
        if capacity >= 2:
            for j in range(2):
                ext = allF[np.lexsort((allF[:, 1 - j], allF[:, j]))[0]]
                assert any(np.array_equal(ext, f) for f in arch.F)


@SETTINGS
@given(arrays(np.float64, st.tuples(st.integers(1, 30), st.just(2)), elements=st.floats(0, 10)),
       arrays(np.float64, st.integers(1, 30), elements=st.sampled_from([0.0, 0.0, 0.5, 1.0, 2.0])))
def test_archive_constrained_dominance(F, V):
    n = min(len(F), len(V))
    F, V = F[:n], V[:n]
    arch = Archive(100)
    arch.update(F.copy(), F, V)
    _assert_archive_invariants(arch)
    if np.any(V <= 0):
        assert np.all(arch.V <= 0)
        assert len(arch) == int(nondominated_mask(F[V <= 0]).sum())
    else:
        assert np.all(arch.V == V.min())


@SETTINGS
@given(st.integers(3, 40), st.integers(1, 12), st.integers(0, 10_000))
def test_prune_2d_matches_recomputing_loop(K, cap, seed):
    rng = np.random.default_rng(seed)
    f1 = np.sort(rng.choice(1000, K, replace=False)).astype(float)
    f2 = np.sort(rng.choice(1000, K, replace=False))[::-1].astype(float)
    F = np.column_stack([f1, f2])[rng.permutation(K)]
    kept = prune_by_crowding(F, cap)
    # the generic loop
    alive = np.arange(K)
    while len(alive) > cap:
        cd = crowding_distance(F[alive])
        order = np.lexsort((alive, cd))  # smallest distance, then lowest index
        alive = np.delete(alive, order[0])
    np.testing.assert_array_equal(np.sort(kept), np.sort(alive))
    assert len(kept) == min(cap, K)


@SETTINGS
@given(arrays(np.float64, st.tuples(st.integers(1, 40), st.just(2)),
              elements=st.one_of(st.integers(0, 6).map(float), st.floats(0, 10))),
       st.one_of(st.none(), arrays(np.float64, 40, elements=st.sampled_from([0.0, 0.0, 0.5, 1.0, 2.0]))))
def test_nondominated_mask_in_2d_is_the_dominance_matrix_rule(F, V):
    # Two objectives are filtered by sorting; the rule is the K x K constrained-dominance matrix's, first of
    # equal (objectives, violation) rows kept.
    V = None if V is None else V[: len(F)]
    want = ~dominance_matrix(F, V).any(axis=0)
    key = F if V is None else np.column_stack([F, V])
    first = np.zeros(len(F), dtype=bool)
    first[np.unique(key, axis=0, return_index=True)[1]] = True
    np.testing.assert_array_equal(nondominated_mask(F, V), want & first)


def test_leader_selection_favours_sparse_regions():
    arch = Archive(100, niche_radius=0.1)
    crowd = np.column_stack([np.linspace(0.0, 0.05, 20), np.linspace(1.0, 0.95, 20)])
    F = np.vstack([crowd, [[1.0, 0.0]]])
    arch.update(F.copy(), F)
    picks = arch.select(np.random.default_rng(0), 20_000)
    lonely = int(np.flatnonzero(arch.F[:, 0] == 1.0)[0])
    share = np.mean(picks == lonely)
    assert share == pytest.approx(0.5, abs=0.02)  # weight 1 against 20 x 1/20


# -- metrics ----------------------------------------------------------------------------------------------
def test_error_ratio_hand_examples():
    ref = np.array([[1.0, 3.0], [2.0, 2.0], [3.0, 1.0]])
    assert error_ratio([[1.0, 3.0], [2.0, 2.0], [3.0, 3.0]], ref) == pytest.approx(1 / 3)  # (3,3) dominated by (2,2)
    assert error_ratio(ref, ref) == 0.0
    assert error_ratio([[2.0, 4.0], [4.0, 4.0]], ref) == 1.0
    assert error_ratio([[0.5, 5.0], [2.0, 2.5], [3.0, 1.0], [9.0, 9.0]], ref) == pytest.approx(2 / 4)
    with pytest.raises(ValueError, match="empty"):
        error_ratio(np.empty((0, 2)), ref)


def test_set_coverage_hand_examples():
    A = np.array([[1.0, 2.0], [2.0, 1.0]])
    B = np.array([[1.0, 2.0], [2.0, 2.0], [0.0, 5.0]])
    assert set_coverage(A, B) == pytest.approx(2 / 3)  # (1,2) equal (weak), (2,2) dominated, (0,5) not
    assert set_coverage(B, A) == pytest.approx(1 / 2)  # (1,2) covered by its equal, (2,1) by nobody
    assert set_coverage(A, A) == 1.0
    assert set_coverage([[0.0, 0.0]], B) == 1.0
    assert set_coverage([[10.0, 10.0]], B) == 0.0


def test_hypervolume_and_knee_hand_examples():
    F = np.array([[1.0, 3.0], [2.0, 2.0], [3.0, 1.0]])
    # Reference (4, 4): 3x1 + 2x1 + 1x1 strips = 6
    assert hypervolume_2d(F, [4.0, 4.0]) == pytest.approx(6.0)
    assert hypervolume_2d(np.vstack([F, [[3.5, 3.5]]]), [4.0, 4.0]) == pytest.approx(6.0)
    assert knee_index(F) == 1
    assert knee_index(np.array([[0.0, 10.0], [1.0, 1.0], [10.0, 0.0], [9.0, 0.5]])) == 1


# -- the planar experiment ------------------------------------------------------------------------------------
def test_planar_map_and_collision_geometry():
    m1, m2 = paper_environment(1), paper_environment(1)
    np.testing.assert_array_equal(m1.centers, m2.centers)
    assert len(m1.radii) == 80 and len(paper_environment(2).radii) == 50
    np.testing.assert_allclose(m1.start, [70.6, 847.2])
    assert not np.array_equal(m1.centers, paper_environment(1, seed=5).centers)
    for m in (m1, paper_environment(2)):
        assert np.all(np.linalg.norm(m.centers - m.start, axis=1) > m.radii)
        assert np.all(np.linalg.norm(m.centers - m.target, axis=1) > m.radii)
    # Exact segment distances against dense sampling.
    rng = np.random.default_rng(0)
    P = rng.uniform(0, 1000, (50, 4, 2))
    d = m1.segment_distances(P)  # (50, 3, 80)
    t = np.linspace(0, 1, 2001)[:, None]
    for p in range(5):
        for s in range(3):
            pts = P[p, s] + t * (P[p, s + 1] - P[p, s])
            brute = np.min(np.linalg.norm(pts[:, None] - m1.centers, axis=-1), axis=0)
            np.testing.assert_allclose(d[p, s], brute, atol=0.5)
    v = m1.violation(P, 0.0)
    free = np.array([m1.collision_free(p) for p in P])
    np.testing.assert_array_equal(v == 0, free)
    # A segment straight through an obstacle's centre penetrates by its radius.
    c, r = m1.centers[0], m1.radii[0]
    through = np.array([c - [r + 5, 0], c + [r + 5, 0]])
    one = CircleMap(m1.centers[:1], m1.radii[:1], m1.start, m1.target)
    assert one.violation(through) == pytest.approx(r)


@pytest.mark.parametrize("env,n,clearance", [(1, 8, 1.0), (2, 3, 0.0), (1, 15, 6.0)])
def test_planar_broad_phase_gives_the_dense_violation_bit_for_bit(env, n, clearance):
    # "offsets" checks only the segment/circle pairs its fixed stations allow; swarms from hugging the line to
    # crossing many obstacles (paths with 0, 1 and many penetrating pairs) give the dense result exactly.
    prob = PlanarPathProblem(paper_environment(env), n, clearance=clearance)
    assert prob._near is not None and prob._near.mean() < 0.5
    rng = np.random.default_rng(env)
    for scale in (0.01, 0.2, 1.0):
        X = prob.sample(rng, 200) * scale
        dense = prob.map.violation(prob.paths(X), clearance)
        assert np.count_nonzero(dense) > 0 or scale < 1
        np.testing.assert_array_equal(prob.evaluate(X)[1], dense)


@pytest.mark.parametrize("delta", [0.0, 0.5])
def test_planar_objectives_equal_path_length_and_smoothness_bit_for_bit(delta):
    # evaluate() computes F1, F2 per coordinate; the public functions reduce over (x, y): the same numbers
    prob = PlanarPathProblem(paper_environment(2), 6, delta=delta)
    X = prob.sample(np.random.default_rng(3), 100)
    X[:3] = X[3]  # duplicates
    X[4] = 0.0  # the straight line: every turning angle 0
    P = prob.paths(X)
    want = np.stack([path_length(P), smoothness(P, delta)], axis=-1)
    np.testing.assert_array_equal(prob.evaluate(X)[0], want)


def test_planar_problem_parametrizations_and_objectives():
    cmap = paper_environment(2)
    prob = PlanarPathProblem(cmap, 6)
    X = prob.sample(np.random.default_rng(0), 200)
    P = prob.paths(X)
    assert P.shape == (200, 8, 2)
    assert np.all((P >= -1e-9) & (P <= 1000 + 1e-9))  # offsets bounded to keep waypoints on the map
    np.testing.assert_allclose(P[:, 0], np.broadcast_to(cmap.start, (200, 2)))
    np.testing.assert_allclose(P[:, -1], np.broadcast_to(cmap.target, (200, 2)))
    # Waypoints at the n + 1 equal divisions of SP -> TP, offset normal to it.
    along = (P[:, 1:-1] - cmap.start) @ prob.e
    np.testing.assert_allclose(along, np.broadcast_to(np.arange(1, 7) / 7 * np.linalg.norm(cmap.target - cmap.start), (200, 6)))
    F, V = prob.evaluate(X)
    np.testing.assert_allclose(F[:, 0], paths.path_length(P))
    np.testing.assert_allclose(F[:, 1], paths.turning_angles(P).sum(axis=1), atol=1e-12)
    np.testing.assert_allclose(V, cmap.violation(P, prob.clearance))
    straight = prob.paths(prob.straight())
    assert smoothness(straight) == pytest.approx(0.0, abs=1e-6)
    assert smoothness(straight, delta=0.5) == pytest.approx(0.5 * 7, abs=1e-6)
    # The literal "angle at the target" reading: hand example, a right angle seen from the target.
    sq = np.array([[0.0, 1.0], [1.0, 0.0], [0.5, 0.5], [0.0, 0.0]])
    assert smoothness(sq, mode="target") == pytest.approx(math.pi / 2 + math.pi / 4)
    pts = PlanarPathProblem(cmap, 3, parametrization="points")
    assert pts.dim == 6 and np.all(pts.ub == 1000)
    with pytest.raises(ValueError, match="parametrization"):
        PlanarPathProblem(cmap, 3, parametrization="polar")
    with pytest.raises(ValueError, match="n_waypoints"):
        PlanarPathProblem(cmap, 0)


def test_planar_mgoa_and_mopso_fronts():
    prob = PlanarPathProblem(paper_environment(2), 5)
    runs = {"MGOA": MGOA(swarm_size=60, iterations=30, random_social=True).run(prob, seed=0),
            "MOPSO": MOPSO(swarm_size=60, iterations=30).run(prob, seed=0)}
    for name, r in runs.items():
        assert r.feasible, name
        F = r.objectives
        assert not dominates(F[:, None], F[None]).any()
        np.testing.assert_allclose(prob.evaluate(r.X)[0], F)
        for p in prob.paths(r.X):
            assert prob.map.collision_free(p, prob.clearance)
        assert len(r.history["archive_size"]) == r.iterations + 1
        feas = r.history["archive_feasible"] > 0
        assert feas[-1] and np.all(np.diff(feas.astype(int)) >= 0)  # once feasible, always feasible
        assert np.all(np.diff(r.history["best_F1"][feas]) <= 1e-9)  # the archive keeps its shortest feasible path
    A, B = runs["MGOA"].objectives, runs["MOPSO"].objectives
    ref = np.concatenate([A, B])
    for x in (error_ratio(A, ref), error_ratio(B, ref), set_coverage(A, B), set_coverage(B, A)):
        assert 0.0 <= x <= 1.0
    again = MOPSO(swarm_size=60, iterations=30).run(prob, seed=0)
    np.testing.assert_array_equal(again.X, runs["MOPSO"].X)


# -- on a real rosary ------------------------------------------------------------------------------------------
def test_rosary_problem_objectives_and_projection(rosary):
    prob = RosaryProblem(rosary)
    rng = np.random.default_rng(0)
    X = prob.sample(rng, 50)
    W = prob.waypoints(X)
    assert rosary.all_in_hatches(W, tol=0.0)
    P = rosary.path(W)
    F, V = prob.evaluate(X)
    np.testing.assert_allclose(F[:, 0], paths.path_length(P), rtol=1e-13)
    np.testing.assert_allclose(F[:, 1], paths.angle_term(P), atol=1e-12)
    np.testing.assert_allclose(length_and_angle(P).sum(axis=1), paths.objective(P), rtol=1e-13)
    assert np.all(V == 0)
    # Repair projects a wild swarm back into the hatches.
    wild = prob.lb + (prob.ub - prob.lb) * rng.uniform(-0.5, 1.5, (40, prob.dim))
    assert rosary.all_in_hatches(prob.waypoints(prob.repair(wild)), tol=0.0)


@pytest.mark.parametrize("name", list(SMOOTHERS))
def test_rosary_front_in_hatches_nondominated_and_consistent(name, rosary, fronts):
    pr = fronts[name]
    F = pr.front_objectives
    assert pr.front_waypoints.shape == (pr.size, rosary.n_hatches, rosary.dim)
    assert pr.front_paths.shape == (pr.size, rosary.k + 1, rosary.dim)
    assert rosary.all_in_hatches(pr.front_waypoints, tol=0.0)
    assert pr.all_in_hatches()
    assert 1 <= pr.size <= 20
    assert not dominates(F[:, None], F[None]).any()
    assert np.all(np.diff(F[:, 0]) > 0) and np.all(np.diff(F[:, 1]) < 0)  # sorted by length
    np.testing.assert_allclose(F[:, 0], paths.path_length(pr.front_paths), rtol=1e-12)
    np.testing.assert_allclose(F[:, 1], paths.angle_term(pr.front_paths), atol=1e-12)
    assert pr.extremes == (0, pr.size - 1)
    assert pr.knee == knee_index(F)
    # The convex path is the shortest through the hatches.
    convex = ConvexShortestPath().smooth(rosary).length
    assert F[:, 0].min() >= convex - 2e-6 * rosary.k
    h = pr.history
    n = pr.iterations + 1
    assert all(len(v) == n for v in h.values())
    assert np.all(np.diff(h["best_length"]) <= 1e-12) and np.all(np.diff(h["best_angle_term"]) <= 1e-12)
    assert h["best_f"][-1] == pytest.approx(pr.f.min())
    assert h["hypervolume"][-1] >= h["hypervolume"][0]
    assert pr.evaluations == SMOOTHERS[name].swarm_size * n


@pytest.mark.parametrize("name", list(SMOOTHERS))
def test_rosary_front_paths_are_collision_free(name, scenario, fronts):
    robot = scenario.robot
    for p in fronts[name].front_paths:
        dense = paths.densify(p, 1e-3)
        assert not any(robot.in_collision(q) for q in dense)


@pytest.mark.parametrize("name", list(SMOOTHERS))
def test_rosary_same_seed_same_front(name, rosary, fronts):
    again = SMOOTHERS[name].front(rosary, seed=0)
    np.testing.assert_array_equal(again.front_waypoints, fronts[name].front_waypoints)
    np.testing.assert_array_equal(again.front_objectives, fronts[name].front_objectives)
    other = SMOOTHERS[name].front(rosary, seed=np.random.default_rng(7))
    assert not np.array_equal(other.front_objectives, fronts[name].front_objectives)


def test_smooth_returns_the_knee_with_the_front(rosary, fronts):
    r = MGOA_S.smooth(rosary, seed=0)
    pr = fronts["MGOA"]
    assert isinstance(r, SmoothingResult) and r.method == "MGOA"
    np.testing.assert_array_equal(r.waypoints, pr.front_waypoints[pr.knee])
    assert r.length == pytest.approx(pr.front_objectives[pr.knee, 0])
    assert r.angle_term == pytest.approx(pr.front_objectives[pr.knee, 1])
    assert r.in_hatches()
    front = r.info["front"]
    np.testing.assert_array_equal(front["objectives"], pr.front_objectives)
    assert front["knee"] == pr.knee and front["extremes"] == list(pr.extremes)
    assert front["objective_names"] == ["length", "angle_term"]
    assert r.history_best[-1] == pytest.approx(pr.f.min())
    shortest = MOPSOSmoother(swarm_size=30, iterations=40, archive_size=20, select="shortest").smooth(rosary, seed=0)
    assert shortest.length == pytest.approx(fronts["MOPSO"].lengths.min())
    assert pr.result("min_f").f == pytest.approx(pr.f.min())
    # An initial path inside the hatches joins the swarm; one outside is refused.
    init = rosary.center_waypoints()
    assert MOPSO_S.front(rosary, init, seed=0).size >= 1
    with pytest.raises(ValueError, match="outside their hatches"):
        MOPSO_S.front(rosary, init + 1.0, seed=0)
