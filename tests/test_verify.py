"""`foam-mj verify`: the product's own independent check of a saved result (MuJoCo, numpy and the JSON only)."""

from __future__ import annotations

import ast
import copy
import json
import re
import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest

from hypothesis import given, settings
from hypothesis import strategies as st

from foam_mj.cli import main
from foam_mj.errors import FoamError
from foam_mj.verify import _Checker, _densify, _distance, _levers, collision_pairs, verify_result

ROOT = Path(__file__).resolve().parents[1]


def _hand_made(tmp_path: Path, name: str, mjcf: str | None, waypoints: list, delta: float = 0.005, qpos0: list | None = None,
               **fields) -> Path:
    """A result file written by hand (no planner): ``mjcf`` (if given) saved as NAME.xml beside it, every qpos entry a
    configuration coordinate of scale 1 unless ``qpos0`` (the scene's held pose) says there are more qpos entries,
    one path of ``waypoints``; ``fields`` are added to the document (robot, ...)."""
    if mjcf is not None:
        (tmp_path / f"{name}.xml").write_text(mjcf)
    n = len(waypoints[0])
    doc = {"format": "foam-mj/result", "version": 1, "mjcf": f"{name}.xml", "planner": {"delta": delta},
           "configuration": {"qpos_index": list(range(n)), "scale": [1.0] * n, "offset": [0.0] * n,
                             "qpos0": [0.0] * n if qpos0 is None else qpos0},
           "paths": {name: {"waypoints": waypoints}}, **fields}
    (tmp_path / f"{name}.json").write_text(json.dumps(doc))
    return tmp_path / f"{name}.json"


def test_a_clean_result_passes(planned_result, capsys):
    assert main(["verify", str(planned_result)]) == 0
    out = capsys.readouterr().out
    last = out.strip().splitlines()[-1]
    assert last.startswith("paths 2 samples ") and "violations 0: clean" in last
    report = verify_result(planned_result)
    doc = json.loads(planned_result.read_text())
    for check in report.paths:
        entry = doc["paths"][check.name]
        # Dense: at least one sample per 1e-3 of path length in q, and every trajectory row.
        assert check.waypoint_samples >= entry["metrics"]["length"] / 1e-3
        assert check.trajectory_samples >= len(entry["qpos"])
        assert check.min_clearance >= doc["planner"]["delta"]
        # The planner's replay measured the same trajectory: verify's minimum is at most that (it samples more).
        assert check.min_clearance <= entry["replay"]["min_clearance"] + 1e-9


def _closest_colliding_q(doc) -> list[float]:
    """A configuration in the obstacle box, found by MuJoCo alone on a grid of the bounds."""
    m = mujoco.MjModel.from_xml_path(doc["mjcf"])
    d = mujoco.MjData(m)
    cfg = doc["configuration"]
    pairs = collision_pairs(m)
    grid = np.stack(np.meshgrid(*[np.linspace(lo, hi, 9) for lo, hi in zip(cfg["lower"], cfg["upper"])]), -1).reshape(-1, 3)
    for q in grid:
        d.qpos[:] = cfg["qpos0"]
        d.qpos[cfg["qpos_index"]] = np.asarray(cfg["offset"]) + np.asarray(cfg["scale"]) * q
        mujoco.mj_kinematics(m, d)
        if min(mujoco.mj_geomDistance(m, d, a, b, 1.0, None) for a, b in pairs if "floor" not in (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, b) or "")) < -0.01:
            return q.tolist()
    raise AssertionError("no colliding configuration on the grid")


