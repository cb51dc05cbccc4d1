"""Genetic Algorithm over the hatches (Nascimento et al. 2020 section 2.2, Algorithm 1, section 4.2; parameters of 5.2).

Real encoding: an individual is the waypoint set sigma (Nascimento et al. 2020 Eq. 3), its alleles the waypoints
q'_i, each confined to its hatch. The initial population is drawn uniformly in the hatches. Each
generation (one iteration of Algorithm 1, fully vectorized over the population):

1. selection: 2 x pop_size parents by roulette, favouring low f (Nascimento et al. 2020 Eq. 5);
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
  and "linear" collapses the population (its mean within 1 % of its best) within 5-15 generations on
  the obstacle rosary, "inverse" within 43-329, and they end at a slightly worse f: after 4,000
  generations with beta = 0.3 (PFM seed 0's rosary, GA seeds 0-4) medians 4.77 (rank) and 4.95
  (linear) against 4.73 (inverse, 4.17-4.92). Heuristic crossover already pushes every child towards
  the better of its parents, so weak roulette pressure keeps the diversity it needs.
* One child per selected pair: Eq. 6 makes one offspring sigma_f from two parents, so a generation
  selects 2 x pop_size parents for pop_size children (the population size stays constant).
* mut_prob is per allele (per waypoint q'_i), the usual reading of a mutation rate in a real-coded GA:
  the paper says both "how often the chromosome will mutate" (section 2.2) and that "the alleles of an
  individual" are adjusted (section 4.2). With 0.001 per allele a generation of 50 paths of 29 waypoints
  mutates about 1.5 waypoints (some 4,000 in the ~3,000 generations of a run); per chromosome it would
  mutate one path every 20 generations (about 150 in a run).
* beta: Nascimento et al. 2020 gives both "beta uniform in [0, 1]" (section 4.2) and "beta = 0.3" (section 5.2,
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
    PROGRESS_INTERVAL,
    Hatches,
    MeanStall,
    ProgressFn,
    SeedLike,
    SmoothingResult,
    Smoother,
    StopCriteria,
    _check_int,
    _check_unit,
    _is_real,
    check_initial,
    check_rosary,
    coordinate_major_objective,
    seeded,
    trivial_result,
)

_EPS = 1e-12  # as foam_mj.smoothing.base

#: Roulette weightings (see the module docstring).
SELECTIONS = ("inverse", "rank", "linear")
#: Generations whose random numbers are drawn in one batch (fixed, so results do not depend on the cap).
CHUNK = 256


@dataclass(frozen=True)
class GeneticAlgorithm(Smoother):
    """GA with Nascimento et al. 2020 section 5.2's parameters (population 50, crossover 0.9, mutation 0.001, beta 0.3).

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
        pair = tuple(self.alpha_range) if isinstance(self.alpha_range, (tuple, list, np.ndarray)) else ()
        if len(pair) != 2 or not all(_is_real(x) for x in pair):
            raise ValueError(f"alpha_range must be a pair of numbers (a, b), got {self.alpha_range!r}")
        a, b = (float(x) for x in pair)
        if not (np.isfinite(a) and np.isfinite(b) and a <= b):
            raise ValueError(f"alpha_range must be finite with a <= b, got {self.alpha_range!r}")
        if self.selection not in SELECTIONS:
            raise ValueError(f"selection must be one of {SELECTIONS}, got {self.selection!r}")
        if not isinstance(self.elitism, bool):
            raise ValueError(f"elitism must be a bool, got {self.elitism!r}")
        if not isinstance(self.stop, StopCriteria):
            raise ValueError(f"stop must be a StopCriteria, got {self.stop!r}")

    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0, *,
               progress: ProgressFn | None = None) -> SmoothingResult:
        """Run the GA; ``progress`` (optional) hears the generations done and the best f about twice a second."""
        t_start = time.perf_counter()
        rng, used = seeded(seed)
        init = check_initial(rosary, initial)
        if rosary.n_hatches == 0:
            return trivial_result(self.name, rosary, t_start)
        check_rosary(rosary)
        h = Hatches.of(rosary)
        m, n, P = h.m, rosary.dim, int(self.pop_size)
        stop = self.stop

        # Coordinate-major population: pop[:, j] is individual j's whole path, (n, P, k+1). Two buffers:
        # each generation's children are written into the other one, then they swap.
        L = m + 2
        pop, child = np.empty((n, P, L)), np.empty((n, P, L))
        pop[:, :, 0] = rosary.q_init[:, None]
        pop[:, :, -1] = rosary.q_goal[:, None]
        wps = h.sample(rng, np.broadcast_to(np.arange(m), (P, m)))
        if init is not None:
            wps[0] = init
        pop[:, :, 1:-1] = wps.transpose(2, 0, 1)
        fit = coordinate_major_objective(pop)
        objective = _PopulationObjective(n, P, L)
        outside = _OutsideHatches(h, P, rosary.q_init, rosary.q_goal)
        x1 = np.empty((n, P, L))  # parent 1 of every child (contiguous); parent 2 is gathered into the child
        # hatch balls as Python floats, for the few mutated alleles of a generation
        ca, cb = h.ca.tolist(), h.cb.tolist()
        ra2, rb2 = (h.ra * h.ra).tolist(), (h.rb * h.rb).tolist()
        # Roulette on rank-scaled fitness (selection="rank"): the cumulative weights of ranks 1..P are fixed.
        cum_rank = np.cumsum(1.0 / np.sqrt(np.arange(1, P + 1)))
        cum_rank /= cum_rank[-1]

        hist_best: list[float] = []
        hist_mean: list[float] = []
        i_best = int(fit.argmin())  # the elite
        best = float(fit[i_best])
        stall = MeanStall(float(fit.sum()) / P, stop.stall_tol)
        t = 0
        reason = stop.reason(0, best, 0)
        cpos = CHUNK
        add_reduce, take, subtract, multiply, add, copyto = np.add.reduce, np.take, np.subtract, np.multiply, np.add, np.copyto
        inverse, rank = self.selection == "inverse", self.selection == "rank"
        cw, u = np.empty(P), np.empty(2 * P)  # roulette weights (cumulated in place), scaled draws
        next_report = t_start + PROGRESS_INTERVAL
        while reason is None:
            if cpos >= CHUNK:
                sel_u, no_cross, beta, mut_gen, mut_pos, mut_alpha = self._draw(rng, P, m)
                nc_any = no_cross.any(axis=1).tolist()
                # u * total < total for every u of the chunk (u < 1 - 2^-40): no index past the wheel's end
                clip = float(sel_u.max()) >= 1.0 - 2.0**-40
                muts: list[list] = [[] for _ in range(CHUNK)]
                for g, flat, alpha in zip(mut_gen.tolist(), mut_pos.tolist(), mut_alpha.tolist()):
                    ind, wp = divmod(flat, m)
                    muts[g].append((ind, wp + 1, alpha, ca[wp], ra2[wp], cb[wp], rb2[wp]))
                cpos = 0
            # 1. roulette selection
            if rank:  # cum_rank ends at 1.0 > u: no index past the end
                pairs = np.argsort(fit, kind="stable")[np.searchsorted(cum_rank, sel_u[cpos], side="right")]
            else:
                if inverse:  # 1 / max(f, 1e-300)
                    np.divide(1.0, np.maximum(fit, 1e-300, out=cw), out=cw)
                else:
                    np.add(fit.max() - fit, 1e-12, out=cw)
                np.add.accumulate(cw, out=cw)  # np.cumsum
                pairs = cw.searchsorted(np.multiply(sel_u[cpos], cw[-1], out=u), "right")
                if clip:
                    np.minimum(pairs, P - 1, out=pairs)
            pairs = pairs.reshape(2, P)  # [first selected parents a; second selected parents b]
            # A child without crossover is a copy of its first parent a: taken as the crossover of a with
            # itself (a + beta (a - a) = a, bit for bit but for the sign of a zero coordinate, which f does
            # not see), so that one code path makes every child.
            if nc_any[cpos]:
                copyto(pairs[1], pairs[0], where=no_cross[cpos])
            fp = fit[pairs]
            # parent 1 (the better; a on a tie) and parent 2 of every child ("clip": the indices are valid, and
            # numpy's default mode buffers the output)
            p1, p2 = np.where(fp[0] <= fp[1], pairs, pairs[::-1])
            take(pop, p1, axis=1, out=x1, mode="clip")
            take(pop, p2, axis=1, out=child, mode="clip")
            # 2. heuristic crossover (Eq. 6): child = x1 + beta (x1 - x2), computed in place over x2 (fewer
            # buffers: the generation's arrays stay in cache); a waypoint leaving its hatch reverts to parent 1's
            subtract(x1, child, child)
            multiply(beta[cpos], child, child)
            add(x1, child, child)
            bad = outside(child)
            if bad.size:
                child.reshape(n, -1)[:, bad] = x1.reshape(n, -1)[:, bad]
            # 3. mutation q' <- alpha q', reverted when it leaves the hatch (about one allele a generation:
            # plain float arithmetic, the same operations as on arrays)
            for ind, col, alpha, c_a, r_a2, c_b, r_b2 in muts[cpos]:
                allele = child[:, ind, col]
                q = [v * alpha for v in allele.tolist()]
                if _sq_dist(q, c_a) <= r_a2 and _sq_dist(q, c_b) <= r_b2:
                    allele[:] = q
            f = objective(child)
            # 4. elitism: the previous best replaces the worst child
            if self.elitism:
                i_worst = int(f.argmax())
                child[:, i_worst] = pop[:, i_best]
                f[i_worst] = fit[i_best]
            pop, child, fit = child, pop, f
            i_best = int(fit.argmin())
            best = float(fit[i_best])
            mean = float(add_reduce(fit)) / P
            stall.update(mean)
            hist_best.append(best)
            hist_mean.append(mean)
            t += 1
            cpos += 1
            reason = stop.reason(t, best, stall.count)
            if progress is not None and time.perf_counter() >= next_report:
                progress(t, best)
                next_report = time.perf_counter() + PROGRESS_INTERVAL

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
                  "infeasible_crossover": "revert waypoint to parent 1", "infeasible_mutation": "revert", "seed": used},
        )

    def _draw(self, rng: np.random.Generator, P: int, m: int):
        """Random numbers for CHUNK generations: selection uniforms (CHUNK, 2P), "no crossover" flags (bool)
        and betas (CHUNK, P), and the mutated alleles as sorted flat positions with their generation and
        alpha."""
        sel_u = rng.random((CHUNK, 2 * P))
        no_cross = rng.random((CHUNK, P)) >= self.cross_prob
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


