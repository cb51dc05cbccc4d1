"""Tests for foam_mj.smoothing's parts: the vectorized objective, SV/TC gradients, hatch projection, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from foam_mj import paths
from foam_mj.rosary import Rosary
from foam_mj.smoothing import (
    ConvexShortestPath,
    GeneticAlgorithm,
    GradientSmoothing,
    HarmonySearch,
    Hatches,
    RosaryAdjustment,
    StopCriteria,
    coordinate_major_objective,
    population_objective,
    sv_and_gradient,
    tc_and_gradient,
)

SETTINGS = settings(max_examples=200, deadline=None)


def reference_f(path: list[list[float]]) -> float:
    """Paper 000 Eq. 4-5 for one path, written out plainly: mean (pi - theta_i) over the interior vertices
    plus the length, theta_i the angle at q'_(i+1) between q'_i - q'_(i+1) and q'_(i+2) - q'_(i+1)."""
    length = sum(math.dist(a, b) for a, b in zip(path[:-1], path[1:]))
    segs = [[y - x for x, y in zip(a, b)] for a, b in zip(path[:-1], path[1:])]
    nonzero = [j for j, s in enumerate(segs) if math.hypot(*s) > 1e-12]
    # A zero-length segment takes the direction of the next non-zero one (else the previous one).
    for j in range(len(segs)):
        if j not in nonzero and nonzero:
            later = [i for i in nonzero if i > j]
            segs[j] = segs[later[0] if later else nonzero[-1]]
    terms = []
    for i in range(len(path) - 2):
        u = [-x for x in segs[i]]
        v = segs[i + 1]
        nu, nv = math.hypot(*u), math.hypot(*v)
        if nu * nv <= 1e-24:
            theta = math.pi  # every segment has zero length
        else:
            c = sum(x * y for x, y in zip(u, v)) / (nu * nv)
            theta = math.acos(max(-1.0, min(1.0, c)))
        terms.append(math.pi - theta)
    return (sum(terms) / len(terms) if terms else 0.0) + length


def reference_sv(path: np.ndarray) -> float:
    t = []
    for i in range(1, len(path) - 1):
        a, b = path[i] - path[i - 1], path[i + 1] - path[i]
        c = np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b))
        t.append(math.acos(max(-1.0, min(1.0, c))) ** 2)
    return sum(t) / len(t)


populations = st.integers(1, 6).flatmap(
    lambda P: st.integers(3, 12).flatmap(
        lambda L: st.integers(2, 4).flatmap(
            lambda n: arrays(np.float64, (P, L, n), elements=st.floats(-3, 3, allow_nan=False, width=64))
        )
    )
)


@SETTINGS
@given(populations, st.booleans())
def test_vectorized_objective_equals_plain_reference(pop, repeat_point):
    if repeat_point:  # a zero-length segment somewhere
        pop = pop.copy()
        pop[:, 1] = pop[:, 0]
    want = np.array([reference_f(p.tolist()) for p in pop])
    # arccos is ill-conditioned at a full reversal (cos = -1): a rounding of 1e-16 in the cosine moves
    # the angle by up to ~1.5e-8, whichever way the cosine is computed.
    tol = dict(rtol=1e-12, atol=1e-7)
    np.testing.assert_allclose(population_objective(pop), want, **tol)
    np.testing.assert_allclose(coordinate_major_objective(np.ascontiguousarray(pop.transpose(2, 0, 1))), want, **tol)
    np.testing.assert_allclose(paths.objective(pop), want, **tol)


