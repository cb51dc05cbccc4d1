"""The bubbles of ``bubbletree``'s two trees, stored for its vectorised growth (foam_mj.planners.bubbletree).

Every array is preallocated and grown by doubling, rows written in place: a growth iteration makes some two
hundred numpy calls on arrays of tens to hundreds of rows, so the count of calls, not their size, sets its time.
"""

from __future__ import annotations

import numpy as np

from foam_mj.foam import Foam
from foam_mj.planners.chains import HATCH


def grow(obj, names: tuple[str, ...], size: int) -> None:
    """Double the arrays ``obj.<name>`` (first axis) until they hold ``size`` rows."""
    while size > len(getattr(obj, names[0])):
        for name in names:
            a = getattr(obj, name)
            setattr(obj, name, np.concatenate([a, np.empty_like(a)]))


def lifted(Y: np.ndarray) -> np.ndarray:
    """The rows [y, 1, |y|^2] of points y (see :class:`Tree`)."""
    L = np.empty((len(Y), Y.shape[1] + 2))
    L[:, :-2] = Y
    L[:, -2] = 1.0
    L[:, -1] = np.einsum("ij,ij->i", Y, Y)
    return L


class Tree:
    """One tree's bubbles in order of creation: their indices ``idx`` among all bubbles, radii ``r``, the rows
    ``pw = [-2c, |c|^2 - r^2, 1]``, ``d2 = [-2c, |c|^2, 1]`` and ``lift = [c, 1, |c|^2]``, so that for the lifted
    rows L = [y, 1, |y|^2] of points y (:func:`lifted`) one matrix product gives the power distances
    |y - c|^2 - r^2 (``L @ pw.T``) or the squared distances |y - c|^2 (``L @ d2.T``) to every bubble; and per
    bubble ``gap``, the smallest |c - c'| - r - r' over bubbles c' of the other tree, ``mate`` that bubble's
    index, and ``tries``, the times the bubble was extended toward the other tree."""

    idx: np.ndarray
    r: np.ndarray
    pw: np.ndarray
    d2: np.ndarray
    lift: np.ndarray
    gap: np.ndarray
    mate: np.ndarray
    tries: np.ndarray

    def __init__(self, dim: int, cap: int = 512) -> None:
        self.dim = dim
        for name, blank in self._blank(cap).items():
            setattr(self, name, blank)
        self.n = 0

    def _blank(self, cap: int) -> dict[str, np.ndarray]:
        """Rows for ``cap`` more bubbles, their constants already in place (a new bubble has no gap, mate or
        try yet; the last entry of a ``pw`` or ``d2`` row is 1), so that :meth:`add` writes only the rest."""
        pw, d2 = np.empty((cap, self.dim + 2)), np.empty((cap, self.dim + 2))
        pw[:, -1] = d2[:, -1] = 1.0
        return dict(idx=np.empty(cap, dtype=np.int64), r=np.empty(cap), pw=pw, d2=d2, lift=np.empty((cap, self.dim + 2)),
                    gap=np.full(cap, np.inf), mate=np.full(cap, -1, dtype=np.int64), tries=np.zeros(cap, dtype=np.int64))

    def reserve(self, size: int) -> None:
        """Double the rows until they hold ``size`` bubbles."""
        while size > len(self.idx):
            for name, blank in self._blank(len(self.idx)).items():
                setattr(self, name, np.concatenate([getattr(self, name), blank]))

    def add(self, idx: np.ndarray, lift: np.ndarray, r: np.ndarray) -> None:
        """Append bubbles given by their indices, lifted centres [c, 1, |c|^2] (:func:`lifted`) and radii."""
        m, n = len(idx), self.dim
        self.reserve(self.n + m)
        s = slice(self.n, self.n + m)
        self.idx[s], self.r[s], self.lift[s] = idx, r, lift
        d2 = self.d2[s]
        np.multiply(lift[:, :n], -2.0, out=d2[:, :n])
        d2[:, n] = lift[:, n + 1]
        self.pw[s] = d2
        self.pw[s, n] -= r**2
        self.n += m


TREES = np.array([0, 1], dtype=np.int8)  # the start and the goal tree's labels, for Bubbles.add


