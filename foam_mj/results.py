"""The JSON result of ``foam-mj plan --json``: enough to check it independently with MuJoCo alone
(``foam-mj verify``, or any checker that reads "mjcf" and every path's "qpos") and to replay it later.

Layout (format "foam-mj/result", version 1)::

    {
      "format": "foam-mj/result", "version": 1,
      "scenario": "obstacle", "scenario_file": "/abs/path/obstacle.toml",
      "mjcf": "/abs/path/to/scene.xml",               # the compiled scene
      "mjcf_relative": "../models/scene.xml",          # the same, relative to the result file's folder
      "model_hash": {"sha256": ..., "parts": {"kinematics", "geometry", "dynamics", "declarations"}},
      "scene_source": "/abs/path/obstacle.xml",        # only when the scenario edits its scene (joints,
      "scene_edits": {"subject": {...}, ...},          # [subject], [obstacle], [[mesh]]): then "mjcf" is
                                                       # <result>.scene.xml, the edited scene saved beside it
      "qpos_joints": ["hip_displacement", ...],        # names of the qpos entries, in qpos order
      "configuration": {"joints": [...], "lower": [...], "upper": [...],
                        "qpos_index": [...], "scale": [...], "offset": [...], "qpos0": [...]},
      "q_init": [...], "q_goal": [...], "seed": 0,
      "planner": {"algorithm": "pfm", "delta": 0.005, "max_bubbles": ..., "time_limit": ..., "K": 10, "r_min": 0.07},  # + the algorithm's options
      "robot": {"robot_root": null, "self_collision": true, "keyframe": null},  # what the robot is (foam_mj.model); replay rebuilds the same pairs
      "outcome": "reached" | "queue empty" | "bubble budget" | "time budget" | "stalled",
      "foam": {"stats": {"planner", "outcome", "bubbles", "distance_queries", "elapsed", "time_to_first_path", ...},
               "centers": [[...], ...], "radii": [...], "parents": [...]},   # every bubble
      "rosary": {"centers": [[...], ...], "radii": [...], "bubble_ids": [...]},
      "timings": {"plan": ..., "smooth": ..., "replay": ..., "total": ...},  # seconds of wall time per phase
      "paths": {
        "<name>": {
          "label": "centre (T)",
          "waypoints": [[q], ...],                     # the configuration-space polyline [q_init, ..., q_goal]
          "rosary": {"centers": ..., "radii": ...},     # the rosary whose hatches hold the waypoints
          "qpos": [[qpos], ...],                        # the joint trajectory, rows of MuJoCo qpos
          "times": [...],                               # seconds, one per qpos row
          "metrics": {"length", "angle_term", "f", "tc", "sv", "n_points"},
          "smoother": {"method", "iterations", "evaluations", "wall_time", "stop_reason", ...},
          "convergence": {"best": [...], "mean": [...]},      # objective per iteration
          "pareto_front": {"objectives": [[length, angle term], ...], "knee": i, "paths": [...]},  # mgoa, mopso
          "certificate": {"certified", "kkt_stationarity", "kkt_complementarity", "kkt_tol",      # optimal only
                          "straight_vertices", "active_constraints", "tied_waypoints", "objective_value",
                          "weights", "best_start", "starts", ...},
          "replay": {"min_clearance": ..., "duration": ...,         # kinematic replay; the rest from the dynamic one
                     "max_error": [...], "rms_error": [...], "contacts": N, "joints": [...], "dynamic_min_clearance": ...},
          "dynamics": {"joints", "torque_units", "peak_torque", "rms_torque", "peak_power", "positive_work",
                       "negative_work", "torque_limit", "peak_use", "body_mass", "peak_torque_per_kg"}
        }, ...
      },
      "limits": {"joints": [...], "velocity": [...], "acceleration": [...], "torque": [...]},  # joint units
      "time_law": "toppra" | "own"
    }

"dynamics" (foam_mj.dynamics): joint torques from ``mj_inverse`` along the timed trajectory, per
configuration joint (N m for hinges, N for slides): peak and RMS torque, peak power (W), positive and
negative work (J), the MJCF's torque limit (null: none) and the peak's share of it, and the peak per
kilogram of the subject's body mass. "limits" and "time_law" are what the trajectories were timed with
(foam_mj.timing); ``replay`` and ``export`` rebuild the same trajectories from them and the waypoints, and refuse
a path whose saved "qpos" or "times" differ from the rebuilt trajectory by more than :data:`TRAJECTORY_TOL` (edited
by hand: they would replay another motion than the one ``verify`` checked), naming the path and the first such row.

"configuration" holds the affine map between the planner's q and MuJoCo's qpos:
``qpos = qpos0; qpos[qpos_index] = offset + scale * q`` (q may be normalized, e.g. the Ortholeg's hip slide).
"model_hash" is :func:`foam_mj.fingerprint.model_fingerprint` of the compiled scene: ``replay`` refuses
a scene that compiles to a different model (exit 2 naming the part that differs), and "version" other
than :data:`VERSION` is refused too.

When ``plan`` has no time-parametrized trajectory (``--no-replay``), "qpos" holds the waypoints'
qpos rows (a polyline in qpos, which is affine in q) and "times" is absent; so it is for a path that no timing
fits the limits (``plan --smoother all`` with tight torque limits), whose "timing_error" says why: the other paths
keep their trajectories.

"certificate" (the optimal smoother's path only): "certified" is true when the path is a local optimum of
its objective (f, Nascimento et al. 2020 Eq. 5, by default) over the hatches to the tolerance "kkt_tol": the first-order
(KKT) residuals "kkt_stationarity" (scaled) and "kkt_complementarity" are both at most it. A number that
is not finite is written as null.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Callable

import mujoco
import numpy as np

from foam_mj.atomic import atomic_write_text
from foam_mj.errors import FoamError, file_problem_text, foreign_file_hint, json_integer, only_numbers, text_problem
from foam_mj.fingerprint import fingerprint_differences, model_fingerprint

FORMAT = "foam-mj/result"
VERSION = 1


def _qpos_names(m: mujoco.MjModel) -> list[str]:
    names = [""] * m.nq
    for j in range(m.njnt):
        names[int(m.jnt_qposadr[j])] = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
    return names


def _rosary_dict(ros) -> dict:
    return {
        "centers": ros.centers.tolist(),
        "radii": ros.radii.tolist(),
        "bubble_ids": None if ros.bubble_ids is None else np.asarray(ros.bubble_ids).tolist(),
    }


#: The packages whose numbers make a result (a result JSON's ``versions``, with foam-mj's, MuJoCo's and Python's): numpy's
#: draws from a seed, Clarabel's cone programs (the corridor, the convex and optimal smoothers), toppra's timing.
VERSIONED_PACKAGES = ("numpy", "scipy", "clarabel", "toppra")


def software_versions() -> dict[str, str | None]:
    """The versions of the software that makes a result: the same seed and inputs give the same numbers under the
    same versions (another MuJoCo can measure other distances, so grow other bubbles); None for a package not installed."""
    import platform
    from importlib.metadata import PackageNotFoundError, version

    import mujoco

    from foam_mj import __version__

    out: dict[str, str | None] = {"foam_mj": __version__, "mujoco": mujoco.__version__, "python": platform.python_version()}
    for name in VERSIONED_PACKAGES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = None
    return out


def _header(scenario, seed: int) -> dict:
    robot = scenario.robot
    cfg = robot.config
    return {
        "format": FORMAT,
        "version": VERSION,
        "scenario": scenario.name,
        "scenario_file": str(scenario.source) if scenario.source else None,
        "mjcf": str(Path(scenario.scene).resolve()),
        "model_hash": model_fingerprint(robot.model),
        "qpos_joints": _qpos_names(robot.model),
        "configuration": {
            "joints": list(cfg.joint_names), "lower": cfg.lower.tolist(), "upper": cfg.upper.tolist(),
            "qpos_index": np.asarray(cfg.qpos_index).tolist(), "scale": np.asarray(cfg.scale).tolist(),
            "offset": np.asarray(cfg.offset).tolist(), "qpos0": np.asarray(cfg.qpos0).tolist(),
        },
        "q_init": np.asarray(scenario.q_init).tolist(),
        "q_goal": np.asarray(scenario.q_goal).tolist(),
        "seed": int(seed),
        "planner": scenario.params.as_dict(),
        "robot": dict(getattr(scenario, "robot_options", {})),  # robot_root, self_collision, keyframe
        "versions": software_versions(),
    }


def _foam_dict(foam, stats) -> dict:
    return {
        "stats": _plain(stats.as_dict()),  # a planner's own counters may be numpy numbers; no rate when elapsed is 0
        "centers": foam.centers.tolist(),
        "radii": foam.radii.tolist(),
        "parents": foam.parents.tolist(),
    }


#: What the JSON keeps of the optimal smoother's info (foam_mj.smoothing.optimal): whether the path is a
#: certified local optimum (``certified``: both KKT residuals at most ``kkt_tol``), the residuals, what is
#: active at the optimum, the objective and its weights (length, angle, sv), and the starts tried.
CERTIFICATE_KEYS = (
    "certified", "kkt_stationarity", "kkt_raw_stationarity", "kkt_complementarity", "kkt_tol", "gradient_norm",
    "straight_vertices", "active_constraints", "tied_waypoints", "objective_value", "weights", "best_start",
    "starts", "inset",
)


def _plain(value: Any) -> Any:
    """numpy scalars, arrays, tuples and dicts as JSON types; a non-finite number becomes null (strict JSON)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (tuple, list, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    return value


def outcome_dict(outcome) -> dict:
    """The JSON document of a :class:`foam_mj.pipeline.Outcome`."""
    doc = _header(outcome.scenario, outcome.seed)
    doc["outcome"] = outcome.plan.stats.outcome
    doc["clock_cut"] = outcome.plan.stats.clock_cut  # null: the seed alone decided the plan (PlanStats.clock_cut)
    doc["foam"] = _foam_dict(outcome.plan.foam, outcome.plan.stats)
    doc["rosary"] = _rosary_dict(outcome.plan.rosary)
    doc["timings"] = dict(outcome.timings)
    cfg = outcome.scenario.robot.config
    paths: dict[str, Any] = {}
    for name, po in outcome.paths.items():
        res = po.result
        entry: dict[str, Any] = {
            "label": po.label,
            "waypoints": np.asarray(res.path).tolist(),
            "rosary": _rosary_dict(res.rosary),
            "metrics": po.metrics.as_dict(),
            "smoother": {k: v for k, v in res.summary().items() if k not in ("f", "angle_term", "length", "tc", "sv")},
        }
        if po.trajectory is not None:
            entry["qpos"] = po.trajectory.qpos.tolist()
            entry["times"] = po.trajectory.times.tolist()
        else:
            entry["qpos"] = cfg.to_qpos(np.asarray(res.path)).tolist()
        if po.timing_error is not None:
            entry["timing_error"] = " ".join(str(po.timing_error).split())
        if len(res.history_best) > 1:
            entry["convergence"] = {"best": np.asarray(res.history_best).tolist(), "mean": np.asarray(res.history_mean).tolist()}
        front = res.info.get("front") if res.info else None
        if front is not None:
            entry["pareto_front"] = {
                "objective_names": list(front.get("objective_names", ("length", "angle term"))),
                "objectives": np.asarray(front["objectives"]).tolist(),
                "knee": None if front.get("knee") is None else int(front["knee"]),
                "paths": np.asarray(front["paths"]).tolist(),
            }
        if res.info and "kkt_stationarity" in res.info:
            entry["certificate"] = {k: _plain(res.info[k]) for k in CERTIFICATE_KEYS if k in res.info}
        if po.kinematic is not None:
            rep: dict[str, Any] = {"min_clearance": po.kinematic.min_clearance, "duration": po.trajectory.duration}
            if po.dynamic is not None:
                rep.update(
                    joints=list(po.dynamic.joint_names),
                    max_error=po.dynamic.max_error.tolist(),
                    rms_error=po.dynamic.rms_error.tolist(),
                    contacts=len(po.dynamic.contacts),
                    dynamic_min_clearance=po.dynamic.min_clearance,
                )
            entry["replay"] = rep
        if getattr(po, "loads", None) is not None:
            entry["dynamics"] = _plain(po.loads.summary())
        paths[name] = entry
    doc["paths"] = paths
    if hasattr(outcome, "limits"):
        doc["limits"] = _plain(outcome.limits.as_dict(outcome.scenario.robot))
        doc["time_law"] = outcome.time_law
    return doc


def _save_edited_scene(p: Path, doc: dict, scenario) -> None:
    """An edited scene (scenario joints, [subject], [obstacle], [[mesh]]) is saved beside the result as
    ``<result stem>.scene.xml`` and "mjcf" points to it, so any MuJoCo-only checker loads the scene planned on."""
    xml = getattr(scenario.robot, "xml", None)
    if not xml:
        return
    scene = p.with_name(p.stem + ".scene.xml")
    atomic_write_text(scene, xml)
    doc["scene_source"] = doc["mjcf"]
    doc["scene_edits"] = scenario.edits.as_dict()
    doc["mjcf"] = str(scene.resolve())


def _with_relative_mjcf(doc: dict, out: Path) -> dict:
    """The document with "mjcf_relative": the scene's path relative to the result file's folder."""
    try:
        rel = os.path.relpath(doc["mjcf"], start=out.resolve().parent)
    except ValueError:  # another drive (Windows): no relative path
        rel = None
    return {**doc, "mjcf_relative": rel}


def write_outcome(path: str | Path, outcome) -> Path:
    """Write the result atomically (complete or not at all; :class:`~foam_mj.atomic.OutputError`)."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"write_outcome(path, outcome): `path` must be a file path, got {type(path).__name__}")
    p = Path(path)
    doc = outcome_dict(outcome)
    _save_edited_scene(p, doc, outcome.scenario)
    return atomic_write_text(p, json.dumps(_with_relative_mjcf(doc, p), indent=1))


def write_failure(path: str | Path, scenario, failure, seed: int) -> Path:
    """What a failed plan has: the foam grown so far and its statistics, no paths."""
    doc = _header(scenario, seed)
    doc["outcome"] = failure.stats.outcome if failure.stats is not None else "failed"
    doc["error"] = str(failure)
    doc["foam"] = _foam_dict(failure.foam, failure.stats) if failure.foam is not None else None
    doc["rosary"] = None
    doc["paths"] = {}
    p = Path(path)
    _save_edited_scene(p, doc, scenario)
    return atomic_write_text(p, json.dumps(_with_relative_mjcf(doc, p), indent=1))


def read_result(path: str | Path) -> dict:
    """Load and check a result file (format and the fields replay needs)."""
    p = Path(path)
    problem = file_problem_text(p, "result file")  # a named pipe waited for ever, /dev/zero was read until memory ran out
    if problem:
        raise FoamError(problem)
    try:
        # An editor's byte-order mark is no part of the JSON (RFC 8259 §8.1); an integer beyond a float's range reads as
        # infinite, so that the field holding it is refused by name (10**400 in a qpos row was an internal error).
        doc = json.loads(p.read_text(encoding="utf-8-sig"), parse_int=json_integer)
    except FileNotFoundError:
        raise FoamError(f"result file not found: {p}") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        hint = foreign_file_hint(p)
        why = text_problem(exc) if isinstance(exc, UnicodeDecodeError) and not hint else exc
        raise FoamError(f"{p}: not a readable JSON result{hint}: {why}") from None
    except RecursionError:  # arrays nested thousands deep: an internal error (exit 1)
        raise FoamError(f"{p}: not a readable JSON result: nested too deeply to read") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise FoamError(f"{p}: not a foam-mj result (field 'format' should be '{FORMAT}')")
    if doc.get("version") != VERSION:
        raise FoamError(f"{p}: unknown format version {doc.get('version')!r} (this foam-mj {_version()} reads version {VERSION})")
    for key in ("mjcf", "paths", "q_init", "q_goal", "planner"):
        if key not in doc:
            raise FoamError(f"{p}: missing field '{key}'")
    if not isinstance(doc["paths"], dict):
        raise FoamError(f"{p}: field 'paths' must be an object")
    if not isinstance(doc["mjcf"], str) or not doc["mjcf"]:  # a number here was a TypeError in `figures` (exit 1)
        raise FoamError(f"{p}: field 'mjcf' must be the path of the MJCF scene (a string), got {doc['mjcf']!r}")
    seed = doc.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed <= 2**63 - 1:  # "x" was "malformed result: invalid literal for int()"
        raise FoamError(f"{p}: field 'seed' must be an integer in [0, 2**63 - 1] (as plan's --seed), got {seed!r}")
    for key in ("planner", "limits"):
        if key in doc and not isinstance(doc[key], dict):
            raise FoamError(f"{p}: field '{key}' must be an object, got {type(doc[key]).__name__}")
    q_init, q_goal = (_finite_array(doc[key], p, f"field '{key}'", 1) for key in ("q_init", "q_goal"))
    if len(q_init) != len(q_goal):
        raise FoamError(f"{p}: fields 'q_init' and 'q_goal' must have as many numbers, got {len(q_init)} and {len(q_goal)}")
    for name, entry in doc["paths"].items():
        for key in ("waypoints", "rosary"):
            if not isinstance(entry, dict) or key not in entry:
                raise FoamError(f"{p}: path '{name}' misses field '{key}'")
        _finite_array(entry["waypoints"], p, f"path '{name}': field 'waypoints'", 2, len(q_init))
    return doc


#: How far (per coordinate, rad or m) a saved path's first and last waypoints may lie from the result's q_init and q_goal.
END_TOL = 1e-9


def check_ends(source, name: str, path: np.ndarray, q_init: np.ndarray, q_goal: np.ndarray, verb: str) -> None:
    """Raise FoamError unless the saved ``path`` starts at ``q_init`` and ends at ``q_goal`` (a moved goal was an internal
    error, exit 1: "`path[30]` (the goal) is not in the rosary's last bubble")."""
    for end, row, q in (("starts", path[0], q_init), ("ends", path[-1], q_goal)):
        if not np.all(np.abs(row - q) <= END_TOL):
            field = "q_init" if end == "starts" else "q_goal"
            raise FoamError(f"{source}: path '{name}' {end} at {row.tolist()}, not at the result's {field} {q.tolist()}: "
                            f"refusing to {verb} it")


#: How far (rad or m, and s) a saved trajectory may lie from the one replay and export rebuild from its waypoints: the JSON
#: keeps every float exactly, and the timing is deterministic; this allows only for another machine's last bits.
TRAJECTORY_TOL = 1e-6


def check_saved_trajectory(source, name: str, entry: dict, trajectory, robot) -> None:
    """Refuse (FoamError naming the path and its first differing row) a path whose saved timed trajectory ("qpos" and
    "times") is not ``trajectory``, the one ``replay`` and ``export`` rebuild from its waypoints. They replay and export
    the rebuilt one, while ``verify`` checks the saved rows: an edited "qpos" would otherwise be replaced by another
    motion without a word. A path saved without "times" (untimed) has nothing to compare."""
    if "times" not in entry or "qpos" not in entry:
        return
    where = f"{source}: path '{name}'"
    hint = ("replay and export rebuild it from the waypoints under the result's 'limits' and 'time_law', verify checks "
            "the saved rows; restore them or plan again")
    try:
        times, qpos = np.asarray(entry["times"], float), np.asarray(entry["qpos"], float)
    except (TypeError, ValueError):
        raise FoamError(f"{where}: fields 'times' and 'qpos' must be lists of numbers") from None
    nq = robot.model.nq
    if times.ndim != 1 or qpos.ndim != 2 or qpos.shape[1] != nq or len(qpos) != len(times):
        raise FoamError(f"{where}: 'qpos' must be rows of {nq} numbers, one row per entry of 'times'; got shapes "
                        f"{qpos.shape} and {times.shape}")
    if len(qpos) != len(trajectory.qpos):
        raise FoamError(f"{where}: 'qpos' has {len(qpos)} rows, the trajectory its waypoints give {len(trajectory.qpos)}: {hint}")
    names = _qpos_names(robot.model)
    for key, saved, rebuilt in (("times", times[:, None], trajectory.times[:, None]), ("qpos", qpos, trajectory.qpos)):
        off = np.abs(saved - rebuilt)
        bad = np.flatnonzero(~np.all(off <= TRAJECTORY_TOL, axis=1))  # NaN is never <= tol
        if len(bad):
            i = int(bad[0])
            j = int(np.argmax(np.where(np.isnan(off[i]), np.inf, off[i])))
            if not np.isfinite(saved[i, j]):
                what = f"{'its time' if key == 'times' else names[j]} is {saved[i, j]}"
            else:
                what = f"it differs by {off[i, j]:.3g} s" if key == "times" else f"{names[j]} differs by {off[i, j]:.3g}"
            raise FoamError(f"{where}: {key} row {i} (t = {trajectory.times[i]:.4g} s) is not the trajectory its "
                            f"waypoints give ({what}): {hint}")


def _finite_array(value: Any, source: Path, where: str, ndim: int, width: int | None = None) -> np.ndarray:
    """``value`` as a float array of ``ndim`` (1: one configuration, 2: rows of them, at least 2) of finite
    numbers, ``width`` numbers per configuration; FoamError naming ``where`` otherwise."""
    expected = "a list of numbers" if ndim == 1 else "a list of at least 2 rows of numbers"
    if width is not None:
        expected += f", {width} per {'list' if ndim == 1 else 'row'} (one per configuration coordinate)"
    try:
        arr = np.asarray(value, dtype=float) if only_numbers(value) else None
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.ndim != ndim or arr.shape[-1] == 0 or (width is not None and arr.shape[-1] != width) or (ndim == 2 and len(arr) < 2):
        raise FoamError(f"{source}: {where} must be {expected}")
    if not np.all(np.isfinite(arr)):
        raise FoamError(f"{source}: {where} holds a number that is not finite (NaN or infinite)")
    return arr


def _version() -> str:
    from foam_mj import __version__

    return __version__


def resolve_model(doc: dict, source: str | Path) -> Path:
    """The scene file a result was planned on, checked against the result's model hash.

    Candidates are "mjcf_relative" (resolved against the result's folder: results moved together with
    their models) and "mjcf" (absolute as ``plan`` writes it; relative, also against the result's folder); every one that exists must compile to the stored "model_hash", else
    :class:`FoamError` naming the field, the file and the parts that differ. Returns the first that
    exists. A result without "model_hash" (written before it existed) is accepted unchecked.
    """
    from foam_mj.mjcf import load_mjcf

    src = Path(source)
    candidates: list[tuple[str, Path]] = []
    if isinstance(doc.get("mjcf_relative"), str):
        candidates.append(("mjcf_relative", (src.parent / doc["mjcf_relative"]).resolve()))
    if isinstance(doc.get("mjcf"), str) and doc["mjcf"]:  # plan writes it absolute; a relative one is beside the result,
        candidates.append(("mjcf", (src.parent / doc["mjcf"]).resolve()))  # as `verify` and verify_result.py read it
    existing = [(k, p) for k, p in candidates if os.path.isfile(p)]  # never raises, as Path.is_file did for a name too long
    if not existing:
        named = ", ".join(f"{k} = {p}" for k, p in candidates) or "none"
        raise FoamError(f"{src}: the scene file it was planned on is not found ({named})")
    stored = doc.get("model_hash")
    if stored is not None and not isinstance(stored, dict):  # a string or list skipped the check: any scene replayed
        raise FoamError(f"{src}: field 'model_hash' must be an object {{\"sha256\": ..., \"parts\": {{...}}}} (the "
                        f"fingerprint of the scene it was planned on), got {str(stored)[:40]!r}: restore it or plan again")
    if isinstance(stored, dict):
        for key, path in existing:
            current = model_fingerprint(load_mjcf(path))
            diff = fingerprint_differences(stored, current)
            if diff:
                raise FoamError(
                    f"{src}: field '{key}' names {path}, which compiles to a different model than the one planned on "
                    f"({', '.join(diff)} differ{'s' if len(diff) == 1 else ''}; model_hash {str(stored.get('sha256'))[:12]} "
                    f"in the result, {current['sha256'][:12]} now): refusing to replay on it"
                )
    return existing[0][1]


def outcome_robot(doc: dict, source: str | Path):
    """The compiled scene a result was planned on (a ModelError, exit 2, when it cannot be loaded)."""
    from foam_mj.model import RobotModel

    return RobotModel.from_xml(resolve_model(doc, source), **robot_options(doc, source))


def robot_options(doc: dict, source: str | Path) -> dict:
    """The result's ``robot`` field (robot_root, self_collision, keyframe): what the robot was when planned."""
    options = doc.get("robot") or {}
    if not isinstance(options, dict) or set(options) - {"robot_root", "self_collision", "keyframe"}:
        raise FoamError(f"{source}: field 'robot' must hold only robot_root, self_collision and keyframe")
    for key, kind, what in (("robot_root", str, "a body name or null"), ("self_collision", bool, "true or false"),
                            ("keyframe", str, "a keyframe name or null")):  # {"a": 1} was an internal error in export
        value = options.get(key)
        if not (isinstance(value, kind) or (value is None and kind is str)):
            if not (key == "self_collision" and key not in options):
                raise FoamError(f"{source}: field 'robot.{key}' must be {what}, got {value!r}")
    return options


def outcome_from_result(doc: dict, source: str | Path, dynamic: bool = True, report: Callable[[str], None] | None = None):
    """Rebuild trajectories from a result's waypoints and rosaries and replay them on its scene; ``report`` is told
    which path is being timed and replayed (as ``foam-mj plan``'s progress line). The waypoints are what is replayed:
    a path whose saved "qpos"/"times" are not the trajectory they give is refused (:func:`check_saved_trajectory`)."""
    from foam_mj.foam import Foam
    from foam_mj.planners import PlannerConfig, PlanResult, PlanStats
    from foam_mj.paths import metrics
    from foam_mj.pipeline import Outcome, PathOutcome
    from foam_mj.replay import replay_clearance
    from foam_mj.rosary import Rosary
    from foam_mj.scenarios import Scenario
    from foam_mj.smoothing import SmoothingResult
    from foam_mj.pipeline import require_a_timing, time_and_replay
    from foam_mj.limits import Limits
    from foam_mj.timing import METHODS, TimingInfeasible, time_path

    try:
        # Results written before the torque-limited time laws have neither field: they were timed by "own".
        limits = Limits.from_dict(doc["limits"]) if doc.get("limits") else Limits()
        time_law = doc.get("time_law") or "own"
        if time_law not in METHODS:
            raise FoamError(f"{source}: field 'time_law' must be one of {list(METHODS)}, got {time_law!r}")
        try:
            params = PlannerConfig.from_dict(doc["planner"])  # results written before the seam were pfm's
        except ValueError as exc:  # a PlannerError too: "unknown planner 'x'" named neither the file nor the field
            raise FoamError(f"{source}: field 'planner': {exc}") from None
        scenario = Scenario(
            doc.get("scenario", "result"), "", resolve_model(doc, source), np.asarray(doc["q_init"], float), np.asarray(doc["q_goal"], float), params, int(doc.get("seed", 0)), Path(source),
            **robot_options(doc, source),  # the robot it was planned as: a keyframe's pose of the other joints, its root, its pairs
        )
        robot = scenario.robot
        q_init, q_goal = scenario.q_init, scenario.q_goal
        foam_doc = doc.get("foam") or {}
        foam = Foam(
            np.asarray(foam_doc.get("centers", [q_init]), float),
            np.asarray(foam_doc.get("radii", [1.0]), float),
            np.asarray(foam_doc.get("parents", [-1]), int),
            q_init,
            q_goal,
        )
        top = doc.get("rosary") or next(iter(doc["paths"].values()))["rosary"]
        ros0 = Rosary(np.asarray(top["centers"], float), np.asarray(top["radii"], float), q_init, q_goal)
        outcome = Outcome(scenario, scenario.seed, PlanResult(foam, ros0, PlanStats(params.algorithm, doc.get("outcome", ""), foam.size, 0, 0.0)),
                          limits=limits, time_law=time_law)
        waypoints: dict[str, np.ndarray] = {}
        for name, entry in doc["paths"].items():
            rosary = Rosary(np.asarray(entry["rosary"]["centers"], float), np.asarray(entry["rosary"]["radii"], float), q_init, q_goal)
            path = np.asarray(entry["waypoints"], float)
            if path.ndim != 2 or path.shape[1] != robot.dim or len(path) != rosary.k + 1:
                raise FoamError(f"{source}: path '{name}' has waypoints of shape {path.shape}, expected ({rosary.k + 1}, {robot.dim})")
            check_ends(source, name, path, q_init, q_goal, "replay")
            if not rosary.all_in_hatches(path[1:-1], tol=1e-9):
                raise FoamError(f"{source}: path '{name}' has waypoints outside its rosary's hatches: refusing to replay it")
            conv = entry.get("convergence") or {}
            res = SmoothingResult.build(
                name, rosary, path[1:-1],
                history_best=np.asarray(conv.get("best", [0.0]), float),
                history_mean=np.asarray(conv["mean"], float) if "mean" in conv else None,
                iterations=0, evaluations=0, wall_time=0.0, stop_reason="loaded",
            )
            outcome.paths[name] = PathOutcome(name, res, metrics(path))
            waypoints[name] = path
        limits.resolve(robot)  # here: limits that do not fit the model are the file's fault (a malformed result)
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, FoamError):
            raise
        raise FoamError(f"{source}: malformed result: {type(exc).__name__}: {exc}") from None
    # The result is read; what fails from here on is the replay's own doing, not the file's.
    timed = {}  # every saved trajectory is compared with the rebuilt one before any replay
    for name, po in outcome.paths.items():
        try:
            timed[name] = time_path(robot, name, waypoints[name], po.rosary, limits, time_law)
        except TimingInfeasible:  # time_and_replay keeps it in po.timing_error
            continue
        check_saved_trajectory(source, name, doc["paths"][name], timed[name], robot)
    clearance = replay_clearance(robot, params.delta)
    try:
        for k, (name, po) in enumerate(outcome.paths.items(), 1):
            time_and_replay(po, robot, waypoints[name], limits, time_law, clearance, dynamic, report, f"{k} of {len(outcome.paths)}",
                            trajectory=timed.get(name))
    finally:
        clearance.close()
    require_a_timing(outcome.paths)
    return outcome
