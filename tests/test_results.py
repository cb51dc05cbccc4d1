"""foam_mj.results: writing and reading a result from Python."""

from __future__ import annotations

import pytest
from pathlib import Path

from foam_mj.results import write_outcome


def test_write_outcome_names_a_path_that_is_not_one(tmp_path):
    # write_outcome(outcome, path), the arguments swapped, failed inside pathlib ("expected str, bytes or os.PathLike").
    with pytest.raises(TypeError, match=r"write_outcome\(path, outcome\): `path` must be a file path, got object"):
        write_outcome(object(), tmp_path / "out.json")
    assert list(tmp_path.iterdir()) == []


def test_replaying_a_result_reports_each_path_as_plan_does(tmp_path):
    """`foam-mj replay` timed and replayed every path of a result without a word (3.8 s on the obstacle's eight paths,
    17 s on a scene of 1,000 obstacles); it now shows which path, of how many, and how long its motion is."""
    from foam_mj.cli import main
    from foam_mj.results import outcome_from_result, read_result

    js = tmp_path / "r.json"
    assert main(["plan", "--scene", "obstacle", "--smoother", "convex", "--no-rrd", "--no-replay", "--json", str(js)]) == 0
    messages: list[str] = []
    outcome = outcome_from_result(read_result(js), js, dynamic=False, report=messages.append)
    steps = {name: len(po.trajectory.times) for name, po in outcome.paths.items()}
    assert [m.split(";")[0].rstrip(")") for m in messages] == [
        "replaying: centre (T) (1 of 2"] * 2 + ["replaying: convex shortest (2 of 2"] * 2
    assert messages[1].endswith(f" s of motion, {steps['centre']:,} steps)")
    assert messages[3].endswith(f" s of motion, {steps['convex']:,} steps)")


def test_a_relative_mjcf_is_read_beside_the_result_not_in_the_working_folder(tmp_path, monkeypatch):
    """`replay`, `export` and `figures` find the scene as `foam-mj verify` and the shared verify_result.py do: a relative
    "mjcf" (a result edited or written by another tool) names a file beside the result, wherever the command runs."""
    import json
    import os
    import shutil

    from foam_mj.cli import main
    from foam_mj.results import resolve_model

    js = tmp_path / "results" / "r.json"
    js.parent.mkdir()
    assert main(["plan", "--scene", "obstacle", "--smoother", "convex", "--no-rrd", "--no-replay", "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    shipped = Path(doc["mjcf"])
    shutil.copytree(shipped.parent, tmp_path / "models")  # the scene and the robot it includes, beside the results
    doc.pop("mjcf_relative")
    doc["mjcf"] = os.path.join("..", "models", shipped.name)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert resolve_model(doc, js) == (tmp_path / "models" / shipped.name).resolve()


def test_the_foam_statistics_are_written_as_strict_json_whatever_numbers_a_planner_reports(tmp_path):
    """A planner's PlanStats went into the result as given: numpy counters in ``details`` (a planner of the user's,
    registered with foam_mj.planners.register) stopped write_outcome with "Object of type int64 is not JSON
    serializable", and a zero ``elapsed`` (an outcome read back from a result) wrote bubbles_per_second as the
    token NaN, which strict JSON readers refuse. Like every other number of the result, they are plain JSON now."""
    import dataclasses
    import json

    import numpy as np

    import foam_mj

    out = foam_mj.run(foam_mj.load_scenario("obstacle"), smoothers="convex", dynamic=False)
    stats = dataclasses.replace(out.plan.stats, elapsed=0.0, details={**out.plan.stats.details, "rounds": np.int64(3),
                                                                       "gain": np.float32(0.5), "spread": np.array([1.0, np.inf])})
    out.plan = dataclasses.replace(out.plan, stats=stats)
    p = write_outcome(tmp_path / "r.json", out)
    written = json.loads(p.read_text(), parse_constant=lambda token: pytest.fail(f"non-standard JSON token {token}"))["foam"]["stats"]
    assert written["rounds"] == 3 and written["gain"] == 0.5 and written["spread"] == [1.0, None]
    assert written["bubbles_per_second"] is None and written["bubbles"] == out.plan.stats.bubbles
