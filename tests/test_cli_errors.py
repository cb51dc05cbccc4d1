"""The command line's contract: every bad input is one line on stderr and exit 2 (before any planning where
it can be) or 3, never a traceback, never a file left behind; outputs are complete or absent; replay refuses
a result that does not match its scene; the exit codes and flags are documented."""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
import sys
import tempfile
import uuid
from pathlib import Path

import pytest

from foam_mj import atomic
from foam_mj.cli import EXIT_CODES, UsageError, build_parser, main

from conftest import MODELS, messages, wait_for_stderr, wall_scenario

ROOT = Path(__file__).resolve().parents[1]
GOOD = "q_init = [0.2, 0.3, 0.08]\nq_goal = [0.45, 0.4536, 1.45]\n"


def _toml(folder: Path, body: str, scene: str = str(MODELS / "obstacle.xml")) -> Path:
    p = folder / f"s{uuid.uuid4().hex[:6]}.toml"
    p.write_text(f'scene = "{scene}"\n{body}')
    return p


def _bad_inputs(d: Path) -> dict[str, tuple[list[str], str]]:
    bad_xml = d / "bad.xml"
    bad_xml.write_text('<mujoco><worldbody><geom type="box" size="1"/></worldbody></mujoco>')
    (d / "folder").mkdir()
    long_name = "a" * 300 + ".json"
    return {
        "q_goal == q_init": (["--scene", str(_toml(d, "q_init = [0.2, 0.3, 0.08]\nq_goal = [0.2, 0.3, 0.08]\n"))], "are equal"),
        "huge K": (["--scene", str(_toml(d, GOOD + "[planner]\nK = 100000000\n"))], "candidates per bubble"),
        "tiny r_min": (["--scene", str(_toml(d, GOOD + "[planner]\nr_min = 1e-7\n"))], "candidates per bubble"),
        "seed -1": (["--seed", "-1"], "--seed"),
        "seed 2**70": (["--seed", str(2**70)], "--seed"),
        "seed not a number": (["--seed", "abc"], "--seed"),
        "--json under /proc": (["--json", "/proc/foam.json"], "cannot create a file in /proc"),
        "--rrd under /proc": (["--rrd", "/proc/foam.rrd"], "cannot create a file in /proc"),
        "--json 300-char name": (["--json", str(d / long_name)], "longer than this file system allows"),
        "--rrd 300-char name": (["--rrd", str(d / ("b" * 300 + ".rrd"))], "longer than this file system allows"),
        "--json a directory": (["--json", str(d / "folder")], "is a directory"),
        "--rrd not .rrd": (["--rrd", str(d / "x.txt")], "must end in .rrd"),
        "--figures a file": (["--figures", str(bad_xml)], "is a file"),
        "scenario name a/b": (["--scene", str(_toml(d, 'name = "a/b"\n' + GOOD))], "field 'name'"),
        "--scene ''": (["--scene", ""], "empty scenario name"),
        "--scene a directory": (["--scene", str(d / "folder")], "is a directory"),
        "MJCF compile error": (["--scene", str(_toml(d, GOOD, str(bad_xml)))], "could not load MJCF"),
        "--no-rrd with --rrd": (["--no-rrd", "--rrd", str(d / "x.rrd")], "not allowed with argument --no-rrd"),
        "unknown smoother": (["--smoother", "fastest"], "unknown smoother"),
        "smoother list with a stray comma": (["--smoother", "ga,,hs"], "an empty smoother name in 'ga,,hs' (a stray comma?)"),
        "smoother ''": (["--smoother", ""], "an empty smoother name in ''"),
        "smoother none in a list": (["--smoother", "all,none"], "'none' (no smoother) cannot be combined with other smoothers in 'all,none'"),
        "unknown scene": (["--scene", "moon_walk"], "unknown scenario"),
        "--json a FIFO": (["--json", str(_fifo(d / "pipe.json"))], "is not a regular file (a FIFO)"),
        "--json ending in /": (["--json", f"{d}/out/"], "ends in '/': it names a folder"),
        "--start with an empty field": (["--mjcf", str(MODELS / "obstacle.xml"), "--start", "0.2,,0.3,0.08", "--goal", "0.45 0.4536 1.45"],
                                        "--start must be numbers separated by spaces or commas, got '0.2,,0.3,0.08'"),
        "--scene 300-char path": (["--scene", str(d / ("s" * 300 + ".toml"))], "File name too long"),
        "--mjcf 300-char name": (["--mjcf", str(d / ("m" * 300 + ".xml")), "--start", "0.2 0.3 0.08", "--goal", "0.45 0.4536 1.45"],
                                 "File name too long"),
        "--delta -inf": (["--delta", "-inf"], "--delta must be a margin >= 0 in metres, got -inf"),
        "a planner name one letter off": (["--planner", "pfmx"], "unknown planner 'pfmx' (did you mean 'pfm'?)"),
        "--start with _": (["--mjcf", str(MODELS / "obstacle.xml"), "--start", "0.2 0.3 0_08", "--goal", "0.45 0.4536 1.45"],
                           "--start must be numbers separated by spaces or commas, got '0.2 0.3 0_08'"),
    }


def _fifo(p: Path) -> Path:
    """A named pipe, as ``/dev/null`` is a device: renaming a result onto either would replace it (as root, the
    device node itself), and opening it would block or discard the result."""
    os.mkfifo(p)
    return p




@pytest.fixture
def inputs(tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    return _bad_inputs(d)


NAMES = ["q_goal == q_init", "huge K", "tiny r_min", "seed -1", "seed 2**70", "seed not a number", "--json under /proc",
         "--rrd under /proc", "--json 300-char name", "--rrd 300-char name", "--json a directory", "--rrd not .rrd",
         "--figures a file", "scenario name a/b", "--scene ''", "--scene a directory", "MJCF compile error",
         "--no-rrd with --rrd", "unknown smoother", "smoother list with a stray comma", "smoother ''", "smoother none in a list", "unknown scene", "--json a FIFO", "--json ending in /", "--start with _"]


@pytest.mark.parametrize("name", NAMES)
def test_every_bad_plan_input_is_one_line_exit_2_and_leaves_no_file(name, inputs, tmp_path, monkeypatch, capsys):
    args, message = inputs[name]
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    before = sorted(p.name for p in (tmp_path / "in").iterdir())
    code = main(["plan", *args])
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert message in err, err
    assert list(work.iterdir()) == [] and sorted(p.name for p in (tmp_path / "in").iterdir()) == before


def test_bad_inputs_are_refused_before_planning(inputs, capsys):
    """K = 1e8 used to end in a MemoryError after 80 s: now the bound is checked up front."""
    import time

    t0 = time.perf_counter()
    for name in ("huge K", "tiny r_min", "q_goal == q_init"):
        assert main(["plan", *inputs[name][0], "--no-rrd"]) == 2
    assert time.perf_counter() - t0 < 30  # generous under load; planning would take minutes or fail
    assert "planning" not in capsys.readouterr().err


def test_bench_refuses_an_unwritable_json_before_any_work(capsys):
    assert main(["bench", "--quick", "--json", "/proc/bench.json"]) == 2
    err = capsys.readouterr().err
    assert "cannot create a file in /proc" in err and len(err.strip().splitlines()) == 1
    assert main(["bench", "--quick", "--json", "bench.txt"]) == 2
    assert "--json output bench.txt must end in .json" in capsys.readouterr().err
    assert main(["bench", "--quick", "--json", ""]) == 2  # was read as the folder '.': "--json output . is a directory"
    assert "--json: empty file name" in capsys.readouterr().err
    for args in (["--runs", "0"], ["--runs", "x"], ["--runs", "10001"], ["--colour"]):
        assert main(["bench", *args]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "foam-mj bench: error" in err, err


def test_a_write_failure_after_planning_leaves_no_file_and_exits_2(tmp_path, monkeypatch, capsys):
    """A full disk at write time (an injected ENOSPC): no .rrd, no .json, no temporary file, exit 2."""

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(atomic.os, "fsync", full)
    # The failure is injected into this process only: the recording helper process (used when a core is free)
    # would write the .rrd fine. A really full disk fails it too (the tmpfs test below).
    monkeypatch.setenv("FOAM_MJ_RECORDER", "inline")
    code = main(["plan", "--smoother", "none", "--no-replay", "--rrd", str(tmp_path / "r.rrd"), "--json", str(tmp_path / "r.json")])
    err = capsys.readouterr().err
    assert code == 2 and "No space left on device" in err and len(messages(err)) == 1
    assert list(tmp_path.iterdir()) == []


@pytest.fixture
def small_tmpfs(tmp_path):
    mnt = tmp_path / "tmpfs"
    mnt.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)], capture_output=True).returncode:
        pytest.skip("mounting a tmpfs needs root (the injected-ENOSPC test covers the same path)")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)


def test_a_really_full_file_system_leaves_no_file(small_tmpfs, monkeypatch, capsys):
    """On a 64 KiB tmpfs: refused before planning; with the free-space check off, the writes fail and leave nothing."""
    rrd, js = small_tmpfs / "r.rrd", small_tmpfs / "r.json"
    assert main(["plan", "--smoother", "none", "--no-replay", "--rrd", str(rrd), "--json", str(js)]) == 2
    assert "no space left" in capsys.readouterr().err
    monkeypatch.setattr(atomic, "MIN_FREE_BYTES", 0)
    assert main(["plan", "--smoother", "none", "--no-replay", "--rrd", str(rrd), "--json", str(js)]) == 2
    err = capsys.readouterr().err
    assert "No space left on device" in err and len(messages(err)) == 1
    assert list(small_tmpfs.iterdir()) == []


