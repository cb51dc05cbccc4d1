"""Scenarios: a scene file, a start and a goal, and the planner's parameters, read from TOML.

Format (every field is checked; an unknown or missing one is named in the error)::

    name = "obstacle"                      # optional, defaults to the file's stem
    description = "..."                    # optional
    scene = "../models/obstacle.xml"       # MJCF scene, relative to the TOML file
    q_init = [0.2, 0.3, 0.08]
    q_goal = [0.45, 0.4536, 1.45]          # or a keyframe's name, e.g. "home": its configuration joints' qpos
    seed = 0                               # optional, default 0
    robot_root = "pelvis"                  # optional: the body whose subtree is the robot (default: every
                                           # body a configuration joint moves); other bodies are obstacles
    self_collision = true                  # optional, default true: also check robot/robot pairs MuJoCo
                                           # lets collide (foam_mj.model)
    keyframe = "home"                      # optional: pose of the joints that are not configuration
                                           # coordinates (default: the keyframe q_init or q_goal names, else qpos0)
    [planner]                              # optional
    algorithm = "pfm"                      # a planner of foam_mj.planners.PLANNERS (see below)
    K = 10                                 # pfm's own options; other planners have others
    r_min = 0.07
    delta = 0.005
    max_bubbles = 200000
    time_limit = 60.0
    [limits]                               # optional; the time law's joint limits, configuration order,
    velocity = [5.0, 5.0, 1.5]             # joint units (rad/s, m/s); default: the model's / JointLimits
    acceleration = [50.0, 50.0, 10.0]      # rad/s^2, m/s^2
    torque = [400.0, 400.0, 3000.0]        # N m, N; default: the MJCF's actuator force ranges
    time_law = "toppra"                    # or "own" (foam_mj.timing)

``delta``, ``max_bubbles`` and ``time_limit`` are shared by every planner; every other field is an
option of the named algorithm (``foam_mj.planners``), checked against its options. Without
``algorithm``, a table holding pfm's options (K, r_min) means pfm, as before the planner seam;
otherwise the default planner (:data:`foam_mj.planners.DEFAULT_PLANNER`).

Optional tables that edit the scene through ``mujoco.MjSpec`` (:mod:`foam_mj.scene_edits`; the MJCF file
itself is never changed)::

    joints = ["hip_flexion", "knee_flexion", "hip_displacement"]  # configuration joints (default: the MJCF's
                                           # declaration, else every limited hinge/slide joint)
    [normalize]                            # per configuration joint: [span] or [qpos_lo, qpos_hi, span] (model.py)
    hip_displacement = [0.0, 0.7, 1.5707963267948966]
    [subject]                              # scale the leg (Winter's segment fractions)
    height = 1.62                          # m
    mass = 58                              # kg
    [obstacle]                             # resize/move/turn the scene's box
    size = [0.2, 0.5, 0.15]                # full extents x, y, z in m
    pos = [0.5, 0.0, 0.075]                # centre, m (default: same x, y and lowest point)
    euler = [0, 0, 30]                     # orientation in the world, degrees, extrinsic x, y, z
    name = "obstacle_box"                  # only needed when the scene has several boxes
    [[mesh]]                               # an obstacle from a mesh file (repeatable)
    file = "kerb.stl"                      # STL/OBJ/PLY, relative to the TOML file
    pos = [0.5, 0.0, 0.0]                  # m
    euler = [0, 0, 90]                     # degrees
    scale = 1.0                            # or [sx, sy, sz]
    decompose = true                       # convex decomposition (CoACD); false: the convex hull
    threshold = 0.05                       # CoACD concavity threshold

:func:`scenario_from_dict` validates a parsed document (so a sweep can override dotted keys such as
``obstacle.size`` or ``subject.height`` before validation); :func:`load_scenario` reads a file.

Built-in scenarios live in the top-level ``scenarios/`` folder (shipped inside the wheel); :func:`load_scenario` takes one of their names or
a path to a TOML file.
"""

from __future__ import annotations