def test_a_waypoint_moved_into_the_obstacle_fails(planned_result, tmp_path, capsys):
    doc = json.loads(planned_result.read_text())
    wp = doc["paths"]["optimal"]["waypoints"]
    wp[len(wp) // 2] = _closest_colliding_q(doc)
    bad = tmp_path / "moved.json"
    bad.write_text(json.dumps(doc))
    assert main(["verify", str(bad)]) == 4
    out = capsys.readouterr().out
    rows = {ln.split()[0]: ln for ln in out.splitlines()[3:-1]}
    assert rows["centre"].split()[-4] == "0" and int(rows["optimal"].split()[-4]) > 0
    assert "UNSAFE" in out.splitlines()[-1]
    # A trajectory row moved into the obstacle is caught as well.
    doc = json.loads(planned_result.read_text())
    rows_q = doc["paths"]["centre"]["qpos"]
    cfg = doc["configuration"]
    qpos = np.asarray(cfg["qpos0"], float)
    qpos[cfg["qpos_index"]] = np.asarray(cfg["offset"]) + np.asarray(cfg["scale"]) * _closest_colliding_q(doc)
    rows_q[len(rows_q) // 2] = qpos.tolist()
    bad.write_text(json.dumps(doc))
    report = verify_result(bad)
    assert {p.name: p.violations > 0 for p in report.paths} == {"centre": True, "optimal": False}


def test_the_pruned_check_equals_the_brute_force_one(planned_result):
    """The bounding-sphere pruning changes nothing: same minimum and violations as every pair at every sample."""
    doc = json.loads(planned_result.read_text())
    m = mujoco.MjModel.from_xml_path(doc["mjcf"])
    d = mujoco.MjData(m)
    pairs = collision_pairs(m)
    rows = np.asarray(doc["paths"]["centre"]["qpos"])[::7]
    rng = np.random.default_rng(3)
    rows = np.vstack([rows, rows[rng.integers(len(rows), size=50)] + rng.normal(0, 0.15, (50, m.nq))])  # some in collision
    brute = np.empty((len(rows), len(pairs)))
    for i, row in enumerate(rows):
        d.qpos[:] = row
        mujoco.mj_kinematics(m, d)
        brute[i] = [mujoco.mj_geomDistance(m, d, a, b, 10.0, None) for a, b in pairs]
    lever = _levers(m, np.asarray(doc["configuration"]["qpos_index"]))
    for margin in (0.005, 0.05):
        calls = {}
        for anchored in (False, True):  # sphere bounds alone, and raised from exact distances at every 16th row
            checker = _Checker(m, pairs, lever if anchored else None)
            dmin, bad, _ = checker.check(rows, margin)
            assert dmin == pytest.approx(brute.min(), abs=1e-12)
            assert bad == int(np.sum(brute.min(axis=1) < margin))
            assert checker.calls < brute.size  # and it did prune
            calls[anchored] = checker.calls
        assert calls[True] < calls[False]
    # The bounds it returns hold at every row: below each row's true minimum, over its moving/static pairs.
    seen = _Checker(m, pairs, lever).measure(rows, 0.005)
    assert np.all(seen.obstacle_bound <= brute.min(axis=1) + 1e-12)


def test_densify_keeps_every_step_small_in_both_units():
    pts = np.array([[0.0, 0.0], [0.3, 0.0], [0.3, 0.0], [0.3, 0.05]])
    extra = np.column_stack([pts[:, 0] * 2, pts[:, 1]])  # qpos: the first coordinate scaled by 2
    s = _densify(pts, extra, 1e-3)
    assert np.allclose(s[0], extra[0]) and np.allclose(s[-1], extra[-1])
    assert np.max(np.abs(np.diff(s, axis=0))) <= 1e-3 + 1e-12


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    out = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.Import):
            out |= {a.name for a in n.names}
        elif isinstance(n, ast.ImportFrom):
            out.add(n.module or "")
    return out


def test_verify_uses_none_of_the_planners_code():
    assert _imports(ROOT / "foam_mj" / "verify.py") <= {
        "__future__", "json", "dataclasses", "pathlib", "mujoco", "numpy", "foam_mj.errors", "foam_mj.fingerprint",
        "foam_mj.verify_geometry"}
    assert _imports(ROOT / "foam_mj" / "verify_geometry.py") <= {"__future__", "dataclasses", "mujoco", "numpy", "foam_mj.errors"}
    assert _imports(ROOT / "foam_mj" / "fingerprint.py") <= {"__future__", "hashlib", "mujoco", "numpy"}
    assert _imports(ROOT / "foam_mj" / "errors.py") <= {"__future__", "difflib", "math", "numbers", "os", "stat", "typing"}  # the standard library only


def test_verify_refuses_bad_input(tmp_path, planned_result, capsys):
    assert main(["verify", str(tmp_path / "none.json")]) == 2
    (tmp_path / "x.json").write_text("{")
    assert main(["verify", str(tmp_path / "x.json")]) == 2
    doc = json.loads(planned_result.read_text())
    del doc["configuration"]["qpos_index"]
    (tmp_path / "old.json").write_text(json.dumps(doc))
    assert main(["verify", str(tmp_path / "old.json")]) == 2
    assert "q -> qpos map" in capsys.readouterr().err
    assert main(["verify", str(planned_result), "--step", "0"]) == 2


def test_verify_result_in_python_names_a_result_that_is_no_path(planned_result):
    """A dict or None was "expected str, bytes or os.PathLike object"."""
    for result in (None, 5, {"format": "foam-mj/result"}):
        with pytest.raises(TypeError, match=r"`result` must be the path of a result file \(plan --json\)"):
            verify_result(result)


def test_verify_result_in_python_names_a_step_that_is_no_number(planned_result):
    for step in ("1e-3", None, True):  # a string was numpy's "ufunc 'isfinite' not supported"
        with pytest.raises(FoamError, match=r"--step must be a positive number at most 0\.1 .*, got"):
            verify_result(planned_result, step=step)


def test_a_step_too_small_to_sample_is_refused_before_any_allocation(planned_result, capsys):
    """--step 1e-12 asked numpy for 33.6 TiB: a MemoryError, exit 1. A path of more than a million samples is refused."""
    for step in ("1e-12", "1e-300"):
        assert main(["verify", str(planned_result), "--step", step]) == 2
        err = capsys.readouterr().err.strip()
        assert f"samples at --step {step} (at most 1,000,000 on one path): use a larger step" in err and "\n" not in err, err
    assert main(["verify", str(planned_result), "--step", "1e-4"]) == 0


def test_a_step_too_coarse_to_sample_between_waypoints_is_refused_before_any_work(tmp_path, planned_result, capsys):
    """--step 1e308 checked only the waypoints and said "clean". A step above 0.1 (rad or m) is refused in one line,
    exit 2, before the result is read (a missing file is not even looked at)."""
    for step in ("1e308", "0.5", "inf"):
        assert main(["verify", str(tmp_path / "none.json"), "--step", step]) == 2
        err = capsys.readouterr().err.strip()
        assert "--step must be a positive number at most 0.1 (rad or m, in q and in qpos), got" in err, err
        assert "\n" not in err and "not found" not in err, err
    with pytest.raises(FoamError, match=r"at most 0\.1"):
        verify_result(planned_result, step=1e308)
    assert main(["verify", str(planned_result), "--step", "0.1"]) == 0
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main(["verify", "--help"])
    assert "at most 0.1" in " ".join(capsys.readouterr().out.split())  # the help states the bound


def test_a_waypoint_far_beyond_the_scene_is_named_in_one_line(tmp_path, planned_result, capsys):
    """A waypoint of 1e308 (a damaged file) overflowed numpy's norm: a RuntimeWarning line, then a message that
    blamed --step. One line now names the path and the segment."""
    doc = json.loads(planned_result.read_text())
    name = next(iter(doc["paths"]))
    doc["paths"][name]["waypoints"][1][0] = 1e308
    (tmp_path / "far.json").write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow warning would fail the test
        assert main(["verify", str(tmp_path / "far.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert f"path '{name}': waypoints: its longest segment is inf long" in err and "\n" not in err, err


@pytest.mark.parametrize("edit, words", [
    (lambda d, p: d["planner"].__setitem__("delta", "5 mm"), "field 'planner.delta' must be a margin >= 0 in metres, got '5 mm'"),
    (lambda d, p: d["paths"][p].__setitem__("qpos", [[0.1, "x", 0.2]]), "field 'qpos' must be a list of rows of 3 numbers each"),
    (lambda d, p: d["paths"][p]["waypoints"][1].append([1]), "field 'waypoints' must be a list of rows of 3 numbers each"),
    (lambda d, p: d["paths"].__setitem__(p, [1, 2]), "misses field 'waypoints'"),
    (lambda d, p: d["paths"][p]["waypoints"][1].__setitem__(0, str(d["paths"][p]["waypoints"][1][0])),
     "field 'waypoints' must be a list of rows of 3 numbers each"),
    (lambda d, p: d["paths"][p]["waypoints"][1].__setitem__(0, True), "field 'waypoints' must be a list of rows of 3 numbers each"),
    (lambda d, p: d["paths"][p]["qpos"][1].__setitem__(0, str(d["paths"][p]["qpos"][1][0])), "field 'qpos' must be a list of rows of 3 numbers each"),
    (lambda d, p: d["q_init"].__setitem__(0, str(d["q_init"][0])), "field 'q_init' must be a list of 3 numbers"),
    (lambda d, p: d["configuration"].__setitem__("qpos_index", [i + 0.25 for i in d["configuration"]["qpos_index"]]),
     "field 'configuration': qpos_index must be integers"),
    (lambda d, p: d["configuration"]["scale"].__setitem__(0, float("nan")),
     "field 'configuration': scale, offset and qpos0 must be finite numbers (no NaN or infinity)"),
    (lambda d, p: d["model_hash"].__setitem__("parts", "x"), "field 'model_hash' must be an object"),
    (lambda d, p: d["planner"].__setitem__("delta", 10 ** 400), "field 'planner.delta' must be a margin >= 0 in metres"),
    (lambda d, p: d.__setitem__("robot", [1]), "field 'robot' must be an object with robot_root, self_collision and keyframe"),
    (lambda d, p: d["robot"].__setitem__("self_collision", "false"), "field 'robot.self_collision' must be true or false, got 'false'"),
    (lambda d, p: d["robot"].__setitem__("keyframe", 3), "field 'robot.keyframe' must be a keyframe name or null, got 3"),
    (lambda d, p: d["paths"][p].__setitem__("times", "abc"), "field 'times' must be a list of numbers"),
])
def test_a_damaged_field_is_named_as_it_is(tmp_path, planned_result, capsys, edit, words):
    """A margin that is a string was called missing; a bad qpos row was blamed on 'waypoints and qpos' together.
    A number written as a string ("0.3", as numpy reads it), true for 1, a qpos_index of 1.25 (read as 1) or a NaN
    scale (every sample NaN) passed as clean (exit 0). A model_hash whose parts are a string and a margin of 10**400
    were internal errors (exit 1); a 'robot' that is a list, self_collision "false" (read as true) and 'times' that
    are a string passed as clean."""
    doc = json.loads(planned_result.read_text())
    edit(doc, next(iter(doc["paths"])))
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    assert main(["verify", str(tmp_path / "bad.json")]) == 2
    assert words in capsys.readouterr().err


@pytest.mark.parametrize("where, value, words", [
    ("scale", "1" + "0" * 400, "field 'configuration': scale, offset and qpos0 must be finite numbers"),
    ("qpos0", "-1" + "0" * 400, "field 'configuration': scale, offset and qpos0 must be finite numbers"),
    ("qpos_index", "1" + "0" * 30, "field 'configuration' does not fit the scene (nq = 3)"),
    ("waypoints", "1" + "0" * 400, "waypoints of shape (2, 3), expected (N >= 2, 3) finite numbers"),
    ("qpos", "1" + "0" * 400, "qpos rows of shape"),
    ("q_init", "1" + "0" * 400, "not at the result's q_init [inf,"),
    ("delta", "7" * 5000, "field 'planner.delta' must be a margin >= 0 in metres, got inf"),
    ("version", "-" + "1" * 4400, "unknown format version -inf"),
])
def test_an_integer_too_large_for_a_float_is_named_as_a_bad_field(planned_result, capsys, where, value, words):
    """JSON integers have no size limit: 10**400 as a scale, a waypoint or a qpos row and 10**30 in qpos_index were
    internal errors (OverflowError, exit 1), and an integer of 5,000 digits anywhere in the file another (Python's
    4,300-digit limit on reading integers, exit 1). They are read as infinite (any integer beyond a float's range), so
    the field that holds one is named (exit 2), as for 1e400."""
    doc = json.loads(planned_result.read_text())
    name = next(iter(doc["paths"]))
    path = doc["paths"][name]
    if where in ("scale", "qpos0", "qpos_index"):
        doc["configuration"][where][0] = "HUGE"
    elif where in ("waypoints", "qpos"):
        path[where] = [path[where][0], ["HUGE"] * 3]
    elif where == "delta":
        doc["planner"]["delta"] = "HUGE"
    else:
        doc[where] = ["HUGE"] * 3 if where == "q_init" else "HUGE"
    bad = planned_result.parent / "huge.json"  # beside the result: its mjcf_relative still resolves
    bad.write_text(json.dumps(doc).replace('"HUGE"', value))  # (Python itself refuses to print a 5,000-digit int)
    assert main(["verify", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and "internal error" not in err and len(err.splitlines()) == 1, err[:300]


@pytest.mark.parametrize("scale, offset, waypoints, rows, words", [
    (1e308, 0.0, [[2.0], [3.0]], None, "its waypoints map to qpos beyond a float's range (waypoint 0, x (qpos[0]): offset + scale q = inf)"),
    (1e308, -1e308, [[-1.0], [1.0]], None, "its waypoints map to qpos beyond a float's range (waypoint 0, x (qpos[0]): offset + scale q = -inf)"),
    (1e-308, 0.0, [[-2e307], [-2e307]], [[-0.2], [2.0], [-0.2]],
     "its qpos rows map to q beyond a float's range (row 1, coordinate 0: (qpos - offset) / scale = inf)"),
])
def test_a_scale_that_overflows_the_map_between_q_and_qpos_is_named(tmp_path, capsys, scale, offset, waypoints, rows, words):
    """A configuration scale of 1e308 took the waypoints to qpos inf (offset + scale q): inf - inf between them, two
    'overflow'/'invalid value' warnings, then numpy's 'repeats may not contain negative values' (exit 1; found by
    fuzzing the arm's result); a scale of 1e-308 took a row to q inf ((qpos - offset) / scale), an 'overflow' warning line
    before the error. One line now names the path, the waypoint or row and the coordinate (exit 2)."""
    (tmp_path / "cart.xml").write_text(CART_AND_POST.format(group=1))
    result = _hand_made(tmp_path, "cart", None, waypoints)
    doc = json.loads(result.read_text())
    doc["configuration"].update(scale=[scale], offset=[offset])
    if rows is not None:
        doc["paths"]["cart"]["qpos"] = rows
    result.write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow warning would fail the test
        assert main(["verify", str(result)]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and "internal error" not in err and len(err.splitlines()) == 1, err


@pytest.mark.parametrize("edit, words", [
    (lambda d: d["planner"].__setitem__("delta", -1.0), "planner.delta"),
    (lambda d: d["planner"].__setitem__("delta", float("nan")), "planner.delta"),
    (lambda d: d.__setitem__("paths", {}), "nothing to verify"),
    (lambda d: d.update(paths={}, outcome="time budget"), "the plan failed (outcome 'time budget'): the result has no paths"),
])
def test_a_result_that_would_pass_vacuously_is_refused(tmp_path, planned_result, capsys, edit, words):
    """A negative margin (every sample passes) or no path at all is bad input (2), never 'clean' (0)."""
    doc = json.loads(planned_result.read_text())
    edit(doc)
    bad = planned_result.parent / "vacuous.json"   # beside the result: its mjcf_relative still resolves
    bad.write_text(json.dumps(doc))
    assert main(["verify", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err



@pytest.mark.parametrize("edit, words", [
    (lambda p: p.__setitem__("qpos", p["qpos"][:10]), "its qpos rows end at"),
    (lambda p: p.__setitem__("qpos", p["qpos"][5:]), "its qpos rows start at"),
    (lambda p: p.__setitem__("times", p["times"][:-1]), "'qpos' has {rows} rows but 'times' {times}"),
    (lambda p: p.__setitem__("qpos", []), "'times' has {times} entries but 'qpos' no rows"),
    (lambda p: p.pop("qpos"), "'times' has {times} entries but 'qpos' no rows"),
    (lambda p: p.__setitem__("qpos", [[]]), "qpos rows of shape (1, 0), expected (N, 3) finite numbers"),
])
def test_a_trajectory_cut_short_or_off_its_times_is_refused(planned_result, capsys, edit, words):
    """verify checks the timed trajectory as the qpos rows hold it: rows cut off after the tenth (a copy cut short, a
    hand edit) passed as clean (exit 0) though the motion never reaches the goal, and replay and export refused the
    same file. Its rows must join the path's own end points, one row per entry of 'times'. A timed path whose rows were
    emptied, deleted or made [[]] had its waypoints checked alone and passed as clean (verify_result.py: 'no qpos rows')."""
    doc = json.loads(planned_result.read_text())
    path = doc["paths"][next(iter(doc["paths"]))]
    edit(path)
    bad = planned_result.parent / "cut.json"   # beside the result: its mjcf_relative still resolves
    bad.write_text(json.dumps(doc))
    assert main(["verify", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words.format(rows=len(path.get("qpos", [])), times=len(path["times"])) in err, err



LOOSE_BOX_ARM = """<mujoco model="arm beside a loose box">
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <geom name="post" type="box" pos="0.45 0 0.125" size="0.04 0.2 0.125"/>
    <body pos="0 0 0.5">
      <joint name="shoulder" type="hinge" axis="0 1 0" range="-100 100"/>
      <geom name="upper" type="capsule" fromto="0 0 0 0.35 0 0" size="0.03" mass="1.2"/>
      <body pos="0.35 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0" range="-150 150"/>
        <geom name="fore" type="capsule" fromto="0 0 0 0.3 0 0" size="0.025" mass="0.6"/>
      </body>
    </body>
    <body name="loose" pos="-0.6 0 0.05"><freejoint/><geom name="loose_box" type="box" size="0.05 0.05 0.05"/></body>
  </worldbody>
</mujoco>
"""


def test_a_loose_object_resting_on_the_floor_is_an_obstacle_not_a_violation(tmp_path, capsys):
    """A free-jointed box lying on the floor (distance 0) is no joint of the configuration: the planner
    treats it as an obstacle at its qpos0, and so does verify; the arm is still checked against it."""
    xml = tmp_path / "arm.xml"
    xml.write_text(LOOSE_BOX_ARM)
    out = tmp_path / "arm.json"
    assert main(["plan", "--mjcf", str(xml), "--start", "0.3 2.0", "--goal", "0.1 0.6", "--smoother", "none",
                 "--no-replay", "--no-rrd", "--json", str(out)]) == 0
    capsys.readouterr()
    assert main(["verify", str(out)]) == 0
    m = mujoco.MjModel.from_xml_path(str(xml))
    gid = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n)  # noqa: E731
    pairs = {tuple(p) for p in collision_pairs(m, np.array([0, 1])).tolist()}   # qpos 0, 1: shoulder, elbow
    assert (gid("upper"), gid("loose_box")) in pairs and (gid("fore"), gid("loose_box")) in pairs
    assert (gid("loose_box"), gid("floor")) not in pairs and len(pairs) == 6


FOLDING_ARM = """<mujoco model="three-link arm that can fold onto itself">
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body pos="0 0 1.0">
      <joint name="j1" type="hinge" axis="0 1 0" range="-60 60"/>
      <geom name="link1" type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" mass="1"/>
      <body pos="0.4 0 0">
        <joint name="j2" type="hinge" axis="0 1 0" range="-170 170"/>
        <geom name="link2" type="capsule" fromto="0 0 0 0.1 0 0" size="0.03" mass="1"/>
        <body pos="0.1 0 0">
          <joint name="j3" type="hinge" axis="0 1 0" range="-170 170"/>
          <geom name="link3" type="capsule" fromto="0 0 0 0.35 0 0" size="0.03" mass="1"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _plan_folding_arm(tmp_path, capsys, *args: str):
    """FOLDING_ARM planned with ``args`` (no smoother) to a JSON that ``verify`` passes -> (MJCF path, JSON path)."""
    xml = tmp_path / "arm.xml"
    xml.write_text(FOLDING_ARM)
    out = tmp_path / "arm.json"
    assert main(["plan", "--mjcf", str(xml), *args, "--smoother", "none", "--no-replay", "--no-rrd", "--json", str(out)]) == 0
    capsys.readouterr()
    assert main(["verify", str(out)]) == 0
    return xml, out


def test_the_robot_touching_itself_is_a_violation_unless_planned_without_self_collision(tmp_path, capsys):
    """link3 folded back onto link1 (two links apart: MuJoCo tests that pair) is unsafe; the planner checked
    robot/robot pairs, and so does verify, with a rule of its own (MuJoCo's filter, not the planner's code)."""
    xml, out = _plan_folding_arm(tmp_path, capsys, "--start", "0 0 0", "--goal", "0.3 0.5 0.5")
    assert "1 robot/robot pair," in capsys.readouterr().out
    m = mujoco.MjModel.from_xml_path(str(xml))
    gid = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n)  # noqa: E731
    pairs = {tuple(p) for p in collision_pairs(m, np.array([0, 1, 2]), self_collision=True).tolist()}
    assert (gid("link1"), gid("link3")) in pairs                 # two links apart
    assert (gid("link1"), gid("link2")) not in pairs and (gid("link2"), gid("link3")) not in pairs   # parent/child
    doc = json.loads(out.read_text())
    folded = [0.0, np.radians(170), np.radians(10)]               # link3 comes back along link1
    d = mujoco.MjData(m)
    d.qpos[:] = np.asarray(doc["configuration"]["offset"]) + np.asarray(doc["configuration"]["scale"]) * folded
    mujoco.mj_kinematics(m, d)
    assert mujoco.mj_geomDistance(m, d, gid("link1"), gid("link3"), 1.0, None) < 0
    assert min(mujoco.mj_geomDistance(m, d, g, gid("floor"), 1.0, None) for g in (gid("link1"), gid("link2"), gid("link3"))) > 0.1
    wp = doc["paths"]["centre"]["waypoints"]
    wp.insert(len(wp) // 2, folded)
    doc["paths"]["centre"]["qpos"] = []
    bad = tmp_path / "folded.json"
    bad.write_text(json.dumps(doc))
    assert main(["verify", str(bad)]) == 4
    assert "link1 / link3" in capsys.readouterr().out
    doc["robot"]["self_collision"] = False                       # planned without robot/robot pairs: not checked
    bad.write_text(json.dumps(doc))
    assert main(["verify", str(bad)]) == 0


def test_a_link_held_still_is_an_obstacle_except_where_it_meets_the_moving_link_at_their_joint(tmp_path, capsys):
    """Only j3 a coordinate: link1 and link2 stay at qpos0 and are obstacles for link3, unfiltered, except link2,
    link3's parent, whose capsule overlaps link3's at j3 by design (MuJoCo never collides parent and child, nor
    does the planner). verify used to count that overlap (-60 mm) on every sample and call a clean plan UNSAFE."""
    xml, out = _plan_folding_arm(tmp_path, capsys, "--joints", "j3", "--start", "0", "--goal", "1.0")
    assert "violations 0: clean" in capsys.readouterr().out
    m = mujoco.MjModel.from_xml_path(str(xml))
    gid = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n)  # noqa: E731
    pairs = {tuple(p) for p in collision_pairs(m, np.array([2]), self_collision=True).tolist()}
    assert pairs == {(gid("link3"), gid("floor")), (gid("link3"), gid("link1"))}


CART_AND_POST = """<mujoco><worldbody>
  <body name="cart"><joint name="x" type="slide" axis="1 0 0" range="-1 1"/>
    <geom name="ball" type="sphere" size="0.05" contype="1" conaffinity="1"/></body>
  <geom name="post" type="sphere" size="0.05" pos="0.5 0 0" contype="{group}" conaffinity="{group}"/>
</worldbody></mujoco>"""


@pytest.mark.parametrize("group, offset, scale", [(1, 0.0, 1.0), (2, 0.0, 1.0), (1, 0.3, 0.5)],
                         ids=["exact-bound", "other-collision-group", "normalized-with-offset"])
def test_a_ball_that_ends_half_a_millimetre_inside_the_margin_is_a_violation(tmp_path, group, offset, scale):
    """A slide carries a ball to 4.5 mm from a ball post (margin 5 mm): a violation, where the bounding-sphere bound
    that prunes the exact queries is itself exact (two spheres), where the post is in another collision group
    (contype/conaffinity 2: MuJoCo would not collide them, the planner and verify check every robot/obstacle pair),
    and where q maps to qpos through an offset and a scale (qpos = offset + scale q)."""
    (tmp_path / "cart.xml").write_text(CART_AND_POST.format(group=group))
    end = 0.5 - 0.1 - 0.0045  # qpos of the cart 4.5 mm from the post
    doc = {"format": "foam-mj/result", "version": 1, "mjcf": str(tmp_path / "cart.xml"), "planner": {"delta": 0.005},
           "configuration": {"qpos_index": [0], "scale": [scale], "offset": [offset], "qpos0": [0.0]},
           "paths": {"straight": {"waypoints": [[(0.0 - offset) / scale], [(end - offset) / scale]]}}}
    (tmp_path / "cart.json").write_text(json.dumps(doc))
    report = verify_result(tmp_path / "cart.json")
    assert report.violations >= 1
    assert report.min_clearance == pytest.approx(0.0045, abs=1e-9)


@pytest.mark.parametrize("margin_mm, end_mm, shown, margin_shown", [
    (12.1862, 12.1858, "12.186", "12.1862"), (12.1862, 12.1866, "12.19", "12.1862"), (12.184, 12.1842, "12.184", "12.184"),
    (12.1862, 12.18619, "12.186", "12.1862"), (12.34564, 12.34562, "12.3456", "12.34564"), (5, 84.85, "84.85", "5")])
def test_the_minimum_is_printed_with_the_digits_that_show_how_it_compares_with_the_margin(tmp_path, capsys, margin_mm,
                                                                                          end_mm, shown, margin_shown):
    """A ball 12.1858 mm from the post, a margin of 12.1862 mm: a violation printed 'min clear 12.19 mm' beside 'margin
    12.1862 mm' (12.1842 mm beside a margin of 12.184 printed 12.18, clean), a contradiction to the eye. The minimum
    keeps 2 decimals, and gets more only where fewer would put it on the wrong side of the margin as printed; the
    margin keeps its 6 significant digits, and gets all its own where those cannot tell them apart (12.34564 mm, printed
    12.3456, with a violation at 12.34562)."""
    (tmp_path / "cart.xml").write_text(CART_AND_POST.format(group=1))
    result = _hand_made(tmp_path, "cart", None, [[0.0], [0.4 - end_mm / 1000]], delta=margin_mm / 1000)
    unsafe = end_mm < margin_mm
    assert main(["verify", str(result)]) == (4 if unsafe else 0)
    out = capsys.readouterr().out.splitlines()
    margin_text = re.search(r"margin (\S+) mm", out[0]).group(1)
    assert margin_text == margin_shown
    row = out[3].split()
    summary = re.search(r"min_clearance_mm (\S+) ", out[-1]).group(1)
    assert row[3] == summary == shown
    assert (float(shown) < float(margin_text)) == unsafe and float(margin_text) == pytest.approx(margin_mm, abs=1e-9)
    if not unsafe:  # the proved clearance as well (at most the minimum, at least the margin)
        proved = re.search(r"at least (\S+) mm clear", out[-1]).group(1)
        assert float(margin_text) <= float(proved) <= float(shown) and proved == row[5]


def test_a_configuration_that_maps_two_coordinates_to_one_qpos_entry_is_refused(tmp_path, capsys):
    """qpos_index [0, 0]: the second coordinate overwrote the first (the last wins), so a path whose first coordinate
    drives the ball through the post while the second stays at 0 was checked standing still and called clean."""
    (tmp_path / "cart.xml").write_text(CART_AND_POST.format(group=1))
    result = _hand_made(tmp_path, "cart", None, [[0.0, 0.0], [0.5, 0.0]])
    doc = json.loads(result.read_text())
    doc["configuration"]["qpos0"] = [0.0]
    doc["configuration"]["qpos_index"] = [0, 0]
    result.write_text(json.dumps(doc))
    assert main(["verify", str(result)]) == 2
    err = capsys.readouterr().err.strip()
    assert "field 'configuration': qpos_index repeats 0 (at positions 0 and 1)" in err and "\n" not in err, err
    assert "Traceback" not in err
    doc["configuration"]["qpos_index"], doc["configuration"]["scale"], doc["configuration"]["offset"] = [0], [1.0], [0.0]
    doc["paths"]["cart"]["waypoints"] = [[0.0], [0.5]]
    result.write_text(json.dumps(doc))
    assert main(["verify", str(result)]) == 4  # the same motion, one coordinate: through the post


MOCAP_WALL = """<mujoco model="a cart whose keyframe puts a mocap wall across its path">
  <worldbody>
    <body name="cart"><joint name="x" type="slide" axis="1 0 0" range="-1 1"/><geom name="ball" type="sphere" size="0.05"/></body>
    <body name="wall" mocap="true" pos="5 0 0"><geom name="slab" type="box" size="0.01 0.5 0.5"/></body>
  </worldbody>
  <keyframe><key name="in" qpos="0" mpos="{x} 0 0"/></keyframe>
</mujoco>"""


def test_a_keyframe_that_moves_a_mocap_obstacle_off_the_scene_is_refused(tmp_path, capsys):
    """The result's keyframe puts the mocap wall across the cart's path (x = 0.3), the scene at x = 5: the planner plans
    with the wall where the keyframe puts it (and saves that scene beside its result), MuJoCo loads it there, but
    verify's distances, of qpos alone, saw it at 5 m and called the path through it clean (exit 0). Such a result is
    not of this scene as written: refused (exit 2, one line); the scene the planner saves (the wall placed) passes."""
    robot = {"robot_root": None, "self_collision": True, "keyframe": "in"}
    result = _hand_made(tmp_path, "wall", MOCAP_WALL.format(x=0.3), [[-0.5], [0.5]], robot=robot)
    assert main(["verify", str(result)]) == 2
    err = capsys.readouterr().err.strip()
    assert "field 'robot.keyframe': keyframe 'in' puts mocap body 'wall' at [0.3, 0, 0], where the scene has it at [5, 0, 0]" in err
    assert "\n" not in err and "Traceback" not in err
    placed = MOCAP_WALL.format(x=0.3).replace('pos="5 0 0"', 'pos="0.3 0 0"')
    assert main(["verify", str(_hand_made(tmp_path, "placed", placed, [[-0.5], [0.5]], robot=robot))]) == 4  # through it
    assert main(["verify", str(_hand_made(tmp_path, "far", MOCAP_WALL.format(x=5), [[-0.5], [0.5]], robot=robot))]) == 0


def test_a_robot_root_that_holds_no_configuration_joint_is_refused(tmp_path, capsys):
    """robot_root names the post's body, not the cart's: the post became the robot's own, checked against the ball only
    as MuJoCo's filter allows (another collision group: never), and a path 100 mm through it passed as clean (exit 0),
    where plan refuses such a root ("configuration joint(s) ['x'] are not in the subtree of robot_root"). Refused."""
    xml = CART_AND_POST.format(group=2).replace("<worldbody>", '<worldbody><geom name="floor" type="plane" size="3 3 .1" pos="0 0 -1"/>')
    xml = xml.replace('<geom name="post"', '<body name="mount" pos="0.5 0 0"><geom name="post"').replace('pos="0.5 0 0" contype', 'contype')
    xml = xml.replace("</worldbody>", "</body></worldbody>")
    assert mujoco.MjModel.from_xml_string(xml).ngeom == 3
    robot = {"robot_root": "mount", "self_collision": True, "keyframe": None}
    result = _hand_made(tmp_path, "post", xml, [[0.0], [0.9]], robot=robot)
    assert main(["verify", str(result)]) == 2
    err = capsys.readouterr().err.strip()
    assert "field 'robot.robot_root' names 'mount', whose subtree holds no x (qpos[0])" in err and "\n" not in err, err
    robot["robot_root"] = None
    assert main(["verify", str(_hand_made(tmp_path, "post", None, [[0.0], [0.9]], robot=robot))]) == 4  # 100 mm into the post


def test_the_readme_shows_what_verify_prints(planned_result, capsys):
    """The README's `foam-mj verify r.json` output (Checking a result) is verify's on the default plan of the
    obstacle scene, but for the result's name and the scene's folder in its first line."""
    readme = (ROOT / "README.md").read_text()
    block = re.search(r"```\n(verify r\.json on .*?)```", readme, flags=re.S).group(1).splitlines()
    assert main(["verify", str(planned_result)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split(": ", 1)[1] == block[0].split(": ", 1)[1]
    assert out[1:] == block[1:]


FLOATING_HIP = """<mujoco model="a hip link overlapping its floating pelvis, which the MJCF's contype/conaffinity keep apart">
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <geom name="post" type="box" size="0.05 0.05 0.3" pos="0.45 0.1 0.3"/>
    <body name="pelvis" pos="0 0 1">
      <freejoint/>
      <geom name="pelvis" type="capsule" fromto="0 -0.1 0 0 0.1 0" size="0.08" contype="1" conaffinity="0"/>
      <body name="roll" pos="0 0.1 0">
        <joint name="roll" axis="1 0 0"/>
        <inertial pos="0 0 0" mass="0.1" diaginertia="1e-4 1e-4 1e-4"/>
        <body name="thigh">
          <joint name="hip" axis="0 1 0" range="-60 60"/>
          <geom name="thigh" type="capsule" fromto="0 0 0 0 0 -0.6" size="0.05" contype="2" conaffinity="4"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_result_planned_with_a_robot_root_is_checked_as_that_robot(tmp_path, capsys):
    """With robot_root the planner counts the held pelvis as part of the robot, so its pair with the planned thigh is
    a robot/robot one, which the MJCF's contype/conaffinity filter out (Cassie of MuJoCo Menagerie: the hip link lies
    66 mm inside the pelvis capsule). verify took the pelvis for an obstacle and reported every sample of a clean
    plan as a violation (exit 4); it now reads robot_root too, and still checks the pelvis against the world."""
    (tmp_path / "hip.xml").write_text(FLOATING_HIP)
    scenario = tmp_path / "hip.toml"
    scenario.write_text('name = "hip"\nscene = "hip.xml"\nrobot_root = "pelvis"\nq_init = [-0.6]\nq_goal = [0.9]\n')
    out = tmp_path / "hip.json"
    assert main(["plan", "--scene", str(scenario), "--smoother", "none", "--no-replay", "--no-rrd", "--json", str(out)]) == 0
    capsys.readouterr()
    assert main(["verify", str(out)]) == 0
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "hip.xml"))
    idx = np.array([m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "hip")]])

    def named(pairs) -> set[frozenset[str]]:
        return {frozenset(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, int(g)) for g in p) for p in pairs}

    pairs = named(collision_pairs(m, idx, True, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "pelvis")))
    assert pairs == {frozenset(p) for p in (("thigh", "floor"), ("thigh", "post"), ("pelvis", "floor"), ("pelvis", "post"))}
    assert frozenset(("pelvis", "thigh")) in named(collision_pairs(m, idx, True))  # without the root: an obstacle


def test_the_header_counts_pairs_in_words_that_agree_with_the_number():
    """'1 robot/robot pairs' read as a slip: one pair is 'pair', several 'pairs', none of robot/robot is left unsaid."""
    from foam_mj.verify import VerifyReport, format_report

    head = lambda pairs, self_pairs: format_report(VerifyReport(Path("r.json"), Path("s.xml"), 0.005, 1e-3, pairs, (), self_pairs)).splitlines()[0]  # noqa: E731
    assert head(6, 1) == "verify r.json on s.xml: 6 moving/static geom pairs and 1 robot/robot pair, step 0.001, margin 5 mm"
    assert head(1, 8) == "verify r.json on s.xml: 1 moving/static geom pair and 8 robot/robot pairs, step 0.001, margin 5 mm"
    assert head(6, 0) == "verify r.json on s.xml: 6 moving/static geom pairs, step 0.001, margin 5 mm"


def _plan_loose_box_arm(tmp_path, capsys, *args: str):
    """LOOSE_BOX_ARM (with a home keyframe) planned over shoulder and elbow, no smoother, timed -> (JSON path, doc)."""
    xml = tmp_path / "arm.xml"
    xml.write_text(LOOSE_BOX_ARM.replace("</mujoco>", '<keyframe><key name="home" qpos="0.3 2.0 -0.6 0 0.05 1 0 0 0"/>'
                                                      "</keyframe></mujoco>"))
    out = tmp_path / "arm.json"
    assert main(["plan", "--mjcf", str(xml), *args, "--goal", "0.1 0.6", "--smoother", "none", "--no-rrd",
                 "--json", str(out)]) == 0
    capsys.readouterr()
    return out, json.loads(out.read_text())


def _drop_shoulder(doc):
    """The result as if planned over the elbow alone (configuration, ends, waypoints), its rows unchanged: they still
    swing the shoulder, which the checker would then count as a link held still."""
    cfg = doc["configuration"]
    for key in ("joints", "lower", "upper", "qpos_index", "scale", "offset"):
        cfg[key].pop(0)
    for key in ("q_init", "q_goal"):
        doc[key].pop(0)
    for entry in doc["paths"].values():
        entry["waypoints"] = [w[1:] for w in entry["waypoints"]]


@pytest.mark.parametrize("start", ["0.3 2.0", "home"], ids=["qpos0", "keyframe"])
def test_the_rows_and_the_configuration_hold_every_other_joint_where_the_planner_held_it(tmp_path, capsys, start):
    """The planner holds every joint that is no coordinate at the scene's qpos0 (or the keyframe's pose), and the
    pairs verify checks follow from which joints move: a result whose configuration leaves out the shoulder while its
    rows swing it had the upper arm checked as a link held still, against nothing (an upper arm swung 15 mm into a
    lintel passed as clean, 7.4 mm, where verify_result.py and a dense mj_geomDistance read -14.9 mm); and a result
    whose qpos0 moves the loose box had it checked where no box is. Both are refused, naming the joint."""
    out, doc = _plan_loose_box_arm(tmp_path, capsys, "--start", start)
    assert main(["verify", str(out)]) == 0
    capsys.readouterr()
    for name, edit, words in [
        ("dropped", _drop_shoulder, "its qpos rows move shoulder (qpos[0]"),
        ("boxmoved", lambda d: d["configuration"]["qpos0"].__setitem__(2, 5.0),
         "field 'configuration': qpos0 puts joint 2 (qpos[2]) at 5, where the scene's "
         + ("keyframe 'home'" if start == "home" else "qpos0") + " has -0.6"),
        ("rowsmoved", lambda d: d["paths"]["centre"]["qpos"][3].__setitem__(2, 5.0), "its qpos rows move joint 2 (qpos[2]"),
        ("joints", lambda d: d["configuration"]["joints"].reverse(), "field 'configuration': joints[0] is elbow, "
         "whose qpos address is 1, not qpos_index[0] = 0"),
    ]:
        bad = copy.deepcopy(doc)
        edit(bad)
        (tmp_path / f"{name}.json").write_text(json.dumps(bad))
        assert main(["verify", str(tmp_path / f"{name}.json")]) == 2, name
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and words in err, err


def test_a_path_beyond_a_joint_range_is_unsafe_and_says_which_joint(planned_result, capsys):
    """The planner keeps every configuration within the joint ranges (its bounds are the MJCF's ranges); a trajectory
    row that bends the knee 0.05 rad past its 2.1 rad stop, clear of every obstacle, passed as clean (exit 0). It is
    unsafe (exit 4) and the line after the table names the joint, how far it went and its range."""
    doc = json.loads(planned_result.read_text())
    m = mujoco.MjModel.from_xml_path(doc["mjcf"])
    knee = int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "knee_flexion")])
    hi = float(m.jnt_range[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "knee_flexion")][1])
    rows = doc["paths"]["centre"]["qpos"]
    rows[len(rows) // 2][knee] = hi + 0.05
    bad = planned_result.parent / "bent.json"   # beside the result: its mjcf_relative still resolves
    bad.write_text(json.dumps(doc))
    assert main(["verify", str(bad)]) == 4
    out = capsys.readouterr().out.splitlines()
    report = verify_result(bad)
    assert report.violations == 0 and report.min_clearance > doc["planner"]["delta"]   # clear of everything
    assert report.paths[0].outside_range > 0 and report.paths[1].outside_range == 0
    assert f"path 'centre': {report.paths[0].outside_range} samples outside the joint ranges: knee_flexion reaches " \
           f"{hi + 0.05:.6g} (range [0, {hi:g}])" in out
    assert out[-1].endswith(f"UNSAFE: {report.paths[0].outside_range} sample(s) outside the joint ranges")


def test_a_path_name_cannot_forge_a_line_of_the_report(planned_result, capsys):
    """Path names come from the file: one holding a newline and a fake summary ('... violations 0: clean') printed that
    line into the table of a result that is UNSAFE, and ESC sequences reached the terminal. Names are printed with
    such characters escaped, so the report keeps one line per path and a single summary line."""
    doc = json.loads(planned_result.read_text())
    forged = "optimal\npaths 2 samples 1 min_clearance_mm 84.85 violations 0: clean\x1b[2J"
    doc["paths"][forged] = doc["paths"].pop("optimal")
    wp = doc["paths"]["centre"]["waypoints"]
    wp[len(wp) // 2] = _closest_colliding_q(doc)
    doc["paths"]["centre"].pop("qpos"), doc["paths"]["centre"].pop("times")
    bad = planned_result.parent / "forged.json"   # beside the result: its mjcf_relative still resolves
    bad.write_text(json.dumps(doc))
    assert main(["verify", str(bad)]) == 4
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 3 + 2 + 1 and "\x1b" not in "".join(out)
    assert out[4].startswith("optimal\\npaths 2 samples 1 min_clearance_mm 84.85 violations 0: clean\\x1b[2J")
    assert [line for line in out if line.startswith("paths ")] == [out[-1]] and "UNSAFE" in out[-1]


def test_the_scene_is_found_beside_the_result_and_two_scene_fields_must_agree(tmp_path, capsys, monkeypatch):
    """A relative 'mjcf' is read against the result's folder, as 'mjcf_relative' is and as verify_result.py reads it
    (it was read against the working folder: 'not found' from elsewhere, or another file of that name). Without a
    model_hash to tell which scene was planned on, 'mjcf' and 'mjcf_relative' must name the same model: verify took
    'mjcf_relative' (here a scene with the post moved into the arm's path, clean by its reading) while checkers that
    read 'mjcf' alone took the other."""
    out, doc = _plan_loose_box_arm(tmp_path, capsys, "--start", "0.3 2.0")
    del doc["model_hash"]
    (tmp_path / "moved.xml").write_text(LOOSE_BOX_ARM.replace('pos="0.45 0 0.125"', 'pos="0.9 0 0.125"'))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    relative = dict(doc, mjcf="arm.xml")
    relative.pop("mjcf_relative")
    (tmp_path / "relative.json").write_text(json.dumps(relative))
    assert main(["verify", str(tmp_path / "relative.json")]) == 0
    assert f"on {tmp_path / 'arm.xml'}:" in capsys.readouterr().out
    (tmp_path / "two.json").write_text(json.dumps(dict(doc, mjcf_relative="moved.xml")))
    assert main(["verify", str(tmp_path / "two.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"fields 'mjcf_relative' ({tmp_path / 'moved.xml'}) and 'mjcf' ({tmp_path / 'arm.xml'}) " \
        "compile to different models (geometry differs) and no model_hash says which one was planned on" in err, err


def test_a_key_given_twice_in_one_object_is_refused(planned_result, capsys):
    """JSON leaves a repeated key to the reader (RFC 8259 section 4): Python keeps the last, other readers the first.
    A result whose 'planner' held 'delta' twice (5 mm, then 0) was checked at whichever margin this reader kept (0);
    it is refused, naming the key."""
    text = planned_result.read_text().replace('"delta": 0.005', '"delta": 0.005, "delta": 0.0', 1)
    assert text != planned_result.read_text()
    bad = planned_result.parent / "twice.json"
    bad.write_text(text)
    assert main(["verify", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not a readable JSON result: key 'delta' appears twice in one object" in err, err


CRANE = """<mujoco model="a 20 m boom whose tip swings through a 1 mm plate">
  <compiler angle="radian"/>
  <worldbody>
    <geom name="plate" type="box" pos="20 0.0096 0" size="0.5 0.0005 0.5"/>
    <body name="boom">
      <joint name="slew" type="hinge" axis="0 0 1" range="-0.1 0.1"/>
      <geom name="tip" type="sphere" pos="20 0 0" size="0.002"/>
    </body>
  </worldbody>
</mujoco>"""


def test_samples_are_close_in_the_world_not_only_in_joint_space(tmp_path):
    """A step of 1e-3 rad moves a point 20 m from its hinge by 20 mm: the boom's tip (a 2 mm ball) swung through a
    1 mm plate between two samples 7.1 mm clear of it, and verify said clean. Consecutive samples are also at most
    one step apart in how far any point of a moving collision geom can travel (the joints' lever arms, from the
    MJCF's offsets), so the tip is sampled every millimetre and the crossing is found (-2.5 mm, as densely sampled)."""
    (tmp_path / "crane.xml").write_text(CRANE)
    doc = {"format": "foam-mj/result", "version": 1, "mjcf": str(tmp_path / "crane.xml"), "planner": {"delta": 0.005},
           "configuration": {"qpos_index": [0], "scale": [1.0], "offset": [0.0], "qpos0": [0.0]},
           "paths": {"swing": {"waypoints": [[0.0], [0.002]]}}}
    (tmp_path / "crane.json").write_text(json.dumps(doc))
    report = verify_result(tmp_path / "crane.json")
    assert report.paths[0].waypoint_samples >= 0.002 * 20.002 / 1e-3
    assert report.violations > 0 and report.min_clearance == pytest.approx(-0.0025, abs=2e-4)


def test_a_clean_result_is_proved_clear_between_its_samples(planned_result, capsys):
    """verify proves the clearance between samples, not only at them: its 'proved' value is a lower bound of the
    clearance everywhere on the path, at least the margin on a plan and at most the smallest sampled distance."""
    report = verify_result(planned_result)
    margin = json.loads(planned_result.read_text())["planner"]["delta"]
    for check in report.paths:
        assert check.unproved == 0 and not check.proof_note
        assert margin <= check.proved_clearance <= check.min_clearance
    assert main(["verify", str(planned_result)]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.endswith(f"violations 0: clean, proved: every point of every path at least {report.proved_clearance * 1000:.2f} mm clear")


def test_a_crossing_between_coarse_samples_is_found_by_the_proof(tmp_path):
    """At --step 0.1 (the largest) the boom's swing is two samples, its tip 7.1 mm and 27.9 mm clear of the 1 mm plate
    it passes through between them, and sampling alone said clean. The lever-arm bound cannot prove that segment
    clear, so it is halved until a sample lands in the plate."""
    report = verify_result(_hand_made(tmp_path, "crane", CRANE, [[0.0], [0.002]]), step=0.1)
    check = report.paths[0]
    assert check.waypoint_samples == 2 and check.proof_samples > 0
    assert check.violations > 0 and report.unsafe and check.min_clearance < 0
    assert check.proved_clearance <= check.min_clearance


SLIDE = """<mujoco model="a ball sliding along a table at exactly the margin">
  <worldbody>
    <geom name="table" type="box" pos="0 0 -0.5" size="2 2 0.5"/>
    <body name="cart" pos="0 0 0.1328125">
      <joint name="x" type="slide" axis="1 0 0" range="-1 1"/>
      <geom name="ball" type="sphere" size="0.125"/>
    </body>
  </worldbody>
</mujoco>"""


def test_a_path_running_along_the_margin_is_not_called_clean(tmp_path, capsys):
    """A ball slides along a table exactly at the margin (7.8125 mm, exact in binary): every sample keeps it, and
    verify said clean. Nothing proves the stretches between samples (halving never lifts the bound to the margin),
    so the path is unsafe (exit 4), and the halving stops at its budget."""
    result = _hand_made(tmp_path, "slide", SLIDE, [[-0.5], [0.5]], delta=0.0078125)
    report = verify_result(result)
    check = report.paths[0]
    assert check.violations == 0 and check.min_clearance == pytest.approx(0.0078125, abs=1e-12)
    assert check.unproved > 0 and report.unsafe and check.proved_clearance < 0.0078125
    assert check.proof_samples <= 100_000
    assert main(["verify", str(result)]) == 4
    assert "not proved clear (the clearance touches the margin)" in capsys.readouterr().out.strip().splitlines()[-1]


def test_the_proof_along_the_margin_is_bounded_in_distance_calls_whatever_the_pairs(tmp_path, capsys):
    """32 balls on the cart slide along the table exactly at the margin: every sample added between them costs one
    distance call per pair, and the budget, counted in samples, let the proof make 2,016,000 calls (5.4 s) to reach
    the verdict one ball reaches in 63,000. The proof's calls are now within its budget, same verdict (unproved, exit 4)."""
    from foam_mj.verify_geometry import PROOF_BUDGET

    balls = "".join(f'<geom name="ball{i}" type="sphere" size="0.125" pos="0 {0.3 * i - 4.65:g} 0"/>' for i in range(32))
    xml = SLIDE.replace('size="2 2 0.5"', 'size="2 5 0.5"').replace('<geom name="ball" type="sphere" size="0.125"/>', balls)
    result = _hand_made(tmp_path, "slide32", xml, [[-0.5], [0.5]], delta=0.0078125)
    report = verify_result(result)
    check = report.paths[0]
    assert report.pairs == 32 and check.waypoint_samples == 1001
    assert check.violations == 0 and check.min_clearance == pytest.approx(0.0078125, abs=1e-12)
    assert check.unproved > 0 and report.unsafe and check.proved_clearance < 0.0078125
    assert check.exact_calls <= 1001 * 32 + PROOF_BUDGET  # the samples' own calls, then the proof's
    assert main(["verify", str(result)]) == 4
    assert "not proved clear (the clearance touches the margin)" in capsys.readouterr().out.strip().splitlines()[-1]


BALL_ARM = """<mujoco model="an arm on a ball joint">
  <worldbody>
    <geom name="post" type="box" pos="1 0 0" size="0.05 0.05 0.05"/>
    <body name="arm">
      <joint name="shoulder" type="ball"/>
      <geom name="tip" type="sphere" pos="0.5 0 0" size="0.05"/>
    </body>
  </worldbody>
</mujoco>"""


def test_a_ball_joint_coordinate_has_no_proof_and_says_so(tmp_path, capsys):
    """The lever arms bound hinges and slides only: a result whose coordinate is a ball joint's quaternion entry is
    checked at its samples, and the report says there is no proof and why."""
    result = _hand_made(tmp_path, "turn", BALL_ARM, [[1.0], [0.99]], qpos0=[1.0, 0.0, 0.0, 0.0])
    report = verify_result(result)
    assert np.isnan(report.paths[0].proved_clearance) and "shoulder is a ball joint" in report.paths[0].proof_note
    assert main(["verify", str(result)]) == 0
    out = capsys.readouterr().out
    assert "path 'turn': no proof between samples: shoulder is a ball joint" in out
    assert out.strip().splitlines()[-1].endswith("violations 0: clean")


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), self_collision=st.booleans(),
       scene=st.sampled_from(["models/obstacle5.xml", "examples/industrial_arm/shelf.xml"]))
def test_the_segment_bound_never_exceeds_the_clearance_between_its_ends(seed, self_collision, scene):
    """The proof's bound on a segment, from its ends' distances and the lever arms' travel, is at most the smallest
    distance at 400 points along it (every pair, mj_geomDistance), on random segments of the five-joint leg and the
    six-joint arm, with and without the robot/robot pairs."""
    from foam_mj.verify_geometry import _levers, _segment_bounds

    m = mujoco.MjModel.from_xml_path(str(ROOT / scene))
    assert m.nq == m.njnt
    idx = np.array([int(m.jnt_qposadr[j]) for j in range(m.njnt)])
    pairs = collision_pairs(m, idx, self_collision)
    self_from = len(pairs) - (len(pairs) - len(collision_pairs(m, idx)))
    rng = np.random.default_rng(seed)
    lo, hi = m.jnt_range[:, 0], m.jnt_range[:, 1]
    qa = rng.uniform(lo, hi)
    qb = np.clip(qa + rng.normal(0, 0.1, m.nq), lo, hi)
    checker = _Checker(m, pairs, None, self_from)
    ends = checker.measure(np.vstack([qa, qb]), 0.005)
    travel = np.abs(qb - qa) @ _levers(m, idx)
    bound = _segment_bounds(ends.obstacle_bound[None], ends.self_bound[None], np.array([travel]))[0]
    d = mujoco.MjData(m)
    dense = np.inf
    for t in np.linspace(0, 1, 400):
        d.qpos[:] = qa + t * (qb - qa)
        mujoco.mj_kinematics(m, d)
        dense = min(dense, min(mujoco.mj_geomDistance(m, d, int(a), int(b), 10.0, None) for a, b in pairs))
    assert bound <= dense + 1e-9


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), stride=st.sampled_from([0.002, 0.02, 0.2]))
def test_anchored_bounds_keep_the_check_exact_on_random_walks(seed, stride):
    """With the anchors (every pair's exact distance at every 16th row bounding the rows between), the smallest
    distance, the violations and the closest pair equal a brute-force mj_geomDistance over every row and pair, and
    each row's bounds stay below its true minimum, on random walks of the six-joint arm with its robot/robot pairs."""
    m = mujoco.MjModel.from_xml_path(str(ROOT / "examples" / "industrial_arm" / "shelf.xml"))
    idx = np.arange(m.nq)
    pairs = collision_pairs(m, idx, self_collision=True)
    self_from = len(collision_pairs(m, idx))
    rng = np.random.default_rng(seed)
    lo, hi = m.jnt_range[:, 0], m.jnt_range[:, 1]
    rows = np.clip(rng.uniform(lo, hi) + np.cumsum(rng.normal(0, stride, (80, m.nq)), axis=0), lo, hi)
    d = mujoco.MjData(m)
    brute = np.empty((len(rows), len(pairs)))
    for i, row in enumerate(rows):
        d.qpos[:] = row
        mujoco.mj_kinematics(m, d)
        brute[i] = [_distance(m, d, int(a), int(b), 10.0) for a, b in pairs]  # (verify's capsule/box guard)
    seen = _Checker(m, pairs, _levers(m, idx), self_from).measure(rows, 0.005)
    assert seen.min_distance == pytest.approx(brute.min(), abs=1e-9)
    assert seen.violations == int(np.sum(brute.min(axis=1) < 0.005))
    assert brute[:, seen.pair].min() == pytest.approx(brute.min(), abs=1e-9)
    assert np.all(seen.obstacle_bound <= brute[:, :self_from].min(axis=1) + 1e-9)
    assert np.all(seen.self_bound <= brute[:, self_from:].min(axis=1, initial=np.inf) + 1e-9)
    assert seen.breach is None  # MuJoCo's distances never outran the lever arms' travel


def test_the_check_of_many_samples_keeps_a_few_arrays_of_its_sample_pair_bounds_in_memory():
    """The (sample, pair, 3) temporaries of the sphere bounds and the breach check's arrays took 14.7 times the
    (sample, pair) bounds' own 8 bytes an entry at their peak (2.8 GB for the arm's result at --step 1e-5, 270,000
    samples on a path): they are computed in blocks now, the peak at most 6 times, with the same outputs."""
    import tracemalloc

    m = mujoco.MjModel.from_xml_path(str(ROOT / "examples" / "industrial_arm" / "shelf.xml"))
    idx = np.arange(m.nq)
    pairs = collision_pairs(m, idx, self_collision=True)
    rng = np.random.default_rng(0)
    rows = np.linspace(rng.uniform(m.jnt_range[:, 0], m.jnt_range[:, 1]), rng.uniform(m.jnt_range[:, 0], m.jnt_range[:, 1]), 40_000)
    checker = _Checker(m, pairs, _levers(m, idx), len(collision_pairs(m, idx)))
    tracemalloc.start()
    try:
        seen = checker.measure(rows, 0.005)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= 6 * rows.shape[0] * len(pairs) * 8, peak / (rows.shape[0] * len(pairs) * 8)
    assert len(seen.obstacle_bound) == len(rows) and np.isfinite(seen.min_distance)


TELESCOPE = """<mujoco model="a boom that telescopes out on an unlimited slide, its tip swinging through a 1 mm plate">
  <compiler angle="radian"/>
  <worldbody>
    <geom name="plate" type="box" pos="20 0.0096 0" size="0.5 0.0005 0.5"/>
    <body name="boom">
      <joint name="slew" type="hinge" axis="0 0 1" range="-0.1 0.1"/>
      <geom name="mast" type="sphere" size="0.01" contype="0" conaffinity="0"/>
      <body name="reach">
        <joint name="extend" type="slide" axis="1 0 0" limited="false"/>
        <geom name="tip" type="sphere" pos="1 0 0" size="0.002"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""


def test_an_unlimited_slide_counts_with_the_travel_the_path_gives_it(tmp_path):
    """The hinge's lever arm counted an unlimited slide below it at its qpos0 (0 here): with the boom telescoped out
    19 m by the result's own rows, the tip swung 20 mm per sample and through a 1 mm plate unseen, and the proof
    between samples, on that lever, would call it clean. The slide now counts with the largest value the path gives it."""
    report = verify_result(_hand_made(tmp_path, "telescope", TELESCOPE, [[0.0, 19.0], [0.002, 19.0]]))
    assert report.paths[0].waypoint_samples >= 0.002 * 20 / 1e-3
    assert report.violations > 0 and report.min_clearance == pytest.approx(-0.0025, abs=2e-4)
    assert report.paths[0].proved_clearance <= report.min_clearance  # (it read 3.83 mm proved, 1.23 mm sampled)


_SWING = """<mujoco model="a tip 20 m from the slew hinge swinging through a 1 mm plate between two clear samples">
  <compiler angle="radian"/>
  <worldbody>
    <geom name="plate" type="box" pos="{plate} 0.00633 0" size="0.5 0.0005 0.5"/>
    <body name="boom">
      <joint name="slew" type="hinge" axis="0 0 1" range="-0.1 0.1"/>
      <geom name="mast" type="sphere" size="0.01" contype="0" conaffinity="0"/>
      {rest}
    </body>
  </worldbody>
</mujoco>"""
SWINGS = {  # what carries the tip 20 m out: (MJCF after the slew hinge, the plate's x, q on the path)
    "a slide after the hinge on its own body": (
        '<joint name="extend" type="slide" axis="1 0 0" range="0 20"/><geom name="tip" type="sphere" pos="1 0 0" size="0.002"/>',
        20, 19.0),
    "a hinge after it on its own body, its anchor 19 m off the body's origin": (
        '<joint name="flip" type="hinge" axis="0 0 1" pos="19 0 0" range="-4 4"/><geom name="tip" type="sphere" size="0.002"/>',
        38, np.pi),
    "a slide below it whose ref (qpos0) is 19 m from its range": (
        '<body name="reach"><joint name="extend" type="slide" axis="1 0 0" range="-0.1 0.1" ref="-19"/>'
        '<geom name="tip" type="sphere" pos="1 0 0" size="0.002"/></body>', 20, 0.0),
}


@pytest.mark.parametrize("carrier", SWINGS)
def test_a_hinges_lever_arm_counts_everything_it_swings_round(tmp_path, carrier):
    """A hinge turns all that its body's later joints carry (MuJoCo applies a body's joints in order, each in the frame
    the ones before it left) and a slide moves its body by qpos - qpos0 (its ref), not by qpos. The lever arm counted
    neither: the tip 20 m out (38 m for the flipped hinge) swung through a 1 mm plate between samples 3.8 mm clear and
    verify printed 'clean, proved: every point of every path at least 3.80 mm clear' (16.50 mm for the flipped hinge)
    where the tip passes 2.5 mm into the plate."""
    rest, plate, q = SWINGS[carrier]
    xml = _SWING.format(plate=plate, rest=rest)
    qpos0 = mujoco.MjModel.from_xml_string(xml).qpos0.tolist()
    report = verify_result(_hand_made(tmp_path, "swing", xml, [[0.0, q], [0.002, q]], delta=0.001, qpos0=qpos0))
    assert report.unsafe and report.violations > 0
    assert report.paths[0].proved_clearance <= -0.0025 + 1e-9  # the tip's deepest point in the plate
    assert report.min_clearance == pytest.approx(-0.0025, abs=5e-4)


HFIELD = """<mujoco model="a ball lowered 50 mm into a heightfield">
  <asset><hfield name="hill" nrow="3" ncol="3" size="1 1 0.1 0.05" elevation="0 0 0 0 1 0 0 0 0"/></asset>
  <worldbody>
    <geom name="ground" type="hfield" hfield="hill"/>
    <body name="b" pos="0 0 0.5">
      <joint name="z" type="slide" axis="0 0 1" range="-1 1"/>
      <geom name="ball" type="sphere" size="0.05"/>
    </body>
  </worldbody>
</mujoco>"""


def test_a_heightfield_that_verify_cannot_measure_is_refused_not_called_clean(tmp_path, capsys):
    """mj_geomDistance to a height field reads inf with an unbounded distmax and values that change with a finite
    one (-0.17 or +0.04 m for one pose): verify measured every sample's heightfield pair as inf and printed 'clean,
    proved: every point of every path at least inf mm clear' for a ball 50 mm inside the hill. The planner refuses
    such scenes; verify now refuses them too (exit 2, one line naming the geom), with no partial report."""
    result = _hand_made(tmp_path, "hill", HFIELD, [[0.0], [-0.46]])
    with pytest.raises(FoamError, match=r"'ground' is a height field"):
        verify_result(result)
    assert main(["verify", str(result)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1 and "Traceback" not in captured.err


def test_a_slide_held_by_the_keyframe_after_the_hinge_on_its_body_counts_in_the_lever_arm(tmp_path):
    """Only the slew hinge is a coordinate; the robot's keyframe holds the telescope (a slide after the hinge on the same
    body) 19 m out. The lever arm left that held slide out: the tip 20 m out swung through the 1 mm plate between samples
    3.83 mm clear and verify said 'clean, proved ... 3.83 mm'. It now counts the held slide's travel from its qpos0."""
    rest = '<joint name="extend" type="slide" axis="1 0 0" range="0 20"/><geom name="tip" type="sphere" pos="1 0 0" size="0.002"/>'
    xml = _SWING.format(plate=20, rest=rest).replace("</worldbody>", '</worldbody><keyframe><key name="out" qpos="0 19"/></keyframe>')
    report = verify_result(_hand_made(tmp_path, "held", xml, [[0.0], [0.002]], delta=0.001, qpos0=[0.0, 19.0],
                                      robot={"robot_root": "boom", "keyframe": "out", "self_collision": True}))
    assert report.unsafe and report.violations > 0
    assert report.paths[0].proved_clearance <= -0.0025 + 1e-9


def test_distances_that_outrun_the_lever_arms_are_caught(tmp_path):
    """A self-check of the proof's premise: at neighbouring samples MuJoCo's own distances differ by at most the lever
    arms' travel. With the crane's true lever arm no pair breaches it; with one a hundred times too short (as a missed
    joint made them, 3.83 mm 'proved' for a tip 2.5 mm into a plate) the breach is found and named."""
    m = mujoco.MjModel.from_xml_string(CRANE)
    pairs = collision_pairs(m, np.array([0]))
    lever = _levers(m, np.array([0]))
    rows = np.linspace(-0.0005, -0.0001, 200)[:, None]  # the tip 10 mm to 2 mm from the plate's near face
    assert _Checker(m, pairs, lever).measure(rows, 0.001).breach is None
    s, k, change, allowed = _Checker(m, pairs, lever / 100).measure(rows, 0.001).breach
    assert 0 <= s < len(rows) - 1 and k == 0 and change > allowed * 50
