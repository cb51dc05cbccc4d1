"""Pareto machinery for the multi-objective smoothers (Elmi and Efe 2018, Eq. 14-19).

* Dominance (Eq. 14): ``a`` dominates ``b`` when a_i <= b_i for every objective and a_i < b_i for one.
  With constraints (the planar experiment's obstacles) the archive uses **constrained dominance**
  (Deb 2000): a feasible solution (violation 0) dominates an infeasible one, of two infeasible ones
  the smaller violation dominates, and two feasible ones compare by Eq. 14. On a rosary every
  solution is feasible (the waypoints are projected onto their hatches) and this is plain Eq. 14.
* Filtering (:func:`nondominated_mask`): the K x K dominance matrix; for two objectives the same rule
  by sorting (O(K log K), the same mask: comparisons only), which the archives of MGOA and MOPSO use.
* :class:`Archive` (Eq. 15-16): the non-dominated solutions found so far, bounded in size. Pruning
  rule: while over capacity, drop the member with the smallest **crowding distance** (NSGA-II,
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

On a rosary (:class:`RosaryProblem`) the two objectives are the path length and the angle term of Nascimento
et al. 2020 Eq. 5 (``paths.path_length`` and ``paths.angle_term``); their sum is Eq. 5's f. The result of a
multi-objective smoother is a :class:`ParetoResult` (the front as arrays, its knee and its two
extremes); :class:`ParetoSmoother` (base of ``MGOASmoother`` and ``MOPSOSmoother``) adapts it to the
:class:`~foam_mj.smoothing.base.Smoother` interface: ``smooth()`` returns the knee's (or another selected
member's) :class:`SmoothingResult` with the front in ``info["front"]``; ``front()`` returns the whole
:class:`ParetoResult`.

On the obstacle rosary the two objectives hardly conflict: the convex shortest path through the
hatches (``ConvexShortestPath``) is also about as smooth as anything the swarms find, and it weakly
dominates every member of their fronts (``benchmarks/mgoa.py``, part (b)). Passing its waypoints as
``initial`` (one particle of the swarm) makes the front start there.
"""

from __future__ import annotations

import heapq
import math
import time
from abc import abstractmethod
from dataclasses import dataclass, field
from typing import Any, ClassVar, Mapping, Protocol

import numpy as np

from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import (
    Hatches,
    SeedLike,
    SmoothingResult,
    Smoother,
    _check_int,
    _check_positive,
    check_initial,
    trivial_result,
)