import os
import re
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from foam_mj.bubbles import BubbleOracle, distance_cap
from foam_mj.data import models_dir, scenarios_dir
from foam_mj.clearance import Clearance
from foam_mj.errors import ConfigurationError, FoamError, ModelError, ScenarioError, clearance_text, file_problem, file_problem_text, is_number, text_problem, unknown_names
from foam_mj.geom_pairs import REVOLUTION as _REVOLUTION
from foam_mj.foam import check_candidate_bound
from foam_mj.model import RobotModel
from foam_mj.rosary import fields_equal
from foam_mj.planners import DEFAULT_PLANNER, PlannerConfig, PlannerError, planner_class
from foam_mj.planners.base import COMMON_FIELDS, option_names
from foam_mj.safe_curve import apart_text, coincide
from foam_mj.scene_edits import BoxObstacle, MeshObstacle, SceneEdits, Subject, build_robot
from foam_mj.limits import Limits
from foam_mj.mjcf import load_spec, mocap_apart
from foam_mj.timing import METHODS as TIME_LAWS

SCENARIO_DIR = scenarios_dir()
MODEL_DIR = models_dir()

#: A scenario's name: it names the default recording ``foam-mj-<name>.rrd`` and Rerun entities.
NAME_PATTERN = re.compile(r"^[A-Za-z0-9_.\-]+$")

_TOP_FIELDS = {"name", "description", "scene", "q_init", "q_goal", "seed", "planner", "joints", "normalize", "subject", "obstacle", "mesh", "limits", "robot_root", "self_collision", "keyframe"}
_SUBJECT_FIELDS = {"height", "mass"}
_OBSTACLE_FIELDS = {"size", "pos", "euler", "name"}
_MESH_FIELDS = {"file", "pos", "euler", "scale", "name", "decompose", "threshold"}
#: Plausible ranges for [subject] (adults and adolescents; Winter's table is for adults).
SUBJECT_HEIGHT_RANGE = (1.2, 2.2)  # m
SUBJECT_MASS_RANGE = (25.0, 200.0)  # kg
_LIMITS_FIELDS = {"velocity", "acceleration", "torque", "time_law"}
#: A top-level field written under a table: TOML puts every key after ``[planner]`` into that table.
_TOP_LEVEL = {f: "a top-level field: write it above the first [table]" for f in _TOP_FIELDS}


@dataclass
class Scenario:
    """A planning problem: where (scene), from and to (q_init, q_goal), and how (params: the planner's name, margin,
    budgets and options; seed). ``==`` compares by value (arrays too), not the compiled robot it caches; unhashable."""

    name: str
    description: str
    scene: Path
    q_init: np.ndarray
    q_goal: np.ndarray
    params: PlannerConfig
    seed: int = 0
    source: Path | None = None
    robot_root: str | None = None  # the robot's root body (foam_mj.model); None: every body a coordinate moves
    self_collision: bool = True  # check robot/robot pairs too
    keyframe: str | None = None  # pose of the non-configuration joints; None: qpos0
    _robot: RobotModel | None = field(default=None, repr=False, compare=False)  # a cache of scene + edits
    edits: SceneEdits = field(default_factory=SceneEdits)
    limits: Limits | None = None  # [limits]: the time law's joint limits (None: the model's)
    time_law: str | None = None  # [limits] time_law (None: foam_mj.timing.DEFAULT_METHOD)

    __eq__ = fields_equal  # arrays by value (foam_mj.rosary)

    @property
    def robot(self) -> RobotModel:
        """The compiled scene with the scenario's edits (loaded on first use)."""
        if self._robot is None:
            self._robot = build_robot(self.scene, self.edits, **self.robot_options)
        return self._robot

    @property
    def robot_options(self) -> dict:
        """robot_root, self_collision and keyframe, as keyword arguments of RobotModel.from_xml."""
        return {"robot_root": self.robot_root, "self_collision": self.self_collision, "keyframe": self.keyframe}

    def oracle(self) -> BubbleOracle:
        """A bubble oracle for this scene with the scenario's safety margin."""
        return BubbleOracle(self.robot, delta=self.params.delta)


def available_scenarios() -> list[str]:
    """Names of the built-in scenarios."""
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.toml"))


