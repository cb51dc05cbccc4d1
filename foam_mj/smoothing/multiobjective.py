"""Multi-objective smoothing runs (Elmi and Efe 2018) on a rosary: the problem, the run record, the result.

On a rosary (:class:`RosaryProblem`) the two objectives are the path length and the angle term of Nascimento
et al. 2020 Eq. 5 (``paths.path_length`` and ``paths.angle_term``); their sum is Eq. 5's f. The result of a
multi-objective smoother is a :class:`ParetoResult` (the front as arrays, its knee and its two
extremes); :class:`ParetoSmoother` (base of ``MGOASmoother`` and ``MOPSOSmoother``) adapts it to the
:class:`~foam_mj.smoothing.base.Smoother` interface: ``smooth()`` returns the knee's (or another selected
member's) :class:`SmoothingResult` with the front in ``info["front"]``; ``front()`` returns the whole
:class:`ParetoResult`.

On the obstacle rosary the two objectives hardly conflict: the convex shortest path through the
hatches (``ConvexShortestPath``) is also about as smooth as anything the swarms find, and it weakly
dominates every member of their fronts (``benchmarks/mgoa.py``, part (b)). Passing its waypoints as
``initial`` (one particle of the swarm) makes the front start there.
"""

from __future__ import annotations

import math
import time
from abc import abstractmethod
from dataclasses import dataclass, field
from typing import Any, ClassVar, Mapping, Protocol

import numpy as np

from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import (
    Hatches,
    SeedLike,
    SmoothingResult,
    Smoother,
    _check_positive,
    check_initial,
    check_rosary,
    check_rosary_type,
    trivial_result,
)
from foam_mj.smoothing.pareto import _EPS, Archive, hypervolume_2d, knee_index

#: What ``ParetoSmoother.smooth`` may return from the front.
SELECTIONS = ("knee", "min_f", "shortest", "smoothest")
#: The rosary objectives, in column order.
ROSARY_OBJECTIVES = ("length", "angle_term")


# -- problems and runs -----------------------------------------------------------------------------------
class Problem(Protocol):
    """What the swarm optimisers need of a (multi-objective) problem over D decision variables.

    ``lb``/``ub`` (D,) bound the search box (GOA's Eq. 6 scales its social term with them);
    ``sample(rng, P)`` draws P feasible starting points (P, D); ``repair(X)`` maps positions (P, D) back
    into the feasible set (box clipping, hatch projection); ``evaluate(X)`` returns the objectives
    (P, M) and constraint violations (P,) >= 0 (0 = feasible).
    """

    lb: np.ndarray
    ub: np.ndarray

    def sample(self, rng: np.random.Generator, size: int) -> np.ndarray: ...

    def repair(self, X: np.ndarray) -> np.ndarray: ...

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class ParetoRun:
    """What MGOA.run and MOPSO.run return: the final archive and the run's history.

    ``X`` (F, D), ``objectives`` (F, M), ``violation`` (F,), sorted by the first objective.
    ``history`` maps names to per-iteration arrays (index 0 = the initial population):
    ``archive_size``, ``archive_feasible`` (1 once the archive holds feasible solutions), ``best_<name>`` (lowest value of that objective in the archive), ``mean_<name>``
    (swarm mean), ``best_sum`` (lowest sum of the objectives in the archive), ``feasible_share`` (of the
    swarm), and ``hypervolume`` (w.r.t. ``info["hv_reference"]``, the worst
    objective values of the initial swarm, for two objectives and a feasible archive; NaN otherwise).
    """

    method: str
    X: np.ndarray
    objectives: np.ndarray
    violation: np.ndarray
    history: Mapping[str, np.ndarray]
    iterations: int
    evaluations: int
    wall_time: float
    info: Mapping[str, Any] = field(default_factory=dict)

    @property
    def feasible(self) -> bool:
        return bool(len(self.violation) and np.all(self.violation <= 0))


