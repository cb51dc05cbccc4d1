"""Studies: `foam-mj sweep` writes one plain row per (parameters, seed, smoother) to Parquet, loses nothing
when killed, gives the same rows locally and on Ray; `foam-mj report` draws the envelope."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from itertools import product
from pathlib import Path

import numpy as np
import pytest

pa = pytest.importorskip("pyarrow")
import pyarrow.parquet as pq  # noqa: E402

from foam_mj.cli import main  # noqa: E402
from foam_mj.sweep import TIMING_COLUMNS, SweepError, row_key  # noqa: E402
from foam_mj.sweep_file import load_sweep  # noqa: E402
from foam_mj.sweep_run import read_rows, run_sweep  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SIZES = [[0.2, 0.5, 0.10], [0.2, 0.5, 0.15]]  # the box: full extents x (walking direction), y, z
STUDY = f"""
scenario = "obstacle"
seeds = [1, 2, 3]
smoothers = "convex"
[grid]
"planner.delta" = [0.005, 0.01]
"obstacle.size" = {json.dumps(SIZES)}
"""


def write(folder: Path, text: str, name: str = "sweep.toml") -> Path:
    p = folder / name
    p.write_text(text)
    return p


def _stored_rows(spec: Path, row) -> Path:
    """A study's rows written straight to an --out folder beside ``spec`` ("out"), without planning: ``row(task, key,
    path)`` gives each (parameters, seed, smoother) row, as a sweep would store it."""
    from foam_mj.sweep_run import RowStore

    sweep = load_sweep(spec)
    out = spec.parent / "out"
    store = RowStore(out, sweep, batch=16)
    store.open(sweep)
    for task in sweep.tasks():
        store.add([row(task, k, path) for k, path in zip(task.keys, task.paths)])
    store.flush()
    store.close()
    return out


def deterministic(rows: list[dict]) -> list[dict]:
    """Rows without their timings, sorted by key."""
    return sorted(({k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows), key=lambda r: r["key"])


def _default_sigint() -> None:
    """Let the child see Ctrl-C even when this test runs in a background job (which inherits SIGINT ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def cli(*args: str, **kw) -> subprocess.Popen:
    """`foam-mj ...` in a subprocess (its own process group, so that we can signal all of it), this checkout first."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen(
        [sys.executable, "-m", "foam_mj.cli", *args], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=_default_sigint, **kw
    )


def wait_for_files(rows: Path, n: int, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    t0 = time.monotonic()
    while len(list(rows.glob("*.parquet"))) < n:
        assert proc.poll() is None, f"the sweep ended before {n} files: {proc.communicate()}"
        assert time.monotonic() - t0 < timeout
        time.sleep(0.02)


def check_folder(out: Path) -> list[dict]:
    """Every Parquet file readable, no duplicate key; the rows."""
    files = sorted((out / "rows").glob("*.parquet"))
    rows = [r for f in files for r in pq.read_table(f).to_pylist()]
    keys = [r["key"] for r in rows]
    assert len(keys) == len(set(keys)), "duplicate row keys"
    return rows


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """The 2 x 2 x 3-seed study (convex smoother, dynamic replay) run by the CLI on 2 local workers."""
    folder = tmp_path_factory.mktemp("sweep")
    spec = write(folder, STUDY)
    out = folder / "study"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "2", "--quiet"]) == 0
    return {"spec": spec, "out": out, "rows": read_rows(out).to_pylist(), "table": read_rows(out)}


def test_a_2x2x3_sweep_writes_12_rows_per_smoother_as_plain_columns(study):
    rows, table = study["rows"], study["table"]
    for smoother in ("centre", "convex"):
        mine = [r for r in rows if r["smoother"] == smoother]
        assert len(mine) == 12
        combos = {(r["planner.delta"], r["obstacle.size"], r["seed"]) for r in mine}
        assert combos == {(d, json.dumps(g), s) for d, g, s in product([0.005, 0.01], SIZES, [1, 2, 3])}
    assert len({r["key"] for r in rows}) == 24
    for r in rows:
        assert r["key"] == row_key((("planner.delta", r["planner.delta"]), ("obstacle.size", json.loads(r["obstacle.size"]))), r["seed"], r["smoother"])
    # plain columns: numbers, strings, booleans (DuckDB and pandas read them as they are)
    assert all(pa.types.is_primitive(f.type) or pa.types.is_string(f.type) for f in table.schema)
    for col in ("planner.delta", "obstacle.size", "seed", "smoother", "outcome", "reason", "plan_time", "task_time", "bubbles",
                "length", "f", "min_clearance", "certified", "peak_torque_knee_flexion"):
        assert col in table.column_names
    # every plan reached, every replay kept the row's own margin, and the torques were measured
    for r in rows:
        assert r["outcome"] == "reached" and r["reason"] is None
        assert r["min_clearance"] >= r["planner.delta"] - 1e-9
        assert r["contacts"] == 0 and r["peak_torque_knee_flexion"] > 0 and r["bubbles"] > r["rosary"] > 1
        assert r["f"] >= r["length"] > 0
    # one plan, two paths: the convex path is never longer than the centre path of the same plan
    by = {(r["planner.delta"], r["obstacle.size"], r["seed"], r["smoother"]): r for r in rows}
    for (d, g, s, smoother), r in by.items():
        if smoother == "convex":
            assert r["length"] <= by[(d, g, s, "centre")]["length"] + 1e-9
            assert r["bubbles"] == by[(d, g, s, "centre")]["bubbles"]


def test_a_rerun_skips_the_rows_already_there(study, capsys):
    assert main(["sweep", str(study["spec"]), "--out", str(study["out"]), "--quiet"]) == 0
    assert "12 plans in all, 12 already done, 0 run now" in capsys.readouterr().out
    assert deterministic(check_folder(study["out"])) == deterministic(study["rows"])



def _starting_workers(pid: int) -> list[int]:
    """``pid``'s children started by multiprocessing's spawn (a local pool's workers) that catch SIGINT (Python's
    handler, installed as the interpreter starts) and do not yet ignore it (:func:`_worker_init`): workers still
    importing what they run (Linux's /proc/PID/status signal masks)."""
    found = []
    bit = 1 << (signal.SIGINT - 1)
    for child in Path(f"/proc/{pid}/task/{pid}/children").read_text().split():
        try:
            if b"spawn_main" not in Path(f"/proc/{child}/cmdline").read_bytes():  # not the resource tracker
                continue
            masks = {k: int(v, 16) for k, v in (line.split(":\t") for line in Path(f"/proc/{child}/status").read_text().splitlines()
                                               if line.startswith(("SigCgt", "SigIgn")))}
        except (OSError, ValueError):  # ended meanwhile
            continue
        if masks["SigCgt"] & bit and not masks["SigIgn"] & bit:
            found.append(int(child))
    return found


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="reads a process's children from Linux's /proc")
def test_a_worker_ignores_ctrl_c_from_its_start(tmp_path):
    """Ctrl-C reaches the whole process group, the pool's workers too; the sweep handles it (writes its rows, exit 130).
    A worker ignores it once it runs (_worker_init), but a spawned worker first spends 0.5-5 s (under load) importing
    foam_mj, numpy and MuJoCo with Python's default handler (or, started by the `foam-mj` script, foam_mj.__main__'s):
    a Ctrl-C then printed the worker's KeyboardInterrupt traceback (or a second "foam-mj: interrupted") above the
    sweep's own line: 3 of 12 trials at random delays of 0.5-6 s, when the sweep had not ended the worker first.
    A worker now holds SIGINT blocked from its start until it ignores it: SIGINT sent to a worker while it imports
    is dropped, and the sweep runs to its end."""
    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = 1\nsmoothers = "none"\nreplay = "none"\n')
    proc = cli("sweep", str(spec), "--out", str(tmp_path / "out"), "--workers", "1", "--quiet")
    t0 = time.monotonic()
    while not (starting := _starting_workers(proc.pid)):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() - t0 < 60
        time.sleep(0.002)
    os.kill(starting[0], signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0 and err == "" and "1 run now" in out, (out, err)

@pytest.mark.slow
def test_ctrl_c_then_a_kill_midway_then_a_rerun_give_the_same_rows(study, tmp_path):
    out = tmp_path / "study"
    args = ("sweep", str(study["spec"]), "--out", str(out), "--workers", "2", "--batch", "1")
    # Ctrl-C (SIGINT to the whole process group, as a terminal does): completed rows written, exit 130
    proc = cli(*args)
    wait_for_files(out / "rows", 1, proc)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    first = check_folder(out)
    # a real kill (SIGKILL to the sweep and its workers) midway through the rest
    proc = cli(*args)
    wait_for_files(out / "rows", len(list((out / "rows").glob("*.parquet"))) + 1, proc)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=60)
    second = check_folder(out)
    assert len(first) <= len(second) < 24, "killed midway"
    duckdb = pytest.importorskip("duckdb")  # a batch cut short leaves nothing a reader's glob picks up
    assert duckdb.sql(f"SELECT count(*) FROM '{out}/rows/*.parquet'").fetchall() == [(len(second),)]
    assert all(len([r for r in second if r["seed"] == s and r["obstacle.size"] == g and r["planner.delta"] == d]) in (0, 2)
               for s, g, d in product([1, 2, 3], map(json.dumps, SIZES), [0.005, 0.01])), "a plan's rows are written together"
    # the re-run runs only what is missing; progress lines on a non-terminal stderr
    proc = cli(*args, "--progress-interval", "0.2")
    stdout, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert f"{len(second) // 2} already done" in stdout
    assert re.search(r"sweep: \d+/12 plans, 0 not reached, [\d.]+ plans/s, ETA", err)
    assert deterministic(check_folder(out)) == deterministic(study["rows"])
    assert not list((out / "rows").glob(".*"))  # no temporary file left behind after a clean run


@pytest.mark.slow
def test_a_worker_that_dies_loses_no_row(tmp_path):
    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = 5\nsmoothers = "none"\nreplay = "none"\n[grid]\n"planner.delta" = [0.005, 0.01]\n')
    out = tmp_path / "out"
    proc = cli("sweep", str(spec), "--out", str(out), "--workers", "2", "--batch", "1")
    wait_for_files(out / "rows", 1, proc)
    workers = []
    for child in Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split():
        if "spawn_main" in Path(f"/proc/{child}/cmdline").read_text():
            workers.append(int(child))
    assert workers
    os.kill(workers[0], signal.SIGKILL)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    rows = check_folder(out)
    assert len(rows) == 10 and all(r["outcome"] == "reached" for r in rows)
    if "a worker died" not in err:  # the worker was idle at the end: nothing to resend, still nothing lost
        pytest.skip("the killed worker had finished its tasks")


@pytest.mark.slow
def test_the_workers_end_when_the_sweep_is_killed_alone(tmp_path):
    """`kill -9 PID` of the sweep alone (or the out-of-memory killer) left its pool workers waiting on the task queue
    forever, each holding its MuJoCo models; they now end with the process that started them."""
    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = 40\nsmoothers = "none"\nreplay = "none"\n')
    out = tmp_path / "out"
    proc = cli("sweep", str(spec), "--out", str(out), "--workers", "2", "--batch", "1")
    wait_for_files(out / "rows", 1, proc)
    children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split()
    workers = [int(c) for c in children if "spawn_main" in Path(f"/proc/{c}/cmdline").read_text()]
    assert len(workers) == min(2, len(os.sched_getaffinity(0)))  # --workers is capped at the cores
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=60)  # not communicate: workers left alive would hold its pipes open

    def alive() -> list[int]:
        return [w for w in workers if Path(f"/proc/{w}").exists() and "spawn_main" in Path(f"/proc/{w}/cmdline").read_text()]

    t0 = time.monotonic()
    while alive() and time.monotonic() - t0 < 30:
        time.sleep(0.1)
    left = alive()
    for w in left:  # ours: not left behind when the test fails
        os.kill(w, signal.SIGKILL)
    assert not left, "the workers outlived the killed sweep by 30 s"
    check_folder(out)


