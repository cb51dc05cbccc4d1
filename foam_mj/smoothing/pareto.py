"""Pareto machinery for the multi-objective smoothers (Elmi and Efe 2018, Eq. 14-19).

* Dominance (Eq. 14): ``a`` dominates ``b`` when a_i <= b_i for every objective and a_i < b_i for one.
  With constraints (the planar experiment's obstacles) the archive uses **constrained dominance**
  (Deb 2000): a feasible solution (violation 0) dominates an infeasible one, of two infeasible ones
  the smaller violation dominates, and two feasible ones compare by Eq. 14. On a rosary every
  solution is feasible (the waypoints are projected onto their hatches) and this is plain Eq. 14.
* Filtering (:func:`nondominated_mask`): the K x K dominance matrix; for two objectives the same rule
  by sorting (O(K log K), the same mask: comparisons only), which the archives of MGOA and MOPSO use.
* :class:`Archive` (Eq. 15-16): the non-dominated solutions found so far, bounded in size. Pruning
  rule: while over capacity, drop the member with the smallest **crowding distance** (NSGA-II, Deb et al. 2002;
  recomputed after every removal; exact and O(K log K) for two objectives via a heap). The two
  extremes have infinite crowding distance, so the ends of the front are never pruned. Objective
  vectors that repeat one already held are not added (GOA's swarm collapses onto its target and would
  otherwise fill the archive with clones).
* Leader / target selection (MOGOA, Mirjalili et al. 2018, and MOPSO, Coello et al. 2004): roulette
  wheel over the archive with probability proportional to 1 / N_i, N_i the number of members within
  ``niche_radius`` of member i (objectives scaled to [0, 1] over the archive; N_i counts i itself).
  Less crowded regions of the front lead more often, which spreads the front.
* Metrics: ER (Eq. 18, :func:`error_ratio`) against a reference front, SCM (Eq. 19,
  :func:`set_coverage`) with weak dominance, 2-D hypervolume and the knee.

The multi-objective runs, the rosary problem and the smoother adapter are in :mod:`foam_mj.smoothing.multiobjective`.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from foam_mj.smoothing.base import _check_int, _check_positive

_EPS = 1e-12


# -- dominance -----------------------------------------------------------------------------------------
def dominates(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Eq. 14, minimisation: a_i <= b_i for all i and a_i < b_i for some i. Broadcasts over leading dims
    of a (..., M) and b (..., M) -> bool (...)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return np.all(a <= b, axis=-1) & np.any(a < b, axis=-1)


def weakly_dominates(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Weak dominance (Eq. 19's relation): a_i <= b_i for every objective. (..., M) x (..., M) -> bool (...)."""
    return np.all(np.asarray(a, dtype=float) <= np.asarray(b, dtype=float), axis=-1)


def dominance_matrix(F: np.ndarray, violation: np.ndarray | None = None) -> np.ndarray:
    """D[i, j] = solution i (constrained-)dominates solution j, for F (K, M) and violation (K,) >= 0."""
    F = np.asarray(F, dtype=float)
    K, M = F.shape
    le = np.ones((K, K), dtype=bool)
    lt = np.zeros((K, K), dtype=bool)
    for j in range(M):  # one (K, K) comparison per objective: much faster than reducing (K, K, M)
        col = np.ascontiguousarray(F[:, j])
        le &= col[:, None] <= col[None, :]
        lt |= col[:, None] < col[None, :]
    D = le & lt
    if violation is None:
        return D
    v = np.asarray(violation, dtype=float)
    feas = v <= 0
    if feas.all():
        return D
    D &= feas[:, None] & feas[None]
    D |= feas[:, None] & ~feas[None]
    D |= (~feas[:, None] & ~feas[None]) & (v[:, None] < v[None])
    return D


def nondominated_mask(F: np.ndarray, violation: np.ndarray | None = None) -> np.ndarray:
    """Members of F (K, M) that no other member (constrained-)dominates; of members with identical
    objective vectors (and violation) only the first is kept. -> bool (K,)."""
    F = np.asarray(F, dtype=float)
    if F.ndim != 2:
        raise ValueError(f"objectives must have shape (K, M), got {F.shape}")
    K = len(F)
    if K == 0:
        return np.zeros(0, dtype=bool)
    if F.shape[1] == 2:
        fast = _nondominated_mask_2d(F, violation)
        if fast is not None:
            return fast
    keep = ~dominance_matrix(F, violation).any(axis=0)
    key = F if violation is None else np.column_stack([F, np.asarray(violation, dtype=float)])
    _, first = np.unique(key, axis=0, return_index=True)
    uniq = np.zeros(K, dtype=bool)
    uniq[first] = True
    return keep & uniq