# -- replay refuses what does not match ----------------------------------------------------------------------
def _edited(src: Path, folder: Path, edit) -> Path:
    doc = json.loads(src.read_text())
    edit(doc)
    out = folder / "edited.json"
    out.write_text(json.dumps(doc))
    return out


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
@pytest.mark.parametrize("command", [["verify"], ["replay", "--kinematic-only"], ["export", "--out", "o.csv"], ["figures", "--dpi", "60"]])
def test_a_result_that_is_no_regular_file_is_refused_before_reading(tmp_path, command):
    """A named pipe given as the result waited for a writer for ever, and /dev/zero was read until memory ran out (an
    internal error, exit 1, after gigabytes): the scenario, sweep and recording readers refuse both, the result readers
    did not. Exit 2 at once, one line."""
    os.mkfifo(tmp_path / "r.json")
    argv = [command[0], "r.json", *(["figs"] if command[0] == "figures" else []), *command[1:]]
    root = Path(__file__).resolve().parents[1]
    run = subprocess.run([sys.executable, "-m", "foam_mj.cli", *argv], capture_output=True, text=True, cwd=tmp_path,
                         env={**os.environ, "PYTHONPATH": str(root)}, timeout=120)
    assert run.returncode == 2 and run.stderr == "foam-mj: error: result file r.json: not a regular file\n", run.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_the_result_names_its_scene_relative_to_itself_and_by_content_hash(planned_result):
    doc = json.loads(planned_result.read_text())
    assert (planned_result.parent / doc["mjcf_relative"]).resolve() == Path(doc["mjcf"]).resolve()
    assert len(doc["model_hash"]["sha256"]) == 64 and set(doc["model_hash"]["parts"]) == {"kinematics", "geometry", "dynamics", "declarations"}


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.update(version=99), "unknown format version 99"),
        (lambda d: (d.update(mjcf=str(MODELS / "step_up.xml")), d.pop("mjcf_relative")), "field 'mjcf' names"),
        (lambda d: d.update(mjcf_relative=os.path.relpath(MODELS / "step_up.xml", d["_folder"])), "field 'mjcf_relative' names"),
        (lambda d: d["model_hash"]["parts"].update(geometry="0" * 64), "geometry differs"),
        (lambda d: d.update(mjcf="/nowhere/scene.xml", mjcf_relative="nowhere.xml"), "not found"),
        # a model_hash that is no object skipped the check: the obstacle's paths replayed on step_up with exit 0
        (lambda d: (d.update(mjcf=str(MODELS / "step_up.xml"), model_hash="fe247d40"), d.pop("mjcf_relative")),
         "field 'model_hash' must be an object"),
        (lambda d: (d.update(mjcf=str(MODELS / "step_up.xml"), model_hash=[d["model_hash"]]), d.pop("mjcf_relative")),
         "field 'model_hash' must be an object"),
    ],
)
def test_replay_refuses_a_result_that_does_not_match_its_scene(planned_result, tmp_path, edit, message, capsys):
    def with_folder(doc):
        doc["_folder"] = str(tmp_path)
        edit(doc)

    bad = _edited(planned_result, tmp_path, with_folder)
    assert main(["replay", str(bad), "--kinematic-only"]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert main(["verify", str(bad)]) == 2
    assert message.split(" names")[0] in capsys.readouterr().err


def test_a_result_moved_away_from_its_scene_still_replays_by_its_absolute_path(planned_result, tmp_path, capsys):
    moved = tmp_path / "deep" / "er"
    moved.mkdir(parents=True)
    (moved / "r.json").write_text(planned_result.read_text())
    assert main(["replay", str(moved / "r.json"), "--kinematic-only"]) == 0


def test_replay_refuses_a_result_without_its_margin(planned_result, tmp_path, capsys):
    """A result whose planner.delta was deleted replayed with exit 0: its clearance was measured with 5 mm but the
    exit-4 check used a margin of 0. verify refuses such a result; replay now does too, before any work."""
    bad = _edited(planned_result, tmp_path, lambda d: d["planner"].pop("delta"))
    assert main(["replay", str(bad), "--kinematic-only", "--rrd", str(tmp_path / "r.rrd")]) == 2
    err = capsys.readouterr().err
    assert err == f"foam-mj: error: {bad}: missing field 'planner.delta' (the safety margin the replay is checked against)\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["edited.json"]


def test_replay_exits_4_when_its_replay_is_closer_than_the_margin(planned_result, tmp_path, capsys):
    """The same result with a margin larger than its clearance (0.5 m): the replay is below the margin."""
    bad = _edited(planned_result, tmp_path, lambda d: d["planner"].update(delta=0.5))
    assert main(["replay", str(bad), "--kinematic-only"]) == 4
    assert "below the margin 500 mm" in capsys.readouterr().err
    assert main(["replay", str(planned_result), "--kinematic-only"]) == 0



def test_export_exits_3_when_no_timing_fits_the_results_limits(planned_result, tmp_path, capsys):
    """A result whose torque limits (1 N m) are below what gravity alone asks of the hip: no timing of its path fits,
    which is a planning failure (exit 3, 'planning failed', nothing written), not bad input (2)."""
    bad = _edited(planned_result, tmp_path, lambda d: d["limits"].update(torque=[1.0] * len(d["limits"]["joints"])))
    out = tmp_path / "t.csv"
    assert main(["export", str(bad), "--out", str(out)]) == 3
    assert "planning failed" in capsys.readouterr().err and not out.exists()

def test_a_failure_of_the_replay_itself_is_not_blamed_on_the_result(planned_result, monkeypatch, capsys):
    """Every ValueError during `replay` was reported as 'malformed result' (exit 2), even one raised by the
    simulation after the file was read (an RK4 model's dynamic replay did): a bug then passed for bad input."""

    def broken(*_args, **_kwargs):
        raise ValueError("the simulation went wrong")

    monkeypatch.setattr("foam_mj.pipeline.replay_dynamic", broken)  # where plan and replay call it (time_and_replay)
    assert main(["replay", str(planned_result)]) == 1
    err = capsys.readouterr().err
    assert "internal error: ValueError: the simulation went wrong" in err and "malformed" not in err


# -- view, version, documentation -----------------------------------------------------------------------------
def test_view_without_a_display_says_what_to_do(tmp_path, monkeypatch, capsys):
    rrd = tmp_path / "x.rrd"
    rrd.write_bytes(b"RRF2")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    assert main(["view", str(rrd)]) == 2
    err = capsys.readouterr().err
    assert "no display" in err and "--web" in err and "rerun rrd stats" in err


def test_view_without_a_display_names_a_rerun_that_runs_when_the_environment_is_not_active(tmp_path, monkeypatch, capsys):
    """The README's first command runs `.venv/bin/foam-mj` without activating the environment: `rerun` (shipped with
    rerun-sdk beside it) is then not on PATH, and the hint `rerun rrd stats FILE` was a command not found. Off PATH,
    the hint names the interpreter's own rerun by its path; on PATH, plain `rerun`."""
    rrd = tmp_path / "x.rrd"
    rrd.write_bytes(b"RRF2")
    beside = Path(sys.executable).with_name("rerun")
    if not beside.exists():
        pytest.skip("no rerun beside this interpreter")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    assert main(["view", str(rrd)]) == 2
    err = capsys.readouterr().err
    assert f"`{beside} rrd stats {rrd}`" in err
    foam = beside.with_name("foam-mj")
    assert f"`{foam if foam.exists() else 'foam-mj'} view --web {rrd}`" in err
    monkeypatch.setenv("PATH", str(beside.parent))
    assert main(["view", str(rrd)]) == 2
    err = capsys.readouterr().err
    assert f"`rerun rrd stats {rrd}`" in err and f"`foam-mj view --web {rrd}`" in err


def test_plan_names_a_foam_mj_that_runs_to_view_its_recording(tmp_path, monkeypatch, capsys):
    """After `.venv/bin/foam-mj plan` (the README's first command, the environment not activated) the line "wrote
    X.rrd (view it with: foam-mj view X.rrd)" named a command not found: off PATH it names the foam-mj beside the
    interpreter by its path."""
    foam = Path(sys.executable).with_name("foam-mj")
    if not foam.exists():
        pytest.skip("no foam-mj console script beside this interpreter")
    rrd = tmp_path / "o.rrd"
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    assert main(["plan", "--scene", "obstacle", "--no-replay", "--rrd", str(rrd)]) == 0
    assert f"wrote {rrd} (view it with: {foam} view {rrd})" in capsys.readouterr().out


@pytest.mark.parametrize(("content", "args", "message"), [
    (b"hello", [], "is not a Rerun recording: it does not start with Rerun's file header 'RRF'"),
    (b"", [], "header 'RRF' (the file is empty)"),
    (b"RRF2", ["--bind", "999.1.1.1"], "--bind must be an IP address (127.0.0.1, 0.0.0.0, ::1), got '999.1.1.1'"),
])
def test_view_refuses_a_file_that_is_not_a_recording_and_a_bad_address(tmp_path, content, args, message, capsys):
    """A text file named .rrd was handed to the viewer (it served it and showed nothing); --bind 999.1.1.1 gave the
    rerun binary's own three-line error."""
    rrd = tmp_path / "x.rrd"
    rrd.write_bytes(content)
    assert main(["view", str(rrd), "--web", *args]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and message in err, err


def test_view_says_when_a_recording_was_cut_short(tmp_path, monkeypatch, capsys):
    """A recording cut short (a partial copy) was served without a word: the viewer shows part of it as if whole."""
    from foam_mj.recording import Recording

    rrd = tmp_path / "v.rrd"
    with Recording(rrd) as rec:
        rec.log_path("p", [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    served: list = []
    monkeypatch.setattr("foam_mj.viewer._run_viewer", lambda cmd: served.append(cmd) or 0)
    assert main(["view", "--web", str(rrd), "--web-port", "0", "--grpc-port", "0"]) == 0
    assert "cut short" not in capsys.readouterr().err
    cut = tmp_path / "cut.rrd"
    cut.write_bytes(rrd.read_bytes()[:-40])
    assert main(["view", "--web", str(cut), "--web-port", "0", "--grpc-port", "0"]) == 0
    err = capsys.readouterr().err
    assert f"note: {cut} does not end with Rerun's footer: the file was cut short" in err and len(served) == 2


def test_view_refuses_a_recording_damaged_between_its_header_and_footer(tmp_path, monkeypatch, capsys):
    """A recording with Rerun's header and footer but zeros in between (a bad copy, a disk error) was served: Rerun
    logged a warning and an error in its own format and the viewer showed part of it."""
    from foam_mj.recording import Recording

    rrd = tmp_path / "v.rrd"
    with Recording(rrd) as rec:
        for i in range(20):
            rec.log_path(f"p{i}", [[float(i), float(k), float(k * k % 7)] for k in range(500)])
    data = bytearray(rrd.read_bytes())
    third = len(data) // 3
    data[third:2 * third] = bytes(third)
    damaged = tmp_path / "damaged.rrd"
    damaged.write_bytes(bytes(data))
    served: list = []
    monkeypatch.setattr("foam_mj.viewer._run_viewer", lambda cmd: served.append(cmd) or 0)
    assert main(["view", "--web", str(rrd), "--web-port", "0", "--grpc-port", "0"]) == 0  # the intact file is served
    capsys.readouterr()
    assert main(["view", "--web", str(damaged), "--web-port", "0", "--grpc-port", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"foam-mj: error: {damaged} is damaged: Rerun cannot decode it ("), err
    assert len(served) == 1


def test_view_refuses_a_port_in_use_or_one_port_for_both_servers(tmp_path, monkeypatch, capsys):
    """Rerun's viewer started, logged "Address already in use" (or "this port is already used by the server we're
    connecting to") and exited 1: an internal error by the exit codes, for a busy port or --web-port = --grpc-port."""
    import socket

    from foam_mj.recording import Recording

    rrd = tmp_path / "v.rrd"
    with Recording(rrd) as rec:
        rec.log_path("p", [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    monkeypatch.setattr("foam_mj.viewer._run_viewer", lambda cmd: 0)
    assert main(["view", "--web", str(rrd), "--web-port", "9999", "--grpc-port", "9999"]) == 2
    assert "--web-port and --grpc-port are both 9999" in capsys.readouterr().err
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert main(["view", "--web", str(rrd), "--grpc-port", str(port), "--web-port", "0"]) == 2
        err = capsys.readouterr().err
    assert err.strip() == f"foam-mj: error: --grpc-port {port} on 127.0.0.1 is in use (another viewer?): give another port, or 0 for a free one"


def test_view_web_serves_on_localhost_only_and_prints_the_url(tmp_path):
    import time
    import urllib.request

    import psutil  # the test extra (rerun-sdk needs it too)

    from foam_mj.recording import Recording

    rrd = tmp_path / "v.rrd"
    with Recording(rrd) as rec:
        rec.log_path("p", [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    exe = Path(sys.executable).with_name("foam-mj")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "RERUN_ANALYTICS": "false"}
    env.pop("RUST_LOG", None)
    proc = subprocess.Popen([str(exe), "view", "--web", str(rrd), "--web-port", "0", "--grpc-port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    viewers: list = []
    try:
        line = proc.stdout.readline()
        assert "open http://127.0.0.1:" in line and "bound to 127.0.0.1" in line, line
        web_port = int(line.split("open http://127.0.0.1:")[1].split("?")[0])
        for _ in range(60):
            viewers = psutil.Process(proc.pid).children(recursive=True)
            try:
                assert urllib.request.urlopen(f"http://127.0.0.1:{web_port}/", timeout=2).status == 200
                break
            except OSError:
                time.sleep(0.5)
        else:
            raise AssertionError("the web viewer did not answer")
        viewers = psutil.Process(proc.pid).children(recursive=True)
        # Only loopback listens: nothing of this viewer on 0.0.0.0.
        listening = [c.laddr.ip for v in viewers for c in v.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN]
        assert listening and set(listening) == {"127.0.0.1"}, listening
    finally:
        proc.terminate()  # SIGTERM stops foam-mj and the viewer's whole process group
        code = proc.wait(timeout=30)
        gone, alive = psutil.wait_procs(viewers, timeout=15)
        for p in alive:  # never leak a server, even when the test fails
            p.kill()
    assert code == 130 and not alive, alive
    err = proc.stderr.read()
    # One line of ours says where to look; Rerun's INFO lines (telemetry, "Hosting a web-viewer", "Listening") are not repeated.
    assert "INFO" not in err and "Hosting" not in err, err


def test_version(capsys):
    from foam_mj import __version__

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"foam-mj {__version__}"


def _options(parser) -> dict[str, list[str]]:
    import argparse

    out = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                out[name] = [s for a in sub._actions for s in a.option_strings if s not in ("-h", "--help")]
    return out


def test_the_readme_documents_every_command_flag_and_exit_code():
    """Each flag in its own command's rows of the Command line tables (a bare search of the README found bubble's
    --q in --quick and any flag under another command)."""
    import re

    readme = (ROOT / "README.md").read_text()
    tables = readme[readme.index("## Command line"):readme.index("Exit codes (every command)")]
    for command, flags in _options(build_parser()).items():
        rows = "\n".join(line for line in tables.splitlines() if line.startswith((f"| `foam-mj {command}", f"| `{command}` |")))
        assert rows, command
        for flag in flags:
            assert re.search(re.escape(flag) + r"(?![\w-])", rows), f"{command} {flag}"
    for flag in ("--quick", "--runs", "--json", "--no-progress", "FOAM_MJ_DEBUG", "--version"):
        assert flag in readme, flag
    for code, meaning in EXIT_CODES.items():
        assert f"| {code} |" in readme, code


def test_the_readmes_placeholders_are_the_help_texts():
    """A flag's value in the README's Command line tables is written as its command's --help writes it (the README
    had `--workers N`, `--hz 500`, `--scene NAME|--mjcf FILE` where --help said WORKERS, HZ, SCENE, ROBOT.xml):
    the placeholder is the option's metavar, or its choices (`toppra|own`; `F ...` for a list of them)."""
    import argparse
    import re

    from foam_mj.benchmark import build_parser as bench_parser

    readme = (ROOT / "README.md").read_text()
    tables = readme[readme.index("## Command line"):readme.index("Exit codes (every command)")]
    parsers = {name: sub for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction) for name, sub in a.choices.items()}
    parsers["bench"] = bench_parser()
    value = r'(?:"[^"]*"|[^\s`\[\]()|\\]+(?:\\\|[^\s`\[\]()|\\]+)*)'
    seen = 0
    for line in tables.splitlines():
        row = re.match(r"\| `(?:foam-mj )?(\w+)[ `]", line)
        if not row or row.group(1) not in parsers:
            continue
        options = {s: a for a in parsers[row.group(1)]._actions for s in a.option_strings}
        for flag, shown in re.findall(rf"(--[\w-]+)[ =]({value})", line.split(" | ")[0] if line.startswith("| `foam-mj") else line.split(" | ")[1]):
            action = options[flag]
            if action.choices:
                ok = shown.split("\\|") == list(action.choices) or (shown == "F" and action.nargs == "+")
            else:
                ok = shown == (action.metavar or action.dest.upper())
            assert ok, f"{row.group(1)} {flag}: README {shown!r}, --help {action.metavar or action.choices or action.dest.upper()!r}"
            seen += 1
    assert seen > 40, seen


def test_the_product_cites_papers_not_the_project_process():
    """Papers are cited by author and year, never by the numbers of the project's text copies ('paper 003', the pfm
    planner's summary 'Nascimento et al. 2020 / 003', a file name '000_5b98...')."""
    import re

    pattern = re.compile(r"issue [0-9]|shared/|paper 00[0-9]|00[0-9]_[0-9a-f]{6}|(?<![\w.,:-])00[0-4](?![\w.,:])")
    hits = []
    for top in ("README.md", "foam_mj", "models", "scenarios", "docs", "examples", "benchmarks"):
        files = [ROOT / top] if (ROOT / top).is_file() else [p for p in (ROOT / top).rglob("*") if p.suffix in (".py", ".md", ".xml", ".toml")]
        for f in files:
            for i, line in enumerate(f.read_text().splitlines(), 1):
                if pattern.search(line):
                    hits.append(f"{f.relative_to(ROOT)}:{i}: {line.strip()[:80]}")
    assert not hits, "\n".join(hits)
    assert (ROOT / "docs" / "references.md").is_file()


def test_every_paper_cited_by_author_and_year_is_in_the_bibliography():
    """The reproduction report cited the SAC paper's Table 1 as 'Nascimento et al. (2019)' and the Harmony Search
    paper as '(2018)', which references.md lists as 2020 and 2019; the README cited Lacevic et al., ICRA 2016, which
    it did not list. Every 'Name et al. [VENUE] YEAR', 'Name and Name [VENUE] YEAR', 'Name (YEAR)' or 'Name YEAR' of the README,
    docs/, the examples' READMEs and the code's docstrings and comments (foam_mj/, benchmarks/, models/, scenarios/,
    examples/: references.md says so) must match an entry of docs/references.md (its list, not its notes) by name
    and year."""
    import re

    cite = re.compile(r"\b([A-Z][a-zç]+) (?:et al\.|and [A-Z][a-zA-Z]+),? (?:\(|(?:[A-Z][\w/.&-]*[,\s]+){0,3})((?:19|20)\d\d)\b"
                      r"|\b([A-Z][a-z]+),? \(?((?:19|20)\d\d)\b")  # also 'Name YEAR' (Quinlan 1995, Winter 2009)
    bibliography = (ROOT / "docs" / "references.md").read_text().split("Notes on the sources")[0]
    entries = bibliography.split("\n- ")[1:]
    missing = []
    code = [p for top in ("foam_mj", "benchmarks", "models", "scenarios", "examples") for p in sorted((ROOT / top).rglob("*"))
            if p.suffix in (".py", ".md", ".xml", ".toml")]
    assert len(code) > 100
    for doc in (ROOT / "README.md", *sorted(p for p in (ROOT / "docs").glob("*.md") if p.name != "references.md"), *code):
        for m in cite.finditer(doc.read_text()):
            name, year = m.group(1) or m.group(3), m.group(2) or m.group(4)
            if not any(name in e and year in e for e in entries):
                missing.append(f"{doc.name}: {m.group(0)!r}")
    assert not missing, missing


def test_replay_of_a_result_without_paths_is_bad_input(planned_result, tmp_path, capsys):
    """A failed plan's JSON (outcome 'queue empty', no paths) has nothing to replay: exit 2, one line."""
    bad = _edited(planned_result, tmp_path, lambda d: (d.update(paths={}, outcome="queue empty"), d.pop("rosary", None)))
    assert main(["replay", str(bad), "--kinematic-only"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no paths to replay" in err and "queue empty" in err


def _refused(argv: list[str], words: str, capsys) -> None:
    """``foam-mj ARGV`` exits 2 with one line on stderr that holds ``words``."""
    assert main(argv) == 2, argv
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err, (argv, err)


def test_an_output_never_overwrites_an_input_or_another_output(planned_result, tmp_path, capsys):
    """Refused before any work (exit 2, one line, every file left as it was): the result as export's
    --out or replay's --rrd, the scenario or the MJCF as plan's --json, --json and --rrd on one file."""
    result = tmp_path / "r.json"
    result.write_text(planned_result.read_text())
    scenario = tmp_path / "s.toml"
    scenario.write_text((ROOT / "scenarios" / "obstacle.toml").read_text().replace("../models/", f"{MODELS}/"))
    arm = tmp_path / "arm.xml"
    arm.write_text((ROOT / "examples" / "two_link_arm" / "arm.xml").read_text())
    before = {p: p.read_bytes() for p in (result, scenario, arm)}
    cases = [
        (["export", str(result), "--format", "csv", "--out", str(result)], "is the result"),
        (["replay", str(tmp_path / "x.rrd"), "--rrd", str(tmp_path / "x.rrd")], "is the result"),
        (["plan", "--scene", str(scenario), "--no-rrd", "--json", str(scenario)], "must end in .json"),
        (["plan", "--mjcf", str(arm), "--start", "0.3 2", "--goal", "0.1 0.6", "--no-rrd", "--json", str(arm)], "must end in .json"),
        (["plan", "--scene", str(scenario), "--rrd", str(tmp_path / "o.rrd"), "--json", str(tmp_path / "o.rrd")], "must end in .json"),
    ]
    for argv, words in cases:
        _refused(argv, words, capsys)
    assert {p: p.read_bytes() for p in before} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm.xml", "r.json", "s.toml"]


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.update(limits="x"), "field 'limits' must be an object, got str"),
        (lambda d: d.update(planner=[1]), "field 'planner' must be an object, got list"),
        (lambda d: d.update(q_init=[0.2, 0.3]), "fields 'q_init' and 'q_goal' must have as many numbers, got 2 and 3"),
        (lambda d: d.update(q_goal="abc"), "field 'q_goal' must be a list of numbers"),
        (lambda d: d["paths"]["centre"]["waypoints"][2].__setitem__(0, float("nan")), "path 'centre': field 'waypoints' holds a number that is not finite"),
        (lambda d: d["paths"]["centre"]["waypoints"][2].append(0.1), "path 'centre': field 'waypoints' must be a list of at least 2 rows of numbers, 3 per row"),
        (lambda d: d["paths"]["centre"]["waypoints"][1].__setitem__(0, str(d["paths"]["centre"]["waypoints"][1][0])),
         "path 'centre': field 'waypoints' must be a list of at least 2 rows of numbers, 3 per row"),
        (lambda d: d["q_init"].__setitem__(0, str(d["q_init"][0])), "field 'q_init' must be a list of numbers"),
        (lambda d: d["paths"]["centre"].update(waypoints=[[0.2, 0.3, 0.08]]), "path 'centre': field 'waypoints' must be a list of at least 2 rows"),
    ],
)
def test_replay_export_and_figures_refuse_a_malformed_result_before_any_output(planned_result, tmp_path, edit, message, capsys):
    """limits = "x" was an internal error (exit 1, AttributeError) in replay and export; a NaN waypoint made
    figures exit 1 after writing some of the figures. Each is now one line, exit 2, and nothing is written."""
    bad = _edited(planned_result, tmp_path, edit)
    for argv in (["replay", str(bad), "--kinematic-only", "--rrd", str(tmp_path / "r.rrd")],
                 ["export", str(bad), "--format", "csv", "--out", str(tmp_path / "t.csv")],
                 ["figures", str(bad), str(tmp_path / "figs")]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and message in err, (argv, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["edited.json"]


@pytest.mark.parametrize(("end", "row", "words"), [
    (-1, [0.45, 1.0, 1.45], "path 'optimal' ends at [0.45, 1.0, 1.45], not at the result's q_goal [0.45, 0.4536, 1.45]"),
    (0, [0.2, 0.31, 0.08], "path 'optimal' starts at [0.2, 0.31, 0.08], not at the result's q_init [0.2, 0.3, 0.08]"),
])
def test_a_saved_path_moved_off_its_start_or_goal_is_refused_by_replay_export_and_verify(planned_result, tmp_path, end, row, words, capsys):
    """A last waypoint moved off q_goal was an internal error in replay and export (exit 1: "`path[30]` (the goal) is not
    in the rosary's last bubble") and passed verify as clean (exit 0): a path that does not join the result's start and
    goal is not its plan. Each now names the path, the end and both configurations: one line, exit 2, nothing written."""
    bad = _edited(planned_result, planned_result.parent, lambda d: d["paths"]["optimal"]["waypoints"].__setitem__(end, row))
    try:  # beside the result: its mjcf_relative still resolves
        for argv in (["replay", str(bad), "--kinematic-only", "--rrd", str(tmp_path / "r.rrd")],
                     ["export", str(bad), "--out", str(tmp_path / "t.csv")],
                     ["verify", str(bad), "--step", "0.05"]):
            _refused(argv, words, capsys)
        assert list(tmp_path.iterdir()) == []
    finally:
        bad.unlink()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--delta", "nan"], "--delta must be a margin >= 0 in metres, got nan"),
        (["--delta", "1e309"], "--delta must be a margin >= 0 in metres, got inf"),
        (["--subject-height", "50"], "--subject-height must be in [1.2, 2.2] m, got 50.0"),
        (["--figure-format", "svg"], "--figure-format goes with --figures DIR"),  # was taken and ignored, no figure drawn
        (["--subject-mass", "nan"], "--subject-mass must be in [25, 200] kg, got nan"),
        (["--robot-root", ""], "--robot-root must name a body of the model, got an empty name"),
        (["--mjcf", str(MODELS / "obstacle.xml"), "--start", "0.2 0.3", "--goal", "0.45 0.4536 1.45"], "--start: q_init must be 3 numbers, one per configuration joint (hip_flexion, knee_flexion, hip_displacement), got 2"),
        (["--mjcf", str(MODELS / "obstacle.xml"), "--start", "0.2 0.3 0.08", "--goal", "0 0 0.785"], "--goal = [0.0, 0.0, 0.785] is in collision"),
        (["--mjcf", str(MODELS / "obstacle.xml"), "--start", "0.2 0.3 0.08", "--goal", "0.2 0.3 0.08"], "--start and --goal are equal"),
        (["--mjcf", str(MODELS / "obstacle.xml"), "--joints", "a,b,c", "--start", "0.2 0.3 0.08", "--goal", "0.45 0.4536 1.45"],
         "--mjcf: " + str(MODELS / "obstacle.xml") + ": configuration joint 'a' is not in the model"),
        # a name left out between commas planned silently over the other two joints
        (["--mjcf", str(MODELS / "obstacle.xml"), "--joints", "hip_flexion,,hip_displacement", "--start", "0.2 0.08", "--goal", "0.45 1.45"],
         "--joints must name joints separated by commas, got an empty name at position 2 in 'hip_flexion,,hip_displacement'"),
    ],
)
def test_a_bad_flag_is_named_as_the_flag_not_as_a_scenario_field(args, message, tmp_path, monkeypatch, capsys):
    """`plan --delta nan` said "scenarios/obstacle.toml: [planner] `delta` must be >= 0", `--subject-height 50`
    "[subject] field 'height'", and `--mjcf ... --goal` "obstacle: field 'q_goal'": a file and fields the user never wrote."""
    monkeypatch.chdir(tmp_path)
    assert main(["plan", *args, "--no-rrd"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and err.startswith(f"foam-mj: error: {message}"), err
    assert ".toml" not in err and list(tmp_path.iterdir()) == []


def test_sigterm_during_plan_is_exit_130_and_leaves_no_file(tmp_path):
    """`kill` of a plan ended it at once (exit 143), a write's temporary file left behind; it now stops as Ctrl-C does.
    The signal is sent once the plan is observably under way (its progress line), not a fixed second after MuJoCo
    loaded: under load that second could fall anywhere."""
    import signal

    toml = wall_scenario(tmp_path)  # no way past the wall: the plan runs until it stalls or its 60 s budget ends
    out = tmp_path / "out"
    out.mkdir()
    exe = Path(sys.executable).with_name("foam-mj")
    proc = subprocess.Popen([str(exe), "plan", "--scene", str(toml), "--json", "r.json", "--rrd", "r.rrd"], cwd=out,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        wait_for_stderr(proc, "planning (")
        assert proc.poll() is None, "the plan ended before it could be interrupted"
        proc.send_signal(signal.SIGTERM)
        err = proc.communicate(timeout=120)[1]
    finally:
        proc.kill()
    assert proc.returncode == 130 and err.strip().splitlines()[-1] == "foam-mj: interrupted", err
    assert list(out.iterdir()) == []


TEARDOWN_SIGNAL = """
import atexit, os, signal, sys
from foam_mj import cli

class Late:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGTERM)

def scenes(args, original=cli.cmd_scenes, when=sys.argv.pop()):
    if when == "exit handler":  # a signal while a library's exit handler runs (rerun's flush, threads joined)
        atexit.register(os.kill, os.getpid(), signal.SIGTERM)
    else:  # or while Python clears its modules, its default signal handlers back
        cli.late = Late()
    return original(args)

cli.cmd_scenes = scenes
sys.argv[1:] = ["scenes"]
sys.exit(cli.main())
"""


@pytest.mark.parametrize("when, code", [("exit handler", 130), ("module teardown", 0)])
def test_a_signal_after_the_command_has_returned_is_no_traceback_and_no_kill(when, code):
    """Ctrl-C or `kill` in the last half second of `foam-mj replay` (its recording written, Python tearing down): the
    KeyboardInterrupt raised in an exit handler printed "Exception ignored ... Traceback" and the command exited 0, or,
    later, SIGTERM killed it (143). Now: exit 130 at once while the exit handlers run, ignored after them."""
    run = subprocess.run([sys.executable, "-c", TEARDOWN_SIGNAL, when], capture_output=True, text=True, timeout=60,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert run.returncode == code, run.stderr
    assert "obstacle" in run.stdout  # the command ran and printed its list
    assert run.stderr == ""


#: A signal that Python handles inside a finalizer (as in importlib's module-lock callback, where one landed under load),
#: or that a library catches and drops, before the command writes its file (`bubble --json`).
SIGNAL_DROPPED = """
import os, signal, sys
from foam_mj import atomic, cli

def noop():
    pass

def signal_here():
    os.kill(os.getpid(), signal.SIGTERM)
    noop()  # a call: Python runs the handler here, inside the caller

class Finalized:
    def __del__(self):
        signal_here()

def write(path, text, original=atomic.atomic_write_text, where=sys.argv.pop()):
    if where == "finalizer":
        Finalized()  # dropped at once: its __del__ runs here
    else:  # a library that catches the KeyboardInterrupt and goes on
        try:
            signal_here()
        except KeyboardInterrupt:
            pass
    return original(path, text)

atomic.atomic_write_text = write
sys.argv[1:] = ["bubble", "--scene", "obstacle", "--q", "0.2 0.3 0.08", "--json", "b.json"]
sys.exit(cli.main())
"""


@pytest.mark.parametrize("where", ["finalizer", "caught by a library"])
def test_a_signal_dropped_inside_a_finalizer_or_a_library_still_stops_the_command(tmp_path, where):
    """Ctrl-C during `foam-mj plan` under load: Python ran the handler inside importlib's module-lock callback, which
    printed "Exception ignored in ... KeyboardInterrupt" and dropped it; the command ran on, wrote its recording and
    exited 0 (a `kill` of a plan: exit 3 after its whole budget). A dropped interruption now stops the command all the
    same: exit 130, one line, no file."""
    run = subprocess.run([sys.executable, "-c", SIGNAL_DROPPED, where], capture_output=True, text=True, timeout=120,
                         cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert (run.returncode, run.stderr) == (130, "foam-mj: interrupted\n"), run.stderr
    assert list(tmp_path.iterdir()) == []


#: A signal while the command line's module loads: foam_mj.cli's own imports are held back (a slow import, as under
#: load) and the process signals itself then.
SIGNAL_WHILE_LOADING = """
import builtins, os, signal, sys
SIG = getattr(signal, sys.argv[1])
real_import = builtins.__import__
def slow_import(name, *args, **kw):
    if name == "argparse":  # foam_mj.cli's first import, before its handlers exist
        os.kill(os.getpid(), SIG)
    return real_import(name, *args, **kw)
builtins.__import__ = slow_import
sys.argv[1:] = ["scenes"]
import runpy
runpy.run_module("foam_mj", run_name="__main__")
"""


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_a_signal_while_the_command_loads_is_exit_130_and_one_line(sig):
    """Ctrl-C in the first tenth of a second of `foam-mj` or `python -m foam_mj` (while foam_mj.cli and argparse load,
    before main installs its handlers) printed a KeyboardInterrupt traceback and exited 1; `python -m foam_mj` did not
    exist. The entry module now handles both signals from its first lines: one line, exit 130."""
    run = subprocess.run([sys.executable, "-c", SIGNAL_WHILE_LOADING, sig], capture_output=True, text=True, timeout=60,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert (run.returncode, run.stderr, run.stdout) == (130, "foam-mj: interrupted\n", "")


def test_python_m_foam_mj_is_the_command_and_the_script_enters_through_it():
    run = subprocess.run([sys.executable, "-m", "foam_mj", "--version"], capture_output=True, text=True, timeout=60,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert run.returncode == 0 and run.stdout.startswith("foam-mj "), run.stderr
    assert 'foam-mj = "foam_mj.__main__:main"' in (ROOT / "pyproject.toml").read_text()


#: A Ctrl-C landing in code run by exec() of a string, as in a dataclass's generated methods while a module loads.
INTERRUPT_IN_EXEC = """
import sys
from foam_mj import cli
def scenes(args):
    exec("raise KeyboardInterrupt")
cli.cmd_scenes = scenes
sys.argv[1:] = ["scenes"]
sys.exit(cli.main())
"""


def test_an_interrupt_inside_exec_of_a_string_ends_the_process_with_130_not_by_sigint(tmp_path):
    """`python -m foam_mj export` interrupted while its modules loaded printed "foam-mj: interrupted", then CPython, which
    had noted the KeyboardInterrupt as unhandled when it left a dataclass's exec'd __init__, killed the process with
    SIGINT after its exit handlers: status -2 in 6 of 14 Ctrl-Cs between 0.8 and 2.1 s, not the documented 130. (Under
    `python -m` only: a script or -c ends through Py_Exit, which does not look at that note.)"""
    (tmp_path / "interrupted_in_exec.py").write_text(INTERRUPT_IN_EXEC)
    run = subprocess.run([sys.executable, "-m", "interrupted_in_exec"], capture_output=True, text=True, timeout=60,
                         env={**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{tmp_path}"})
    assert (run.returncode, run.stderr) == (130, "foam-mj: interrupted\n")


def test_ctrl_c_inside_an_import_is_exit_130_not_an_internal_error(monkeypatch, capsys):
    """Ctrl-C while MuJoCo's C extension initialises surfaces as "ImportError: initialization failed" caused by the
    KeyboardInterrupt: it was reported as an internal error (exit 1; test_recorder's Ctrl-C test failed so under load)."""
    import foam_mj.cli as cli

    def interrupted_import(args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise ImportError("initialization failed") from exc

    monkeypatch.setattr(cli, "cmd_scenes", interrupted_import)
    monkeypatch.delenv("FOAM_MJ_DEBUG", raising=False)
    assert main(["scenes"]) == 130
    assert capsys.readouterr().err.strip() == "foam-mj: interrupted"


@pytest.mark.parametrize("command", [["plan", "--start", "0.2 0.3 0.08", "--goal", "0.45 0.4536 1.45", "--no-rrd"], ["bubble", "--q", "0.2 0.3 0.08"]])
def test_an_mjcf_that_is_a_folder_or_an_empty_name_is_named_as_such(command, tmp_path, capsys):
    """--mjcf /tmp said "MJCF file not found: /tmp"."""
    for value, message in ((str(tmp_path), f"--mjcf: {tmp_path} is a folder, not an MJCF file"), ("", "--mjcf: empty file name")):
        assert main([command[0], "--mjcf", value, *command[1:]]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and message in err, err


@pytest.mark.parametrize("argv", [
    ["bubble", "--scene", "LONG.toml", "--q", "0.2 0.3 0.08"],
    ["bubble", "--mjcf", "LONG.xml", "--q", "0.2 0.3 0.08"],
    ["view", "LONG.rrd"],
    ["sweep", "LONG.toml", "--out", "study"],
    ["report", "LONG"],
    ["verify", "LONG.json"],
    ["replay", "LONG.json"],
])
def test_an_input_name_too_long_for_the_file_system_is_one_line_exit_2(argv, tmp_path, capsys, monkeypatch):
    """Python 3.11's Path.is_file/exists raise OSError (File name too long) where a shorter name is just missing:
    --scene, --mjcf, view, sweep ended as internal errors (exit 1)."""
    monkeypatch.chdir(tmp_path)
    assert main([a.replace("LONG", str(tmp_path / ("y" * 300))) for a in argv]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "internal error" not in err, err


@pytest.mark.parametrize("command", [["verify"], ["replay"], ["export", "--out", "x.csv"], ["figures", "DIR"]])
@pytest.mark.parametrize("content, what", [(b"RRF2\x00\x00\x00\x00rest", "(it is a Rerun recording (.rrd), not JSON)"),
                                           (b"PAR1\x15\x04", "(it is a Parquet table, not JSON)"),
                                           (b"", "(the file is empty)")])
def test_a_recording_or_table_given_as_the_result_is_named_as_what_it_is(command, content, what, tmp_path, capsys, monkeypatch):
    """A .rrd given where the JSON result goes said only "'utf-8' codec can't decode byte 0xcc in position 31"."""
    monkeypatch.chdir(tmp_path)
    given = tmp_path / "result.json"
    given.write_bytes(content)
    argv = [command[0], str(given), *[str(tmp_path / "figs") if a == "DIR" else a for a in command[1:]]]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"{given}: not a readable JSON result {what}" in err and len(err.strip().splitlines()) == 1, err


def test_a_value_that_starts_with_a_minus_sign_is_its_options_value(capsys):
    """README: --start/--goal/--q take numbers separated by spaces or commas. argparse read a comma-separated
    value with a negative first number ('-0.1,0.3,0.08'), or '-1e-3', as an option of its own: 'argument --start:
    expected one argument' (fuzz: --mjcf plans of random arms). The value is the option's; '--' still ends options."""
    args = build_parser().parse_args(["plan", "--mjcf", "r.xml", "--start", "-0.1,0.3,0.08", "--goal", "-.5,0,1"])
    assert (args.start, args.goal) == ("-0.1,0.3,0.08", "-.5,0,1")
    assert main(["bubble", "--scene", "obstacle", "--q", "-0.1,0.3,0.08"]) == 0
    assert "certified radius" in capsys.readouterr().out
    assert main(["plan", "--scene", "obstacle", "--delta", "-1e-3", "--no-rrd"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "foam-mj: error: --delta must be a margin >= 0 in metres, got -0.001"
    assert main(["plan", "--scene", "obstacle", "--no-rrd", "-1"]) == 2  # a flag without a value keeps argparse's message
    assert "unrecognized arguments: -1" in capsys.readouterr().err


def test_a_flag_the_command_does_not_take_is_refused_by_that_command(capsys):
    """`foam-mj replay r.json --no-rrd` (plan's flag; replay writes a recording only with --rrd) said 'foam-mj: error:
    unrecognized arguments: --no-rrd (see foam-mj --help)', a help without replay's flags; the command's parser says it."""
    assert main(["replay", "r.json", "--no-rrd"]) == 2
    assert capsys.readouterr().err == "foam-mj replay: error: unrecognized arguments: --no-rrd (see foam-mj replay --help)\n"
    assert main(["scenes", "extra", "--x"]) == 2
    assert capsys.readouterr().err == "foam-mj scenes: error: unrecognized arguments: extra --x (see foam-mj scenes --help)\n"


@pytest.mark.parametrize("argv, flag, prog", [
    (["plan", "--sce", "obstacle", "--no-rrd"], "--sce obstacle; did you mean --scene?", "foam-mj plan"),
    (["plan", "--scene", "obstacle", "--no-rr"], "--no-rr; did you mean --no-rrd?", "foam-mj plan"),
    (["plan", "--scene", "obstacle", "--no-rrd", "--see", "3"], "--see 3; did you mean --seed?", "foam-mj plan"),
    (["bubble", "--scene", "obstacle", "--q", "0.2 0.3 0.08", "--del", "0.01"], "--del 0.01; did you mean --delta?", "foam-mj bubble"),
    (["sweep", "s.toml", "--out", "o", "--work", "2"], "--work 2; did you mean --workers?", "foam-mj sweep"),
    (["bench", "--run", "1"], "--run 1; did you mean --runs?", "foam-mj bench"),
    (["--vers"], "--vers; did you mean --version?", "foam-mj"),
])
def test_an_abbreviated_flag_is_refused_not_taken_for_the_flag_it_begins(argv, flag, prog, tmp_path, monkeypatch, capsys):
    """argparse took `plan --sce obstacle` for --scene (any unambiguous prefix), so a flag added later could change what
    a command line means, or break it; every parser now takes a flag only as it is named. One line, exit 2, nothing
    written, before any work."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert capsys.readouterr().err == f"{prog}: error: unrecognized arguments: {flag} (see {prog} --help)\n"
    assert list(tmp_path.iterdir()) == []


def test_figures_module_entry_point_refuses_like_the_command(tmp_path, capsys):
    """`python -m foam_mj.figures` built a plain argparse parser: a bad flag printed argparse's usage block and took
    `--dp 10` for --dpi; it now answers as `foam-mj figures` does, one line."""
    from foam_mj.figures import main as figures_main

    assert figures_main([str(tmp_path / "r.json"), str(tmp_path / "out"), "--dp", "10"]) == 2
    assert capsys.readouterr().err == "foam-mj figures: error: unrecognized arguments: --dp 10; did you mean --dpi? (see foam-mj figures --help)\n"


@pytest.mark.parametrize("text, seed", [("7", 7), ("007", 7), ("0x10", 16), ("1_000", 1000), (str(2**63 - 1), 2**63 - 1)])
def test_a_seed_is_read_as_an_integer_in_any_of_pythons_spellings(text, seed):
    """--seed 010 was refused as 'must be an integer' (Python's int(text, 0) takes no leading zero), while 0x10 and
    1_000 were taken: a decimal with leading zeros is now read as decimal."""
    from foam_mj.arguments import seed_number

    assert seed_number(text) == seed


@pytest.mark.parametrize("text, message", [("-1", "must be an integer in [0, 2**63 - 1], got -1"),
                                           (str(2**63), f"must be an integer in [0, 2**63 - 1], got {2**63}"),
                                           ("1e3", "must be an integer, got '1e3'"), ("1.0", "must be an integer, got '1.0'"),
                                           ("", "must be an integer, got ''"), ("nan", "must be an integer, got 'nan'")])
def test_a_bad_seed_is_one_line_naming_the_flag(text, message, capsys):
    assert main(["plan", "--scene", "obstacle", "--no-rrd", "--seed", text]) == 2
    assert capsys.readouterr().err == f"foam-mj plan: error: argument --seed: {message} (see foam-mj plan --help)\n"


FULL_WIDTH = "('\uff11' is U+FF11 FULLWIDTH DIGIT ONE: write numbers with ASCII characters, 0-9)"
ARABIC = "('\u0663' is U+0663 ARABIC-INDIC DIGIT THREE: write numbers with ASCII characters, 0-9)"


@pytest.mark.parametrize("argv, message", [
    (["plan", "--delta", "0.0\uff11"], f"foam-mj plan: error: argument --delta: must be a number, got '0.0\uff11' {FULL_WIDTH}"),
    (["plan", "--time-limit", "\uff11"], f"foam-mj plan: error: argument --time-limit: must be a number, got '\uff11' {FULL_WIDTH}"),
    (["plan", "--seed", "\u0663"], f"foam-mj plan: error: argument --seed: must be an integer, got '\u0663' {ARABIC}"),
    (["plan", "--mjcf", str(MODELS / "obstacle.xml"), "--start", "0.2 0.\u0663 0.08", "--goal", "0.45 0.4536 1.45"],
     f"foam-mj: error: --start must be numbers separated by spaces or commas, got '0.2 0.\u0663 0.08' {ARABIC}"),
    (["bubble", "--scene", "obstacle", "--q", "0.2 0.\u0663 0.08"],
     f"foam-mj: error: --q must be numbers separated by spaces or commas, got '0.2 0.\u0663 0.08' {ARABIC}"),
    (["verify", "--step", "0.0\uff11", "r.json"], f"foam-mj verify: error: argument --step: must be a number, got '0.0\uff11' {FULL_WIDTH}"),
    (["export", "--hz", "\uff1100", "--out", "t.csv", "r.json"], "foam-mj: error: --hz must be a number of samples per second, got '\uff1100'"),
    (["figures", "--dpi", "\uff11", "r.json", "figs"], f"foam-mj figures: error: argument --dpi: must be an integer, got '\uff11' {FULL_WIDTH}"),
    (["view", "--web-port", "\uff11", "r.rrd"], f"foam-mj view: error: argument --web-port: must be a port number, got '\uff11' {FULL_WIDTH}"),
    (["sweep", "--workers", "\uff11", "--out", "o", "s.toml"], f"foam-mj sweep: error: argument --workers: must be an integer, got '\uff11' {FULL_WIDTH}"),
    (["bench", "--runs", "\uff11"], f"foam-mj bench: error: argument --runs: must be an integer, got '\uff11' {FULL_WIDTH}"),
    (["plan", "--delta", "0_005"], "foam-mj plan: error: argument --delta: must be a number, got '0_005'"),
])
def test_a_number_is_written_in_ascii_digits(argv, message, tmp_path, monkeypatch, capsys):
    """Python's float() and int() read any script's digits: `--seed \u0663` planned with seed 3 and `--time-limit \uff11`
    with 1 s, though no scenario TOML, result JSON or sweep file may spell a number so. A number on the command line is
    now ASCII too, refused with the character named; and `--delta 0_005` (float() reads 5.0: a 5 m margin) is refused
    as `--start 0_08` already was."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(message) and len(err.splitlines()) == 1, err
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("argv, option, values", [
    (["figures", "--paths", "optimal", "r.json", "figs"], "--paths", "optimal, r.json, figs"),
    (["report", "--axes", "subject.height", "planner.delta", "out"], "--axes", "subject.height, planner.delta, out"),
])
def test_an_option_of_several_values_that_took_the_positionals_is_named(argv, option, values, tmp_path, monkeypatch, capsys):
    """`foam-mj figures --paths optimal r.json figs` said only 'the following arguments are required: RESULT.json, DIR',
    though both were given: --paths took them as path names. The error now says which option took which values."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"; {option} took every value after it ({values}): give the positional arguments before {option}, or end its values with --" in err
    assert len(err.splitlines()) == 1 and os.listdir(tmp_path) == []


def test_a_file_name_with_control_characters_is_named_with_escapes(tmp_path, monkeypatch, capsys):
    """A name holding ESC or DEL was printed as it is: `foam-mj verify $'a\\x1b[31mb.json'` turned the terminal red and
    named a file the user could not see. The error names it with escapes, on one line."""
    monkeypatch.chdir(tmp_path)
    assert main(["verify", "a\x1b[31mb\x7f.json"]) == 2
    err = capsys.readouterr().err
    assert err == "foam-mj: error: result file not found: a\\x1b[31mb\\x7f.json\n"


def test_an_option_before_the_command_that_foam_mj_does_not_take_is_named(capsys):
    """`foam-mj --bogus` said only 'the following arguments are required: COMMAND': the unknown option is named, on
    one line, exit 2, with or without a command after it."""
    for argv in (["--bogus"], ["--bogus", "plan"]):
        assert main(argv) == 2
        assert capsys.readouterr().err == "foam-mj: error: unrecognized arguments: --bogus (see foam-mj --help)\n"
    assert main([]) == 2
    assert "required: COMMAND" in capsys.readouterr().err


def test_a_configuration_may_be_given_unquoted():
    """`--start 0.2 -0.3 0.08` (no quotes, as a user types numbers) said 'unrecognized arguments: -0.3 0.08'. The
    numbers after --start/--goal/--q are one configuration, quoted or not; a word after them still ends it."""
    args = build_parser().parse_args(["plan", "--mjcf", "r.xml", "--start", "0.2", "-0.3", "1e-3", "--goal", "-.5,0", "1"])
    assert (args.start, args.goal) == ("0.2 -0.3 1e-3", "-.5,0 1")
    args = build_parser().parse_args(["bubble", "--scene", "obstacle", "--q", "-0.1", "0.3", "0.08"])
    assert args.q == "-0.1 0.3 0.08"
    assert build_parser().parse_args(["plan", "--mjcf", "r.xml", "--start", "home", "--goal", "0", "1"]).start == "home"
    with pytest.raises(UsageError, match="unrecognized arguments: x"):
        build_parser().parse_args(["plan", "--mjcf", "r.xml", "--start", "0.2", "0.3", "x", "--goal", "0 1"])


def test_a_file_that_is_no_mjcf_is_one_line(tmp_path, capsys):
    """`--mjcf notes` (a file with no .xml suffix) printed MuJoCo's 'Must provide extension or content_type to
    mjp_findDecoder' warning as a line of its own above the error: a failed load's warnings are dropped."""
    notes = tmp_path / "notes"
    notes.write_text("not a model\n")
    assert main(["plan", "--mjcf", str(notes), "--start", "0", "--goal", "1", "--no-rrd"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "could not load MJCF file" in err, err


@pytest.mark.skipif(os.geteuid() == 0 and shutil.which("setpriv") is None, reason="root reads any file: needs setpriv to run as nobody")
def test_an_mjcf_the_user_may_not_read_is_named_unreadable_not_empty():
    """An MJCF without read permission was "could not load MJCF file x.xml: ParseXML: empty file" (MuJoCo's words) in
    plan and bubble, and "could not load" in verify. Each now says it cannot be read, and why."""
    from conftest import TWO_LINK_ARM

    folder = Path(tempfile.mkdtemp(prefix="foam-unreadable-"))  # not under pytest's tmp_path, which only root may enter
    try:
        folder.chmod(0o755)
        arm = folder / "arm.xml"
        arm.write_text(TWO_LINK_ARM.read_text())
        arm.chmod(0)
        result = folder / "r.json"
        result.write_text(json.dumps({"format": "foam-mj/result", "version": 1, "mjcf": str(arm), "planner": {"delta": 0.005}, "paths": {}}))
        result.chmod(0o644)
        as_user = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"] if os.geteuid() == 0 else []
        for argv, message in (
            (["bubble", "--mjcf", str(arm), "--q", "0.3 2"], f"MJCF file {arm}: cannot read: Permission denied"),
            (["plan", "--mjcf", str(arm), "--start", "0.3 2", "--goal", "0.1 0.6", "--no-rrd"], f"--mjcf: MJCF file {arm}: cannot read: Permission denied"),
            (["verify", str(result)], f"field 'mjcf': cannot read {arm}: Permission denied"),
        ):
            run = subprocess.run([*as_user, sys.executable, "-m", "foam_mj.cli", *argv], capture_output=True, text=True, timeout=120,
                                 cwd=folder, env={**os.environ, "PYTHONPATH": str(ROOT), "HOME": str(folder)})
            assert run.returncode == 2 and len(run.stderr.splitlines()) == 1 and message in run.stderr, (argv, run.stderr)
    finally:
        shutil.rmtree(folder)


@pytest.mark.parametrize("argv, message", [
    (["replay", "{json}"], "{json}: not a readable JSON result: nested too deeply to read"),
    (["verify", "{json}"], "{json}: not a readable JSON result: nested too deeply to read"),
    (["export", "{json}", "--out", "{dir}/t.csv"], "{json}: not a readable JSON result: nested too deeply to read"),
    (["figures", "{json}", "{dir}/figs"], "{json}: not a readable JSON result: nested too deeply to read"),
    (["plan", "--scene", "{toml}", "--no-rrd"], "{toml}: malformed TOML: nested too deeply to read"),
    (["bubble", "--scene", "{toml}", "--q", "0 0 0"], "{toml}: malformed TOML: nested too deeply to read"),
    (["sweep", "{toml}", "--out", "{dir}/out"], "{toml}: malformed TOML: nested too deeply to read"),
    (["report", "{dir}"], "{dir}/sweep.json: unreadable sweep manifest: nested too deeply to read"),
])
def test_a_file_nested_too_deeply_to_parse_is_bad_input_not_an_internal_error(argv, message, tmp_path, capsys):
    """Arrays nested 100,000 deep in a result, scenario, sweep file or sweep manifest were an internal error (exit 1:
    RecursionError from Python's JSON or TOML parser) in every command that reads one."""
    deep = "[" * 100_000 + "]" * 100_000
    (tmp_path / "r.json").write_text(deep)
    (tmp_path / "sweep.json").write_text(deep)
    (tmp_path / "s.toml").write_text("a = " + deep)
    names = {"json": str(tmp_path / "r.json"), "toml": str(tmp_path / "s.toml"), "dir": str(tmp_path)}
    assert main([a.format(**names) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "foam-mj: error: " + message.format(**names)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "s.toml", "sweep.json"]


@pytest.mark.parametrize(("edit", "commands", "message"), [
    (lambda d: d["robot"].update(self_collision={"a": 1}), ("replay", "export"), "field 'robot.self_collision' must be true or false, got {'a': 1}"),
    (lambda d: d["robot"].update(robot_root=5), ("replay", "export"), "field 'robot.robot_root' must be a body name or null, got 5"),
    (lambda d: d["paths"]["centre"]["qpos"][0].__setitem__(1, [[]]), ("figures",), "path 'centre': field 'qpos' must be numbers (a list, or rows of equal length)"),
    (lambda d: d["paths"]["centre"].update(times=2**70), ("figures",), "path 'centre': field 'times' must be a list of"),
])
def test_a_result_field_of_the_wrong_type_found_by_fuzzing_is_named(planned_result, tmp_path, edit, commands, message, capsys):
    """Found by mutating a plan --json result at random (notes): each was an internal error, exit 1 (TypeError
    "`self_collision` must be True or False" from deep in the model; ValueError "inhomogeneous shape" for a ragged qpos
    row; TypeError "len() of unsized object" for times that are a number)."""
    bad = _edited(planned_result, planned_result.parent, edit)
    try:  # beside the result: its mjcf_relative still resolves
        argv = {"replay": ["replay", str(bad), "--kinematic-only", "--rrd", str(tmp_path / "r.rrd")],
                "export": ["export", str(bad), "--out", str(tmp_path / "t.csv")], "figures": ["figures", str(bad), str(tmp_path / "figs")]}
        for command in commands:
            assert main(argv[command]) == 2, command
            err = capsys.readouterr().err.strip()
            assert len(err.splitlines()) == 1 and message in err, (command, err)
        assert list(tmp_path.iterdir()) == []
    finally:
        bad.unlink()


def test_an_output_suffix_in_capitals_is_the_same_suffix(tmp_path, capsys):
    """`plan --json X.JSON` was refused ('must end in .json') and `--rrd X.RRD` likewise: a file system's names are
    case-sensitive, but a suffix is a format's name, and Rerun's viewer picks its loader by the lower-cased suffix. Both
    are written, read back by verify, and `view` takes the recording as one."""
    result, rec = tmp_path / "X.JSON", tmp_path / "Rec.RRD"
    assert main(["plan", "--scene", "obstacle", "--json", str(result), "--rrd", str(rec)]) == 0
    capsys.readouterr()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["Rec.RRD", "X.JSON"]
    assert main(["verify", str(result), "--step", "0.05"]) == 0
    assert main(["view", str(rec), "--bind", "nonsense"]) == 2  # past the recording's checks: the address is refused
    assert capsys.readouterr().err.strip().endswith("--bind must be an IP address (127.0.0.1, 0.0.0.0, ::1), got 'nonsense'")
    assert main(["replay", str(result), "--kinematic-only", "--rrd", str(tmp_path / "again.Rrd")]) == 0
    assert (tmp_path / "again.Rrd").stat().st_size > 0


def test_a_file_name_that_starts_with_a_minus_sign_is_its_options_value(planned_result, tmp_path, monkeypatch, capsys):
    """`foam-mj export r.json --out -.csv` said 'argument --out: expected one argument': argparse took the file name for
    an option. A value of a file or folder option (--out, --json, --rrd, --figures, --scene, --mjcf) that starts with a
    single minus sign and is no flag of the command is the option's value; a flag (--out --format) still is not."""
    monkeypatch.chdir(tmp_path)
    assert main(["export", str(planned_result), "--out", "-.csv"]) == 0
    assert main(["export", str(planned_result), "--out", "-x.npz", "--hz", "100"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["-.csv", "-x.npz"]
    assert (tmp_path / "-.csv").read_text().startswith('# {"format":"foam-mj/trajectory"')
    capsys.readouterr()
    assert main(["export", str(planned_result), "--out", "--hz", "100"]) == 2
    assert "argument --out: expected one argument" in capsys.readouterr().err
    assert main(["plan", "--scene", "-missing.toml", "--no-rrd"]) == 2
    assert "-missing.toml" in capsys.readouterr().err


def test_a_result_that_starts_with_a_byte_order_mark_is_read_by_every_command(planned_result, tmp_path, capsys):
    """A result saved by an editor that writes a UTF-8 byte-order mark got Python's own words in every command that reads
    results ('Unexpected UTF-8 BOM (decode using utf-8-sig)', exit 2): the mark is not part of the JSON (RFC 8259 lets a
    reader ignore it), so verify, replay, export and figures read the result as if it were not there."""
    bom = tmp_path / "bom.json"
    bom.write_bytes(b"\xef\xbb\xbf" + planned_result.read_bytes())
    assert main(["verify", str(bom), "--step", "0.05"]) == 0
    assert main(["replay", str(bom), "--kinematic-only"]) == 0
    assert main(["export", str(bom), "--out", str(tmp_path / "t.csv")]) == 0
    assert main(["figures", str(bom), str(tmp_path / "figs"), "--paths", "optimal"]) == 0
    assert "BOM" not in capsys.readouterr().err
    assert (tmp_path / "t.csv").stat().st_size > 0 and any((tmp_path / "figs").iterdir())


@pytest.mark.parametrize(("edit", "words"), [
    (lambda p: p["qpos"][40].__setitem__(1, p["qpos"][40][1] + 0.05),
     "path 'optimal': qpos row 40 (t = 0.08 s) is not the trajectory its waypoints give (hip_flexion differs by 0.05)"),
    (lambda p: p.update(qpos=p["qpos"][:-3], times=p["times"][:-3]),
     "path 'optimal': 'qpos' has 471 rows, the trajectory its waypoints give 474"),
    (lambda p: p["times"].__setitem__(10, p["times"][10] + 0.001),
     "path 'optimal': times row 10 (t = 0.02 s) is not the trajectory its waypoints give (it differs by 0.001 s)"),
    (lambda p: p["times"].__setitem__(3, float("nan")), "path 'optimal': times row 3 (t = 0.006 s) is not the trajectory its "
     "waypoints give (its time is nan): replay and export rebuild it from the waypoints under the result's 'limits' and 'time_law'"),
])
def test_a_result_whose_saved_trajectory_was_edited_is_refused_by_replay_and_export(planned_result, tmp_path, edit, words, capsys):
    """replay and export rebuild each trajectory from the path's waypoints, as plan made it; verify checks the saved
    'qpos' rows. A user who edited qpos (or times) got a replay and an export of another motion than the one verify
    had passed, without a word. Both now refuse a saved trajectory that is not the one its waypoints give, naming the
    path and the row: one line, exit 2, nothing written."""
    bad = _edited(planned_result, planned_result.parent, lambda d: edit(d["paths"]["optimal"]))
    try:
        for argv in (["replay", str(bad), "--kinematic-only", "--rrd", str(tmp_path / "r.rrd")],
                     ["export", str(bad), "--out", str(tmp_path / "t.csv")]):
            _refused(argv, words, capsys)
        assert list(tmp_path.iterdir()) == []
    finally:
        bad.unlink()


@pytest.mark.parametrize("bom, words", [(b"\xff\xfe", "UTF-16 (little-endian)"), (b"\xfe\xff", "UTF-16 (big-endian)")])
def test_a_file_saved_as_utf16_is_named_as_such_by_every_reader(planned_result, tmp_path, bom, words, capsys):
    """A scenario, sweep file or result saved as UTF-16 (Windows editors' 'Unicode') got Python's words: "cannot read:
    'utf-8' codec can't decode byte 0xff in position 0: invalid start byte". It is now named: one line, exit 2."""
    enc = "utf-16-le" if bom == b"\xff\xfe" else "utf-16-be"
    files = {"scenario": tmp_path / "s.toml", "sweep": tmp_path / "w.toml", "result": tmp_path / "r.json"}
    files["scenario"].write_bytes(bom + (ROOT / "scenarios" / "obstacle.toml").read_text().encode(enc))
    files["sweep"].write_bytes(bom + 'scenario = "obstacle"\nseeds = 1\n'.encode(enc))
    files["result"].write_bytes(bom + planned_result.read_text().encode(enc))
    expected = f"is UTF-16 text ({words.split('(')[1]}; save it as UTF-8"
    for argv in (["plan", "--scene", str(files["scenario"]), "--no-rrd"], ["sweep", str(files["sweep"]), "--out", str(tmp_path / "o")],
                 ["verify", str(files["result"])], ["replay", str(files["result"])], ["export", str(files["result"]), "--out", str(tmp_path / "t.csv")]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and expected in err and "codec" not in err, (argv, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "s.toml", "w.toml"]


def test_replay_names_the_file_and_field_of_an_unknown_planner(planned_result, tmp_path, capsys):
    """replay of a result whose planner.algorithm is unknown said "unknown planner 'nope'; known planners: ...", naming
    neither the file nor the field (export and figures do not need the planner and go on)."""
    bad = _edited(planned_result, tmp_path, lambda d: d["planner"].update(algorithm="nope"))
    assert main(["replay", str(bad), "--kinematic-only"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"foam-mj: error: {bad}: field 'planner': unknown planner 'nope'; known planners: ") and len(err.splitlines()) == 1


@pytest.mark.parametrize("argv, hint", [
    (["plna"], "; did you mean plan? (see foam-mj --help)"),
    (["plan", "--sceen", "obstacle"], "unrecognized arguments: --sceen obstacle; did you mean --scene? (see foam-mj plan --help)"),
    (["export", "r.json", "--out", "t.csv", "--formt=csv"], "; did you mean --format? (see foam-mj export --help)"),
    (["plan", "--xyz"], "unrecognized arguments: --xyz (see foam-mj plan --help)"),
])
def test_a_mistyped_command_or_option_is_answered_with_the_nearest_name(argv, hint, capsys):
    """`foam-mj plna` listed the eleven commands and `plan --sceen obstacle` said only 'unrecognized arguments', where
    a mistyped scenario, planner or smoother name gets 'did you mean'. Nothing near: no guess."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.rstrip().endswith(hint), err


def _missing_extra_cases(d: Path) -> dict[str, tuple[tuple[str, ...], list[str], str, list[Path]]]:
    """name: (modules made unimportable, argv, the extra the error must name, paths that must not appear)."""
    import trimesh

    trimesh.creation.box(extents=[0.3, 0.5, 0.1]).export(d / "kerb.stl")
    kerb = d / "kerb.toml"
    kerb.write_text(f'scene = "{MODELS / "step_up.xml"}"\n{GOOD}[[mesh]]\nfile = "kerb.stl"\npos = [1.5, 0.0, 0.05]\n'
                    "decompose = true\n")
    sweep = d / "sweep.toml"
    sweep.write_text('scenario = "obstacle"\n[grid]\n"planner.delta" = [0.005]\n')
    return {
        "meshes": (("coacd",), ["plan", "--scene", str(kerb), "--rrd", str(d / "k.rrd"), "--json", str(d / "k.json")],
                   "meshes", [d / "k.rrd", d / "k.json"]),
        "cluster": (("ray",), ["sweep", str(sweep), "--out", str(d / "study"), "--ray"], "cluster", [d / "study"]),
        "sweep": (("pyarrow", "pyarrow.parquet"), ["sweep", str(sweep), "--out", str(d / "study")], "sweep", [d / "study"]),
        "export": (("pyarrow", "pyarrow.parquet"), ["export", str(d / "r.json"), "--format", "parquet", "--out", str(d / "t.parquet")],
                   "export", [d / "t.parquet"]),
        "figures": (("matplotlib",), ["plan", "--scene", "step_up", "--no-rrd", "--figures", str(d / "figs")], "figures",
                    [d / "figs"]),
    }


@pytest.mark.parametrize("case", ["meshes", "cluster", "sweep", "export", "figures"])
def test_a_missing_optional_extra_is_one_line_naming_it_exit_2_and_nothing_written(tmp_path, case):
    """A user who installed foam-mj without an optional extra and runs the command that needs it gets one line on
    stderr that names the extra to install (pip install 'foam-mj[EXTRA]'), exit 2, no traceback, and no output
    file or folder; the extra's package is made unimportable in a fresh interpreter, as on an install without it."""
    blocked, argv, extra, outputs = _missing_extra_cases(tmp_path)[case]
    code = ("import sys\n"
            f"for m in {blocked!r}:\n"
            "    sys.modules[m] = None\n"
            "from foam_mj.cli import main\n"
            f"sys.exit(main({argv!r}))\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert run.returncode == 2, (run.returncode, run.stderr)
    lines = run.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("foam-mj: error: "), run.stderr
    assert f"pip install 'foam-mj[{extra}]'" in lines[0], lines[0]
    assert [p for p in outputs if p.exists()] == []
