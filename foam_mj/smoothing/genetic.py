"""Genetic Algorithm over the hatches (paper 000 section 2.2, Algorithm 1, section 4.2; parameters of 5.2).

Real encoding: an individual is the waypoint set sigma (paper 000 Eq. 3), its alleles the waypoints
q'_i, each confined to its hatch. The initial population is drawn uniformly in the hatches. Each
generation (one iteration of Algorithm 1, fully vectorized over the population):

1. selection: 2 x pop_size parents by roulette, favouring low f (paper 000 Eq. 5);
2. crossover, per pair with probability cross_prob: heuristic crossover (Eq. 6)
   sigma_f = sigma_p1 + beta (sigma_p1 - sigma_p2), sigma_p1 the better parent; without crossover the
   child is a copy of the first selected parent;
3. mutation, per allele with probability mut_prob: q'_i <- alpha q'_i with alpha ~ U[a, b], reverted
   when the mutated waypoint leaves its hatch (section 4.2);
4. elitism: the previous generation's best replaces the worst child (section 4.2).

Choices (the paper leaves them open):

* Roulette weights ``selection``: "inverse" (default), p_j proportional to 1/f_j, the plain reading of
  "a higher probability to ... the ones with low values of f". Also "rank" (weight 1/sqrt(rank),
  MATLAB's default ``fitscalingrank``) and "linear" (f_max - f_j). The stronger pressure of "rank"
  and "linear" collapses the population within ~50 generations on the obstacle rosary and ends at
  a worse f (about 4.6 against 4.3 after 4,000 generations with beta = 0.3); heuristic crossover already pushes every
  child towards the better of its parents, so weak roulette pressure keeps the diversity it needs.
* beta: paper 000 gives both "beta uniform in [0, 1]" (section 4.2) and "beta = 0.3" (section 5.2,
  the setting of the reported runs). Default ``beta = 0.3``; ``beta=None`` draws beta ~ U[0, 1] per
  crossover.
* A crossover child's waypoint that leaves its hatch is reverted to parent 1's (the better parent,
  which Eq. 6 extrapolates from), waypoint by waypoint.
* [a, b] for alpha is not given in the paper; default [0.95, 1.05] (a move of up to about 0.07 rad
  at the task's joint values, of the order of the hatches).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import (
    Hatches,
    MeanStall,
    SeedLike,
    SmoothingResult,
    Smoother,
    StopCriteria,
    _check_int,
    _check_unit,
    as_generator,
    check_initial,
    coordinate_major_objective,
    trivial_result,
)

#: Roulette weightings (see the module docstring).
SELECTIONS = ("inverse", "rank", "linear")
#: Generations whose random numbers are drawn in one batch (fixed, so results do not depend on the cap).
CHUNK = 256


@dataclass(frozen=True)
class GeneticAlgorithm(Smoother):
    """GA with paper 000 section 5.2's parameters (population 50, crossover 0.9, mutation 0.001, beta 0.3).

    ``initial`` (optional) replaces one random individual of the initial population; the paper's
    population is all random (``initial=None``). ``stop`` defaults to Table 1's criterion (200
    generations without a better population mean) capped at 2 x 10^4 generations.
    """

    pop_size: int = 50
    cross_prob: float = 0.9
    mut_prob: float = 0.001
    beta: float | None = 0.3
    alpha_range: tuple[float, float] = (0.95, 1.05)
    elitism: bool = True
    selection: str = "inverse"
    stop: StopCriteria = field(default_factory=StopCriteria)

    name: ClassVar[str] = "GA"

    def __post_init__(self) -> None:
        _check_int("pop_size", self.pop_size, 2)
        _check_unit("cross_prob", self.cross_prob)
        _check_unit("mut_prob", self.mut_prob)
        if self.beta is not None:
            _check_unit("beta", self.beta)
        try:
            a, b = (float(x) for x in self.alpha_range)
        except (TypeError, ValueError):
            raise ValueError(f"alpha_range must be a pair (a, b), got {self.alpha_range!r}") from None
        if not (np.isfinite(a) and np.isfinite(b) and a <= b):
            raise ValueError(f"alpha_range must be finite with a <= b, got {self.alpha_range!r}")
        if self.selection not in SELECTIONS:
            raise ValueError(f"selection must be one of {SELECTIONS}, got {self.selection!r}")
        if not isinstance(self.elitism, bool):
            raise ValueError(f"elitism must be a bool, got {self.elitism!r}")
        if not isinstance(self.stop, StopCriteria):
            raise ValueError(f"stop must be a StopCriteria, got {self.stop!r}")

    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> SmoothingResult:
        t_start = time.perf_counter()
        rng = as_generator(seed)
        init = check_initial(rosary, initial)
        if rosary.n_hatches == 0:
            return trivial_result(self.name, rosary, t_start)
        h = Hatches.of(rosary)
        m, n, P = h.m, rosary.dim, int(self.pop_size)
        stop = self.stop

        # Coordinate-major population: pop[:, j] is individual j's whole path, (n, P, k+1).
        pop = np.empty((n, P, m + 2))
        pop[:, :, 0] = rosary.q_init[:, None]
        pop[:, :, -1] = rosary.q_goal[:, None]
        wps = h.sample(rng, np.broadcast_to(np.arange(m), (P, m)))
        if init is not None:
            wps[0] = init
        pop[:, :, 1:-1] = wps.transpose(2, 0, 1)
        fit = coordinate_major_objective(pop)
        # Roulette on rank-scaled fitness (selection="rank"): the cumulative weights of ranks 1..P are fixed.
        cum_rank = np.cumsum(1.0 / np.sqrt(np.arange(1, P + 1)))
        cum_rank /= cum_rank[-1]

        hist_best: list[float] = []
        hist_mean: list[float] = []
        best = float(fit.min())
        stall = MeanStall(float(fit.sum()) / P, stop.stall_tol)
        t = 0
        reason = stop.reason(0, best, 0)
        cpos = CHUNK
        while reason is None:
            if cpos >= CHUNK:
                sel_u, no_cross, beta, mut_gen, mut_pos, mut_alpha = self._draw(rng, P, m)
                mut_bounds = np.searchsorted(mut_gen, np.arange(CHUNK + 1))
                cpos = 0
            # 1. roulette selection
            if self.selection == "rank":
                order = np.argsort(fit, kind="stable")
                parents = order[np.minimum(np.searchsorted(cum_rank, sel_u[cpos], side="right"), P - 1)]
            else:
                w = 1.0 / np.maximum(fit, 1e-300) if self.selection == "inverse" else fit.max() - fit + 1e-12
                cw = np.cumsum(w)
                parents = np.minimum(np.searchsorted(cw, sel_u[cpos] * cw[-1], side="right"), P - 1)
            a, b = parents[:P], parents[P:]
            a_better = fit[a] <= fit[b]
            p1 = np.where(a_better, a, b)
            p2 = np.where(a_better, b, a)
            # 2. heuristic crossover (Eq. 6); a waypoint leaving its hatch reverts to parent 1's
            x1 = pop[:, p1]
            child = x1 + beta[cpos] * (x1 - pop[:, p2])
            bi, bw = h.outside_cm(child[:, :, 1:-1]).nonzero()  # few (about 1%): revert them sparsely
            if bi.size:
                child[:, bi, bw + 1] = x1[:, bi, bw + 1]
            nc = no_cross[cpos]
            if nc.size:
                child[:, nc] = pop[:, a[nc]]
            # 3. mutation q' <- alpha q', reverted when it leaves the hatch
            lo, hi = mut_bounds[cpos], mut_bounds[cpos + 1]
            if hi > lo:
                ind, wp = np.divmod(mut_pos[lo:hi], m)
                mutated = child[:, ind, wp + 1] * mut_alpha[lo:hi]
                ok = ((np.sum((mutated.T - h.ca[wp]) ** 2, axis=1) <= h.ra[wp] ** 2)
                      & (np.sum((mutated.T - h.cb[wp]) ** 2, axis=1) <= h.rb[wp] ** 2))
                child[:, ind[ok], wp[ok] + 1] = mutated[:, ok]
            f = coordinate_major_objective(child)
            # 4. elitism: the previous best replaces the worst child
            if self.elitism:
                i_old = int(fit.argmin())
                i_worst = int(f.argmax())
                child[:, i_worst] = pop[:, i_old]
                f[i_worst] = fit[i_old]
            pop, fit = child, f
            best = float(fit.min())
            mean = float(fit.sum()) / P
            stall.update(mean)
            hist_best.append(best)
            hist_mean.append(mean)
            t += 1
            cpos += 1
            reason = stop.reason(t, best, stall.count)

        i_best = int(fit.argmin())
        return SmoothingResult.build(
            self.name,
            rosary,
            pop[:, i_best, 1:-1].T,
            history_best=np.array(hist_best),
            history_mean=np.array(hist_mean),
            iterations=t,
            evaluations=P * (t + 1),
            wall_time=time.perf_counter() - t_start,
            stop_reason=reason,
            info={"pop_size": P, "cross_prob": self.cross_prob, "mut_prob": self.mut_prob,
                  "beta": "uniform[0,1]" if self.beta is None else self.beta,
                  "alpha_range": list(self.alpha_range), "selection": f"roulette ({self.selection})",
                  "infeasible_crossover": "revert waypoint to parent 1", "infeasible_mutation": "revert"},
        )

    def _draw(self, rng: np.random.Generator, P: int, m: int):
        """Random numbers for CHUNK generations: selection uniforms (CHUNK, 2P), crossover flags and betas
        (CHUNK, P), and the mutated alleles as sorted flat positions with their generation and alpha."""
        sel_u = rng.random((CHUNK, 2 * P))
        no_cross = [np.flatnonzero(row) for row in rng.random((CHUNK, P)) >= self.cross_prob]
        if self.beta is None:
            beta = rng.random((CHUNK, P))[:, :, None]  # broadcasts over (n, P, k+1) as (P, 1)
        else:
            beta = np.full((CHUNK, 1, 1), float(self.beta))
        per_gen = P * m
        count = int(rng.binomial(CHUNK * per_gen, self.mut_prob))
        flat = np.sort(rng.choice(CHUNK * per_gen, size=count, replace=False))
        gen, pos = np.divmod(flat, per_gen)
        alpha = rng.uniform(*self.alpha_range, size=count)
        return sel_u, no_cross, beta, gen, pos, alpha