@pytest.mark.slow
def test_ray_gives_the_same_rows_as_local(study, tmp_path):
    pytest.importorskip("ray")
    # a slice of the study (same keys, so the same row keys), as Ray tasks on a local Ray instance
    spec = write(tmp_path, STUDY.replace("seeds = [1, 2, 3]", "seeds = [2]").replace('[0.005, 0.01]', '[0.01]'))
    out = tmp_path / "ray"
    proc = cli("sweep", str(spec), "--out", str(out), "--ray", "--workers", "2", "--quiet")
    stdout, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    assert "on Ray (local)" in stdout
    ray_rows = deterministic(check_folder(out))
    assert len(ray_rows) == 4
    local = {r["key"]: r for r in deterministic(study["rows"])}
    assert ray_rows == [local[r["key"]] for r in ray_rows]


@pytest.mark.parametrize(
    "table, named",
    [
        ('"planner.dleta" = [0.01]', ["planner.dleta", "dleta"]),
        ('"planner.delta" = [0.005, -1.0]', ["'planner.delta' = -1.0", "delta"]),
        ('"obstacel.size" = [[0.5, 0.2, 0.1]]', ["obstacel.size", "obstacel"]),
        ('"q_goal" = [[0.45, 0.4536, 1.45], [0.45, 0.4536, 9.0]]', ["'q_goal' = [0.45, 0.4536, 9.0]", "bound"]),
        ('"q_goal" = [[0.45, 0.4536, 1.45, 2.0]]', ["'q_goal'"]),
        ('"planner.K" = [10, "ten"]', ["'planner.K' mixes"]),
        ('"seed" = [1, 2]', ["'seed' cannot be swept", "seeds"]),
        ('"planner.delta" = []', ["'planner.delta' must be a non-empty list"]),
    ],
)
def test_a_bad_key_or_value_is_exit_2_before_any_work_naming_it(tmp_path, capsys, table, named):
    spec = write(tmp_path, f'scenario = "obstacle"\nseeds = 2\n[grid]\n{table}\n')
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and err.startswith("foam-mj: error:")
    for piece in named:
        assert piece in err
    assert not out.exists()


def test_an_obstacle_moved_onto_the_goal_gives_invalid_rows_not_a_refused_sweep(tmp_path, capsys):
    """A swept box position that puts q_goal in collision is a data point of the study (no path there), not a
    bad value: its rows say 'invalid' and name the goal's clearance; the other positions are planned. The last line
    counts it as not reached (it said "1 failed" / "with a row not reached", while the report's `failed` column,
    a plan that did not reach, read 0)."""
    spec = write(tmp_path, 'scenario = "obstacle"\nsmoothers = "none"\nreplay = "none"\n'
                           '[grid]\n"obstacle.pos" = [[0.5, 0.0, 0.075], [0.9, 0.0, 0.1]]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    assert "2 plans in all, 0 already done, 2 run now (1 not reached), 2 rows" in capsys.readouterr().out
    rows = {r["obstacle.pos"]: r for r in read_rows(out).to_pylist()}
    assert rows["[0.5, 0.0, 0.075]"]["outcome"] == "reached"
    bad = rows["[0.9, 0.0, 0.1]"]
    assert bad["outcome"] == "invalid" and "'q_goal'" in bad["reason"] and "in collision" in bad["reason"]


def test_an_invalid_row_of_a_built_in_scenario_names_it_not_where_it_is_installed(tmp_path):
    """The reason began with this install's path ('/.../scenarios/obstacle.toml: field 'q_goal' ...'), so the same row
    differed between two installs (a cluster's nodes, two checkouts); it names the built-in scenario's file alone."""
    from foam_mj.data import scenarios_dir
    from foam_mj.sweep import run_task

    spec = write(tmp_path, 'scenario = "obstacle"\nsmoothers = "none"\nreplay = "none"\n[grid]\n"obstacle.pos" = [[0.9, 0.0, 0.1]]\n')
    (task,) = load_sweep(spec).tasks()
    (row,) = run_task(task)
    assert row["outcome"] == "invalid" and row["reason"].startswith("obstacle.toml: field 'q_goal'"), row["reason"]
    assert str(scenarios_dir()) not in row["reason"]


def test_a_failed_plan_gives_the_same_reason_on_every_run(tmp_path):
    """A failed row's reason held the planner's wall time ("... after 715 bubbles in 0.17 s"), so the same row
    differed between runs and engines in a column that is not a timing column; the time is in plan_time."""
    from foam_mj.sweep import run_task

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = [1]\nsmoothers = "none"\nreplay = "none"\n[grid]\n'
                           '"obstacle.size" = [[0.2, 0.5, 0.6]]\n"subject.height" = [1.55]\n"planner.delta" = [0.02]\n')
    (task,) = load_sweep(spec).tasks()
    first, second = run_task(task), run_task(task)
    assert [r["outcome"] for r in first] == ["failed"] and first[0]["plan_time"] > 0
    assert first[0]["reason"].startswith("queue empty: the foam did not reach q_goal (queue empty) after 715 bubbles: it came nearest")
    assert deterministic(first) == deterministic(second)


def test_a_path_that_no_timing_fits_fails_its_row_alone(tmp_path):
    """A 52 N m hip limit fits obstacle's convex path but not its centre path: the whole task's rows said 'failed'
    (the pipeline raised on the first untimed path). Now only the centre row fails, with the timing's reason."""
    from foam_mj.sweep import run_task

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = [0]\nsmoothers = "convex"\nreplay = "kinematic"\n[grid]\n'
                           '"limits.torque" = [[52.0, 400.0, 3000.0]]\n')
    (task,) = load_sweep(spec).tasks()
    rows = {r["smoother"]: r for r in run_task(task)}
    assert rows["centre"]["outcome"] == "failed" and "path 'centre': no timing fits the torque limit of hip_flexion" in rows["centre"]["reason"]
    assert rows["convex"]["outcome"] == "reached" and rows["convex"]["duration"] > 0 and rows["convex"]["min_clearance"] > 0.005


def test_when_no_timing_fits_any_path_each_row_keeps_its_measures_and_its_own_reason(tmp_path):
    """A 5 N m knee limit (below gravity's load) fits no path: every row said "failed" with the centre path's reason,
    the convex row included ("path 'centre': ..."), and none kept its bubbles, length or f, though both paths were planned."""
    from foam_mj.sweep import run_task

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = [0]\nsmoothers = "convex"\nreplay = "kinematic"\n[grid]\n'
                           '"limits.torque" = [[400.0, 5.0, 3000.0]]\n')
    (task,) = load_sweep(spec).tasks()
    rows = {r["smoother"]: r for r in run_task(task)}
    for path, row in rows.items():
        assert row["outcome"] == "failed"
        assert row["reason"].startswith(f"path '{path}': no timing fits the torque limit of knee_flexion"), row["reason"]
        assert row["bubbles"] > row["rosary"] > 1 and row["f"] >= row["length"] > 0 and row["plan_time"] > 0
        assert row.get("duration") is None and row.get("min_clearance") is None
    assert rows["convex"]["length"] <= rows["centre"]["length"]


