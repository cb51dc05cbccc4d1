"""``pfm``: the Probabilistic Foam Method exactly as the papers give it (:func:`foam_mj.foam.plan`).

The growth is Nascimento et al. 2020 section 3.1's: parents first-in-first-out, N = K floor(r / r_min)^(n-1)
candidates (Eq. 2) drawn uniformly on each parent's surface, a candidate dropped when it lies in another bubble or its
bubble is smaller than r_min, the search ended by the first bubble that holds q_goal. What foam-mj adds lies outside
that loop, each where it is made: the radius is certified per geom pair with a margin delta and capped at the joint
bounds (:mod:`foam_mj.bubbles`; the papers' Eq. 4 has one distance and no margin), candidates outside the joint
bounds are dropped (the papers do not say what happens at the joint limits), and bubble and time budgets end a search the papers would run on.

This wrapper only translates: the problem's margin and budgets and the options K and r_min become
:class:`~foam_mj.foam.FoamParams`, the foam's statistics become :class:`PlanStats`. The same seed
grows the same foam, bubble for bubble, as calling :func:`foam_mj.foam.plan` directly (the paper
reproductions rely on it). A root bubble below r_min is refused before planning: the papers state r >= r_min for
children only, but with n >= 2 Eq. 2 gives such a root floor(r / r_min) = 0, so N = 0 candidates and the foam could
not grow (gbpf, rbpf and hpf accept it; rbpf and hpf give it K candidates, :mod:`foam_mj.planners.variants`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from foam_mj.errors import PlanningFailed
from foam_mj.foam import FoamParams, FoamStats, plan as foam_plan
from foam_mj.planners.base import PlanningProblem, PlanResult, PlanStats, Planner, Progress, ProgressFn, check_problem


@dataclass(frozen=True)
class PFMOptions:
    """K candidates per unit of r / r_min (Nascimento et al. 2020 Eq. 2), r_min the smallest bubble kept.
    Defaults are Nascimento et al. 2020's (K = 10, r_min = 0.07)."""

    K: int = 10
    r_min: float = 0.07

    def __post_init__(self) -> None:
        FoamParams(K=self.K, r_min=self.r_min)  # the same validation, the same messages


def _stats(st: FoamStats, reached: bool) -> PlanStats:
    details = {k: v for k, v in st.as_dict().items() if k not in ("bubbles", "elapsed", "outcome", "clearance_calls", "bubbles_per_second")}
    return PlanStats(
        planner="pfm", outcome=st.outcome, bubbles=st.bubbles, distance_queries=st.clearance_calls, elapsed=st.elapsed,
        time_to_first_path=st.elapsed if reached else None, details=details,
    )


class PFMPlanner(Planner):
    name = "pfm"
    summary = "Probabilistic Foam Method, breadth-first (Nascimento et al. 2020; Nascimento and Alsina 2021; the paper reproductions use it)"
    Options = PFMOptions

    def foam_params(self, problem: PlanningProblem) -> FoamParams:
        o = self.options
        return FoamParams(K=o.K, r_min=o.r_min, delta=problem.delta, max_bubbles=int(problem.max_bubbles), time_limit=problem.time_limit)

    def plan(self, problem: PlanningProblem, seed: int | np.random.Generator = 0, progress: ProgressFn | None = None) -> PlanResult:
        check_problem(problem, progress)
        problem.endpoint_radii()  # q_init or q_goal closer than delta: the same message as every planner's
        report = None if progress is None else (lambda st: progress(Progress(st.bubbles, st.elapsed)))  # as every planner's
        try:
            res = foam_plan(problem.oracle, problem.q_init, problem.q_goal, self.foam_params(problem), seed=seed, progress=report)
        except PlanningFailed as exc:
            stats = _stats(exc.stats, False) if isinstance(exc.stats, FoamStats) else exc.stats
            raise PlanningFailed(str(exc), stats, exc.foam, exc.reason) from None
        return PlanResult(res.foam, res.rosary, _stats(res.stats, True))
