"""Which points lie strictly inside which balls (Nascimento and Alsina 2021 Eq. 1's open ball), without Python loops
over the balls: :class:`CoverageIndex` (a k-d tree on lifted points) and the brute-force tests beside it. The squares
are summed coordinate by coordinate in every test, so every test agrees on a point to the last bit. Used by the foams
(:mod:`foam_mj.foam`, :mod:`foam_mj.planners.variants`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # scipy is imported where a k-d tree is built (reading a scenario does not need it)
    from scipy.spatial import cKDTree


class CoverageIndex:
    """Which query points lie strictly inside some stored ball, without a Python loop over the balls.

    Each ball (c, r) is lifted to the point (c, sqrt(R^2 - r^2)) in n+1 dimensions, R >= every radius;
    a query point p lifts to (p, 0). Then |lift(p) - lift(c)|^2 = |p - c|^2 + R^2 - r^2, which is
    below R^2 exactly when |p - c| < r: containment becomes a nearest-neighbour query in a k-d tree,
    confirmed by the exact test |p - c|^2 < r^2. Balls added since the last rebuild are tested by brute
    force; the tree is rebuilt when that buffer outgrows a fraction of the tree (amortised O(log N) per
    ball). The BIG_BALLS largest balls stay out of the tree and are tested by brute force too: the tree's
    search reaches every node within lifted distance R, and a few large balls (the root, early bubbles)
    would set R for all.

    The excluded ball ``exclude[i]`` is usually the parent of a point on its surface, at lifted distance R
    up to rounding: the tree is first asked for the nearest ball closer than R (1 - 1e-12), which leaves
    the parent out without a second neighbour; only points whose nearest is their excluded ball are asked
    again for two. A point less than 1e-12 R^2 / (2 r) inside a sphere (an exact tie, for random points)
    may be reported outside it.
    """

    def __init__(self, dim: int, capacity: int = 4096) -> None:
        self._c = np.empty((capacity, dim))
        self._r = np.empty(capacity)
        self.n = 0
        self._tree: cKDTree | None = None
        self._tree_ids = np.empty(0, dtype=np.intp)  # tree point -> ball, and -1 for "none found"
        self._big = np.empty(0, dtype=np.intp)  # balls kept out of the tree
        self._n_tree = 0
        self._R = 0.0

    def add(self, centers: np.ndarray, radii: np.ndarray | float) -> None:
        """Store balls (k, n) with radii (k,) (one ball: (n,) and a float)."""
        centers = np.asarray(centers, dtype=float).reshape(-1, self._c.shape[1])
        k = len(centers)
        if self.n + k > len(self._r):
            size = max(2 * len(self._r), self.n + k)
            self._c = np.concatenate([self._c[: self.n], np.empty((size - self.n, self._c.shape[1]))])
            self._r = np.concatenate([self._r[: self.n], np.empty(size - self.n)])
        self._c[self.n : self.n + k] = centers
        self._r[self.n : self.n + k] = radii
        self.n += k

    def _rebuild(self) -> None:
        n = self.n
        c, r = self._c[:n], self._r[:n]
        if n > 4 * BIG_BALLS:
            thr = np.partition(r, n - BIG_BALLS - 1)[n - BIG_BALLS - 1]  # the (BIG_BALLS + 1)-th largest radius
            small, self._big = np.flatnonzero(r <= thr), np.flatnonzero(r > thr)
        else:
            small, self._big = np.arange(n), np.empty(0, dtype=np.intp)
        rs = r[small]
        self._R = R = float(rs.max())
        lifted = np.empty((len(small), c.shape[1] + 1))
        lifted[:, :-1] = c[small]
        lifted[:, -1] = np.sqrt(np.maximum(R * R - rs * rs, 0.0))
        from scipy.spatial import cKDTree

        self._tree = cKDTree(lifted, leafsize=TREE_LEAFSIZE)
        self._tree_ids = np.append(small, -1)
        self._n_tree = n

    def covered(self, points: np.ndarray, exclude: np.ndarray) -> np.ndarray:
        """For each point (m, n): is it strictly inside a stored ball other than ``exclude[i]``?"""
        m = len(points)
        out = np.zeros(m, dtype=bool)
        if m == 0 or self.n == 0:
            return out
        exclude = np.asarray(exclude)
        if self.n - self._n_tree > max(REBUILD_MIN, self._n_tree // REBUILD_FRACTION):
            self._rebuild()
        if self._n_tree:
            tree = self._tree
            assert tree is not None  # built with _n_tree (_rebuild)
            R = self._R
            lifted = np.empty((m, points.shape[1] + 1))
            lifted[:, :-1] = points
            lifted[:, -1] = 0.0
            # Only balls within lifted distance R can contain a point: the bound prunes the search (a
            # missing neighbour comes back as (inf, n_tree), that is ball -1).
            dist, idx = tree.query(lifted, k=1, distance_upper_bound=R * (1.0 - 1e-12))
            j = self._tree_ids[idx]
            own = np.flatnonzero((j >= 0) & (j == exclude))
            if own.size:  # the nearest is the excluded ball: take the next one
                d2, i2 = tree.query(lifted[own], k=2, distance_upper_bound=R * (1.0 + 1e-9))
                g = self._tree_ids[i2]
                second = g[:, 0] == exclude[own]
                dist[own] = np.where(second, d2[:, 1], d2[:, 0])
                j[own] = np.where(second, g[:, 1], g[:, 0])
            hit = np.flatnonzero((dist < R) & (j >= 0))
            if hit.size:
                # Exact confirmation of the lifted test (guards against rounding near the boundary).
                j = j[hit]
                out[hit] = row_sq_sums(points[hit] - self._c[j]) < self._r[j] ** 2
        # The balls outside the tree (the largest, and those added since the rebuild), by brute force, for
        # the points the tree did not already find covered.
        rest_balls = self._big if self.n == self._n_tree else np.concatenate([self._big, np.arange(self._n_tree, self.n)])
        if rest_balls.size:
            rest = np.flatnonzero(~out)
            if rest.size == 0:
                return out
            inside = pairwise_sq_dist(points[rest], self._c[rest_balls]) < self._r[rest_balls][None, :] ** 2
            inside &= exclude[rest][:, None] != rest_balls[None, :]
            out[rest] = inside.any(axis=1)
        return out


#: The coverage tree is rebuilt (at query time) once more than max(REBUILD_MIN, N / REBUILD_FRACTION)
#: bubbles wait in the brute-force buffer.
REBUILD_MIN = 64
REBUILD_FRACTION = 16
#: Points per leaf of the coverage tree: 32 instead of scipy's 16 makes both the build and the queries about
#: 20% faster on foams of 1,000-3,000 bubbles (the neighbours found are the same, up to exact ties in distance).
TREE_LEAFSIZE = 32
#: The largest balls kept out of the coverage tree (tested by brute force; see :class:`CoverageIndex`).
BIG_BALLS = 16

def pairwise_sq_dist(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a_i - b_j|^2 for all pairs, summed coordinate by coordinate from the differences.

    No matrix product: the sets are small (a few hundred by a few hundred in a few dimensions), where
    BLAS's threads cost more than they save on a busy machine, and the differences are exact to rounding
    (no cancellation as in |a|^2 + |b|^2 - 2 a.b), independent of the BLAS build and its thread count."""
    d = np.subtract.outer(a[:, 0], b[:, 0])
    out = d * d
    for k in range(1, a.shape[1]):
        np.subtract.outer(a[:, k], b[:, k], out=d)
        np.multiply(d, d, out=d)
        out += d
    return out


