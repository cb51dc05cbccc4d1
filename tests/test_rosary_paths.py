"""Tests for foam_mj.rosary (hatches, portals, sampling) and foam_mj.paths (metrics of paper 000 Eq. 4-5, paper 003 Eq. 6-7)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foam_mj.paths import angle_term, densify, metrics, objective, path_length, sv, tc, turning_angles
from foam_mj.rosary import Rosary


def random_rosary(rng, k=8, n=3) -> Rosary:
    """A chain of balls, each child centred on its parent's surface (as the foam builds them)."""
    centers, radii = [rng.uniform(-1, 1, n)], [rng.uniform(0.05, 0.2)]
    for _ in range(k - 1):
        u = rng.standard_normal(n)
        centers.append(centers[-1] + radii[-1] * u / np.linalg.norm(u))
        radii.append(rng.uniform(0.05, 0.2))
    c, r = np.array(centers), np.array(radii)
    u = rng.standard_normal(n)
    goal = c[-1] + 0.5 * r[-1] * u / np.linalg.norm(u)
    return Rosary(c, r, c[0].copy(), goal)


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_hatch_samples_are_in_their_hatches_and_portals_lie_on_both_spheres(seed):
    rng = np.random.default_rng(seed)
    ros = random_rosary(rng)
    pts = ros.sample_hatches(rng, size=200)
    assert pts.shape == (200, ros.k - 1, 3)
    assert np.all(ros.in_hatches(pts))
    for i, p in enumerate(ros.portals()):
        d = np.linalg.norm(ros.centers[i + 1] - ros.centers[i])
        if abs(ros.radii[i] - ros.radii[i + 1]) >= d:  # one ball inside the other: the spheres do not meet
            assert p.radius == 0.0
            continue
        # A point on the portal's rim is on both spheres.
        v = np.cross(p.normal, rng.standard_normal(3))
        rim = p.center + p.radius * v / np.linalg.norm(v)
        assert np.linalg.norm(rim - ros.centers[i]) == pytest.approx(ros.radii[i], rel=1e-9)
        assert np.linalg.norm(rim - ros.centers[i + 1]) == pytest.approx(ros.radii[i + 1], rel=1e-9)
        assert ros.in_hatches(np.repeat(p.center[None], ros.k - 1, axis=0))[i]


def test_hatch_sampling_is_uniform_over_the_lens():
    """Two unit balls with centres 1 apart: the lens is symmetric about x = 0.5, mean at the midpoint."""
    ros = Rosary(np.array([[0.0, 0, 0], [1.0, 0, 0]]), np.array([1.0, 1.0]), np.zeros(3), np.array([1.0, 0, 0]))
    pts = ros.sample_hatches(np.random.default_rng(0), size=20000)[:, 0]
    np.testing.assert_allclose(pts.mean(axis=0), [0.5, 0, 0], atol=0.01)
    # The lens's volume share of the ball: 5/16 for unit balls at distance 1.
    rng = np.random.default_rng(1)
    u = rng.uniform(-1, 1, (200000, 3))
    u = u[np.sum(u**2, axis=1) <= 1]
    share = np.mean(np.sum((u - [1, 0, 0]) ** 2, axis=1) <= 1)
    assert share == pytest.approx(5 / 16, abs=0.01)


def test_metrics_of_a_right_angle_path():
    p = np.array([[0.0, 0, 0], [1.0, 0, 0], [1.0, 1.0, 0]])
    np.testing.assert_allclose(turning_angles(p), [np.pi / 2])
    assert path_length(p) == pytest.approx(2.0)
    assert objective(p) == pytest.approx(np.pi / 2 + 2.0)
    assert tc(p) == pytest.approx(np.sqrt(2) / 2)
    assert sv(p) == pytest.approx((np.pi / 2) ** 2)
    m = metrics(p)
    assert (m.length, m.angle_term, m.n_points) == (pytest.approx(2.0), pytest.approx(np.pi / 2), 3)


def test_a_straight_path_scores_zero_angle_and_tc_one():
    p = np.linspace([0, 0, 0], [1, 2, 3], 6)
    assert angle_term(p) == pytest.approx(0.0, abs=1e-7)
    assert tc(p) == pytest.approx(1.0)
    assert sv(p) == pytest.approx(0.0, abs=1e-12)


