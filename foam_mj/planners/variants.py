"""The PFM variants of Nascimento et al. (2021): goal-biased (GBPF), radius-biased (RBPF), heuristic-guided (HPF).

L. B. P. Nascimento, D. Barrios-Aranibar, V. G. Santos, D. S. Pereira, W. C. Ribeiro, P. J. Alsina,
"Safe Path Planning Algorithms for Mobile Robots Based on Probabilistic Foam", Sensors 21(12):4156, 2021.

All three keep PFM's bubbles (certified radius r(q) = (d(q) - delta) / ||rho||_2 from MuJoCo distance
queries, :class:`~foam_mj.bubbles.BubbleOracle`), its rule that a child's centre lies on its parent's
surface, outside every other bubble, with a radius of at least r_min, and its rosary (the parent
chain from the root to the bubble holding q_goal). They change only *which* parent grows next:

* **GBPF** (the paper's Algorithm 2, introduced in the authors' earlier work): each iteration draws an
  auxiliary configuration q_aux, q_goal with probability ``bias`` and a uniform sample of the bounds
  otherwise; the bubble whose centre is nearest to q_aux is the parent, and the one candidate is the
  point of its surface nearest to q_aux: c + r (q_aux - c) / |q_aux - c|. An RRT-like, goal-driven
  foam: the paper reports it fast.
* **RBPF** (Algorithm 3): PFM's expansion (N = K floor(r / r_min)^(n-1) candidates drawn uniformly on
  the parent's surface, Nascimento et al. 2020 Eq. 2), but the parent is drawn from the open list (bubbles not yet
  expanded) by roulette wheel, with probability p_i = r_i / sum_j r_j (Eq. 6): wide, high-clearance
  regions grow first; the paper reports high-clearance paths.
* **HPF** (Algorithm 4): PFM's expansion, but the open bubble with the least f = g + h (Eq. 7) is
  expanded first (best-first, as A*): h(b) = |c_b - q_goal|, g(b) the length of the centre polyline
  from the root to c_b along parents; the paper reports short paths.

What is reconstructed, and why
------------------------------
Only the paper's abstract was readable here (the full text was not in the sources available to this
project), so the algorithms are rebuilt from the abstract (GBPF fast, HPF short paths, RBPF high
clearance; RBPF and HPF new in that paper), the method names, the authors' published 2-D GBPF
script, and two public third-party reimplementations that cite the paper (they agree on RBPF's roulette
wheel over the radii and HPF's best-first f = g + h, and disagree on HPF's g). The algorithm and
equation numbers used here (Algorithms 2-4, Eq. 6, Eq. 7) are theirs: they could not be checked
against the paper's text. The choices:

* GBPF's ``bias`` defaults to 0.25, the value in the authors' 2-D script; the nearest bubble is the
  nearest *centre* (Euclidean in q), as there.
* RBPF's roulette weights are the radii themselves (Eq. 6 as p_i = r_i / sum r_j); an expanded
  bubble leaves the open list (each bubble is expanded once, as in PFM).
* HPF's g adds the distance between consecutive centres, i.e. the parent's radius (a child sits on its
  parent's surface), so g is the centre path's length and g + h a lower bound of any centre path
  through b: the A* reading of "heuristic-guided" for short paths (one reimplementation adds the
  child's radius instead, which is not a length). Ties go to the older bubble.
* K defaults to Nascimento et al. 2020's 10, as pfm's. Nascimento and Alsina 2021 (section 5.1) says that
  Nascimento et al. 2021 defines K as a function of the dimension of C, and uses K = 6 for n = 3 (the leg and
  the walker); the function itself could not be read, so it is not applied (pass K = 6 for the thesis's setting).
* Every variant starts from a root bubble of *any* positive certified radius (pfm requires
  r >= r_min there): the root gets at least K candidates, since floor(r / r_min) = 0 would leave it
  none. A start or goal with clearance <= delta is refused (:class:`ConfigurationError`).

Batching and determinism
------------------------
RBPF and HPF take one parent per iteration, exactly as the paper's loop; its candidates are sized in
one batch (:meth:`BubbleOracle.radii`) and accepted in their drawn order, each checked against the
siblings accepted before it (as :func:`foam_mj.foam.plan`). GBPF draws ``batch`` auxiliary samples per
iteration against the foam as it stood at the start of the iteration and sizes their candidates in one
batch; ``batch = 1`` is the paper's loop exactly. A candidate that GBPF has already rejected (same
parent, same direction toward q_goal) is not queried again: its answer cannot change. All randomness
comes from one ``numpy.random.Generator`` seeded by ``seed``: same seed, same foam.
"""

