"""Probabilistic Foam propagation (Nascimento et al. 2020 section 3.1; Nascimento and Alsina 2021 section 2.1).

The root bubble is centred at q_init with the certified radius. Parents are taken first-in-first-out.
A parent of radius r gets

    N = K floor(r / r_min)^(n-1)                                               (Nascimento et al. 2020 Eq. 2)

candidate centres drawn uniformly on its surface (the (n-1)-sphere). A candidate is dropped when it
lies outside the configuration bounds, when it lies inside an existing bubble (other than its parent,
on whose surface it sits), or when its certified radius is below r_min. Each surviving child joins
the foam with its parent recorded and is queued. Propagation stops when a bubble contains q_goal and
fails (:class:`PlanningFailed`) when the queue empties or a budget (bubble count, wall time) runs out.

Implementation notes
--------------------
* The candidates of one parent are sized in one batch (``BubbleOracle.radii`` over ``Clearance.batch_pairs``: MuJoCo distance sensors
  evaluated in one ``mujoco.batch.Batch`` call). Candidates of one parent are then accepted in their drawn order,
  each checked against the siblings accepted before it, so the result is the same as drawing and
  testing them one by one.
* "Inside an existing bubble" is strict (``|c - c_i| < r_i``, Nascimento and Alsina 2021 Eq. 1's open ball),
  the squares summed coordinate by coordinate in every test. A candidate is first tested against its
  grandparent (the parent sits on the grandparent's surface, so about a quarter of the candidates lie
  in it), then with :class:`~foam_mj.coverage.CoverageIndex`: a k-d tree on lifted points plus a brute-force buffer of
  recent bubbles, so no Python loop runs over the bubbles. Siblings of one batch are settled from
  the pairs a k-d tree lists (:func:`~foam_mj.coverage.accept_in_order`).
* Where the work goes (obstacle scene, about 20 candidates and 6 MuJoCo configurations per bubble):
  roughly a third MuJoCo's distance sensors (2.5-3.5 us of CPU per configuration), a third the
  coverage tree's queries (about 0.6 us per candidate), the rest numpy bookkeeping per batch.
* Deterministic for a given seed: all randomness comes from one ``numpy.random.Generator``.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from importlib import import_module
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from foam_mj.bubbles import BubbleOracle
from foam_mj.coverage import CoverageIndex, accept_in_order, inside_rows, row_sq_sums
from foam_mj.errors import ConfigurationError, PlanningFailed, clearance_text, is_finite_number, is_number, radius_text
from foam_mj.rosary import MEMBERSHIP_TOL, Rosary, fields_equal
from foam_mj.safe_curve import apart_text, coincide


def load_kd_tree() -> None:
    """Import scipy's k-d tree, which the foams use; a planner calls this before its clock starts, so that the import
    (0.3-1 s the first time) is neither counted as planning time nor taken from its time limit."""
    import_module("scipy.spatial")


@dataclass(frozen=True)
class FoamParams:
    """Planner parameters. Defaults are Nascimento et al. 2020's (K = 10, r_min = 0.07)."""

    K: int = 10
    r_min: float = 0.07
    delta: float = 0.005  # safety margin, metres of workspace clearance kept inside every bubble
    max_bubbles: int = 200_000
    time_limit: float = 60.0  # seconds of wall time

    def __post_init__(self) -> None:
        if not (isinstance(self.K, (int, np.integer)) and is_number(self.K) and self.K >= 1):
            raise ValueError(f"`K` must be an integer >= 1, got {self.K!r}")
        if not (is_finite_number(self.r_min) and self.r_min > 0):
            raise ValueError(f"`r_min` must be > 0, got {self.r_min!r}")
        if not (is_finite_number(self.delta) and self.delta >= 0):
            raise ValueError(f"`delta` must be >= 0 (metres), got {self.delta!r}")
        if not (isinstance(self.max_bubbles, (int, np.integer)) and is_number(self.max_bubbles) and self.max_bubbles >= 1):
            raise ValueError(f"`max_bubbles` must be an integer >= 1, got {self.max_bubbles!r}")
        if not (is_finite_number(self.time_limit) and self.time_limit > 0):  # inf was written to the result as Infinity
            raise ValueError(f"`time_limit` must be > 0 seconds and finite, got {self.time_limit!r}")