@SETTINGS
@given(arrays(np.float64, (7, 3), elements=st.floats(-2, 2, width=64)))
def test_sv_gradient_matches_finite_differences(p):
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    ang = paths.turning_angles(p)
    # Finite differences need a smooth neighbourhood: segments not tiny, turns away from 0 and pi.
    if seg.min() < 0.05 or ang.min() < 0.05 or ang.max() > math.pi - 0.05:
        return
    sv, g = sv_and_gradient(p)
    assert sv == pytest.approx(reference_sv(p), rel=1e-12, abs=1e-12)
    h = 1e-6
    num = np.zeros_like(p)
    for i in range(len(p)):
        for j in range(p.shape[1]):
            e = np.zeros_like(p)
            e[i, j] = h
            num[i, j] = (sv_and_gradient(p + e)[0] - sv_and_gradient(p - e)[0]) / (2 * h)
    np.testing.assert_allclose(g, num, atol=1e-5 * max(1.0, np.abs(num).max()))


def test_tc_gradient_matches_finite_differences():
    rng = np.random.default_rng(0)
    p = rng.normal(size=(9, 3))
    tc, g = tc_and_gradient(p)
    assert tc == pytest.approx(paths.tc(p))
    h = 1e-6
    for i in range(1, len(p) - 1):
        for j in range(3):
            e = np.zeros_like(p)
            e[i, j] = h
            num = (tc_and_gradient(p + e)[0] - tc_and_gradient(p - e)[0]) / (2 * h)
            assert g[i, j] == pytest.approx(num, abs=1e-7)
    assert np.all(g[[0, -1]] == 0)


def test_sv_gradient_at_straight_vertex_is_finite():
    p = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 1, 0]])
    sv, g = sv_and_gradient(p)
    assert np.all(np.isfinite(g)) and sv > 0


two_balls = st.tuples(
    st.floats(0.05, 1.0), st.floats(0.05, 1.0), st.floats(0.0, 1.0),
    arrays(np.float64, (3,), elements=st.floats(-1, 1)), st.integers(0, 2**32 - 1),
)