@pytest.mark.parametrize("table, named", [
    ("seeds = 1000000000000", "field 'seeds' = 1,000,000,000,000 is more plans than one sweep takes (10,000,000)"),
    ('seeds = 2\n[random]\nsamples = 100000000000\n[random.uniform]\n"planner.delta" = [0.001, 0.01]',
     "200,000,000,000 plans (100,000,000,000 random samples x 2 seeds) are more than one sweep takes (10,000,000)"),
    ('seeds = 11\n[grid]\n"planner.K" = ' + json.dumps(list(range(1, 1001))) + '\n"planner.delta" = ' + json.dumps([0.001 * k for k in range(1, 1001)]),
     "11,000,000 plans (1,000 'planner.K' x 1,000 'planner.delta' x 11 seeds) are more than one sweep takes"),
])
def test_a_sweep_too_big_to_hold_is_exit_2_at_once_naming_its_factors(tmp_path, capsys, table, named):
    """seeds = 1e12 or 1e11 random samples was 'internal error: MemoryError' (exit 1)."""
    out = tmp_path / "out"
    assert main(["sweep", str(write(tmp_path, f'scenario = "obstacle"\n{table}\n')), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and named in err and "split the study into several sweep files" in err, err
    assert not out.exists()


def test_the_first_run_of_a_big_study_hashes_no_row_key_before_its_first_plan(tmp_path, monkeypatch):
    """A study of more than 200,000 plans counted its done plans by hashing every row key, twice, even on its
    first run with nothing done: minutes before the first plan of a 10-million-plan study."""
    from foam_mj import sweep as sweep_module

    hashed = []
    real = sweep_module.row_key
    monkeypatch.setattr(sweep_module, "row_key", lambda *a: hashed.append(a) or real(*a))
    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = 1000\nsmoothers = "none"\nreplay = "none"\n[grid]\n"planner.K" = '
                 + json.dumps(list(range(5, 305))) + "\n")
    summary = run_sweep(load_sweep(spec), tmp_path / "out", workers=1, limit=1, progress=False)
    assert (summary.tasks, summary.skipped, summary.run, summary.rows_written) == (300_000, 0, 1, 1)
    assert len(hashed) == 0  # the worker process hashes its own task's keys


@pytest.mark.parametrize("address, message", [("nohost", "expected auto, HOST:PORT or ray://HOST:PORT"),
                                              ("ray://127.0.0.1:{port}", "no Ray cluster answers there (Connection refused)"),
                                              ("127.0.0.1:{port}", "no Ray cluster answers there (Connection refused)")])
def test_a_ray_address_where_no_cluster_answers_is_exit_2_before_any_work(tmp_path, capsys, address, message):
    """`--ray 127.0.0.1:1` waited minutes in ray.init, logging warnings, after creating the output folder."""
    import socket

    pytest.importorskip("ray")
    with socket.socket() as s:  # a port where nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = address.format(port=port)
    out = tmp_path / "out"
    assert main(["sweep", str(write(tmp_path, STUDY)), "--out", str(out), "--ray", address]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"foam-mj: error: --ray {address}: {message}") and len(err.splitlines()) == 1, err
    assert not out.exists()


@pytest.mark.parametrize("reply, message", [(b"HTTP/1.0 400 Bad request\r\n\r\n", "it replied 'HTTP/1.0 '"),
                                            (b"", "it closed the connection")])
def test_a_ray_address_where_something_else_answers_is_exit_2_at_once(tmp_path, capsys, reply, message):
    """`--ray 127.0.0.1:PORT` where a web server listens waited in ray.init for minutes, printing 'Failed to connect to
    GCS' every 5 s (a TCP connection alone passed the address check): now one line, exit 2, no output folder."""
    import socket
    import threading
    import time

    pytest.importorskip("ray")
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]

    def answer():
        conn, _ = server.accept()
        with conn:
            conn.recv(64)
            conn.sendall(reply)

    threading.Thread(target=answer, daemon=True).start()
    out = tmp_path / "out"
    start = time.monotonic()
    try:
        code = main(["sweep", str(write(tmp_path, STUDY)), "--out", str(out), "--ray", f"127.0.0.1:{port}"])
    finally:
        server.close()
    err = capsys.readouterr().err
    assert code == 2 and len(err.splitlines()) == 1, err
    assert err.startswith(f"foam-mj: error: --ray 127.0.0.1:{port}: something answers there, but not a Ray cluster "
                          f"(it does not speak gRPC: {message}"), err
    assert time.monotonic() - start < 30 and not out.exists()
    assert not out.exists()


def test_bad_random_tables_and_fields_are_named(tmp_path):
    bad = {
        '[random]\nsamples = 3\n[random.uniform]\n"planner.r_min" = [0.09, 0.05]\n': "low <= high",
        # an empty range drew one value every time (2 samples, 1 plan, 'the 1 distinct ones are planned'), exit 0
        '[random]\nsamples = 2\n[random.uniform]\n"subject.height" = [1.5, 1.5]\n': "'subject.height' = [1.5, 1.5] is an empty range (low = high)",
        '[random]\nsamples = 2\n[random.uniform]\n"obstacle.size" = [[0.2, 0.5, 0.1], [0.2, 0.5, 0.1]]\n': "is an empty range (low = high in every element)",
        '[random]\nsamples = 0\n[random.uniform]\n"planner.r_min" = [0.05, 0.09]\n': "'samples'",
        '[random]\nsamples = 2\n[random.uniform]\n"planner.r_min" = [0.0, 0.09]\n': "'planner.r_min' = 0.0",
        'grids = 1\n': "unknown field(s) 'grids' (did you mean 'grid'?)",
        'replay = "sometimes"\n': "'replay'",
        'smoothers = "best"\n': "unknown smoother 'best'",
        '[grid]\n': "[grid] is empty",
        '[random]\nsamples = 3\n': "[random] has no key",
    }
    for text, named in bad.items():
        top, _, rest = text.partition("[")
        spec = write(tmp_path, f'scenario = "obstacle"\n{top}' + (f"[{rest}" if rest else ""))
        with pytest.raises(SweepError, match=re.escape(named)):
            load_sweep(spec)


def test_random_samples_are_drawn_once_from_their_seed_and_crossed_with_the_grid(tmp_path):
    spec = write(tmp_path, """
scenario = "obstacle"
seeds = [0, 1]
[grid]
"planner.delta" = [0.005, 0.01]
[random]
samples = 3
seed = 7
[random.uniform]
"planner.r_min" = [0.05, 0.09]
"planner.K" = [6, 10]
"q_goal" = [[0.4, 0.45, 1.4], [0.45, 0.4536, 1.45]]
[random.choice]
"planner.max_bubbles" = [100000, 200000]
""")
    a, b = load_sweep(spec), load_sweep(spec)
    assert a.n_tasks == 2 * 3 * 2 == len(list(a.tasks()))
    pa_, pb = list(a.points()), list(b.points())
    assert pa_ == pb and len(pa_) == 6
    assert [p["planner.r_min"] for p in pa_[:3]] == [p["planner.r_min"] for p in pa_[3:]]  # the same draws per grid point
    for p in pa_:
        assert 0.05 <= p["planner.r_min"] <= 0.09 and isinstance(p["planner.K"], int) and 6 <= p["planner.K"] <= 10
        assert all(lo <= v <= hi for v, lo, hi in zip(p["q_goal"], [0.4, 0.45, 1.4], [0.45, 0.4536, 1.45]))
        assert p["planner.max_bubbles"] in (100000, 200000)
    keys = [k for t in a.tasks() for k in t.keys]
    assert len(keys) == len(set(keys)) == 12 * 2
    assert dict(a.columns())["q_goal"] == "string" and dict(a.columns())["planner.K"] == "int64"


def test_a_random_draw_that_repeats_an_earlier_one_is_planned_once(tmp_path, capsys):
    """Six draws from a choice of two values are at most two plans: each repeat ran again and wrote its rows again
    under the same key (three rows of one key in the Parquet, counted three times by the report)."""
    spec = write(tmp_path, 'scenario = "obstacle"\nsmoothers = "none"\nreplay = "none"\n'
                           '[random]\nsamples = 6\n[random.choice]\n"planner.K" = [6, 8]\n')
    sweep = load_sweep(spec)
    assert sweep.n_tasks == len(list(sweep.tasks())) == 2 and sweep.repeated_draws == 4
    assert sorted(p["planner.K"] for p in sweep.points()) == [6, 8]
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--batch", "1"]) == 0
    std = capsys.readouterr()
    assert "4 of the 6 random samples repeat an earlier draw; the 2 distinct ones are planned" in std.err
    assert "2 plans in all" in std.out
    assert sorted(r["planner.K"] for r in check_folder(out)) == [6, 8]


def test_a_folder_of_another_sweep_is_refused(study, tmp_path):
    other = load_sweep(write(tmp_path, STUDY.replace('smoothers = "convex"', 'smoothers = "convex"\nreplay = "kinematic"')))
    with pytest.raises(SweepError, match="holds rows of another sweep"):
        run_sweep(other, study["out"], workers=1, progress=False)


@pytest.mark.parametrize("manifest", ["another sweep's", "unreadable"])
def test_a_refused_out_folder_is_left_as_it_was(manifest, tmp_path, capsys):
    """`foam-mj sweep S.toml --out DIR` where DIR holds another sweep's manifest (its rows moved away) or a damaged one
    created DIR/rows/ and DIR/.lock, then refused the folder; it now refuses it first: one line, exit 2, DIR unchanged."""
    from foam_mj.sweep_run import MANIFEST

    spec = write(tmp_path, STUDY)
    out = tmp_path / "out"
    out.mkdir()
    other = load_sweep(write(tmp_path, STUDY.replace('smoothers = "convex"', 'smoothers = "convex"\nreplay = "kinematic"'), "other.toml"))
    text = json.dumps(other.manifest(), indent=1) if manifest == "another sweep's" else "{not json"
    (out / MANIFEST).write_text(text)
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and ("holds rows of another sweep" in err or "unreadable sweep manifest" in err), err
    assert [p.name for p in out.iterdir()] == [MANIFEST] and (out / MANIFEST).read_text() == text


def test_report_draws_the_envelope_and_prints_a_summary(study, tmp_path, capsys):
    import matplotlib.image as mpimg

    from foam_mj.report import envelope_axes, grid_values, load

    figs = tmp_path / "figs"
    assert main(["report", str(study["out"]), "--figures", str(figs)]) == 0
    text = capsys.readouterr().out
    assert re.search(r"convex\s+12\s+12 \(100%\)", text) and re.search(r"centre\s+12\s+12 \(100%\)", text)
    for measure in ("success", "min_clearance", "f", "knee_torque"):
        for smoother in ("centre", "convex"):
            img = mpimg.imread(figs / f"{measure}-{smoother}.png")
            assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
    summary = json.loads((figs / "summary.json").read_text())
    assert {s["smoother"]: s["reached"] for s in summary} == {"centre": 12, "convex": 12}
    # the f heatmap's cells are the medians over the seeds of each (delta, size); the box's size is labelled by
    # the one element that varies, its height
    manifest, table = load(study["out"])
    x, y = envelope_axes(manifest, table)[:2]
    assert {x.name, y.name} == {"planner.delta", "obstacle.size[2]"}
    assert (x if x.key == "obstacle.size" else y).labels == ("0.1", "0.15")
    smoother = np.array(table.column("smoother").to_pylist())
    f = np.array(table.column("f").to_pylist(), dtype=float)
    cells = grid_values(x, y, smoother == "convex", lambda idx: float(np.median(f[idx])))
    xs, ys = table.column(x.key).to_pylist(), table.column(y.key).to_pylist()
    for k in np.flatnonzero(smoother == "convex"):
        same = (smoother == "convex") & (np.array(xs, dtype=object) == xs[k]) & (np.array(ys, dtype=object) == ys[k])
        assert same.sum() == 3
        assert cells[y.index[k], x.index[k]] == pytest.approx(np.median(f[same]))