from __future__ import annotations

import heapq
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from foam_mj.bubbles import BubbleOracle
from foam_mj.coverage import CoverageIndex, accept_in_order
from foam_mj.errors import ConfigurationError, PlanningFailed, clearance_text, is_number, radius_text
from foam_mj.foam import Foam, FoamParams, FoamStats, PlanResult, check_candidate_bound, load_kd_tree, nearest_hint, seed_rng, small_goal_hint
from foam_mj.planners.closure import closure_text, foam_closure, queue_empty_text, surface_holds_no_child
from foam_mj.rosary import MEMBERSHIP_TOL

if TYPE_CHECKING:  # scipy is imported where a k-d tree is built (as in foam_mj.foam)
    from scipy.spatial import cKDTree

#: Citation used in docstrings, the README and docs/references.md.
PAPER = (
    'Nascimento, Barrios-Aranibar, Santos, Pereira, Ribeiro, Alsina: "Safe Path Planning Algorithms for '
    'Mobile Robots Based on Probabilistic Foam", Sensors 21(12):4156, 2021'
)


#: The largest GBPF ``batch``: a batch is drawn, measured and scanned whole before the time budget is looked at again;
#: 10,000 samples took the obstacle scene 5 s per batch (6 bubbles by the budget), 2**40 asked numpy for 8 TiB.
MAX_BATCH = 1_000


@dataclass(frozen=True)
class GoalBias:
    """GBPF's own parameters: the probability of aiming at q_goal, and auxiliary samples per batch."""

    bias: float = 0.25
    batch: int = 8

    def __post_init__(self) -> None:
        if not (is_number(self.bias) and 0.0 <= self.bias <= 1.0):  # a string was "'<=' not supported between ..."
            raise ValueError(f"`bias` must be a number in [0, 1], got {self.bias!r}")
        if not (isinstance(self.batch, (int, np.integer)) and not isinstance(self.batch, bool) and 1 <= self.batch <= MAX_BATCH):
            raise ValueError(f"`batch` must be an integer in [1, {MAX_BATCH:,}], got {self.batch!r}")


def _unit(rng: np.random.Generator, count: int, dim: int) -> np.ndarray:
    u = rng.standard_normal((count, dim))
    return u / np.linalg.norm(u, axis=1, keepdims=True)


