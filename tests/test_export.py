"""`foam-mj plan --json` then `foam-mj export`: the trajectory table in CSV, NPZ and Parquet, its units,
torques that an independent mj_inverse reproduces, the loads in the JSON and the recording, bad input
(exit 2) and limits no timing can meet (exit 3)."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from foam_mj.cli import main
from foam_mj.recording import read_blueprint, read_recording

from conftest import MODELS, messages

JOINTS = ("hip_flexion", "knee_flexion", "hip_displacement")
SUFFIXES = ("q", "qd", "qdd", "tau", "power")


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    out = tmp_path_factory.mktemp("export")
    js, rrd = out / "r.json", out / "r.rrd"
    assert main(["plan", "--scene", "obstacle", "--json", str(js), "--rrd", str(rrd)]) == 0
    return {"dir": out, "json": js, "rrd": rrd, "doc": json.loads(js.read_text())}


def read_csv(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    lines = path.read_text().splitlines()
    assert lines[0].startswith("# ")
    meta = json.loads(lines[0][2:])
    names = lines[1].split(",")
    data = np.loadtxt(lines[2:], delimiter=",", ndmin=2)
    return meta, {n: data[:, i] for i, n in enumerate(names)}


def independent_inverse(mjcf: str, cols: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """mj_inverse on the exported q, qd, qdd with plain MuJoCo: joints found by name, others at qpos0."""
    m = mujoco.MjModel.from_xml_path(mjcf)
    d = mujoco.MjData(m)
    ids = {j: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in JOINTS}
    tau = {j: np.empty(len(cols["time_s"])) for j in JOINTS}
    for i in range(len(cols["time_s"])):
        d.qpos[:] = m.qpos0
        d.qvel[:] = 0.0
        d.qacc[:] = 0.0
        for j, jid in ids.items():
            d.qpos[m.jnt_qposadr[jid]] = cols[f"{j}.q"][i]
            d.qvel[m.jnt_dofadr[jid]] = cols[f"{j}.qd"][i]
            d.qacc[m.jnt_dofadr[jid]] = cols[f"{j}.qdd"][i]
        mujoco.mj_inverse(m, d)
        for j, jid in ids.items():
            tau[j][i] = d.qfrc_inverse[m.jnt_dofadr[jid]]
    return tau


def test_the_done_when_command_exports_a_csv_with_units_and_reproducible_torques(planned, capsys):
    out = planned["dir"] / "t.csv"
    assert main(["export", str(planned["json"]), "--format", "csv", "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    meta, cols = read_csv(out)
    assert list(cols) == ["time_s"] + [f"{j}.{s}" for j in JOINTS for s in SUFFIXES]
    assert meta["units"]["hip_flexion.tau"] == "N m" and meta["units"]["hip_displacement.tau"] == "N"
    assert meta["units"]["knee_flexion.q"] == "rad" and meta["units"]["hip_displacement.qdd"] == "m/s^2"
    assert meta["path"] == "optimal" and meta["hz"] == 500
    t = cols["time_s"]
    np.testing.assert_allclose(np.diff(t), 1 / 500, atol=1e-9)
    assert t[-1] == pytest.approx(meta["duration_s"])
    # Torques: an independent mj_inverse on the exported q, qd, qdd agrees within 1 % of each joint's peak.
    ref = independent_inverse(planned["doc"]["mjcf"], cols)
    for j in JOINTS:
        peak = np.abs(ref[j]).max()
        assert np.max(np.abs(cols[f"{j}.tau"] - ref[j])) <= 0.01 * peak, j
        np.testing.assert_allclose(cols[f"{j}.power"], cols[f"{j}.tau"] * cols[f"{j}.qd"], rtol=1e-6, atol=1e-6 * peak)
    # q, qd, qdd are one motion: each integrates to the previous (trapezoid rule, within 1 % of the range
    # for qd -> q; 2 % for qdd -> qd, since toppra's accelerations jump between samples).
    for j in JOINTS:
        for lo, hi, tol in (("q", "qd", 0.01), ("qd", "qdd", 0.02)):
            integral = np.concatenate([[0.0], np.cumsum(0.5 * (cols[f"{j}.{hi}"][1:] + cols[f"{j}.{hi}"][:-1]) * np.diff(t))])
            x = cols[f"{j}.{lo}"]
            assert np.max(np.abs(x[0] + integral - x)) <= tol * max(np.ptp(x), 1e-9), (j, lo)
    # At 500 Hz (the model's timestep) the exported positions are the result's own trajectory samples.
    qpos = np.asarray(planned["doc"]["paths"]["optimal"]["qpos"])
    names = planned["doc"]["qpos_joints"]
    for j in JOINTS:
        np.testing.assert_allclose(cols[f"{j}.q"], qpos[: len(t), names.index(j)], atol=1e-8)


def test_export_loads_neither_the_pipeline_nor_its_smoothers_or_solvers(planned, tmp_path):
    """`foam-mj export` re-times one saved path: it imported the whole pipeline (every smoother, Clarabel) for that,
    about a third of a second of start-up; it loads only the timing code plan ran."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from foam_mj.cli import main\n"
        f"assert main(['export', {str(planned['json'])!r}, '--out', {str(tmp_path / 't.csv')!r}]) == 0\n"
        "print('loaded:', ','.join(m for m in ('foam_mj.pipeline', 'foam_mj.smoothing', 'clarabel') if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines()[-1] == "loaded: "