@SETTINGS
@given(two_balls)
def test_projection_onto_lens_is_inside_and_nearest(args):
    ra, rb, frac, direction, seed = args
    if np.linalg.norm(direction) < 1e-3 or frac < 1e-3:
        return
    u = direction / np.linalg.norm(direction)
    # Centre distance from nested (0) to a thin lens (0.8 (ra + rb): thinner lenses make the rejection
    # sampling below slow).
    d = frac * 0.8 * (ra + rb)
    ca, cb = np.zeros(3), d * u
    ros = Rosary(np.array([ca, cb]), np.array([ra, rb]), ca, cb)
    h = Hatches.of(ros)
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(40, 1, 3)) * 1.5
    p = h.project(x)
    assert np.all(h.inside(p, -1e-9))
    inside_pts = ros.sample_hatches(rng, 400)[:, 0]
    for xi, pi in zip(x[:, 0], p[:, 0]):
        best_sample = np.min(np.linalg.norm(inside_pts - xi, axis=1))
        assert np.linalg.norm(pi - xi) <= best_sample + 1e-9
    # Points inside stay put.
    np.testing.assert_array_equal(h.project(inside_pts[:, None]), inside_pts[:, None])
    # The shrunk lens: strictly inside.
    q = h.project(x, inset=1e-3)
    assert np.all(h.inside(q, 1e-3 - 1e-9))


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: HarmonySearch(HMCR=1.5), r"HMCR must be in \[0, 1\], got 1.5"),
        (lambda: HarmonySearch(PAR=-0.1), r"PAR must be in \[0, 1\]"),
        (lambda: HarmonySearch(BW=-1.0), r"BW must be in \[0, 1\].*, got -1.0"),
        (lambda: HarmonySearch(BW=1.5), r"BW must be in \[0, 1\] \(Nascimento et al. 2020 Eq. 1\), got 1.5"),
        (lambda: HarmonySearch(HMS=0), r"HMS must be an integer >= 1"),
        (lambda: HarmonySearch(HMS=2.5), r"HMS must be an integer"),
        (lambda: GeneticAlgorithm(pop_size=1), r"pop_size must be an integer >= 2"),
        (lambda: GeneticAlgorithm(cross_prob=2), r"cross_prob must be in \[0, 1\]"),
        (lambda: GeneticAlgorithm(mut_prob=-1e-3), r"mut_prob must be in \[0, 1\]"),
        (lambda: GeneticAlgorithm(beta=1.3), r"beta must be in \[0, 1\]"),
        (lambda: GeneticAlgorithm(alpha_range=(1.1, 0.9)), r"alpha_range must be finite with a <= b"),
        (lambda: GeneticAlgorithm(selection="tournament"), r"selection must be one of"),
        (lambda: StopCriteria(max_iterations=None, stall_iterations=None), r"cannot both be None"),
        (lambda: StopCriteria(max_iterations=0), r"max_iterations must be an integer >= 1"),
        (lambda: StopCriteria(f_threshold=float("nan")), r"f_threshold must be a finite number"),
        (lambda: StopCriteria(stall_tol=-1.0), r"stall_tol must be >= 0"),
        (lambda: GradientSmoothing(eta=0.0), r"eta must be > 0"),
        (lambda: GradientSmoothing(eta=1.5), r"eta must be in \(0, 1\] \(Nascimento and Alsina 2021 Eq. 9\), got 1.5"),
        (lambda: RosaryAdjustment(r_min=0.07, eta=2), r"eta must be in \(0, 1\] \(Nascimento and Alsina 2021 Eq. 8\), got 2"),
        (lambda: RosaryAdjustment(r_min=-0.07), r"r_min must be > 0"),
        (lambda: RosaryAdjustment(r_min=0.07, eta=float("inf")), r"eta must be > 0 and finite"),
        (lambda: ConvexShortestPath(smoothness=-1.0), r"smoothness must be >= 0"),
        (lambda: ConvexShortestPath(inset=0.0), r"inset must be > 0"),
    ],
)
def test_bad_parameters_raise_value_error_naming_them(make, message):
    """Ranges are the papers' where they give one: BW in [0, 1] (Nascimento et al. 2020 Eq. 1), eta in (0, 1]
    (Nascimento and Alsina 2021 Eq. 8 and 9; BW = 1.5 and eta = 2 were accepted before)."""
    with pytest.raises(ValueError, match=message):
        make()


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: HarmonySearch(HMCR=True), r"HMCR must be in \[0, 1\], got True"),
        (lambda: HarmonySearch(BW=True), r"BW must be in \[0, 1\].*, got True"),
        (lambda: GeneticAlgorithm(mut_prob=True), r"mut_prob must be in \[0, 1\], got True"),
        (lambda: GeneticAlgorithm(alpha_range=(True, 2.0)), r"alpha_range must be a pair of numbers"),
        (lambda: GeneticAlgorithm(alpha_range=("0.9", "1.1")), r"alpha_range must be a pair of numbers"),
        (lambda: StopCriteria(f_threshold=True), r"f_threshold must be a finite number or None, got True"),
        (lambda: GradientSmoothing(eta=True), r"eta must be > 0 and finite, got True"),
        (lambda: RosaryAdjustment(r_min=True), r"r_min must be > 0 and finite, got True"),
    ],
)
def test_a_boolean_is_not_a_number_parameter(make, message):
    """True passed for a rate, a step or a radius was taken as 1 (HMCR=True: always from memory)."""
    with pytest.raises(ValueError, match=message):
        make()


def test_alpha_range_takes_any_pair_of_numbers():
    for pair in ((0.9, 1.1), [0.9, 1.1], np.array([0.9, 1.1]), (np.float32(0.9), 1)):
        GeneticAlgorithm(alpha_range=pair)


def test_stop_criteria_order_and_reasons():
    s = StopCriteria(f_threshold=1.0, max_iterations=10, stall_iterations=3)
    assert s.reason(0, 2.0, 0) is None
    assert s.reason(5, 0.5, 0) == "f threshold"
    assert s.reason(5, 2.0, 3) == "stall"
    assert s.reason(10, 2.0, 0) == "iteration cap"


