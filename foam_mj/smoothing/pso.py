"""Particle Swarm Optimisation (Elmi and Efe 2018 Eq. 8-9) and its multi-objective version MOPSO, vectorised.

Every particle i moves with (Eq. 9, then Eq. 8)

    v_i <- w v_i + c1 r1 (P_best,i - x_i) + c2 r2 (G_best - x_i),     x_i <- x_i + v_i

r1, r2 ~ U[0, 1] drawn per particle and coordinate. ``inertia`` is w, a constant or a pair (w_start,
w_end) decreasing linearly over the iterations (w_l = w_start + (w_end - w_start) l / L); ``c1``, ``c2``
are the individual and group learning rates. Elmi and Efe 2018 gives no values; defaults: the inertia of
Shi and Eberhart 1999, decreasing from 0.9 to 0.4, with the c1 = c2 = 1.49618 of Clerc and Kennedy 2002 (their
constant w = 0.7298, ``inertia=CLERC_W``, ends about twice as far from the convex length
bound on the obstacle rosary and slightly worse on the planar maps).

Choices: velocities start at 0 and are clamped to ``v_max`` (ub - lb) per coordinate (None: no
clamp); a new position is clipped to [lb, ub] and passed through the problem's ``repair`` (projection
onto the hatches on a rosary), and the particle's velocity is then set to the displacement it really
made (so a particle pressed against a wall does not keep accelerating into it).

MOPSO (Coello et al. 2004, the leader rule that MGOA shares): G_best is replaced by a leader drawn
per particle and iteration from the bounded Pareto archive by roulette on 1 / niche count
(:class:`~foam_mj.smoothing.pareto.Archive`). P_best is replaced by the new position when that
(constrained-)dominates it, kept when it dominates the new one, and otherwise replaced with probability
1/2.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, ClassVar

import numpy as np

from foam_mj.smoothing.base import SeedLike, _check_int, _check_positive, seeded
from foam_mj.smoothing.goa import OptimizeResult, _check_box
from foam_mj.smoothing.multiobjective import ParetoRun, ParetoSmoother, Problem, RunRecorder, finish_run
from foam_mj.smoothing.pareto import Archive, dominates

#: The constriction-equivalent constants of Clerc and Kennedy 2002.
CLERC_W = 0.7298
CLERC_C = 1.49618


def _dominates_constrained(Fa, Va, Fb, Vb) -> np.ndarray:
    """Row-wise constrained dominance of (Fa, Va) over (Fb, Vb) (see foam_mj.smoothing.pareto)."""
    fa, fb = Va <= 0, Vb <= 0
    return np.where(fa & fb, dominates(Fa, Fb), (fa & ~fb) | (~fa & ~fb & (Va < Vb)))


@dataclass(frozen=True)
class PSOParams:
    """PSO's parameters (shared by :class:`PSO`, :class:`MOPSO` and :class:`MOPSOSmoother`)."""

    swarm_size: int = 500
    iterations: int = 100
    inertia: float | tuple[float, float] = (0.9, 0.4)
    c1: float = CLERC_C
    c2: float = CLERC_C
    v_max: float | None = 0.2

    def _check_pso(self) -> None:
        _check_int("swarm_size", self.swarm_size, 1)
        _check_int("iterations", self.iterations, 1)
        w = self.inertia
        pair = isinstance(w, (tuple, list))
        try:
            vals = [float(x) for x in w] if isinstance(w, (tuple, list)) else [float(w)]
        except (TypeError, ValueError):
            raise ValueError(f"inertia must be a number or a pair (w_start, w_end), got {w!r}") from None
        if (pair and len(vals) != 2) or not all(np.isfinite(v) and v >= 0 for v in vals) or isinstance(w, bool):
            raise ValueError(f"inertia must be a number >= 0 or a pair of them, got {w!r}")
        _check_positive("c1", self.c1, allow_zero=True)
        _check_positive("c2", self.c2, allow_zero=True)
        if self.v_max is not None:
            _check_positive("v_max", self.v_max)

    def weights(self) -> np.ndarray:
        """w for iterations 1..L."""
        L = int(self.iterations)
        if isinstance(self.inertia, (tuple, list)):
            w0, w1 = (float(x) for x in self.inertia)
            return w0 + (w1 - w0) * np.arange(1, L + 1) / L
        return np.full(L, float(self.inertia))

    def move(self, rng, X, Vel, pbest, guide, w, lb, ub, repair):
        """Eq. 9 then Eq. 8 for the whole swarm; returns the new (feasible) positions and velocities."""
        N, D = X.shape
        r = rng.random((2, N, D))
        Vel = w * Vel + self.c1 * r[0] * (pbest - X) + self.c2 * r[1] * (guide - X)
        if self.v_max is not None:
            vm = float(self.v_max) * (ub - lb)
            np.clip(Vel, -vm, vm, out=Vel)
        Xn = np.clip(X + Vel, lb, ub)
        if repair is not None:
            Xn = repair(Xn)
        return Xn, Xn - X

    def _pso_info(self) -> dict[str, Any]:
        w = list(self.inertia) if isinstance(self.inertia, (tuple, list)) else self.inertia
        return {"swarm_size": self.swarm_size, "iterations": self.iterations, "inertia": w, "c1": self.c1,
                "c2": self.c2, "v_max": self.v_max}