@dataclass
class FoamStats:
    """What the propagation did."""

    bubbles: int = 0
    parents_expanded: int = 0
    candidates: int = 0
    dropped_out_of_bounds: int = 0
    dropped_covered: int = 0
    dropped_small: int = 0
    clearance_calls: int = 0
    elapsed: float = 0.0
    outcome: str = "running"  # "reached", "queue empty", "bubble budget", "time budget"

    @property
    def bubbles_per_second(self) -> float:
        return self.bubbles / self.elapsed if self.elapsed > 0 else float("nan")

    def as_dict(self) -> dict:
        d = asdict(self)
        d["bubbles_per_second"] = self.bubbles_per_second
        return d


@dataclass
class Foam:
    """The bubbles grown so far: centres (N, n), radii (N,), parent index (-1 for the root)."""

    centers: np.ndarray
    radii: np.ndarray
    parents: np.ndarray
    q_init: np.ndarray
    q_goal: np.ndarray
    goal_bubble: int | None = None

    __eq__ = fields_equal  # arrays by value

    @property
    def size(self) -> int:
        return len(self.radii)

    def depth(self, i: int) -> int:
        n = 0
        while self.parents[i] >= 0:
            i = int(self.parents[i])
            n += 1
        return n

    def chain(self, i: int) -> np.ndarray:
        """Bubble indices from the root to bubble i, following parents (Nascimento and Alsina 2021 Def. 2.5, reversed)."""
        out = [i]
        while self.parents[out[-1]] >= 0:
            out.append(int(self.parents[out[-1]]))
        return np.array(out[::-1])

    def rosary(self) -> Rosary:
        """The rosary from the root to the goal bubble."""
        if self.goal_bubble is None:
            raise ValueError("the foam did not reach the goal: it has no rosary")
        ids = self.chain(self.goal_bubble)
        return Rosary(self.centers[ids], self.radii[ids], self.q_init, self.q_goal, ids)


@dataclass
class PlanResult:
    foam: Foam
    rosary: Rosary
    stats: FoamStats


#: The most candidates one bubble may get. Eq. 2's N = K floor(r / r_min)^(n-1) grows without bound as
#: r_min shrinks or K grows (K = 1e8 or r_min = 1e-7 asked for terabytes and ended in a MemoryError after
#: minutes); a million candidates (24 MB of 3-D centres) is far beyond any useful foam (the papers' settings
#: give at most a few thousand per bubble), so larger settings are refused before planning.
MAX_CANDIDATES_PER_BUBBLE = 1_000_000