# -- the per-generation fast path ---------------------------------------------------------------------
# A generation works on 50 paths of ~30 points: numpy's per-call overhead and strided loops dominate.
# The two classes below compute what ``coordinate_major_objective`` and ``Hatches.outside_cm`` compute,
# with the same floating-point operations in the same order (dot products over the coordinates add
# x0 y0 + x1 y1 + ... in sequence, as numpy's einsum does over a leading axis), but on the whole
# contiguous population buffer (n, P, L) at once, flat: a path's last point differs with the next
# path's first one, which gives junk entries that are computed (finite) and left out of the sums;
# the ends get a dummy hatch that holds them. Preallocated buffers, positional ``out`` arguments.


def _sq_dist(q: list[float], c: list[float]) -> float:
    """|q - c|^2 summed in coordinate order, as numpy sums a short axis."""
    d = q[0] - c[0]
    s = d * d
    for x, y in zip(q[1:], c[1:]):
        d = x - y
        s = s + d * d
    return s


try:  # numpy's einsum without its Python wrapper (the same function; about 1.5 us less a call)
    from numpy._core.multiarray import c_einsum as _einsum
except ImportError:  # pragma: no cover - another numpy layout
    _einsum = np.einsum


class _PopulationObjective:
    """f of Nascimento et al. 2020 Eq. 5 for a coordinate-major population X (n, b, L) -> (b,), any b <= P paths
    (contiguous X): equal, bit for bit, to ``coordinate_major_objective(X)`` (tests/test_smoothing_math.py).
    The buffers are sized for P paths; the views for b paths are made once (Harmony Search evaluates
    blocks of varying size with it).

    Fewer calls: |seg|^2 and the dots of consecutive segments in one einsum over strided views of the flat
    segment buffer (the reference's einsum, the same sums); the angles and the lengths live in one buffer,
    so that when a row's extra zero cannot change numpy's pairwise sum (L - 1 <= 128 and not a multiple
    of 8: the zero is added last) one reduction sums both."""

    def __init__(self, n: int, P: int, L: int) -> None:
        PL = P * L
        self.n, self.L, self.n_ang = n, L, L - 2
        self._seg = np.zeros(n * PL + 1)  # seg[k] = x[k + 1] - x[k] (flat), the last two elements unused
        self._q = np.empty(2 * PL)
        self._al = np.empty(2 * PL + 1)  # [angles (P L), lengths (P L), 1.0]
        self._den = np.empty(PL)
        # 0-d operands: no conversion of a Python float per call, and no constant arrays in the cache
        self._eps, self._one, self._minus_one = np.array(_EPS * _EPS), np.array(1.0), np.array(-1.0)
        self._fused = L - 1 <= 128 and (L - 1) % 8 != 0
        self._views: dict[int, tuple] = {}

    def _views_for(self, b: int) -> tuple:
        v = self._views.get(b)
        if v is None:
            n, L, bL = self.n, self.L, b * self.L
            al = self._al[: 2 * bL + 1]
            ang, lens = al[:bL], al[bL:]
            v = (
                # [seg_i; seg_i] and [seg_i; seg_i shifted by one] (n, 2, b L): einsum -> [|seg|^2, dot of
                # consecutive segments] (2, b L)
                (_strided(self._seg, (n, 2, bL), (bL, 0, 1)), _strided(self._seg, (n, 2, bL), (bL, 1, 1))),
                self._q[: 2 * bL].reshape(2, bL),
                lens, self._den[:bL], ang, self._eps, self._one, self._minus_one,
                # per path: the L - 2 angles and the L - 1 segment lengths (the rest is junk); fused: the
                # angles with a zero in column L - 2, then the lengths, (2 b, L - 1)
                ang.reshape(b, L)[:, : L - 2], lens[:bL].reshape(b, L)[:, : L - 1],
                ang.reshape(b, L)[:, L - 2], al[: 2 * bL].reshape(2 * b, L)[:, : L - 1],
            )
            self._views[b] = v
        return v

    def __call__(self, X: np.ndarray) -> np.ndarray:
        x = X.reshape(-1)
        b = X.shape[1]
        pairs, q, lens, den, ang, eps, one, minus_one, ang_rows, len_rows, pad, both = self._views_for(b)
        np.subtract(x[1:], x[:-1], self._seg[: x.size - 1])
        _einsum("ikj,ikj->kj", *pairs, out=q)
        lens[-1] = 1.0  # the last path's junk segment times 1
        np.sqrt(q[0], lens[:-1])
        np.multiply(lens[:-1], lens[1:], den)
        # repeated points (rare): the reference code (junk lengths may trip the contiguous test, not the rows')
        if np.minimum.reduce(lens) <= _EPS and np.minimum.reduce(len_rows, axis=None) <= _EPS:
            return coordinate_major_objective(X)
        np.maximum(den, eps, out=den)
        np.divide(q[1], den, ang)
        np.minimum(ang, one, out=ang)
        np.maximum(ang, minus_one, out=ang)
        np.arccos(ang, ang)
        if self._fused:
            pad[...] = 0.0
            sums = np.add.reduce(both, axis=-1)
            angle = sums[:b]
            angle /= self.n_ang
            return np.add(angle, sums[b:], angle)
        angle = np.add.reduce(ang_rows, axis=-1) / self.n_ang
        return angle + np.add.reduce(len_rows, axis=-1)


