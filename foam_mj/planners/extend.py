"""``bubbletree``'s extension step (steps 3 and 4 of :mod:`foam_mj.planners.bubbletree`): from the parents and targets of
one iteration, the candidate centres along each direction, their certified radii in one batch of distance queries, and
the children kept (the farthest good candidate of each extension, in no other bubble of its tree).

An iteration makes some two hundred numpy calls on arrays of tens to hundreds of rows, so that their count, not their
size, sets its time: the constants of these calls (the bounds as columns, the siblings' mask as infinities to add, row
numbers) are made once per plan here, and each step is written with as few calls as give the same values to the last bit.
"""

from __future__ import annotations

import numpy as np

from foam_mj.planners.chains import HATCH
from foam_mj.planners.trees import Bubbles, lifted

#: Candidate centres per extension, at s r_p from the parent's centre along the direction to the target.
STEPS = np.array([1.0, 2.0])
#: BY_STEP_PAIRS: with at least this many checked pairs, the candidates are sized a step at a time (the farthest first,
#: one batch per step), a nearer step only for the extensions whose farther candidates are not good: the farthest good
#: candidate is the child, so the children are the same to the last bit, with fewer queries (on MuJoCo Menagerie's
#: arms the s = 2 candidate is good for 11-16 % of the extensions, so its s = 1 query is saved there), for one more
#: batch call per iteration (some 80 us with its numpy calls), which a cheap query does not repay: about 5 % of an
#: iteration's ~130 queries are saved, so it pays from ~15 us a query (the 3-joint leg: 6 pairs, 3 us; the UR5e's 38
#: capsule pairs, 11-13 us: break-even, left out; the Allegro finger's 89 primitive pairs 33 us, xArm7 and Panda 50-65).
BY_STEP_PAIRS = 64
#: An extension's kind: toward a sample, up the radius's gradient (ESCAPE), toward the other tree (as masks only when read).
SAMPLED, ESCAPING, GOAL = 0, 1, 2