class RunRecorder:
    """Collects a run's per-iteration history (shared by MGOA and MOPSO); ``names`` name the objectives."""

    def __init__(self, F0: np.ndarray, V0: np.ndarray, names: tuple[str, ...]) -> None:
        self.names = tuple(names)
        feas = V0 <= 0
        self.hv_ref = (F0[feas] if feas.any() else F0).max(axis=0).astype(float)
        self.rows: dict[str, list[float]] = {"archive_size": [], "archive_feasible": [], "feasible_share": [],
                                             "hypervolume": [], "best_sum": []}
        for nm in self.names:
            self.rows[f"best_{nm}"] = []
            self.rows[f"mean_{nm}"] = []

    def record(self, archive: Archive, F: np.ndarray, V: np.ndarray) -> None:
        r = self.rows
        r["archive_size"].append(len(archive))
        r["archive_feasible"].append(1.0 if archive.feasible else 0.0)
        r["feasible_share"].append(float(np.mean(V <= 0)))
        r["best_sum"].append(float(archive.F.sum(axis=1).min()))
        for j, nm in enumerate(self.names):
            r[f"best_{nm}"].append(float(archive.F[:, j].min()))
            r[f"mean_{nm}"].append(float(F[:, j].mean()))
        two = len(self.names) == 2 and archive.feasible
        r["hypervolume"].append(hypervolume_2d(archive.F, self.hv_ref) if two else math.nan)

    def history(self) -> dict[str, np.ndarray]:
        out = {}
        for k, v in self.rows.items():
            a = np.array(v, dtype=float)
            a.setflags(write=False)
            out[k] = a
        return out


def finish_run(method: str, archive: Archive, rec: RunRecorder, iterations: int, evaluations: int,
               t_start: float, info: Mapping[str, Any]) -> ParetoRun:
    """The ParetoRun of a finished optimiser: the archive sorted by the first objective."""
    order = np.lexsort(archive.F.T[::-1])
    X, F, V = (np.array(a[order]) for a in (archive.X, archive.F, archive.V))
    for a in (X, F, V):
        a.setflags(write=False)
    info = dict(info)
    info["hv_reference"] = rec.hv_ref.tolist()
    return ParetoRun(method, X, F, V, rec.history(), iterations, evaluations,
                     time.perf_counter() - t_start, info)


def check_schedule_params(c_max: Any, c_min: Any) -> None:
    _check_positive("c_max", c_max)
    _check_positive("c_min", c_min)
    if float(c_min) > float(c_max):
        raise ValueError(f"c_min must be <= c_max, got c_min={c_min!r} > c_max={c_max!r}")


# -- the rosary problem ----------------------------------------------------------------------------------
def length_and_angle(points: np.ndarray) -> np.ndarray:
    """(paths.path_length, paths.angle_term) of paths (P, k+1, n) in one pass -> (P, 2): the two terms of
    Nascimento et al. 2020 Eq. 5 (length; mean supplementary angle over the interior vertices, a vertex next to a
    zero-length segment counting as straight)."""
    p = np.asarray(points, dtype=float)
    seg = p[..., 1:, :] - p[..., :-1, :]
    lens = np.sqrt(np.einsum("...i,...i->...", seg, seg))
    dot = np.einsum("...i,...i->...", seg[..., :-1, :], seg[..., 1:, :])
    den = lens[..., :-1] * lens[..., 1:]
    cos = np.where(den > _EPS, dot / np.where(den > _EPS, den, 1.0), 1.0)
    ang = np.arccos(np.clip(cos, -1.0, 1.0))
    angle = ang.mean(axis=-1) if ang.shape[-1] else np.zeros(ang.shape[:-1])
    return np.stack([lens.sum(axis=-1), angle], axis=-1)


class RosaryProblem:
    """The waypoints of a rosary (Nascimento et al. 2020 Eq. 3) as a two-objective problem: minimise (length,
    angle term) with waypoint i in hatch i.

    Decision vector: the k-1 waypoints flattened waypoint-major (D = (k-1) n). The search box is the
    bounding box of every hatch (box of ball a ∩ box of ball b). ``repair`` is the Euclidean
    projection onto the hatches shrunk by ``inset`` (``Hatches.project``, closed form), so every
    position the optimisers evaluate is feasible (violation 0) and its path lies in the rosary's
    certified bubbles; the small default inset (less in a hatch too thin for it, ``Hatches.fitting_inset``)
    keeps projected waypoints strictly inside the closed hatches despite rounding.
    """

    names = ROSARY_OBJECTIVES

    def __init__(self, rosary: Rosary, inset: float = 1e-9) -> None:
        self.rosary = rosary
        check_rosary(rosary)
        self.hatches = h = Hatches.of(rosary)
        self.inset = h.fitting_inset(inset)
        self.m, self.n = h.m, rosary.dim
        lo = np.maximum(h.ca - h.ra[:, None], h.cb - h.rb[:, None])
        hi = np.minimum(h.ca + h.ra[:, None], h.cb + h.rb[:, None])
        self.lb = lo.ravel()
        self.ub = hi.ravel()
        self._q0 = rosary.q_init
        self._q1 = rosary.q_goal

    @property
    def dim(self) -> int:
        return self.m * self.n

    def waypoints(self, X: np.ndarray) -> np.ndarray:
        """(..., D) -> (..., k-1, n)."""
        X = np.asarray(X, dtype=float)
        return X.reshape(X.shape[:-1] + (self.m, self.n))

    def sample(self, rng: np.random.Generator, size: int) -> np.ndarray:
        w = self.hatches.sample(rng, np.broadcast_to(np.arange(self.m), (size, self.m)))
        return self.repair(w.reshape(size, self.dim))

    def repair(self, X: np.ndarray) -> np.ndarray:
        w = self.hatches.project(self.waypoints(X), self.inset)
        return w.reshape(np.shape(X))

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = self.waypoints(X)
        F = length_and_angle(self.rosary.path(w))
        return F, np.zeros(len(F))