class _OutsideHatches:
    """Which waypoints of a coordinate-major population X (n, b, L), b <= P, lie outside their hatch: their
    flat indices path * L + point (ascending; never an end), the same test as ``Hatches.outside_cm(X[:, :,
    1:-1])``. Few waypoints leave their hatch (a handful of a generation's thousands), so the callers
    revert them by index rather than with a mask over the whole population."""

    def __init__(self, h: Hatches, P: int, q_init: np.ndarray, q_goal: np.ndarray) -> None:
        m, n = h.ca.shape
        L = m + 2

        def full(c, r):  # (n, P, L) centres and (P * L,) squared radii; the ends: the end itself, radius 1
            cf = np.empty((n, L))
            cf[:, 0], cf[:, 1:-1], cf[:, -1] = q_init, c.T, q_goal
            rf = np.ones(L)
            rf[1:-1] = r * r
            return np.broadcast_to(cf[:, None, :], (n, P, L)).reshape(n, P * L), np.broadcast_to(rf, (P, L)).reshape(-1)

        ca, ra2 = full(h.ca, h.ra)
        cb, rb2 = full(h.cb, h.rb)
        self._c = np.ascontiguousarray(np.stack([ca, cb]))  # (2, n, P L): ball a and ball b
        self._r2 = np.ascontiguousarray(np.stack([ra2, rb2]))
        self._d = np.empty((n, P * L))  # one ball at a time: a smaller working set
        self._q = np.empty((2, P * L))
        self._out = np.empty((2, P * L), dtype=bool)
        self._L = L
        self._views: dict[int, tuple] = {}

    def __call__(self, X: np.ndarray) -> np.ndarray:
        b = X.shape[1]
        v = self._views.get(b)
        if v is None:
            bL = b * self._L
            v = self._views[b] = (self._c[:, :, :bL], self._r2[:, :bL], self._d[:, :bL], self._q[:, :bL],
                                  self._out[:, :bL], (X.shape[0], bL))
        c, r2, d, q, out, xshape = v
        x = X.reshape(xshape)
        for ball in (0, 1):  # |x - c|^2, as Hatches.outside_cm's einsum
            np.subtract(x, c[ball], d)
            _einsum("ij,ij->j", d, d, out=q[ball])
        np.greater(q, r2, out)
        return np.logical_or(out[0], out[1], out[0]).nonzero()[0]


def _strided(buf: np.ndarray, shape: tuple[int, ...], strides: tuple[int, ...]) -> np.ndarray:
    """A strided view of the flat buffer ``buf`` (strides in elements)."""
    item = buf.itemsize
    return np.lib.stride_tricks.as_strided(buf, shape=shape, strides=tuple(x * item for x in strides), writeable=True)