def _nondominated_mask_2d(F: np.ndarray, violation: np.ndarray | None) -> np.ndarray | None:
    """:func:`nondominated_mask` for two objectives by sorting, O(K log K) instead of the K x K matrix; the same
    mask (comparisons only). None where it does not apply (NaN objectives, feasible violations that differ:
    then the dominance matrix decides)."""
    K = len(F)
    if violation is None:
        cand = None
    else:
        v = np.asarray(violation, dtype=float)
        if not np.isfinite(v).all():
            return None
        feas = v <= 0
        # constrained dominance: any feasible member dominates every infeasible one; with none feasible, the
        # smallest violations dominate the rest and no objective comparison is made
        cand = feas if feas.any() else v == v.min()
        vc = v[cand]
        if not (vc == vc[0]).all():  # the duplicate test below compares objectives only
            return None
        if not feas.any():
            return _first_of_duplicates(F, cand)
    idx = np.arange(K) if cand is None else np.flatnonzero(cand)
    f0, f1 = F[idx, 0], F[idx, 1]
    if not (np.isfinite(f0).all() and np.isfinite(f1).all()):
        return None
    order = np.lexsort((f1, f0))  # by f0, then f1; stable: equal rows stay in index order
    s0, s1 = f0[order], f1[order]
    new0 = np.empty(len(order), dtype=bool)  # first of its group of equal f0
    new0[0] = True
    np.not_equal(s0[1:], s0[:-1], out=new0[1:])
    start = np.maximum.accumulate(np.where(new0, np.arange(len(order)), 0))
    # i is dominated by a member with a smaller f0 and f1 <= its f1, or by one with the same f0 and a smaller f1
    prefix = np.minimum.accumulate(s1)
    before = np.concatenate(([np.inf], prefix[:-1]))[start]  # lowest f1 of the smaller f0 values
    keep = (s1 < before) & (s1 == s1[start])
    # of equal objective vectors only the first (by index) stays
    keep[1:] &= ~((s0[1:] == s0[:-1]) & (s1[1:] == s1[:-1]))
    out = np.zeros(K, dtype=bool)
    out[idx[order[keep]]] = True
    return out


def _first_of_duplicates(F: np.ndarray, cand: np.ndarray) -> np.ndarray:
    """Members of ``cand`` whose objective vector no earlier member of ``cand`` has."""
    idx = np.flatnonzero(cand)
    _, first = np.unique(F[idx], axis=0, return_index=True)
    out = np.zeros(len(F), dtype=bool)
    out[idx[first]] = True
    return out


def nondominated(F: np.ndarray) -> np.ndarray:
    """The non-dominated rows of F (K, M), duplicates removed, sorted by the first objective."""
    F = np.asarray(F, dtype=float)
    out = F[nondominated_mask(F)]
    return out[np.lexsort(out.T[::-1])]


# -- crowding and niches ---------------------------------------------------------------------------------
def crowding_distance(F: np.ndarray) -> np.ndarray:
    """NSGA-II crowding distance of every member of F (K, M): per objective, the gap between its two
    neighbours in that objective's order divided by the objective's range, summed; the members at
    either end of any objective get +inf."""
    F = np.asarray(F, dtype=float)
    K, M = F.shape
    cd = np.zeros(K)
    if K <= 2:
        return np.full(K, np.inf)
    for j in range(M):
        order = np.argsort(F[:, j], kind="stable")
        f = F[order, j]
        span = f[-1] - f[0]
        cd[order[0]] = cd[order[-1]] = np.inf
        if span > 0:
            cd[order[1:-1]] += (f[2:] - f[:-2]) / span
    return cd


