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
   the floor, thinned to the fewest that still hold it (:func:`thin_line_chain`), at most CHORD_GROWTH x as
   many bubbles as the stretch they replace) and prunes the chain to a short sub-chain that holds the path
   (:func:`prune_chain`). A round takes up to CHORD_STEPS (3) steps of chords before its cone program:
   after a step, the polyline itself is updated (:func:`splice_chain`: the old path up to the chord's
   start, points on the chord in consecutive chord bubbles, the old path after its end), so the next
   step's chords are drawn and certified on it with no program in between; the later steps take only
   chords that win more than ``refine_tol`` each and stop once the chain holds ``max_chain`` bubbles.
4. **Re-cover.** The last chain is pruned once more with, besides its own bubbles, certified bubbles
   centred at RECOVER points per segment of its shortest path (one batch of distance queries): where
   the path slides along an obstacle, bubbles centred on the path hold it with fewer bubbles than the
   pressing and chord bubbles the rounds left there. The new chain still holds that path (so its own
   shortest path is no longer), and every hatch is then made deep (:func:`deepen`).

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
per program need fewer rounds: cone programs per plan 9 / 7.5 / 9 -> 3 / 4 / 4. The re-cover shrinks the
final chain by 15-20 % (68.5 / 43.5 / 58 before it -> 69.5 / 36 / 47 now, with the longer chords). Lengths
0.8672 / 0.8798 / 1.756 -> 0.8264 / 0.8795 / 1.756 (seeds 10-19: 0.8779 / 0.8798 / 1.7571 -> 0.8613 / 0.8794
/ 1.7411). With the cached cone program, chord gaps filled in one batch and the interval prune, the
corridor's CPU time on obstacle fell from about 34 to 19 ms (plan + optimal smoother 80-84 -> 57-65 ms;
step_up 47-49 -> 34-39, step_down 70-75 -> 47-53; obstacle5 210-236 -> 182-184 ms, arm6 159 -> 155-159;
one loaded 2-core machine, best of 3 per seed). The smoother's time per seed (19-50 ms on obstacle) does not
follow the chain's size closely, so a changed trajectory moves its 10-seed median by a few ms either way.
Bubbles pushed off the path, away from the obstacle, were tried for the re-cover and do not help: the
certified radius grows only 0.2-0.4 x as fast as the centre moves away (the bound is conservative), so
such a bubble holds a shorter stretch of the path. Tried and not kept: chords in end-to-end tilings (no
fewer rounds), no pruning inside the rounds, or a chain cap lowered to 0.7-0.8 (fewer rounds, but step_down
0.5-1 % longer), a looser tolerance for the rounds' programs (1e-6: waypoints only 0.64 INSET inside; 1e-4
with a projection onto the lenses: -20 % program time, but the smoother's median rose 5 ms).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import lru_cache

import clarabel
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from foam_mj.rosary import Rosary
from foam_mj.smoothing.convex import build_socp

#: A hatch must be at least this fraction of the smaller radius deep.
HATCH = 0.05
DEBUG = False
#: The final rosary's hatches are at least this fraction of the smaller radius deep (hatch sampling by
#: rejection from the smaller ball then accepts a few per cent of draws even in 6-D).
DEEP = 0.5
#: Outward pushes of a refinement bubble's centre, in units of the radius at the pressing waypoint.
PUSH = np.array([0.0, 0.5, 0.75, 0.9])
#: Ball inset of the cone program (configuration units), as the convex smoother's default.
INSET = 1e-6
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
#: certify_chords queries every COARSE-th point of the chords first (a chord through an obstacle dies there).
COARSE = 4
#: A gap between two chord points that do not overlap deeply gets ceil(d / (SPLIT x the smaller radius)) - 1
#: evenly spaced points at once (at most GAP_POINTS): fewer bisection levels (one batch of queries each).
SPLIT = 1.4
GAP_POINTS = 8
#: Steps of chords per round (one cone program per round); the later steps take chords that win more than
#: STEP_GAIN x refine_tol of the length each (small wins there only lengthened the chain: arm6 60 -> 56).
CHORD_STEPS = 3
STEP_GAIN = 1.0
#: The last chain is re-covered with bubbles centred at RECOVER points per segment of its shortest path, as
#: well as its own (see :func:`prune_chain`); 0: pruned with its own bubbles only.
RECOVER = 4