def test_report_into_a_sweep_folder_that_cannot_take_it_says_how_to_write_elsewhere(study, capsys, monkeypatch):
    """Results on read-only or full storage: the default DIR/report was named as "--figures output DIR/x",
    a flag the user had not given and a file nobody named."""
    from foam_mj import atomic

    monkeypatch.setattr(atomic, "MIN_FREE_BYTES", 1 << 62)
    assert main(["report", str(study["out"])]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"foam-mj: error: report folder {study['out']}/report: no space left on its file system")
    assert err.strip().endswith("(the default report folder; write elsewhere with --figures FIGDIR)") and len(err.splitlines()) == 1
    assert not (study["out"] / "report").exists()


def test_report_with_an_empty_figures_name_is_refused_as_plan_refuses_one(study, tmp_path, capsys, monkeypatch):
    """--figures "" became Path("") = ".": the figures and summaries went into the current folder without a word."""
    monkeypatch.chdir(tmp_path)
    assert main(["report", str(study["out"]), "--figures", ""]) == 2
    assert capsys.readouterr().err.strip() == "foam-mj: error: --figures: empty folder name"
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_while_writing_rows_is_exit_2_naming_the_folder_and_leaves_no_partial_file(tmp_path, capsys, monkeypatch):
    """A batch that hit a full disk (pyarrow's OSError, errno 28) was an internal error, exit 1."""
    import errno

    def full_disk(table, where, **kw):
        Path(where).write_bytes(b"PAR1 half a file")
        raise OSError(errno.ENOSPC, "Error writing bytes to file. Detail: [errno 28] No space left on device")

    monkeypatch.setattr(pq, "write_table", full_disk)
    spec = write(tmp_path, 'scenario = "obstacle"\nsmoothers = "none"\nreplay = "none"\n[grid]\n"planner.delta" = [0.005]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert f"--out {out}: could not write a batch of 1 row to {out / 'rows'}: No space left on device;" in err
    assert "run the same command again" in err and "internal error" not in err
    assert list((out / "rows").iterdir()) == []  # nothing half-written, no temporary file


def test_the_readme_duckdb_query_runs_on_the_parquet_files(study, monkeypatch):
    duckdb = pytest.importorskip("duckdb")
    readme = (ROOT / "README.md").read_text()
    queries = re.findall(r"```sql\n(.*?)```", readme, flags=re.S)
    assert queries, "the README shows a DuckDB query"
    monkeypatch.chdir(study["out"].parent)  # the README's folder is called study/
    result = duckdb.sql(queries[0]).fetchall()
    assert len(result) == 4  # one line per (delta, goal) of the convex rows: 3 seeds each, all reached
    assert [(r[0], r[1]) for r in result] == sorted(product([0.005, 0.01], map(json.dumps, SIZES)))
    assert all(r[2] == 1.0 and r[-1] == 3 for r in result)


def test_the_readme_sweep_file_is_valid(tmp_path):
    readme = (ROOT / "README.md").read_text()
    example = re.findall(r"```toml\n(.*?)```", readme[readme.index("## Studies"):], flags=re.S)[0]
    sweep = load_sweep(write(tmp_path, example))
    assert sweep.keys == ("planner.delta", "obstacle.size", "subject.height", "planner.K")
    assert sweep.n_tasks == 2 * 2 * 20 * 3
    heights = {p["subject.height"] for p in sweep.points()}
    assert len(heights) == 20 and all(1.55 <= h <= 1.95 for h in heights)


def test_a_list_key_drawn_at_random_gives_one_binned_axis_per_element_that_varies(tmp_path):
    """obstacle.size drawn element-wise gave one axis label per plan (its full-precision JSON): 1,600 plans drew
    figures 235,000 pixels wide, in 11 minutes and 3 GB. Each element that varies is now a numeric axis of at most
    BINS bins, and the report says what it is doing (reading, summarising, each figure)."""
    from foam_mj.report import BINS, envelope_axes, load, write_report

    spec = write(tmp_path, """
scenario = "obstacle"
smoothers = "none"
replay = "none"
[random]
samples = 40
seed = 0
[random.uniform]
"obstacle.size" = [[0.15, 0.45, 0.03], [0.25, 0.55, 0.2]]
""")
    out = _stored_rows(spec, lambda task, k, path: {"key": k, "obstacle.size": json.dumps(dict(task.params)["obstacle.size"]),
                                                    "seed": task.seed, "smoother": path, "outcome": "reached", "f": 3.0})
    manifest, table = load(out)
    axes = envelope_axes(manifest, table)
    assert [a.name for a in axes] == ["obstacle.size[0]", "obstacle.size[1]", "obstacle.size[2]"]
    sizes = np.array([json.loads(v) for v in table.column("obstacle.size").to_pylist()])
    for i, axis in enumerate(axes):
        assert len(axis.labels) == BINS and axis.key == "obstacle.size"
        centres = np.array([float(label) for label in axis.labels])
        half = (centres[1] - centres[0]) / 2
        assert np.all(np.abs(sizes[:, i] - centres[axis.index]) <= half + 1e-4)  # each row in its element's bin (labels: 4 digits)
    messages: list[str] = []
    write_report(out, progress=messages.append)
    assert messages[:3] == [f"reading the rows of {out}", "summarising 40 rows", "binning the swept keys of 40 rows"]
    assert messages[3:] == [f"drawing {m}-centre ({k} of 3, 40 rows)" for k, m in enumerate(("success", "min_clearance", "f"), 1)]


def test_the_envelope_uses_the_most_varied_keys_and_one_panel_per_value_of_a_third(tmp_path):
    """Rows written straight to the store (no planning): the report's cells are what the rows say."""
    from foam_mj.report import envelope_axes, grid_values, load, write_report
    from foam_mj.sweep_run import RowStore

    spec = write(tmp_path, """
scenario = "obstacle"
seeds = [0, 1]
smoothers = "none"
replay = "none"
[grid]
"planner.delta" = [0.005, 0.01]
"planner.r_min" = [0.05, 0.06, 0.07]
"planner.K" = [6, 8, 10, 12]
""")
    sweep = load_sweep(spec)
    out = tmp_path / "out"
    store = RowStore(out, sweep, batch=7)
    store.open(sweep)

    def reached(p, seed):  # the envelope: small margins always, the large one only with K >= 10 and seed 1
        return p["planner.delta"] < 0.01 or (p["planner.K"] >= 10 and seed == 1)

    for task in sweep.tasks():
        p = dict(task.params)
        ok = reached(p, task.seed)
        store.add([{"key": k, **p, "seed": task.seed, "smoother": path, "outcome": "reached" if ok else "failed",
                    "f": 3.0 + p["planner.r_min"] if ok else None} for k, path in zip(task.keys, task.paths)])
    store.flush()
    store.close()
    manifest, table = load(out)
    axes = envelope_axes(manifest, table)
    assert [a.key for a in axes] == ["planner.K", "planner.r_min", "planner.delta"]
    x, y, panel = axes
    outcome = np.array(table.column("outcome").to_pylist())
    for k, label in enumerate(panel.labels):
        rows = panel.index == k
        cells = grid_values(x, y, rows, lambda idx: float(np.mean(outcome[idx] == "reached")))
        expected = 1.0 if float(label) < 0.01 else np.array([0.0, 0.0, 0.5, 0.5])  # per K, over the two seeds
        assert np.allclose(cells, np.broadcast_to(expected, cells.shape))
    text, written = write_report(out)
    names = {p.name for p in written}
    assert {"success-centre.png", "f-centre.png", "summary.txt", "summary.json"} <= names
    assert "min_clearance-centre.png" not in names  # nothing replayed, nothing to draw
    assert re.search(r"centre\s+48\s+30 \(62%\)\s+18", text)


def test_on_a_terminal_progress_is_a_live_bar_with_rate_and_eta(tmp_path):
    import pty

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = 2\nsmoothers = "none"\nreplay = "none"\n')
    master, slave = pty.openpty()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]), "COLUMNS": "120"}
    proc = subprocess.Popen([sys.executable, "-m", "foam_mj.cli", "sweep", str(spec), "--out", str(tmp_path / "out"), "--workers", "1"],
                            env=env, stdout=subprocess.PIPE, stderr=slave, text=True)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # the other end closed
            break
        if not data:
            break
        chunks.append(data)
    proc.wait(timeout=300)
    os.close(master)
    assert proc.returncode == 0
    screen = b"".join(chunks).decode(errors="replace")
    assert "2/2" in screen and "plans/s" in screen and "ETA" in screen and "0 not reached" in screen
    assert "━" in screen  # rich's bar, not the plain lines


@pytest.mark.slow
def test_ray_with_an_address_joins_that_cluster(study, tmp_path):
    ray = pytest.importorskip("ray")
    import logging

    ray.init(num_cpus=2, include_dashboard=False, logging_level=logging.ERROR, log_to_driver=False)
    try:
        address = ray.get_runtime_context().gcs_address
        spec = write(tmp_path, STUDY.replace("seeds = [1, 2, 3]", "seeds = [3]").replace("[0.005, 0.01]", "[0.005]")
                     .replace(json.dumps(SIZES), json.dumps(SIZES[:1])))
        proc = cli("sweep", str(spec), "--out", str(tmp_path / "joined"), "--ray", address, "--quiet")
        stdout, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err
        assert f"on Ray ({address})" in stdout  # ray.init(address=...) succeeded: it ran on this cluster
    finally:
        ray.shutdown()
    rows = deterministic(check_folder(tmp_path / "joined"))
    local = {r["key"]: r for r in deterministic(study["rows"])}
    assert len(rows) == 2 and rows == [local[r["key"]] for r in rows]


@pytest.mark.slow
def test_a_kill_during_a_ray_sweep_exits_130_and_writes_the_rows_received(study, tmp_path):
    """`kill` (SIGTERM to the sweep alone) stops a Ray sweep as it stops a local one. ray.init had replaced the
    SIGTERM handler with sys.exit(15): the sweep ended with exit 1 or 143, no message, sometimes a Ray crash
    dump, and the rows received but not yet in a batch were lost."""
    pytest.importorskip("ray")
    import threading

    out = tmp_path / "ray"
    # one batch at the end only (nothing written before the kill), progress every 0.2 s to see plans arrive
    proc = cli("sweep", str(study["spec"]), "--out", str(out), "--ray", "--workers", "2", "--flush-seconds", "3600",
               "--progress-interval", "0.2")
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stderr), daemon=True)
    reader.start()
    t0 = time.monotonic()
    while not any(re.match(r"sweep: [1-9]\d*/12 plans", ln) for ln in lines):
        assert proc.poll() is None and time.monotonic() - t0 < 300, lines
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGTERM)
    code = proc.wait(timeout=120)
    reader.join(timeout=10)
    assert code == 130, lines
    assert "interrupted" in lines[-1] and not any("Traceback" in ln or "Check failed" in ln for ln in lines), lines
    rows = deterministic(check_folder(out))
    assert rows and len(rows) % 2 == 0, "every plan received has both its rows"
    local = {r["key"]: r for r in deterministic(study["rows"])}
    assert rows == [local[r["key"]] for r in rows]


