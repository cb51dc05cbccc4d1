"""Harmony Search over the hatches (Nascimento et al. 2020 section 2.1, Eq. 1; parameters of section 5.1).

A harmony is one set of waypoints sigma = {q'_1, ..., q'_(k-1)} (Nascimento et al. 2020 Eq. 3); its decision
variables (the "instruments") are the waypoints, each confined to its hatch. The harmony memory holds
HMS harmonies drawn uniformly in the hatches. Each improvisation builds a new harmony waypoint by
waypoint:

* with probability HMCR, memory consideration: waypoint i of a harmony chosen uniformly from memory;
  then, with probability PAR, pitch adjustment h_new = h ± x BW (Eq. 1), applied per coordinate with
  its own x ~ U[0, 1] and sign (i.e. h + BW U[-1, 1]^n);
* otherwise random selection: a uniform point of hatch i.

The new harmony replaces the worst in memory when its f (Nascimento et al. 2020 Eq. 5) is lower.

Choices (the paper leaves them open):

* Memory consideration is decided waypoint by waypoint, each from its own harmony drawn from memory: the
  paper's instruments are the decision variables (section 2.1), and per-variable consideration is the
  Harmony Search of Geem et al. 2001 that it cites. Its sentence "a harmony h is selected from the HM with
  probability HMCR" read as one whole harmony per improvisation would only copy a memory member and
  pitch-adjust it, never combining waypoints of different harmonies.
* BW is in configuration units (radians, or the normalized hip displacement), the same for every
  coordinate, as section 5.1 gives it (BW = 0.01); it is not scaled to the hatches.
* Infeasible pitch adjustments are **reverted**: a waypoint whose adjusted value leaves its hatch keeps
  its unadjusted (memory) value. Reverting needs no extra random draws, so the random stream depends
  only on the iteration index (which the speculative evaluation below relies on), and it never biases
  the result towards the hatch boundary as clipping would.
* The population's mean (Table 1's stop criterion) is the memory's mean f. It falls exactly when a
  harmony is replaced, so "no improvement in 200 iterations" is 200 improvisations without one. On
  the obstacle rosary that never happens (PFM seed 0's rosary, HS seeds 0-4: 3,100-3,500 replacements in
  2 x 10^4 improvisations, never more than 72-105 improvisations apart), so HS runs to the cap; the paper's ~4,200 iterations cannot be
  reproduced with this exact reading (a ``stall_tol`` > 0 is the knob for a looser one).

Speed: all random numbers for 1024 improvisations are drawn at once. Improvisations are then
evaluated **speculatively** in blocks: B harmonies are improvised from the current memory with the
random numbers of iterations t..t+B-1 and evaluated in one vectorized call; the first that beats the
worst harmony is accepted and the later ones discarded. Since the memory does not change until that
replacement, this is exactly the sequential algorithm (same seed, same result, whatever the block
size); the block size adapts to the observed replacement rate. A block is evaluated by the GA's
preallocated kernels (:mod:`foam_mj.smoothing.genetic`: the same floating-point operations as
``coordinate_major_objective`` and ``Hatches.outside_cm``, so the same results bit for bit, with fewer
numpy calls).
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
from foam_mj.smoothing.genetic import _OutsideHatches, _PopulationObjective

#: Improvisations whose random numbers are drawn in one batch (fixed, so results do not depend on the cap).
CHUNK = 1024
#: Largest speculative block.
MAX_BLOCK = 256


@dataclass(frozen=True)
class HarmonySearch(Smoother):
    """Harmony Search with Nascimento et al. 2020 section 5.1's parameters (HMS 50, HMCR 0.99, PAR 0.15, BW 0.01).

    ``initial`` (optional) replaces one random harmony of the initial memory; the paper's memory is all
    random (``initial=None``). ``stop`` defaults to Table 1's criterion (200 improvisations without a
    better mean) capped at Nascimento et al. 2019's NI = 2 x 10^4.
    """

    HMS: int = 50
    HMCR: float = 0.99
    PAR: float = 0.15
    BW: float = 0.01
    stop: StopCriteria = field(default_factory=StopCriteria)

    name: ClassVar[str] = "HS"

    def __post_init__(self) -> None:
        _check_int("HMS", self.HMS, 1)
        _check_unit("HMCR", self.HMCR)
        _check_unit("PAR", self.PAR)
        if not (_is_real(self.BW) and 0.0 <= float(self.BW) <= 1.0):  # Eq. 1: "BW is a parameter between [0, 1]"
            raise ValueError(f"BW must be in [0, 1] (Nascimento et al. 2020 Eq. 1), got {self.BW!r}")
        if not isinstance(self.stop, StopCriteria):
            raise ValueError(f"stop must be a StopCriteria, got {self.stop!r}")

    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0, *,
               progress: ProgressFn | None = None) -> SmoothingResult:
        """Run HS; ``progress`` (optional) hears the improvisations done and the best f about twice a second."""
        t_start = time.perf_counter()
        rng, used = seeded(seed)
        init = check_initial(rosary, initial)
        if rosary.n_hatches == 0:
            return trivial_result(self.name, rosary, t_start)
        check_rosary(rosary)
        h = Hatches.of(rosary)
        m, n, hms = h.m, rosary.dim, int(self.HMS)
        stop = self.stop
        cap = stop.max_iterations if stop.max_iterations is not None else np.iinfo(np.int64).max
        stall_cap = stop.stall_iterations if stop.stall_iterations is not None else np.iinfo(np.int64).max
        threshold = stop.f_threshold if stop.f_threshold is not None else -np.inf

        # pool[:HMS] is the harmony memory; pool[HMS + c] holds iteration c's random hatch points, so one
        # gather improvises a whole block (memory consideration and random selection alike).
        # Everything is stored coordinate-major (n, harmonies, waypoints): see coordinate_major_objective.
        pool = np.empty((n, hms + CHUNK, m))
        mem0 = h.sample(rng, np.broadcast_to(np.arange(m), (hms, m)))
        if init is not None:
            mem0[0] = init
        pool[:, :hms] = mem0.transpose(2, 0, 1)
        # A block of b candidates is the contiguous (n, b, k+1) head of one flat buffer (its ends rewritten
        # when b changes), evaluated by the GA's preallocated kernels (the same operations as
        # coordinate_major_objective and Hatches.outside_cm, bit for bit).
        L, most = m + 2, max(hms, MAX_BLOCK)
        flat = np.empty(n * most * L)
        objective = _PopulationObjective(n, most, L)
        outside = _OutsideHatches(h, most, rosary.q_init, rosary.q_goal)
        q_ends = np.stack([rosary.q_init, rosary.q_goal], axis=1)[:, None, :]  # (n, 1, 2)
        mem = flat[: n * hms * L].reshape(n, hms, L)
        mem[:, :, [0, -1]] = q_ends
        mem[:, :, 1:-1] = pool[:, :hms]
        fit = coordinate_major_objective(mem)
        ends_b = hms
        worst = int(np.argmax(fit))
        best = float(fit.min())
        total = float(fit.sum())
        stall = MeanStall(total / hms, stop.stall_tol)

        cols = np.arange(m)
        pool_planes = pool.reshape(n, -1)
        base_flat = np.empty(n * MAX_BLOCK * m)
        runs: list[tuple[float, float, int]] = []  # (best, mean, iterations) runs of the history
        t = 0  # improvisations done
        spec_evals = 0
        block = 4
        reason = stop.reason(0, best, 0)
        cpos = CHUNK  # position in the current chunk of random numbers; CHUNK forces a draw
        next_report = t_start + PROGRESS_INTERVAL
        while reason is None:
            if cpos >= CHUNK:
                gidx, offset = self._draw(rng, h, pool, hms, m, n)
                gflat = gidx * m + cols  # positions in a coordinate's (pool rows x m) plane
                cpos = 0
            b = min(block, CHUNK - cpos, cap - t, stall_cap - stall.count)
            g = gidx[cpos : cpos + b]
            base = np.take(pool_planes, gflat[cpos : cpos + b], axis=1, mode="clip",
                           out=base_flat[: n * b * m].reshape(n, b, m))  # pool[:, g, cols]
            blk = flat[: n * b * L].reshape(n, b, L)
            if b != ends_b:
                blk[:, :, ::L - 1] = q_ends
                ends_b = b
            cand = blk[:, :, 1:-1]
            np.add(base, offset[:, cpos : cpos + b], out=cand)  # pitch adjustment (offset 0 elsewhere)
            bad = outside(blk)  # revert infeasible adjustments
            if bad.size:
                path, point = np.divmod(bad, L)
                cand[:, path, point - 1] = base[:, path, point - 1]
            f = objective(blk)
            spec_evals += b
            # Walk the block in order. A replacement of slot w invalidates the later harmonies that took a
            # waypoint from w (``limit``); those before it were improvised from the right memory.
            j0, limit = 0, b
            while j0 < limit:
                hits = (f[j0:limit] < fit[worst]).nonzero()[0]
                j = j0 + int(hits[0]) if hits.size else limit
                if j > j0:
                    runs.append((best, total / hms, j - j0))
                    t += j - j0
                    stall.count += j - j0
                if not hits.size:
                    j0 = limit
                    break
                w = worst
                pool[:, w] = cand[:, j]
                total += float(f[j]) - float(fit[w])
                fit[w] = f[j]
                worst = int(fit.argmax())
                best = min(best, float(f[j]))
                stall.update(total / hms)
                t += 1
                runs.append((best, total / hms, 1))
                j0 = j + 1
                if best < threshold:
                    break
                if j0 < limit:
                    taint = np.logical_or.reduce(g[j0:limit] == w, axis=1).nonzero()[0]
                    if taint.size:
                        limit = j0 + int(taint[0])
            cpos += j0
            block = min(max(2 * j0, 4), MAX_BLOCK)
            reason = stop.reason(t, best, stall.count)
            if progress is not None and time.perf_counter() >= next_report:
                progress(t, best)
                next_report = time.perf_counter() + PROGRESS_INTERVAL

        i_best = int(np.argmin(fit))
        bests, means, lens = (np.array(x) for x in zip(*runs)) if runs else (np.empty(0),) * 3
        return SmoothingResult.build(
            self.name,
            rosary,
            pool[:, i_best].T,
            history_best=np.repeat(bests, lens.astype(np.intp)),
            history_mean=np.repeat(means, lens.astype(np.intp)),
            iterations=t,
            evaluations=hms + t,
            wall_time=time.perf_counter() - t_start,
            stop_reason=reason,
            info={"HMS": hms, "HMCR": self.HMCR, "PAR": self.PAR, "BW": self.BW,
                  "speculative_evaluations": spec_evals, "infeasible_adjustment": "revert", "seed": used},
        )

    def _draw(self, rng: np.random.Generator, h: Hatches, pool: np.ndarray, hms: int, m: int, n: int):
        """Random numbers for CHUNK improvisations: the pool row of every waypoint (a memory slot, or
        HMS + c for random selection, whose uniform hatch point is written to pool[HMS + c]) and the
        pitch offsets BW U[-1, 1]^n (zero where no adjustment applies)."""
        gidx = rng.integers(0, hms, (CHUNK, m))
        use_mem = rng.random((CHUNK, m)) < self.HMCR
        pitch = use_mem & (rng.random((CHUNK, m)) < self.PAR)
        offset = (rng.uniform(-self.BW, self.BW, (CHUNK, m, n)) * pitch[..., None]).transpose(2, 0, 1).copy()
        rows, wps = np.nonzero(~use_mem)
        if rows.size:
            pool[:, hms + rows, wps] = h.sample(rng, wps).T
            gidx[rows, wps] = hms + rows
        return gidx, offset