def resolve_scenario_path(name_or_path: str | Path) -> Path:
    """A built-in scenario's file, or the given path; ScenarioError listing the known names otherwise."""
    if not isinstance(name_or_path, (str, os.PathLike)):
        raise TypeError(f"a scenario is a built-in name or a TOML path, got {type(name_or_path).__name__} "
                        "(for a dict of scenario fields use scenario_from_dict)")
    if not str(name_or_path).strip():
        raise ScenarioError(f"empty scenario name; known scenarios: {', '.join(available_scenarios())}")
    p = Path(name_or_path)
    if p.suffix == ".toml" or os.path.lexists(p) or len(p.parts) > 1:
        problem = file_problem(p)
        if problem == "a folder, not a file":
            raise ScenarioError(f"scenario {p} is a directory, not a scenario TOML file")
        if problem == "not found":
            raise ScenarioError(f"scenario file not found: {p}")
        if problem:
            raise ScenarioError(f"scenario file {p}: {problem}")
        return p
    builtin = SCENARIO_DIR / f"{name_or_path}.toml"
    if file_problem(builtin):
        raise ScenarioError(f"unknown scenario {unknown_names([str(name_or_path)], available_scenarios())}; known scenarios: "
                            f"{', '.join(available_scenarios())}")
    return builtin


def _number_list(value, where: str, n: int | None = None) -> np.ndarray:
    if isinstance(value, np.ndarray) and value.ndim == 1:  # from Python: a numpy vector is a list of numbers
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or not all(is_number(v) for v in value):
        raise ScenarioError(f"{where} must be a list of numbers, got {value!r}")
    if n is not None and len(value) != n:
        raise ScenarioError(f"{where} must have {n} numbers, got {len(value)}")
    return np.array(value, dtype=float)


def _end_point(value, where: str, robot, held_at: str | None = None) -> np.ndarray:
    """q_init or q_goal: a list of numbers (q), or the name of one of the scene's keyframes (``<key name="home">``),
    whose qpos gives the configuration joints' values; its other joints are held at the scenario's own ``keyframe``,
    or without one at the first end point's keyframe (``held_at``): a second keyframe that puts them elsewhere is
    refused, since they stay at one pose along a path. ``robot()`` compiles the scene."""
    if not isinstance(value, str):
        return _number_list(value, where)
    import mujoco

    m = robot().model
    k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, value) if value else -1
    if k < 0:
        names = [n for n in (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_KEY, i) for i in range(m.nkey)) if n]
        raise ScenarioError(f"{where} = {value!r} is no keyframe of the scene (its named keyframes: "
                            f"{', '.join(names) if names else 'none'}); give one number per configuration joint or a keyframe's name")
    config = robot().config
    if held_at is not None and value != held_at:
        held = np.setdiff1d(np.arange(m.nq), config.qpos_index)
        apart = held[np.abs(m.key_qpos[k][held] - config.qpos0[held]) > 1e-9]
        moved = mocap_apart(m, k, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, held_at))  # obstacles stay put too
        if len(apart) or moved:
            joints = [f"{_qpos_joint(m, int(a))} {m.key_qpos[k][a]:.6g} (not {config.qpos0[a]:.6g})" for a in apart[:4]] + moved[:4]
            kinds = " and ".join(t for t, on in (("joints outside the configuration", len(apart)), ("mocap bodies", moved)) if on)
            raise ScenarioError(
                f"{where} = {value!r}: that keyframe puts {kinds} elsewhere than keyframe {held_at!r}, "
                f"where the other end point holds them ({', '.join(joints)}{', ...' if len(apart) > 4 or len(moved) > 4 else ''}), "
                "and they stay at one pose along a path: name the pose to hold them at (keyframe = \"NAME\" in a scenario), "
                f"{'plan over them too (joints), ' if len(apart) else ''}or give this end point as numbers")
    return np.asarray(config.to_q(m.key_qpos[k]), dtype=float)


def _qpos_joint(m, adr: int) -> str:
    """The name of the joint whose qpos holds address ``adr`` (with its component for a free or ball joint)."""
    import mujoco

    j = int(np.searchsorted(m.jnt_qposadr, adr, side="right") - 1)
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint {j}"
    return name if adr == int(m.jnt_qposadr[j]) and int(m.jnt_type[j]) > 1 else f"{name}[{adr - int(m.jnt_qposadr[j])}]"


def _first_keyframe(scene: Path, raw: dict) -> str:
    """The name of the first end point (q_init, then q_goal) that names a keyframe of the scene, or ""."""
    names: list[str] = [raw[f] for f in ("q_init", "q_goal") if isinstance(raw.get(f), str)]
    if not names:
        return ""
    try:
        keys = {k.name for k in load_spec(scene).keys}
    except ModelError:
        return ""  # the scene's own error is reported where it compiles
    return next((n for n in names if n in keys), "")