# -- the specialised fast paths equal the generic code ----------------------------------------------
# Gradient smoothing, the GA and the rosary adjustment run on preallocated, flat, fewer-call versions of
# the functions above (see their modules). They do the same floating-point operations: on x86-64 the
# results are bit-identical; the tolerances below only allow for a platform whose einsum adds a
# short axis in another order.
from foam_mj.smoothing.adjust import _tc_and_step  # noqa: E402
from foam_mj.smoothing.genetic import _OutsideHatches, _PopulationObjective  # noqa: E402
from foam_mj.smoothing.gradient import _EPS, _LensProjection, _PathSV  # noqa: E402

TIGHT = dict(rtol=1e-12, atol=1e-14)


@st.composite
def single_paths(draw):
    """A path (L, n) with, at times, repeated points (zero-length segments), straight or reversed vertices."""
    L, n = draw(st.integers(3, 12)), draw(st.integers(2, 4))
    p = draw(arrays(np.float64, (L, n), elements=st.floats(-3, 3, allow_nan=False, width=64)))
    p = p.copy()
    kind = draw(st.sampled_from(["plain", "repeat", "straight", "reverse"]))
    i = draw(st.integers(1, L - 2))
    if kind == "repeat":
        p[i] = p[i - 1]
    elif kind == "straight":  # p[i] halfway between its neighbours: theta = 0 (up to rounding)
        p[i] = 0.5 * (p[i - 1] + p[i + 1])
    elif kind == "reverse":
        p[i + 1] = p[i - 1]
    return p


@SETTINGS
@given(single_paths())
def test_path_sv_kernel_equals_sv_and_gradient(p):
    L, n = p.shape
    seg = np.diff(p, axis=0)
    ls = np.sqrt(np.einsum("ij,ij->i", seg, seg))
    den = ls[:-1] * ls[1:]
    # |a||b| within a factor 4 of the zero-segment threshold: the kernel's |a||b| (other summation order)
    # may fall on the other side of it and take the other branch (a vertex counted or not): not a
    # property of the kernel.
    assume(not np.any((den > _EPS / 4) & (den < 4 * _EPS)))
    turn = den > _EPS
    cos = np.einsum("ij,ij->i", seg[:-1], seg[1:]) / np.where(turn, den, 1.0)
    reversal = bool(np.any(turn & (cos < -1 + 1e-9)))
    sv, g = sv_and_gradient(p)
    kernel = _PathSV(L - 2, n)
    for _ in range(2):  # the buffers are reused: a second call gives the same
        sv2, g2 = kernel(np.ascontiguousarray(p.T))
        # At a full reversal arccos is ill-conditioned (cos = -1 +- 1e-16 moves the angle ~1.5e-8), and
        # theta / sin(theta) with it; elsewhere the two differ by rounding only (the kernel's coordinate
        # sums, or the generic code on a transposed view where a segment has zero length: hypothesis
        # found 6e-13 of the gradient's scale next to a repeated point).
        assert sv2 == pytest.approx(float(sv), rel=1e-12, abs=1e-7)
        scale = max(1.0, float(np.abs(g).max()))
        np.testing.assert_allclose(g2[:, 1:-1].T, g[1:-1], rtol=1e-12, atol=(1e-7 if reversal else 1e-12) * scale)


@st.composite
def chains_and_trials(draw):
    """Hatches of a random chain of balls (as a Rosary: nested, thin, even disjoint pairs) and trial paths
    around them, some on a lens's axis."""
    m, n = draw(st.integers(1, 6)), draw(st.integers(2, 4))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    centers = np.cumsum(rng.normal(size=(m + 1, n)) * 0.4, axis=0)
    if draw(st.booleans()):  # centres on a line: the lens axes are the first coordinate axis
        centers[:, 1:] = 0.0
    radii = rng.uniform(0.05, 0.8, size=m + 1)
    ros = Rosary(centers, radii, centers[0], centers[-1])
    trials = centers[1:][None] + rng.normal(size=(6, m, n)) * rng.uniform(0.01, 1.0)
    trials[0] = 0.5 * (centers[:-1] + centers[1:])  # often inside both balls
    trials[1] = centers[:-1]  # on the axes (ball a's centre)
    trials[2, :, 0] += 5.0  # far away
    return ros, trials, draw(st.sampled_from([0.0, 1e-10, 1e-3]))