class Bubbles:
    """Growing arrays of bubbles: centre, radius, parent (-1 for a root), tree (0: start, 1: goal) and position
    among its tree's bubbles; the two trees (:class:`Tree`)."""

    def __init__(self, dim: int, cap: int = 1024) -> None:
        self.c = np.empty((cap, dim))
        self.r = np.empty(cap)
        self.parent = np.empty(cap, dtype=np.int64)
        self.tree = np.empty(cap, dtype=np.int8)
        self.pos = np.empty(cap, dtype=np.int64)
        self.trees = (Tree(dim), Tree(dim))
        self.n = 0
        self.closest = np.inf  # the smallest gap between the trees so far (update_gaps)
        self._ar = np.arange(cap)

    @property
    def _rows(self) -> np.ndarray:
        """0, 1, ..., at least as many as the bubbles (row numbers for :meth:`update_gaps`, made once per doubling)."""
        if len(self._ar) < len(self.r):
            self._ar = np.arange(len(self.r))
        return self._ar

    def add(self, c: np.ndarray, r: np.ndarray, parent: np.ndarray, tree: np.ndarray, lift: np.ndarray | None = None) -> list[np.ndarray]:
        """Append bubbles, ``tree`` in non-decreasing order (the start tree's first, then the goal tree's, then
        any of neither; ``lift``: their rows :func:`lifted` (c) if already computed); return the indices of
        the new ones of tree 0 and of tree 1."""
        m = len(r)
        grow(self, ("c", "r", "parent", "tree", "pos"), self.n + m)
        s = slice(self.n, self.n + m)
        self.c[s], self.r[s], self.parent[s], self.tree[s] = c, r, parent, tree
        ends = tree.searchsorted(TREES, side="right").tolist()
        if lift is None and ends[1]:
            lift = lifted(c)
        out = []
        rows = self._rows  # views of its rows, not new aranges (it is replaced, never written, when it grows)
        for t, (a, b) in enumerate(((0, ends[0]), (ends[0], ends[1]))):
            out.append(rows[self.n + a : self.n + b])
            if b > a:
                T = self.trees[t]
                self.pos[self.n + a : self.n + b] = rows[T.n : T.n + b - a]
                assert lift is not None  # (made above when a tree gets bubbles)
                T.add(out[t], lift[a:b], r[a:b])
        self.n += m
        return out

    def update_gaps(self, new: list[np.ndarray], find: bool = True) -> tuple[int, int] | None:
        """Refresh every bubble's gap to the other tree (``Tree.gap``, the nearest other bubble in ``Tree.mate``:
        |c_a - c_b| - r_a - r_b) with ``new``, each tree's bubbles just added (the last of their tree), and
        ``closest``, the smallest gap so far; if ``find``, return a connecting pair (a in tree 0, b in tree 1)
        overlapping with a hatch of HATCH x the smaller radius, if any (the first found, the start tree's new
        bubbles first)."""
        best = None
        for t in (0, 1):
            T, O = self.trees[t], self.trees[1 - t]
            k = len(new[t])
            if k == 0 or O.n == 0:
                continue
            sl = slice(T.n - k, T.n)
            D = T.lift[sl] @ O.d2[: O.n].T
            np.sqrt(np.maximum(D, 0.0, out=D), out=D)
            D -= T.r[sl, None]
            D -= O.r[None, : O.n]
            j = D.argmin(axis=1)
            g = D[self._rows[:k], j]
            self.closest = min(self.closest, float(g.min()))
            better = g < T.gap[sl]
            np.copyto(T.gap[sl], g, where=better)
            np.copyto(T.mate[sl], O.idx[j], where=better)
            g2 = D.min(axis=0)  # the other tree's bubbles may now be nearer to a new one
            better = np.flatnonzero(g2 < O.gap[: O.n])  # (indices: a boolean mask over D's columns copies slowly)
            O.gap[better] = g2[better]
            O.mate[better] = new[t][D[:, better].argmin(axis=0)]
            if find and best is None:
                over = (g < 0).nonzero()[0]
                if over.size:
                    hit = np.argwhere(D[over] <= -HATCH * np.minimum(T.r[sl][over, None], O.r[None, : O.n]))
                    if hit.size:
                        a, b = int(new[t][over[hit[0, 0]]]), int(O.idx[hit[0, 1]])
                        best = (a, b) if t == 0 else (b, a)
        return best

    def foam(self, q_init: np.ndarray, q_goal: np.ndarray) -> Foam:
        n = self.n
        return Foam(self.c[:n].copy(), self.r[:n].copy(), self.parent[:n].copy(), q_init, q_goal)


#: SHRINK: besides ``stall`` (no progress of r_min / 2 in a window), the first level of the search for a first path (FINER)
#: is stalled once it has run SHRINK_FROM iterations and its gap shrank by less than SHRINK of itself while its iterations
#: grew SPAN-fold: a window that grows with the search, so a slow search goes on as long as every three doublings of its
#: effort bring the trees 1 % closer. Beside a goal beyond a wall the trees creep r_min / 2 closer now and then, each creep
#: restarting ``stall``'s window, while the gap itself stays put (the obstacle scene with a 2 cm wall 2 m tall in place of
#: its box, seed 0: 0.416 at iteration 104, 0.4146 at 1,000 and at 4,000, when ``stall`` ended the level; now at 824).
#: Measured, before the trees met: no feasible search is stalled by SHRINK = 1 % with SPAN = 2 from 500 iterations on
#: (boxes 0.50 and 0.51 m tall, seeds 0-2, 783-3,010 iterations; 0.52 m, seed 0, 18,956; boxes moved 5 cm, 20-50 % larger
#: and 23 random boxes, 4-199), nor with SHRINK = 5 %. But a puck's channel under a wall's end (y in [0.44, 0.445],
#: narrower than r_min: it meets only after a refinement) kept its gap for 4x its iterations (250 -> 1,000, seed 3) in a
#: first level of 5,089-51,650 iterations that brought its trees to the channel's ends; SPAN = 2 cut that short on 5 of
#: its 6 seeds (at 500-2,042) and 4 of them then failed; SPAN = 4 cut seed 3 (764); SPAN = 8 none. The wall's gap too may take a last step of 1-2 %
#: after a few hundred iterations (seed 2: 0.42 -> 0.41 at 800), which SPAN = 8 then waits out. Finer levels keep
#: ``stall``'s rule alone: a refined search is what threads a narrow passage.
SHRINK = 0.01
SHRINK_FROM = 500
SPAN = 8


class GapHistory:
    """The smallest gap between the trees (:attr:`Bubbles.closest`) at the start of each iteration, for the SHRINK rule."""

    def __init__(self) -> None:
        self.gaps: list[float] = []

    def record(self, gap: float) -> None:
        self.gaps.append(gap)

    def stalled(self, floor: int) -> bool:
        """Whether the search has run ``floor`` iterations or more (k) and its gap at the last one is above (1 - SHRINK)
        x its gap at iteration k // SPAN (a gap <= 0 there: never stalled)."""
        k = len(self.gaps) - 1
        if k < floor:
            return False
        then = self.gaps[k // SPAN]
        return 0.0 < then and self.gaps[k] > (1.0 - SHRINK) * then