def _number(value, where: str, lo: float | None = None, hi: float | None = None) -> float:
    if not is_number(value):
        raise ScenarioError(f"{where} must be a number, got {value!r}")
    if (lo is not None and not value >= lo) or (hi is not None and not value <= hi):
        raise ScenarioError(f"{where} must be in [{lo}, {hi}], got {value!r}")
    return float(value)


def _table(raw: dict, key: str, fields: set[str], where: str) -> dict | None:
    value = raw.get(key)
    if value is None:
        return None
    if not isinstance(value, dict):
        raise ScenarioError(f"{where}: [{key}] must be a table")
    unknown = set(value) - fields
    if unknown:
        raise ScenarioError(f"{where}: unknown [{key}] field(s) {unknown_names(unknown, fields, _TOP_LEVEL)}; expected {sorted(fields)}")
    return value


#: The largest [obstacle] size or position (m): MuJoCo overflowed beyond (size 1e300: "size 1 must be positive").
MAX_METRES = 1e6


def _vec3(value, where: str, positive: bool = False, most: float = np.inf) -> tuple[float, float, float]:
    arr = _number_list(value, where, 3)
    if not np.all(np.isfinite(arr)) or (positive and not np.all(arr > 0)):
        raise ScenarioError(f"{where} must be 3 finite numbers{' > 0' if positive else ''}, got {value!r}")
    if np.any(np.abs(arr) > most):
        raise ScenarioError(f"{where} must be 3 numbers of magnitude at most {most:g}, got {value!r}")
    return tuple(float(v) for v in arr)  # type: ignore[return-value]


def _scene_edits(raw: dict, where: str, base_dir: Path) -> SceneEdits:
    joints = raw.get("joints")
    if joints is not None:
        if not isinstance(joints, (list, tuple)) or not joints or not all(isinstance(j, str) and j for j in joints):
            raise ScenarioError(f"{where}: field 'joints' must be a non-empty list of joint names, got {joints!r}")
        joints = tuple(joints)
    normalize = raw.get("normalize", {})
    if not isinstance(normalize, dict):
        raise ScenarioError(f"{where}: [normalize] must be a table of joint = [span] or [qpos_lo, qpos_hi, span]")
    norm: dict[str, tuple[float, ...]] = {}
    for joint, value in normalize.items():
        value = [value] if isinstance(value, (int, float)) and not isinstance(value, bool) else value
        arr = _number_list(value, f"{where}: [normalize] field '{joint}'")
        if arr.size not in (1, 3):
            raise ScenarioError(f"{where}: [normalize] field '{joint}' must be [span] or [qpos_lo, qpos_hi, span], got {value!r}")
        norm[joint] = tuple(float(v) for v in arr)
    subject = None
    t = _table(raw, "subject", _SUBJECT_FIELDS, where)
    if t is not None:
        h = None if t.get("height") is None else _number(t["height"], f"{where}: [subject] field 'height' (m)", *SUBJECT_HEIGHT_RANGE)
        m = None if t.get("mass") is None else _number(t["mass"], f"{where}: [subject] field 'mass' (kg)", *SUBJECT_MASS_RANGE)
        subject = Subject(h, m) if (h is not None or m is not None) else None
    obstacle = None
    t = _table(raw, "obstacle", _OBSTACLE_FIELDS, where)
    if t is not None:
        size = None if t.get("size") is None else _vec3(t["size"], f"{where}: [obstacle] field 'size' (full extents x, y, z in m)", positive=True, most=MAX_METRES)
        pos = None if t.get("pos") is None else _vec3(t["pos"], f"{where}: [obstacle] field 'pos' (m)", most=MAX_METRES)
        euler = None if t.get("euler") is None else _vec3(t["euler"], f"{where}: [obstacle] field 'euler' (degrees)")
        name = t.get("name")
        if name is not None and (not isinstance(name, str) or not name):
            raise ScenarioError(f"{where}: [obstacle] field 'name' must be a geom name")
        obstacle = BoxObstacle(size, pos, name, euler) if any(v is not None for v in (size, pos, name, euler)) else None
    meshes = []
    mesh_list = raw.get("mesh", [])
    if isinstance(mesh_list, dict):
        mesh_list = [mesh_list]
    if not isinstance(mesh_list, list):
        raise ScenarioError(f"{where}: [[mesh]] must be an array of tables")
    for i, t in enumerate(mesh_list):
        w = f"{where}: [[mesh]] #{i + 1}"
        if not isinstance(t, dict):
            raise ScenarioError(f"{w} must be a table")
        unknown = set(t) - _MESH_FIELDS
        if unknown:
            raise ScenarioError(f"{w}: unknown field(s) {unknown_names(unknown, _MESH_FIELDS, _TOP_LEVEL)}; expected {sorted(_MESH_FIELDS)}")
        if not isinstance(t.get("file"), str):
            raise ScenarioError(f"{w}: field 'file' (a mesh file path) is missing")
        f = (base_dir / t["file"]).resolve()
        problem = file_problem_text(f, "mesh file")
        if problem:
            raise ScenarioError(f"{w}: field 'file': {problem}")
        if f.suffix.lower() not in (".stl", ".obj", ".ply"):
            raise ScenarioError(f"{w}: field 'file': {f.name} is not an STL, OBJ or PLY file")
        scale = t.get("scale", 1.0)
        if isinstance(scale, (int, float)) and not isinstance(scale, bool):
            scale = [scale] * 3
        decompose = t.get("decompose", True)
        if not isinstance(decompose, bool):
            raise ScenarioError(f"{w}: field 'decompose' must be true or false")
        name = t.get("name")
        if name is not None and (not isinstance(name, str) or not name):
            raise ScenarioError(f"{w}: field 'name' must be a non-empty string")
        meshes.append(MeshObstacle(
            f, _vec3(t.get("pos", [0, 0, 0]), f"{w}: field 'pos' (m)"), _vec3(t.get("euler", [0, 0, 0]), f"{w}: field 'euler' (degrees)"),
            _vec3(scale, f"{w}: field 'scale'", positive=True), name, decompose,
            _number(t.get("threshold", 0.05), f"{w}: field 'threshold'", 0.01, 1.0),
        ))
    return SceneEdits(joints, norm, subject, obstacle, tuple(meshes))