class Extender:
    """The extension step of one plan (module docstring). ``floors(kind, P, rP, target_r)`` gives each extension's
    smallest radius kept (the planner's rules GROW, SMALLEST, CORNER, TOWARD_SMALL, ESCAPE and FINER); ``k_max``
    bounds the extensions per tree per iteration."""

    def __init__(self, oracle, k_max: int, max_bubbles: int) -> None:
        self.oracle = oracle
        robot = oracle.robot
        self.n = n = robot.dim
        self.lo_col, self.hi_col = robot.lower.reshape(n, 1), robot.upper.reshape(n, 1)
        self.steps = STEPS[None, :]
        self.max_bubbles = max_bubbles
        # later[i, j]: sibling j is not earlier than i, as +inf (else 0) to add to the siblings' power distances
        self.later = np.where(np.tri(k_max, k_max, -1, dtype=bool), 0.0, np.inf)
        self.rows = np.arange(k_max)
        self.by_step = len(robot.pairs) >= BY_STEP_PAIRS

    def children(self, B: Bubbles, P: np.ndarray, targets: np.ndarray, floors, counters: dict):
        """The children of the extensions from bubbles P toward ``targets`` (the start tree's extensions first):
        (centres, radii, parents, trees, lifted centres) of those kept, or None. ``floors(live, P, rP)`` returns the
        smallest radius kept per extension (m,), for the extensions ``live`` (indices, or None for all) from parents P
        of radii rP."""
        n, oracle = self.n, self.oracle
        cP, rP = B.c.take(P, axis=0), B.r.take(P)
        v = targets - cP
        dist = np.sqrt(np.einsum("ij,ij->i", v, v))
        ok = dist > rP * (1 + 1e-9)  # a target inside its parent adds nothing
        live = None
        if not ok.all():
            live = ok.nonzero()[0]
            if live.size == 0:
                return None
            P, cP, rP, v, dist = P.take(live), cP.take(live, axis=0), rP.take(live), v.take(live, axis=0), dist.take(live)
        s = np.minimum(self.steps * rP[:, None], dist[:, None])  # (m, S) distances from the parent's centre
        cand = cP[:, None, :] + (s / dist[:, None])[..., None] * v[:, None, :]  # (m, S, n)
        # Every candidate lies on the segment from its parent's centre to its target, both in the joint box
        # (convex). A radius is at most the distance to the bounds: a candidate too near them for a good
        # radius (below) is not sized (radius 0, never kept: 12 % of them on the obstacle scene, nearly all
        # at s = 2); the rest are, in one batch. (The bounds' distances as BubbleOracle.to_bounds.)
        flat = cand.reshape(-1, n)
        fT = flat.T
        W = np.empty((2 * n, len(flat)))
        np.subtract(fT, self.lo_col, out=W[:n])
        np.subtract(self.hi_col, fT, out=W[n:])
        wall = np.minimum.reduce(W, axis=0).reshape(s.shape)
        reach = rP[:, None]
        floor = floors(live, P, rP)[:, None]
        ask = np.flatnonzero((wall >= floor) & (s <= reach + (1 - HATCH) * wall))
        r = np.zeros(s.shape)
        # A candidate's radius is at most its parent's plus the step (r is 1-Lipschitz) and its distance to the
        # bounds: MuJoCo measures each pair only that far (the same radii to the last bit).
        def size(a: np.ndarray) -> None:  # the candidates at flat indices a
            wall_a = wall.take(a)
            r.put(a, oracle.radii_below(flat.take(a, axis=0), np.minimum((reach + s).take(a), wall_a), wall_a))
            counters["candidates"] += len(a)

        if not self.by_step:
            size(ask)
        else:  # BY_STEP: the farthest step first, a nearer one only for extensions with no good candidate farther out
            S = STEPS.size
            found = np.zeros(len(s), dtype=bool)
            for k in range(S - 1, -1, -1):
                a = ask[ask % S == k]
                if k < S - 1:
                    a = a[~found.take(a // S)]
                if a.size:
                    size(a)
                    found |= (r[:, k] >= floor[:, 0]) & (s[:, k] <= rP + (1 - HATCH) * r[:, k])
        good = (r >= floor) & (s <= reach + (1 - HATCH) * r)
        counters["rejected_small"] += len(ask) - int(np.count_nonzero(good))
        # The farthest good candidate of each extension.
        rows = np.logical_or.reduce(good, axis=1).nonzero()[0]
        if rows.size == 0:
            return None
        S = STEPS.size
        at = rows * S + (S - 1 - good[rows, ::-1].argmax(axis=1))
        cc, cr, cp = flat.take(at, axis=0), r.take(at), P.take(rows)
        ct = B.tree.take(cp)
        # Not inside another bubble of its tree (the parent excluded), nor inside an earlier sibling of this
        # batch: per tree (the start tree's extensions come first), power distances < 0 to the tree's
        # bubbles and to the siblings' balls, in one product.
        keep = np.empty(len(rows), dtype=bool)
        k0 = int(np.count_nonzero(ct == 0))
        L = lifted(cc)
        for t, a, b in ((0, 0, k0), (1, k0, len(rows))):
            k = b - a
            if k == 0:
                continue
            T = B.trees[t]
            T.reserve(T.n + k)  # the siblings' rows [-2c, |c|^2 - r^2, 1] go after the tree's own
            sib = T.pw[T.n : T.n + k]
            np.multiply(cc[a:b], -2.0, out=sib[:, :n])
            sib[:, n] = L[a:b, -1] - cr[a:b] ** 2
            pw = L[a:b] @ T.pw[: T.n + k].T
            pw[self.rows[:k], B.pos.take(cp[a:b])] = np.inf
            tail = pw[:, T.n :]
            np.add(tail, self.later[:k, :k], out=tail)  # an earlier sibling's only: +0 keeps the rest, and inf their own
            keep[a:b] = pw.min(axis=1) >= 0.0
        kept = int(np.count_nonzero(keep))
        counters["rejected_covered"] += len(rows) - kept
        room = self.max_bubbles - B.n
        if kept == len(rows) and kept <= room:
            return cc, cr, cp, ct, L
        sel = keep.nonzero()[0][:room]
        if sel.size == 0:
            return None
        return cc.take(sel, axis=0), cr.take(sel), cp.take(sel), ct.take(sel), L.take(sel, axis=0)
