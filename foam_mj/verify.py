"""``foam-mj verify RESULT.json``: an independent check of a saved result, with MuJoCo alone.

None of the planner's code is used: only the JSON, numpy and MuJoCo (and foam_mj's error and
fingerprint helpers, which use nothing else). For every path of the result:

* its waypoints, a polyline in the configuration q, sampled so that consecutive samples are at most
  ``step`` apart in q (Euclidean), in qpos (largest coordinate) and in metres that any point of a collision geom can
  travel (a bound from the joints' lever arms in the MJCF, :func:`_levers`: a 1e-3 rad step swings a point 20 m from
  its hinge by 20 mm, past a thin plate between two clear samples); q is mapped to qpos by the
  result's own "configuration" map (``qpos = qpos0; qpos[qpos_index] = offset + scale * q``; q may be
  normalized, e.g. the Ortholeg's hip slide);
* its timed trajectory, the "qpos" rows, with linear samples between rows at the same step (the rows must start and
  end where the waypoints do and number one per entry of "times": rows cut short are refused, exit 2);

and at every sample, ``mujoco.mj_geomDistance`` (at most minus a capsule's radius where its axis runs through a box,
which MuJoCo can misread as apart) between every moving collision geom (on a body a
configuration joint moves) and every other one (contype or conaffinity non-zero; a loose object on a
joint that is not a configuration coordinate is an obstacle where the rows put it), with no
contype/conaffinity filtering, as the planner (only a geom on the same or the parent or child
body of a moving one is left out, as by MuJoCo: they meet at their joint); and, unless the result says the robot was planned
with ``self_collision`` false, between the robot's own geoms, for the pairs MuJoCo's collision detection
tests whose distance a configuration joint changes (:func:`collision_pairs`). A result planned with a ``robot_root``
counts that body's subtree as the robot, as the planner does: its geoms no configuration joint moves (a held floating
base) are checked against the static ones, and against the moving ones as robot/robot pairs. A sample is a *violation*
when some pair is closer than the result's margin ("planner" / "delta"); a sample that puts a configuration joint
beyond its MJCF range (the planner's bounds) is unsafe too. The rows and "configuration"'s qpos0 must hold every
joint that is no coordinate where the planner held it (the scene's qpos0, or the result's keyframe's pose): which
geoms count as moving follows from the coordinates, so a joint left out of them but swung by the rows is refused.
A scene whose checked pairs include a height field is refused: ``mj_geomDistance`` reads inf to one with an unbounded
distmax and values that change with a finite one (the planner refuses such scenes too).

Between samples the clearance is proved, not assumed (:func:`foam_mj.verify_geometry.prove`): from two neighbouring
samples' distances d_a, d_b and how far any point of a collision geom can travel between them (the lever arms), the
clearance anywhere between them is at least (d_a + d_b - travel) / 2; a segment where that falls below the margin is
halved until each piece is proved or a new sample breaks the margin. A stretch that stays unproved (a path running along
the margin exactly) is unsafe too; a coordinate of a ball or free joint, whose travel the lever arms do not bound, gets
no proof (said in the report), only its samples.

Speed: poses of all samples come from one ``mj_kinematics`` call each; a lower bound of every (sample, pair) is
computed with numpy: the bounding spheres' (centre distance minus both ``geom_rbound``; for a plane, the signed
distance of the other sphere), raised by the exact distances at every 16th sample (no point moves further between two
samples than the lever arms allow, so a pair's distance changes at most that much, twice for a robot/robot pair).
``mj_geomDistance`` then runs only where that bound is below max(margin, an upper bound of the minimum found from the
most promising pairs). This is exact for both outputs: a pair skipped has a distance at least its bound, which is at
least the margin and at least the smallest distance found. (The anchors took the 6-joint arm's check from 297,000
distance calls and 9.0 s of CPU to 30,000 and 0.8 s, and the obstacle result's from 0.85 to 0.41 s.)

The scene is the result's "mjcf_relative" or "mjcf" (both, when relative, resolved against the result's folder), and
must compile to the stored "model_hash" when there is one (otherwise it is refused: exit 2); without one, the two
fields must name the same model.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from foam_mj.errors import (FoamError, file_problem, file_problem_text, foreign_file_hint, is_number, json_integer, only_numbers,
                             text_problem)
from foam_mj.fingerprint import fingerprint_differences, model_fingerprint
from foam_mj.verify_geometry import HELD_TOL as _HELD_TOL
from foam_mj.verify_geometry import (MAX_SAMPLES, _Checker, _beyond_ranges, _densify, _distance, _levers,  # noqa: F401
                                     _subtree, _unprovable, collision_pairs, prove)

#: How far (per coordinate, rad or m) a path's first and last waypoints may lie from the result's q_init and q_goal.
END_TOL = 1e-9
#: The largest --step (rad or m, in q and in qpos): a coarser one would sample little more than the waypoints
#: (--step 1e308 checked only the vertices and said "clean"), and 0.1 rad already moves a 1 m link 10 cm.
MAX_STEP = 0.1


@dataclass(frozen=True)
class PathCheck:
    """The check of one path: waypoint and trajectory samples, the smallest distance, the violations."""

    name: str
    waypoint_samples: int
    trajectory_samples: int
    min_clearance: float  # metres, over every sample and pair
    violations: int  # samples closer than the margin
    worst_pair: tuple[str, str]
    exact_calls: int  # mj_geomDistance calls made
    outside_range: int = 0  # samples with a configuration joint beyond its MJCF range
    range_note: str = ""  # the joint that went furthest beyond its range, how far, and the range
    proved_clearance: float = float("nan")  # metres: a lower bound of the clearance everywhere between the samples (nan: no proof)
    unproved: int = 0  # segments between samples whose clearance neither the proof nor a violation settled
    proof_samples: int = 0  # samples the proof added (bisections), besides the waypoint and trajectory samples
    proof_note: str = ""  # why there is no proof


@dataclass(frozen=True)
class VerifyReport:
    result: Path
    mjcf: Path
    margin: float
    step: float
    pairs: int
    paths: tuple[PathCheck, ...] = field(default_factory=tuple)
    self_pairs: int = 0  # robot/robot pairs checked besides the moving/static ones

    @property
    def violations(self) -> int:
        return sum(p.violations for p in self.paths)

    @property
    def outside_range(self) -> int:
        return sum(p.outside_range for p in self.paths)

    @property
    def unproved(self) -> int:
        return sum(p.unproved for p in self.paths)

    @property
    def unsafe(self) -> bool:
        """Some sample is closer than the margin, or beyond a joint range, or a stretch between samples is not proved
        clear."""
        return bool(self.violations or self.outside_range or self.unproved)

    @property
    def proved_clearance(self) -> float:
        """The smallest proved clearance over the paths (nan when a path has no proof)."""
        return min((p.proved_clearance for p in self.paths), default=float("inf"), key=lambda v: -np.inf if np.isnan(v) else v)

    @property
    def samples(self) -> int:
        return sum(p.waypoint_samples + p.trajectory_samples for p in self.paths)

    @property
    def min_clearance(self) -> float:
        return min((p.min_clearance for p in self.paths), default=float("inf"))


def _fail(source: Path, msg: str) -> FoamError:
    return FoamError(f"{source}: {msg}")


class _RepeatedKey(ValueError):
    pass


def _one_value_per_key(pairs: list) -> dict:
    """json's object hook: a key given twice in one object is ambiguous (RFC 8259 §4: Python keeps the last, other
    readers the first), so a "delta" given twice would be checked at whichever margin this reader kept."""
    seen = set()
    for key, _ in pairs:
        if key in seen:
            raise _RepeatedKey(f"key {key!r} appears twice in one object")
        seen.add(key)
    return dict(pairs)


def _load(source: Path) -> dict:
    problem = file_problem_text(source, "result file")  # a named pipe waited for ever, /dev/zero filled the memory
    if problem:
        raise FoamError(problem)
    try:
        doc = json.loads(source.read_text(encoding="utf-8-sig"), object_pairs_hook=_one_value_per_key,
                         parse_int=json_integer)  # an editor's byte-order mark is no part of the JSON (RFC 8259 §8.1)
    except FileNotFoundError:
        raise FoamError(f"result file not found: {source}") from None
    except _RepeatedKey as exc:
        raise _fail(source, f"not a readable JSON result: {exc}; keep one") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        hint = foreign_file_hint(source)
        why = text_problem(exc) if isinstance(exc, UnicodeDecodeError) and not hint else " ".join(str(exc).split())
        raise _fail(source, f"not a readable JSON result{hint}: {why}") from None
    except RecursionError:  # arrays nested thousands deep: an internal error (exit 1)
        raise _fail(source, "not a readable JSON result: nested too deeply to read") from None
    if not isinstance(doc, dict) or doc.get("format") != "foam-mj/result":
        raise _fail(source, "not a foam-mj result (field 'format' should be 'foam-mj/result')")
    if doc.get("version") != 1:
        raise _fail(source, f"unknown format version {doc.get('version')!r} (verify reads version 1)")
    return doc


def _scene(doc: dict, source: Path) -> tuple[Path, mujoco.MjModel]:
    candidates = []
    if isinstance(doc.get("mjcf_relative"), str):
        candidates.append(("mjcf_relative", (source.parent / doc["mjcf_relative"]).resolve()))
    if isinstance(doc.get("mjcf"), str) and doc["mjcf"]:  # plan writes it absolute; a relative one is beside the result
        candidates.append(("mjcf", source.parent / doc["mjcf"]))
    existing = [(k, p) for k, p in candidates if file_problem(p) is None]  # Path.is_file raised OSError for a name too long
    if not existing:
        raise _fail(source, "the scene file it was planned on is not found (" + (", ".join(f"{k} = {p}" for k, p in candidates) or "no 'mjcf' field") + ")")
    stored = doc.get("model_hash")
    if stored is not None and not (isinstance(stored, dict) and isinstance(stored.get("parts", {}), dict)
                                   and isinstance(stored.get("sha256", ""), str)):  # a string or list skipped the check: any scene passed
        raise _fail(source, f"field 'model_hash' must be an object {{\"sha256\": ..., \"parts\": {{...}}}} (the fingerprint "
                            f"of the scene it was planned on), got {str(stored)[:40]!r}: restore it or plan again")
    chosen, first = None, None
    for key, path in existing:
        try:
            with open(path, "rb"):  # MuJoCo calls a file it may not read "empty file"
                pass
            m = mujoco.MjModel.from_xml_path(str(path))
        except OSError as exc:
            raise _fail(source, f"field '{key}': cannot read {path}: {exc.strerror or exc}") from None
        except ValueError as exc:
            raise _fail(source, f"field '{key}': could not load {path}: {' '.join(str(exc).split())}") from None
        if isinstance(stored, dict):
            diff = fingerprint_differences(stored, model_fingerprint(m))
            if diff:
                raise _fail(source, f"field '{key}' names {path}, which compiles to a different model than the one planned on ({', '.join(diff)} differ{'s' if len(diff) == 1 else ''}; model_hash {str(stored.get('sha256'))[:12]} in the result)")
        elif first is None:
            first = (key, path, model_fingerprint(m))
        else:  # two scenes and no hash to tell which was planned on: other checkers read 'mjcf' alone
            diff = fingerprint_differences(first[2], model_fingerprint(m))
            if diff:
                raise _fail(source, f"fields '{first[0]}' ({first[1]}) and '{key}' ({path}) compile to different models "
                                    f"({', '.join(diff)} differ{'s' if len(diff) == 1 else ''}) and no model_hash says which "
                                    "one was planned on: restore the result or plan again")
        chosen = chosen or (path, m)
    assert chosen is not None  # (existing is not empty)
    return chosen


def _configuration_map(doc: dict, m: mujoco.MjModel, source: Path):
    cfg = doc.get("configuration") or {}
    try:
        if not all(only_numbers(cfg[key]) for key in ("qpos_index", "scale", "offset", "qpos0")):
            raise _fail(source, "field 'configuration': qpos_index, scale, offset and qpos0 must be lists of numbers")
        if not all(isinstance(i, int) for i in cfg["qpos_index"]):  # dtype=int truncated 1.7 to 1
            raise _fail(source, f"field 'configuration': qpos_index must be integers, got {str(cfg['qpos_index'])[:60]!r}")
        if not all(0 <= i < m.nq for i in cfg["qpos_index"]):  # (10**30 overflowed numpy's int64)
            raise _fail(source, f"field 'configuration' does not fit the scene (nq = {m.nq})")
        idx = np.asarray(cfg["qpos_index"], dtype=int)
        scale = np.asarray(cfg["scale"], dtype=float)
        offset = np.asarray(cfg["offset"], dtype=float)
        qpos0 = np.asarray(cfg["qpos0"], dtype=float)
    except (KeyError, TypeError, ValueError):
        raise _fail(source, "field 'configuration' lacks the q -> qpos map (qpos_index, scale, offset, qpos0): "
                            "written by an older foam-mj; plan it again") from None
    if qpos0.shape != (m.nq,) or not (idx.shape == scale.shape == offset.shape) or idx.ndim != 1 or np.any((idx < 0) | (idx >= m.nq)):
        raise _fail(source, f"field 'configuration' does not fit the scene (nq = {m.nq})")
    values, counts = np.unique(idx, return_counts=True)
    if np.any(counts > 1):  # qpos[idx] = ... kept the last: the other coordinates' motion went unchecked
        k = int(values[np.argmax(counts > 1)])
        at = [str(i) for i in np.flatnonzero(idx == k)]
        raise _fail(source, f"field 'configuration': qpos_index repeats {k} (at positions {', '.join(at[:-1])} and {at[-1]}): "
                            "each coordinate maps to a qpos entry of its own; restore it or plan again")
    if not all(np.all(np.isfinite(a)) for a in (scale, offset, qpos0)):
        raise _fail(source, "field 'configuration': scale, offset and qpos0 must be finite numbers (no NaN or infinity)")
    if np.any(scale == 0):
        raise _fail(source, "field 'configuration': a scale is 0")
    names = cfg.get("joints")
    if names is not None:  # plan writes them: each names the joint whose qpos address qpos_index gives
        if not (isinstance(names, list) and len(names) == len(idx) and all(isinstance(n, str) for n in names)):
            raise _fail(source, f"field 'configuration': joints must be a list of {len(idx)} joint names, got {str(names)[:60]!r}")
        for i, (name, adr) in enumerate(zip(names, idx.tolist())):
            j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
            address = int(m.jnt_qposadr[j]) if j >= 0 else None
            if address != adr:
                whose = f"whose qpos address is {address}" if j >= 0 else "which is no joint of the scene"
                raise _fail(source, f"field 'configuration': joints[{i}] is {name}, {whose}, not qpos_index[{i}] = {adr}")
    return idx, scale, offset, qpos0


def _qpos_name(m: mujoco.MjModel, k: int) -> str:
    """The joint that owns qpos entry ``k``, and the entry: 'shoulder (qpos[7])'."""
    j = max(j for j in range(m.njnt) if int(m.jnt_qposadr[j]) <= k)
    return f"{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f'joint {j}'} (qpos[{k}])"


def _geom_name(m: mujoco.MjModel, g: int) -> str:
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, int(g)) or f"geom{int(g)}"


def _robot_options(doc: dict, source: Path) -> dict:
    """The result's "robot" (what the robot was when planned): robot_root and keyframe (names or null) and
    self_collision (true or false), each defaulting as plan does when the field is absent."""
    robot = doc.get("robot")
    if robot is None:
        robot = {}
    if not isinstance(robot, dict) or set(robot) - {"robot_root", "self_collision", "keyframe"}:
        raise _fail(source, f"field 'robot' must be an object with robot_root, self_collision and keyframe, got {str(robot)[:60]!r}")
    out = {"robot_root": None, "self_collision": True, "keyframe": None, **robot}
    for key, kind, what in (("robot_root", str, "a body name or null"), ("keyframe", str, "a keyframe name or null"),
                            ("self_collision", bool, "true or false")):
        if not (isinstance(out[key], kind) or (out[key] is None and kind is str)):  # "false" was read as true
            raise _fail(source, f"field 'robot.{key}' must be {what}, got {out[key]!r}")
    return out


def _mocap_in_place(m: mujoco.MjModel, k: int, key: str, source: Path) -> None:
    """Refuse keyframe ``k`` if it poses a mocap body elsewhere than the scene does: the planner plans with them where
    the keyframe puts them (and saves that scene with its result), but distances of qpos alone see them where the scene
    has them (a path through a wall the keyframe placed across it passed as clean)."""
    for b in np.flatnonzero(m.body_mocapid >= 0):
        i = int(m.body_mocapid[b])
        pos, quat = m.key_mpos[k, 3 * i:3 * i + 3], m.key_mquat[k, 4 * i:4 * i + 4]
        turned = min(np.abs(quat - m.body_quat[b]).max(), np.abs(quat + m.body_quat[b]).max()) > _HELD_TOL
        if np.any(np.abs(pos - m.body_pos[b]) > _HELD_TOL * (1 + np.abs(m.body_pos[b]))) or turned:
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(b)) or f"body {b}"
            at = lambda v: "[" + ", ".join(f"{x:.6g}" for x in v) + "]"  # noqa: E731
            what = f"turns mocap body '{name}' to {at(quat)}" if turned else f"puts mocap body '{name}' at {at(pos)}"
            has = f"turned to {at(m.body_quat[b])}" if turned else f"at {at(m.body_pos[b])}"
            raise _fail(source, f"field 'robot.keyframe': keyframe '{key}' {what}, where the scene has it {has}: the "
                                "planner plans with it where the keyframe puts it, on the scene it saves beside the result; "
                                "verify that scene (the result's mjcf) or plan again")


def _held_pose(doc: dict, m: mujoco.MjModel, source: Path, idx: np.ndarray, qpos0: np.ndarray) -> np.ndarray:
    """The qpos entries that are no coordinate (a loose object, a joint left out of the plan): the planner holds them
    at the scene's qpos0, or at the pose of the result's keyframe, and which geoms verify counts as moving follows from
    that. Refuses a configuration "qpos0" that holds one elsewhere; returns their addresses."""
    key = _robot_options(doc, source)["keyframe"]
    ref, where = np.asarray(m.qpos0, dtype=float), "qpos0"
    if key is not None:
        k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, str(key))
        if k < 0:
            raise _fail(source, f"field 'robot.keyframe' names {key!r}, which is no keyframe of the scene")
        ref, where = np.asarray(m.key_qpos[k], dtype=float), f"keyframe '{key}'"
        _mocap_in_place(m, k, str(key), source)
    held = np.setdiff1d(np.arange(m.nq), idx)
    off = held[np.abs(qpos0[held] - ref[held]) > _HELD_TOL * (1 + np.abs(ref[held]))]
    if len(off):
        k = int(off[0])
        raise _fail(source, f"field 'configuration': qpos0 puts {_qpos_name(m, k)} at {qpos0[k]:.6g}, where the scene's "
                            f"{where} has {ref[k]:.6g}: the planner holds every joint that is no coordinate there; "
                            "restore it or plan again")
    return held


def verify_result(result: str | Path, step: float = 1e-3) -> VerifyReport:
    """Check every path of a result densely with MuJoCo (see the module docstring)."""
    if not isinstance(result, (str, Path)) and not hasattr(result, "__fspath__"):
        raise TypeError(f"`result` must be the path of a result file (plan --json), got {type(result).__name__}")
    source = Path(result)
    if not (is_number(step) and np.isfinite(step) and 0 < step <= MAX_STEP):
        raise FoamError(f"--step must be a positive number at most {MAX_STEP:g} (rad or m, in q and in qpos), got {step!r}")
    doc = _load(source)
    mjcf, m = _scene(doc, source)
    idx, scale, offset, qpos0 = _configuration_map(doc, m, source)
    held = _held_pose(doc, m, source, idx, qpos0)
    planner = doc.get("planner")
    if not isinstance(planner, dict) or "delta" not in planner:
        raise _fail(source, "missing field 'planner.delta' (the safety margin)")
    if not is_number(planner["delta"]):
        raise _fail(source, f"field 'planner.delta' must be a margin >= 0 in metres, got {planner['delta']!r}")
    try:
        margin = float(planner["delta"])
    except OverflowError:  # an integer of 400 digits was an internal error
        margin = float("inf")
    if not (np.isfinite(margin) and margin >= 0):
        # A negative or NaN margin would let every sample pass: refuse it rather than call the result clean.
        raise _fail(source, f"field 'planner.delta' must be a margin >= 0 in metres, got {margin}")
    paths = doc.get("paths")
    if not isinstance(paths, dict):
        raise _fail(source, "field 'paths' must be an object")
    if not paths:
        outcome = doc.get("outcome")
        if isinstance(outcome, str) and outcome != "reached":
            raise _fail(source, f"the plan failed (outcome '{outcome}'): the result has no paths, nothing to verify")
        raise _fail(source, "field 'paths' is empty: nothing to verify")
    robot = _robot_options(doc, source)
    self_collision, root_name = robot["self_collision"], robot["robot_root"]
    root = None
    if root_name is not None:
        root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, str(root_name))
        if root < 0:
            raise _fail(source, f"field 'robot.robot_root' names {root_name!r}, which is no body of the scene {mjcf}")
        inside = _subtree(m, root)
        for k in idx.tolist():  # the planner's robot is that subtree, every coordinate in it (it refuses another root)
            j = max(j for j in range(m.njnt) if int(m.jnt_qposadr[j]) <= k)
            if not inside[int(m.jnt_bodyid[j])]:
                raise _fail(source, f"field 'robot.robot_root' names {root_name!r}, whose subtree holds no {_qpos_name(m, k)}, "
                                    "a configuration joint: the robot is that subtree, with every configuration joint in it; "
                                    "restore it or plan again")
    pairs = collision_pairs(m, idx, self_collision, root)
    n_self = len(pairs) - len(collision_pairs(m, idx, root=root))
    if len(pairs) == 0:
        raise _fail(source, f"the scene {mjcf} has no pair of moving and static collision geoms")
    self_from = len(pairs) - n_self  # collision_pairs lists the robot/robot pairs last
    hfield = [g for g in np.unique(pairs) if int(m.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_HFIELD)]
    if hfield:  # mj_geomDistance reads inf to one with distmax inf, and values that change with a finite distmax
        raise _fail(source, f"geom {_geom_name(m, hfield[0])!r} is a height field, whose distance MuJoCo's "
                            "mj_geomDistance does not measure (the planner refuses such scenes): verify cannot check it")
    proof_note = _unprovable(m, idx)
    checker = _Checker(m, pairs, None, self_from)
    ends = {}  # the end points each path must join, when the result has them (plan's always does)
    for key in ("q_init", "q_goal"):
        if key not in doc:
            continue
        try:
            ends[key] = np.asarray(doc[key], dtype=float)
            if ends[key].shape != (len(idx),) or not only_numbers(doc[key]):
                raise ValueError
        except (KeyError, TypeError, ValueError):
            raise _fail(source, f"field '{key}' must be a list of {len(idx)} numbers, got {doc[key]!r}") from None
    names = lambda g: _geom_name(m, g)  # noqa: E731
    checks = []
    for name, entry in paths.items():
        if not isinstance(entry, dict) or "waypoints" not in entry:
            raise _fail(source, f"path '{name}' misses field 'waypoints'")
        arrays = []
        for key, value, width in (("waypoints", entry["waypoints"], len(idx)), ("qpos", entry.get("qpos", []), m.nq)):
            try:
                if not only_numbers(value):  # numpy reads the string "0.3" as 0.3
                    raise ValueError
                arrays.append(np.asarray(value, dtype=float))
            except (TypeError, ValueError):
                raise _fail(source, f"path '{name}': field '{key}' must be a list of rows of {width} numbers each") from None
        wp, rows = arrays
        times = entry.get("times")
        if times is not None and not (isinstance(times, list) and only_numbers(times)):  # a string was ignored
            raise _fail(source, f"path '{name}': field 'times' must be a list of numbers (seconds), got {str(times)[:40]!r}")
        given = entry.get("qpos", []) != []  # [[]] is a row of no numbers, not a path without rows
        if not given and isinstance(times, list) and times:  # its waypoints were checked alone and called clean
            raise _fail(source, f"path '{name}': 'times' has {len(times)} entries but 'qpos' no rows: its timed trajectory "
                                "would go unchecked; restore the rows or plan again")
        if wp.ndim != 2 or wp.shape[1] != len(idx) or len(wp) < 2 or not np.all(np.isfinite(wp)):
            raise _fail(source, f"path '{name}': waypoints of shape {wp.shape}, expected (N >= 2, {len(idx)}) finite numbers")
        for end, row, key in (("starts", wp[0], "q_init"), ("ends", wp[-1], "q_goal")):
            # a path moved off its end points is not the plan of this result, however clear of obstacles (it passed as clean)
            q = ends.get(key)
            if q is not None and not np.all(np.abs(row - q) <= END_TOL):
                raise _fail(source, f"path '{name}' {end} at {row.tolist()}, not at the result's {key} {q.tolist()}")
        wp_qpos = np.broadcast_to(qpos0, (len(wp), m.nq)).copy()
        with np.errstate(over="ignore"):
            wp_qpos[:, idx] = offset + scale * wp
        if not np.all(np.isfinite(wp_qpos)):  # inf - inf between two waypoints was numpy's "repeats may not contain negative values"
            r, c = np.argwhere(~np.isfinite(wp_qpos[:, idx]))[0]
            raise _fail(source, f"path '{name}': its waypoints map to qpos beyond a float's range (waypoint {r}, "
                                f"{_qpos_name(m, int(idx[c]))}: offset + scale q = {wp_qpos[r, idx[c]]}): check the configuration's "
                                "scale and offset, or the waypoints")
        lever = _levers(m, idx, np.max(np.abs(wp_qpos - m.qpos0), axis=0))
        samples_wp = _densify(wp, wp_qpos, step, f"{source}: path '{name}': waypoints", lever)
        if given:
            if rows.ndim != 2 or rows.shape[1] != m.nq or not np.all(np.isfinite(rows)):
                raise _fail(source, f"path '{name}': qpos rows of shape {rows.shape}, expected (N, {m.nq}) finite numbers")
            moved = np.abs(rows[:, held] - qpos0[held]) > _HELD_TOL * (1 + np.abs(qpos0[held]))
            if np.any(moved):  # the upper arm swung by rows whose configuration left the shoulder out passed as a still link
                r, c = np.argwhere(moved)[0]
                k = int(held[c])
                raise _fail(source, f"path '{name}': its qpos rows move {_qpos_name(m, k)}, to {rows[r, k]:.6g} in row {r}, "
                                    f"which is no configuration coordinate: the planner held it at {qpos0[k]:.6g} "
                                    "(configuration.qpos0); restore the rows or plan again")
            for end, row, at in (("start", rows[0], wp_qpos[0]), ("end", rows[-1], wp_qpos[-1])):
                # rows cut short (a copy, a hand edit) were checked as far as they went and called clean
                if not np.all(np.abs(row[idx] - at[idx]) <= END_TOL * (1 + np.abs(at[idx]))):
                    raise _fail(source, f"path '{name}': its qpos rows {end} at {row[idx].tolist()} (the configuration "
                                        f"joints' qpos), not at its waypoints' {end} {at[idx].tolist()}: the trajectory is "
                                        "not this path's whole motion; restore the rows or plan again")
            if isinstance(times, list) and len(times) != len(rows):
                raise _fail(source, f"path '{name}': 'qpos' has {len(rows)} rows but 'times' {len(times)} entries: one row "
                                    "per entry; restore them or plan again")
            lever = np.maximum(lever, _levers(m, idx, np.max(np.abs(rows - m.qpos0), axis=0)))  # (the proof's: both polylines)
            with np.errstate(over="ignore"):
                q_rows = (rows[:, idx] - offset) / scale
            if not np.all(np.isfinite(q_rows)):
                r, c = np.argwhere(~np.isfinite(q_rows))[0]
                raise _fail(source, f"path '{name}': its qpos rows map to q beyond a float's range (row {r}, coordinate {c}: "
                                    f"(qpos - offset) / scale = {q_rows[r, c]}): check the configuration's scale and offset")
            samples_tr = _densify(q_rows, rows, step, f"{source}: path '{name}': qpos rows", lever)
        else:
            samples_tr = np.empty((0, m.nq))
        allq = np.vstack([samples_wp, samples_tr])
        outside, note = _beyond_ranges(m, idx, allq)
        calls0 = checker.calls
        checker.lever = None if proof_note else lever
        seen = checker.measure(allq, margin)
        path_note = proof_note
        if seen.breach is not None:  # the travel bound fails here: no anchors and no proof, the samples alone
            s, k, change, allowed = seen.breach
            path_note = (f"the distance of {names(pairs[k, 0])} / {names(pairs[k, 1])} changes by {change * 1000:.3g} mm between "
                         f"samples {s} and {s + 1}, more than the {allowed * 1000:.3g} mm the lever arms allow (a bound "
                         "verify gets wrong for this model: please report it); only the samples are checked")
            checker.lever = None
            seen = checker.measure(allq, margin)
        dmin, bad, pair = seen.min_distance, seen.violations, seen.pair
        proved, unproved, added = float("nan"), 0, 0
        if not path_note:
            proved = float("inf")
            for part in (slice(0, len(samples_wp)), slice(len(samples_wp), len(allq))):
                if part.stop - part.start:
                    pr = prove(checker, allq[part], seen.obstacle_bound[part], seen.self_bound[part], margin)
                    proved, unproved, added = min(proved, pr.clearance), unproved + pr.unproved, added + pr.samples
                    bad, dmin = bad + pr.violations, min(dmin, pr.min_distance)
        checks.append(PathCheck(name, len(samples_wp), len(samples_tr), dmin, bad,
                                (names(pairs[pair, 0]), names(pairs[pair, 1])) if pair >= 0 else ("", ""), checker.calls - calls0,
                                outside, note, proved, unproved, added, path_note))
    return VerifyReport(source, mjcf, margin, step, len(pairs) - n_self, tuple(checks), n_self)


def _shown(name: str) -> str:
    """A name from the file as printed: a character that does not print (a newline, ESC) as its escape, so that a
    path named 'x\\npaths 2 ... violations 0: clean' cannot add a line to the report, nor colour the terminal."""
    return name if name.isprintable() else "".join(c if c.isprintable() else repr(c)[1:-1] for c in name)


def _count(n: int, noun: str) -> str:
    return f"{n:,} {noun}{'' if n == 1 else 's'}"


def _mm(v: float, margin: float, margin_text: str) -> str | None:
    """A clearance ``v`` (m) as the report prints it, in mm: 2 decimals, or more where fewer would not show which side
    of the margin (printed ``margin_text``) it is on (a minimum 0.4 um below a margin of 12.1862 mm printed 12.19):
    printed below the margin exactly when it is below it. None when 9 decimals (a picometre) do not tell them apart."""
    for n in range(2, 10):
        shown = f"{v * 1000:.{n}f}"
        if not np.isfinite(v) or (float(shown) < float(margin_text)) == (v < margin):
            return shown
    return None


def _margin_text(margin: float, values: list[float]) -> str:
    """The margin (m) as the report prints it, in mm: 6 significant digits, or all its own where those cannot tell it
    apart from a clearance of ``values`` (one between the margin and its rounding)."""
    text = f"{margin * 1000:g}"
    return text if all(_mm(v, margin, text) for v in values) else np.format_float_positional(margin * 1000, trim="-")


def format_report(r: VerifyReport) -> str:
    """The table ``foam-mj verify`` prints, and a last summary line."""
    margin = _margin_text(r.margin, [v for p in r.paths for v in (p.min_clearance, p.proved_clearance)])
    mm = lambda v: _mm(v, r.margin, margin) or f"{v * 1000:.9f}"  # noqa: E731
    head = (f"{'path':<20}{'waypoint samples':>17}{'trajectory samples':>20}{'min clear':>11}{'proved':>11}{'violations':>11}"
            "  closest pair")
    pairs = _count(r.pairs, "moving/static geom pair") + (f" and {_count(r.self_pairs, 'robot/robot pair')}" if r.self_pairs else "")
    lines = [f"verify {_shown(str(r.result))} on {_shown(str(r.mjcf))}: {pairs}, step {r.step:g}, margin {margin} mm",
             head, "-" * len(head)]
    for p in r.paths:
        proved = "none" if np.isnan(p.proved_clearance) else f"{mm(p.proved_clearance)} mm"
        lines.append(f"{_shown(p.name):<20}{p.waypoint_samples:>17,}{p.trajectory_samples:>20,}{mm(p.min_clearance):>8} mm"
                     f"{proved:>11}{p.violations:>11}  {_shown(p.worst_pair[0])} / {_shown(p.worst_pair[1])}")
    for p in r.paths:
        if p.outside_range:
            lines.append(f"path '{_shown(p.name)}': {p.outside_range} samples outside the joint ranges: {p.range_note}")
        if p.proof_note:
            lines.append(f"path '{_shown(p.name)}': no proof between samples: {p.proof_note}")
    faults = ([f"{r.violations} sample(s) closer than the margin"] if r.violations else []) + \
             ([f"{r.outside_range} sample(s) outside the joint ranges"] if r.outside_range else []) + \
             ([f"{r.unproved:,} stretch(es) between samples not proved clear (the clearance touches the margin)"] if r.unproved else [])
    verdict = "UNSAFE: " + "; ".join(faults) if faults else "clean"
    if not faults and not np.isnan(r.proved_clearance):
        verdict += f", proved: every point of every path at least {mm(r.proved_clearance)} mm clear"
    lines.append(f"paths {len(r.paths)} samples {r.samples} min_clearance_mm {mm(r.min_clearance)} "
                 f"violations {r.violations}: {verdict}")
    return "\n".join(lines)