def read_scenario_doc(name_or_path: str | Path) -> tuple[dict, Path]:
    """The parsed TOML document of a scenario (built-in name or path) and its file, not yet validated."""
    path = resolve_scenario_path(name_or_path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8-sig")), path  # TOML is UTF-8; a byte-order mark is let through
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: malformed TOML: {exc}") from None
    except RecursionError:  # arrays nested thousands deep: an internal error (exit 1)
        raise ScenarioError(f"{path}: malformed TOML: nested too deeply to read") from None
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: {text_problem(exc)}") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read: {exc}") from None


def load_scenario(name_or_path: str | Path, *, check: bool = True) -> Scenario:
    """Read and validate a scenario (built-in name or TOML path).

    With ``check`` (the default) the scene is loaded and q_init and q_goal are refused when out of the
    bounds or closer to an obstacle than the safety margin, with their clearance in the message.
    """
    raw, path = read_scenario_doc(name_or_path)
    return scenario_from_dict(raw, path.parent, source=path, check=check)


def scenario_from_dict(doc: dict, base_dir: str | Path, *, source: Path | None = None, check: bool = True) -> Scenario:
    """Validate a parsed scenario document (the TOML's tables as dicts) into a :class:`Scenario`.

    Relative paths (``scene``, mesh files) are relative to ``base_dir``; ``source`` (the TOML file, if
    any) names the scenario in messages and gives the default name. ``check`` as in :func:`load_scenario`.
    Where the TOML has an array of numbers, a tuple or a 1-D numpy array will do; numpy numbers are numbers.
    """
    raw = doc
    if not isinstance(base_dir, (str, os.PathLike)):
        raise TypeError(f"`base_dir` (the folder relative paths start from) must be a path, got {type(base_dir).__name__}")
    base_dir = Path(base_dir)
    path = source if source is not None else "scenario"
    if not isinstance(raw, dict):
        raise ScenarioError(f"{path}: a scenario must be a table, got {type(raw).__name__}")
    unknown = set(raw) - _TOP_FIELDS
    if unknown:
        raise ScenarioError(f"{path}: unknown field(s) {unknown_names(unknown, _TOP_FIELDS)}; expected {sorted(_TOP_FIELDS)}")
    for req in ("scene", "q_init", "q_goal"):
        if req not in raw:
            raise ScenarioError(f"{path}: missing field '{req}'")
    # A name the user did not write (the file's stem) is made safe; a written one must already be.
    name = raw.get("name", re.sub(r"[^A-Za-z0-9_.\-]", "_", source.stem) if source is not None else "scenario")
    description = raw.get("description", "")
    if not isinstance(name, str) or not NAME_PATTERN.match(name):
        raise ScenarioError(
            f"{path}: field 'name' must be letters, digits, '_', '-' or '.' (it names output files and recording "
            f"entities), got {name!r}"
        )
    if not isinstance(description, str):
        raise ScenarioError(f"{path}: field 'description' must be a string")
    if not isinstance(raw["scene"], (str, Path)):
        raise ScenarioError(f"{path}: field 'scene' must be a path string")
    scene = (base_dir / raw["scene"]).resolve()
    problem = file_problem(scene)
    if problem == "a folder, not a file":  # scene = "" or a folder: "MJCF file not found" named an existing folder
        raise ScenarioError(f"{path}: field 'scene' = {str(raw['scene'])!r} names the folder {scene}, not an MJCF file")
    if problem:
        raise ScenarioError(f"{path}: field 'scene': {file_problem_text(scene, 'MJCF file')}")
    seed = raw.get("seed", 0)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or not 0 <= seed <= 2**63 - 1:
        raise ScenarioError(f"{path}: field 'seed' must be an integer in [0, 2**63 - 1], got {seed!r}")
    seed = int(seed)
    robot_root, keyframe = raw.get("robot_root"), raw.get("keyframe")
    for key, value in (("robot_root", robot_root), ("keyframe", keyframe)):
        if value is not None and (not isinstance(value, str) or not value):
            raise ScenarioError(f"{path}: field '{key}' must be a name (a non-empty string), got {value!r}")
    self_collision = raw.get("self_collision", True)
    if not isinstance(self_collision, bool):
        raise ScenarioError(f"{path}: field 'self_collision' must be true or false, got {self_collision!r}")
    planner = raw.get("planner", {})
    if not isinstance(planner, dict):
        raise ScenarioError(f"{path}: [planner] must be a table")
    algorithm = planner.get("algorithm")
    if algorithm is not None and not isinstance(algorithm, str):
        raise ScenarioError(f"{path}: [planner] field 'algorithm' must be a planner name, got {algorithm!r}")
    if algorithm is None:
        algorithm = "pfm" if ("K" in planner or "r_min" in planner) else DEFAULT_PLANNER
    try:
        cls = planner_class(algorithm)
    except PlannerError as exc:
        raise ScenarioError(f"{path}: [planner] field 'algorithm': {exc}") from None
    own = option_names(cls)
    unknown = set(planner) - set(COMMON_FIELDS) - set(own)
    if unknown:
        expected = sorted(COMMON_FIELDS) + sorted(own)
        raise ScenarioError(f"{path}: unknown [planner] field(s) {unknown_names(unknown, expected, _TOP_LEVEL)} for algorithm "
                            f"'{algorithm}'; expected {expected}")
    defaults = {f.name: f.default for f in fields(cls.Options)}
    for key, value in planner.items():
        numeric = key in ("delta", "max_bubbles", "time_limit") or (
            isinstance(defaults.get(key), (int, float)) and not isinstance(defaults.get(key), bool)
        )
        if numeric and not is_number(value):
            raise ScenarioError(f"{path}: [planner] field '{key}' must be a number, got {value!r}")
    try:
        params = PlannerConfig.from_dict(planner)
    except (PlannerError, ValueError) as exc:
        raise ScenarioError(f"{path}: [planner] {exc}") from None
    edits = _scene_edits(raw, str(path), base_dir)
    implied = keyframe is None and _first_keyframe(scene, raw)
    if implied:  # an end point is a keyframe: the other joints stay at that pose, as the model keeps the robot there
        keyframe = implied
    robots: list[RobotModel] = []  # the scene, compiled only when an end point names a keyframe

    def robot() -> RobotModel:
        if not robots:
            try:
                robots.append(build_robot(scene, edits, robot_root=robot_root, self_collision=self_collision, keyframe=keyframe))
            except FoamError as exc:
                raise ScenarioError(f"{path}: field 'scene': {exc}") from None
        return robots[0]

    q_init, q_goal = (_end_point(raw[f], f"{path}: field '{f}'", robot, implied or None) for f in ("q_init", "q_goal"))
    scenario = Scenario(
        name, description, scene, q_init, q_goal, params, seed, source,
        robot_root=robot_root, self_collision=self_collision, keyframe=keyframe, edits=edits,
    )
    scenario.limits, scenario.time_law = _limits(raw.get("limits"), path)
    if check:
        check_scenario(scenario, robots[0] if robots else None)  # the scene compiled once, for a keyframe end point
    return scenario


