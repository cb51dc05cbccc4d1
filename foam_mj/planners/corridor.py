"""A near-shortest certified corridor through a set of bubbles.

1. **Shortest chain.** The bubbles form a graph: an edge joins two bubbles that overlap with a hatch
   (|c_i - c_j| <= r_i + r_j - HATCH min(r_i, r_j)), weighted by |c_i - c_j|; q_init joins every bubble
   that holds it, q_goal likewise. Dijkstra's algorithm (``scipy.sparse.csgraph.dijkstra``) gives the
   shortest chain through this graph -- through any overlapping bubbles, not only a tree's parent links.
2. **Shortest path in the chain.** The shortest polyline whose waypoint i lies in the hatch
   b_i ∩ b_(i+1) is a second-order cone program (:func:`foam_mj.smoothing.convex.build_socp`,
   Clarabel). Each of its segments lies in one bubble, so the path keeps the margin delta.
3. **Refinement.** Where that path presses on a bubble's boundary (waypoint i at distance r - tol
   from the centre of b_i or b_(i+1)), the corridor is too narrow for it. A certified bubble centred
   at the waypoint itself is spliced between b_i and b_(i+1): it holds w_i, so it overlaps both, the
   old path stays feasible (the length cannot grow), and it reaches beyond the pressed boundary by its
   own radius. The program is solved again; rounds repeat while the length drops by more than
   ``refine_tol`` (0.5 %). Bubbles below the floor ``floor_factor * delta / ||rho||_2`` are not added:
   such a bubble's centre has a clearance below (1 + floor_factor) delta, and the length it could win is
   of the order of its radius. Each round also tries certified chords between ``chords`` (24) random pairs
   of points of the path (chains of overlapping bubbles along the straight shortcut, down to CHORD_FLOOR x
   the floor, thinned to the fewest that still hold it (:func:`foam_mj.planners.chains.thin_line_chain`), at most CHORD_GROWTH x as
   many bubbles as the stretch they replace) and prunes the chain to a short sub-chain that holds the path
   (:func:`foam_mj.planners.chains.prune_chain`; not a chain of ``max_chain`` bubbles, which ends the rounds). A round takes up to CHORD_STEPS (3) steps of chords before its cone program:
   after a step, the polyline itself is updated (:func:`foam_mj.planners.chains.splice_chain`: the old path up to the chord's
   start, points on the chord in consecutive chord bubbles, the old path after its end), so the next
   step's chords are drawn and certified on it with no program in between; the later steps take only
   chords that win more than ``refine_tol`` each and stop once the chain holds ``max_chain`` bubbles.
4. **Re-cover.** The last chain is pruned once more with, besides its own bubbles, certified bubbles
   centred at RECOVER points per segment of its shortest path (one batch of distance queries): where
   the path slides along an obstacle, bubbles centred on the path hold it with fewer bubbles than the
   pressing and chord bubbles the rounds left there. The new chain still holds that path (so its own
   shortest path is no longer), and every hatch is then made deep (:func:`foam_mj.planners.chains.deepen`).

Lengths are measured with per-coordinate weights (``metric``: the configuration map's qpos units per
q unit by default, see :func:`shortest_path`); the bubbles are balls in q throughout.

Why the floor is a trade-off: along an obstacle the shortest path grazes, a ball that holds the path
has a radius of about the path's own clearance minus delta over ||rho||_2, so halving the floor about
doubles the bubbles along that stretch, and the rosary's size is what the smoothers' time grows with.
Measured on the three leg scenes (10 seeds): floor 2 -> 3 cost 1-7 % of length and saved 5-15 % of
plan + optimal smoother CPU time.

Design choice: splicing (rather than re-running Dijkstra after each round) keeps every round's chain
a superset of the previous path's corridor, so the length is monotone and each round costs one batch of
distance queries and one cone program.

Why 24 thinned chords, 3 chord steps per round and the re-cover (measured on the three leg scenes obstacle /
step_up / step_down, seeds 0-9, medians, against 8 unthinned chords, one step and no re-cover; lengths in
qpos after the default optimal smoother): the chords do most of a round's shortening, so more of them per
round, thinner chord chains (smaller cone programs, more chords under CHORD_GROWTH) and several chord steps
per program need fewer rounds: cone programs per plan 9 / 7.5 / 9 -> 3 / 4 / 4. The re-cover takes 15-20 %
off the chain the rounds leave (final chains 68.5 / 43.5 / 58 -> 69.5 / 36 / 47: the longer chords leave
longer chains on obstacle). Lengths
0.8672 / 0.8798 / 1.756 -> 0.8264 / 0.8795 / 1.756 (seeds 10-19: 0.8779 / 0.8798 / 1.7571 -> 0.8613 / 0.8794
/ 1.7411). With the cached cone program, chord gaps filled in one batch and the interval prune, the
corridor's CPU time fell by a third (obstacle 29-30 -> 20-21 ms, step_up 20.5-21 -> 13.5-14, step_down 29 ->
18-19, obstacle5 80-84 -> 47-49, arm6 50-51 -> 31; plan + optimal smoother 68.5-69 -> 59-61 ms, 45.5-46 ->
35-37, 71-74 -> 50-52, 205-206 -> 169, 149-150 -> 147-150; one 2-core machine shared with other work, CPU
time, best of 3 per seed, two interleaved runs). The smoother's time per seed (19-50 ms on obstacle) does not
follow the chain's size closely, so a changed trajectory moves its 10-seed median by a few ms either way.
The cone program's template written in CSC form and handed to Clarabel as lists, the overlap graph's CSR arrays
written directly and fewer array passes in the prune and the chords (the same plans, bit for bit) took the corridor's
CPU time on obstacle from 22.1 to 20.7 ms (32.4 -> 30.2 in a slower spell; per-seed ratio 0.95-0.96), and from 24.9 to
22.0 ms (ratio 0.89) when every chain length's template is built afresh, as in a run that plans each seed once
(step_down 0.87, arm6 0.93; base and new alternated in one process, best of 3 per seed, seeds 0-9).
The overlap graph's pairs from flat indices, no round prune of a chain that has reached ``max_chain`` (the re-cover
prunes it), fewer array passes in the chords, the prune's sample bands and the cone program's b (the same plans on
obstacle and step_up) took it a further 5 % down (per-seed ratio 0.946 obstacle, 0.955 step_up, 0.948 step_down;
obstacle 26.3 -> 24.0 ms in a slow spell, dijkstra 1.96 -> 1.38, prune 2.21 -> 1.42; every chain length's template
built afresh, best of 5 per seed).
Bubbles pushed off the path, away from the obstacle, were tried for the re-cover and do not help: the
certified radius grows only 0.2-0.4 x as fast as the centre moves away (the bound is conservative), so
such a bubble holds a shorter stretch of the path. Tried and not kept: chords in end-to-end tilings (no
fewer rounds), no pruning inside the rounds, or a chain cap lowered to 0.7-0.8 (fewer rounds, but step_down
0.5-1 % longer), a looser tolerance for the rounds' programs (1e-6: waypoints only 0.64 INSET inside; 1e-4
with a projection onto the lenses: -20 % program time, but the smoother's median rose 5 ms). The last
program cannot be saved by handing the smoother the old path (the re-covered chain still holds it; a sample
of it in each new hatch): plan -2.5 ms, but the smoother's median doubled (26.7 -> 52.3 ms on obstacle, it
starts farther from its optimum); solving it to 1e-7 or 1e-6 instead of 1e-8 saved nothing measurable.
Also left out (obstacle / step_down / step_up, seeds 0-9, medians; lengths in qpos after the optimal smoother):
RECOVER 2 (obstacle 0.8264 -> 0.8298, smoother +13 ms) or 8 (plan +3 ms, total no better), CHORD_STEPS 2
(obstacle 0.849, smoother +13 ms), CHORD_SPACING 3 (smoother +6 to +13 ms), 16 chords a round (obstacle 0.846,
step_down 1.765), the rounds' programs without equilibration (no measurable gain). The chords certified do
not depend on COARSE; 4 is within 0.4 % of the fewest distance queries per plan on obstacle and step_down
(2-12 tried; arm6: 2 % fewer at 8).
Also measured and left out (obstacle, seeds 0-9, CPU medians): the rounds' and the last program solved first with
only the near-active balls (15-22 % of the ball cones are active at the optimum; with exactly those, Clarabel's
constructor and solve take 1.6-1.9 instead of 3.7 ms), because the program is degenerate -- waypoints on a straight
stretch slide along it, out of the balls left out (every program, even with the exact active set) -- and the
previous path's bends recall only 14-30 % of the last program's active balls; skipping the last round's program
(re-cover and prune along the spliced polyline, one program after): plan -5.4 ms, but obstacle's length +2.3 %
(0.8264 -> 0.8456), and with no re-cover +5.8 %; chord batches of mutually disjoint chords (fewer wasted
queries, but batches of one: 24.6 certify calls per plan instead of 6.5, plan +6.6 ms); CHORD_BATCH 3 or 12 (the
same plans, no faster); the fewest bubbles that hold the path with deep hatches (a shortest path over the prune's
intervals) instead of the greedy walk: 0-3 bubbles fewer per chain (obstacle 70 -> 69.5 median); PRUNE_BAND 48
(the same chains).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from importlib import import_module

import numpy as np

from foam_mj.paths import row_norms
from foam_mj.planners.chains import (
    HATCH,
    INSET,
    PIECES,
    arc_points,
    certify_chords,
    deepen,
    held,
    path_samples,
    press_bubbles,
    prune_chain,
    splice_chain,
    thin_line_chain,
)
from foam_mj.planners.conepath import shortest_path
from foam_mj.rosary import Rosary

# scipy, Clarabel and foam_mj.smoothing are imported inside the functions that use them: reading a scenario checks its
# [planner] table against the planners' options, and `foam-mj scenes` or a bad flag should not wait for them.
_SOLVERS = ("scipy.spatial", "scipy.sparse.csgraph", "clarabel", "foam_mj.smoothing.convex")


def load_solvers() -> None:
    """Import what the corridor uses (scipy's k-d tree and graph search, Clarabel); a planner calls this before its
    clock starts, so that the imports are neither counted as planning time nor taken from its time limit."""
    for name in _SOLVERS:
        import_module(name)

#: A round's pruned chain is solved again only if it drops more than this share of the bubbles (else the
#: unpruned chain goes on: one cone program fewer); the last chain is always pruned.
PRUNE_GAIN = 0.85
#: Chords may use bubbles down to this fraction of the floor (a chord that passes one obstacle closely
#: needs a few small bubbles only there; step_up's straight line passes 7.7 mm from the step), but a chord
#: is spliced in only if its chain has at most CHORD_GROWTH x as many bubbles as the stretch it replaces
#: (a chord that grazes an obstacle over its length would need a long chain of small bubbles).
CHORD_FLOOR = 1.0 / 3.0
CHORD_GROWTH = 2.0
#: Clarabel's gap and feasibility tolerances for the refinement rounds' cone programs (the last program
#: is solved to 1e-8): 15 % fewer interior-point iterations, waypoints still 0.9 INSET inside their balls.
ROUND_TOL = 1e-7
#: A chord's bubbles start this many x the chain's median radius apart (bisected where they do not overlap
#: deeply): chords through an obstacle die after fewer distance queries.
CHORD_SPACING = 2.0
#: Chords certified per batch (by gain, those disjoint from the chords already taken).
CHORD_BATCH = 6
#: Steps of chords per round (one cone program per round); the later steps take chords that win more than
#: STEP_GAIN x refine_tol of the length each (small wins there only lengthened the chain: arm6 60 -> 56).
CHORD_STEPS = 3
STEP_GAIN = 1.0
#: The last chain is re-covered with bubbles centred at RECOVER points per segment of its shortest path, as
#: well as its own (see :func:`foam_mj.planners.chains.prune_chain`); 0: pruned with its own bubbles only.
RECOVER = 4


@dataclass(frozen=True)
class CorridorOptions:
    refine: bool = True
    refine_tol: float = 0.005
    refine_rounds: int = 30
    floor_factor: float = 0.1
    chords: int = 24
    time_limit: float = 10.0  # process CPU seconds
    #: No new round after this ``time.perf_counter()`` instant: the planner's own ``time_limit``, so that a plan whose
    #: trees met near it does not refine for up to ``time_limit`` CPU seconds more.
    deadline: float = float("inf")
    prune: bool = True
    #: Per-coordinate length weights (None: Euclidean in q); see :func:`shortest_path`.
    metric: np.ndarray | None = None
    #: No new round once the chain holds this many bubbles (the smoothers' time grows with it; the last
    #: rounds of a path sliding along an obstacle add many bubbles for a per cent or two).
    max_chain: int = 10**9
    #: ... or, if more, this many times the bubbles of the first (Dijkstra) chain (0: ``max_chain`` alone).
    max_chain_first: float = 0.0


@dataclass
class Corridor:
    """The chain of bubbles (indices into the planner's bubbles, then into ``added_*``), and the bubbles
    the refinement added (their ``added_parents``: the chain bubble before which they were spliced)."""

    centers: np.ndarray
    radii: np.ndarray
    ids: np.ndarray
    added_centers: np.ndarray
    added_radii: np.ndarray
    added_parents: np.ndarray
    waypoints: np.ndarray
    length: float
    stats: dict = field(default_factory=dict)

    def rosary(self, q_init: np.ndarray, q_goal: np.ndarray) -> Rosary:
        return Rosary(self.centers, self.radii, q_init, q_goal, self.ids)


def overlap_pairs(centers: np.ndarray, radii: np.ndarray, hatch: float = HATCH) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i < j) of bubbles that overlap with a hatch of ``hatch`` x the smaller radius.

    Up to :data:`BRUTE_FORCE` bubbles, all pairs in blocks; beyond, k-d trees of radius classes (below)."""
    n = len(radii)
    if n < 2:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    if n <= BRUTE_FORCE:
        # By radius, largest first: for i before j the bound is r_i + (1 - hatch) r_j, and |c_i - c_j|^2 minus its
        # square is one product of lifted rows, [c_i, r_i, |c_i|^2 - r_i^2, 1] . [-2 c_j, -2 h r_j, 1, |c_j|^2 - h^2 r_j^2]
        # with h = 1 - hatch; rows against the later columns only, in row blocks of 128 (the same pairs as
        # the distances against the bound, in half the time on 600-1,100 bubbles). A block's pairs from the flat
        # indices of its entries (np.nonzero on the 2-D block took half of this function's time).
        o = np.argsort(-radii, kind="stable")
        C, R = centers[o], radii[o]
        sq = np.einsum("ij,ij->i", C, C)
        h = 1.0 - hatch
        d = C.shape[1]
        A = np.empty((n, d + 3))
        B = np.empty((n, d + 3))
        A[:, :d], A[:, d], A[:, d + 1], A[:, d + 2] = C, R, sq - R * R, 1.0
        B[:, :d], B[:, d], B[:, d + 1], B[:, d + 2] = -2.0 * C, -2.0 * h * R, 1.0, sq - (h * R) ** 2
        I, J = [], []
        for s0 in range(0, n, 128):
            f = np.flatnonzero(A[s0 : s0 + 128] @ B[s0:].T <= 0.0)
            i, j = f // (n - s0), f % (n - s0)
            up = j > i  # both local: row s0 + i, column s0 + j
            I.append(i[up] + s0)
            J.append(j[up] + s0)
        i, j = o[np.concatenate(I)], o[np.concatenate(J)]
        return np.minimum(i, j), np.maximum(i, j)
    # Radius classes (r_max / 2^(k+1), r_max / 2^k], a k-d tree each: two bubbles of one class that overlap are at
    # most twice its largest radius apart, of two classes at most the sum of their largest radii. (One tree asked for
    # every bubble's neighbours within r_i + r_max -- the largest radius widening every query -- gave a UR5e foam of
    # 8,700 bubbles 161,600 candidates in 68 ms; by class 28,500 in 38 ms, the same pairs.)
    from scipy.spatial import cKDTree

    top = float(radii.max())
    k = np.floor(np.log2(top / np.maximum(radii, top * 2.0**-40))).astype(np.int64)
    order = np.argsort(k, kind="stable")
    groups = np.split(order, np.unique(k[order], return_index=True)[1][1:])
    trees = [cKDTree(centers[g]) for g in groups]
    reach = [float(radii[g].max()) for g in groups]
    I, J = [], []
    for a, (ga, ta) in enumerate(zip(groups, trees)):
        p = ta.query_pairs(2.0 * reach[a], output_type="ndarray")
        I.append(ga[p[:, 0]])
        J.append(ga[p[:, 1]])
        for b in range(a + 1, len(groups)):
            M = ta.sparse_distance_matrix(trees[b], reach[a] + reach[b], output_type="ndarray")
            I.append(ga[M["i"]])
            J.append(groups[b][M["j"]])
    i, j = np.concatenate(I), np.concatenate(J)
    i, j = np.minimum(i, j), np.maximum(i, j)
    d = row_norms(centers[i] - centers[j])
    ok = d <= radii[i] + radii[j] - hatch * np.minimum(radii[i], radii[j])
    return i[ok], j[ok]


#: Bubble counts up to which the overlap graph is built by brute force.
BRUTE_FORCE = 4096


def shortest_chain(
    centers: np.ndarray, radii: np.ndarray, q_init: np.ndarray, q_goal: np.ndarray, metric: np.ndarray | None = None
) -> np.ndarray | None:
    """Bubble indices of the shortest chain q_init -> q_goal through the overlap graph, or None
    (edge weights: distances between centres, weighted by ``metric`` as :func:`shortest_path`)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import dijkstra

    from foam_mj.smoothing.convex import to_csc

    n = len(radii)
    s = 1.0 if metric is None else np.asarray(metric, dtype=float)
    i, j = overlap_pairs(centers, radii)
    w = row_norms((centers[i] - centers[j]) * s)
    S, G = n, n + 1
    hs = np.flatnonzero(row_norms(centers - q_init) <= radii)
    hg = np.flatnonzero(row_norms(centers - q_goal) <= radii)
    rows = np.concatenate([i, j, np.full(len(hs), S), hg])
    cols = np.concatenate([j, i, hs, np.full(len(hg), G)])
    vals = np.concatenate([w, w, row_norms((centers[hs] - q_init) * s), row_norms((centers[hg] - q_goal) * s)])
    vals = np.maximum(vals, 1e-12)  # an explicit zero would read as "no edge"
    # The CSR arrays directly (no two equal (row, column) pairs), as scipy's COO -> CSR conversion orders them, for
    # a fifth of its time: a matrix's CSR arrays are its transpose's CSC arrays.
    gT = to_csc(cols, rows, vals, (n + 2, n + 2))
    g = sp.csr_matrix((gT.data, gT.indices, gT.indptr), shape=(n + 2, n + 2))
    dist, pred = dijkstra(g, directed=True, indices=S, return_predecessors=True)
    if not np.isfinite(dist[G]):
        return None
    out = []
    k = int(pred[G])
    while k != S:
        out.append(k)
        k = int(pred[k])
    return np.array(out[::-1], dtype=np.int64)


class _Clock:
    """CPU time (``time.process_time``) per phase, for the statistics."""

    def __init__(self) -> None:
        self.t = time.process_time()
        self.acc: dict[str, float] = {}

    def lap(self, name: str) -> None:
        t = time.process_time()
        self.acc[name] = self.acc.get(name, 0.0) + t - self.t
        self.t = t

    def ms(self) -> dict[str, float]:
        return {k: round(1e3 * v, 2) for k, v in self.acc.items()}


def build_corridor(
    problem, centers: np.ndarray, radii: np.ndarray, link: tuple[int, int] | None, options: CorridorOptions,
    rng: np.random.Generator | None = None, chain: np.ndarray | None = None,
) -> Corridor:
    """The shortest chain through the bubbles (``chain``, if the caller found it already), refined while its path shortens."""
    build = CorridorBuild(problem, centers, radii, options, rng, chain)
    build.refine(options.refine_rounds)
    return build.corridor()


class CorridorBuild:
    """:func:`build_corridor` in steps: the chain and its first program (constructor), refinement rounds
    (:meth:`refine`, resumable: ``refine(1)`` then ``refine(k - 1)`` are the rounds of ``refine(k)``, the same
    random numbers drawn), and the last chain's re-cover, deepening and program (:meth:`corridor`, which leaves
    the rounds' state as it was, so that the rounds can go on after it)."""

    def __init__(self, problem, centers: np.ndarray, radii: np.ndarray, options: CorridorOptions,
                 rng: np.random.Generator | None = None, chain: np.ndarray | None = None) -> None:
        self.problem, self.options, self.dim = problem, options, centers.shape[1]
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.n_base = len(radii)
        self.clock = clock = _Clock()
        q0, q1, M = problem.q_init, problem.q_goal, options.metric
        ids = shortest_chain(centers, radii, q0, q1, M) if chain is None else chain
        clock.lap("dijkstra")
        if ids is None:  # pragma: no cover - the trees met, so a chain exists
            raise RuntimeError("no chain of overlapping bubbles joins q_init and q_goal")
        self.C, self.R, self.ids = centers[ids], radii[ids], ids
        self.added_c: list[np.ndarray] = []
        self.added_r: list[np.ndarray] = []
        self.statuses: list[str] = []
        self.w, self.length = shortest_path(self.C, self.R, q0, q1, M, status=self.statuses)
        clock.lap("socp")
        self.stats: dict = {"chain_first": int(len(ids)), "length_first": self.length, "refine_rounds": 0, "refine_added": 0, "shortcuts": 0}
        self.max_chain = max(options.max_chain, int(options.max_chain_first * len(ids)))
        self.done = False  # no further round would run (a round ended them, or none can start)
        if not held(self.C, self.R, self.w):  # the first program stopped short with a waypoint outside its balls (see held): no rounds
            self.stats["refine_stopped"] = "cone program unsolved"
            self.done = True
        elif not (options.refine and len(ids) > 1):
            self.done = True
        else:
            self.floor = options.floor_factor * max(problem.delta, 1e-4) / problem.oracle.bound.ball_factor
            self.t_end = time.process_time() + options.time_limit  # CPU time: the same rounds on a loaded machine

    def next_id(self, added_r: list | None = None) -> int:
        """The id of the next bubble the refinement adds (after the planner's and those added so far)."""
        return self.n_base + sum(len(x) for x in (self.added_r if added_r is None else added_r))

    def pick_chords(self, P: np.ndarray, C: np.ndarray, R: np.ndarray, length: float, min_gain: float = 1e-3) -> dict[int, tuple[int, np.ndarray, np.ndarray]]:
        """The chords to splice into the chain whose segment j of P lies in bubble j (C, R: its centres and radii), each
        shorter than the stretch of P it replaces by more than ``min_gain`` x ``length`` (the round's)."""
        options, M, oracle, floor = self.options, self.options.metric, self.problem.oracle, self.floor
        splices: dict[int, tuple[int, np.ndarray, np.ndarray]] = {}
        if not options.chords:
            return splices
        k = len(R)
        u = np.sort(self.rng.random((options.chords, 2)), axis=1)
        x = u * np.sum(row_norms(np.diff(P, axis=0) * (1.0 if M is None else M)))
        AB, jab = arc_points(P, x.T.ravel(), M)  # both ends in one call
        A, B, ja, jb = AB[: options.chords], AB[options.chords :], jab[: options.chords], jab[options.chords :]
        gain = (x[:, 1] - x[:, 0]) - row_norms((B - A) * (1.0 if M is None else M))
        cand = np.flatnonzero((jb > ja) & (gain > min_gain * length))
        # The chords by gain, certified in batches of CHORD_BATCH (one batch of distance queries each),
        # each batch the best ones disjoint from those taken; a certified chord is thinned to its fewest
        # bubbles and spliced if it has at most CHORD_GROWTH x as many as the stretch it replaces. The
        # result is that of certifying all at once (the same chords taken), with fewer queries: most
        # chords overlap the best one.
        pending = cand[np.argsort(-gain[cand], kind="stable")]
        used = np.zeros(k + 1, dtype=bool)
        spacing = max(CHORD_SPACING * float(np.median(R)), floor)
        while pending.size:
            cu = np.concatenate([[0], np.cumsum(used)])  # used segments before each index
            free = cu[jb[pending] + 1] == cu[ja[pending]]
            pending = pending[free]
            todo, pending = pending[:CHORD_BATCH], pending[CHORD_BATCH:]
            if todo.size == 0:
                break
            res = certify_chords(oracle, A[todo], B[todo], floor * CHORD_FLOOR, spacing, near=(C, R))
            for i, ch in zip(todo, res):
                if ch is None or used[ja[i] : jb[i] + 1].any():
                    continue
                ch = thin_line_chain(*ch, most=int(CHORD_GROWTH * (jb[i] - ja[i] + 1)))
                if ch is not None:
                    used[ja[i] : jb[i] + 1] = True
                    splices[int(ja[i])] = (int(jb[i]), *ch)
        return splices

    def refine(self, rounds: int) -> None:
        """Up to ``rounds`` more refinement rounds (fewer if the length stops dropping, the chain is full, a
        program stops short or the time is up: then no round follows, :attr:`done`)."""
        if self.done:
            return
        options, oracle, stats, clock = self.options, self.problem.oracle, self.stats, self.clock
        q0, q1, M, floor, max_chain = self.problem.q_init, self.problem.q_goal, options.metric, self.floor, self.max_chain
        C, R, ids, w, length = self.C, self.R, self.ids, self.w, self.length
        added_c, added_r, statuses = self.added_c, self.added_r, self.statuses
        done = True
        for _ in range(rounds):
            if time.process_time() > self.t_end:
                stats["refine_stopped"] = "time"
                break
            if time.perf_counter() > options.deadline:
                stats["refine_stopped"] = "time limit"
                break
            P = np.concatenate([[q0], w, [q1]])
            k = len(R)
            # 1. Shortcuts: certified chords between random points of the path; the best disjoint ones
            #    replace the bubbles between their ends: C[:ja+1] + chord + C[jb:] (segment j lies in bubble j).
            clock.lap("other")
            splices = self.pick_chords(P, C, R, length)
            clock.lap("chords")
            # 2. Bubbles where the path presses on a boundary, spliced in place (hatch p: bubbles p, p + 1),
            #    except inside a chord's span.
            sp_, pc, pr = press_bubbles(oracle, C, R, w, floor)
            clock.lap("press")
            conflict = np.zeros(k, dtype=bool)
            for a_, (b_, _, _) in splices.items():
                conflict[a_:b_] = True
            press = {int(p_): (c_, r_) for p_, c_, r_ in zip(sp_, pc, pr) if not conflict[p_]}
            if not splices and not press:
                break
            C2, R2, ids2, P2, nc_, nr_ = splice_chain(C, R, ids, P, splices, press, self.next_id())
            added_c += nc_
            added_r += nr_
            stats["shortcuts"] += len(splices)
            # 3. Further chords on the spliced polyline (no cone program in between).
            for _step in range(CHORD_STEPS - 1):
                if len(R2) >= max_chain:
                    break
                more = self.pick_chords(P2, C2, R2, length, STEP_GAIN * options.refine_tol)
                if not more:
                    break
                C2, R2, ids2, P2, nc_, nr_ = splice_chain(C2, R2, ids2, P2, more, {}, self.next_id())
                added_c += nc_
                added_r += nr_
                stats["shortcuts"] += len(more)
            clock.lap("chords")
            w2, length2 = shortest_path(C2, R2, q0, q1, M, tol=ROUND_TOL, status=statuses)
            clock.lap("socp")
            # 3. Drop the bubbles the path no longer needs (not from a chain of max_chain bubbles: that ends the
            #    rounds, and the re-cover below prunes it; over obstacle, step_up and step_down seeds 0-19, this prune
            #    dropped more than PRUNE_GAIN of such a chain in 1 round of 37).
            if options.prune and len(R2) < max_chain:
                keep_pos = prune_chain(C2, R2, np.concatenate([[q0], w2, [q1]]))
                clock.lap("prune")
                if len(keep_pos) < PRUNE_GAIN * len(R2):
                    C2, R2, ids2 = C2[keep_pos], R2[keep_pos], ids2[keep_pos]
                    w2, length2 = shortest_path(C2, R2, q0, q1, M, tol=ROUND_TOL, status=statuses)
                    clock.lap("socp")
            stats["refine_rounds"] += 1
            stats["refine_added"] = sum(len(x) for x in added_r)
            if not held(C2, R2, w2):  # a program that stopped short, its path outside a ball: keep the last round's chain
                stats["refine_stopped"] = "cone program unsolved"
                break
            gain = (length - length2) / length if length > 0 else 0.0
            if length2 <= length:
                C, R, ids, w, length = C2, R2, ids2, w2, length2
            if gain <= options.refine_tol or len(R) >= max_chain:
                break
        else:
            done = False  # every round asked for ran and none ended the rounds
        self.C, self.R, self.ids, self.w, self.length, self.done = C, R, ids, w, length, done

    def corridor(self) -> Corridor:
        """The corridor of the rounds so far (its chain re-covered and deepened; the rounds' state unchanged)."""
        options, oracle, clock = self.options, self.problem.oracle, self.clock
        q0, q1, M = self.problem.q_init, self.problem.q_goal, options.metric
        C, R, ids, w, length = self.C, self.R, self.ids, self.w, self.length
        added_c, added_r, statuses, stats = list(self.added_c), list(self.added_r), list(self.statuses), dict(self.stats)
        acc = dict(clock.acc)  # this step's laps are not the rounds' (restored below)

        def new_ids(count: int) -> np.ndarray:
            start = self.next_id(added_r)
            return np.arange(start, start + count)

        # 4. The last chain pruned (rounds skip a prune that drops few bubbles), then every hatch made deep enough
        #    to sample from: the smaller ball's centre inside the larger ball. One cone program for both.
        clock.lap("other")
        changed = False
        if options.refine and options.prune and len(R) > 2:
            P = np.concatenate([[q0], w, [q1]])
            extra = None
            if RECOVER:
                D = path_samples(P, PIECES)
                at = np.arange(0, len(D), PIECES // RECOVER)
                # Segment j of P (w_j to w_(j+1), P[0] = q0) lies in chain bubble j, so a sample's radius is at most that
                # bubble's plus its distance to the centre (r is 1-Lipschitz); the nearest of all bubbles, a (samples x
                # chain) product, doubled the re-cover's instructions on the 3-joint leg for the same radii.
                X, home = D[at], np.minimum(at // PIECES, len(R) - 1)
                rE = oracle.radii_below(X, R[home] + row_norms(X - C[home]))
                ok = rE > 4 * INSET
                extra = (at[ok], rE[ok])
                clock.lap("recover")
            keep_pos = prune_chain(C, R, P, extra=extra)
            if len(keep_pos) < len(R) or np.any(keep_pos >= len(R)):
                new = keep_pos >= len(R)
                if new.any():
                    assert extra is not None  # (only the re-cover's samples add bubbles)
                    j = keep_pos[new] - len(R)
                    ids = np.concatenate([ids, np.full(len(extra[1]), -1)])
                    ids[keep_pos[new]] = new_ids(int(new.sum()))
                    added_c.append(D[extra[0][j]])
                    added_r.append(extra[1][j])
                    C, R = np.concatenate([C, D[extra[0]]]), np.concatenate([R, extra[1]])
                    stats["recovered"] = int(new.sum())
                C, R, ids = C[keep_pos], R[keep_pos], ids[keep_pos]
                changed = True
            clock.lap("prune")
        C, R, ids, extra_c, extra_r = deepen(oracle, C, R, ids, new_ids)
        if len(extra_r):
            added_c.append(extra_c)
            added_r.append(extra_r)
            stats["deepened"] = int(len(extra_r))
        clock.lap("deepen")
        if changed or len(extra_r):
            w, length = shortest_path(C, R, q0, q1, M, status=statuses)
            clock.lap("socp")
        stats.update(socp_unsolved=sum(st not in ("Solved", "AlmostSolved") for st in statuses), chain=int(len(ids)), length=length, cpu_ms=clock.ms())
        clock.acc, clock.t = acc, time.process_time()
        n = self.dim
        ac = np.concatenate(added_c) if added_c else np.empty((0, n))
        ar = np.concatenate(added_r) if added_r else np.empty(0)
        return Corridor(C, R, ids, ac, ar, np.full(len(ar), -1, dtype=np.int64), w, length, stats)
