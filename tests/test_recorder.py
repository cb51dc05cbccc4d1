"""Tests foam_mj.recorder: the recording written by the helper process is the one written in-process,
and the helper never changes what the command reports (its failures fall back to the in-process path)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import pytest

from foam_mj.cli import main
from foam_mj.pipeline import run
from foam_mj.recorder import MODE_ENV, RecorderProcess, RecordingJob, outcome_job, recorder_mode
from foam_mj.recording import _store_chunks, read_recording
from foam_mj.scenarios import load_scenario

from conftest import wait_for_stderr, wall_scenario


@pytest.fixture(scope="module")
def outcome():
    """The obstacle scene with the convex smoother: every kind of log call (scene, foam, rosary, paths,
    trajectories, joint loads, dynamic replays)."""
    return run(load_scenario("obstacle"), None, ("convex",))


def _content(path) -> list[tuple]:
    """Every chunk of the recording store as (entity, static, column names) and its Arrow batch without the
    row ids (unique per write), in a canonical order (stable: file order within an entity)."""
    out = []
    for ch in _store_chunks(path):
        batch = ch.to_record_batch()
        batch = batch.drop_columns([c for c in batch.schema.names if c == "rerun.controls.RowId"])
        out.append(((str(ch.entity_path), bool(ch.is_static), tuple(batch.schema.names)), batch))
    return sorted(out, key=lambda kb: kb[0])


def _same(a, b) -> bool:
    return len(a) == len(b) and all(ka == kb and ba.equals(bb) for (ka, ba), (kb, bb) in zip(a, b))


def test_the_helper_writes_the_same_recording_as_the_command_itself(outcome, tmp_path):
    inline, helper = tmp_path / "inline.rrd", tmp_path / "helper.rrd"
    outcome_job(inline, outcome).write()
    recorder = RecorderProcess.start("process")
    assert recorder is not None
    assert recorder.write(outcome_job(helper, outcome)) is True
    rows = read_recording(helper)
    assert rows["cspace/foam"] == 1 and rows["cspace/rosary"] == 1
    assert {"cspace/paths/centre", "cspace/paths/convex", "world/leg/convex/thigh", "plots/torque/convex"} <= set(rows)
    assert _same(_content(helper), _content(inline))
    assert not list(tmp_path.glob(".*"))  # no temporary file left behind


def test_the_recorded_robot_and_clearance_are_the_planned_trajectory(outcome, tmp_path):
    """The recording showed the servo replay's poses (0.2-0.5 mm off the plan on obstacle, 2 mm on a Panda) and its
    clearance (84.95 mm where the summary's min clear said 84.85): the robot drawn and its clearance plot must be
    the planned trajectory, pose for pose as MuJoCo puts it, with the servo replay's tracking errors beside it."""
    import mujoco
    import numpy as np

    from foam_mj.recording import read_component

    # The servo replay now tracks the plan to rounding (its feed-forward is exact for MuJoCo's step), so that the test
    # can still tell the two apart, each path's replay is displaced here: 10 mrad / 10 mm, its bodies 1 cm, its
    # clearance 1 cm. Drawing the replay instead of the plan would then miss by far more than the tolerances below.
    displaced = dataclasses.replace(outcome, paths={
        name: dataclasses.replace(po, dynamic=dataclasses.replace(
            po.dynamic, qpos=po.dynamic.qpos + 0.01, clearance=po.dynamic.clearance + 0.01,
            poses=dataclasses.replace(po.dynamic.poses, xpos=po.dynamic.poses.xpos + 0.01)))
        for name, po in outcome.paths.items()})
    rrd = tmp_path / "o.rrd"
    outcome_job(rrd, displaced).write()
    robot = outcome.scenario.robot
    m, d = robot.model, mujoco.MjData(robot.model)
    rows = read_recording(rrd, static=False)
    for name, po in displaced.paths.items():
        assert po.dynamic is not None and np.max(np.abs(po.dynamic.qpos - po.trajectory.qpos)) > 1e-6  # they differ
        foot = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "foot")
        xyz = np.array(read_component(rrd, f"world/leg/{name}/foot", "Transform3D:translation")).reshape(-1, 3)
        assert len(xyz) == len(po.trajectory)
        for i in (0, len(xyz) // 3, len(xyz) // 2, len(xyz) - 1):
            d.qpos[:] = po.trajectory.qpos[i]
            mujoco.mj_kinematics(m, d)
            np.testing.assert_allclose(xyz[i], d.xpos[foot], atol=1e-6)
        clearance = np.array(read_component(rrd, f"plots/clearance/{name}", "Scalars:scalars")).ravel()
        assert clearance.min() == pytest.approx(po.kinematic.min_clearance, abs=1e-9)
        assert rows[f"plots/tracking/{name}"] == po.dynamic.n_frames


def test_two_recordings_of_one_scene_are_two_recordings_in_the_viewer(outcome, tmp_path):
    """Every recording of a scene had the recording id foam-mj-<scene> (and every --mjcf scene.xml 'foam-mj-scene'):
    Rerun's viewer merges the files of one application and recording id, so two runs opened together showed one foam
    and a mix of both runs' motions. Each file now has its own id, still named after the scene."""
    from rerun.chunk import RrdReader

    a, b = tmp_path / "a.rrd", tmp_path / "b.rrd"
    outcome_job(a, outcome).write()
    outcome_job(b, outcome).write()
    ids = [[s.recording_id for s in RrdReader(p).recordings()] for p in (a, b)]
    assert len(ids[0]) == len(ids[1]) == 1 and ids[0] != ids[1]
    assert all(i[0].startswith("foam-mj-obstacle-") for i in ids)


def test_the_foam_of_a_failed_plan_is_recorded_the_same_way(outcome, tmp_path):
    # `plan` records the foam grown so far when planning fails: scene, bubbles, q_init and q_goal.
    scenario, foam = outcome.scenario, outcome.plan.foam
    inline, helper = tmp_path / "inline.rrd", tmp_path / "helper.rrd"
    outcome_job(inline, scenario=scenario, foam=foam).write()
    assert RecorderProcess.start("process").write(outcome_job(helper, scenario=scenario, foam=foam)) is True
    rows = read_recording(helper)
    assert rows["cspace/foam"] == 1 and "cspace/q_goal" in rows and not any(e.startswith("cspace/paths") for e in rows)
    assert _same(_content(helper), _content(inline))


def test_a_failing_helper_leaves_the_job_to_the_command(outcome, tmp_path):
    # The helper cannot write into a folder that does not exist: it reports failure and writes nothing;
    # the command's own Recording then raises its usual error.
    job = outcome_job(tmp_path / "missing" / "run.rrd", outcome)
    recorder = RecorderProcess.start("process")
    assert recorder.write(job) is False
    assert not (tmp_path / "missing").exists()
    with pytest.raises(ValueError, match="folder does not exist"):
        job.write()


def test_a_helper_sent_no_job_is_stopped_and_writes_nothing(tmp_path):
    recorder = RecorderProcess.start("process")
    proc = recorder._proc
    recorder.close()
    assert proc.returncode is not None  # ended, not left running
    recorder.close()  # idempotent
    assert recorder.write(RecordingJob(tmp_path / "late.rrd", "late")) is False  # stopped: the caller writes it
    assert list(tmp_path.iterdir()) == []


def test_modes_from_the_environment(monkeypatch):
    monkeypatch.delenv(MODE_ENV, raising=False)
    assert recorder_mode() == "auto"
    monkeypatch.setenv(MODE_ENV, "inline")
    assert recorder_mode() == "inline" and RecorderProcess.start() is None
    monkeypatch.setenv(MODE_ENV, "Process ")
    assert recorder_mode() == "process"
    monkeypatch.setenv(MODE_ENV, "thread")
    with pytest.raises(Exception, match="FOAM_MJ_RECORDER must be one of auto, process, inline, got 'thread'"):
        recorder_mode()


def test_plan_with_a_bad_recorder_mode_exits_2_in_one_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv(MODE_ENV, "thread")
    assert main(["plan", "--scene", "obstacle", "--smoother", "convex", "--rrd", str(tmp_path / "o.rrd")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "FOAM_MJ_RECORDER" in err[0]
    assert not (tmp_path / "o.rrd").exists()


def test_plan_through_the_helper_writes_a_complete_recording(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv(MODE_ENV, "process")
    rrd = tmp_path / "o.rrd"
    assert main(["plan", "--scene", "obstacle", "--smoother", "convex", "--no-replay", "--rrd", str(rrd)]) == 0
    assert f"wrote {rrd}" in capsys.readouterr().out
    rows = read_recording(rrd)
    assert rows["cspace/foam"] == 1 and "cspace/paths/convex" in rows


def test_importing_the_recorder_loads_neither_rerun_nor_numpy():
    code = "import sys, foam_mj.recorder; print(sorted(m for m in ('numpy', 'rerun', 'mujoco') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def _default_sigint() -> None:
    """Let the child see Ctrl-C even when this test runs in a background job (which inherits SIGINT ignored)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_ctrl_c_stops_the_command_and_its_helper_and_writes_nothing(tmp_path):
    """Ctrl-C while a plan runs, its recording's helper started: both stop, exit 130, nothing written. The signal is
    sent once the plan is observably under way (its progress line) and far from done (a plan that runs until it
    stalls): half a second after the helper started, under load, fell during an import or after the plan (exit 0)."""
    import os
    import signal

    import psutil  # the test extra (rerun-sdk needs it too)

    env = {**os.environ, MODE_ENV: "process"}
    toml = wall_scenario(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    rrd = out / "w.rrd"
    proc = subprocess.Popen([sys.executable, "-m", "foam_mj.cli", "plan", "--scene", str(toml), "--rrd", str(rrd)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_default_sigint)
    helpers: list = []
    try:
        wait_for_stderr(proc, "planning (")  # the helper starts before the plan
        helpers = psutil.Process(proc.pid).children()
        assert helpers, "no helper process was started"
        os.killpg(proc.pid, signal.SIGINT)  # as a terminal does: the whole process group
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
        gone, alive = psutil.wait_procs(helpers, timeout=30)
        for p in alive:
            p.kill()
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert not alive
    assert list(out.iterdir()) == []  # no recording, no temporary file
