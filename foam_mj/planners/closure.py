"""Closure of a foam at r_min: proofs that no bubble of radius >= r_min fits on a bubble's surface outside the other
bubbles (a cover of the sphere by patches, each closed by the joint box, another bubble, or a Lipschitz bound of the
certified radius), and the words a failed foam planner uses for them (foam_mj.planners.variants, foam_mj.foam).

A foam closed at r_min can grow no further under PFM's rules (a child's centre on its parent's surface, in the box,
strictly inside no other bubble, its radius >= r_min), whatever candidates are drawn: a planner may stop at once.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from foam_mj.bubbles import BubbleOracle
from foam_mj.foam import Foam

#: :func:`surface_holds_no_child` gives up (nothing proven) beyond this many distance queries.
COVER_QUERIES = 2_048


def surface_holds_no_child(oracle: BubbleOracle, c: np.ndarray, r: float, r_min: float, budget: int = COVER_QUERIES,
                           others: tuple[np.ndarray, np.ndarray] | None = None) -> bool:
    """:func:`surface_cover`'s proof alone."""
    return surface_cover(oracle, c, r, r_min, budget, others)[0]


def surface_cover(oracle: BubbleOracle, c: np.ndarray, r: float, r_min: float, budget: int = COVER_QUERIES,
                  others: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[bool, np.ndarray | None]:
    """Whether no point of the sphere |x - c| = r inside the joint box has a certified radius >= r_min, proven by a
    cover: the sphere is the radial image of the faces of the cube [-1, 1]^n, cut into patches (sub-cubes of a face,
    halved until proven); the image of a patch of half-diagonal h lies within rho = r h of the image p of its centre
    (the radial map is 1-Lipschitz off the unit ball), and the radius is 1-Lipschitz in the box (each pair's term, as
    the bubbles' own bound, and the distance to the bounds), so the patch holds no child when r(p) + rho < r_min, or,
    for p outside the box by e, when rho - e < r_min (a point of the box within rho of p is within rho - e of a face).
    (True, None) when proven; (False, that point) as soon as a point has radius >= r_min (a child fits); (False, None)
    beyond ``budget`` distance queries (not proven).
    gbpf's random samples of such a root searched the whole time budget: a start beside an obstacle 3.4 cm to the
    leg's side, whose clearance no in-plane motion changes (every bubble there 0.0433 < r_min = 0.07), took 20 s
    to fail where 126 queries prove it. With ``others`` (the centres and radii of the foam's other bubbles), a patch
    strictly inside one of them (|p - c_j| + rho < r_j) is closed too: a candidate there is dropped as covered."""
    n, lo, hi = len(c), oracle.robot.lower, oracle.robot.upper
    if others is not None:  # only the bubbles that reach the sphere can cover a patch of it
        oc, orr = others
        near = np.linalg.norm(oc - c, axis=1) < r + orr
        oc, orr = oc[near], orr[near]
    # The patches: face axis K, sign S and centre M (the other n - 1 coordinates), as arrays (one row per patch).
    K, S, M = np.repeat(np.arange(n), 2), np.tile([-1.0, 1.0], n), np.zeros((2 * n, n - 1))
    half = 1.0
    corners = np.array(np.meshgrid(*[[-1.0, 1.0]] * (n - 1), indexing="ij")).reshape(n - 1, -1).T if n > 1 else np.zeros((1, 0))
    while len(K):
        y = np.empty((len(K), n))
        rows = np.arange(len(K))
        y[rows[:, None], np.arange(n - 1)[None, :] + (np.arange(n - 1)[None, :] >= K[:, None])] = M  # M around column K
        y[rows, K] = S
        p = c + r * y / np.linalg.norm(y, axis=1, keepdims=True)
        rho = r * half * np.sqrt(n - 1)
        out = np.maximum(lo - p, p - hi).max(axis=1)  # > 0: outside the box by that much
        closed = np.where(out > 0, rho - out < r_min, False)
        if others is not None and len(orr):
            closed |= (np.linalg.norm(p[:, None, :] - oc[None], axis=2) + rho < orr).any(axis=1)
        inside = np.flatnonzero((out <= 0) & ~closed)
        if inside.size > budget:
            return False, None
        budget -= inside.size
        radii = oracle.radii(p[inside])
        big = np.flatnonzero(radii >= r_min)
        if big.size:  # a point of the box where a child fits, unless it lies in another bubble
            free = big if others is None else big[~_covered(p[inside[big]], oc, orr)]
            if free.size:
                return False, p[inside[free[0]]]
        closed[inside] = radii + rho < r_min
        if np.count_nonzero(~closed) * len(corners) > budget:  # the next level would cost more than is left
            return False, None
        half /= 2
        left = ~closed  # each open patch's 2^(n-1) quarters, in order
        K, S = np.repeat(K[left], len(corners)), np.repeat(S[left], len(corners))
        M = (M[left][:, None, :] + half * corners[None]).reshape(len(K), n - 1)  # len(K), not -1: n = 1 has 0 columns
    return True, None


def _covered(points: np.ndarray, centers: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """For each point: strictly inside one of the balls (the test of :meth:`foam_mj.coverage.CoverageIndex.covered`)?"""
    if len(radii) == 0:
        return np.zeros(len(points), dtype=bool)
    return (np.sum((points[:, None, :] - centers[None]) ** 2, axis=2) < radii**2).any(axis=1)


def foam_closure(oracle: BubbleOracle, centers: np.ndarray, radii: np.ndarray, r_min: float, start: int = 0,
                 queries: int | None = None, stop: Callable[[], bool] | None = None) -> tuple[int, tuple[int, np.ndarray] | None]:
    """Prove bubbles ``start``, ``start`` + 1, ... of a foam closed at ``r_min`` (:func:`surface_cover` with the other
    bubbles: no point of its surface in the box and outside the others has radius >= r_min), in order, until one is
    not. Returns (the number of bubbles proven closed counted from 0, the first open bubble and a point of its surface
    where a child fits, if one was found); stops early, proving nothing more, beyond ``queries`` distance queries or
    when ``stop()`` says so. The foam is closed when the count is len(radii)."""
    calls0 = oracle.clearance.calls
    done = start
    while done < len(radii):
        left = None if queries is None else queries - (oracle.clearance.calls - calls0)
        if (left is not None and left <= 0) or (stop is not None and stop()):
            return done, None
        others = np.arange(len(radii)) != done
        proven, witness = surface_cover(oracle, centers[done], float(radii[done]), r_min,
                                        COVER_QUERIES if left is None else min(COVER_QUERIES, left), (centers[others], radii[others]))
        if not proven:
            return done, None if witness is None else (done, witness)
        done += 1
    return done, None


def closure_text(count: int, r_min: float, queries: int) -> str:
    """That a foam of ``count`` bubbles is closed at ``r_min``, proven with ``queries`` distance queries."""
    return (f"the foam is closed at r_min = {r_min}: no bubble of radius >= r_min fits on the surface of any of its {count} "
            f"bubbles outside the others (proven by a cover of each surface, {queries:,} distance queries)")


def open_text(oracle: BubbleOracle, foam: Foam, r_min: float, K: int, found: tuple[int, np.ndarray]) -> str:
    """That a foam whose queue emptied is not closed: the candidates drawn missed room for a child at the point found."""
    i, x = found
    r = float(oracle.radii(x[None])[0])
    return (f"; but the foam is not closed: its random candidates missed room for a bubble of radius {r:.3g} >= r_min at "
            f"q = {np.round(x, 4).tolist()}, on the surface of the bubble at q = {np.round(foam.centers[i], 4).tolist()} "
            f"(each bubble is expanded once, with K floor(r / r_min)^(n-1) = {K} floor(r / {r_min})^{foam.centers.shape[1] - 1} "
            "random candidates): raise K, or plan with bubbletree")


#: A foam whose queue emptied is checked for closure (:func:`foam_closure`) with at most this many distance queries.
DIAGNOSIS_QUERIES = 10_000


def queue_empty_text(oracle: BubbleOracle, foam: Foam, r_min: float, K: int) -> str:
    """Whether a PFM-style foam whose queue emptied is closed at r_min (proven), or where its candidates missed room for a
    child; "" when neither is settled within DIAGNOSIS_QUERIES."""
    calls = oracle.clearance.calls
    done, found = foam_closure(oracle, foam.centers, foam.radii, r_min, queries=DIAGNOSIS_QUERIES)
    if done == len(foam.radii):
        return f"; proven: {closure_text(done, r_min, oracle.clearance.calls - calls)}"
    return "" if found is None else open_text(oracle, foam, r_min, K, found)