# -- the result on a rosary --------------------------------------------------------------------------------
@dataclass(frozen=True)
class ParetoResult:
    """The Pareto front of a multi-objective smoother on a rosary.

    ``front_waypoints`` (F, k-1, n) and ``front_paths`` (F, k+1, n), ``front_objectives`` (F, 2) with
    columns ``objective_names`` = ("length", "angle_term") (paths.path_length and paths.angle_term;
    their sum is Nascimento et al. 2020 Eq. 5's f), sorted by length (so by decreasing angle term). ``knee`` indexes
    the member closest to the ideal point (:func:`knee_index`); ``extremes`` = (shortest, smoothest).
    ``history`` per iteration (index 0 = initial swarm): archive_size, archive_feasible, best_length, best_angle_term,
    mean_length, mean_angle_term, feasible_share, hypervolume, best_f (lowest f = length + angle term
    in the archive), mean_f (swarm mean f). :meth:`summary` adds ``convex_length`` and the gaps to it when given one.
    """

    method: str
    rosary: Rosary
    front_waypoints: np.ndarray
    front_paths: np.ndarray
    front_objectives: np.ndarray
    knee: int
    extremes: tuple[int, int]
    history: Mapping[str, np.ndarray]
    iterations: int
    evaluations: int
    wall_time: float
    info: Mapping[str, Any] = field(default_factory=dict)
    objective_names: tuple[str, str] = ROSARY_OBJECTIVES

    @classmethod
    def from_run(cls, run: ParetoRun, problem: RosaryProblem) -> "ParetoResult":
        W = np.array(problem.waypoints(run.X))
        P = problem.rosary.path(W)
        F = np.array(run.objectives)
        for a in (W, P, F):
            a.setflags(write=False)
        h = dict(run.history)
        h["best_f"] = h.pop("best_sum")
        h["mean_f"] = h["mean_length"] + h["mean_angle_term"]
        ext = (int(np.argmin(F[:, 0])), int(np.argmin(F[:, 1])))
        return cls(run.method, problem.rosary, W, P, F, knee_index(F), ext, h, run.iterations,
                   run.evaluations, run.wall_time, dict(run.info))

    @property
    def size(self) -> int:
        return len(self.front_objectives)

    @property
    def lengths(self) -> np.ndarray:
        return self.front_objectives[:, 0]

    @property
    def angle_terms(self) -> np.ndarray:
        return self.front_objectives[:, 1]

    @property
    def f(self) -> np.ndarray:
        """Nascimento et al. 2020 Eq. 5 of every member."""
        return self.front_objectives.sum(axis=1)

    def index(self, select: str) -> int:
        """The member ``select`` names: "knee", "min_f" (lowest Eq. 5 f), "shortest" or "smoothest"."""
        if select == "knee":
            return self.knee
        if select == "min_f":
            return int(np.argmin(self.f))
        if select == "shortest":
            return self.extremes[0]
        if select == "smoothest":
            return self.extremes[1]
        raise ValueError(f"select must be one of {SELECTIONS}, got {select!r}")

    def result(self, i: int | str = "knee", method: str | None = None) -> SmoothingResult:
        """Member i (an index or a :data:`SELECTIONS` name) as a :class:`SmoothingResult`: histories of
        f (Eq. 5; best = lowest f in the archive, mean = the swarm's), the front in ``info["front"]``."""
        idx = self.index(i) if isinstance(i, str) else int(i)
        if not 0 <= idx < self.size:
            raise ValueError(f"front index {idx} out of range (front of {self.size})")
        label = i if isinstance(i, str) else f"member {idx}"
        info = dict(self.info)
        info.update({"selected": label, "selected_index": idx, "front": self.front_arrays(),
                     "front_size": self.size, "pareto": self})
        return SmoothingResult.build(
            method or self.method, self.rosary, self.front_waypoints[idx],
            history_best=self.history["best_f"], history_mean=self.history["mean_f"],
            iterations=self.iterations, evaluations=self.evaluations, wall_time=self.wall_time,
            stop_reason="iteration cap", objective="f", info=info,
        )

    def knee_result(self) -> SmoothingResult:
        return self.result("knee")

    def extreme_results(self) -> tuple[SmoothingResult, SmoothingResult]:
        return self.result("shortest"), self.result("smoothest")

    def front_arrays(self) -> dict[str, Any]:
        """The front for recordings and JSON: waypoints (F, k-1, n), paths (F, k+1, n), objectives (F, 2),
        objective names, knee index, extremes (shortest, smoothest)."""
        return {"waypoints": self.front_waypoints, "paths": self.front_paths, "objectives": self.front_objectives,
                "objective_names": list(self.objective_names), "knee": self.knee, "extremes": list(self.extremes)}

    def all_in_hatches(self, tol: float = 0.0) -> bool:
        return self.rosary.all_in_hatches(self.front_waypoints, tol)

    def summary(self, convex_length: float | None = None) -> dict:
        """Scalars for tables and JSON (with the gaps to ``convex_length`` when given)."""
        F = self.front_objectives
        out: dict[str, Any] = {
            "method": self.method, "front_size": self.size, "iterations": self.iterations,
            "evaluations": self.evaluations, "wall_time": self.wall_time,
            "shortest": {"length": float(F[self.extremes[0], 0]), "angle_term": float(F[self.extremes[0], 1])},
            "smoothest": {"length": float(F[self.extremes[1], 0]), "angle_term": float(F[self.extremes[1], 1])},
            "knee": {"length": float(F[self.knee, 0]), "angle_term": float(F[self.knee, 1])},
            "min_f": float(self.f.min()),
            "hypervolume": float(self.history["hypervolume"][-1]),
        }
        if convex_length is not None:
            out["convex_length"] = float(convex_length)
            for key in ("shortest", "knee", "smoothest"):
                out[key]["length_gap_to_convex"] = out[key]["length"] - float(convex_length)
                out[key]["length_ratio_to_convex"] = out[key]["length"] / float(convex_length)
        return out


