"""More than one route for bubbletree's corridor (its option ``routes``).

The corridor (:func:`foam_mj.planners.corridor.build_corridor`) refines the shortest chain of overlapping bubbles
(Dijkstra's algorithm on the overlap graph), and its shortcuts cannot leave that chain's homotopy class when the free space
between two routes is a ridge thinner than the refinement's floor: on step_down the seeds split between a route
of qpos length 1.61-1.64 and one of 1.70-1.91, joined only over a ridge 0-0.7 mm above delta, so the first
chain decides the route. With ``routes = k`` the corridor is also built from k - 1 further chains, each through
the same certified bubbles minus the middle half of every earlier first chain's (so that it must pass elsewhere);
each further corridor is first refined for one round only, and its rounds go on (up to all its rounds, the
same rounds as a corridor built with all of them from the start) only when that already beats the best so far; the shortest final corridor is kept (a losing further corridor's length in the
stats is the one after its single round). Every corridor is built by the same code
from the same certified bubbles and refinement, so the path kept is certified like the default one.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from foam_mj.planners.corridor import Corridor, CorridorBuild, CorridorOptions, build_corridor, shortest_chain


def build_routes(
    routes: int, problem, centers: np.ndarray, radii: np.ndarray, link, options: CorridorOptions, rng: np.random.Generator,
) -> Corridor:
    """The shortest of the corridors built from ``routes`` chains (1: :func:`build_corridor`'s alone); with more,
    the result's ``stats["routes"]`` says which won (1: the first chain's) and every corridor's length."""
    if routes <= 1:
        return build_corridor(problem, centers, radii, link, options, rng)
    ids = shortest_chain(centers, radii, problem.q_init, problem.q_goal, options.metric)  # each chain found once
    best = build_corridor(problem, centers, radii, link, options, rng, chain=ids)
    cpu0 = time.process_time()
    n = len(radii)
    banned = np.zeros(n, dtype=bool)
    lengths, won = [float(best.length)], 1
    for k in range(2, routes + 1):
        if ids is not None:
            banned[ids[len(ids) // 4 : len(ids) - len(ids) // 4]] = True  # the chain's middle half
        keep = np.flatnonzero(~banned)
        sub_c, sub_r = centers[keep], radii[keep]
        sub = shortest_chain(sub_c, sub_r, problem.q_init, problem.q_goal, options.metric)
        if sub is None:  # no chain avoids the earlier routes' middles
            break
        ids = keep[sub]
        state = rng.bit_generator.state
        build = CorridorBuild(problem, sub_c, sub_r, options, rng, chain=sub)
        build.refine(1)
        alt = build.corridor()
        if alt.length < best.length:  # the probe's rounds go on (the rounds of a build from scratch, see CorridorBuild)
            if options.refine_rounds >= 1:
                build.refine(options.refine_rounds - 1)
                alt = build.corridor()
            else:  # no rounds at all: built again without the probe's
                rng.bit_generator.state = state
                alt = build_corridor(problem, sub_c, sub_r, link, options, rng, chain=sub)
        lengths.append(float(alt.length))
        if alt.length < best.length:
            best, won = _renumbered(alt, keep, n), k
    best.stats["routes"] = {"won": won, "lengths": lengths}
    best.stats["cpu_ms"] = {**best.stats["cpu_ms"], "routes": round(1e3 * (time.process_time() - cpu0), 2)}
    return best


def _renumbered(c: Corridor, keep: np.ndarray, n: int) -> Corridor:
    """A corridor built on the bubbles ``keep`` of n, with its chain's ids in the numbering of all n (its added
    bubbles numbered from n on, as the planner appends them)."""
    m = len(keep)
    ids = np.where(c.ids < m, keep[np.minimum(c.ids, m - 1)], c.ids + (n - m))
    return dataclasses.replace(c, ids=ids)


__all__ = ["build_routes"]