def _reference_f(points):
    """Paper 000 Eq. 4-5 written plainly, one path at a time."""
    total, count = 0.0, 0
    for i in range(len(points) - 2):
        a, b, c = points[i], points[i + 1], points[i + 2]
        u, v = a - b, c - b
        theta = np.arccos(np.clip(u @ v / (np.linalg.norm(u) * np.linalg.norm(v)), -1, 1))
        total += np.pi - theta
        count += 1
    length = sum(np.linalg.norm(points[i + 1] - points[i]) for i in range(len(points) - 1))
    return total / count + length


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), m=st.integers(3, 30), pop=st.integers(1, 20))
def test_vectorized_objective_equals_the_plain_reference(seed, m, pop):
    P = np.random.default_rng(seed).normal(size=(pop, m, 3))
    np.testing.assert_allclose(objective(P), [_reference_f(p) for p in P], rtol=1e-10)


def test_densify_keeps_the_step_and_the_vertices():
    p = np.array([[0.0, 0, 0], [0.01, 0, 0], [0.01, 0.0235, 0]])
    d = densify(p, step=1e-3)
    assert np.max(np.abs(np.diff(d, axis=0))) <= 1e-3 + 1e-15
    for v in p:
        assert np.any(np.all(np.isclose(d, v), axis=1))


@pytest.mark.parametrize("q_init", [np.zeros(2), np.array([np.nan, 0.0, 0.0]), [0.0, 0.0, np.inf]])
def test_a_rosary_names_a_bad_end(q_init):
    """q_init of the wrong length failed in a numpy broadcast inside a smoother; a NaN one was accepted."""
    with pytest.raises(ValueError, match=r"rosary q_init must be 3 finite numbers \(the centres' dimension\), got"):
        Rosary(np.zeros((1, 3)), np.array([1.0]), q_init, np.zeros(3))


def test_rosary_rejects_bad_shapes():
    with pytest.raises(ValueError, match="radii"):
        Rosary(np.zeros((3, 3)), np.ones(2), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="> 0"):
        Rosary(np.zeros((2, 3)), np.array([1.0, -1.0]), np.zeros(3), np.zeros(3))


# -- thin hatches: lens sampling ---------------------------------------------------------------------
from foam_mj.rosary import uniform_in_lenses  # noqa: E402


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 7), ra=st.floats(1e-3, 1.0), ratio=st.floats(0.2, 5.0), overlap=st.floats(1e-4, 0.99), seed=st.integers(0, 2**31 - 1))
def test_lens_samples_lie_in_both_balls_however_thin_the_lens(n, ra, ratio, overlap, seed):
    rng = np.random.default_rng(seed)
    rb = ra * ratio
    d = max(ra + rb - overlap * 2 * min(ra, rb), abs(ra - rb) * 0.5)
    u = rng.standard_normal(n)
    ca = rng.standard_normal(n)
    cb = ca + d * u / np.linalg.norm(u)
    pts = uniform_in_lenses(rng, np.tile(ca, (50, 1)), np.full(50, ra), np.tile(cb, (50, 1)), np.full(50, rb))
    assert np.all(np.linalg.norm(pts - ca, axis=1) <= ra * (1 + 1e-12))
    assert np.all(np.linalg.norm(pts - cb, axis=1) <= rb * (1 + 1e-12))


def test_lens_samples_are_uniform_like_rejection_from_the_smaller_ball():
    """Same distribution as plain rejection from the smaller ball on a lens both can sample: the mean and
    spread along the axis and the mean distance from it agree."""
    rng = np.random.default_rng(0)
    n, N = 4, 40_000
    ca, cb, ra, rb = np.zeros(n), np.r_[0.9, np.zeros(n - 1)], 0.6, 0.5
    lens = uniform_in_lenses(rng, np.tile(ca, (N, 1)), np.full(N, ra), np.tile(cb, (N, 1)), np.full(N, rb))
    g = rng.standard_normal((20 * N, n))
    ball = cb + g / np.linalg.norm(g, axis=1, keepdims=True) * (rb * rng.random(20 * N) ** (1 / n))[:, None]
    ref = ball[np.linalg.norm(ball - ca, axis=1) <= ra][:N]
    assert len(ref) > 5000
    assert abs(lens[:, 0].mean() - ref[:, 0].mean()) < 0.005
    assert abs(lens[:, 0].std() - ref[:, 0].std()) < 0.005
    assert abs(np.linalg.norm(lens[:, 1:], axis=1).mean() - np.linalg.norm(ref[:, 1:], axis=1).mean()) < 0.005


def test_an_empty_lens_is_refused():
    with pytest.raises(RuntimeError, match="empty or degenerate"):
        uniform_in_lenses(np.random.default_rng(0), np.zeros((1, 3)), np.ones(1), np.full((1, 3), 2.0), np.ones(1))


