"""The benchmark scripts (benchmarks/): a user's own problem beside the peers, their checks, their refusals."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from foam_mj.arguments import UsageError
from foam_mj.bubbles import BubbleOracle
from foam_mj.model import RobotModel

from conftest import TWO_LINK_ARM

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCHMARKS))
import planners  # noqa: E402


def two_link_toml(folder: Path, planner: str = "[planner]\nK = 8\nr_min = 0.04\ndelta = 0.01\n", q_goal: str = "[0.1, 0.6]") -> Path:
    """A scenario TOML for the bring-your-own-robot two-link arm (examples/two_link_arm), written to ``folder``."""
    path = folder / "my_arm.toml"
    path.write_text(f'name = "my_arm"\nscene = "{TWO_LINK_ARM}"\nq_init = [0.3, 2.0]\nq_goal = {q_goal}\n{planner}')
    return path


def run_planners(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(BENCHMARKS / "planners.py"), "--no-progress", *args],
                          capture_output=True, text=True, timeout=600)


def test_planners_benchmark_runs_a_users_scenario_with_its_margin_and_parameters(tmp_path):
    toml, out = two_link_toml(tmp_path), tmp_path / "bench.json"
    r = run_planners("--problems", str(toml), "--seeds", "1", "--no-ompl", "--json", str(out))
    assert r.returncode == 0, r.stderr
    doc = json.loads(out.read_text())
    pb = doc["problems"]["my_arm"]  # the row is named by the scenario's name
    assert (pb["K"], pb["r_min"], pb["delta"], pb["dim"]) == (8, 0.04, 0.01, 2)
    assert pb["source"] == str(toml) and pb["scene"] == str(TWO_LINK_ARM)
    assert set(pb["planners"]) == set(planners.PLANNERS)  # every planner of ours, no OMPL rows
    for name, res in pb["planners"].items():
        assert res["summary"]["ok"] == 1, (name, res["summary"]["failures"])
        assert res["runs"][0]["clearance"] >= 0.01 - 1e-6  # the scenario's 10 mm, under the dense check
    assert doc["margin_violations"] == []
    table_row = next(line for line in r.stdout.splitlines() if line.split()[:3] == ["my_arm", "10", "pfm"])
    assert "1/1" in table_row  # the table states the problem's margin in mm
    # Wall times compare only on one machine: the JSON and the last line name it and its load.
    rep = doc["reproduce"]
    assert rep["cpus"] >= 1 and rep["cpu_model"]
    assert all(len(rep[k]) == 3 and min(rep[k]) >= 0 for k in ("load_average_start", "load_average_end"))
    assert f"x {rep['cpu_model']}, load average" in r.stdout.splitlines()[-2 if "wrote" in r.stdout.splitlines()[-1] else -1]


def test_a_scenario_without_planner_parameters_gets_the_benchmarks_defaults(tmp_path):
    pb = planners.problem(str(two_link_toml(tmp_path, planner="")))
    assert (pb.K, pb.r_min, pb.delta) == (planners.DEFAULT_K, planners.DEFAULT_R_MIN, planners.DELTA)


@pytest.mark.parametrize("args, message", [
    (["--problems", "no_such_problem"], "unknown problem 'no_such_problem'; built-in problems: obstacle"),
    (["--problems", "missing/robot.toml"], "scenario file not found: missing/robot.toml"),
    (["--problems", "obstacle", "obstacle"], "'obstacle' is given twice"),
    (["--seeds", "0"], "--seeds must be in [1, 10000]"),
    (["--time-limit", "inf"], "--time-limit must be a finite number of seconds > 0, got inf"),
    (["--json", "nowhere/out.json"], "folder nowhere does not exist"),
    (["--json", "out.txt"], "must end in .json"),
    (["--planners", "rrt"], "unknown planner 'rrt'"),
])
def test_planners_benchmark_refuses_bad_arguments_in_one_line_before_any_run(args, message, tmp_path):
    r = subprocess.run([sys.executable, str(BENCHMARKS / "planners.py"), "--no-ompl", *args], capture_output=True, text=True,
                       timeout=120, cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == ""
    assert len(r.stderr.strip().splitlines()) == 1 and message in r.stderr, r.stderr


@pytest.mark.parametrize("args, message", [
    (["--scenario", "no_such"], "--scenario: unknown scenario 'no_such'; a scenario TOML file, or a built-in scenario: obstacle"),
    (["--scenario", "missing/robot.toml"], "--scenario: scenario file not found: missing/robot.toml"),
    (["--mjcf", str(TWO_LINK_ARM)], "--mjcf needs --start and --goal"),
    (["--mjcf", "missing/arm.xml", "--start", "0 0", "--goal", "1 1"], "--mjcf: MJCF file not found: missing/arm.xml"),
    (["--mjcf", str(TWO_LINK_ARM), "--start", "0.3", "--goal", "0.1 0.6"], "--start: q_init must be 2 numbers, one per configuration joint"),
    (["--mjcf", str(TWO_LINK_ARM), "--start", "0.3 x", "--goal", "0.1 0.6"], "--start must be numbers separated by spaces or commas"),
    (["--start", "0.3 2.0"], "--start goes with --mjcf"),
    (["--delta", "-0.01"], "--delta must be a finite margin > 0 in metres, got -0.01"),
    (["--ompl-resolution", "0"], "--ompl-resolution must be a fraction in (0, 0.5]"),
])
def test_a_users_problem_flags_are_checked_before_any_run(args, message):
    """--scenario, --mjcf/--start/--goal (plan's own parsing and messages), --delta and --ompl-resolution: one-line
    refusals from the argument parsing, which runs nothing (in-process here: the exit-2 path is the test above's)."""
    with pytest.raises(UsageError) as exc:
        planners.parse(["--no-ompl", *args])
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_an_mjcf_problem_is_the_scenario_foam_mj_plan_builds_from_every_field_of_plans_parser(tmp_path):
    """mjcf_problem handed plan_scenario a Namespace naming, by hand, the fields it read (scene, mjcf, ..., delta,
    time_limit, subject_height): a field plan's parser gained and plan_scenario read was an AttributeError (exit 1)
    here. The Namespace is now plan's own parse of ``plan`` with the --mjcf flags set: every field of plan's parser is
    in it, and the problem is the scenario `foam-mj plan --mjcf` plans (same joints, ends, robot and margin)."""
    from foam_mj.cli import build_parser
    from foam_mj.plan_command import plan_scenario

    import planner_problems

    flags = ["--mjcf", str(TWO_LINK_ARM), "--start", "0.3 2.0", "--goal", "0.1 0.6", "--joints", "shoulder,elbow", "--no-self-collision"]
    args, _, (pb,), _ = planners.parse(["--no-ompl", *flags])
    ns = planner_problems.plan_namespace(args)
    plan = next(a for a in build_parser()._actions if a.dest == "command").choices["plan"]
    assert {a.dest for a in plan._actions if a.dest != "help"} <= set(vars(ns))
    s = plan_scenario(build_parser().parse_args(["plan", *flags]))
    assert pb.name == s.name and pb.delta == s.params.delta and pb.source == str(TWO_LINK_ARM.resolve())
    assert np.array_equal(pb.q_init, s.q_init) and np.array_equal(pb.q_goal, s.q_goal)
    assert np.array_equal(pb.robot.config.joint_ids, s.robot.config.joint_ids) and pb.robot.self_collision is s.robot.self_collision is False


def test_a_scenario_that_fails_its_checks_is_refused_naming_the_field(tmp_path):
    toml = two_link_toml(tmp_path, q_goal="[0.1]")
    r = run_planners("--problems", str(toml), "--no-ompl")
    assert r.returncode == 2 and r.stdout == ""
    assert f"--problems: {toml}: field 'q_goal'" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_the_dense_check_counts_a_loose_object_as_an_obstacle_and_checks_self_collision(tmp_path):
    # A box on a free joint (not a configuration coordinate) in the arm's way: the planner holds it where the model
    # puts it, an obstacle; a checker that took every jointed body for the robot never measured the arm against it.
    (tmp_path / "arm.xml").write_text("""<mujoco><worldbody>
      <body name="upper"><joint name="shoulder" type="hinge" axis="0 0 1" range="-2 2"/>
        <geom name="upper_geom" type="capsule" fromto="0 0 0 0.5 0 0" size="0.03"/>
        <body name="fore" pos="0.5 0 0"><joint name="elbow" type="hinge" axis="0 0 1" range="-2.5 2.5"/>
          <geom name="fore_geom" type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/>
          <body name="hand" pos="0.4 0 0"><joint name="wrist" type="hinge" axis="0 0 1" range="-2 2"/>
            <geom name="hand_geom" type="capsule" fromto="0 0 0 0.2 0 0" size="0.03"/></body></body></body>
      <body name="loose" pos="0.3 -0.3 0"><freejoint/><geom name="loose_box" type="box" size="0.05 0.05 0.05"/></body>
    </worldbody></mujoco>""")
    robot = RobotModel.from_xml(tmp_path / "arm.xml", joints=["shoulder", "elbow", "wrist"])
    checker = planners.DenseChecker(robot)
    names = {(robot.geom_name(a), robot.geom_name(b)) for a, b in checker.pairs}
    assert ("upper_geom", "loose_box") in names
    assert {(robot.geom_name(a), robot.geom_name(b)) for a, b in checker.self_pairs} == {("upper_geom", "hand_geom")}
    # Folding the hand back onto the upper arm: the self pair closes to below the capsules' radii.
    clear, self_clear = checker.min_clearance(np.array([[0.0, 0.0, 0.0], [0.0, 2.5, 2.0]]))
    assert self_clear < 0.0 < clear


@pytest.mark.parametrize("script, args, message", [
    ("certificate.py", ["--scenarios", "no_such"], "--scenarios: unknown scenario 'no_such'"),
    ("foam.py", ["--json", "nowhere/out.json"], "--json output nowhere/out.json: folder nowhere does not exist"),
    ("foam.py", ["--scenarios", "obstacle5"], "--scenarios: obstacle5 plans with 'bubbletree'; this benchmark measures pfm"),
    ("walker_routes.py", ["--json", "out.txt"], "--json output out.txt must end in .json"),
    ("clearance.py", ["--repeats", "0"], "argument --repeats: expected an integer in [1, 10,000], got 0"),
    ("timing.py", ["--paths", "no_such"], "argument --paths: invalid choice: 'no_such'"),
    ("mgoa.py", ["--runs", "0"], "argument --runs: expected an integer in [1, 10,000], got 0"),
    ("mgoa.py", ["--quick", "--json", "nowhere/out.json"], "folder nowhere does not exist"),  # it made the folder, and ran
    ("optimal_solvers.py", ["--json", "nowhere/out.json"], "folder nowhere does not exist"),
    ("speed.py", ["--repeats", "0"], "argument --repeats: expected an integer in [1, 10,000], got 0"),
    ("sweep.py", ["--plans", "0"], "argument --plans: expected an integer in [2, 10,000], got 0"),
    ("reproduce.py", ["--seeds", "1"], "argument --seeds: expected an integer in [2, 10,000], got 1"),
    ("reproduce.py", ["--quick", "--json", "out.txt"], "--json output out.txt must end in .json"),  # was after the runs
    ("reproduce.py", ["--quick", "--out", "report.txt"], "--out output report.txt must end in .md"),
    ("smoothing.py", ["--runs", "0"], "--runs must be in [1, 10000]"),
])
def test_every_benchmark_script_refuses_a_bad_argument_in_one_line_before_any_work(script, args, message, tmp_path):
    # Before: tracebacks (an unknown scenario, an unknown path name), a --json refused only after all the work, or
    # 0 / -1 runs accepted (an empty table, exit 0) or silently read as the default.
    r = subprocess.run([sys.executable, str(BENCHMARKS / script), *args], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == "", r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and message in r.stderr, r.stderr
    assert list(tmp_path.iterdir()) == []  # no folder made, nothing written


def test_ompl_plans_in_qpos_units_with_the_problems_margin():
    # OMPL planned in q: on the leg (hip displacement normalized, 0.7 m onto pi/2) RRT* minimized the length in q
    # while the table compares lengths in qpos, which favoured us.
    pytest.importorskip("ompl")
    pb = planners.problem("obstacle")
    oracle = BubbleOracle(pb.robot, delta=pb.delta)
    runner = planners.OMPLRunner(pb, oracle)
    bounds = runner.space.getBounds()
    scale = pb.robot.config.scale
    np.testing.assert_allclose([bounds.high[i] for i in range(3)], scale * pb.robot.upper)
    state = runner.space.allocState()
    for i, x in enumerate(scale * pb.q_init):
        state[i] = float(x)
    assert runner._setup(0).getSpaceInformation().isValid(state)  # 110 mm of clearance > 5 mm
    wide = planners.OMPLRunner(dataclasses.replace(pb, delta=0.2), oracle)  # the problem's margin, not 5 mm
    assert not wide._setup(0).getSpaceInformation().isValid(state)


def test_an_rrtstar_run_writes_strict_json():
    # RRT* has no first-solution time: it was NaN, which strict JSON readers (jq, JavaScript) refuse.
    pytest.importorskip("ompl")
    pb = planners.problem("step_up")
    runner = planners.OMPLRunner(pb, BubbleOracle(pb.robot, delta=pb.delta))
    rec = planners.finish_ompl(runner.optimizing(0.3, 0), pb.robot, planners.DenseChecker(pb.robot))
    assert rec["ok"], rec
    json.dumps(rec, allow_nan=False)


def test_every_benchmarks_help_opens_with_whole_sentences():
    """`--help` opens with the script's docstring: its first paragraph, not its first line (planners.py's read
    '... f and clearance,' and walker_routes.py's '... and which', cut mid-sentence)."""
    import ast
    import re

    scripts = [p for p in sorted(BENCHMARKS.glob("*.py")) if "__doc__" in p.read_text() and not p.name.startswith("_")]
    assert len(scripts) >= 10
    for script in scripts:
        text = script.read_text()
        (use,) = re.findall(r"[pP]arser\((?:description=)?__doc__(\.splitlines\(\)\[0\]|\.split\(\"\\n\\n\"\)\[0\])\)", text)
        doc = ast.get_docstring(ast.parse(text), clean=False)
        description = doc.splitlines()[0] if "splitlines" in use else doc.split("\n\n")[0]
        assert description.rstrip().endswith((".", ")")), (script.name, description)


def test_a_users_scenario_and_mjcf_run_side_by_side_with_one_margin(tmp_path):
    """--scenario (repeatable) and --mjcf/--start/--goal, as `foam-mj plan` takes them, are problems of their own:
    only they run (no built-in problem), each row named by its scenario or file, --delta the margin of both."""
    toml, out = two_link_toml(tmp_path), tmp_path / "bench.json"
    r = run_planners("--scenario", str(toml), "--mjcf", str(TWO_LINK_ARM), "--start", "0.3 2.0", "--goal", "0.1 0.6",
                     "--delta", "0.008", "--planners", "gbpf", "--seeds", "2", "--no-ompl", "--json", str(out))
    assert r.returncode == 0, r.stderr
    doc = json.loads(out.read_text())
    assert list(doc["problems"]) == ["my_arm", "arm"]
    for pb in doc["problems"].values():
        assert pb["delta"] == 0.008 and pb["joints"] == ["shoulder", "elbow"] and pb["ompl"] is None
        runs = pb["planners"]["gbpf"]["runs"]
        assert [run["seed"] for run in runs] == [0, 1] and all(run["ok"] and run["clearance"] >= 0.008 - 1e-6 for run in runs)
    assert doc["problems"]["arm"]["q_init"] == [0.3, 2.0] and doc["problems"]["arm"]["source"] == str(TWO_LINK_ARM)
    assert doc["problems"]["my_arm"]["scenario_toml"] == toml.read_text() and doc["problems"]["arm"]["scenario_toml"] is None
    assert doc["reproduce"]["argv"][:3] == ["planners.py", "--no-progress", "--scenario"] and doc["reproduce"]["ompl_used"] is False
    assert [line.split()[:4] for line in r.stdout.splitlines() if line.split()[:1] in (["my_arm"], ["arm"])] == [
        ["my_arm", "8", "gbpf", "2/2"], ["arm", "8", "gbpf", "2/2"]]


def test_a_users_mjcf_beside_ompl_same_bounds_margin_and_dense_check(tmp_path):
    pytest.importorskip("ompl")
    out = tmp_path / "bench.json"
    r = run_planners("--mjcf", str(TWO_LINK_ARM), "--start", "0.3 2.0", "--goal", "0.1 0.6", "--delta", "0.01", "--planners", "gbpf",
                     "--seeds", "1", "--time-limit", "2", "--json", str(out))
    assert r.returncode == 0, r.stderr
    pb = json.loads(out.read_text())["problems"]["arm"]
    assert set(pb["planners"]) == {"gbpf", "ompl:rrtconnect+simplify", "ompl:rrtstar(10x)"}
    assert pb["ompl"]["bounds_qpos_units"] == [pb["lower"], pb["upper"]]  # the arm's hinges: scale 1, the joint ranges
    diagonal = np.linalg.norm(np.subtract(pb["upper"], pb["lower"]))
    assert pb["ompl"]["resolution"] == 0.01 and pb["ompl"]["longest_valid_segment"] == pytest.approx(0.01 * diagonal)
    for name in ("ompl:rrtconnect+simplify", "ompl:rrtstar(10x)"):
        (run,) = pb["planners"][name]["runs"]
        assert run["ok"] and run["seed"] == 0 and run["queries"] > 0, run
        assert run["clearance"] > 0.0 and run["len_qpos"] >= np.linalg.norm([0.2, 1.4]) - 1e-9  # dense-checked, no shorter than the chord
    ratio = next(line for line in r.stdout.splitlines() if line.split()[:3] == ["arm", "gbpf", "1/1/1"])
    assert len(ratio.split()) == 8  # problem, planner, successes, five ratios


def test_ompl_runs_repeat_by_their_seed_whatever_ran_before():
    # OMPL was seeded once per process: a problem's OMPL rows depended on the problems and seeds run before it.
    pytest.importorskip("ompl")
    pb = planners.problem("step_up")
    runner = planners.OMPLRunner(pb, BubbleOracle(pb.robot, delta=pb.delta))
    first = runner.rrtconnect(2.0, seed=3)
    runner.rrtconnect(2.0, seed=4)
    again = runner.rrtconnect(2.0, seed=3)
    assert first["ok"] and again["ok"]
    np.testing.assert_array_equal(first["path"], again["path"])


NO_OMPL = "import runpy, sys; sys.modules['ompl'] = None; sys.argv = sys.argv[1:]; runpy.run_path(sys.argv[0], run_name='__main__')"


def test_without_ompl_the_benchmark_says_so_once_and_runs_ours(tmp_path):
    """OMPL is an optional extra: without it (its import made to fail) a run says so on stderr and writes our rows;
    --bitstar, which only OMPL runs, is refused in one line."""
    out = tmp_path / "bench.json"
    script = str(BENCHMARKS / "planners.py")
    r = subprocess.run([sys.executable, "-c", NO_OMPL, script, "--no-progress", "--mjcf", str(TWO_LINK_ARM), "--start", "0.3 2.0",
                        "--goal", "0.1 0.6", "--planners", "gbpf", "--seeds", "1", "--json", str(out)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert r.stderr.count("OMPL is not installed") == 1 and 'pip install -e ".[peers]"' in r.stderr
    doc = json.loads(out.read_text())
    assert doc["reproduce"]["ompl_used"] is False and list(doc["problems"]["arm"]["planners"]) == ["gbpf"]
    r = subprocess.run([sys.executable, "-c", NO_OMPL, script, "--bitstar", "--quick"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stdout == "" and len(r.stderr.strip().splitlines()) == 1
    assert "--bitstar runs OMPL's BIT*, but OMPL is not installed" in r.stderr


FLOATING_BASE = """<mujoco><compiler angle="radian"/><worldbody>
  <geom name="floor" type="plane" size="2 2 0.1"/>
  <body name="base" pos="0 0 0.2"><freejoint/><geom name="base_box" type="box" size="0.05 0.05 0.05"/>
    <body name="upper" pos="0 0 0.1"><joint name="shoulder" type="hinge" axis="0 1 0" range="-2 2"/>
      <geom name="upper_geom" type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="fore" pos="0.3 0 0"><joint name="elbow" type="hinge" axis="0 1 0" range="-2.8 2.8"/>
        <geom name="fore_geom" type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/></body></body></body>
</worldbody></mujoco>"""


def test_the_dense_check_takes_a_held_base_under_robot_root_for_the_robot(tmp_path):
    # Without the root the checker took the held base for an obstacle: its own forearm folding past it was a
    # "collision" (a false margin break, exit 1) and the base was never checked against the floor.
    (tmp_path / "base.xml").write_text(FLOATING_BASE)
    robot = RobotModel.from_xml(tmp_path / "base.xml", joints=["shoulder", "elbow"], robot_root="base")
    checker = planners.DenseChecker(robot)
    names = {(robot.geom_name(a), robot.geom_name(b)) for a, b in checker.pairs}
    assert ("base_box", "floor") in names and ("fore_geom", "base_box") not in names
    assert ("base_box", "fore_geom") in {(robot.geom_name(a), robot.geom_name(b)) for a, b in checker.self_pairs}


def test_a_margin_that_a_pair_no_joint_moves_breaks_is_refused_before_any_run(tmp_path):
    # The base stands 0.15 m above the floor and no configuration joint moves it: with delta 0.2 every path breaks the
    # margin. Our planners refuse; OMPL, whose validity checker leaves such pairs out as ours does, could still plan.
    (tmp_path / "base.xml").write_text(FLOATING_BASE)
    toml = tmp_path / "base.toml"
    toml.write_text('name = "base"\nscene = "base.xml"\nrobot_root = "base"\nq_init = [-0.5, -0.5]\nq_goal = [-1.0, -0.3]\n')
    planners.parse(["--no-ompl", "--scenario", str(toml)])  # 5 mm: the base keeps 150 mm
    with pytest.raises(UsageError, match=r"base_box.*floor.*within the safety margin delta 0.2 m"):
        planners.parse(["--no-ompl", "--scenario", str(toml), "--delta", "0.2"])


def test_no_timed_run_of_the_planner_benchmark_pays_for_a_first_import(tmp_path):
    """The first timed run of ours imported scipy.spatial, scipy.linalg and Clarabel (the corridor's solvers, 145
    modules) inside its clock: on obstacle, seed 0 read 716 ms total (354 ms CPU) against 149-251 ms (72-125 ms CPU)
    for seeds 1-4, while OMPL's modules are imported before its first run. With --seeds 2 the median is the mean of
    the two. The planners' solvers are now imported before the first timed run: no module is imported inside one
    (the property itself; how long a run takes belongs in the benchmark, not in a test)."""
    code = ("import json, sys; sys.argv = ['planners.py']\n"
            f"sys.path.insert(0, {str(BENCHMARKS)!r})\n"
            "import planners as P\n"
            "orig, new = P.run_ours, []\n"
            "def spy(*a, **k):\n"
            "    before = set(sys.modules); r = orig(*a, **k); new.append(sorted(set(sys.modules) - before)); return r\n"
            "P.run_ours = spy\n"
            f"P.main(['--planners', 'bubbletree', '--problems', 'obstacle', '--seeds', '2', '--no-ompl', '--no-progress', '--json', {str(tmp_path / 'p.json')!r}])\n"
            "print(json.dumps(new))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                       env={**__import__("os").environ, "PYTHONPATH": str(BENCHMARKS.parent)})
    assert r.returncode == 0, r.stderr[-2000:]
    imported = json.loads(r.stdout.strip().splitlines()[-1])
    assert imported == [[], []], [m[:8] for m in imported]
    runs = json.loads((tmp_path / "p.json").read_text())["problems"]["obstacle"]["planners"]["bubbletree"]["runs"]
    assert all(x["ok"] for x in runs)


_BLAS_THREADS = """
import ctypes, glob, os, sys
sys.path.insert(0, {bench!r})
import {script}  # noqa
import numpy
lib = ctypes.CDLL(glob.glob(os.path.join(os.path.dirname(numpy.__file__), '..', 'numpy.libs', '*openblas*'))[0])
print(lib.scipy_openblas_get_num_threads64_())
"""


@pytest.mark.parametrize("script", ["optimal_solvers", "planners"])
def test_a_benchmark_of_peers_runs_scipys_blas_in_one_thread(script):
    """optimal_solvers.py times scipy's SLSQP and trust-constr beside our SCP (Clarabel: one thread), but left OpenBLAS
    at one thread per core: on the shared 2-core machine SLSQP on the obstacle rosary's f took 41 s wall / 27 s CPU
    with BLAS's 2 threads against 8 s / 4 s in one (trust-constr 12-15 s / 7.3-7.6 s against 7 s / 3.7 s), the peers'
    times inflated 2-7x by threads spinning on a busy machine. It now sets OMP_NUM_THREADS and OPENBLAS_NUM_THREADS
    to 1 (unless set) before numpy loads, as planners.py does."""
    env = {k: v for k, v in __import__("os").environ.items() if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}
    env["PYTHONPATH"] = str(BENCHMARKS.parent)
    probe = subprocess.run([sys.executable, "-c", "import numpy, glob, os; print(len(glob.glob(os.path.join(os.path.dirname(numpy.__file__), "
                            "'..', 'numpy.libs', '*openblas*'))))"], capture_output=True, text=True, env=env)
    if probe.stdout.strip() != "1":
        pytest.skip("numpy is not linked to scipy-openblas here")
    r = subprocess.run([sys.executable, "-c", _BLAS_THREADS.format(bench=str(BENCHMARKS), script=script)], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr[-1500:]
    assert r.stdout.strip() == "1"


def test_in_ci_quick_mode_a_failed_run_of_ours_fails_the_benchmark_but_a_study_lists_it(tmp_path):
    """CI runs `planners.py --quick`: a run of ours that finds no path (here a 1 ms budget) is exit 1 there, named on
    stderr, with the table and the JSON still written; without --quick a study's failures are data (exit 0)."""
    out = tmp_path / "quick.json"
    args = ("--no-ompl", "--planners", "bubbletree", "--problems", "obstacle", "--seeds", "1", "--time-limit", "0.001")
    r = run_planners("--quick", *args, "--json", str(out))
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert "FAILED (--quick): bubbletree on obstacle: 1 x time budget" in r.stderr
    assert json.loads(out.read_text())["problems"]["obstacle"]["planners"]["bubbletree"]["summary"]["ok"] == 0
    r = run_planners(*args)
    assert r.returncode == 0 and "failed runs: obstacle bubbletree: 1 x time budget" in r.stdout, r.stderr