def test_npz_and_parquet_hold_the_same_table_and_their_units(planned):
    import pyarrow.parquet as pq

    csv, npz, parquet = (planned["dir"] / f"t200.{ext}" for ext in ("csv", "npz", "parquet"))
    for fmt, out in (("csv", csv), ("npz", npz), ("parquet", parquet)):
        assert main(["export", str(planned["json"]), "--path", "centre", "--format", fmt, "--out", str(out), "--hz", "200"]) == 0
    _, cols = read_csv(csv)
    with np.load(npz) as z:
        meta = json.loads(str(z["metadata"]))
        assert meta["path"] == "centre" and meta["units"]["knee_flexion.power"] == "W"
        for name, values in cols.items():
            np.testing.assert_allclose(z[name], values, rtol=1e-8, atol=1e-8)
    table = pq.read_table(parquet)
    assert table.column_names == list(cols)
    assert json.loads(table.schema.metadata[b"foam_mj"])["hz"] == 200
    assert table.schema.field("hip_flexion.tau").metadata[b"unit"] == b"N m"
    for name, values in cols.items():
        np.testing.assert_allclose(table.column(name).to_numpy(), values, rtol=1e-8, atol=1e-8)
    assert np.diff(cols["time_s"])[:-1] == pytest.approx(np.full(len(cols["time_s"]) - 2, 1 / 200))