@SETTINGS
@given(chains_and_trials())
def test_lens_projection_kernel_equals_hatches_project(args):
    ros, trials, inset = args
    h = Hatches.of(ros)
    if np.any(h.ra <= inset) or np.any(h.rb <= inset):
        return
    proj = _LensProjection(h, inset, ros.q_init, ros.q_goal)
    out = np.empty((ros.dim, ros.k + 1))
    for w in trials:
        x = np.ascontiguousarray(ros.path(w).T)
        got = proj(x, out)
        np.testing.assert_allclose(got[:, 1:-1].T, h.project(w, inset), **TIGHT)
        np.testing.assert_array_equal(got[:, [0, -1]], x[:, [0, -1]])  # the ends stay put


def test_lens_projection_kernel_is_exact_for_inside_points():
    ros = Rosary(np.array([[0.0, 0, 0], [0.5, 0, 0], [0.5, 0.5, 0]]), np.array([0.6, 0.6, 0.6]),
                 np.zeros(3), np.array([0.5, 0.5, 0]))
    h = Hatches.of(ros)
    w = ros.sample_hatches(np.random.default_rng(0))
    x = np.ascontiguousarray(ros.path(w).T)
    np.testing.assert_array_equal(_LensProjection(h, 0.0, ros.q_init, ros.q_goal)(x, np.empty_like(x)), x)


@SETTINGS
@given(populations, st.booleans())
def test_population_objective_kernel_equals_coordinate_major_objective(pop, repeat_point):
    if repeat_point:
        pop = pop.copy()
        pop[:, 1] = pop[:, 0]
    X = np.ascontiguousarray(pop.transpose(2, 0, 1))
    n, P, L = X.shape
    kernel = _PopulationObjective(n, P, L)
    want = coordinate_major_objective(X)
    np.testing.assert_allclose(kernel(X), want, **TIGHT)
    np.testing.assert_allclose(kernel(X), want, **TIGHT)  # buffers reused
    # sized for more paths (Harmony Search's blocks): any number up to that, in any order
    big = _PopulationObjective(n, P + 3, L)
    for b in (P, 1, P, max(P - 1, 1)):
        Xb = np.ascontiguousarray(X[:, :b])
        np.testing.assert_allclose(big(Xb), want[:b], **TIGHT)


@SETTINGS
@given(chains_and_trials(), st.integers(1, 5))
def test_outside_hatches_kernel_equals_outside_cm(args, P):
    ros, trials, _ = args
    h = Hatches.of(ros)
    X = np.ascontiguousarray(ros.path(trials[:P]).transpose(2, 0, 1))  # (n, P, L)
    kernel = _OutsideHatches(h, P + 2, ros.q_init, ros.q_goal)  # sized for more paths: any number up to that
    for b in (P, 1, P):
        Xb = np.ascontiguousarray(X[:, :b])
        want = np.zeros((b, ros.k + 1), dtype=bool)  # the ends are never outside
        want[:, 1:-1] = h.outside_cm(Xb[:, :, 1:-1])
        np.testing.assert_array_equal(kernel(Xb), np.flatnonzero(want))


def test_tc_step_equals_tc_and_gradient():
    rng = np.random.default_rng(3)
    for L in (3, 4, 9, 30):
        p = rng.normal(size=(L, 3))
        tc, g = tc_and_gradient(p)
        tc2, step = _tc_and_step(p, 0.1)
        assert tc2 == float(tc)
        np.testing.assert_array_equal(step, 0.1 * g[1:-1])


