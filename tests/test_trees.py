"""bubbletree's two trees (foam_mj.planners.trees): the gaps between them, kept up to date as bubbles arrive."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from foam_mj.planners.chains import HATCH
from foam_mj.planners.trees import Bubbles


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), dim=st.integers(2, 7), batches=st.integers(1, 6))
def test_every_bubbles_gap_is_its_distance_to_the_nearest_bubble_of_the_other_tree(seed, dim, batches):
    """After bubbles arrive in batches (each refreshed with update_gaps), every bubble's gap is
    min over the other tree's bubbles of |c - c'| - r - r', its mate is such a bubble, and closest is the smallest
    gap; a returned connection is a pair of the two trees overlapping by a hatch of HATCH x the smaller radius."""
    rng = np.random.default_rng(seed)
    B = Bubbles(dim, cap=4)  # small: the arrays grow while bubbles arrive
    for _ in range(batches):
        k0, k1 = rng.integers(0, 5, size=2)
        c = rng.uniform(-1, 1, size=(k0 + k1, dim))
        r = rng.uniform(0.01, 0.5, size=k0 + k1)
        new = B.add(c, r, np.full(k0 + k1, -1), np.repeat(np.array([0, 1], dtype=np.int8), [k0, k1]))
        link = B.update_gaps(new)
        if link is not None:
            a, b = link
            assert B.tree[a] == 0 and B.tree[b] == 1
            assert np.linalg.norm(B.c[a] - B.c[b]) <= B.r[a] + B.r[b] - HATCH * min(B.r[a], B.r[b]) + 1e-9
    n = B.n
    D = np.linalg.norm(B.c[:n, None] - B.c[None, :n], axis=2) - B.r[:n, None] - B.r[None, :n]
    for t in (0, 1):
        T, mine, other = B.trees[t], B.tree[:n] == t, B.tree[:n] == 1 - t
        if not other.any() or not mine.any():
            continue
        want = D[np.ix_(mine, other)].min(axis=1)
        np.testing.assert_allclose(T.gap[: T.n], want, atol=1e-9)
        np.testing.assert_allclose(D[T.idx[: T.n], T.mate[: T.n]], want, atol=1e-9)
    if (B.tree[:n] == 0).any() and (B.tree[:n] == 1).any():
        assert abs(B.closest - D[np.ix_(B.tree[:n] == 0, B.tree[:n] == 1)].min()) <= 1e-9




@settings(max_examples=60, deadline=None)
@given(floor=st.integers(50, 500), g0=st.floats(1e-4, 10.0), a=st.floats(0.006, 2.0), plateau=st.integers(0, 3000), first=st.integers(0, 30))
def test_a_search_is_stalled_once_its_gap_no_longer_shrinks_by_SHRINK_while_its_iterations_grow_SPAN_fold(floor, g0, a, plateau, first):
    """GapHistory (the SHRINK rule): after ``floor`` iterations, the search is stalled at iteration k when its gap shrank
    by less than SHRINK since iteration k // SPAN. A gap that keeps shrinking as g0 / (1 + k)^a (a >= 0.006, so that
    every SPAN-fold of the iterations brings more than 1 %) is never stalled, however long the search runs; once the gap
    stops shrinking (a plateau from iteration p on), the search is stalled as soon as k // SPAN >= p and k >= floor, and
    not while the gap is still SHRINK below its value at k // SPAN; never while that earlier gap is <= 0 (bubbles of the
    two trees already overlap, without a hatch) or infinite (the other tree has no bubble yet)."""
    from foam_mj.planners.trees import SHRINK, SPAN, GapHistory

    assert SPAN**-0.006 < 1 - SHRINK
    h = GapHistory()
    gaps = [np.inf] * first + [g0 / (1.0 + k) ** a for k in range(first, 1500)]
    for k, g in enumerate(gaps):
        h.record(g)
        assert not h.stalled(floor), k
    p = len(gaps) - 1  # the plateau's first iteration
    for k in range(len(gaps), len(gaps) + plateau):
        h.record(gaps[-1])
        if k // SPAN >= p:
            assert h.stalled(floor) == (k >= floor)
        elif gaps[-1] < (1 - SHRINK) * h.gaps[k // SPAN]:
            assert not h.stalled(floor)
    overlap = GapHistory()
    for g in [0.5, 0.0] + [0.0] * 100:
        overlap.record(g)
        assert not overlap.stalled(1)