_EPS = 1e-12
#: What ``ParetoSmoother.smooth`` may return from the front.
SELECTIONS = ("knee", "min_f", "shortest", "smoothest")
#: The rosary objectives, in column order.
ROSARY_OBJECTIVES = ("length", "angle_term")


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
    """SCM(A, B) of Elmi and Efe 2018 Eq. 19 (Zitzler's C metric): the share of B weakly dominated by some member
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


# -- problems and runs -----------------------------------------------------------------------------------
class Problem(Protocol):
    """What the swarm optimisers need of a (multi-objective) problem over D decision variables.

    ``lb``/``ub`` (D,) bound the search box (GOA's Eq. 6 scales its social term with them);
    ``sample(rng, P)`` draws P feasible starting points (P, D); ``repair(X)`` maps positions (P, D) back
    into the feasible set (box clipping, hatch projection); ``evaluate(X)`` returns the objectives
    (P, M) and constraint violations (P,) >= 0 (0 = feasible).
    """

    lb: np.ndarray
    ub: np.ndarray

    def sample(self, rng: np.random.Generator, size: int) -> np.ndarray: ...

    def repair(self, X: np.ndarray) -> np.ndarray: ...

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class ParetoRun:
    """What MGOA.run and MOPSO.run return: the final archive and the run's history.

    ``X`` (F, D), ``objectives`` (F, M), ``violation`` (F,), sorted by the first objective.
    ``history`` maps names to per-iteration arrays (index 0 = the initial population):
    ``archive_size``, ``archive_feasible`` (1 once the archive holds feasible solutions), ``best_<name>`` (lowest value of that objective in the archive), ``mean_<name>``
    (swarm mean), ``best_sum`` (lowest sum of the objectives in the archive), ``feasible_share`` (of the
    swarm), and ``hypervolume`` (w.r.t. ``info["hv_reference"]``, the worst
    objective values of the initial swarm, for two objectives and a feasible archive; NaN otherwise).
    """

    method: str
    X: np.ndarray
    objectives: np.ndarray
    violation: np.ndarray
    history: Mapping[str, np.ndarray]
    iterations: int
    evaluations: int
    wall_time: float
    info: Mapping[str, Any] = field(default_factory=dict)

    @property
    def feasible(self) -> bool:
        return bool(len(self.violation) and np.all(self.violation <= 0))


class RunRecorder:
    """Collects a run's per-iteration history (shared by MGOA and MOPSO); ``names`` name the objectives."""

    def __init__(self, F0: np.ndarray, V0: np.ndarray, names: tuple[str, ...]) -> None:
        self.names = tuple(names)
        feas = V0 <= 0
        self.hv_ref = (F0[feas] if feas.any() else F0).max(axis=0).astype(float)
        self.rows: dict[str, list[float]] = {"archive_size": [], "archive_feasible": [], "feasible_share": [],
                                             "hypervolume": [], "best_sum": []}
        for nm in self.names:
            self.rows[f"best_{nm}"] = []
            self.rows[f"mean_{nm}"] = []

    def record(self, archive: Archive, F: np.ndarray, V: np.ndarray) -> None:
        r = self.rows
        r["archive_size"].append(len(archive))
        r["archive_feasible"].append(1.0 if archive.feasible else 0.0)
        r["feasible_share"].append(float(np.mean(V <= 0)))
        r["best_sum"].append(float(archive.F.sum(axis=1).min()))
        for j, nm in enumerate(self.names):
            r[f"best_{nm}"].append(float(archive.F[:, j].min()))
            r[f"mean_{nm}"].append(float(F[:, j].mean()))
        two = len(self.names) == 2 and archive.feasible
        r["hypervolume"].append(hypervolume_2d(archive.F, self.hv_ref) if two else math.nan)

    def history(self) -> dict[str, np.ndarray]:
        out = {}
        for k, v in self.rows.items():
            a = np.array(v, dtype=float)
            a.setflags(write=False)
            out[k] = a
        return out


def finish_run(method: str, archive: Archive, rec: RunRecorder, iterations: int, evaluations: int,
               t_start: float, info: Mapping[str, Any]) -> ParetoRun:
    """The ParetoRun of a finished optimiser: the archive sorted by the first objective."""
    order = np.lexsort(archive.F.T[::-1])
    X, F, V = (np.array(a[order]) for a in (archive.X, archive.F, archive.V))
    for a in (X, F, V):
        a.setflags(write=False)
    info = dict(info)
    info["hv_reference"] = rec.hv_ref.tolist()
    return ParetoRun(method, X, F, V, rec.history(), iterations, evaluations,
                     time.perf_counter() - t_start, info)


def check_schedule_params(c_max: Any, c_min: Any) -> None:
    _check_positive("c_max", c_max)
    _check_positive("c_min", c_min)
    if float(c_min) > float(c_max):
        raise ValueError(f"c_min must be <= c_max, got c_min={c_min!r} > c_max={c_max!r}")


# -- the rosary problem ----------------------------------------------------------------------------------
def length_and_angle(points: np.ndarray) -> np.ndarray:
    """(paths.path_length, paths.angle_term) of paths (P, k+1, n) in one pass -> (P, 2): the two terms of
    Nascimento et al. 2020 Eq. 5 (length; mean supplementary angle over the interior vertices, a vertex next to a
    zero-length segment counting as straight)."""
    p = np.asarray(points, dtype=float)
    seg = p[..., 1:, :] - p[..., :-1, :]
    lens = np.sqrt(np.einsum("...i,...i->...", seg, seg))
    dot = np.einsum("...i,...i->...", seg[..., :-1, :], seg[..., 1:, :])
    den = lens[..., :-1] * lens[..., 1:]
    cos = np.where(den > _EPS, dot / np.where(den > _EPS, den, 1.0), 1.0)
    ang = np.arccos(np.clip(cos, -1.0, 1.0))
    angle = ang.mean(axis=-1) if ang.shape[-1] else np.zeros(ang.shape[:-1])
    return np.stack([lens.sum(axis=-1), angle], axis=-1)


class RosaryProblem:
    """The waypoints of a rosary (Nascimento et al. 2020 Eq. 3) as a two-objective problem: minimise (length,
    angle term) with waypoint i in hatch i.

    Decision vector: the k-1 waypoints flattened waypoint-major (D = (k-1) n). The search box is the
    bounding box of every hatch (box of ball a ∩ box of ball b). ``repair`` is the Euclidean
    projection onto the hatches shrunk by ``inset`` (``Hatches.project``, closed form), so every
    position the optimisers evaluate is feasible (violation 0) and its path lies in the rosary's
    certified bubbles; the small default inset keeps projected waypoints strictly inside the closed
    hatches despite rounding.
    """

    names = ROSARY_OBJECTIVES

    def __init__(self, rosary: Rosary, inset: float = 1e-9) -> None:
        self.rosary = rosary
        self.hatches = Hatches.of(rosary)
        self.inset = float(inset)
        h = self.hatches
        if np.any(h.ra <= 2 * self.inset) or np.any(h.rb <= 2 * self.inset):
            raise ValueError(f"inset {inset} is too large for the rosary's smallest ball")
        self.m, self.n = h.m, rosary.dim
        lo = np.maximum(h.ca - h.ra[:, None], h.cb - h.rb[:, None])
        hi = np.minimum(h.ca + h.ra[:, None], h.cb + h.rb[:, None])
        self.lb = lo.ravel()
        self.ub = hi.ravel()
        self._q0 = rosary.q_init
        self._q1 = rosary.q_goal

    @property
    def dim(self) -> int:
        return self.m * self.n

    def waypoints(self, X: np.ndarray) -> np.ndarray:
        """(..., D) -> (..., k-1, n)."""
        X = np.asarray(X, dtype=float)
        return X.reshape(X.shape[:-1] + (self.m, self.n))

    def sample(self, rng: np.random.Generator, size: int) -> np.ndarray:
        w = self.hatches.sample(rng, np.broadcast_to(np.arange(self.m), (size, self.m)))
        return self.repair(w.reshape(size, self.dim))

    def repair(self, X: np.ndarray) -> np.ndarray:
        w = self.hatches.project(self.waypoints(X), self.inset)
        return w.reshape(np.shape(X))

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = self.waypoints(X)
        F = length_and_angle(self.rosary.path(w))
        return F, np.zeros(len(F))


# -- the result on a rosary --------------------------------------------------------------------------------
@dataclass(frozen=True)
class ParetoResult:
    """The Pareto front of a multi-objective smoother on a rosary.

    ``front_waypoints`` (F, k-1, n) and ``front_paths`` (F, k+1, n), ``front_objectives`` (F, 2) with
    columns ``objective_names`` = ("length", "angle_term") (paths.path_length and paths.angle_term;
    their sum is Nascimento et al. 2020 Eq. 5's f), sorted by length (so by decreasing angle term). ``knee`` indexes
    the member closest to the ideal point (:func:`knee_index`); ``extremes`` = (shortest, smoothest).
    ``history`` per iteration (index 0 = initial swarm): archive_size, archive_feasible, best_length, best_angle_term,
    mean_length, mean_angle_term, feasible_share, hypervolume, best_f (lowest f = length + angle term
    in the archive), mean_f (swarm mean f). ``convex_length`` is filled in by :meth:`with_convex`.
    """

    method: str
    rosary: Rosary
    front_waypoints: np.ndarray
    front_paths: np.ndarray
    front_objectives: np.ndarray
    knee: int
    extremes: tuple[int, int]
    history: Mapping[str, np.ndarray]
    iterations: int
    evaluations: int
    wall_time: float
    info: Mapping[str, Any] = field(default_factory=dict)
    objective_names: tuple[str, str] = ROSARY_OBJECTIVES

    @classmethod
    def from_run(cls, run: ParetoRun, problem: RosaryProblem) -> "ParetoResult":
        W = np.array(problem.waypoints(run.X))
        P = problem.rosary.path(W)
        F = np.array(run.objectives)
        for a in (W, P, F):
            a.setflags(write=False)
        h = dict(run.history)
        h["best_f"] = h.pop("best_sum")
        h["mean_f"] = h["mean_length"] + h["mean_angle_term"]
        ext = (int(np.argmin(F[:, 0])), int(np.argmin(F[:, 1])))
        return cls(run.method, problem.rosary, W, P, F, knee_index(F), ext, h, run.iterations,
                   run.evaluations, run.wall_time, dict(run.info))

    @property
    def size(self) -> int:
        return len(self.front_objectives)

    @property
    def lengths(self) -> np.ndarray:
        return self.front_objectives[:, 0]

    @property
    def angle_terms(self) -> np.ndarray:
        return self.front_objectives[:, 1]

    @property
    def f(self) -> np.ndarray:
        """Nascimento et al. 2020 Eq. 5 of every member."""
        return self.front_objectives.sum(axis=1)

    def index(self, select: str) -> int:
        """The member ``select`` names: "knee", "min_f" (lowest Eq. 5 f), "shortest" or "smoothest"."""
        if select == "knee":
            return self.knee
        if select == "min_f":
            return int(np.argmin(self.f))
        if select == "shortest":
            return self.extremes[0]
        if select == "smoothest":
            return self.extremes[1]
        raise ValueError(f"select must be one of {SELECTIONS}, got {select!r}")

    def result(self, i: int | str = "knee", method: str | None = None) -> SmoothingResult:
        """Member i (an index or a :data:`SELECTIONS` name) as a :class:`SmoothingResult`: histories of
        f (Eq. 5; best = lowest f in the archive, mean = the swarm's), the front in ``info["front"]``."""
        idx = self.index(i) if isinstance(i, str) else int(i)
        if not 0 <= idx < self.size:
            raise ValueError(f"front index {idx} out of range (front of {self.size})")
        label = i if isinstance(i, str) else f"member {idx}"
        info = dict(self.info)
        info.update({"selected": label, "selected_index": idx, "front": self.front_arrays(),
                     "front_size": self.size, "pareto": self})
        return SmoothingResult.build(
            method or self.method, self.rosary, self.front_waypoints[idx],
            history_best=self.history["best_f"], history_mean=self.history["mean_f"],
            iterations=self.iterations, evaluations=self.evaluations, wall_time=self.wall_time,
            stop_reason="iteration cap", objective="f", info=info,
        )

    def knee_result(self) -> SmoothingResult:
        return self.result("knee")

    def extreme_results(self) -> tuple[SmoothingResult, SmoothingResult]:
        return self.result("shortest"), self.result("smoothest")

    def front_arrays(self) -> dict[str, Any]:
        """The front for recordings and JSON: waypoints (F, k-1, n), paths (F, k+1, n), objectives (F, 2),
        objective names, knee index, extremes (shortest, smoothest)."""
        return {"waypoints": self.front_waypoints, "paths": self.front_paths, "objectives": self.front_objectives,
                "objective_names": list(self.objective_names), "knee": self.knee, "extremes": list(self.extremes)}

    def all_in_hatches(self, tol: float = 0.0) -> bool:
        return self.rosary.all_in_hatches(self.front_waypoints, tol)

    def summary(self, convex_length: float | None = None) -> dict:
        """Scalars for tables and JSON (with the gaps to ``convex_length`` when given)."""
        F = self.front_objectives
        out = {
            "method": self.method, "front_size": self.size, "iterations": self.iterations,
            "evaluations": self.evaluations, "wall_time": self.wall_time,
            "shortest": {"length": float(F[self.extremes[0], 0]), "angle_term": float(F[self.extremes[0], 1])},
            "smoothest": {"length": float(F[self.extremes[1], 0]), "angle_term": float(F[self.extremes[1], 1])},
            "knee": {"length": float(F[self.knee, 0]), "angle_term": float(F[self.knee, 1])},
            "min_f": float(self.f.min()),
            "hypervolume": float(self.history["hypervolume"][-1]),
        }
        if convex_length is not None:
            out["convex_length"] = float(convex_length)
            for key in ("shortest", "knee", "smoothest"):
                out[key]["length_gap_to_convex"] = out[key]["length"] - float(convex_length)
                out[key]["length_ratio_to_convex"] = out[key]["length"] / float(convex_length)
        return out


# -- the smoother adapter -------------------------------------------------------------------------------------
class ParetoSmoother(Smoother):
    """A multi-objective smoother: ``front(rosary, initial, seed)`` -> :class:`ParetoResult`;
    ``smooth(...)`` -> the SmoothingResult of the member named by ``self.select`` (default "knee"),
    with the front in ``info["front"]`` and the ParetoResult in ``info["pareto"]``.

    Subclasses provide ``run(problem, seed, initial)`` -> :class:`ParetoRun` and the fields ``select``
    and ``inset``.
    """

    name: ClassVar[str]
    select: str
    inset: float

    @abstractmethod
    def run(self, problem: Problem, seed: SeedLike = 0, initial: np.ndarray | None = None) -> ParetoRun:
        """Optimise ``problem``."""

    def _check_smoother(self) -> None:
        if self.select not in SELECTIONS:
            raise ValueError(f"select must be one of {SELECTIONS}, got {self.select!r}")
        _check_positive("inset", self.inset, allow_zero=True)

    def front(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> ParetoResult:
        """The Pareto front of (length, angle term) over the rosary's hatches. ``initial`` (optional,
        (k-1, n) in the hatches) replaces one particle of the random initial swarm."""
        init = check_initial(rosary, initial)
        if rosary.n_hatches == 0:
            raise ValueError(f"the rosary has {rosary.k} bubble(s): there is no waypoint to smooth (need k >= 2)")
        problem = RosaryProblem(rosary, self.inset)
        x0 = None if init is None else problem.repair(init.reshape(1, -1))[0]
        run = self.run(problem, seed, x0)
        return ParetoResult.from_run(run, problem)

    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> SmoothingResult:
        if rosary.n_hatches == 0:
            check_initial(rosary, initial)
            return trivial_result(self.name, rosary, time.perf_counter())
        return self.front(rosary, initial, seed).result(self.select, self.name)


__all__ = [
    "Archive", "ParetoResult", "ParetoRun", "ParetoSmoother", "Problem", "RosaryProblem", "SELECTIONS",
    "crowding_distance", "dominance_matrix", "dominates", "error_ratio", "hypervolume_2d", "knee_index",
    "length_and_angle", "metric_stats", "niche_counts", "nondominated", "nondominated_mask",
    "prune_by_crowding", "set_coverage", "weakly_dominates",
]