def prune_by_crowding(F: np.ndarray, capacity: int) -> np.ndarray:
    """Indices (sorted) of the ``capacity`` members of F (K, M) kept when the one with the smallest
    crowding distance is removed repeatedly, the distances recomputed after each removal (ties: the
    lowest index goes first). F must be mutually non-dominated with no duplicates (as in an archive)."""
    F = np.asarray(F, dtype=float)
    K, M = F.shape
    if capacity >= K:
        return np.arange(K)
    if capacity < 1:
        raise ValueError(f"capacity must be >= 1, got {capacity}")
    if M == 2:
        return _prune_2d(F, capacity)
    alive = np.arange(K)
    while len(alive) > capacity:
        cd = crowding_distance(F[alive])
        alive = np.delete(alive, int(np.argmin(cd)))
    return alive


def _prune_2d(F: np.ndarray, capacity: int) -> np.ndarray:
    """Two objectives: sorted by f1 a non-dominated set has f2 decreasing, a member's crowding distance
    involves its two neighbours only, and the ranges never change (the extremes stay), so a heap with
    lazy invalidation prunes exactly as the recomputing loop would."""
    K = len(F)
    order = np.lexsort((F[:, 1], F[:, 0]))
    f = F[order]
    span = np.maximum(f.max(axis=0) - f.min(axis=0), _EPS)
    prev = list(range(-1, K - 1))
    nxt = list(range(1, K + 1))
    f0 = f[:, 0].tolist()
    f1 = f[:, 1].tolist()
    s0, s1 = float(span[0]), float(span[1])

    def cd(i: int) -> float:
        p, q = prev[i], nxt[i]
        if p < 0 or q >= K:
            return math.inf
        return (f0[q] - f0[p]) / s0 + abs(f1[p] - f1[q]) / s1

    stamp = [0] * K
    heap = [(cd(i), int(order[i]), i, 0) for i in range(K)]
    heapq.heapify(heap)
    alive = [True] * K
    left = K
    while left > capacity:
        _, _, i, st = heapq.heappop(heap)
        if not alive[i] or st != stamp[i]:
            continue
        alive[i] = False
        left -= 1
        p, q = prev[i], nxt[i]
        if p >= 0:
            nxt[p] = q
        if q < K:
            prev[q] = p
        for j in (p, q):
            if 0 <= j < K:
                stamp[j] += 1
                heapq.heappush(heap, (cd(j), int(order[j]), j, stamp[j]))
    return np.sort(order[np.array(alive)])


def niche_counts(F: np.ndarray, radius: float) -> np.ndarray:
    """N_i: members of F (K, M) within ``radius`` of member i (itself included), objectives scaled to
    [0, 1] over F (a constant objective is left unscaled)."""
    F = np.asarray(F, dtype=float)
    lo, hi = F.min(axis=0), F.max(axis=0)
    G = (F - lo) / np.where(hi > lo, hi - lo, 1.0)
    d2 = np.sum((G[:, None] - G[None]) ** 2, axis=-1)
    return np.count_nonzero(d2 <= radius * radius, axis=1)


# -- the archive ------------------------------------------------------------------------------------
class Archive:
    """The bounded archive of non-dominated solutions (see the module docstring for the rules).

    Holds positions X (K, D), objectives F (K, M) and constraint violations V (K,). Invariant: no member
    (constrained-)dominates another, and no two share an objective vector.
    """

    def __init__(self, capacity: int, niche_radius: float = 0.1) -> None:
        _check_int("archive_size", capacity, 1)
        _check_positive("niche_radius", niche_radius)
        self.capacity = int(capacity)
        self.niche_radius = float(niche_radius)
        self.X = np.empty((0, 0))
        self.F = np.empty((0, 0))
        self.V = np.empty(0)
        self._weights: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.V)

    def update(self, X: np.ndarray, F: np.ndarray, V: np.ndarray | None = None) -> int:
        """Offer solutions X (P, D) with objectives F (P, M) and violations V (P,) (None: all feasible);
        returns how many entered the archive (before pruning)."""
        X = np.asarray(X, dtype=float)
        F = np.asarray(F, dtype=float)
        V = np.zeros(len(F)) if V is None else np.maximum(np.asarray(V, dtype=float), 0.0)
        if len(self) == 0:
            allX, allF, allV = X, F, V
        else:
            allX = np.concatenate([self.X, X])
            allF = np.concatenate([self.F, F])
            allV = np.concatenate([self.V, V])
        keep = nondominated_mask(allF, allV)
        entered = int(keep[len(self):].sum())
        idx = np.flatnonzero(keep)
        if len(idx) > self.capacity:
            idx = idx[prune_by_crowding(allF[idx], self.capacity)]
        self.X, self.F, self.V = allX[idx], allF[idx], allV[idx]
        self._weights = None
        return entered

    @property
    def feasible(self) -> bool:
        """True when the archive holds feasible solutions (then all of them are)."""
        return len(self) > 0 and bool(self.V[0] <= 0)

    def select(self, rng: np.random.Generator, size: int) -> np.ndarray:
        """Indices of ``size`` leaders drawn by roulette with probability proportional to 1 / N_i."""
        if len(self) == 0:
            raise RuntimeError("the archive is empty")
        if self._weights is None:
            w = 1.0 / niche_counts(self.F, self.niche_radius)
            self._weights = np.cumsum(w) / w.sum()
        return np.minimum(np.searchsorted(self._weights, rng.random(size), side="right"), len(self) - 1)


