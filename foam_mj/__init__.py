"""foam-mj: certified safe motion planning with the Probabilistic Foam Method over MuJoCo scenes.

The names a user reaches for first are importable from the package itself, as the modules that define them
give them (``foam_mj.get_planner is foam_mj.planners.get_planner``)::

    import foam_mj

    s = foam_mj.load_scenario("obstacle")
    oracle = s.oracle()
    problem = foam_mj.PlanningProblem(oracle, s.q_init, s.q_goal, delta=oracle.delta)
    result = foam_mj.get_planner("bubbletree").plan(problem, seed=0)
    path = foam_mj.get_smoother("optimal").smooth(result.rosary, seed=0)

They are imported on first use (PEP 562), so that ``import foam_mj`` -- and with it every ``foam-mj`` command,
``--help`` included -- does not wait for MuJoCo, SciPy or Clarabel.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

__version__ = "0.1.0"

if TYPE_CHECKING:  # what a type checker sees (the names below are imported on first use at run time)
    from foam_mj.bubbles import BubbleOracle as BubbleOracle
    from foam_mj.clearance import Clearance as Clearance
    from foam_mj.errors import (
        ConfigurationError as ConfigurationError,
        FoamError as FoamError,
        ModelError as ModelError,
        PlanningFailed as PlanningFailed,
        ScenarioError as ScenarioError,
    )
    from foam_mj.model import RobotModel as RobotModel
    from foam_mj.pipeline import run as run
    from foam_mj.planners import (
        PLANNERS as PLANNERS,
        Planner as Planner,
        PlannerError as PlannerError,
        PlanningProblem as PlanningProblem,
        PlanResult as PlanResult,
        PlanStats as PlanStats,
        get_planner as get_planner,
        register as register,
    )
    from foam_mj.rosary import Rosary as Rosary
    from foam_mj.scenarios import (
        Scenario as Scenario,
        available_scenarios as available_scenarios,
        load_scenario as load_scenario,
        scenario_from_dict as scenario_from_dict,
    )
    from foam_mj.smoothing import SMOOTHER_CLASSES as SMOOTHER_CLASSES, get_smoother as get_smoother
    from foam_mj.timing import TimingInfeasible as TimingInfeasible

#: Public name -> the module that defines it.
_EXPORTS: dict[str, str] = {
    # Models and certified bubbles
    "RobotModel": "foam_mj.model",
    "BubbleOracle": "foam_mj.bubbles",
    "Clearance": "foam_mj.clearance",
    "Rosary": "foam_mj.rosary",
    # Scenarios
    "Scenario": "foam_mj.scenarios",
    "available_scenarios": "foam_mj.scenarios",
    "load_scenario": "foam_mj.scenarios",
    "scenario_from_dict": "foam_mj.scenarios",
    # The planner seam
    "PLANNERS": "foam_mj.planners",
    "Planner": "foam_mj.planners",
    "PlanningProblem": "foam_mj.planners",
    "PlanResult": "foam_mj.planners",
    "PlanStats": "foam_mj.planners",
    "get_planner": "foam_mj.planners",
    "register": "foam_mj.planners",
    # Smoothers
    "SMOOTHER_CLASSES": "foam_mj.smoothing",
    "get_smoother": "foam_mj.smoothing",
    # The whole job (plan, smooth, time, replay), as `foam-mj plan`
    "run": "foam_mj.pipeline",
    # Errors
    "FoamError": "foam_mj.errors",
    "ModelError": "foam_mj.errors",
    "ConfigurationError": "foam_mj.errors",
    "ScenarioError": "foam_mj.errors",
    "PlanningFailed": "foam_mj.errors",
    "PlannerError": "foam_mj.planners",
    "TimingInfeasible": "foam_mj.timing",
}

__all__ = ["__version__", *_EXPORTS]


if not TYPE_CHECKING:  # (seen by a type checker, it would make every misspelt foam_mj.<name> an Any)

    def __getattr__(name: str) -> object:
        module = _EXPORTS.get(name)
        if module is None:
            raise AttributeError(f"module 'foam_mj' has no attribute {name!r}")
        value = getattr(import_module(module), name)
        globals()[name] = value  # later lookups skip this function
        return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
