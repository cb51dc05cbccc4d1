"""Tests for foam_mj.planners.chains: the chain surgery of the corridor (pruning and re-covering a chain along a
path, thinning a chord's chain, splicing chords and pressing bubbles into a chain). Each operation must leave a
polyline that the new chain holds segment by segment, no longer than before."""

from __future__ import annotations

import numpy as np
import pytest


def test_pruning_keeps_the_path_inside_a_shorter_chain():
    from foam_mj.planners.chains import prune_chain
    from foam_mj.planners.corridor import shortest_path

    # Ten overlapping balls on a straight line, q_init and q_goal at the ends: two balls suffice.
    C = np.stack([np.linspace(0, 1, 10), np.zeros(10)], axis=1)
    R = np.full(10, 0.3)
    q0, q1 = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    w, L = shortest_path(C, R, q0, q1)
    keep = prune_chain(C, R, np.concatenate([[q0], w, [q1]]))
    assert len(keep) < 10 and np.all(np.diff(keep) > 0)
    w2, L2 = shortest_path(C[keep], R[keep], q0, q1)
    assert L2 <= L + 1e-9 and L2 == pytest.approx(1.0, abs=1e-5)


def test_pruning_with_bubbles_centred_on_the_path_holds_it_with_fewer():
    """A chain of small balls along a zigzag, and larger balls centred at points of its shortest path: the
    re-covered chain uses the larger ones, has fewer bubbles, consecutive ones overlap with a hatch, and
    its own shortest path is no longer (the old path, cut at one shared sample per hand-over, still fits)."""
    from foam_mj.planners.chains import HATCH, path_samples, prune_chain
    from foam_mj.planners.corridor import shortest_path

    rng = np.random.default_rng(3)
    x = np.linspace(0.0, 2.0, 41)
    C = np.stack([x, 0.05 * np.sin(3 * x)], axis=1)
    R = 0.06 + 0.01 * rng.random(41)
    q0, q1 = C[0], C[-1]
    w, L = shortest_path(C, R, q0, q1)
    P = np.concatenate([[q0], w, [q1]])
    D = path_samples(P, 8)
    at = np.arange(0, len(D), 2)
    r_extra = np.full(len(at), 0.15)
    keep = prune_chain(C, R, P, extra=(at, r_extra))
    Cn = np.concatenate([C, D[at]])[keep]
    Rn = np.concatenate([R, r_extra])[keep]
    assert np.any(keep >= len(R)) and len(keep) < prune_chain(C, R, P).size
    d = np.linalg.norm(np.diff(Cn, axis=0), axis=1)
    assert np.all(d <= Rn[:-1] + Rn[1:] - HATCH * np.minimum(Rn[:-1], Rn[1:]))
    _, L2 = shortest_path(Cn, Rn, q0, q1)
    assert L2 <= L + 1e-6


def test_a_chords_chain_is_thinned_to_fewer_bubbles_that_still_hold_it():
    from foam_mj.planners.chains import DEEP, thin_line_chain

    rng = np.random.default_rng(0)
    for _ in range(20):
        m = int(rng.integers(3, 30))
        A, B = rng.random(3), rng.random(3)
        t = np.linspace(0.0, 1.0, m)
        pts = A + t[:, None] * (B - A)
        step = np.linalg.norm(B - A) / (m - 1)
        r = step * (0.7 + 2.0 * rng.random(m))  # consecutive ones overlap deeply
        p2, r2 = thin_line_chain(pts, r)
        assert len(r2) <= m
        np.testing.assert_array_equal(p2[[0, -1]], pts[[0, -1]])
        d = np.linalg.norm(np.diff(p2, axis=0), axis=1)
        assert np.all(d <= r2[:-1] + r2[1:] - DEEP * np.minimum(r2[:-1], r2[1:]) + 1e-12)
        # Every point of the chord lies in a kept ball.
        s = A + np.linspace(0.0, 1.0, 200)[:, None] * (B - A)
        assert np.all(np.min(np.linalg.norm(s[:, None] - p2[None], axis=2) - r2[None], axis=1) <= 1e-12)


def test_a_chord_thinned_with_a_cap_is_rejected_exactly_when_its_thinned_chain_is_longer():
    """thin_line_chain(most=k): the same chain as without the cap when that keeps at most k bubbles, else None
    (the walk stops at the cap: the corridor splices a chord only if its chain is short enough)."""
    from foam_mj.planners.chains import thin_line_chain

    rng = np.random.default_rng(1)
    seen = set()
    for _ in range(60):
        m = int(rng.integers(2, 30))
        A, B = rng.random(3), rng.random(3)
        pts = A + np.linspace(0.0, 1.0, m)[:, None] * (B - A)
        r = np.linalg.norm(B - A) / max(m - 1, 1) * (0.7 + 2.0 * rng.random(m))
        full = thin_line_chain(pts, r)
        for k in (len(full[1]) - 1, len(full[1]), len(full[1]) + 1):
            capped = thin_line_chain(pts, r, most=k)
            if len(full[1]) <= k:
                np.testing.assert_array_equal(capped[0], full[0])
                np.testing.assert_array_equal(capped[1], full[1])
                seen.add("kept")
            else:
                assert capped is None
                seen.add("rejected")
    assert seen == {"kept", "rejected"}