@pytest.mark.slow
def test_an_interrupt_inside_the_ray_engine_reaches_the_sweep_before_ray_shuts_down(study):
    """A Ctrl-C that lands inside the Ray engine (in ray.wait, most often) ran Ray's teardown before the sweep had
    written the rows it had received, and that teardown can hang or abort. The engine now yields INTERRUPTED with
    Ray still up, and shuts Ray down only when the sweep closes it, after the rows are written."""
    ray = pytest.importorskip("ray")
    from foam_mj.sweep_run import INTERRUPTED, ray_engine

    def tasks():
        raise KeyboardInterrupt
        yield  # a generator

    events = ray_engine(tasks(), workers=1, address=None)
    assert next(events) is INTERRUPTED
    assert ray.is_initialized(), "Ray is still up while the sweep writes its rows"
    events.close()
    assert not ray.is_initialized()


@pytest.mark.parametrize("flag, value", [("--batch", "0"), ("--batch", "-5"), ("--limit", "0"), ("--limit", "-1"), ("--workers", "0"),
                                         ("--flush-seconds", "nan"), ("--flush-seconds", "-1"), ("--progress-interval", "0"),
                                         ("--progress-interval", "inf")])
def test_bad_numbers_for_the_sweep_flags_are_exit_2_before_any_work(tmp_path, capsys, flag, value):
    """--batch -5 ran as 1, --limit -1 ran nothing and exited 0, --flush-seconds nan was taken: each is refused, naming the flag."""
    out = tmp_path / "out"
    assert main(["sweep", str(write(tmp_path, STUDY)), "--out", str(out), flag, value]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and f"{flag} must be" in err and value in err, err
    assert not out.exists()


@pytest.mark.parametrize("damage, message", [
    (lambda rows: (rows / "zzz.parquet").write_text("hello"), "zzz.parquet: not a readable Parquet file"),
    (lambda rows: pq.write_table(pa.table({"a": [1, 2]}), rows / "other.parquet"), "other.parquet: not a row file of this sweep (no column(s) ['key'"),
    (lambda rows: (lambda f: f.write_bytes(f.read_bytes()[:300]))(sorted(rows.glob("*.parquet"))[0]), "not a readable Parquet file"),
])
def test_a_corrupt_or_foreign_parquet_file_is_named_by_report_and_by_a_rerun(study, tmp_path, capsys, damage, message):
    """A truncated batch, a file that is not Parquet or one of another schema in rows/ was an internal error
    (exit 1, ArrowInvalid / KeyError) in `report` and in a rerun of the sweep: now exit 2 naming the file."""
    import shutil

    out = tmp_path / "study"
    shutil.copytree(study["out"], out)
    damage(out / "rows")
    before = sorted(p.name for p in (out / "rows").iterdir())
    for argv in (["report", str(out), "--figures", str(tmp_path / "figs")], ["sweep", str(study["spec"]), "--out", str(out), "--quiet"]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and message in err and "move it out of" in err, err
    assert sorted(p.name for p in (out / "rows").iterdir()) == before and not (tmp_path / "figs").exists()


def test_a_manifest_saved_with_a_byte_order_mark_is_read_by_report_and_a_rerun(study, tmp_path, capsys):
    """A sweep.json re-saved by an editor that adds a UTF-8 byte-order mark was 'unreadable sweep manifest: Unexpected
    UTF-8 BOM' (exit 2) in report and in a rerun: the mark is no part of the JSON, and the manifest is read as UTF-8
    whatever the locale."""
    import shutil

    out = tmp_path / "study"
    shutil.copytree(study["out"], out)
    (out / "sweep.json").write_bytes(b"\xef\xbb\xbf" + (out / "sweep.json").read_bytes())
    assert main(["report", str(out), "--figures", str(tmp_path / "figs")]) == 0
    assert main(["sweep", str(study["spec"]), "--out", str(out), "--quiet"]) == 0
    assert "BOM" not in capsys.readouterr().err


def test_a_sweep_file_that_is_its_out_folders_manifest_is_refused_as_such(tmp_path, capsys):
    """`foam-mj sweep study/sweep.json --out study` (the sweep file saved under the manifest's name) was refused as an
    'unreadable sweep manifest: Expecting value' (it is TOML): the message now says which file is which."""
    (tmp_path / "study").mkdir()
    spec = write(tmp_path / "study", STUDY, "sweep.json")
    assert main(["sweep", str(spec), "--out", str(tmp_path / "study"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"foam-mj: error: the sweep file {spec} is where --out {tmp_path / 'study'} keeps its manifest "
                   "(sweep.json): save the sweep file under another name, e.g. sweep.toml"), err
    assert spec.read_text() == STUDY and [p.name for p in (tmp_path / "study").iterdir()] == ["sweep.json"]


@pytest.mark.parametrize("edit, message", [
    (lambda m: m.update(version=2), "field 'version' is 2: written by a foam-mj that writes sweep format version 2; this one reads 1"),
    (lambda m: m.pop("version"), "field 'version' is None"),
    (lambda m: m.update(keys=list(m["keys"])), "field 'keys' must be an object of swept key: kind"),
    (lambda m: m.update(paths=3), "field 'paths' must be a list of path names"),
    (lambda m: m.update(columns="key"), "field 'columns' must be a list of column names"),
    (lambda m: m.update(model_hash="fe247d40"), "field 'model_hash' must be an object"),
])
def test_a_manifest_edited_by_hand_or_of_another_version_is_named_by_report_and_by_a_rerun(study, tmp_path, capsys, edit, message):
    """A sweep.json whose 'keys' was a list or 'paths' a number was an internal error in report (exit 1); one of
    format version 2 (or none) was read as version 1, and a model_hash that is no object skipped a rerun's check that
    the scene still compiles to the same model. Both report and a rerun now refuse it: exit 2, one line naming
    the field, the folder left as it was."""
    import shutil

    out = tmp_path / "study"
    shutil.copytree(study["out"], out)
    manifest = json.loads((out / "sweep.json").read_text())
    edit(manifest)
    (out / "sweep.json").write_text(json.dumps(manifest))
    before = sorted(p.name for p in out.rglob("*"))
    for argv in (["report", str(out)], ["sweep", str(study["spec"]), "--out", str(out), "--quiet"]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.startswith(f"foam-mj: error: {out / 'sweep.json'}: ") and message in err and "\n" not in err, err
    assert sorted(p.name for p in out.rglob("*")) == before


@pytest.mark.parametrize("rows, message", [
    ("empty", r"no rows to report: the \d+ Parquet file\(s\) in {rows} hold 0 rows"),
    ("none", r"no rows to report: no Parquet file in {rows}"),
])
def test_report_on_a_sweep_with_no_rows_is_exit_2_naming_the_rows_folder(study, tmp_path, capsys, rows, message):
    """Row files of 0 rows (real Parquet files of the sweep's schema) were reported as "wrote 0 figure(s)", exit 0.
    A sweep with no row to report, empty files or none, is one line naming its rows folder, exit 2, and no figure."""
    import shutil

    out = tmp_path / "study"
    shutil.copytree(study["out"], out)
    for f in (out / "rows").glob("*.parquet"):
        if rows == "empty":
            pq.write_table(pq.read_table(f).slice(0, 0), f)
        else:
            f.unlink()
    assert main(["report", str(out), "--figures", str(tmp_path / "figs")]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert len(err.splitlines()) == 1 and re.search(message.format(rows=re.escape(str(out / "rows"))), err), err
    assert "figure(s)" not in captured.out and not (tmp_path / "figs").exists()


def test_with_limit_the_progress_and_its_eta_count_to_where_this_run_stops(tmp_path, capsys):
    """`--limit 100` on a 270-plan study showed "42/270 plans ... ETA 55 s" while the run ended 14 s later: the
    bar and its ETA now count to the run's end, and say that --limit ends it there."""
    from foam_mj.progress import SweepProgress

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = 3\nsmoothers = "none"\nreplay = "none"\n')
    run_sweep(load_sweep(spec), tmp_path / "out", workers=1, interval=0.0, limit=1)
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines[0].startswith("sweep (--limit: to 1 of 3): 0/1 plans, 0 not reached") and lines[-1].startswith("sweep (--limit: to 1 of 3): 1/1 plans")
    bar = SweepProgress(270, 100, terminal=False, stop=200)  # a second run of --limit 100: 100 done before it
    bar.done, bar.start_done, bar.t0 = 150, 100, bar.t0 - 10.0  # 50 plans in 10 s: 50 left to its end, 10 s
    assert re.fullmatch(r"sweep \(--limit: to 200 of 270\): 150/200 plans, 0 not reached, [\d.]+ plans/s, ETA 1[01] s", bar.line())
    assert SweepProgress(270, 0, terminal=False, stop=300).line().startswith("sweep: 0/270 plans")  # the study ends first


def test_a_rerun_counts_the_failures_of_the_plans_done_before(tmp_path, capsys):
    """A re-run's progress counted the plans done before in "1/2 plans" but not their failures ("0 failed" while the
    folder held an invalid plan); failures are now counted over the same plans as the done ones."""
    spec = write(tmp_path, 'scenario = "obstacle"\nsmoothers = "none"\nreplay = "none"\n'
                           '[grid]\n"obstacle.pos" = [[0.9, 0.0, 0.1], [0.5, 0.0, 0.075]]\n')  # the first: goal in collision
    out = tmp_path / "out"
    run_sweep(load_sweep(spec), out, workers=1, limit=1, progress=False)
    assert [r["outcome"] for r in read_rows(out).to_pylist()] == ["invalid"]
    summary = run_sweep(load_sweep(spec), out, workers=1, interval=0.0)
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines[0].startswith("sweep: 1/2 plans, 1 not reached") and lines[-1].startswith("sweep: 2/2 plans, 1 not reached"), lines
    assert (summary.skipped, summary.run, summary.failed) == (1, 1, 0)  # the run's own summary: this run's plans


def test_every_value_of_the_panel_key_gets_its_panel(tmp_path, monkeypatch):
    """Only the first MAX_PANELS (6) values of the third key were drawn: 8 bins of the box's height lost their two
    tallest, where the plans fail. Panels now wrap into rows of at most MAX_PANELS."""
    from matplotlib.figure import Figure

    from foam_mj.report import MAX_PANELS, write_report
    from foam_mj.sweep_run import RowStore

    deltas = [0.002, 0.003, 0.004, 0.005, 0.006, 0.007, 0.008]
    assert len(deltas) > MAX_PANELS
    spec = write(tmp_path, f"""
scenario = "obstacle"
smoothers = "none"
replay = "none"
[grid]
"planner.K" = [4, 5, 6, 7, 8, 9, 10, 11, 12]
"planner.r_min" = [0.03, 0.035, 0.04, 0.045, 0.05, 0.055, 0.06, 0.065]
"planner.delta" = {deltas}
""")
    sweep = load_sweep(spec)
    out = tmp_path / "out"
    store = RowStore(out, sweep, batch=500)
    store.open(sweep)
    for task in sweep.tasks():
        store.add([{"key": k, **dict(task.params), "seed": task.seed, "smoother": path, "outcome": "reached", "f": 3.0}
                   for k, path in zip(task.keys, task.paths)])
    store.flush()
    store.close()
    drawn = {}

    def savefig(fig, where, **kw):
        drawn[Path(where).name] = [ax.get_title() for ax in fig.axes if ax.get_visible() and ax.images]
        Path(where).write_bytes(b"")

    monkeypatch.setattr(Figure, "savefig", savefig)
    write_report(out)
    assert drawn and all(titles == [f"planner.delta = {d:g}" for d in deltas] for titles in drawn.values())


def test_more_workers_than_cores_are_capped_at_the_cores_with_a_note(tmp_path, capsys):
    """`--workers 64` on a 2-core machine was accepted, and the pool could start up to 128 processes that only share
    the cores. Local workers are capped at the cores this process may use, and the run says so in one line."""
    from foam_mj.sweep_run import default_workers

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = 1\nsmoothers = "none"\nreplay = "none"\n')
    summary = run_sweep(load_sweep(spec), tmp_path / "out", workers=default_workers() + 62, limit=1, interval=3600.0)
    assert summary.workers == default_workers()
    note = f"sweep: --workers {default_workers() + 62} capped at {default_workers()}, the cores this process may use"
    assert capsys.readouterr().err.splitlines()[0] == note


def test_the_envelope_tells_cells_without_a_valid_problem_from_cells_the_planner_failed(tmp_path, monkeypatch):
    """A cell whose plans were all `invalid` (start or goal not free) was drawn as a success of 0.00, the colour of
    a cell the planner failed. Success is the share of the valid plans that reached; a cell without a valid plan has
    no success value and is hatched in every figure, with a legend saying why, and a failed cell stays 0."""
    from matplotlib.figure import Figure

    from foam_mj.report import INVALID_LABEL, NOT_REACHED_LABEL, _measures, _data, envelope_axes, grid_values, load, write_report
    from foam_mj.sweep_run import RowStore

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = [0, 1]\nsmoothers = "none"\nreplay = "none"\n'
                           '[grid]\n"planner.delta" = [0.005, 0.01]\n"planner.r_min" = [0.05, 0.06, 0.07]\n')
    sweep = load_sweep(spec)
    out = tmp_path / "out"
    store = RowStore(out, sweep, batch=50)
    store.open(sweep)

    def outcome(p, seed):  # r_min 0.07: never a valid problem; delta 0.01: the planner fails; one seed invalid at 0.06
        if p["planner.r_min"] == 0.07 or (p["planner.r_min"] == 0.06 and seed == 0):
            return "invalid"
        return "failed" if p["planner.delta"] == 0.01 else "reached"

    for task in sweep.tasks():
        p = dict(task.params)
        o = outcome(p, task.seed)
        store.add([{"key": k, **p, "seed": task.seed, "smoother": path, "outcome": o, "f": 3.0 if o == "reached" else None}
                   for k, path in zip(task.keys, task.paths)])
    store.flush()
    store.close()
    manifest, table = load(out)
    x, y = envelope_axes(manifest, table)
    assert (x.key, y.key) == ("planner.r_min", "planner.delta")
    success = dict((m[0], m[4]) for m in _measures(_data(table), None))["success"]
    cells = grid_values(x, y, np.ones(table.num_rows, dtype=bool), success)
    assert np.array_equal(cells, [[1.0, 1.0, np.nan], [0.0, 0.0, np.nan]], equal_nan=True)  # rows: delta; columns: r_min

    drawn = {}
    real = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda fig, fname, **kw: drawn.setdefault(fig._suptitle.get_text(), fig) and real(fig, fname, **kw))
    write_report(out)
    for title, legend in (("success rate of valid plans (centre)", [INVALID_LABEL]), ("median f (centre)", [INVALID_LABEL, NOT_REACHED_LABEL])):
        fig = drawn[title]
        hatched = [(p.get_x() + 0.5, p.get_y() + 0.5) for ax in fig.axes for p in ax.patches if p.get_hatch()]
        assert sorted(hatched) == [(2.0, 0.0), (2.0, 1.0)]  # the r_min 0.07 column, and only it
        assert [t.get_text() for t in fig.legends[0].get_texts()] == legend  # f's failed cells (delta 0.01) are grey: said so


def test_a_study_whose_every_cell_is_invalid_still_draws_its_success_figure_all_hatched(tmp_path):
    """When no cell holds a valid problem (every start or goal in collision), no measure has a value; the report drew
    no figure at all, so the study's only picture said nothing. The success figure is drawn with every cell hatched
    and the legend saying why; measures without a fixed scale (f) still get no figure."""
    from foam_mj.report import write_report
    from foam_mj.sweep_run import RowStore

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = [0]\nsmoothers = "none"\nreplay = "none"\n'
                           '[grid]\n"planner.delta" = [0.005, 0.01]\n')
    sweep = load_sweep(spec)
    out = tmp_path / "out"
    store = RowStore(out, sweep, batch=50)
    store.open(sweep)
    for task in sweep.tasks():
        store.add([{"key": k, **dict(task.params), "seed": task.seed, "smoother": path, "outcome": "invalid"}
                   for k, path in zip(task.keys, task.paths)])
    store.flush()
    store.close()
    _, written = write_report(out)
    assert sorted(p.name for p in written if p.suffix == ".png") == ["success-centre.png"]


def test_an_interrupt_before_any_row_is_written_does_not_point_at_rows_that_are_not_there(tmp_path, capsys, monkeypatch):
    """Ctrl-C in a sweep's first seconds said "the completed plans are in OUT/rows", a folder that did not exist."""
    import foam_mj.sweep_run as sweep_run

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep_run, "run_sweep", interrupted)
    out = tmp_path / "out"
    assert main(["sweep", str(write(tmp_path, STUDY)), "--out", str(out), "--quiet"]) == 130
    err = capsys.readouterr().err.strip()
    assert err == f"foam-mj: interrupted before any plan was written to {out / 'rows'} (run the same command again to start)"


def test_a_smoother_added_to_a_sweep_adds_its_rows_and_writes_no_row_twice(tmp_path, capsys):
    """Re-running with one more smoother re-plans each task (its new path has no row yet), and the task returns every
    path's row: the centre and convex rows already in the folder were written a second time (a 24-plan study then
    held 48 centre rows under 24 keys)."""
    text = 'scenario = "obstacle"\nseeds = 2\nsmoothers = "convex"\nreplay = "none"\n'
    out = tmp_path / "out"
    run_sweep(load_sweep(write(tmp_path, text)), out, workers=1, progress=False)
    before = check_folder(out)
    assert sorted(r["smoother"] for r in before) == ["centre", "centre", "convex", "convex"]
    summary = run_sweep(load_sweep(write(tmp_path, text.replace('"convex"', '["convex", "gradient"]'))), out, workers=1, progress=False)
    after = check_folder(out)  # asserts each key once
    assert summary.rows_written == 2
    assert sorted(r["smoother"] for r in after) == ["centre", "centre", "convex", "convex", "gradient", "gradient"]
    assert deterministic([r for r in after if r["smoother"] != "gradient"]) == deterministic(before)


def test_every_row_names_the_versions_that_made_it(study):
    """A study's rows outlive the software: each says which foam-mj and MuJoCo made it, and so does sweep.json."""
    import mujoco

    import foam_mj

    assert {(r["foam_mj_version"], r["mujoco_version"]) for r in study["rows"]} == {(foam_mj.__version__, mujoco.__version__)}
    manifest = json.loads((study["out"] / "sweep.json").read_text())
    assert manifest["versions"] == {"foam_mj_version": foam_mj.__version__, "mujoco_version": mujoco.__version__}


def _own_obstacle_scenario(folder: Path, K: int = 10) -> Path:
    """The obstacle scenario as a TOML of the study's own, on a copy of the models (so that a test may edit them)."""
    import shutil

    shutil.copytree(ROOT / "models", folder / "models", dirs_exist_ok=True)
    text = (ROOT / "scenarios" / "obstacle.toml").read_text().replace("K = 10", f"K = {K}")
    return write(folder, text.replace('scene = "../models/obstacle.xml"', 'scene = "models/obstacle.xml"'), "leg.toml")


def test_a_sweep_whose_scene_was_edited_is_refused_on_its_folder_naming_what_changed(tmp_path):
    """The folder compared the scenario's TOML table (which names the scene file), not the scene: a box made taller in
    the MJCF between two runs mixed rows of two models in one study, silently."""
    _own_obstacle_scenario(tmp_path)
    spec = write(tmp_path, 'scenario = "leg.toml"\nseeds = 2\nsmoothers = "none"\nreplay = "none"\n')
    out = tmp_path / "out"
    run_sweep(load_sweep(spec), out, workers=1, limit=1, progress=False)
    scene = tmp_path / "models" / "obstacle.xml"
    scene.write_text(scene.read_text().replace('size="0.1 0.25 0.075"', 'size="0.1 0.25 0.09"'))
    with pytest.raises(SweepError, match=r"holds rows of another sweep \(its base scene compiles to another model now \(geometry differs"):
        run_sweep(load_sweep(spec), out, workers=1, progress=False)
    assert len(check_folder(out)) == 1


def test_a_refusal_names_the_field_that_differs_and_leaves_the_folder_unlocked(tmp_path):
    """The refusal quoted the first 120 characters of the folder's whole base scenario (not what differs), and kept
    the folder locked in the refusing process: the right sweep, run next in the same process, was told that "another
    sweep is writing to this folder"."""
    _own_obstacle_scenario(tmp_path)
    spec = write(tmp_path, 'scenario = "leg.toml"\nsmoothers = "none"\nreplay = "none"\n', "a.toml")
    out = tmp_path / "out"
    run_sweep(load_sweep(spec), out, workers=1, limit=1, progress=False)
    _own_obstacle_scenario(tmp_path, K=8)
    with pytest.raises(SweepError, match=r"its base scenario's field planner\.K: 10 -> 8\); use another folder"):
        run_sweep(load_sweep(spec), out, workers=1, progress=False)
    _own_obstacle_scenario(tmp_path, K=10)
    with pytest.raises(SweepError, match=r"its swept keys: \['planner\.delta'\] not swept there\)"):
        run_sweep(load_sweep(write(tmp_path, spec.read_text() + '[grid]\n"planner.delta" = [0.01]\n', "b.toml")), out,
                  workers=1, progress=False)
    assert run_sweep(load_sweep(spec), out, workers=1, progress=False).skipped == 1


def test_a_rerun_with_nothing_to_do_starts_no_engine(tmp_path):
    """A re-run of a finished study with --ray started a local Ray instance (15 s on this machine) to run nothing, and
    said "0 rows in 0 files ...; 0.00 plans/s on Ray (local)"; it now starts no engine and says there is nothing to do."""
    spec = write(tmp_path, 'scenario = "obstacle"\nsmoothers = "none"\nreplay = "none"\n')
    out = tmp_path / "out"
    run_sweep(load_sweep(spec), out, workers=1, progress=False)
    code = ("import sys; from foam_mj.sweep_file import load_sweep; from foam_mj.sweep_run import run_sweep; "
            f"s = run_sweep(load_sweep({str(spec)!r}), {str(out)!r}, engine='ray', workers=1, progress=False); "
            "print(s.skipped, s.run, 'ray' in sys.modules)")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert done.stdout.split() == ["1", "0", "False"], done.stderr  # Ray not even imported
    proc = cli("sweep", str(spec), "--out", str(out), "--quiet")
    stdout, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert stdout.strip() == f"sweep {spec}: 1 plans in all, 1 already done, 0 run now: nothing to do, every row is in {out / 'rows'}"


def test_sweeping_the_whole_obstacle_table_places_each_box_where_its_value_says(tmp_path):
    """The README's way to vary a box's position and height together (obstacle.pos is the centre, so crossing it with
    obstacle.size would sink taller boxes into the floor): each value is one box, its size and centre as given."""
    import mujoco

    from foam_mj.sweep import build_scenario

    boxes = [{"size": [0.2, 0.5, 0.10], "pos": [0.45, 0.0, 0.05]}, {"size": [0.2, 0.5, 0.15], "pos": [0.55, 0.0, 0.075]}]
    spec = write(tmp_path, 'scenario = "obstacle"\nsmoothers = "none"\nreplay = "none"\n[grid]\n'
                           '"obstacle" = [{size = [0.2, 0.5, 0.10], pos = [0.45, 0.0, 0.05]}, '
                           '{size = [0.2, 0.5, 0.15], pos = [0.55, 0.0, 0.075]}]\n')
    sweep = load_sweep(spec)
    assert [dict(t.params)["obstacle"] for t in sweep.tasks()] == boxes
    for task, box in zip(sweep.tasks(), boxes):
        m = build_scenario(task.scenario, task.builtin, task.base, task.params).robot.model
        g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "obstacle_box")
        assert np.allclose(m.geom_pos[g], box["pos"]) and np.allclose(2 * m.geom_size[g], box["size"])
        assert m.geom_pos[g][2] - m.geom_size[g][2] == pytest.approx(0.0)  # on the floor, as the values were chosen
    duckdb = pytest.importorskip("duckdb")
    run_sweep(sweep, tmp_path / "out", workers=1, progress=False)
    query = f"""SELECT (obstacle::JSON->>'$.pos[0]')::DOUBLE, count(*) FROM '{tmp_path / "out"}/rows/*.parquet' GROUP BY ALL ORDER BY ALL"""
    assert duckdb.sql(query).fetchall() == [(0.45, 1), (0.55, 1)]  # one row each: the centre path


def _fake_study(tmp_path: Path, text: str, outcome) -> Path:
    """A sweep folder whose rows are written directly (no plan): ``outcome(params, seed)`` gives each row's outcome."""
    from foam_mj.sweep import column_value
    from foam_mj.sweep_run import RowStore

    sweep = load_sweep(write(tmp_path, text))
    out = tmp_path / "out"
    store = RowStore(out, sweep, batch=1000)
    store.open(sweep)
    for task in sweep.tasks():
        p = dict(task.params)
        o = outcome(p, task.seed)
        columns = {k: column_value(v, kind) for (k, v), kind in zip(task.params, task.kinds)}  # lists as JSON text
        store.add([{"key": k, **columns, "seed": task.seed, "smoother": path, "outcome": o, "f": 3.0 if o == "reached" else None}
                   for k, path in zip(task.keys, task.paths)])
    store.flush()
    store.close()
    return out


def test_report_axes_are_chosen_by_name_and_the_title_names_the_keys_pooled(tmp_path, monkeypatch, capsys):
    """A study over boxes, subjects and planners drew boxes x subjects and pooled the planners into each cell without a
    word (pfm invalid and rbpf reached in one cell read as a success of 1.00); `--axes` now picks the keys, and the title
    names what is pooled."""
    from matplotlib.figure import Figure

    text = ('scenario = "obstacle"\nsmoothers = "none"\nreplay = "none"\n[grid]\n"planner.delta" = [0.005, 0.01, 0.02]\n'
            '"planner.r_min" = [0.05, 0.06, 0.07]\n"planner.algorithm" = ["pfm", "rbpf"]\n')
    out = _fake_study(tmp_path, text, lambda p, seed: "reached" if p["planner.algorithm"] == "rbpf" else "failed")
    drawn = {}
    real = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda fig, fname, **kw: drawn.setdefault(Path(fname).name, fig) and real(fig, fname, **kw))
    assert main(["report", str(out), "--axes", "planner.algorithm", "planner.r_min"]) == 0
    fig = next(f for name, f in drawn.items() if "success-centre" in name)
    assert fig._suptitle.get_text() == "success rate of valid plans (centre; pooled: planner.delta)"
    ax = next(a for a in fig.axes if a.images)
    assert ax.get_xlabel() == "planner.algorithm" and ax.get_ylabel() == "planner.r_min"
    assert np.array_equal(ax.images[0].get_array().filled(np.nan), [[0.0, 1.0]] * 3)  # pfm failed, rbpf reached
    drawn.clear()
    assert main(["report", str(out), "--figures", str(tmp_path / "default")]) == 0  # the most varied two, then a panel each
    assert next(f for name, f in drawn.items() if "success-centre" in name)._suptitle.get_text() == "success rate of valid plans (centre)"
    capsys.readouterr()
    assert main(["report", str(out), "--axes", "subject.height"]) == 2
    assert capsys.readouterr().err.strip() == (f"foam-mj: error: --axes 'subject.height': not a swept key that varies in {out}; "
                                              "choose from ['planner.delta', 'planner.r_min', 'planner.algorithm']")