@pytest.mark.parametrize("gap", [1e-2, 1e-3, 1e-4])
def test_hatch_sampling_reaches_thin_lenses_in_five_dimensions(gap):
    """Two unit balls 2 - gap apart in 5-D: their lens holds a vanishing share of either ball (rejection in the smaller
    ball alone gives up); the points are uniform in the lens, so symmetric about its middle."""
    from foam_mj.rosary import Rosary

    n = 5
    q0, q1 = np.zeros(n), np.r_[2 - gap + 0.5, np.zeros(n - 1)]
    ros = Rosary(np.array([np.zeros(n), np.r_[2 - gap, np.zeros(n - 1)]]), np.array([1.0, 1.0]), q0, q1)
    h = Hatches.of(ros)
    pts = h.sample(np.random.default_rng(0), np.zeros(500, dtype=int))
    d0 = np.linalg.norm(pts, axis=1)
    d1 = np.linalg.norm(pts - ros.centers[1], axis=1)
    assert np.all(d0 <= 1 + 1e-12) and np.all(d1 <= 1 + 1e-12)
    assert abs(pts[:, 0].mean() - (2 - gap) / 2) < 0.1 * gap + 1e-6


def reference_sample(h: Hatches, rng: np.random.Generator, idx: np.ndarray) -> np.ndarray:
    """Hatches.sample written plainly: rejection in the smaller ball of each hatch, every round's pending
    points re-gathered, then (after BALL_ROUNDS) in the lens's bounding cylinder."""
    from foam_mj.smoothing.base import BALL_ROUNDS, _lens_cylinder_points

    n = h.ca.shape[1]
    small_a = h.ra <= h.rb
    cs = np.where(small_a[:, None], h.ca, h.cb)[idx]
    rs = np.where(small_a, h.ra, h.rb)[idx]
    co = np.where(small_a[:, None], h.cb, h.ca)[idx]
    ro = np.where(small_a, h.rb, h.ra)[idx]
    out = np.empty((len(idx), n))
    todo = np.arange(len(idx))
    for round_ in range(1000):
        if todo.size == 0:
            break
        if round_ < BALL_ROUNDS:
            g = rng.standard_normal((todo.size, n))
            g /= np.linalg.norm(g, axis=1, keepdims=True)
            pts = cs[todo] + g * (rs[todo] * rng.random(todo.size) ** (1.0 / n))[:, None]
        else:
            pts = _lens_cylinder_points(rng, cs[todo], rs[todo], co[todo], ro[todo])
        ok = (np.sum((pts - co[todo]) ** 2, axis=1) <= ro[todo] ** 2) & (np.sum((pts - cs[todo]) ** 2, axis=1) <= rs[todo] ** 2)
        out[todo[ok]] = pts[ok]
        todo = todo[~ok]
    return out


@SETTINGS
@given(st.integers(1, 6), st.integers(2, 6), st.floats(1e-4, 1.0), st.integers(0, 2**32 - 1))
def test_hatch_sampling_equals_the_plain_rejection_loop_draw_for_draw(m, n, overlap, seed):
    """Hatches.sample (its pending points' balls kept compacted) draws the same points as the plain loop and
    leaves the generator in the same state; thin lenses (small ``overlap``) reach the cylinder rounds."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(size=(m, n))
    steps /= np.linalg.norm(steps, axis=1, keepdims=True)
    centers = np.vstack([np.zeros(n), np.cumsum(steps, axis=0)])  # unit steps
    radii = 0.5 + overlap * rng.uniform(0.1, 0.5, size=m + 1)  # overlapping neighbours, some lenses thin
    ros = Rosary(centers, radii, centers[0], centers[-1])
    h = Hatches.of(ros)
    idx = rng.integers(0, m, size=40)
    a, b = np.random.default_rng(seed), np.random.default_rng(seed)
    np.testing.assert_array_equal(h.sample(a, idx), reference_sample(h, b, idx))
    assert a.random() == b.random()