def candidate_bound(params: FoamParams, lower, upper) -> float:
    """The most candidates Eq. 2 can give one bubble inside the bounds [lower, upper].

    A bubble centred in the box with a radius above the box's diagonal has every surface point outside
    the box, so the planner caps r at the diagonal D when counting (:func:`plan`), and the bound is
    K (D / r_min)^(n-1).
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    diag = float(np.linalg.norm(upper - lower))
    return float(params.K) * float(np.floor(diag / params.r_min)) ** (len(lower) - 1)


def seed_rng(seed: int | np.random.Generator) -> np.random.Generator:
    """A planner's random generator: ``seed`` itself, or one seeded by an integer in [0, 2**63 - 1];
    ConfigurationError for anything else (numpy's own messages, e.g. "expected non-negative integer", name nothing)."""
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= 2**63 - 1:
        raise ConfigurationError(f"seed must be an integer in [0, 2**63 - 1] or a numpy Generator, got {seed!r}")
    return np.random.default_rng(int(seed))


def check_candidate_bound(params: Any, lower, upper) -> None:
    """Refuse (ConfigurationError) settings whose bubbles could get more than MAX_CANDIDATES_PER_BUBBLE candidates."""
    if getattr(params, "K", None) is None or getattr(params, "r_min", None) is None:
        return  # a planner without Eq. 2's expansion (one candidate per sample)
    bound = candidate_bound(params, lower, upper)
    if bound > MAX_CANDIDATES_PER_BUBBLE:
        diag = float(np.linalg.norm(np.asarray(upper, float) - np.asarray(lower, float)))
        raise ConfigurationError(
            f"K = {params.K} and r_min = {params.r_min} give up to {bound:.3g} candidates per bubble "
            f"(N = K floor(r / r_min)^(n-1), r up to the bounds' diagonal {diag:.3g}), more than the "
            f"{MAX_CANDIDATES_PER_BUBBLE:,} the planner allows (memory): lower K or raise r_min "
            f"(options of a scenario's [planner] table), or plan with bubbletree or gbpf, which grow one candidate per sample"
        )


#: Candidates drawn per batch of parents (one clearance call); bounds memory and latency only.
MAX_BATCH_CANDIDATES = 2048


def _unit_sphere(rng: np.random.Generator, count: int, dim: int) -> np.ndarray:
    u = rng.standard_normal((count, dim))
    return u / np.sqrt(row_sq_sums(u))[:, None]


def small_goal_hint(oracle: BubbleOracle, q_goal: np.ndarray, r_min: float, outcome: str = "", time_limit: float | None = None,
                    max_bubbles: int | None = None) -> str:
    """The reason a foam that did not reach q_goal may have missed it: its own certified bubble is below r_min, so
    only a bubble of at least r_min placed just so can hold it (and the coverage rule drops most candidates there);
    and, when a budget ended the search (``outcome``), that more time or bubbles let the foam grow on."""
    r_goal = float(oracle.radius(q_goal))
    if r_goal >= r_min:
        return ""
    return (f": q_goal's own certified bubble has radius {radius_text(r_goal, r_min)} < r_min = {r_min}, so only a bubble of at least "
            f"r_min placed to reach it can hold it; lower r_min, or plan with bubbletree{time_hint(outcome, time_limit, max_bubbles)}")


def time_hint(outcome: str, time_limit: float | None = None, max_bubbles: int | None = None) -> str:
    """When a budget ended a foam's search (``outcome``: "time budget", "bubble budget"), that it did (the limit,
    ``time_limit`` seconds or ``max_bubbles``, if given) and that more lets it grow on: a limit of 0.01 s or 60 bubbles
    stopped it after a few bubbles, and the hint about r_min, or none, read as if the geometry had."""
    if outcome == "time budget":
        limit = "" if time_limit is None else f" ({time_limit:g} s)"
        return f"; the time limit{limit} ended the search: with more (--time-limit, the [planner] time_limit) the foam grows on"
    if outcome == "bubble budget":
        limit = "" if max_bubbles is None else f" (max_bubbles = {max_bubbles:,})"
        return f"; the bubble budget{limit} ended the search: with more (the [planner] max_bubbles) the foam grows on"
    return ""


def nearest_hint(oracle: BubbleOracle, foam: "Foam", r_min: float, outcome: str, time_limit: float | None = None,
                 max_bubbles: int | None = None) -> str:
    """Where a foam that did not reach q_goal came nearest to it: the bubble whose surface is nearest q_goal (its centre),
    the gap, and what blocks the way there (that surface point toward q_goal, the clearance and closest pair at it); when a
    budget stopped it (``outcome``), that more lets it grow on (:func:`time_hint`); unless the bubble budget stopped it,
    that every bubble has radius >= r_min, so a way that only smaller bubbles fit through stays closed to the foam."""
    if len(foam.radii) == 0:
        return ""
    to_goal = foam.q_goal - foam.centers
    dist = np.linalg.norm(to_goal, axis=1)
    i = int(np.argmin(dist - foam.radii))
    c, r = foam.centers[i], float(foam.radii[i])
    surface = c + r * to_goal[i] / dist[i]
    p = np.clip(surface, oracle.robot.lower, oracle.robot.upper)
    report = oracle.explain(p)  # at the surface, not the centre: the message names both points
    near = (f": it came nearest with the bubble at q = {np.round(c, 4).tolist()} (radius {r:.3g}, its surface {dist[i] - r:.3g} "
            f"from q_goal); at its surface point toward q_goal, q = {np.round(p, 4).tolist()}"
            f"{'' if np.array_equal(p, surface) else ' (in the joint bounds)'}, the clearance is "
            f"{clearance_text(report.clearance, oracle.delta)} between {oracle.robot.pair_label(int(np.argmin(report.pair_distances)))}")
    if outcome == "bubble budget":
        return f"{near}{time_hint(outcome, time_limit, max_bubbles)}"
    if outcome == "time budget":
        return (f"{near}{time_hint(outcome, time_limit)}, but every bubble has radius >= r_min = {r_min}, so a way narrower than that "
                "stays closed to it either way: lower r_min, or plan with bubbletree")
    return (f"{near}; every bubble has radius >= r_min = {r_min}, so a way narrower than that stays closed to it: lower "
            "r_min, or plan with bubbletree")


def plan(
    oracle: BubbleOracle,
    q_init: ArrayLike,
    q_goal: ArrayLike,
    params: FoamParams = FoamParams(),
    seed: int | np.random.Generator = 0,
    progress: Callable[[FoamStats], None] | None = None,
) -> PlanResult:
    """Grow the foam from q_init until a bubble holds q_goal; return the foam, rosary and statistics.

    Raises :class:`ConfigurationError` when q_init or q_goal is malformed, out of bounds, or too close
    to an obstacle, and :class:`PlanningFailed` (carrying ``stats`` and ``foam``) when the goal is not
    reached within the budget or the foam can grow no further.
    """
    robot = oracle.robot
    robot.check_unchanged()
    q_init = robot.validate(q_init, "q_init")
    q_goal = robot.validate(q_goal, "q_goal")
    if oracle.delta != params.delta:
        raise ValueError(f"the oracle's margin delta={oracle.delta} differs from params.delta={params.delta}")
    if coincide(q_init, q_goal):
        raise ConfigurationError(f"q_goal equals q_init{apart_text(q_init, q_goal)} ({q_init.tolist()}): nothing to plan")
    robot.check_fixed_pairs(params.delta)
    robot.check_margins(params.delta)
    check_candidate_bound(params, robot.lower, robot.upper)
    rng = seed_rng(seed)
    n = robot.dim
    lo, hi = robot.lower, robot.upper
    r_min = params.r_min
    diag = float(np.linalg.norm(hi - lo))  # a larger radius puts every candidate outside the bounds
    load_kd_tree()
    t0 = time.perf_counter()
    stats = FoamStats()
    calls0 = oracle.clearance.calls

    goal_clear = oracle.clearance(q_goal)
    if goal_clear <= params.delta:
        raise ConfigurationError(
            f"q_goal {q_goal.tolist()} is too close to an obstacle: clearance {clearance_text(goal_clear, params.delta)} <= margin {params.delta} m"
        )
    clear0 = oracle.clearance(q_init)
    r0 = float(oracle.radius(q_init))
    if r0 < r_min:
        raise ConfigurationError(
            f"q_init {q_init.tolist()} admits a root bubble of radius {radius_text(r0, r_min)} < r_min = {r_min} "
            f"(clearance {clearance_text(clear0, params.delta)}, margin {params.delta} m): move it away from obstacles and bounds, lower r_min (an option of the "
            "[planner] table), or plan with bubbletree (the default planner), whose r_min adapts"
        )

    cap = 4096
    centers = np.empty((cap, n))
    radii = np.empty(cap)
    parents = np.empty(cap, dtype=np.int64)
    cum = np.zeros(cap + 1, dtype=np.int64)  # cum[i]: candidates of bubbles 0..i-1 (Eq. 2)
    index = CoverageIndex(n)
    count = 0

    def add(c: np.ndarray, r: np.ndarray, parent: np.ndarray) -> None:
        """Append bubbles (k, n), radii (k,), parents (k,) to the preallocated arrays (doubled when full)."""
        nonlocal centers, radii, parents, cum, count
        k = len(r)
        if count + k > len(radii):
            size = max(2 * len(radii), count + k)
            centers = np.concatenate([centers[:count], np.empty((size - count, n))])
            radii = np.concatenate([radii[:count], np.empty(size - count)])
            parents = np.concatenate([parents[:count], np.empty(size - count, dtype=np.int64)])
            cum = np.concatenate([cum[: count + 1], np.empty(size - count, dtype=np.int64)])
        centers[count : count + k], radii[count : count + k], parents[count : count + k] = c, r, parent
        # Eq. 2's N for each new bubble, summed into the running totals that batch the queue.
        n_cand = (params.K * np.floor(np.minimum(r, diag) / r_min) ** (n - 1)).astype(np.int64)
        np.cumsum(n_cand, out=cum[count + 1 : count + k + 1])
        cum[count + 1 : count + k + 1] += cum[count]
        index.add(c, r)
        count += k

    def foam_now(goal: int | None = None) -> Foam:
        return Foam(centers[:count].copy(), radii[:count].copy(), parents[:count].copy(), q_init, q_goal, goal)

    def finish(outcome: str) -> None:
        stats.bubbles = count
        stats.elapsed = time.perf_counter() - t0
        stats.clearance_calls = oracle.clearance.calls - calls0
        stats.outcome = outcome

    add(q_init[None, :], np.array([r0]), np.array([-1]))
    goal = 0 if np.sum((q_goal - q_init) ** 2) <= (r0 + MEMBERSHIP_TOL) ** 2 else None
    head = 0
    next_report = time.perf_counter() + 0.5
    while goal is None:
        if head >= count:
            finish("queue empty")
            break
        if count >= params.max_bubbles:
            finish("bubble budget")
            break
        now = time.perf_counter()
        if now - t0 > params.time_limit:
            finish("time budget")
            break
        if progress is not None and now >= next_report:
            stats.bubbles, stats.elapsed = count, now - t0
            progress(stats)
            next_report = now + 0.5
        # A batch of queued parents, taken in FIFO order. Their candidates are drawn in parent order from
        # the one generator and accepted in that order below, exactly as one-by-one processing would.
        # The longest run of parents whose candidates number at most MAX_BATCH_CANDIDATES (at least one parent).
        stop = head + int(np.searchsorted(cum[head + 1 : count + 1], cum[head] + MAX_BATCH_CANDIDATES, side="right"))
        stop = min(max(stop, head + 1), count)
        batch = np.arange(head, stop)
        counts = np.diff(cum[head : stop + 1])
        total = int(cum[stop] - cum[head])
        head = stop
        stats.parents_expanded += len(batch)
        if total == 0:
            continue
        parent_of = np.repeat(batch, counts)
        cand = np.repeat(centers[batch], counts, axis=0) + np.repeat(radii[batch], counts)[:, None] * _unit_sphere(rng, total, n)
        stats.candidates += total
        keep = (cand[:, 0] >= lo[0]) & (cand[:, 0] <= hi[0])  # inside the bounds, column by column
        for k in range(1, n):
            keep &= (cand[:, k] >= lo[k]) & (cand[:, k] <= hi[k])
        stats.dropped_out_of_bounds += int(total - keep.sum())
        live = np.flatnonzero(keep)
        # A child often lies in its grandparent (the parent sits on the grandparent's surface): that test is one
        # vectorized comparison, and only the other candidates need the coverage index's k-d tree.
        gp = parents[parent_of[live]]
        root = gp < 0  # the root's children have no grandparent
        gp[root] = 0
        by_gp = inside_rows(cand[live], centers[gp], radii[gp]) & ~root
        rest = live[~by_gp]
        cov = index.covered(cand[rest], parent_of[rest])
        stats.dropped_covered += int(by_gp.sum()) + int(cov.sum())
        keep[live[by_gp]] = False
        keep[rest[cov]] = False
        cand, parent_of = cand[keep], parent_of[keep]
        if len(cand) == 0:
            continue
        r = oracle.radii(cand)
        big = r >= r_min
        stats.dropped_small += int((~big).sum())
        cand, parent_of, r = cand[big], parent_of[big], r[big]
        if len(cand) == 0:
            continue
        # Candidates of this batch covered by a bubble accepted earlier in the same batch are dropped.
        accepted = accept_in_order(cand, r)
        stats.dropped_covered += int((~accepted).sum())
        # Stop at the first accepted bubble that holds the goal, and at the bubble budget.
        order = np.flatnonzero(accepted)[: params.max_bubbles - count]
        reach = np.sum((cand[order] - q_goal) ** 2, axis=1) <= (r[order] + MEMBERSHIP_TOL) ** 2
        hits = np.flatnonzero(reach)
        if hits.size:
            order = order[: hits[0] + 1]
        # The accepted bubbles join in their drawn order; only the last can hold the goal (order ends there).
        add(cand[order], r[order], parent_of[order])
        if hits.size:
            goal = count - 1
    if goal is None:
        foam = foam_now()
        hint = (small_goal_hint(oracle, q_goal, params.r_min, stats.outcome, params.time_limit, params.max_bubbles)
                or nearest_hint(oracle, foam, params.r_min, stats.outcome, params.time_limit, params.max_bubbles))
        if stats.outcome == "queue empty":  # closed at r_min, or its candidates missed room (foam_mj.planners.variants)
            from foam_mj.planners.closure import queue_empty_text

            hint += queue_empty_text(oracle, foam, params.r_min, params.K)
        raise PlanningFailed.after(f"the foam did not reach q_goal ({stats.outcome}) after {stats.bubbles} bubbles", stats, hint, foam)
    finish("reached")
    foam = foam_now(goal)
    return PlanResult(foam, foam.rosary(), stats)