def test_report_axes_on_rows_where_no_key_varies_yet_say_so(tmp_path, capsys):
    """A study run with --limit 1 so far (one value of each key in its rows): `report --axes planner.delta` said
    'choose from []', a list with nothing to choose."""
    text = 'scenario = "obstacle"\nsmoothers = "none"\nreplay = "none"\n[grid]\n"planner.delta" = [0.005]\n'
    out = _fake_study(tmp_path, text, lambda p, seed: "reached")
    assert main(["report", str(out), "--axes", "planner.delta"]) == 2
    assert capsys.readouterr().err.strip() == (f"foam-mj: error: --axes 'planner.delta': not a swept key that varies in {out}; "
                                              "no swept key varies in its rows yet (run more of the sweep, or leave --axes out)")


def test_a_run_by_another_version_on_a_folder_says_so(tmp_path, capsys):
    """Rows made by another foam-mj or MuJoCo may join a study (each names its versions), but not silently."""
    import mujoco

    import foam_mj

    spec = write(tmp_path, 'scenario = "obstacle"\nsmoothers = "none"\nreplay = "none"\n')
    out = tmp_path / "out"
    run_sweep(load_sweep(spec), out, workers=1, progress=False)
    manifest = json.loads((out / "sweep.json").read_text())
    manifest["versions"] = {"foam_mj_version": "0.0.1", "mujoco_version": "3.3.0"}
    (out / "sweep.json").write_text(json.dumps(manifest))
    capsys.readouterr()
    run_sweep(load_sweep(spec), out, workers=1)
    assert capsys.readouterr().err.splitlines()[0] == (
        f"sweep: {out} holds rows made by foam-mj 0.0.1, MuJoCo 3.3.0; this run is foam-mj {foam_mj.__version__}, "
        f"MuJoCo {mujoco.__version__} (each row names its versions)")