@pytest.mark.parametrize(
    "args, message",
    [
        (["--path", "nope", "--format", "csv"], "--path 'nope' is not in the result; its paths: centre, optimal"),
        (["--hz", "0", "--format", "csv"], "--hz must be"),
        (["--hz", "nan", "--format", "csv"], "--hz must be"),
        (["--hz", "fast", "--format", "csv"], "--hz must be"),
        ([], "give --format csv|npz|parquet, or an --out ending in .csv, .npz, .parquet, .pq"),
    ],
)
def test_bad_export_input_is_one_line_and_exit_2_with_no_file(planned, tmp_path, capsys, args, message):
    out = tmp_path / "x.out"
    assert main(["export", str(planned["json"]), *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["limits"]["velocity"].pop(), "limits `velocity` must have 3 numbers"),
    (lambda d: d.__setitem__("mjcf", 5), "field 'mjcf' must be the path of the MJCF scene (a string), got 5"),
    (lambda d: d.__setitem__("seed", "x"), "field 'seed' must be an integer in [0, 2**63 - 1] (as plan's --seed), got 'x'"),
    (lambda d: d.__setitem__("seed", 2**63), "field 'seed' must be an integer in [0, 2**63 - 1] (as plan's --seed), got 9223372036854775808"),
    (lambda d: d["q_init"].__setitem__(0, 10**400), "field 'q_init'"),
    (lambda d: d["paths"]["optimal"]["qpos"][3].__setitem__(0, 10**400), "path 'optimal': qpos row 3"),
])
def test_a_damaged_result_is_one_line_and_exit_2_with_no_file(planned, tmp_path, capsys, edit, message):
    """A limits list one short reached the timing (a ValueError: internal error, exit 1); a number for 'mjcf' and a
    string for 'seed' were a TypeError and an int() message that named no field; an integer beyond a float's range
    (JSON has no limit) in q_init or a qpos row was an OverflowError (exit 1), and a seed of 2**63 was accepted."""
    doc = json.loads(json.dumps(planned["doc"]))
    edit(doc)
    (tmp_path / "in").mkdir()
    src = tmp_path / "in" / "r.json"
    src.write_text(json.dumps(doc))
    out = tmp_path / "x.csv"
    assert main(["export", str(src), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert not out.exists()


def test_the_format_follows_the_out_suffix_and_a_mismatch_is_refused(planned, tmp_path, capsys):
    out = tmp_path / "t.npz"
    assert main(["export", str(planned["json"]), "--out", str(out), "--hz", "100"]) == 0
    assert "(npz)" in capsys.readouterr().out
    with np.load(out) as z:
        assert "time_s" in z.files
    wrong = tmp_path / "t.csv"
    assert main(["export", str(planned["json"]), "--format", "npz", "--out", str(wrong)]) == 2
    err = capsys.readouterr().err
    assert "--out " + str(wrong) + " ends in .csv, a csv file, but --format is npz" in err and err.count("\n") == 1
    assert not wrong.exists()


def test_an_unwritable_export_target_is_exit_2(planned, tmp_path, capsys):
    assert main(["export", str(planned["json"]), "--format", "csv", "--out", str(tmp_path / "missing" / "t.csv")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_the_json_and_recording_carry_torques_and_power(planned):
    doc = planned["doc"]
    assert doc["time_law"] == "toppra"
    assert doc["limits"]["torque"] == [400.0, 400.0, 3000.0]
    for name, entry in doc["paths"].items():
        dyn = entry["dynamics"]
        assert dyn["joints"] == list(JOINTS)
        assert all(0 < u <= 1 for u in dyn["peak_use"]), name
        assert all(p >= r > 0 for p, r in zip(dyn["peak_torque"], dyn["rms_torque"]))
    rows = read_recording(planned["rrd"], static=False)
    for name, entry in doc["paths"].items():
        assert rows[f"plots/torque/{name}"] == rows[f"plots/power/{name}"] == len(entry["times"])  # a series per joint
    origins = {v["origin"] for v in read_blueprint(planned["rrd"])}
    assert {"plots/torque", "plots/power"} <= origins


def test_plan_prints_the_loads_beside_the_human_reference(tmp_path, capsys):
    assert main(["plan", "--scene", "obstacle", "--smoother", "convex", "--no-rrd", "--time-law", "own"]) == 0
    out = capsys.readouterr().out
    assert "joint loads (mj_inverse along each trajectory, timed by own)" in out
    assert "human reference, swing of normal walking (Winter (2009)): peak hip 0.34 N m/kg, knee 0.26 N m/kg" in out


def _tight_scenario(tmp_path: Path, torque: str) -> Path:
    p = tmp_path / "tight.toml"
    p.write_text(
        f'scene = "{MODELS / "obstacle.xml"}"\nq_init = [0.2, 0.3, 0.08]\nq_goal = [0.45, 0.4536, 1.45]\n'
        f"[planner]\nK = 10\nr_min = 0.07\n[limits]\ntorque = {torque}\n"
    )
    return p


def test_a_torque_limit_below_gravity_is_exit_3_naming_the_joint(tmp_path, capsys):
    js = tmp_path / "r.json"
    code = main(["plan", "--scene", str(_tight_scenario(tmp_path, "[400.0, 3.0, 3000.0]")), "--no-rrd", "--json", str(js)])
    err = capsys.readouterr().err
    assert code == 3, err
    assert "torque limit of knee_flexion: gravity alone needs" in err and "over its limit 3.0 N m by" in err
    assert len(messages(err)) == 1 and not js.exists()  # besides the progress log off a terminal
    assert "--no-replay plans and writes them without timing" in err
    assert main(["plan", "--scene", str(_tight_scenario(tmp_path, "[400.0, 3.0, 3000.0]")), "--no-rrd", "--no-replay",
                 "--json", str(js)]) == 0  # the hint holds: the certified paths, untimed
    assert json.loads(js.read_text())["paths"]


def test_a_malformed_limits_table_is_exit_2(tmp_path, capsys):
    assert main(["plan", "--scene", str(_tight_scenario(tmp_path, "[400.0, 3.0]")), "--no-rrd"]) == 2
    assert "[limits] limits `torque` must have 3 numbers" in capsys.readouterr().err
    assert main(["plan", "--scene", str(_tight_scenario(tmp_path, "[400.0, -3.0, 1.0]")), "--no-rrd"]) == 2
    assert "[limits] field 'torque'" in capsys.readouterr().err


def test_a_subject_scaled_scenario_loads_and_exports_with_the_scaled_model(tmp_path, capsys):
    """The torques are those of the scenario's compiled (subject-scaled) model: the JSON's per-kilogram
    figures use the subject's mass, and the export agrees with mj_inverse on the scene saved beside the
    result, not with the unscaled leg."""
    toml = tmp_path / "small.toml"
    toml.write_text(
        f'scene = "{MODELS / "obstacle.xml"}"\nq_init = [0.2, 0.3, 0.08]\nq_goal = [0.45, 0.4536, 1.45]\n'
        "[planner]\nK = 10\nr_min = 0.07\n[subject]\nheight = 1.62\nmass = 58.0\n"
    )
    js, csv = tmp_path / "r.json", tmp_path / "t.csv"
    assert main(["plan", "--scene", str(toml), "--smoother", "convex", "--no-rrd", "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    assert doc["paths"]["convex"]["dynamics"]["body_mass"] == 58.0
    assert main(["export", str(js), "--format", "csv", "--out", str(csv)]) == 0
    capsys.readouterr()
    _, cols = read_csv(csv)
    scaled = independent_inverse(doc["mjcf"], cols)
    plain = independent_inverse(str(MODELS / "obstacle.xml"), cols)
    for j in JOINTS:
        peak = np.abs(scaled[j]).max()
        assert np.max(np.abs(cols[f"{j}.tau"] - scaled[j])) <= 0.01 * peak, j
    assert np.max(np.abs(plain["hip_flexion"] - scaled["hip_flexion"])) > 0.05 * np.abs(scaled["hip_flexion"]).max()


def test_export_table_in_python_checks_its_path_and_rate(planned):
    # From Python an unknown path was a bare KeyError and hz = 0 a one-row table of NaN (silently).
    from foam_mj.errors import FoamError
    from foam_mj.export import export_table

    with pytest.raises(FoamError, match=r"--path 'nope' is not in the result; its paths: centre, optimal"):
        export_table(planned["doc"], planned["json"], "nope")
    for hz in (0, None, "fast"):
        with pytest.raises(FoamError, match="--hz must be a number of samples per second"):
            export_table(planned["doc"], planned["json"], "optimal", hz)
    table = export_table(planned["doc"], planned["json"], None, 50)  # None: the last path, as the command
    assert np.all(np.isfinite(table.columns["time_s"])) and table.columns["time_s"][1] == pytest.approx(0.02)


def test_export_table_in_python_names_a_document_or_rate_of_the_wrong_type(planned):
    """A path given for the document was "'str' object has no attribute 'get'"; hz = True made a table at 1 Hz."""
    from foam_mj.errors import FoamError
    from foam_mj.export import export_table

    with pytest.raises(TypeError, match=r"`doc` must be a result document \(foam_mj.results.read_result\(path\)\), got PosixPath"):
        export_table(planned["json"], planned["json"], None)
    with pytest.raises(FoamError, match="--hz must be a number of samples per second, got True"):
        export_table(planned["doc"], planned["json"], None, True)


def test_export_says_what_it_is_doing(planned):
    """`export --hz 100000` of a 2 s path worked 5-10 s without a word (timing, inverse dynamics of every sample,
    writing); it now reports each step, with the number of samples."""
    from foam_mj.export import export_table

    messages: list[str] = []
    table = export_table(planned["doc"], planned["json"], "optimal", 2000, report=messages.append)
    duration = table.metadata["duration_s"]
    assert messages == ["exporting: timing path 'optimal'",
                        f"exporting: path 'optimal', {table.n_rows:,} samples at 2000 Hz ({duration:.3f} s of motion)"]


def test_a_failed_plan_s_result_is_refused_naming_the_file_and_its_outcome(tmp_path, capsys):
    """export of a failed plan's result said 'the result has no paths to export (planning failed?)': no file named, a
    guess where replay and verify give the outcome the result records."""
    result = tmp_path / "failed.json"
    assert main(["plan", "--scene", "obstacle", "--planner", "pfm", "--time-limit", "0.001", "--no-rrd", "--json", str(result)]) == 3
    capsys.readouterr()
    assert main(["export", str(result), "--out", str(tmp_path / "t.csv")]) == 2
    assert capsys.readouterr().err == f"foam-mj: error: {result}: the result has no paths to export (outcome: time budget)\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["failed.json"]
