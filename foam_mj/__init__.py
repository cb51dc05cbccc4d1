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

__version__ = "0.1.0"

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


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'foam_mj' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