def test_splicing_a_chord_and_a_pressing_bubble_keeps_a_polyline_held_segment_by_segment():
    """splice_chain: after a chord (balls centred on it, consecutive ones overlapping) replaces a stretch of
    the chain and a pressing bubble goes into a hatch, segment j of the new polyline lies in bubble j, the
    polyline is no longer than the old one, and the new bubbles get consecutive new ids."""
    from foam_mj.planners.chains import splice_chain
    from foam_mj.planners.corridor import shortest_path

    rng = np.random.default_rng(7)
    for _ in range(10):
        # A zigzag chain of balls and its shortest path.
        k = 12
        C = np.stack([np.arange(k) * 0.1, 0.03 * (-1.0) ** np.arange(k)], axis=1)
        R = np.full(k, 0.08)
        q0, q1 = C[0], C[-1]
        w, _ = shortest_path(C, R, q0, q1)
        P = np.concatenate([[q0], w, [q1]])
        ja, jb = int(rng.integers(0, 4)), int(rng.integers(7, k))
        A = P[ja] + rng.random() * (P[ja + 1] - P[ja])
        B = P[jb] + rng.random() * (P[jb + 1] - P[jb])
        m = int(rng.integers(2, 9))
        pts = A + np.linspace(0.0, 1.0, m)[:, None] * (B - A)
        step = np.linalg.norm(B - A) / (m - 1)
        r = step * (0.6 + rng.random(m))  # consecutive ones overlap
        pp = int(rng.integers(jb, k - 1)) if jb < k - 1 else None
        press = {pp: (P[pp + 1] + 0.001, 0.05)} if pp is not None else {}  # a bubble that holds P[pp + 1]
        ids = np.arange(k)
        C2, R2, ids2, P2, nc, nr = splice_chain(C, R, ids, P, {ja: (jb, pts, r)}, press, 100)
        assert len(P2) == len(R2) + 1 and len(R2) == len(ids2)
        assert np.all(np.linalg.norm(P2[:-1] - C2, axis=1) <= R2 + 1e-9)
        assert np.all(np.linalg.norm(P2[1:] - C2, axis=1) <= R2 + 1e-9)
        L = lambda X: float(np.sum(np.linalg.norm(np.diff(X, axis=0), axis=1)))  # noqa: E731
        assert L(P2) <= L(P) + 1e-12
        n_new = sum(len(x) for x in nr)
        assert sorted(ids2[ids2 >= 100].tolist()) == list(range(100, 100 + n_new))


@pytest.mark.parametrize("scene, q_init, q_goal", [
    ("obstacle", None, None),
    ("bench_arm6", [-0.7, 0.87, 1.12, -0.08, 0.0, 0.0], [0.7, 0.87, 1.12, -0.08, 0.0, 0.0]),
])
def test_every_upper_bound_given_to_radii_below_in_a_plan_bounds_the_full_radius(scene, q_init, q_goal):
    """bubbletree's growth and its corridor (chords, pressing and deepening bubbles, the re-cover) measure a point's
    pairs only up to a bound of its radius from a sized neighbour (r is 1-Lipschitz; BubbleOracle.radii_below): each
    such bound is at least the full radius, so the capped radii are the full ones to the last bit."""
    from foam_mj.bubbles import BubbleOracle
    from foam_mj.model import RobotModel
    from foam_mj.data import models_dir
    from foam_mj.planners import PlanningProblem, get_planner
    from foam_mj.scenarios import load_scenario

    if q_init is None:
        s = load_scenario(scene)
        robot, q_init, q_goal = s.robot, s.q_init, s.q_goal
    else:
        robot = RobotModel.from_xml(models_dir() / f"{scene}.xml")
    oracle = BubbleOracle(robot, delta=0.005)
    calls, capped = [], oracle.radii_below

    def spy(Q, upper, *bounds):  # bounds: the growth passes the candidates' distances to the joint bounds
        r = capped(Q, upper, *bounds)
        full = oracle.radii(Q)
        assert np.all(full <= upper), f"an upper bound below the full radius: {np.max(full - upper):.3g}"
        assert np.array_equal(r, full)
        calls.append(len(Q))
        return r

    oracle.radii_below = spy
    res = get_planner("bubbletree").plan(PlanningProblem(oracle, np.asarray(q_init, float), np.asarray(q_goal, float), delta=0.005), seed=0)
    assert res.stats.outcome == "reached" and len(calls) > res.stats.details["iterations"]  # the corridor's calls too


def test_chords_sized_from_the_chain_they_shortcut_get_the_full_radii_with_capped_queries_only():
    """certify_chords given the chain it shortcuts (``near``: bubbles whose radii are the certified radii at their
    centres) sizes every point of a chord through radii_below, with the bound min_j r_j + |x - c_j| (r is 1-Lipschitz),
    and returns the same chains to the last bit as with full queries of the coarse points."""
    from foam_mj.bubbles import BubbleOracle
    from foam_mj.planners import PlanningProblem, get_planner
    from foam_mj.planners.chains import certify_chords
    from foam_mj.scenarios import load_scenario

    s = load_scenario("obstacle")
    oracle = BubbleOracle(s.robot, delta=0.005)
    res = get_planner("bubbletree", refine=False).plan(PlanningProblem(oracle, s.q_init, s.q_goal, delta=0.005), seed=0)
    C, R = res.rosary.centers, res.rosary.radii
    P = np.concatenate([[s.q_init], res.waypoints, [s.q_goal]])
    rng = np.random.default_rng(0)
    i, j = np.sort(rng.choice(len(P), (2, 12)), axis=0)
    A, B = P[i], P[j] + 1e-3 * (j == i)[:, None]
    floor, spacing = 0.3 * float(R.min()), 2.0 * float(np.median(R))
    full = certify_chords(oracle, A, B, floor, spacing)
    asked = []
    oracle.radii = lambda Q: asked.append(len(Q))  # a full query would fail the comparison below
    near = certify_chords(oracle, A, B, floor, spacing, near=(C, R))
    assert not asked
    assert sum(x is not None for x in full) >= 3  # some chords are certified, some are not
    for a, b in zip(full, near):
        assert (a is None) == (b is None)
        if a is not None:
            assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