class _Growth:
    """The foam under construction, shared by the three variants: storage, coverage, candidate tests, budget."""

    def __init__(self, oracle: BubbleOracle, q_init: ArrayLike, q_goal: ArrayLike, params: FoamParams, seed, progress) -> None:
        robot = oracle.robot
        self.oracle = oracle
        self.params = params
        robot.check_unchanged()
        self.q_init = robot.validate(q_init, "q_init")
        self.q_goal = robot.validate(q_goal, "q_goal")
        if oracle.delta != params.delta:
            raise ValueError(f"the oracle's margin delta={oracle.delta} differs from params.delta={params.delta}")
        self.rng = seed_rng(seed)
        self.n = robot.dim
        self.lo, self.hi = robot.lower, robot.upper
        load_kd_tree()
        self.t0 = time.perf_counter()
        self.stats = FoamStats()
        self.calls0 = oracle.clearance.calls
        self.progress = progress
        self.next_report = self.t0 + 0.5
        for name, q in (("q_init", self.q_init), ("q_goal", self.q_goal)):
            c = float(oracle.clearance(q))
            if c <= params.delta:
                state = "in collision" if c < 0 else "too close to an obstacle"
                raise ConfigurationError(f"{name} {q.tolist()} is {state}: clearance {clearance_text(c, params.delta)} <= margin delta = {params.delta} m")
        self.root_distances = oracle.clearance.pair_distances(self.q_init)  # per pair, for root_cannot_grow
        self._root_closed: bool | None = None
        r0 = float(oracle.radius_from_distances(self.root_distances, self.q_init))
        if r0 <= 0.0:
            raise ConfigurationError(f"q_init {self.q_init.tolist()} lies on the boundary of the joint bounds: no certified bubble "
                                     f"centred there fits (the bubbletree planner accepts it)")
        cap = 1024
        self.centers = np.empty((cap, self.n))
        self.radii = np.empty(cap)
        self.parents = np.empty(cap, dtype=np.int64)
        self.count = 0
        self.index = CoverageIndex(self.n)
        self.goal: int | None = None
        self.closed = ""  # why the foam can grow no further, once proven (GBPF's _Closure)
        self.proven_closed: int | None = None  # bubbles proven closed so far, once GBPF's _Closure has checked
        self.open_at: tuple[int, np.ndarray] | None = None  # a bubble and a point of its surface where a child fits (_Closure)
        self.add(self.q_init, r0, -1)
        self.goal = 0 if self.holds_goal(self.q_init, r0) else None

    def root_cannot_grow(self) -> bool:
        """True when no child of radius >= r_min can sit on the root's surface, proven (computed once). A pair's distance
        changes by at most ||rho_p|| per unit of q, so a point r0 from q_init has radius at most min_p (d_p - delta) /
        ||rho_p|| + r0 (exact when that pair's distance reads below the cap ``distmax``, which is then required), and the
        distance to the joint box's nearest face changes by at most r0 too (a start just inside a joint limit); where
        that bound is not enough and the root is below r_min, a cover of its surface (:func:`surface_holds_no_child`)."""
        if self._root_closed is None:
            terms = self.oracle.pair_radii(self.root_distances)
            k = int(np.argmin(terms))
            r0, r_min = self.radii[0], self.params.r_min
            pair_bound = self.root_distances[k] < self.oracle.clearance.distmax and terms[k] + r0 < r_min
            self._root_closed = bool(pair_bound or float(self.oracle.to_bounds(self.q_init)) + r0 < r_min
                                     or (r0 < r_min and surface_holds_no_child(self.oracle, self.q_init, float(r0), r_min)))
        return self._root_closed

    def holds_goal(self, c: np.ndarray, r) -> np.ndarray:
        return np.sum((np.atleast_2d(c) - self.q_goal) ** 2, axis=1) <= (np.asarray(r) + MEMBERSHIP_TOL) ** 2

    def add(self, c: np.ndarray, r: float, parent: int) -> int:
        if self.count == len(self.radii):
            self.centers = np.concatenate([self.centers, np.empty_like(self.centers)])
            self.radii = np.concatenate([self.radii, np.empty_like(self.radii)])
            self.parents = np.concatenate([self.parents, np.empty_like(self.parents)])
        i = self.count
        self.centers[i], self.radii[i], self.parents[i] = c, r, parent
        self.index.add(c, r)
        self.count += 1
        return i

    def child_count(self, r: float, is_root: bool) -> int:
        """N = K floor(r / r_min)^(n-1) (Nascimento et al. 2020 Eq. 2); at least K for the root (see the module docstring)."""
        k = int(self.params.K * np.floor(r / self.params.r_min) ** (self.n - 1))
        return max(k, self.params.K) if is_root else k

    def budget(self) -> str | None:
        """The exhausted budget's name, or None (and report progress every 0.5 s)."""
        if self.count >= self.params.max_bubbles:
            return "bubble budget"
        now = time.perf_counter()
        if now - self.t0 > self.params.time_limit:
            return "time budget"
        if self.progress is not None and now >= self.next_report:
            self.stats.bubbles, self.stats.elapsed = self.count, now - self.t0
            self.progress(self.stats)
            self.next_report = now + 0.5
        return None

    def offer(self, cand: np.ndarray, parent_of: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Test candidate centres (bounds, coverage, certified radius >= r_min, earlier siblings) and add the
        survivors in order, stopping at the first that holds q_goal or at the bubble budget.

        Returns (mask over ``cand`` of the rejected ones, indices of the bubbles added)."""
        st = self.stats
        m = len(cand)
        st.candidates += m
        rejected = np.ones(m, dtype=bool)
        keep = np.all((cand >= self.lo) & (cand <= self.hi), axis=1)
        st.dropped_out_of_bounds += int(m - keep.sum())
        idx = np.flatnonzero(keep)
        cov = self.index.covered(cand[idx], parent_of[idx])
        st.dropped_covered += int(cov.sum())
        idx = idx[~cov]
        if idx.size == 0:
            return rejected, np.empty(0, dtype=np.int64)
        r = self.oracle.radii(cand[idx])
        big = r >= self.params.r_min
        st.dropped_small += int((~big).sum())
        idx, r = idx[big], r[big]
        acc = accept_in_order(cand[idx], r)
        st.dropped_covered += int((~acc).sum())
        idx, r = idx[acc], r[acc]
        idx, r = idx[: self.params.max_bubbles - self.count], r[: self.params.max_bubbles - self.count]
        reach = self.holds_goal(cand[idx], r)
        if reach.any():
            stop = int(np.argmax(reach)) + 1
            idx, r = idx[:stop], r[:stop]
        added = np.array([self.add(cand[i], float(ri), int(parent_of[i])) for i, ri in zip(idx.tolist(), r.tolist())], dtype=np.int64)
        rejected[idx] = False
        if len(added) and reach[len(added) - 1]:
            self.goal = int(added[-1])
        return rejected, added

    def finish(self, outcome: str) -> PlanResult:
        st = self.stats
        st.bubbles = self.count
        st.elapsed = time.perf_counter() - self.t0
        st.clearance_calls = self.oracle.clearance.calls - self.calls0
        st.outcome = outcome
        foam = Foam(
            self.centers[: self.count].copy(), self.radii[: self.count].copy(), self.parents[: self.count].copy(),
            self.q_init, self.q_goal, self.goal,
        )
        if self.goal is None:
            stuck = ""
            if self.count == 1 and outcome != "bubble budget":  # a budget of one bubble stopped it, not r_min
                bubble, r_min = f"the start's bubble (radius {radius_text(self.radii[0], self.params.r_min)})", f"r_min = {self.params.r_min}"
                if self.root_cannot_grow():  # proven by the bound: no candidate could have been good
                    stuck = f": no bubble of radius >= {r_min} fits on {bubble}; lower r_min, or plan with bubbletree"
                elif outcome == "time budget":  # the clock, not the geometry (a child may fit)
                    stuck = (f": the time budget ended before a bubble of radius >= {r_min} was found on {bubble}; "
                             "raise time_limit, lower r_min, or plan with bubbletree")
                else:  # the candidates drawn all failed; others might not
                    stuck = f": none of the candidates drawn on {bubble} had radius >= {r_min}; lower r_min, or plan with bubbletree"
            else:
                stuck = (small_goal_hint(self.oracle, self.q_goal, self.params.r_min, outcome, self.params.time_limit, self.params.max_bubbles)
                         or nearest_hint(self.oracle, foam, self.params.r_min, outcome, self.params.time_limit, self.params.max_bubbles))
                if self.closed:
                    stuck = f"{self.closed}; {stuck.removeprefix(': ')}"
                elif outcome == "queue empty":  # rbpf, hpf: every bubble expanded once
                    stuck += queue_empty_text(self.oracle, foam, self.params.r_min, self.params.K)
                elif self.proven_closed is not None:  # gbpf's closure checks ran: how far the foam was from closed
                    stuck += (f"; {self.proven_closed:,} of its {self.count:,} bubbles are proven closed at r_min (no bubble of "
                              "r_min fits on their surfaces outside the others)")
                    if self.open_at is not None:  # a point where a child fits, found by the last check
                        i, x = self.open_at
                        stuck += (f"; the bubble at q = {np.round(self.centers[i], 4).tolist()} still has room for one of radius "
                                  f"{float(self.oracle.radii(x[None])[0]):.3g} at q = {np.round(x, 4).tolist()}, which its samples have not hit")
            raise PlanningFailed.after(f"the foam did not reach q_goal ({outcome}) after {st.bubbles} bubbles", st, stuck, foam)
        return PlanResult(foam, foam.rosary(), st)


def _expand(g: _Growth, parent: int) -> np.ndarray:
    """PFM's expansion of one parent: N candidates uniform on its surface, tested and added in drawn order."""
    g.stats.parents_expanded += 1
    count = g.child_count(float(g.radii[parent]), parent == 0)
    if count == 0:
        return np.empty(0, dtype=np.int64)
    cand = g.centers[parent] + g.radii[parent] * _unit(g.rng, count, g.n)
    _, added = g.offer(cand, np.full(count, parent, dtype=np.int64))
    return added


def plan_rbpf(
    oracle: BubbleOracle, q_init: ArrayLike, q_goal: ArrayLike, params: FoamParams = FoamParams(), seed: int | np.random.Generator = 0,
    progress: Callable[[FoamStats], None] | None = None,
) -> PlanResult:
    """Radius-biased Probabilistic Foam (RBPF, Nascimento et al. 2021, Algorithm 3): the next parent is drawn
    from the open list by roulette wheel, p_i = r_i / sum_j r_j (Eq. 6), then expanded as in PFM.

    Raises :class:`ConfigurationError` for a bad start or goal and :class:`PlanningFailed` when the open
    list empties or a budget runs out."""
    check_candidate_bound(params, oracle.robot.lower, oracle.robot.upper)  # PFM's expansion: N = K floor(r / r_min)^(n-1)
    g = _Growth(oracle, q_init, q_goal, params, seed, progress)
    open_w = np.zeros(1024)  # roulette weight of each bubble: its radius while open, 0 once expanded
    open_w[0] = g.radii[0]
    while g.goal is None:
        if (outcome := g.budget()) is not None:
            return g.finish(outcome)
        w = open_w[: g.count]
        cum = np.cumsum(w)
        if cum[-1] <= 0.0:
            return g.finish("queue empty")
        parent = min(int(np.searchsorted(cum, g.rng.random() * cum[-1], side="right")), g.count - 1)
        while w[parent] == 0.0:  # guard against rounding at the wheel's edges
            parent -= 1
        open_w[parent] = 0.0
        added = _expand(g, parent)
        if g.count > len(open_w):
            open_w = np.concatenate([open_w, np.zeros(max(len(open_w), g.count))])
        open_w[added] = g.radii[added]
    return g.finish("reached")


def plan_hpf(
    oracle: BubbleOracle, q_init: ArrayLike, q_goal: ArrayLike, params: FoamParams = FoamParams(), seed: int | np.random.Generator = 0,
    progress: Callable[[FoamStats], None] | None = None,
) -> PlanResult:
    """Heuristic-guided Probabilistic Foam (HPF, Nascimento et al. 2021, Algorithm 4): the open bubble with the
    least f = g + h (Eq. 7) is expanded next, h = |c - q_goal|, g the centre-path length from the root.

    Raises :class:`ConfigurationError` for a bad start or goal and :class:`PlanningFailed` when the open
    list empties or a budget runs out."""
    check_candidate_bound(params, oracle.robot.lower, oracle.robot.upper)  # PFM's expansion: N = K floor(r / r_min)^(n-1)
    g = _Growth(oracle, q_init, q_goal, params, seed, progress)
    cost = np.zeros(1024)  # g of each bubble
    heap: list[tuple[float, int]] = [(float(np.linalg.norm(g.q_init - g.q_goal)), 0)]
    while g.goal is None:
        if (outcome := g.budget()) is not None:
            return g.finish(outcome)
        if not heap:
            return g.finish("queue empty")
        _, parent = heapq.heappop(heap)
        added = _expand(g, parent)
        if g.count > len(cost):
            cost = np.concatenate([cost, np.zeros(max(len(cost), g.count))])
        if len(added):
            cost[added] = cost[parent] + g.radii[parent]
            h = np.linalg.norm(g.centers[added] - g.q_goal, axis=1)
            for f, i in zip((cost[added] + h).tolist(), added.tolist()):
                heapq.heappush(heap, (f, i))
    return g.finish("reached")


class _NearestCentre:
    """Nearest bubble centre to query points: a k-d tree rebuilt as the foam doubles, plus a brute-force buffer."""

    def __init__(self) -> None:
        self._tree: cKDTree | None = None
        self._n_tree = 0

    def query(self, centers: np.ndarray, count: int, points: np.ndarray) -> np.ndarray:
        if count - self._n_tree > max(64, self._n_tree // 8):
            from scipy.spatial import cKDTree

            self._tree = cKDTree(centers[:count])
            self._n_tree = count
        best_d = np.full(len(points), np.inf)
        best_i = np.zeros(len(points), dtype=np.int64)
        if self._tree is not None:
            best_d, best_i = self._tree.query(points)
            best_i = np.asarray(best_i, dtype=np.int64)
        if count > self._n_tree:
            buf = centers[self._n_tree : count]
            d = np.linalg.norm(points[:, None, :] - buf[None, :, :], axis=2)
            j = np.argmin(d, axis=1)
            closer = d[np.arange(len(points)), j] < best_d
            best_i[closer] = self._n_tree + j[closer]
        return best_i


def plan_gbpf(
    oracle: BubbleOracle, q_init: ArrayLike, q_goal: ArrayLike, params: FoamParams = FoamParams(), seed: int | np.random.Generator = 0,
    progress: Callable[[FoamStats], None] | None = None, goal_bias: GoalBias = GoalBias(),
) -> PlanResult:
    """Goal-biased Probabilistic Foam (GBPF, Nascimento et al. 2021, Algorithm 2): aim at q_goal with probability
    ``goal_bias.bias`` and at a uniform sample otherwise; grow the nearest bubble's surface point toward it.

    K is not used (one candidate per sample). Raises :class:`ConfigurationError` for a bad start or goal and
    :class:`PlanningFailed` when a budget runs out."""
    g = _Growth(oracle, q_init, q_goal, params, seed, progress)
    nearest = _NearestCentre()
    dead_toward_goal = np.zeros(1024, dtype=bool)  # bubble's candidate toward q_goal already rejected
    B = int(goal_bias.batch)
    if g.goal is None and g.root_cannot_grow():
        return g.finish("queue empty")  # random samples would spend the whole time budget finding nothing
    closure = _Closure(g)
    idle = 0  # batches since a bubble was last added
    while g.goal is None:
        if (outcome := g.budget()) is not None:
            return g.finish(outcome)
        g.stats.parents_expanded += B
        to_goal = g.rng.random(B) < goal_bias.bias
        aux = g.lo + (g.hi - g.lo) * g.rng.random((B, g.n))
        aux[to_goal] = g.q_goal
        parent = nearest.query(g.centers, g.count, aux)
        skip = to_goal & dead_toward_goal[parent]
        if goal_bias.bias == 1.0 and skip.all():
            return g.finish("queue empty")  # every bubble's step toward q_goal is spent: nothing else to try
        aux, parent, to_goal = aux[~skip], parent[~skip], to_goal[~skip]
        step = aux - g.centers[parent]
        norm = np.linalg.norm(step, axis=1)
        ok = norm > 0.0
        aux, parent, to_goal, step, norm = aux[ok], parent[ok], to_goal[ok], step[ok], norm[ok]
        if len(aux) == 0:
            continue
        cand = g.centers[parent] + g.radii[parent, None] * step / norm[:, None]
        rejected, added = g.offer(cand, parent)
        dead_toward_goal[parent[to_goal & rejected]] = True
        idle = 0 if len(added) else idle + 1
        if idle >= CLOSURE_IDLE and closure.proven():
            return g.finish("queue empty")  # no sample can ever add a bubble
        if idle >= CLOSURE_IDLE and g.open_at is not None:  # FILL: the room the check found, as a sample aimed there would
            i, x = g.open_at
            if len(g.offer(x[None], np.array([i]))[1]):
                g.open_at = None  # filled: no longer room
        if g.count > len(dead_toward_goal):
            dead_toward_goal = np.concatenate([dead_toward_goal, np.zeros(max(len(dead_toward_goal), g.count), dtype=bool)])
    return g.finish("reached")


#: GBPF checks whether its foam is closed (:class:`_Closure`) after each batch once this many in a row added no bubble.
#: Reachable goals went at most 3 batches without a bubble (session 15's measurement); unreachable ones 51-501 on the
#: 3-joint leg, and the rest of the budget on a 2-joint puck behind a wall. FILL: a check that finds room for a bubble (a
#: surface point outside the others with radius >= r_min) adds it, so that the checks end in a proof: the puck's foam is
#: closed after 0.1 s of CPU (its samples found that room after 1.2-1.8 s), the 3-joint leg behind a wall 2 m tall after
#: 8-10 s (seeds 0-2; it drew samples until any budget ended). Reachable goals never reach a check (above): unchanged.
CLOSURE_IDLE = 16


class _Closure:
    """Whether GBPF's foam is closed at r_min: no point of any bubble's surface, inside the joint box and strictly
    inside no other bubble, has a certified radius >= r_min (:func:`surface_holds_no_child` with the other bubbles,
    bubble by bubble). Then no candidate GBPF can draw (a point of a bubble's surface) is ever kept: the foam can
    grow no further, and waiting out the time budget would change nothing. Sound by construction, and monotone: a
    bubble proven closed stays closed as bubbles are added (they only cover more), so each is proven once."""

    def __init__(self, g: _Growth) -> None:
        self.g = g
        self.done = 0  # bubbles 0 .. done - 1 are proven closed
        self.blocked = (-1, 0)  # the bubble last found open (or not proven), and the foam's size then
        self.queries = 0

    def proven(self) -> bool:
        """Prove the remaining bubbles closed, in order; False at the first that is not. That bubble is examined again
        only once a bubble added since reaches its surface: its proof depends on nothing else (the radius and the box
        do not change), so until then the answer is the same, and a check costs no distance query."""
        g = self.g
        i, size = self.blocked
        if i >= 0 and not np.any(np.linalg.norm(g.centers[size : g.count] - g.centers[i], axis=1) < g.radii[size : g.count] + g.radii[i]):
            return False
        calls = g.oracle.clearance.calls
        # a long proof stops with the budget (and reports progress)
        self.done, g.open_at = foam_closure(g.oracle, g.centers[: g.count], g.radii[: g.count], g.params.r_min, self.done,
                                            stop=lambda: g.budget() is not None)
        g.proven_closed = self.done
        self.queries += g.oracle.clearance.calls - calls
        if self.done < g.count:
            self.blocked = (self.done, g.count)
            return False
        g.closed = f": {closure_text(g.count, g.params.r_min, self.queries)}, so no sample can add one"
        return True


# ---------------------------------------------------------------------------------------------------
# The planner seam: ``--planner gbpf | rbpf | hpf``.

from foam_mj.planners.base import PlanningProblem, PlanResult as SeamResult, PlanStats, Planner, Progress, ProgressFn, check_problem  # noqa: E402


@dataclass(frozen=True)
class FoamOptions:
    """K candidates per unit of r / r_min (Nascimento et al. 2020 Eq. 2) and r_min, the smallest bubble kept (Nascimento et al. 2020's
    defaults, as pfm's)."""

    K: int = 10
    r_min: float = 0.07

    def __post_init__(self) -> None:
        FoamParams(K=self.K, r_min=self.r_min)  # the same validation and messages as pfm's


@dataclass(frozen=True)
class GBPFOptions:
    """r_min, the smallest bubble kept; ``bias``, the probability of aiming at q_goal; ``batch``, auxiliary
    samples sized per distance-query batch (1 = the paper's loop exactly)."""

    r_min: float = 0.07
    bias: float = 0.25
    batch: int = 8

    def __post_init__(self) -> None:
        FoamParams(r_min=self.r_min)
        GoalBias(self.bias, self.batch)


def _seam_stats(name: str, st: FoamStats, reached: bool) -> PlanStats:
    details = {k: v for k, v in st.as_dict().items() if k not in ("bubbles", "elapsed", "outcome", "clearance_calls", "bubbles_per_second")}
    return PlanStats(
        planner=name, outcome=st.outcome, bubbles=st.bubbles, distance_queries=st.clearance_calls, elapsed=st.elapsed,
        time_to_first_path=st.elapsed if reached else None, details=details,
    )


class _VariantPlanner(Planner):
    Options: ClassVar[type] = FoamOptions

    def _run(self, problem: PlanningProblem, params: FoamParams, seed, progress: ProgressFn | None, **kw) -> SeamResult:
        report = None if progress is None else (lambda st: progress(Progress(st.bubbles, st.elapsed)))
        fn = _FUNCTIONS[self.name]
        try:
            res = fn(problem.oracle, problem.q_init, problem.q_goal, params, seed=seed, progress=report, **kw)
        except PlanningFailed as exc:
            stats = _seam_stats(self.name, exc.stats, False) if isinstance(exc.stats, FoamStats) else exc.stats
            raise PlanningFailed(str(exc), stats, exc.foam, exc.reason) from None
        return SeamResult(res.foam, res.rosary, _seam_stats(self.name, res.stats, True))

    def plan(self, problem: PlanningProblem, seed: int | np.random.Generator = 0, progress: ProgressFn | None = None) -> SeamResult:
        check_problem(problem, progress)
        o = self.options
        params = FoamParams(K=getattr(o, "K", FoamParams.K), r_min=o.r_min, delta=problem.delta,
                            max_bubbles=int(problem.max_bubbles), time_limit=problem.time_limit)
        return self._run(problem, params, seed, progress)


class GBPFPlanner(_VariantPlanner):
    name = "gbpf"
    summary = "goal-biased Probabilistic Foam (Nascimento et al., Sensors 2021): grow the nearest bubble toward q_goal or a sample"
    Options = GBPFOptions

    def plan(self, problem: PlanningProblem, seed: int | np.random.Generator = 0, progress: ProgressFn | None = None) -> SeamResult:
        check_problem(problem, progress)
        o = self.options
        params = FoamParams(r_min=o.r_min, delta=problem.delta, max_bubbles=int(problem.max_bubbles), time_limit=problem.time_limit)
        return self._run(problem, params, seed, progress, goal_bias=GoalBias(o.bias, o.batch))


class RBPFPlanner(_VariantPlanner):
    name = "rbpf"
    summary = "radius-biased Probabilistic Foam (Nascimento et al., Sensors 2021): parents drawn by roulette on their radii"


class HPFPlanner(_VariantPlanner):
    name = "hpf"
    summary = "heuristic-guided Probabilistic Foam (Nascimento et al., Sensors 2021): best-first on g + h, as A*"


_FUNCTIONS = {"gbpf": plan_gbpf, "rbpf": plan_rbpf, "hpf": plan_hpf}