def accept_in_order(cand: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Candidates taken one by one in order: ``accepted[i]`` is False when centre i lies strictly inside the
    bubble of an accepted j < i (|c_i - c_j|^2 < r_j^2, the squares summed coordinate by coordinate as in
    :func:`pairwise_sq_dist`), True otherwise.

    Only pairs closer than the largest radius can hold one in the other; a k-d tree lists them (a pair
    within rounding of that radius is kept: the exact test above decides). The one-by-one rule,
    accepted[i] = not any(accepted[j] for the pairs (i, j)), is then settled in rounds without a loop
    over the candidates: a candidate none of whose pairs is open is accepted, one paired with an accepted
    j is dropped, and pairs whose i is settled or whose j was dropped close. Every j < i, so the first
    unsettled candidate has all its j settled and is settled in the next round: the rounds end, with the
    one-by-one result.
    """
    m = len(cand)
    accepted = np.ones(m, dtype=bool)
    if m < 2:
        return accepted
    from scipy.spatial import cKDTree

    pairs = cKDTree(cand).query_pairs(float(r.max()) * (1.0 + 1e-9), output_type="ndarray")  # (j, i), j < i
    if len(pairs) == 0:
        return accepted
    j, i = pairs[:, 0], pairs[:, 1]
    d = cand[i, 0] - cand[j, 0]
    d2 = d * d
    for k in range(1, cand.shape[1]):
        d = cand[i, k] - cand[j, k]
        d2 += d * d
    inside = d2 < r[j] ** 2  # i lies in j's bubble
    i, j = i[inside], j[inside]
    open_ = np.zeros(m, dtype=bool)  # not settled yet: has pairs whose j is not settled
    open_[i] = True
    while i.size:
        dropped = i[~open_[j] & accepted[j]]  # paired with a settled, accepted j
        accepted[dropped] = False
        open_[dropped] = False
        keep = open_[i] & open_[j]  # a settled j no longer matters: accepted ones have dropped their i
        i, j = i[keep], j[keep]
        still = np.zeros(m, dtype=bool)
        still[i] = True
        open_ &= still  # open candidates left without pairs: every j was dropped, so accepted
    return accepted


def inside_rows(points: np.ndarray, centers: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """|p_i - c_i|^2 < r_i^2 row by row, the squares summed coordinate by coordinate (as everywhere here)."""
    d = points[:, 0] - centers[:, 0]
    d2 = d * d
    for k in range(1, points.shape[1]):
        d = points[:, k] - centers[:, k]
        d2 += d * d
    return d2 < radii**2


def row_sq_sums(d: np.ndarray) -> np.ndarray:
    """``np.sum(d * d, axis=1)`` (what ``np.linalg.norm(d, axis=1)`` squares), the same floats: below 8 columns
    numpy adds a row left to right, as the column-by-column sum here, which avoids numpy's slow reduction
    over a short last axis; from 8 columns on numpy sums pairwise, so numpy is called."""
    if d.shape[1] >= 8:
        return np.sum(d * d, axis=1)
    out = d[:, 0] * d[:, 0]
    for k in range(1, d.shape[1]):
        out += d[:, k] * d[:, k]
    return out
