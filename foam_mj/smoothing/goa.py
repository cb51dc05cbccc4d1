"""The Grasshopper Optimisation Algorithm (Saremi et al. 2017) and its multi-objective version MGOA
(Elmi and Efe 2018, Eq. 1-7 and 14-17), vectorised over the swarm.

Each iteration moves every grasshopper i of the swarm at once (Elmi and Efe 2018 Eq. 6):

    x_i^d <- c ( sum_(j != i) c (ub_d - lb_d) / 2  s(r_ij^d)  (x_j^d - x_i^d) / d_ij ) + T_d

with s(r) = f e^(-r / l) - e^(-r) (Eq. 3; attraction for r > 2.079 with f = 0.5, l = 1.5, repulsion
below), T the target (best solution so far; for MGOA a member of the Pareto archive) and c decreasing
linearly from c_max to c_min over the iterations (Eq. 7: c = c_max - l (c_max - c_min) / L at
iteration l = 1..L, so the last iteration uses c_min). Gravity and wind (Eq. 4-5) are not part of
Eq. 6: the target term replaces the wind and there is no gravity, as in Saremi's algorithm.

Choices (the papers leave them open), all parameters:

* Distances. Positions are scaled to the unit box u = (x - lb) / (ub - lb); d_ij = |u_j - u_i| and
  the argument of s is the per-dimension distance |u_j^d - u_i^d| mapped linearly onto
  ``distance_range`` = [1, 4] (Saremi et al.: "the distance between grasshoppers is normalised in
  [1, 4]", where s goes from repulsion through the comfort zone at 2.079 to weak attraction). In raw
  coordinates a 1000-pixel map would put every pair at s ~ 0, and hatches of 0.1 rad every pair in
  the repulsion zone. Pairs at the same point contribute nothing.
* ``social``: "sum" is Eq. 6 as written (the social term grows with the swarm size N); "mean"
  divides it by N - 1 so that the step does not depend on N. See ``benchmarks/mgoa.py`` for both.
* ``random_social``: Elmi and Efe 2018 notes that "to introduce random behavior, it is possible to multiply
  both terms in (6) with random variables"; with True the social term is multiplied by U[0, 1] per
  particle and coordinate (the target term is left alone: scaling a position by a random factor
  would pull it towards the origin of the coordinates). Off by default (Eq. 6 as written: GOA is
  then deterministic given the initial swarm and the targets).
* After the update a position is clipped to [lb, ub] (Saremi's code) and then passed through the
  problem's ``repair`` (projection onto the hatches on a rosary).
* The pairwise term is an N x N x D computation, done in blocks of rows of at most ``block_elements``
  elements (default 2^16, 512 kB per temporary: cache-sized), so memory stays bounded for any N and D;
  the antisymmetry of the pair terms halves the work. The block size is part of the result (it orders
  the sums). ``threads`` > 1 computes the blocks in that many threads and adds their sums in block order:
  the same result bit for bit; default 1. Measured on an idle 2-core machine (500 x 100 on Elmi and Efe
  2018's map #1): 1 thread 0.81-0.94 s, 2 threads 1.20-1.24 s wall (1.6 s CPU): the blocks are too small
  for the threads' hand-over to pay, so the option stays off by default.

MGOA keeps the non-dominated positions in a bounded :class:`~foam_mj.smoothing.pareto.Archive`
(crowding-distance pruning) and draws the target T of each iteration from it by roulette favouring
the least crowded members (MOGOA, Mirjalili et al. 2018); see :mod:`foam_mj.smoothing.pareto`.
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Callable, ClassVar

import numpy as np

from foam_mj.smoothing.base import SeedLike, _check_int, _check_positive, seeded
from foam_mj.smoothing.multiobjective import ParetoRun, ParetoSmoother, Problem, RunRecorder, check_schedule_params, finish_run
from foam_mj.smoothing.pareto import Archive

#: Saremi et al.'s social force parameters: attraction intensity f and attractive length scale l.
PAPER_F = 0.5
PAPER_L = 1.5
#: Elmi and Efe 2018 Table I.
PAPER_SWARM = 500
PAPER_ITERATIONS = 100
PAPER_C_MAX = 1.0
PAPER_C_MIN = 1e-5
SOCIAL_MODES = ("sum", "mean")
_EPS = 1e-12


def s_function(r: np.ndarray, f: float = PAPER_F, l: float = PAPER_L) -> np.ndarray:
    """Social force strength, Elmi and Efe 2018 Eq. 3: s(r) = f e^(-r/l) - e^(-r)."""
    r = np.asarray(r, dtype=float)
    return f * np.exp(-r / l) - np.exp(-r)


def c_schedule(c_max: float, c_min: float, iterations: int) -> np.ndarray:
    """Eq. 7's reduction coefficient for iterations l = 1..L: c_l = c_max - l (c_max - c_min) / L."""
    check_schedule_params(c_max, c_min)
    _check_int("iterations", iterations, 1)
    l = np.arange(1, iterations + 1)
    return c_max - l * (c_max - c_min) / iterations


