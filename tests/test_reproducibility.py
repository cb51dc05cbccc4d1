"""Reproducibility: a result names what made it, and says when a clock, not the seed, decided it.

The same seed and inputs give the same plan bit for bit, except where a clock ends a phase: the plan's wall-clock
``time_limit`` (bubbletree's search for other routes after the first path, and its refinement) or bubbletree's CPU
budget ``refine_time``. Such a result depends on the machine's speed and load, so the result JSON, the summary and a
study's rows say so; and every result JSON records the software versions, since another MuJoCo can give other
distances and so other bubbles.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from foam_mj.cli import main
from foam_mj.data import models_dir
from foam_mj.planners import PlanStats

OBSTACLE = Path(models_dir()) / "obstacle.xml"


def _bubbletree_scenario(tmp_path: Path, **planner) -> Path:
    """The obstacle step-over planned by bubbletree, with ``planner`` options."""
    opts = "".join(f"{k} = {v!r}\n" for k, v in planner.items())
    path = tmp_path / "bt.toml"
    path.write_text(f'name = "bt"\nscene = "{OBSTACLE}"\nq_init = [0.2, 0.3, 0.08]\nq_goal = [0.45, 0.4536, 1.45]\nseed = 0\n'
                    f'[planner]\nalgorithm = "bubbletree"\n{opts}')
    return path


def test_a_result_json_records_the_versions_of_the_software_that_made_it(tmp_path):
    import mujoco

    import foam_mj

    js = tmp_path / "r.json"
    assert main(["plan", "--scene", "step_up", "--no-rrd", "--no-replay", "--smoother", "convex", "--quiet", "--json", str(js)]) == 0
    versions = json.loads(js.read_text())["versions"]
    assert versions["foam_mj"] == foam_mj.__version__
    assert versions["mujoco"] == mujoco.__version__
    assert versions["numpy"] == np.__version__
    assert versions["python"] == ".".join(map(str, sys.version_info[:3]))


def test_a_plan_no_clock_ended_says_nothing_of_clocks(tmp_path, capsys):
    js = tmp_path / "r.json"
    assert main(["plan", "--scene", str(_bubbletree_scenario(tmp_path)), "--no-rrd", "--no-replay", "--smoother", "convex",
                 "--quiet", "--json", str(js)]) == 0
    assert json.loads(js.read_text())["clock_cut"] is None
    assert "machine's speed" not in capsys.readouterr().out


def test_a_refinement_its_cpu_budget_ended_is_flagged_in_the_json_and_the_summary(tmp_path, capsys):
    """refine_time (CPU seconds) ended bubbletree's refinement before its first round: the path is a valid certified
    path, but another machine (or load) could refine further, so the run names the clock that decided it."""
    js = tmp_path / "r.json"
    assert main(["plan", "--scene", str(_bubbletree_scenario(tmp_path, refine_time=1e-9)), "--no-rrd", "--no-replay",
                 "--smoother", "convex", "--quiet", "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    assert doc["foam"]["stats"]["refine_stopped"] == "time"
    assert "refine_time" in doc["clock_cut"]
    out = capsys.readouterr().out
    note = [line for line in out.splitlines() if line.startswith("note:") and "machine's speed" in line]
    assert len(note) == 1 and "refine_time" in note[0], out


def test_plan_stats_name_every_phase_a_clock_ended():
    def stats(**details):
        return PlanStats("bubbletree", "reached", 10, 20, 0.5, 0.1, details)

    assert stats().clock_cut is None
    assert stats(refine_stopped="cone program unsolved").clock_cut is None  # not a clock: the same on every machine
    explore = stats(explore_stopped="time limit").clock_cut
    assert "time limit" in explore and "other routes" in explore
    assert "time limit" in stats(refine_stopped="time limit").clock_cut
    both = stats(explore_stopped="time limit", refine_stopped="time").clock_cut
    assert "other routes" in both and "refine_time" in both


def test_a_studys_reached_row_that_a_clock_decided_says_so_in_its_reason(tmp_path):
    pq = pytest.importorskip("pyarrow.parquet")

    _bubbletree_scenario(tmp_path, refine_time=1e-9)
    spec = tmp_path / "s.toml"
    spec.write_text('scenario = "bt.toml"\nseeds = [0]\nsmoothers = "convex"\nreplay = "none"\n[grid]\n"planner.delta" = [0.005]\n')
    assert main(["sweep", str(spec), "--out", str(tmp_path / "out"), "--workers", "1", "--quiet"]) == 0
    rows = [r for f in sorted((tmp_path / "out" / "rows").glob("*.parquet")) for r in pq.read_table(f).to_pylist()]
    assert len(rows) == 2
    for row in rows:
        assert row["outcome"] == "reached"
        assert row["reason"] is not None and "refine_time" in row["reason"], row


# -- the same problem gives the same plan whatever ran before it, and whatever the batch threads ------------------

_PLAN_B = """
import hashlib, sys
import numpy as np
from foam_mj.planners import PlanningProblem, get_planner
from foam_mj.planners.base import smoother_start
from foam_mj.scenarios import load_scenario
from foam_mj.smoothing import HarmonySearch, OptimalSmoother, StopCriteria

def digest(name, threads=2, seed=1):
    s = load_scenario(name)
    oracle = s.oracle()
    oracle.clearance.threads = threads
    res = get_planner("bubbletree").plan(PlanningProblem(oracle, s.q_init, s.q_goal, delta=oracle.delta, time_limit=60.0), seed=seed)
    paths = [OptimalSmoother().smooth(res.rosary, initial=smoother_start(res.rosary, res.waypoints), seed=seed).path,
             HarmonySearch(stop=StopCriteria(max_iterations=300)).smooth(res.rosary, seed=seed).path]
    h = hashlib.md5()
    for a in (res.rosary.centers, res.rosary.radii, res.foam.centers, res.foam.radii, res.foam.parents, *paths):
        h.update(np.ascontiguousarray(np.asarray(a, float)).tobytes())
    h.update(repr((res.stats.bubbles, res.stats.distance_queries)).encode())
    return h.hexdigest()
"""


def _digest_in_a_fresh_process(name: str) -> str:
    import subprocess

    code = _PLAN_B + f"\nprint(digest({name!r}))\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_a_plan_after_other_problems_in_one_process_equals_the_plan_alone_in_a_fresh_one():
    """Caches that outlive a plan (the corridor's cone-program templates per chain length, the smoothers' index
    tables) must not carry one problem into the next: step_down (seed 1) planned after step_up, obstacle and step_down
    with other seeds (whose chains have the same lengths), in this process, is bit for bit step_down planned alone in
    a new interpreter (another hash seed, nothing cached)."""
    scope: dict = {}
    exec(_PLAN_B, scope)
    for other, seed in (("step_up", 1), ("obstacle", 1), ("step_down", 0), ("step_down", 2)):
        scope["digest"](other, seed=seed)
    assert scope["digest"]("step_down") == _digest_in_a_fresh_process("step_down")


def test_the_distance_batches_threads_do_not_change_a_plan():
    scope: dict = {}
    exec(_PLAN_B, scope)
    assert scope["digest"]("step_up", threads=1) == scope["digest"]("step_up", threads=2)
