"""Scenarios: a scene file, a start and a goal, and the planner's parameters, read from TOML.

Format (every field is checked; an unknown or missing one is named in the error)::

    name = "obstacle"                      # optional, defaults to the file's stem
    description = "..."                    # optional
    scene = "../models/obstacle.xml"       # MJCF scene, relative to the TOML file
    q_init = [0.2, 0.3, 0.08]
    q_goal = [0.45, 0.4536, 1.45]
    seed = 0                               # optional, default 0
    [planner]                              # optional; defaults are FoamParams'
    K = 10
    r_min = 0.07
    delta = 0.005
    max_bubbles = 200000
    time_limit = 60.0

Built-in scenarios live in the top-level ``scenarios/`` folder (shipped inside the wheel); :func:`load_scenario` takes one of their names or
a path to a TOML file.
"""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from foam_mj.bubbles import BubbleOracle
from foam_mj.data import models_dir, scenarios_dir
from foam_mj.clearance import Clearance
from foam_mj.errors import ConfigurationError, FoamError, ScenarioError
from foam_mj.foam import FoamParams
from foam_mj.model import RobotModel

SCENARIO_DIR = scenarios_dir()
MODEL_DIR = models_dir()

_TOP_FIELDS = {"name", "description", "scene", "q_init", "q_goal", "seed", "planner"}
_PLANNER_FIELDS = {f.name for f in dataclasses.fields(FoamParams)}


@dataclass
class Scenario:
    """A planning problem: where (scene), from and to (q_init, q_goal), and how (params, seed)."""

    name: str
    description: str
    scene: Path
    q_init: np.ndarray
    q_goal: np.ndarray
    params: FoamParams
    seed: int = 0
    source: Path | None = None
    _robot: RobotModel | None = field(default=None, repr=False)

    @property
    def robot(self) -> RobotModel:
        """The compiled scene (loaded on first use)."""
        if self._robot is None:
            self._robot = RobotModel.from_xml(self.scene)
        return self._robot

    def oracle(self) -> BubbleOracle:
        """A bubble oracle for this scene with the scenario's safety margin."""
        return BubbleOracle(self.robot, delta=self.params.delta)


def available_scenarios() -> list[str]:
    """Names of the built-in scenarios."""
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.toml"))


def resolve_scenario_path(name_or_path: str | Path) -> Path:
    """A built-in scenario's file, or the given path; ScenarioError listing the known names otherwise."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists() or len(p.parts) > 1:
        if not p.is_file():
            raise ScenarioError(f"scenario file not found: {p}")
        return p
    builtin = SCENARIO_DIR / f"{name_or_path}.toml"
    if not builtin.is_file():
        raise ScenarioError(f"unknown scenario '{name_or_path}'; known scenarios: {', '.join(available_scenarios())}")
    return builtin


def _number_list(value, where: str, n: int | None = None) -> np.ndarray:
    if not isinstance(value, list) or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        raise ScenarioError(f"{where} must be a list of numbers, got {value!r}")
    if n is not None and len(value) != n:
        raise ScenarioError(f"{where} must have {n} numbers, got {len(value)}")
    return np.array(value, dtype=float)


def load_scenario(name_or_path: str | Path, *, check: bool = True) -> Scenario:
    """Read and validate a scenario (built-in name or TOML path).

    With ``check`` (the default) the scene is loaded and q_init and q_goal are refused when out of the
    bounds or closer to an obstacle than the safety margin, with their clearance in the message.
    """
    path = resolve_scenario_path(name_or_path)
    try:
        raw = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: malformed TOML: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: cannot read: {exc}") from None
    unknown = set(raw) - _TOP_FIELDS
    if unknown:
        raise ScenarioError(f"{path}: unknown field(s) {sorted(unknown)}; expected {sorted(_TOP_FIELDS)}")
    for req in ("scene", "q_init", "q_goal"):
        if req not in raw:
            raise ScenarioError(f"{path}: missing field '{req}'")
    name = raw.get("name", path.stem)
    description = raw.get("description", "")
    if not isinstance(name, str) or not name:
        raise ScenarioError(f"{path}: field 'name' must be a non-empty string")
    if not isinstance(description, str):
        raise ScenarioError(f"{path}: field 'description' must be a string")
    if not isinstance(raw["scene"], str):
        raise ScenarioError(f"{path}: field 'scene' must be a path string")
    scene = (path.parent / raw["scene"]).resolve()
    if not scene.is_file():
        raise ScenarioError(f"{path}: field 'scene': MJCF file not found: {scene}")
    seed = raw.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ScenarioError(f"{path}: field 'seed' must be an integer >= 0, got {seed!r}")
    planner = raw.get("planner", {})
    if not isinstance(planner, dict):
        raise ScenarioError(f"{path}: [planner] must be a table")
    unknown = set(planner) - _PLANNER_FIELDS
    if unknown:
        raise ScenarioError(f"{path}: unknown [planner] field(s) {sorted(unknown)}; expected {sorted(_PLANNER_FIELDS)}")
    for key, value in planner.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ScenarioError(f"{path}: [planner] field '{key}' must be a number, got {value!r}")
    try:
        params = FoamParams(**planner)
    except ValueError as exc:
        raise ScenarioError(f"{path}: [planner] {exc}") from None
    q_init = _number_list(raw["q_init"], f"{path}: field 'q_init'")
    q_goal = _number_list(raw["q_goal"], f"{path}: field 'q_goal'")
    scenario = Scenario(name, description, scene, q_init, q_goal, params, seed, path)
    if check:
        check_scenario(scenario)
    return scenario


def check_scenario(scenario: Scenario) -> None:
    """Load the scene and check q_init and q_goal: shape, bounds, and clearance above the margin."""
    where = scenario.source or scenario.name
    try:
        robot = RobotModel.from_xml(scenario.scene)
    except FoamError as exc:
        raise ScenarioError(f"{where}: field 'scene': {exc}") from None
    clearance = Clearance(robot)
    try:
        for field_name in ("q_init", "q_goal"):
            q = getattr(scenario, field_name)
            try:
                robot.validate(q, field_name)
            except ConfigurationError as exc:
                raise ScenarioError(f"{where}: field '{field_name}': {exc}") from None
            d = clearance(q)
            if d <= scenario.params.delta:
                state = "in collision" if d < 0 else "too close to an obstacle"
                raise ScenarioError(
                    f"{where}: field '{field_name}' = {q.tolist()} is {state}: clearance {d:.4f} m "
                    f"(the safety margin delta is {scenario.params.delta} m)"
                )
    finally:
        clearance.close()
    scenario._robot = robot