# -- metrics ------------------------------------------------------------------------------------------
def _as_set(A, name: str) -> np.ndarray:
    A = np.asarray(A, dtype=float)
    if A.ndim != 2:
        raise ValueError(f"{name} must be an array of objective vectors (K, M), got shape {A.shape}")
    return A


def error_ratio(front: np.ndarray, reference: np.ndarray) -> float:
    """ER of Elmi and Efe 2018 Eq. 18: the share of ``front``'s solutions that are not members of the Pareto
    optimal set. The true set being unknown, ``reference`` stands for it (in the benchmark: the
    non-dominated union of every run's front): x_i = 1 when some reference point dominates solution i
    (Eq. 14), else 0 (a solution that no reference point dominates belongs to the reference front's
    non-dominated union)."""
    A, R = _as_set(front, "front"), _as_set(reference, "reference")
    if len(A) == 0:
        raise ValueError("front is empty: ER is undefined")
    if len(R) == 0:
        return 0.0
    x = dominates(R[None, :, :], A[:, None, :]).any(axis=1)
    return float(x.mean())


def set_coverage(A: np.ndarray, B: np.ndarray) -> float:
    """SCM(A, B) of Elmi and Efe 2018 Eq. 19 (the C metric of Zitzler and Thiele 1999): the share of B weakly dominated by some member
    of A (a <= b in every objective). 1: A covers all of B; 0: none of it."""
    A, B = _as_set(A, "A"), _as_set(B, "B")
    if len(B) == 0:
        raise ValueError("B is empty: SCM is undefined")
    if len(A) == 0:
        return 0.0
    return float(weakly_dominates(A[None, :, :], B[:, None, :]).any(axis=1).mean())


def hypervolume_2d(F: np.ndarray, reference: np.ndarray) -> float:
    """Area dominated by the two-objective set F (K, 2) and bounded by the reference point."""
    F = _as_set(F, "F")
    r = np.asarray(reference, dtype=float)
    F = F[np.all(F < r, axis=1)]
    if len(F) == 0:
        return 0.0
    F = nondominated(F)
    f2_prev = np.concatenate([[r[1]], F[:-1, 1]])
    return float(np.sum((r[0] - F[:, 0]) * (f2_prev - F[:, 1])))


def knee_index(F: np.ndarray) -> int:
    """The knee of a front F (K, M): the member closest (Euclidean) to the ideal point after scaling each
    objective to [0, 1] over the front (a constant objective contributes 0). Ties: the lowest index."""
    F = _as_set(F, "F")
    if len(F) == 0:
        raise ValueError("the front is empty")
    lo, hi = F.min(axis=0), F.max(axis=0)
    G = (F - lo) / np.where(hi > lo, hi - lo, 1.0)
    return int(np.argmin(np.sum(G * G, axis=1)))


def metric_stats(values, higher_is_better: bool = False) -> dict[str, float]:
    """Table II's columns for a metric over runs: average, (sample) std, median, best and worst."""
    a = np.asarray(values, dtype=float)
    best, worst = (a.max(), a.min()) if higher_is_better else (a.min(), a.max())
    return {"ave": float(a.mean()), "std": float(a.std(ddof=1)) if a.size > 1 else 0.0,
            "median": float(np.median(a)), "best": float(best), "worst": float(worst)}


__all__ = [
    "Archive", "crowding_distance", "dominance_matrix", "dominates", "error_ratio", "hypervolume_2d", "knee_index",
    "metric_stats", "niche_counts", "nondominated", "nondominated_mask", "prune_by_crowding", "set_coverage",
    "weakly_dominates",
]