def _limits(table, path: Path | str) -> tuple[Limits | None, str | None]:
    """The [limits] table: velocity, acceleration, torque (lists of numbers > 0) and time_law."""
    if table is None:
        return None, None
    if not isinstance(table, dict):
        raise ScenarioError(f"{path}: [limits] must be a table")
    unknown = set(table) - _LIMITS_FIELDS
    if unknown:
        raise ScenarioError(f"{path}: unknown [limits] field(s) {unknown_names(unknown, _LIMITS_FIELDS, _TOP_LEVEL)}; expected {sorted(_LIMITS_FIELDS)}")
    lists: dict = {}
    for key in ("velocity", "acceleration", "torque"):
        if key in table:
            vals = _number_list(table[key], f"{path}: [limits] field '{key}'")
            if len(vals) == 0 or not np.all(np.isfinite(vals) & (vals > 0)):
                raise ScenarioError(f"{path}: [limits] field '{key}' must be a non-empty list of numbers > 0, got {table[key]!r}")
            lists[key] = tuple(vals.tolist())
    law = table.get("time_law")
    if law is not None and law not in TIME_LAWS:
        raise ScenarioError(f"{path}: [limits] field 'time_law' must be one of {list(TIME_LAWS)}, got {law!r}")
    return (Limits(**lists) if lists else None), law