@dataclass(frozen=True)
class PSO(PSOParams):
    """Single-objective PSO over a box: ``minimize(fn, lb, ub, seed)``, fn mapping (N, D) to (N,)."""

    name: ClassVar[str] = "PSO"

    def __post_init__(self) -> None:
        self._check_pso()

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
        t_start = time.perf_counter()
        lb, ub = _check_box(lb, ub, x0)
        rng, used = seeded(seed)
        N = int(self.swarm_size)
        X = lb + (ub - lb) * rng.random((N, lb.size))
        if x0 is not None:
            X[0] = x0
        if repair is not None:
            X = repair(X)
        Vel = np.zeros_like(X)
        val = np.asarray(fn(X), dtype=float)
        pbest, pval = X.copy(), val.copy()
        g = int(np.argmin(pval))
        hb, hm = [float(pval[g])], [float(val.mean())]
        for w in self.weights():
            X, Vel = self.move(rng, X, Vel, pbest, pbest[g], float(w), lb, ub, repair)
            val = np.asarray(fn(X), dtype=float)
            better = val < pval
            pbest[better] = X[better]
            pval[better] = val[better]
            g = int(np.argmin(pval))
            hb.append(float(pval[g]))
            hm.append(float(val.mean()))
        return OptimizeResult(pbest[g].copy(), float(pval[g]), np.array(hb), np.array(hm), int(self.iterations),
                              N * (int(self.iterations) + 1), time.perf_counter() - t_start, used)


@dataclass(frozen=True)
class MOPSO(PSOParams):
    """Multi-objective PSO: leaders drawn per particle from the bounded Pareto archive (``archive_size``,
    crowding pruning, roulette on 1 / niche count with ``niche_radius``). ``run(problem, seed, initial)``
    -> :class:`ParetoRun`."""

    archive_size: int = 100
    niche_radius: float = 0.1

    name: ClassVar[str] = "MOPSO"

    def __post_init__(self) -> None:
        self._check_pso()
        Archive(self.archive_size, self.niche_radius)  # validates both

    def run(self, problem: Problem, seed: SeedLike = 0, initial: np.ndarray | None = None) -> ParetoRun:
        t_start = time.perf_counter()
        rng, used = seeded(seed)
        lb, ub = _check_box(problem.lb, problem.ub, initial)
        N = int(self.swarm_size)
        X = problem.sample(rng, N)
        if initial is not None:
            X[0] = initial
        Vel = np.zeros_like(X)
        F, V = problem.evaluate(X)
        pX, pF, pV = X.copy(), F.copy(), V.copy()
        archive = Archive(self.archive_size, self.niche_radius)
        archive.update(X, F, V)
        rec = RunRecorder(F, V, tuple(getattr(problem, "names", [f"f{j}" for j in range(F.shape[1])])))
        rec.record(archive, F, V)
        for w in self.weights():
            leaders = archive.X[archive.select(rng, N)]
            X, Vel = self.move(rng, X, Vel, pX, leaders, float(w), lb, ub, problem.repair)
            F, V = problem.evaluate(X)
            new_dom = _dominates_constrained(F, V, pF, pV)
            old_dom = _dominates_constrained(pF, pV, F, V)
            coin = rng.random(N) < 0.5
            take = new_dom | (~old_dom & coin)
            pX[take], pF[take], pV[take] = X[take], F[take], V[take]
            archive.update(X, F, V)
            rec.record(archive, F, V)
        info = self._pso_info() | {"archive_size": self.archive_size, "niche_radius": self.niche_radius,
                                   "leader": "roulette on 1/niche count, per particle",
                                   "pruning": "crowding distance", "seed": used}
        return finish_run(self.name, archive, rec, int(self.iterations), N * (int(self.iterations) + 1),
                          t_start, info)


@dataclass(frozen=True)
class MOPSOSmoother(MOPSO, ParetoSmoother):
    """MOPSO over a rosary's hatches, objectives (length, angle term of Nascimento et al. 2020 Eq. 5); the same
    interface as :class:`~foam_mj.smoothing.goa.MGOASmoother` (``front`` and ``smooth``). Positions are
    projected onto the hatches (shrunk by ``inset``) after each move. Defaults: a swarm of 100 for
    500 iterations (about 1 s on the obstacle rosary)."""

    swarm_size: int = 100
    iterations: int = 500
    select: str = "knee"
    inset: float = 1e-9

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_smoother()
