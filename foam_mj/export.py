"""``foam-mj export``: a saved result's timed trajectory as a table a controller can load.

One row per sample at ``hz`` samples per second, t = k / hz for k = 0, 1, ... up to the duration, plus a
last row at the end of the motion when the duration is not a whole number of periods (the leg at rest
at the goal). Columns: ``time_s``, then for each configuration joint, in the model's configuration order
and MuJoCo's qpos units,

    <joint>.q     position      rad (hinge) or m (slide)
    <joint>.qd    velocity      rad/s or m/s
    <joint>.qdd   acceleration  rad/s^2 or m/s^2
    <joint>.tau   joint torque  N m, or force N: mujoco.mj_inverse at (q, qd, qdd), other joints at qpos0
    <joint>.power tau * qd      W

The trajectory is rebuilt from the result's waypoints and rosary with the result's limits and time law
(:func:`foam_mj.timing.time_path`, the same code ``plan`` ran), and evaluated exactly at the export's
times from its curve and time law, so any rate is exact, not interpolated between stored samples.

Formats (units stored in the file):

* ``csv``: a first line starting with ``#`` holding the metadata as JSON (scenario, path, rate, units per
  column, MJCF), then a header line and the rows;
* ``npz``: one array per column (named as the columns) and ``metadata``, the same JSON as a string;
* ``parquet``: one column per column, the JSON under the schema metadata key ``foam_mj`` and each
  field's unit under its field metadata key ``unit`` (needs ``pyarrow``: ``pip install foam-mj[export]``).

Every file is written to a temporary file in the target folder and renamed into place when complete.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from foam_mj.errors import FoamError, unknown_names

FORMATS = ("csv", "npz", "parquet")
DEFAULT_HZ = 500.0
#: Highest export rate accepted (samples per second).
MAX_HZ = 100_000.0


@dataclass(frozen=True)
class ExportTable:
    """Columns (name -> (T,) array, ``time_s`` first) and their units, with the export's metadata."""

    columns: dict[str, np.ndarray]
    units: dict[str, str]
    metadata: dict

    @property
    def n_rows(self) -> int:
        return len(self.columns["time_s"])


def check_hz(hz) -> float:
    """``hz`` as a float in (0, MAX_HZ], or FoamError (exit 2)."""
    try:
        if isinstance(hz, (bool, np.bool_)):  # True is 1.0 to float(): a table at 1 Hz
            raise TypeError
        if isinstance(hz, str) and (not hz.isascii() or "_" in hz):  # float("５00") is 500.0 (foam_mj.arguments)
            raise ValueError
        v = float(hz)
    except (TypeError, ValueError):
        raise FoamError(f"--hz must be a number of samples per second, got {hz!r}") from None
    if not (np.isfinite(v) and 0 < v <= MAX_HZ):
        raise FoamError(f"--hz must be a number of samples per second in (0, {MAX_HZ:g}], got {hz!r}")
    return v


def pick_path(doc: dict, name: str | None) -> str:
    """The path to export: ``name`` (FoamError listing the result's paths when unknown), or by default
    the result's last path (``plan``'s smoothed one; the centre path when it is alone)."""
    names = list(doc.get("paths") or {})
    if not names:
        raise FoamError(f"the result has no paths to export (outcome: {doc.get('outcome', 'unknown')})")  # as replay says
    if name is None:
        return names[-1]
    if name not in names:
        raise FoamError(f"--path {unknown_names([name], names)} is not in the result; its paths: {', '.join(names)}")
    return name