def _meet_at_a_joint(robot: RobotModel, a: int, b: int) -> bool:
    """Is robot geom ``a`` on a body whose parent is welded to the world with obstacle geom ``b`` (a first link on
    its fixed base)? MuJoCo's parent/child filter exempts the world, so such a pair is checked."""
    m = robot.model
    fixed = int(m.geom_bodyid[b])
    return int(m.body_weldid[fixed]) == 0 and fixed == int(m.body_parentid[m.body_weldid[m.geom_bodyid[a]]])


def _fixed_root(robot: RobotModel, g: int) -> str:
    """The name of the world's child whose subtree holds geom g's body (a robot's base, fixed to the world)."""
    m = robot.model
    b = int(m.geom_bodyid[g])
    while int(m.body_parentid[b]) != 0:
        b = int(m.body_parentid[b])
    return m.body(b).name or f"body {b}"


def _held(robot: RobotModel, g: int) -> bool:
    """Is geom g on a body that a joint moves, none of them a configuration joint (a floating base, a stance leg)?"""
    from foam_mj.geom_pairs import body_is_moving

    return bool(body_is_moving(robot.model, int(robot.model.geom_bodyid[g])) and not robot.moves[g].any())


def check_scenario(scenario: Scenario, robot: RobotModel | None = None, *, check_clearance: bool = True) -> None:
    """Load the scene (unless its compiled ``robot`` is given, e.g. a sweep worker's cached one) and check
    q_init and q_goal: shape, bounds, and (unless ``check_clearance`` is false) clearance above the margin."""
    where = scenario.source or scenario.name
    if robot is None:
        try:
            robot = build_robot(scenario.scene, scenario.edits, **scenario.robot_options)
        except FoamError as exc:
            raise ScenarioError(f"{where}: field 'scene': {exc}") from None
    for field_name in ("q_init", "q_goal"):  # shape, finiteness and bounds first: 1e308 overflowed the comparison below
        try:
            robot.validate(getattr(scenario, field_name), field_name)
        except ConfigurationError as exc:
            raise ScenarioError(f"{where}: field '{field_name}': {exc}") from None
    if coincide(scenario.q_init, scenario.q_goal):
        raise ScenarioError(f"{where}: fields 'q_goal' and 'q_init' are equal{apart_text(scenario.q_init, scenario.q_goal)} "
                            f"({np.asarray(scenario.q_init).tolist()}): nothing to plan")
    try:
        check_candidate_bound(scenario.params, robot.lower, robot.upper)
    except ConfigurationError as exc:
        raise ScenarioError(f"{where}: [planner] {exc}") from None
    try:  # the [limits] table against the joints, and the MJCF's own foam_mj:limits:<joint> fields
        (scenario.limits or Limits()).resolve(robot)
    except ModelError as exc:
        raise ScenarioError(f"{where}: field 'scene': {exc}") from None
    except ValueError as exc:
        raise ScenarioError(f"{where}: [limits] {exc}") from None
    clearance = Clearance(robot, distmax=distance_cap(robot, scenario.params.delta))
    try:
        for field_name in ("q_init", "q_goal"):
            if not check_clearance:
                continue
            q = np.asarray(getattr(scenario, field_name), dtype=float)
            d = clearance(q)
            # A link turned about the axis of a fixed sphere, capsule or cylinder (its pedestal, a held pelvis) is a pair no
            # joint changes, out of the clearance: an end point within delta of it is named as on others, with the way out.
            fixed = min((t for t in robot.fixed_obstacle_distances if int(robot.model.geom_type[t[1]]) in _REVOLUTION),
                        key=lambda t: t[2], default=(0, 0, np.inf))
            if min(d, fixed[2]) <= scenario.params.delta:
                i = int(np.argmin(clearance.pair_distances(q))) if d <= fixed[2] else -1  # -1: the fixed pair
                a, b = robot.pairs[i] if i >= 0 else fixed[:2]
                own = i >= 0 and bool(np.asarray(robot.self_pair)[i])  # a robot/robot pair: no obstacle in it
                d = min(d, fixed[2])
                state = "in collision" if d < 0 else "too close to itself" if own else "too close to an obstacle"
                hint = robot.hull_hint(int(a), int(b))
                if own:
                    import mujoco

                    bodies = [mujoco.mj_id2name(robot.model, mujoco.mjtObj.mjOBJ_BODY, int(robot.model.geom_bodyid[g])) or f"body {int(robot.model.geom_bodyid[g])}" for g in (a, b)]
                    hint += (f"; a robot/robot pair: if these links overlap by design, add <contact><exclude body1=\"{bodies[0]}\" "
                            f"body2=\"{bodies[1]}\"/> to the MJCF, or leave self-collision out (--no-self-collision; "
                            "self_collision = false in a scenario)")
                elif _meet_at_a_joint(robot, int(a), int(b)):
                    root = _fixed_root(robot, int(b))
                    hint += (f"; {robot.geom_name(int(a))} is on a link jointed to the fixed body of {robot.geom_name(int(b))}: they "
                            "are checked like any robot/obstacle pair (<contact><exclude> does not apply); if that body is the "
                            f"robot's base, name its root (--robot-root {root}; robot_root = \"{root}\" in a scenario) and the "
                            "pair follows MuJoCo's contact filters as self-collision (a checker counting every static geom as an "
                            "obstacle still reads it), else shorten one so they keep delta apart, or give the fixed one "
                            "contype=\"0\" conaffinity=\"0\"")
                elif _held(robot, int(b)):
                    hint += (f"; {robot.geom_name(int(b))} is on a body that a joint outside the configuration moves, held at its pose "
                            "as an obstacle whatever contype/conaffinity say: if it is part of the robot (a floating base, the other "
                            "leg), name the robot's root body (--robot-root; robot_root in a scenario), and its pairs with the planned "
                            "links follow MuJoCo's contact filters as self-collision")
                keyframe_flag = f" --keyframe {scenario.keyframe}" if scenario.keyframe else ""  # bubble holds the rest there too
                raise ScenarioError(
                    f"{where}: field '{field_name}' = {q.tolist()} is {state}: clearance {clearance_text(d, scenario.params.delta)} "
                    f"between {robot.geom_label(int(a))} and {robot.geom_label(int(b))} "
                    f"(the safety margin delta is {scenario.params.delta} m; `foam-mj bubble{keyframe_flag}` shows more){hint}"
                )
        if check_clearance:  # a per-plan check in a sweep, as the clearance's (see check_clearance)
            try:
                robot.check_fixed_pairs(scenario.params.delta)
                robot.check_margins(scenario.params.delta)
            except ConfigurationError as exc:
                raise ScenarioError(f"{where}: field 'scene': {exc}") from None
    finally:
        clearance.close()
    scenario._robot = robot