def _s_in_place(r: np.ndarray, f: float, l: float, inv_l: float, out: np.ndarray | None = None) -> np.ndarray:
    """s(r) of Eq. 3 (into ``out`` if given), overwriting r. e^(-r) = (e^(-r/l))^l: for the usual l = 1.5 it
    is E sqrt(E), which saves the second (and slowest) exponential."""
    E = np.multiply(r, -inv_l, out=out)
    np.exp(E, out=E)
    if l == 1.5:
        np.sqrt(E, out=r)
        r *= E
    elif l == 1.0:
        r[...] = E
    elif l == 2.0:
        np.multiply(E, E, out=r)
    else:
        np.negative(r, out=r)
        np.exp(r, out=r)
    E *= f
    E -= r
    return E


def social_interaction(
    X: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    f: float = PAPER_F,
    l: float = PAPER_L,
    distance_range: tuple[float, float] = (1.0, 4.0),
    mean: bool = False,
    block_elements: int = 1 << 16,
    threads: int = 1,
) -> np.ndarray:
    """The sum in Eq. 6 without its factor c: for every i, sum_(j != i) (ub - lb)/2 s(r_ij^d) (u_j^d - u_i^d) / d_ij
    with u the positions scaled to the unit box and r_ij^d = a + (b - a) |u_j^d - u_i^d|,
    (a, b) = ``distance_range`` (see the module docstring). X (N, D) -> (N, D); ``mean`` divides by N - 1.
    Computed in blocks of rows of at most ``block_elements`` pairwise elements; with ``threads`` > 1 the blocks
    are computed by that many threads (numpy releases the GIL in its loops) and their sums added in block
    order, so the result is the same bit for bit."""
    X = np.asarray(X, dtype=float)
    N, D = X.shape
    span = np.asarray(ub, dtype=float) - np.asarray(lb, dtype=float)
    safe = np.where(span > 0, span, 1.0)
    # Coordinate-major (D, N): every reduction below runs over contiguous memory. The term of pair (i, j) is
    # minus that of (j, i) (s depends on |u_j - u_i| only), so only the pairs j >= i are computed: block
    # [i0, i1) of rows against columns [i0, N); the row sums go to S_i, and for the columns beyond the
    # block (whose own rows come later) the column sums are subtracted from S_j.
    UT = np.ascontiguousarray(((X - lb) / safe).T)
    a, b = float(distance_range[0]), float(distance_range[1])
    S = np.zeros((D, N))
    rows = max(1, int(block_elements) // max(N * D, 1))
    inv_l = 1.0 / float(l)
    blocks = [(i0, min(N, i0 + rows)) for i0 in range(0, N, rows)]
    # work buffers for the largest block, reused (each block's arrays are contiguous (D, B, N - i0) views)
    size = D * min(rows, N) * N
    local = threading.local()

    def block_sums(i0: int, i1: int) -> tuple[np.ndarray, np.ndarray | None]:
        bufs = getattr(local, "bufs", None)
        if bufs is None:
            bufs = local.bufs = (np.empty(size), np.empty(size), np.empty(size), np.empty(min(rows, N) * N))
        buf_u, buf_r, buf_e, buf_d = bufs
        shape = (D, i1 - i0, N - i0)
        count = shape[0] * shape[1] * shape[2]
        dU = np.subtract(UT[:, None, i0:], UT[:, i0:i1, None], out=buf_u[:count].reshape(shape))  # u_j - u_i
        d = np.einsum("dbn,dbn->bn", dU, dU, out=buf_d[: count // D].reshape(shape[1:]))
        np.sqrt(d, out=d)
        np.maximum(d, _EPS, out=d)
        r = np.abs(dU, out=buf_r[:count].reshape(shape))
        r *= b - a
        r += a
        s = _s_in_place(r, f, l, inv_l, buf_e[:count].reshape(shape))
        s *= dU
        s /= d
        return s.sum(axis=-1), (s[:, :, i1 - i0:].sum(axis=1) if i1 < N else None)

    def add(i0: int, i1: int, sums: tuple[np.ndarray, np.ndarray | None]) -> None:
        S[:, i0:i1] += sums[0]
        if sums[1] is not None:
            S[:, i1:] -= sums[1]

    if threads > 1 and len(blocks) > 1:
        with ThreadPoolExecutor(min(int(threads), len(blocks))) as pool:
            for (i0, i1), sums in zip(blocks, pool.map(lambda blk: block_sums(*blk), blocks)):
                add(i0, i1, sums)
    else:
        for i0, i1 in blocks:
            add(i0, i1, block_sums(i0, i1))
    S = S.T
    S *= span / 2.0
    if mean and N > 1:
        S /= N - 1
    return S


@dataclass(frozen=True)
class GOAParams:
    """GOA's parameters (shared by :class:`GOA`, :class:`MGOA` and :class:`MGOASmoother`)."""

    swarm_size: int = PAPER_SWARM
    iterations: int = PAPER_ITERATIONS
    c_max: float = PAPER_C_MAX
    c_min: float = PAPER_C_MIN
    f: float = PAPER_F
    l: float = PAPER_L
    distance_range: tuple[float, float] = (1.0, 4.0)
    social: str = "sum"
    random_social: bool = False
    block_elements: int = 1 << 16
    threads: int = 1

    def _check_goa(self) -> None:
        _check_int("swarm_size", self.swarm_size, 2)
        _check_int("iterations", self.iterations, 1)
        check_schedule_params(self.c_max, self.c_min)
        _check_positive("f", self.f, allow_zero=True)
        _check_positive("l", self.l)
        try:
            a, b = (float(x) for x in self.distance_range)
        except (TypeError, ValueError):
            raise ValueError(f"distance_range must be a pair (a, b), got {self.distance_range!r}") from None
        if not (np.isfinite(a) and np.isfinite(b) and 0.0 <= a < b):
            raise ValueError(f"distance_range must satisfy 0 <= a < b (finite), got {self.distance_range!r}")
        if self.social not in SOCIAL_MODES:
            raise ValueError(f"social must be one of {SOCIAL_MODES}, got {self.social!r}")
        if not isinstance(self.random_social, bool):
            raise ValueError(f"random_social must be a bool, got {self.random_social!r}")
        _check_int("block_elements", self.block_elements, 1)
        _check_int("threads", self.threads, 1)

    def schedule(self) -> np.ndarray:
        return c_schedule(self.c_max, self.c_min, self.iterations)

    def move(self, X: np.ndarray, target: np.ndarray, c: float, lb: np.ndarray, ub: np.ndarray,
             rng: np.random.Generator | None = None) -> np.ndarray:
        """Eq. 6 for the whole swarm, then clipped to [lb, ub] (``random_social``: the social term scaled
        by U[0, 1] per particle and coordinate, drawn from ``rng``)."""
        S = social_interaction(X, lb, ub, self.f, self.l, self.distance_range, self.social == "mean",
                               self.block_elements, self.threads)
        Xn = S
        Xn *= c * c
        if self.random_social:
            if rng is None:
                raise ValueError("random_social needs a random generator")
            Xn *= rng.random(Xn.shape)
        Xn += target
        return np.clip(Xn, lb, ub, out=Xn)

    def _goa_info(self) -> dict[str, Any]:
        return {"swarm_size": self.swarm_size, "iterations": self.iterations, "c_max": self.c_max,
                "c_min": self.c_min, "f": self.f, "l": self.l, "distance_range": list(self.distance_range),
                "social": self.social, "random_social": self.random_social}


@dataclass(frozen=True)
class OptimizeResult:
    """A single-objective run: best position and value, per-iteration best and swarm mean (index 0 = the
    initial swarm), evaluations, wall time, and the integer seed of the run (drawn when ``seed=None``, so that
    ``seed=result.seed`` repeats it; None for a given Generator)."""

    x: np.ndarray
    fun: float
    history_best: np.ndarray
    history_mean: np.ndarray
    iterations: int
    evaluations: int
    wall_time: float
    seed: int | None = None


def _check_box(lb, ub, x0=None) -> tuple[np.ndarray, np.ndarray]:
    lb = np.asarray(lb, dtype=float).ravel()
    ub = np.asarray(ub, dtype=float).ravel()
    if lb.shape != ub.shape or lb.size == 0:
        raise ValueError(f"lb and ub must be non-empty vectors of one shape, got {lb.shape} and {ub.shape}")
    if not (np.all(np.isfinite(lb)) and np.all(np.isfinite(ub)) and np.all(lb <= ub)):
        raise ValueError("lb and ub must be finite with lb <= ub")
    if x0 is not None:
        x0 = np.asarray(x0, dtype=float)
        if x0.shape != lb.shape:
            raise ValueError(f"x0 must have shape {lb.shape}, got {x0.shape}")
    return lb, ub


@dataclass(frozen=True)
class GOA(GOAParams):
    """Single-objective GOA over a box: ``minimize(fn, lb, ub, seed)``, fn mapping a swarm (N, D) to
    values (N,). The target T is the best position found so far (elitist)."""

    name: ClassVar[str] = "GOA"

    def __post_init__(self) -> None:
        self._check_goa()

    def minimize(
        self,
        fn: Callable[[np.ndarray], np.ndarray],
        lb: np.ndarray,
        ub: np.ndarray,
        seed: SeedLike = 0,
        *,
        x0: np.ndarray | None = None,
        repair: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> OptimizeResult:
        """Minimise ``fn`` over [lb, ub] (``repair`` maps clipped positions into a feasible set; ``x0``
        replaces one particle of the uniform initial swarm)."""
        t_start = time.perf_counter()
        lb, ub = _check_box(lb, ub, x0)
        rng, used = seeded(seed)
        N = int(self.swarm_size)
        X = lb + (ub - lb) * rng.random((N, lb.size))
        if x0 is not None:
            X[0] = x0
        if repair is not None:
            X = repair(X)
        val = np.asarray(fn(X), dtype=float)
        i = int(np.argmin(val))
        best_x, best = X[i].copy(), float(val[i])
        hb, hm = [best], [float(val.mean())]
        for c in self.schedule():
            X = self.move(X, best_x, float(c), lb, ub, rng)
            if repair is not None:
                X = repair(X)
            val = np.asarray(fn(X), dtype=float)
            i = int(np.argmin(val))
            if val[i] < best:
                best_x, best = X[i].copy(), float(val[i])
            hb.append(best)
            hm.append(float(val.mean()))
        return OptimizeResult(best_x, best, np.array(hb), np.array(hm), int(self.iterations),
                              N * (int(self.iterations) + 1), time.perf_counter() - t_start, used)


@dataclass(frozen=True)
class MGOA(GOAParams):
    """Multi-objective GOA (Elmi and Efe 2018): GOA whose target T is drawn each iteration from the bounded Pareto
    archive (``archive_size`` members, crowding pruning, roulette on 1 / niche count with
    ``niche_radius``). ``run(problem, seed, initial)`` -> :class:`ParetoRun`."""

    archive_size: int = 100
    niche_radius: float = 0.1

    name: ClassVar[str] = "MGOA"

    def __post_init__(self) -> None:
        self._check_goa()
        Archive(self.archive_size, self.niche_radius)  # validates both

    def run(self, problem: Problem, seed: SeedLike = 0, initial: np.ndarray | None = None) -> ParetoRun:
        t_start = time.perf_counter()
        rng, used = seeded(seed)
        lb, ub = _check_box(problem.lb, problem.ub, initial)
        N = int(self.swarm_size)
        X = problem.sample(rng, N)
        if initial is not None:
            X[0] = initial
        F, V = problem.evaluate(X)
        archive = Archive(self.archive_size, self.niche_radius)
        archive.update(X, F, V)
        rec = RunRecorder(F, V, tuple(getattr(problem, "names", [f"f{j}" for j in range(F.shape[1])])))
        rec.record(archive, F, V)
        for c in self.schedule():
            target = archive.X[archive.select(rng, 1)[0]]
            X = problem.repair(self.move(X, target, float(c), lb, ub, rng))
            F, V = problem.evaluate(X)
            archive.update(X, F, V)
            rec.record(archive, F, V)
        info = self._goa_info() | {"archive_size": self.archive_size, "niche_radius": self.niche_radius,
                                   "target": "roulette on 1/niche count", "pruning": "crowding distance", "seed": used}
        return finish_run(self.name, archive, rec, int(self.iterations), N * (int(self.iterations) + 1),
                          t_start, info)


@dataclass(frozen=True)
class MGOASmoother(MGOA, ParetoSmoother):
    """MGOA over a rosary's hatches, objectives (length, angle term of Nascimento et al. 2020 Eq. 5).

    ``front(rosary, initial, seed)`` -> :class:`~foam_mj.smoothing.multiobjective.ParetoResult`;
    ``smooth(rosary, initial, seed)`` -> the :class:`SmoothingResult` of the front member named by
    ``select`` ("knee" by default; "min_f", "shortest", "smoothest"), the front in ``info["front"]``.
    Every position is projected onto its hatches (shrunk by ``inset``) after each move, so every path
    evaluated and returned lies in the rosary's certified bubbles. Defaults (tuned on the obstacle
    rosary, D = 84; ``benchmarks/mgoa.py``): a swarm of 50 for 500 iterations, Eq. 6's "sum" social
    term with ``random_social`` on (deterministic Eq. 6 ends about twice as far from the convex
    length bound), about 2 s; the paper's 500 x 100 costs about 25 s for a worse front.
    """

    swarm_size: int = 50
    iterations: int = 500
    random_social: bool = True
    select: str = "knee"
    inset: float = 1e-9

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_smoother()