# -- the smoother adapter -------------------------------------------------------------------------------------
class ParetoSmoother(Smoother):
    """A multi-objective smoother: ``front(rosary, initial, seed)`` -> :class:`ParetoResult`;
    ``smooth(...)`` -> the SmoothingResult of the member named by ``self.select`` (default "knee"),
    with the front in ``info["front"]`` and the ParetoResult in ``info["pareto"]``.

    Subclasses provide ``run(problem, seed, initial)`` -> :class:`ParetoRun` and the fields ``select``
    and ``inset``.
    """

    name: ClassVar[str]
    select: str
    inset: float

    @abstractmethod
    def run(self, problem: Problem, seed: SeedLike = 0, initial: np.ndarray | None = None) -> ParetoRun:
        """Optimise ``problem``."""

    def _check_smoother(self) -> None:
        if self.select not in SELECTIONS:
            raise ValueError(f"select must be one of {SELECTIONS}, got {self.select!r}")
        _check_positive("inset", self.inset, allow_zero=True)

    def front(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> ParetoResult:
        """The Pareto front of (length, angle term) over the rosary's hatches. ``initial`` (optional,
        (k-1, n) in the hatches) replaces one particle of the random initial swarm."""
        init = check_initial(rosary, initial)
        if rosary.n_hatches == 0:
            raise ValueError(f"the rosary has {rosary.k} bubble(s): there is no waypoint to smooth (need k >= 2)")
        problem = RosaryProblem(rosary, self.inset)
        x0 = None if init is None else problem.repair(init.reshape(1, -1))[0]
        run = self.run(problem, seed, x0)
        return ParetoResult.from_run(run, problem)

    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> SmoothingResult:
        check_rosary_type(rosary)
        if rosary.n_hatches == 0:
            check_initial(rosary, initial)
            return trivial_result(self.name, rosary, time.perf_counter())
        return self.front(rosary, initial, seed).result(self.select, self.name)



__all__ = [
    "ParetoResult", "ParetoRun", "ParetoSmoother", "Problem", "RosaryProblem", "RunRecorder", "ROSARY_OBJECTIVES", "SELECTIONS",
    "check_schedule_params", "finish_run", "length_and_angle",
]