def export_table(doc: dict, source: str | Path, path_name: str | None, hz: float = DEFAULT_HZ,
                 report: Callable[[str], None] | None = None) -> ExportTable:
    """The table of ``path_name`` of a result document (module docstring; None: :func:`pick_path`'s default).
    ``path_name`` and ``hz`` are checked as ``--path`` and ``--hz`` (:func:`pick_path`, :func:`check_hz`); ``report``
    is told what is being done (timing the path, the inverse dynamics of its samples)."""
    if not isinstance(doc, dict):  # a path was "'str' object has no attribute 'get'"
        raise TypeError(f"`doc` must be a result document (foam_mj.results.read_result(path)), got {type(doc).__name__}")
    path_name = pick_path(doc, path_name)  # an unknown name was a KeyError, hz = 0 a table of NaN
    hz = check_hz(hz)
    import mujoco

    from foam_mj.dynamics import inverse_dynamics, joint_units
    from foam_mj.results import check_ends, check_saved_trajectory, outcome_robot
    from foam_mj.rosary import Rosary
    from foam_mj.limits import Limits
    from foam_mj.timing import METHODS, time_path

    robot = outcome_robot(doc, source)
    entry = doc["paths"][path_name]
    try:
        limits = Limits.from_dict(doc["limits"]) if doc.get("limits") else Limits()
        limits.resolve(robot)  # one number per joint (the timing's ValueError was an internal error, exit 1)
        time_law = doc.get("time_law") or "own"
        if time_law not in METHODS:
            raise FoamError(f"{source}: field 'time_law' must be one of {list(METHODS)}, got {time_law!r}")
        q_init, q_goal = np.asarray(doc["q_init"], float), np.asarray(doc["q_goal"], float)
        rosary = Rosary(np.asarray(entry["rosary"]["centers"], float), np.asarray(entry["rosary"]["radii"], float), q_init, q_goal)
        path = np.asarray(entry["waypoints"], float)
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, FoamError):
            raise
        raise FoamError(f"{source}: malformed result: {type(exc).__name__}: {exc}") from None
    if path.ndim != 2 or path.shape[1] != robot.dim or len(path) != rosary.k + 1:
        raise FoamError(f"{source}: path '{path_name}' has waypoints of shape {path.shape}, expected ({rosary.k + 1}, {robot.dim})")
    check_ends(source, path_name, path, q_init, q_goal, "export")
    if not rosary.all_in_hatches(path[1:-1], tol=1e-9):
        raise FoamError(f"{source}: path '{path_name}' has waypoints outside its rosary's hatches: refusing to export it")
    if report:
        report(f"exporting: timing path '{path_name}'")
    traj = time_path(robot, path_name, path, rosary, limits, time_law)
    check_saved_trajectory(source, path_name, entry, traj, robot)  # the waypoints are exported: refuse an edited qpos

    T = traj.duration
    k = np.arange(int(np.floor(T * hz + 1e-9)) + 1)
    times = k / hz
    if T - times[-1] > 1e-9:
        times = np.append(times, T)
    if report:
        report(f"exporting: path '{path_name}', {len(times):,} samples at {hz:g} Hz ({T:.3f} s of motion)")
    q, qd, qdd = traj.evaluate(times)
    cfg, m = robot.config, robot.model
    scale = cfg.scale
    qd, qdd = qd * scale, qdd * scale
    qpos = cfg.to_qpos(q)
    dof = m.jnt_dofadr[cfg.joint_ids]
    qvel = np.zeros((len(times), m.nv))
    qacc = np.zeros((len(times), m.nv))
    qvel[:, dof] = qd
    qacc[:, dof] = qdd
    tau = inverse_dynamics(robot, qpos, qvel, qacc)[:, dof]

    columns: dict[str, np.ndarray] = {"time_s": times}
    units: dict[str, str] = {"time_s": "s"}
    for j, (joint, (uq, uqd, uqdd, utau)) in enumerate(zip(cfg.joint_names, joint_units(robot))):
        for suffix, values, unit in (
            ("q", qpos[:, cfg.qpos_index[j]], uq),
            ("qd", qd[:, j], uqd),
            ("qdd", qdd[:, j], uqdd),
            ("tau", tau[:, j], utau),
            ("power", tau[:, j] * qd[:, j], "W"),
        ):
            columns[f"{joint}.{suffix}"] = np.asarray(values, dtype=float)
            units[f"{joint}.{suffix}"] = unit
    metadata = {
        "format": "foam-mj/trajectory",
        "version": 1,
        "scenario": doc.get("scenario"),
        "path": path_name,
        "hz": hz,
        "duration_s": T,
        "time_law": time_law,
        "joints": list(cfg.joint_names),
        "units": units,
        "mjcf": doc.get("mjcf"),
        "tau": "mujoco.mj_inverse at (q, qd, qdd); other joints at qpos0; N m for hinges, N for slides",
        "mujoco": mujoco.__version__,
    }
    return ExportTable(columns, units, metadata)


