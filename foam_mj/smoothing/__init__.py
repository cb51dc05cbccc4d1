"""Path smoothers over a rosary's hatches.

One module per method, one interface (:class:`Smoother`: ``smooth(rosary, initial, seed)`` ->
:class:`SmoothingResult`):

* :class:`HarmonySearch` (Nascimento et al. 2020 section 2.1, Eq. 1) and :class:`GeneticAlgorithm` (section 2.2,
  Algorithm 1, Eq. 6) minimise f of Nascimento et al. 2020 Eq. 5 with waypoint i in hatch b_i ∩ b_(i+1);
* :class:`GradientSmoothing` (Nascimento and Alsina 2021 Eq. 9) and :class:`RosaryAdjustment` (Eq. 8) give the thesis's
  paths T, T_CA, T_RA, T_RCA (:func:`thesis_paths`);
* :class:`ConvexShortestPath` is the convex reference (shortest path through the hatches, SOCP);
* :class:`OptimalSmoother` minimises f (or SV, or a weighted objective) in the hatches to a
  certified local optimum (sequential convex programming, KKT certificate);
* :class:`MGOASmoother` and :class:`MOPSOSmoother` (Elmi and Efe 2018) return the Pareto front of
  (length, angle term) (``front()`` -> :class:`ParetoResult`; ``smooth()`` -> the knee, the front in
  ``info["front"]``).
"""

from typing import Any

from foam_mj.smoothing.adjust import AdjustmentResult, RosaryAdjustment, thesis_paths
from foam_mj.smoothing.base import (
    PAPER_F_THRESHOLD,
    PAPER_MAX_ITERATIONS,
    PAPER_STALL_ITERATIONS,
    Hatches,
    SmoothingResult,
    Smoother,
    StopCriteria,
    coordinate_major_objective,
    population_objective,
)
from foam_mj.smoothing.certificate import Certificate, kkt_certificate
from foam_mj.smoothing.convex import ConvexShortestPath, ConvexSolveError, build_socp
from foam_mj.smoothing.genetic import GeneticAlgorithm
from foam_mj.smoothing.goa import GOA, MGOA, MGOASmoother
from foam_mj.smoothing.gradient import GradientSmoothing, center_path_result, sv_and_gradient, tc_and_gradient
from foam_mj.smoothing.harmony import HarmonySearch
from foam_mj.smoothing.multiobjective import ParetoResult, ParetoSmoother, RosaryProblem
from foam_mj.smoothing.objective import ObjectiveWeights
from foam_mj.smoothing.optimal import OptimalSmoother
from foam_mj.smoothing.pareto import Archive, error_ratio, hypervolume_2d, knee_index, set_coverage
from foam_mj.smoothing.pso import MOPSO, PSO, MOPSOSmoother

#: The smoothers that share :class:`Smoother`'s ``smooth(rosary, initial=None, seed=0)``, by their ``--smoother`` names
#: (:data:`foam_mj.smoother_names.SMOOTHERS`): a script picks one by name as ``foam-mj plan --smoother`` does, as
#: :func:`foam_mj.planners.get_planner` picks a planner.
SMOOTHER_CLASSES: dict[str, type[Smoother]] = {
    "hs": HarmonySearch,
    "ga": GeneticAlgorithm,
    "gradient": GradientSmoothing,
    "convex": ConvexShortestPath,
    "optimal": OptimalSmoother,
    "mgoa": MGOASmoother,
    "mopso": MOPSOSmoother,
}


def get_smoother(name: str, **params: Any) -> Smoother:
    """A smoother by its ``--smoother`` name with its parameters (the class's fields, validated by the class): a
    ValueError lists the names for an unknown one ("adjust" moves the bubbles and needs the oracle:
    :class:`RosaryAdjustment`), a TypeError lists the parameters for an unknown parameter."""
    import dataclasses

    from foam_mj.errors import unknown_names

    if not isinstance(name, str) or name not in SMOOTHER_CLASSES:
        if name == "adjust":
            raise ValueError("'adjust' moves the rosary's bubbles and needs the oracle: RosaryAdjustment(r_min=...)"
                             ".adjust(rosary, oracle), then a smoother on its .rosary")
        raise ValueError(f"unknown smoother {unknown_names([name], SMOOTHER_CLASSES)}; known smoothers: {', '.join(SMOOTHER_CLASSES)}")
    cls = SMOOTHER_CLASSES[name]
    fields = [f.name for f in dataclasses.fields(cls) if f.init]  # type: ignore[arg-type]  # (each one a dataclass)
    unknown = [k for k in params if k not in fields]
    if unknown:
        raise TypeError(f"smoother '{name}' ({cls.__name__}) has no parameter {unknown_names(unknown, fields)}; "
                        f"its parameters: {', '.join(fields)}")
    return cls(**params)


__all__ = [
    "PAPER_F_THRESHOLD",
    "PAPER_MAX_ITERATIONS",
    "PAPER_STALL_ITERATIONS",
    "AdjustmentResult",
    "Archive",
    "Certificate",
    "ConvexShortestPath",
    "ConvexSolveError",
    "GOA",
    "GeneticAlgorithm",
    "GradientSmoothing",
    "HarmonySearch",
    "Hatches",
    "MGOA",
    "MGOASmoother",
    "MOPSO",
    "MOPSOSmoother",
    "ObjectiveWeights",
    "OptimalSmoother",
    "PSO",
    "ParetoResult",
    "ParetoSmoother",
    "RosaryAdjustment",
    "RosaryProblem",
    "SMOOTHER_CLASSES",
    "SmoothingResult",
    "Smoother",
    "StopCriteria",
    "build_socp",
    "center_path_result",
    "coordinate_major_objective",
    "error_ratio",
    "get_smoother",
    "hypervolume_2d",
    "kkt_certificate",
    "knee_index",
    "population_objective",
    "set_coverage",
    "sv_and_gradient",
    "tc_and_gradient",
    "thesis_paths",
]
