"""Planners over certified bubbles, interchangeable by name (``foam-mj plan --planner NAME``, or
``algorithm = "NAME"`` in a scenario's ``[planner]`` table).

==============  =====================================================================================
name            what it is
==============  =====================================================================================
pfm             the Probabilistic Foam Method of the papers, breadth-first (foam_mj.planners.pfm)
bubbletree      bidirectional goal-directed tree of certified bubbles + near-shortest corridor (default)
gbpf            goal-biased PFM: the nearest bubble grows toward q_goal or a uniform sample (variants)
rbpf            radius-biased PFM: parents drawn by roulette wheel on their radii (variants)
hpf             heuristic-guided PFM: best-first on g + h, as A* (variants)
==============  =====================================================================================

Add a planner: subclass :class:`~foam_mj.planners.base.Planner` (``name``, ``summary``, a frozen
``Options`` dataclass, ``plan``) and :func:`register` it.
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

from foam_mj.errors import ConfigurationError, PlanningFailed, unknown_names
from foam_mj.planners.base import (
    Planner,
    PlannerConfig,
    PlannerError,
    PlanningProblem,
    PlanResult,
    PlanStats,
    Progress,
    make_options,
)
from foam_mj.planners.bubbletree import BubbleTreePlanner
from foam_mj.planners.pfm import PFMPlanner
from foam_mj.planners.variants import GBPFPlanner, HPFPlanner, RBPFPlanner

#: Every planner by name.
PLANNERS: dict[str, type[Planner]] = {}

#: The planner a scenario uses when its ``[planner]`` table names none (and holds no pfm option).
DEFAULT_PLANNER = "bubbletree"

_P = TypeVar("_P", bound=Planner)


def register(cls: type[_P], *, replace: bool = False) -> type[_P]:
    """Add a planner class to :data:`PLANNERS` under ``cls.name``; TypeError unless it is a :class:`Planner`
    with a non-empty string ``name`` and a frozen dataclass ``Options`` (options are shared, never changed).
    A name another class holds (a built-in's) is refused unless ``replace``: it would change every plan by that name."""
    if not (isinstance(cls, type) and issubclass(cls, Planner)):
        raise TypeError(f"register() takes a subclass of foam_mj.planners.base.Planner, got {cls!r}")
    name = getattr(cls, "name", None)
    if not isinstance(name, str) or not name:
        raise TypeError(f"planner class {cls.__name__}: `name` must be a non-empty string, got {name!r}")
    options = cls.Options
    if not (dataclasses.is_dataclass(options) and options.__dataclass_params__.frozen):  # type: ignore[attr-defined]
        raise TypeError(f"planner '{name}': `Options` must be a frozen dataclass (@dataclass(frozen=True)), got {options.__name__}")
    held = PLANNERS.get(name)
    if held is not None and held is not cls and not replace:
        raise PlannerError(f"planner '{name}' is already registered ({held.__module__}.{held.__qualname__}); choose another "
                           "name, or register(cls, replace=True) to replace it")
    PLANNERS[cls.name] = cls
    return cls


def planner_class(name: str) -> type[Planner]:
    """The planner class called ``name``; :class:`PlannerError` listing the known names otherwise."""
    try:
        return PLANNERS[name]
    except (KeyError, TypeError):
        raise PlannerError(f"unknown planner {unknown_names([name], PLANNERS)}; known planners: {', '.join(sorted(PLANNERS))}") from None


def get_planner(name: str, **options: Any) -> Planner:
    """A planner by name with its options (unknown or invalid options are named in a PlannerError)."""
    cls = planner_class(name)
    return cls(make_options(cls, options))


register(PFMPlanner)
register(BubbleTreePlanner)
for _cls in (GBPFPlanner, RBPFPlanner, HPFPlanner):  # Nascimento et al., Sensors 2021
    register(_cls)

__all__ = [
    "DEFAULT_PLANNER", "PLANNERS", "ConfigurationError", "Planner", "PlannerConfig", "PlannerError", "PlanningFailed",
    "PlanningProblem", "PlanResult", "PlanStats", "Progress", "get_planner", "planner_class", "register",
]