def test_the_readme_query_counts_success_over_the_valid_plans_as_the_report_does(tmp_path, monkeypatch):
    """The README's query averaged 'reached' over every row, invalid ones included (no problem to solve), so a cell the
    report drew as a success of 1.00 read 0.67 in DuckDB; it now filters them out, as the report does."""
    duckdb = pytest.importorskip("duckdb")
    text = f'scenario = "obstacle"\nseeds = 3\nsmoothers = "convex"\nreplay = "none"\n[grid]\n"planner.delta" = [0.005]\n"obstacle.size" = {json.dumps(SIZES)}\n'
    out = _fake_study(tmp_path, text, lambda p, seed: "invalid" if seed == 0 else "reached")
    (tmp_path / "study").symlink_to(out)
    monkeypatch.chdir(tmp_path)
    query = re.findall(r"```sql\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)[0]
    assert [(r[2], r[-1]) for r in duckdb.sql(query).fetchall()] == [(1.0, 3), (1.0, 3)]  # success, plans


def test_report_on_a_file_or_a_missing_folder_says_which(tmp_path, capsys):
    """`foam-mj report result.json` said 'sweep folder not found: result.json' of a file that is there."""
    result = tmp_path / "result.json"
    result.write_text("{}")
    for given, words in ((result, f"{result} is a file, not a sweep folder (the --out folder of foam-mj sweep)"),
                         (tmp_path / "missing", f"sweep folder not found: {tmp_path / 'missing'}")):
        assert main(["report", str(given)]) == 2
        err = capsys.readouterr().err.strip()
        assert err == f"foam-mj: error: {words}", err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.json"]


@pytest.mark.parametrize("top, named", [
    ("seeds = [1, 9223372036854775808]\n", "'seeds' must be a count >= 1 or a non-empty list of integers in [0, 2**63 - 1]"),
    ("seeds = 3\nscenario = 3\n", "field 'scenario' must be a built-in scenario name or a TOML path (text), got 3"),
])
def test_a_seed_past_2_63_or_a_scenario_that_is_not_text_is_named_exit_2_and_creates_nothing(tmp_path, capsys, top, named):
    # a seed of 2**63 was an internal error (exit 1, OverflowError) after --out was created; scenario = 3 said it was missing
    spec = write(tmp_path, (top if "scenario" in top else f'scenario = "obstacle"\n{top}') + '[grid]\n"planner.delta" = [0.005]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and named in err
    assert not out.exists()


def test_a_study_where_one_cell_reached_reads_that_value_on_the_colour_bar_and_names_its_grey_cells(tmp_path):
    """With one cell reached, every measure but success has one value: the colour bar spanned it +- 1e-9 and read
    '2.00 ... 2.75' under an offset '1e-9+8.620876132e1' (min clearance 86.2 mm); the grey cell beside it (no plan
    reached) had no legend. The bar now has one tick, the value; a legend names the grey cells."""
    from foam_mj.report import NOT_REACHED_LABEL, _data, _figure, _measures, _torque_column, envelope_axes, load

    spec = write(tmp_path, 'scenario = "obstacle"\nsmoothers = "none"\nreplay = "kinematic"\n[grid]\n"planner.max_bubbles" = [5, 200000]\n')
    def row(task, k, path):
        budget = dict(task.params)["planner.max_bubbles"]
        return {"key": k, "planner.max_bubbles": budget, "seed": task.seed, "smoother": path, "outcome": "reached" if budget > 5 else "failed",
                "f": 3.258 if budget > 5 else None, "min_clearance": 0.08620876132 if budget > 5 else None,
                "peak_torque_knee_flexion": 91.6 if budget > 5 else None}

    out = _stored_rows(spec, row)
    manifest, table = load(out)
    (x,) = envelope_axes(manifest, table)
    data = _data(table)
    mask, invalid = data["smoother"] == "centre", data["outcome"] == "invalid"
    seen = {}
    for stem, title, unit, cmap, agg, lims in _measures(data, _torque_column(table.column_names)):
        fig = _figure(title, unit, cmap, lims, agg, x, None, None, mask, invalid)
        assert fig is not None, stem
        fig.canvas.draw()
        bar = fig.axes[-1]
        seen[stem] = ([t.get_text() for t in bar.get_yticklabels()], bar.yaxis.get_offset_text().get_text(),
                      [t.get_text() for t in fig.legends[0].get_texts()] if fig.legends else [])
    assert seen["min_clearance"] == (["86.21"], "", [NOT_REACHED_LABEL])
    assert seen["f"] == (["3.258"], "", [NOT_REACHED_LABEL])
    assert seen["knee_torque"] == (["91.6"], "", [NOT_REACHED_LABEL])
    assert seen["success"][1:] == ("", []) and len(seen["success"][0]) > 2  # success keeps its 0-1 scale; its cells all coloured


def test_report_says_over_which_keys_it_drew_and_why_a_measure_has_no_figure(tmp_path, capsys):
    """A study where no plan reached printed only 'wrote 2 figure(s)': not which, over what, nor why the clearance
    and f figures were missing. It now says the axes and names each measure left out and why."""

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = [0, 1]\nsmoothers = "convex"\nreplay = "kinematic"\n[grid]\n"planner.max_bubbles" = [5, 10]\n')
    out = _stored_rows(spec, lambda task, k, path: {"key": k, **dict(task.params), "seed": task.seed, "smoother": path,
                                                    "outcome": "failed", "reason": "bubble budget"})
    assert main(["report", str(out)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-2] == ("figures over x: planner.max_bubbles; no min_clearance figure for centre, convex: no replayed plan reached; "
                         "no f figure for centre, convex: no plan reached; no knee_torque figure for centre, convex: no replayed plan reached")
    assert lines[-1] == f"wrote 2 figure(s), summary.txt and summary.json to {out / 'report'}"


def test_plan_time_is_the_planners_own_time_not_a_workers_first_imports(tmp_path):
    """plan_time of a reached row was the wall time around the planner, which in a worker's first plan also held the
    first import of scipy.spatial (measured 0.64 s there against 0.22 s for the same work later): whichever cell a
    worker ran first looked slow. It is now the planner's own clock, as a failed row's (two cells of identical
    work, the first run by a fresh process: their plan times agree)."""
    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = [0]\nsmoothers = "none"\nreplay = "none"\n[grid]\n"planner.max_bubbles" = [200000, 300000]\n')
    code = ("import json, sys; from foam_mj.sweep_file import load_sweep; from foam_mj.sweep import run_task\n"
            "assert 'scipy.spatial' not in sys.modules\n"
            f"rows = [run_task(t)[0] for t in load_sweep({str(spec)!r}).tasks()]\n"
            "print(json.dumps([(r['outcome'], r['bubbles'], r['plan_time'], r['task_time']) for r in rows]))")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    (first, second) = json.loads(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout)
    assert first[:2] == second[:2] == ["reached", first[1]]  # the same foam: its budget is never reached
    # The first task's imports are in its task time, not its plan time: its time outside the planner exceeds the
    # second's (0.10 s against a few ms on a fast machine, 0.4 s on a slow one; a fixed 0.1 s failed on the fast one).
    assert first[3] - first[2] > (second[3] - second[2]) + 0.03, (first, second)
    assert first[2] < 1.5 * second[2] + 0.05, (first, second)


def test_the_summary_counts_success_over_the_valid_plans_as_the_figure_does(tmp_path):
    """The summary's success was reached / every plan: a study whose valid plans all reached, beside as many
    invalid ones (a subject too tall for the box), read '4 (50%)' while its success figure drew 1.00 and the README's
    query gave 1.0. It is now of the valid plans, and '-' (None in summary.json) where no plan was valid."""
    from foam_mj.report import format_summary, load, summary

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = [0, 1]\nsmoothers = "none"\nreplay = "none"\n[grid]\n"subject.height" = [1.55, 1.95]\n')
    def row(task, k, path):
        tall = dict(task.params)["subject.height"] > 1.9
        return {"key": k, **dict(task.params), "seed": task.seed, "smoother": path, "outcome": "invalid" if tall else "reached",
                "f": None if tall else 3.0}

    out = _stored_rows(spec, row)
    (line,) = summary(*load(out))
    assert (line["plans"], line["reached"], line["invalid"], line["success"]) == (4, 2, 2, 1.0)
    assert re.search(r"centre\s+4\s+2 \(100%\)", format_summary([line]))
    none_valid = {**line, "reached": 0, "invalid": 4, "success": None}
    assert re.search(r"centre\s+4\s+0 \(-\)", format_summary([none_valid]))


def test_the_summary_never_rounds_a_failure_away_to_100_percent_nor_a_success_to_0(tmp_path):
    """233 of 234 valid plans reached in a 240-plan study (measured: random subjects and boxes, pfm and rbpf): the
    summary read '233 (100%)' beside 'failed 1', the share rounded to whole percents. A share strictly between 0 and 1
    now never reads 100% nor 0%: '99.6%' and, for 1 of 240, '0.4%'; whole percents elsewhere, as before."""
    from foam_mj.report import format_summary, load, summary

    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = 240\nsmoothers = "none"\nreplay = "none"\n')
    out = _stored_rows(spec, lambda task, k, path: {"key": k, "seed": task.seed, "smoother": path,
                                                    "outcome": "failed" if task.seed == 7 else "reached", "f": 3.0})
    (line,) = summary(*load(out))
    assert (line["plans"], line["reached"], line["failed"]) == (240, 239, 1)
    text = format_summary([line])
    assert re.search(r"centre\s+240\s+239 \(99\.6%\)\s+1\s", text), text
    assert re.search(r"\(0\.4%\)", format_summary([{**line, "reached": 1, "failed": 239, "success": 1 / 240}]))
    assert re.search(r"\(<0\.1%\)", format_summary([{**line, "success": 1 / 2000}]))
    assert re.search(r"\(>99\.9%\)", format_summary([{**line, "success": 1999 / 2000}]))
    assert re.search(r"\(50%\)", format_summary([{**line, "success": 0.5}]))
    assert re.search(r"\(100%\)", format_summary([{**line, "success": 1.0}]))


def test_a_sweep_that_ends_normally_does_not_say_interrupted(tmp_path):
    """Run as the `foam-mj` console script runs (a script that imports foam_mj.__main__, whose SIGTERM handler prints
    "foam-mj: interrupted"), each spawned pool worker re-ran the script as its main module and kept that handler; the
    pool's workers are ended with SIGTERM when the sweep is done, so a sweep that succeeded (exit 0) printed
    "foam-mj: interrupted" once per worker. A sweep over subjects, 2 plans on 2 workers."""
    spec = write(tmp_path, 'scenario = "obstacle"\nseeds = [1]\nsmoothers = "convex"\nreplay = "kinematic"\n'
                           '[grid]\n"subject.height" = [1.5, 1.75]\n')
    script = write(tmp_path, "import sys\nfrom foam_mj.__main__ import main\nif __name__ == '__main__':\n    sys.exit(main())\n", "foam-mj")  # as pip writes it
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, str(script), "sweep", str(spec), "--out", str(tmp_path / "out"), "--workers", "2"],
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "interrupted" not in done.stderr, done.stderr
    rows = check_folder(tmp_path / "out")
    assert sorted({r["subject.height"] for r in rows}) == [1.5, 1.75] and all(r["outcome"] == "reached" for r in rows), rows