# -- writers ---------------------------------------------------------------------------------------------------
def _atomic(out: Path, write) -> None:
    """Call ``write(tmp_path)`` on a temporary file in ``out``'s folder and rename it onto ``out``
    (:func:`foam_mj.atomic.atomic_path`: nothing is left behind on failure, an OSError is exit 2)."""
    from foam_mj.atomic import atomic_path

    with atomic_path(out) as tmp:
        write(tmp)


def _csv_text(table: ExportTable) -> str:
    names = list(table.columns)
    data = np.column_stack([table.columns[n] for n in names])
    buf = io.StringIO()
    buf.write("# " + json.dumps(table.metadata, separators=(",", ":")) + "\n")
    np.savetxt(buf, data, delimiter=",", header=",".join(names), comments="", fmt="%.9g")
    return buf.getvalue()


#: The file name endings each format is known by (``--out``'s suffix picks the format when none is given).
SUFFIXES = {".csv": "csv", ".npz": "npz", ".parquet": "parquet", ".pq": "parquet"}


def resolve_format(out: str | Path, fmt: str | None) -> str:
    """The table format for ``out``: ``fmt`` when given, else the one its suffix names; a known suffix of another
    format than ``fmt`` is refused (``--format npz --out e.csv`` would write NPZ into a file every reader takes for CSV)."""
    suffix = Path(out).suffix.lower()
    named = SUFFIXES.get(suffix)
    if fmt is None:
        if named is None:
            raise FoamError(f"--out {out}: give --format {'|'.join(FORMATS)}, or an --out ending in "
                            f"{', '.join(SUFFIXES)} to pick it")
        return named
    if fmt not in FORMATS:
        raise FoamError(f"--format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    if named is not None and named != fmt:
        raise FoamError(f"--out {out} ends in {suffix}, a {named} file, but --format is {fmt}: "
                        f"give --format {named} or an --out ending in .{fmt}")
    return fmt


def write_table(table: ExportTable, out: str | Path, fmt: str) -> Path:
    """Write ``table`` to ``out`` as csv, npz or parquet, atomically."""
    out = Path(out)
    if fmt == "csv":
        text = _csv_text(table)
        _atomic(out, lambda p: p.write_text(text))
    elif fmt == "npz":
        arrays: dict[str, Any] = dict(table.columns)  # (np.savez's keywords)
        arrays["metadata"] = np.array(json.dumps(table.metadata))

        def write_npz(p: Path) -> None:
            with open(p, "wb") as f:
                np.savez(f, **arrays)

        _atomic(out, write_npz)
    elif fmt == "parquet":
        pa, pq = require_pyarrow()
        fields = [pa.field(n, pa.float64(), metadata={"unit": table.units[n]}) for n in table.columns]
        schema = pa.schema(fields, metadata={"foam_mj": json.dumps(table.metadata)})
        arrow = pa.table({n: pa.array(v) for n, v in table.columns.items()}, schema=schema)
        _atomic(out, lambda p: pq.write_table(arrow, p))
    else:
        raise FoamError(f"--format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    return out


def require_pyarrow():
    """(pyarrow, pyarrow.parquet), or FoamError with the install hint."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise FoamError("--format parquet needs pyarrow: pip install 'foam-mj[export]'") from None
    return pa, pq
