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