@dataclass(frozen=True)
class CorridorOptions:
    refine: bool = True
    refine_tol: float = 0.005
    refine_rounds: int = 30
    floor_factor: float = 0.1
    chords: int = 24
    time_limit: float = 10.0  # process CPU seconds
    prune: bool = True
    #: Per-coordinate length weights (None: Euclidean in q); see :func:`shortest_path`.
    metric: np.ndarray | None = None
    #: No new round once the chain holds this many bubbles (the smoothers' time grows with it; the last
    #: rounds of a path sliding along an obstacle add many bubbles for a per cent or two).
    max_chain: int = 10**9


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

    Up to :data:`BRUTE_FORCE` bubbles, all pairs in blocks; beyond, a k-d tree: each bubble's neighbours
    within r_i + max r."""
    n = len(radii)
    if n < 2:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    I, J = [], []
    if n <= BRUTE_FORCE:
        # Squared distances against a squared bound (the bound r_i + r_j - hatch min(r_i, r_j) is positive),
        # rows against the later columns only.
        sq = np.einsum("ij,ij->i", centers, centers)
        for s0 in range(0, n, 256):
            s1 = min(n, s0 + 256)
            rest = slice(s0, n)
            d2 = sq[s0:s1, None] + sq[None, rest] - 2.0 * centers[s0:s1] @ centers[rest].T
            rb, rr = radii[s0:s1, None], radii[None, rest]
            bound = rb + rr - hatch * np.minimum(rb, rr)
            ok = d2 <= bound * bound
            i, j = np.nonzero(ok)
            i = i + s0
            j = j + s0
            up = j > i
            I.append(i[up])
            J.append(j[up])
        return np.concatenate(I), np.concatenate(J)
    tree = cKDTree(centers)
    nb = tree.query_ball_point(centers, r=radii + float(radii.max()), return_sorted=False)
    counts = np.fromiter((len(x) for x in nb), dtype=np.int64, count=n)
    i = np.repeat(np.arange(n), counts)
    j = np.fromiter((k for x in nb for k in x), dtype=np.int64, count=int(counts.sum()))
    up = j > i
    i, j = i[up], j[up]
    d = np.linalg.norm(centers[i] - centers[j], axis=1)
    ok = d <= radii[i] + radii[j] - hatch * np.minimum(radii[i], radii[j])
    return i[ok], j[ok]


#: Bubble counts up to which the overlap graph is built by brute force.
BRUTE_FORCE = 4096


def shortest_chain(
    centers: np.ndarray, radii: np.ndarray, q_init: np.ndarray, q_goal: np.ndarray, metric: np.ndarray | None = None
) -> np.ndarray | None:
    """Bubble indices of the shortest chain q_init -> q_goal through the overlap graph, or None
    (edge weights: distances between centres, weighted by ``metric`` as :func:`shortest_path`)."""
    n = len(radii)
    s = 1.0 if metric is None else np.asarray(metric, dtype=float)
    i, j = overlap_pairs(centers, radii)
    w = np.linalg.norm((centers[i] - centers[j]) * s, axis=1)
    S, G = n, n + 1
    hs = np.flatnonzero(np.linalg.norm(centers - q_init, axis=1) <= radii)
    hg = np.flatnonzero(np.linalg.norm(centers - q_goal, axis=1) <= radii)
    rows = np.concatenate([i, j, np.full(len(hs), S), hg])
    cols = np.concatenate([j, i, hs, np.full(len(hg), G)])
    vals = np.concatenate([w, w, np.linalg.norm((centers[hs] - q_init) * s, axis=1), np.linalg.norm((centers[hg] - q_goal) * s, axis=1)])
    vals = np.maximum(vals, 1e-12)  # an explicit zero would read as "no edge"
    g = sp.csr_matrix((vals, (rows, cols)), shape=(n + 2, n + 2))
    dist, pred = dijkstra(g, directed=True, indices=S, return_predecessors=True)
    if not np.isfinite(dist[G]):
        return None
    out = []
    k = int(pred[G])
    while k != S:
        out.append(k)
        k = int(pred[k])
    return np.array(out[::-1], dtype=np.int64)


@lru_cache(maxsize=128)
def _socp_template(m: int, n: int, metric: tuple[float, ...] | None):
    """The parts of :func:`foam_mj.smoothing.convex.build_socp`'s program for m waypoints in R^n that do not depend
    on the bubbles (P, q, A with the segment rows weighted by ``metric``, the cones), and where b takes the
    bubbles and the end points: (P, q, A, cones, rows of q_init, rows of q_goal, ball radius rows, ball centre
    rows, row weights or None)."""
    ros = Rosary(np.zeros((m + 1, n)), np.ones(m + 1), np.zeros(n), np.zeros(n))
    P, q, A, _, cones, _ = build_socp(ros, 0.0, 0.0)
    cd = n + 1
    d = np.arange(n)
    first = 1 + d  # segment 0: (t_0, w_1 - q_init)
    last = m * cd + 1 + d  # segment m: (t_m, q_goal - w_m)
    bbase = (m + 1) * cd + (np.arange(m)[:, None] * 2 + np.arange(2)) * cd  # (m, 2): both balls of each waypoint
    brow = bbase[..., None] + 1 + d  # (m, 2, n)
    row_w = None
    if metric is not None:
        # Segment cone j occupies rows j (n + 1) .. j (n + 1) + n: (t_j, p_(j+1) - p_j); weight its vector rows.
        row_w = np.ones(A.shape[0])
        seg_rows = (np.arange(m + 1)[:, None] * cd + 1 + d).ravel()
        row_w[seg_rows] = np.tile(np.asarray(metric), m + 1)
        A = A.copy()
        A.data *= row_w[A.indices]  # CSC: indices are row indices
    return P, q, A, cones, first, last, bbase.ravel(), brow.ravel(), row_w


def shortest_path(
    centers: np.ndarray, radii: np.ndarray, q_init: np.ndarray, q_goal: np.ndarray, metric: np.ndarray | None = None,
    tol: float = 1e-8,
) -> tuple[np.ndarray, float]:
    """Waypoints (k-1, n) of the shortest polyline through the chain's hatches, and its length.

    ``metric``: per-coordinate weights s (length sum_j |s * (p_(j+1) - p_j)|, e.g. the configuration map's
    qpos units per q unit: the length in MuJoCo's qpos); None is the Euclidean length in q. The balls stay
    balls in q (the weights scale only the segment cones' rows), so the program stays a small SOCP: the
    program of :func:`foam_mj.smoothing.convex.build_socp` (balls shrunk by INSET), its bubble-independent
    parts cached per chain length (:func:`_socp_template`)."""
    centers = np.asarray(centers, dtype=float)
    radii = np.asarray(radii, dtype=float)
    q_init = np.asarray(q_init, dtype=float)
    q_goal = np.asarray(q_goal, dtype=float)
    k, n = centers.shape
    sw = 1.0 if metric is None else np.asarray(metric, dtype=float)
    m = k - 1
    if m == 0:
        return np.empty((0, n)), float(np.linalg.norm((q_goal - q_init) * sw))
    P, q, A, cones, first, last, bbase, brow, row_w = _socp_template(m, n, None if metric is None else tuple(np.asarray(metric, dtype=float).tolist()))
    b = np.zeros(A.shape[0])
    b[first] = -q_init
    b[last] = q_goal
    b[bbase] = np.stack([radii[:-1], radii[1:]], axis=1).ravel() - INSET
    b[brow] = -np.stack([centers[:-1], centers[1:]], axis=1).ravel()
    if row_w is not None:
        b *= row_w
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    # Without presolve (nothing to remove) and iterative refinement: 40 % less time for the same path to 1e-8.
    settings.presolve_enable = False
    settings.iterative_refinement_enable = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = tol
    sol = clarabel.DefaultSolver(P, q, A, b, cones, settings).solve()
    w = np.asarray(sol.x[: m * n]).reshape(m, n)
    pts = np.concatenate([[q_init], w, [q_goal]])
    return w, float(np.sum(np.linalg.norm(np.diff(pts, axis=0) * sw, axis=1)))


def _arc_points(P: np.ndarray, x: np.ndarray, metric: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Points of the polyline P at arc lengths x (weighted by ``metric``), and the segment index of each."""
    seg = np.linalg.norm(np.diff(P, axis=0) * (1.0 if metric is None else metric), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    j = np.clip(np.searchsorted(cum, x, side="right") - 1, 0, len(seg) - 1)
    f = np.clip((x - cum[j]) / np.where(seg[j] > 0, seg[j], 1.0), 0.0, 1.0)
    return P[j] + f[:, None] * (P[j + 1] - P[j]), j


def certify_chords(oracle, A: np.ndarray, B: np.ndarray, floor: float, spacing: float, levels: int = 10) -> list[tuple[np.ndarray, np.ndarray] | None]:
    """For each straight chord A[k] -> B[k]: bubble centres along it, every two consecutive overlapping
    with a hatch and every radius >= floor (a certified chain that holds the chord), or None.

    Centres start ``spacing`` apart; a gap between two neighbours that do not overlap gets its midpoint,
    all chords' midpoints in one batch per level (at most ``levels``). The chords' points live in flat
    arrays sorted by (chord, position): no Python loop over chords."""
    lo, hi = oracle.robot.lower, oracle.robot.upper
    K = len(A)
    if K == 0:
        return []
    V = B - A
    m = np.maximum(1, np.ceil(np.linalg.norm(V, axis=1) / spacing).astype(np.int64))
    cid = np.repeat(np.arange(K), m + 1)
    start = np.repeat(np.cumsum(m + 1) - (m + 1), m + 1)
    t = (np.arange(len(cid)) - start) / m[cid]
    pts = A[cid] + V[cid] * t[:, None]
    alive = np.ones(K, dtype=bool)
    r = np.zeros(len(pts))
    # A chord through an obstacle dies on any point: every COARSE-th point first, the others of the survivors after.
    coarse = (np.arange(len(cid)) - start) % COARSE == COARSE // 2 if COARSE > 1 else np.ones(len(cid), dtype=bool)
    r[coarse] = oracle.radii(pts[coarse])
    alive[cid[coarse & (r < floor)]] = False
    rest = ~coarse & alive[cid]
    if rest.any():
        r[rest] = oracle.radii(pts[rest])
        alive[cid[rest & (r < floor)]] = False

    def gaps() -> np.ndarray:
        same = cid[:-1] == cid[1:]
        d = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        return np.flatnonzero(same & alive[cid[:-1]] & (d > r[:-1] + r[1:] - DEEP * np.minimum(r[:-1], r[1:])))

    for _ in range(levels):
        keep = alive[cid]  # drop the dead chords' points
        cid, t, pts, r = cid[keep], t[keep], pts[keep], r[keep]
        g = gaps()
        if g.size == 0:
            break
        # Each gap gets evenly spaced points, as many as its ends' smaller radius suggests (SPLIT x that radius
        # apart: deep overlaps if the radius holds in between), at most GAP_POINTS; one if GAP_POINTS is 1.
        dg = np.linalg.norm(pts[g + 1] - pts[g], axis=1)
        cnt = np.clip(np.ceil(dg / (SPLIT * np.maximum(np.minimum(r[g], r[g + 1]), 1e-12))).astype(np.int64) - 1, 1, GAP_POINTS)
        gi = np.repeat(g, cnt)
        frac = (np.arange(len(gi)) - np.repeat(np.cumsum(cnt) - cnt, cnt) + 1) / np.repeat(cnt + 1, cnt)
        cm = cid[gi]
        tm = t[gi] + frac * (t[gi + 1] - t[gi])
        newp = A[cm] + V[cm] * tm[:, None]
        inb = np.all((newp >= lo) & (newp <= hi), axis=1)
        rn = np.zeros(len(newp))
        if inb.any():
            rn[inb] = oracle.radii(newp[inb])
        alive[cm[rn < floor]] = False
        cid, t = np.concatenate([cid, cm]), np.concatenate([t, tm])
        pts, r = np.concatenate([pts, newp]), np.concatenate([r, rn])
        order = np.lexsort((t, cid))
        cid, t, pts, r = cid[order], t[order], pts[order], r[order]
    alive[cid[gaps()]] = False  # still a gap after the last level
    out: list[tuple[np.ndarray, np.ndarray] | None] = [None] * K
    for k in np.flatnonzero(alive):
        sel = cid == k
        out[int(k)] = (pts[sel], r[sel])
    return out




def thin_line_chain(pts: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The fewest of a chord's bubbles (centres in order along the chord) that still hold it: from each kept
    bubble, the farthest later one that overlaps it with a deep hatch (DEEP). Two balls centred on a
    segment that overlap cover the segment between their centres, so the kept chain holds the chord."""
    m = len(r)
    if m <= 2:
        return pts, r
    d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=2)
    ok = d <= r[:, None] + r[None, :] - DEEP * np.minimum(r[:, None], r[None, :])
    # Consecutive bubbles overlap deeply by construction (certify_chords bisects until they do).
    far = m - 1 - np.argmax(ok[:, ::-1], axis=1)  # the last bubble each one overlaps deeply
    keep = [0]
    while keep[-1] < m - 1:
        keep.append(max(far[keep[-1]], keep[-1] + 1))
    keep = np.array(keep)
    return pts[keep], r[keep]


def path_samples(P: np.ndarray, pieces: int) -> np.ndarray:
    """The polyline P sampled ``pieces`` times per segment: sample j * pieces is P[j]; the last is P[-1]."""
    t = np.arange(pieces) / pieces
    return np.concatenate([(P[:-1, None, :] + (P[1:] - P[:-1])[:, None, :] * t[None, :, None]).reshape(-1, P.shape[1]), P[-1:]])


#: prune_chain looks for a bubble's held samples at most this many samples beyond its home interval.
PRUNE_BAND = 24
#: prune_chain compares all pairs of bubbles up to this many bubbles, else only pairs of touching intervals.
DENSE_SUCC = 128


def prune_chain(
    C: np.ndarray, R: np.ndarray, P: np.ndarray, pieces: int = 8, extra: tuple[np.ndarray, np.ndarray] | None = None
) -> np.ndarray:
    """Positions (into the chain, then into ``extra``) of a short chain of bubbles that still holds the polyline P.

    P's segment j lies in bubble j. ``extra`` = (sample indices, certified radii): further bubbles centred at
    samples of P (:func:`path_samples` with ``pieces``) that may be used. Each bubble holds an interval of samples
    around its home (segment j's samples j*pieces .. (j+1)*pieces for chain bubble j, its centre's sample for an
    extra one; looked for at most PRUNE_BAND samples beyond). Greedily, from the bubble that holds the first
    sample, take the bubble whose interval starts inside the current one and reaches farthest, among those that
    overlap the current one with a deep hatch (DEEP; else any hatch, HATCH). The polyline through one shared
    sample per hand-over keeps each piece inside one bubble (balls are convex) and is no longer than P (triangle
    inequality), so the shortest path through the new chain is no longer either. "Holds" is tested with the
    balls shrunk by 1.5 INSET so that the cone program stays feasible."""
    k = len(R)
    D = path_samples(P, pieces)
    T = len(D)
    h0 = np.arange(k) * pieces
    h1 = h0 + pieces
    if extra is not None and len(extra[1]):
        idx = np.asarray(extra[0], dtype=np.int64)
        C, R = np.concatenate([C, D[idx]]), np.concatenate([R, extra[1]])
        h0, h1 = np.concatenate([h0, idx]), np.concatenate([h1, idx])
    nb = len(R)
    rs2 = np.maximum(R - 1.5 * INSET, 0.0) ** 2
    # Held samples after the home interval (offsets 1..PRUNE_BAND) and before it; the home interval itself is
    # held (the segment and both waypoints were solved inside the shrunk balls, to the solver's tolerance).
    off = np.arange(1, PRUNE_BAND + 1)
    after = h1[:, None] + off
    before = h0[:, None] - off
    ina = (after < T) & (np.einsum("ijk,ijk->ij", *(2 * [D[np.minimum(after, T - 1)] - C[:, None, :]])) <= rs2[:, None])
    inb = (before >= 0) & (np.einsum("ijk,ijk->ij", *(2 * [D[np.maximum(before, 0)] - C[:, None, :]])) <= rs2[:, None])
    # Length of the run of held samples next to the home interval (all of the band if it never breaks).
    na = np.where(ina.all(axis=1), PRUNE_BAND, np.argmin(ina, axis=1))
    nbf = np.where(inb.all(axis=1), PRUNE_BAND, np.argmin(inb, axis=1))
    e = np.minimum(h1 + na, T - 1)
    s_ = np.maximum(h0 - nbf, 0)
    # The successor of each bubble (it depends on that bubble only): among the bubbles whose interval starts
    # inside its own and reaches farther, the farthest-reaching one (the first such index) with a deep hatch,
    # else with any hatch. Such a bubble holds the sample after the interval's end; for many bubbles the
    # candidates are read from the samples' lists of the bubbles that hold them (pairs of intervals that
    # touch, not all pairs).
    succ = np.full(nb, -1)
    if nb <= DENSE_SUCC:
        sq = np.einsum("ij,ij->i", C, C)
        slack = R[:, None] + R[None, :] - np.sqrt(np.maximum(sq[:, None] + sq[None, :] - 2.0 * (C @ C.T), 0.0))
        small = np.minimum(R[:, None], R[None, :])
        reach = (s_[None, :] <= e[:, None]) & (e[None, :] > e[:, None])
        for depth in (HATCH, DEEP):  # the deep tier last: it overrides where it has a candidate
            score = np.where(reach & (slack >= depth * small), e[None, :], -1)
            best = np.argmax(score, axis=1)
            succ = np.where(score[np.arange(nb), best] >= 0, best, succ)
    else:
        L = e - s_ + 1
        jj = np.repeat(np.arange(nb), L)
        pp = np.repeat(s_, L) + (np.arange(int(L.sum())) - np.repeat(np.cumsum(L) - L, L))
        order = np.argsort(pp, kind="stable")
        jj, pp = jj[order], pp[order]
        lo_ = np.searchsorted(pp, e + 1, side="left")
        cnt = np.searchsorted(pp, e + 1, side="right") - lo_
        ii = np.repeat(np.arange(nb), cnt)
        cj = jj[np.repeat(lo_, cnt) + (np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt))]
        ok = s_[cj] <= e[ii]
        ii, cj = ii[ok], cj[ok]
        slack = R[ii] + R[cj] - np.linalg.norm(C[ii] - C[cj], axis=1)
        small = np.minimum(R[ii], R[cj])
        for depth in (HATCH, DEEP):
            sel = slack >= depth * small
            a_, b_ = ii[sel], cj[sel]
            o = np.lexsort((-b_, e[b_], a_))  # by bubble, reach, then index down: a run's last is the pick
            a_, b_ = a_[o], b_[o]
            last = np.flatnonzero(np.r_[a_[1:] != a_[:-1], True]) if len(a_) else np.empty(0, dtype=np.int64)
            succ[a_[last]] = b_[last]
    start = np.flatnonzero(s_ == 0)
    out = [int(start[np.argmax(e[start])])]
    while e[out[-1]] < T - 1:
        nxt = int(succ[out[-1]])
        if nxt < 0:
            return np.arange(k)  # no overlapping bubble makes progress: keep the chain as it is
        out.append(nxt)
    return np.array(out, dtype=np.int64)


def deepen(oracle, C: np.ndarray, R: np.ndarray, ids: np.ndarray, new_ids) -> tuple:
    """Make every hatch deep: where consecutive bubbles a, b overlap by less than DEEP x the smaller radius
    (a thin lens, which the smoothers' rejection sampling of hatches cannot fill), splice a certified
    bubble centred at their portal centre m. m lies in both balls, so r(m) > 0 (r is 1-Lipschitz), and
    each new hatch is more than r(m) deep: |c_a - m| < r_a gives r_a + r(m) - |c_a - m| > r(m) >= min(r_a, r(m)).
    Returns the new chain and the added bubbles."""
    d = np.linalg.norm(np.diff(C, axis=0), axis=1)
    thin = np.flatnonzero(d > R[:-1] + R[1:] - DEEP * np.minimum(R[:-1], R[1:]))
    n = C.shape[1]
    if thin.size == 0:
        return C, R, ids, np.empty((0, n)), np.empty(0)
    ca, cb, ra, rb, dd = C[thin], C[thin + 1], R[thin], R[thin + 1], d[thin]
    t = (dd**2 + ra**2 - rb**2) / (2 * dd)
    m = ca + (t / dd)[:, None] * (cb - ca)
    rm = oracle.radii(m)
    good = rm > 2 * INSET
    thin, m, rm = thin[good], m[good], rm[good]
    nid = new_ids(len(rm))
    return np.insert(C, thin + 1, m, axis=0), np.insert(R, thin + 1, rm), np.insert(ids, thin + 1, nid), m, rm


def _press_bubbles(oracle, C, R, w, floor):
    """Certified bubbles for the waypoints that press on a ball's boundary, pushed outward (see PUSH):
    (positions in the chain after which each goes, centres, radii)."""
    da = np.linalg.norm(w - C[:-1], axis=1)
    db = np.linalg.norm(w - C[1:], axis=1)
    tol = 1e-3 * np.minimum(R[:-1], R[1:]) + 4 * INSET
    on_a, on_b = da >= R[:-1] - tol, db >= R[1:] - tol
    press = np.flatnonzero(on_a | on_b)
    if press.size == 0:
        return press, np.empty((0, w.shape[1])), np.empty(0)
    wp = w[press]
    rp = oracle.radii(wp)
    # Outward: away from the centres of the pressed balls. r is 1-Lipschitz (the Cauchy-Schwarz ball of
    # Nascimento and Alsina 2021 Eq. 4), so a centre pushed by t r with t <= 1/2 still holds w.
    nrm = (wp - C[press]) * on_a[press, None] + (wp - C[press + 1]) * on_b[press, None]
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
    cands = wp[:, None, :] + (PUSH[None, :, None] * rp[:, None, None]) * nrm[:, None, :]
    flat = cands.reshape(-1, wp.shape[1])
    okb = np.all((flat >= oracle.robot.lower) & (flat <= oracle.robot.upper), axis=1)
    rc = np.zeros(len(flat))
    if okb.any():
        rc[okb] = oracle.radii(flat[okb])
    rc = rc.reshape(len(press), len(PUSH))
    holds = rc * (1 - HATCH) > PUSH[None, :] * rp[:, None] + 2 * INSET  # holds w with a hatch of HATCH r
    reach = np.where(holds, PUSH[None, :] * rp[:, None] + rc, -np.inf)
    best = np.argmax(reach, axis=1)
    row = np.arange(len(press))
    has = np.isfinite(reach[row, best])
    pc = np.where(has[:, None], cands[row, best], wp)
    pr = np.where(has, rc[row, best], rp)
    useful = (
        (pr >= floor)
        & (np.linalg.norm(pc - C[press], axis=1) + pr > R[press] * (1 + 1e-6))
        & (np.linalg.norm(pc - C[press + 1], axis=1) + pr > R[press + 1] * (1 + 1e-6))
    )
    return press[useful], pc[useful], pr[useful]


def splice_chain(C: np.ndarray, R: np.ndarray, ids: np.ndarray, P: np.ndarray, splices: dict, press: dict, first_id: int) -> tuple:
    """The chain with chords and pressing bubbles spliced in, a polyline whose segment j lies in its bubble j,
    and the new bubbles (centres, radii).

    ``P``: a polyline whose segment j lies in bubble j of (C, R). ``splices``: {ja: (jb, centres, radii)}, a
    chord's chain from A (on segment ja) to B (on segment jb), centres on the chord in order, consecutive ones
    overlapping; it replaces bubbles ja + 1 .. jb - 1. ``press``: {p: (centre, radius)}, a bubble that holds
    P[p + 1], spliced between bubbles p and p + 1. The new polyline is P up to A, then through one point of
    each pair of consecutive chord bubbles (on the chord, in both: the middle of where both balls meet the
    chord) to B, then P on; a pressing bubble gets a segment of no length at P[p + 1]. It is no longer than P
    (the chord replaces the stretch A .. B of P). The new bubbles get the ids first_id, first_id + 1, ... in
    the order returned."""
    k = len(R)
    removed = np.zeros(k + 1, dtype=int)
    for a_, (b_, _, _) in splices.items():
        removed[a_ + 1] += 1
        removed[b_] -= 1
    inside_span = np.cumsum(removed)[:k] > 0  # bubbles a_+1 .. b_-1 of a chord
    parts_c, parts_r, parts_i, verts, new_c, new_r = [], [], [], [P[:1]], [], []
    for j in range(k):
        if inside_span[j]:
            continue
        parts_c.append(C[j : j + 1])
        parts_r.append(R[j : j + 1])
        parts_i.append(ids[j : j + 1])
        extra = splices[j][1:] if j in splices else (press[j][0][None, :], np.array([press[j][1]])) if j in press else None
        if j in splices:
            pc_, pr_ = extra
            a0 = pc_[0]
            dv = pc_[-1] - a0
            uv = dv / max(float(np.linalg.norm(dv)), 1e-300)
            sc = (pc_ - a0) @ uv
            lo_ = np.maximum(sc[1:] - pr_[1:], sc[:-1])
            hi_ = np.minimum(sc[:-1] + pr_[:-1], sc[1:])
            verts += [pc_[:1], a0 + (0.5 * (lo_ + hi_))[:, None] * uv, pc_[-1:]]
        elif j in press:
            verts += [P[j + 1 : j + 2], P[j + 1 : j + 2]]
        else:
            verts.append(P[j + 1 : j + 2])
        if extra is not None:
            parts_c.append(extra[0])
            parts_r.append(extra[1])
            parts_i.append(first_id + sum(len(x) for x in new_r) + np.arange(len(extra[1])))
            new_c.append(extra[0])
            new_r.append(extra[1])
    return np.concatenate(parts_c), np.concatenate(parts_r), np.concatenate(parts_i), np.concatenate(verts), new_c, new_r


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
    rng: np.random.Generator | None = None,
) -> Corridor:
    """The shortest chain through the bubbles, refined while the shortest path through it shortens."""
    oracle = problem.oracle
    rng = rng if rng is not None else np.random.default_rng(0)
    q0, q1 = problem.q_init, problem.q_goal
    n_base = len(radii)
    M = options.metric
    clock = _Clock()
    ids = shortest_chain(centers, radii, q0, q1, M)
    clock.lap("dijkstra")
    if ids is None:  # pragma: no cover - the trees met, so a chain exists
        raise RuntimeError("no chain of overlapping bubbles joins q_init and q_goal")
    C, R = centers[ids], radii[ids]
    added_c: list[np.ndarray] = []
    added_r: list[np.ndarray] = []
    w, length = shortest_path(C, R, q0, q1, M)
    clock.lap("socp")
    stats = {"chain_first": int(len(ids)), "length_first": length, "refine_rounds": 0, "refine_added": 0, "shortcuts": 0}

    def new_ids(count: int) -> np.ndarray:
        start = n_base + sum(len(x) for x in added_r)
        return np.arange(start, start + count)

    if options.refine and len(ids) > 1:
        floor = options.floor_factor * max(problem.delta, 1e-4) / oracle.bound.ball_factor
        t_end = time.process_time() + options.time_limit  # CPU time: the same rounds on a loaded machine

        def pick_chords(P: np.ndarray, R: np.ndarray, min_gain: float = 1e-3) -> dict[int, tuple[int, np.ndarray, np.ndarray]]:
            """The chords to splice into the chain whose segment j of P lies in bubble j (R: its radii), each
            shorter than the stretch of P it replaces by more than ``min_gain`` x the length."""
            splices: dict[int, tuple[int, np.ndarray, np.ndarray]] = {}
            if not options.chords:
                return splices
            k = len(R)
            u = np.sort(rng.random((options.chords, 2)), axis=1)
            x = u * np.sum(np.linalg.norm(np.diff(P, axis=0) * (1.0 if M is None else M), axis=1))
            A, ja = _arc_points(P, x[:, 0], M)
            B, jb = _arc_points(P, x[:, 1], M)
            gain = (x[:, 1] - x[:, 0]) - np.linalg.norm((B - A) * (1.0 if M is None else M), axis=1)
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
                free = np.array([not used[ja[i] : jb[i] + 1].any() for i in pending], dtype=bool)
                pending = pending[free]
                todo, pending = pending[:CHORD_BATCH], pending[CHORD_BATCH:]
                if todo.size == 0:
                    break
                res = certify_chords(oracle, A[todo], B[todo], floor * CHORD_FLOOR, spacing)
                for i, ch in zip(todo, res):
                    if ch is None or used[ja[i] : jb[i] + 1].any():
                        continue
                    ch = thin_line_chain(*ch)
                    if len(ch[1]) <= CHORD_GROWTH * (jb[i] - ja[i] + 1):
                        used[ja[i] : jb[i] + 1] = True
                        splices[int(ja[i])] = (int(jb[i]), *ch)
            return splices

        for _ in range(options.refine_rounds):
            if time.process_time() > t_end:
                stats["refine_stopped"] = "time"
                break
            P = np.concatenate([[q0], w, [q1]])
            k = len(R)
            # 1. Shortcuts: certified chords between random points of the path; the best disjoint ones
            #    replace the bubbles between their ends: C[:ja+1] + chord + C[jb:] (segment j lies in bubble j).
            clock.lap("other")
            splices = pick_chords(P, R)
            clock.lap("chords")
            # 2. Bubbles where the path presses on a boundary, spliced in place (hatch p: bubbles p, p + 1),
            #    except inside a chord's span.
            sp_, pc, pr = _press_bubbles(oracle, C, R, w, floor)
            clock.lap("press")
            conflict = np.zeros(k, dtype=bool)
            for a_, (b_, _, _) in splices.items():
                conflict[a_:b_] = True
            press = {int(p_): (c_, r_) for p_, c_, r_ in zip(sp_, pc, pr) if not conflict[p_]}
            if not splices and not press:
                break
            C2, R2, ids2, P2, nc_, nr_ = splice_chain(C, R, ids, P, splices, press, n_base + sum(len(x) for x in added_r))
            added_c += nc_
            added_r += nr_
            stats["shortcuts"] += len(splices)
            # 3. Further chords on the spliced polyline (no cone program in between).
            for _step in range(CHORD_STEPS - 1):
                if len(R2) >= options.max_chain:
                    break
                more = pick_chords(P2, R2, STEP_GAIN * options.refine_tol)
                if not more:
                    break
                C2, R2, ids2, P2, nc_, nr_ = splice_chain(C2, R2, ids2, P2, more, {}, n_base + sum(len(x) for x in added_r))
                added_c += nc_
                added_r += nr_
                stats["shortcuts"] += len(more)
            clock.lap("chords")
            w2, length2 = shortest_path(C2, R2, q0, q1, M, tol=ROUND_TOL)
            clock.lap("socp")
            # 3. Drop the bubbles the path no longer needs.
            if options.prune:
                keep_pos = prune_chain(C2, R2, np.concatenate([[q0], w2, [q1]]))
                clock.lap("prune")
                if len(keep_pos) < PRUNE_GAIN * len(R2):
                    C2, R2, ids2 = C2[keep_pos], R2[keep_pos], ids2[keep_pos]
                    w2, length2 = shortest_path(C2, R2, q0, q1, M, tol=ROUND_TOL)
                    clock.lap("socp")
            stats["refine_rounds"] += 1
            stats["refine_added"] = sum(len(x) for x in added_r)
            gain = (length - length2) / length if length > 0 else 0.0
            if DEBUG:
                print(f"round: k {k} press {len(press)} chords {len(splices)} (+{sum(len(v[2]) for v in splices.values())} -{sum(v[0]-a for a, v in splices.items())}) chain {len(R2)} length {length:.4f} -> {length2:.4f}")
            if length2 <= length:
                C, R, ids, w, length = C2, R2, ids2, w2, length2
            if gain <= options.refine_tol or len(R) >= options.max_chain:
                break
    # 4. The last chain pruned (rounds skip a prune that drops few bubbles), then every hatch made deep enough
    #    to sample from: the smaller ball's centre inside the larger ball. One cone program for both.
    clock.lap("other")
    changed = False
    if options.refine and options.prune and len(R) > 2:
        P = np.concatenate([[q0], w, [q1]])
        extra = None
        if RECOVER:
            D = path_samples(P, 8)
            at = np.arange(0, len(D), 8 // RECOVER)
            rE = oracle.radii(D[at])
            ok = rE > 4 * INSET
            extra = (at[ok], rE[ok])
            clock.lap("recover")
        keep_pos = prune_chain(C, R, P, extra=extra)
        if len(keep_pos) < len(R) or np.any(keep_pos >= len(R)):
            new = keep_pos >= len(R)
            if new.any():
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
    C, R, ids, extra_c, extra_r = deepen(oracle, C, R, ids, lambda m: new_ids(m))
    if len(extra_r):
        added_c.append(extra_c)
        added_r.append(extra_r)
        stats["deepened"] = int(len(extra_r))
    clock.lap("deepen")
    if changed or len(extra_r):
        w, length = shortest_path(C, R, q0, q1, M)
        clock.lap("socp")
    stats.update(chain=int(len(ids)), length=length, cpu_ms=clock.ms())
    n = centers.shape[1]
    ac = np.concatenate(added_c) if added_c else np.empty((0, n))
    ar = np.concatenate(added_r) if added_r else np.empty(0)
    return Corridor(C, R, ids, ac, ar, np.full(len(ar), -1, dtype=np.int64), w, length, stats)