def test_hatch_sampling_succeeds_in_a_thin_5d_hatch():
    """A hatch 0.5 % of the bubbles' diameter thick in 5-D (refined corridors make such hatches): both
    hatch samplers used to give up there."""
    from foam_mj.smoothing.base import Hatches

    c = np.array([[0.0] * 5, [0.0199] + [0.0] * 4])
    ros = Rosary(c, np.array([0.01, 0.01]), c[0], c[1], np.arange(2))
    for pts in (ros.sample_hatches(np.random.default_rng(1), size=20)[:, 0], Hatches.of(ros).sample(np.random.default_rng(2), np.zeros(20, dtype=np.intp))):
        assert np.all(np.linalg.norm(pts - c[0], axis=1) <= 0.01 + 1e-15)
        assert np.all(np.linalg.norm(pts - c[1], axis=1) <= 0.01 + 1e-15)


def test_membership_is_the_closed_ball_to_rounding_only():
    """A point on a bubble's sphere is in it, one a micrometre (of q) outside is not: waypoints, the goal and a path's
    points are held to the certified balls themselves (the tolerance only absorbs a child centre computed on its
    parent's surface), in in_hatches and in the path check of the safe curve."""
    from foam_mj.safe_curve import validate_path

    ros = Rosary(np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([0.6, 0.6]), np.array([0.0, 0.0]), np.array([1.0, 0.0]))
    rim = np.array([0.5, np.sqrt(0.6**2 - 0.5**2)])  # on both spheres
    assert ros.all_in_hatches(rim[None])
    out = rim + [0.0, 1e-6]
    assert not ros.all_in_hatches(out[None])
    with pytest.raises(ValueError, match=r"`path\[1\]` is not in hatch 0"):
        validate_path([ros.q_init, out, ros.q_goal], ros)
    with pytest.raises(ValueError, match="the goal"):
        validate_path([ros.q_init, rim, [1.6 + 1e-6, 0.0]], ros)


def test_the_structure_check_reports_bubbles_that_only_touch_or_miss():
    """Consecutive bubbles must overlap: two that touch (a hatch of one point) or miss by a millimetre are reported,
    as are ends outside the first and last bubbles."""
    touch = Rosary(np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([0.5, 0.5]), np.zeros(2), np.array([1.0, 0.0]))
    assert touch.check_structure(tol=0.0) == ["bubbles [0] do not overlap their successors"]
    miss = Rosary(np.array([[0.0, 0.0], [1.002, 0.0]]), np.array([0.5, 0.5]), np.zeros(2), np.array([1.002, 0.0]))
    assert miss.check_structure() == ["bubbles [0] do not overlap their successors"]
    ok = Rosary(np.array([[0.0, 0.0], [0.9, 0.0]]), np.array([0.5, 0.5]), np.zeros(2), np.array([0.9, 0.0]))
    assert ok.check_structure() == []
    ends = Rosary(ok.centers, ok.radii, np.array([-0.501, 0.0]), np.array([1.401, 0.0]))
    assert ends.check_structure() == ["q_init is not in the first bubble", "q_goal is not in the last bubble"]


def test_a_rosary_keeps_its_own_read_only_arrays():
    # Its arrays were the caller's, and writable: `c = rosary.centers; c += noise` left a frozen, "certified" rosary
    # that no longer was. It copies them and keeps them read-only.
    from foam_mj.rosary import Rosary

    centers, radii = np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([0.6, 0.6])
    ros = Rosary(centers, radii, [0.0, 0.0], [1.0, 0.0])
    centers[0, 0] = 5.0
    assert ros.centers[0, 0] == 0.0
    for a in (ros.centers, ros.radii, ros.q_init, ros.q_goal):
        with pytest.raises(ValueError, match="read-only"):
            a[0] = 1.0


@pytest.mark.parametrize("scale", [0.0, 1e-14, 1e-13])
def test_a_path_that_does_not_move_has_tc_0_and_finite_metrics(scale):
    """TC (Nascimento and Alsina 2021 Eq. 6) is 0 / 0 on a path that does not move: it was |q_goal - q_init| / 1e-12,
    0 for a path at one point but 0.01 or 0.1 for a straight one 1e-14 or 1e-13 long. Such a path has TC 0, as a path
    back to its start, and every measure is finite; a straight path 1e-9 long keeps TC 1."""
    from foam_mj.smoothing.gradient import tc_and_gradient

    p = np.array([[0.2, 0.3, 0.08], [0.2, 0.3, 0.08 + scale / 2], [0.2, 0.3, 0.08 + scale]])
    m = metrics(p)
    assert m.tc == 0.0 and float(tc(p)) == 0.0 and all(np.isfinite([m.length, m.f, m.sv, m.angle_term]))
    value, grad = tc_and_gradient(p)
    assert float(value) == 0.0 and np.all(grad == 0.0)
    straight = np.array([[0.2, 0.3, 0.08], [0.2, 0.3, 0.08 + 1e-9]])
    assert metrics(straight).tc == pytest.approx(1.0)
