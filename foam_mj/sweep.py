"""Studies at scale: a sweep file, its tasks, and the rows they produce.

A sweep file (TOML) names a base scenario and the values to try::

    scenario = "obstacle"            # a built-in scenario or a TOML path (relative to the sweep file)
    seeds = [1, 2, 3]                # or a count: seeds = 3 means 0, 1, 2 (default: the scenario's seed)
    smoothers = "convex"             # as ``foam-mj plan --smoother`` (default: optimal)
    replay = "dynamic"               # "dynamic" (default: servos under gravity), "kinematic" (clearance,
                                     # joint torques by inverse dynamics) or "none" (paths only)
    [grid]                           # every combination of these values
    "planner.delta" = [0.005, 0.01]
    "q_goal" = [[0.45, 0.4536, 1.45], [0.40, 0.45, 1.45]]
    [random]                         # and/or `samples` random draws (each combined with every grid point;
                                     # a draw that repeats an earlier one is planned once)
    samples = 20
    seed = 0
    [random.uniform]                 # uniform in [low, high]; integers when both are; lists element-wise
    "planner.r_min" = [0.05, 0.09]
    [random.choice]                  # one of the listed values
    "planner.K" = [6, 8, 10]

A swept key is a dotted path into the scenario's TOML table (``planner.delta`` is the ``delta`` field of
``[planner]``); the value replaces that field *before* the scenario is validated, so every field the
scenario format knows can be swept and a wrong key or value is named by the scenario's own check.
Every value of every key is checked that way before any planning (:func:`foam_mj.sweep_file.load_sweep`); a combination
that is only wrong together (a goal in collision with a taller obstacle, say), or a value that puts the
start or goal within the margin of an obstacle (a problem of the study, not a bad value), becomes a row
with outcome ``invalid``.

A *task* is one (parameters, seed): one plan, smoothed by every requested smoother, replayed. It gives
one *row* per path (``centre`` always, plus the smoothers' paths), identified by a deterministic key,
the hash of (parameters, seed, path) (:func:`row_key`); the engines (foam_mj.sweep_run) skip rows whose
key is already in the output. The row's columns (:meth:`Sweep.columns`) are plain: one per swept key (the
dotted key is the column name; list values are stored as their JSON text), then ``seed``, ``smoother``
(the path name), ``outcome`` and ``reason`` (why not reached; a path that no timing fits the limits is ``failed``
while the task's other paths keep theirs), the
times, the foam's size, the path's measures, its replay and, when replayed, the peak joint torque along
the timed trajectory by inverse dynamics (``peak_torque_<joint>``, foam_mj.dynamics: N m for hinges, N for
slides); every row also names the foam-mj and MuJoCo versions that made it.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import time
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from foam_mj.errors import FoamError, PlanningFailed, ScenarioError

FORMAT = "foam-mj/sweep"
VERSION = 1
REPLAYS = ("dynamic", "kinematic", "none")
#: reached: the plan reached the goal; failed: it did not (budget, queue empty) or no timing fits the limits;
#: invalid: the combination is no valid problem (a goal in collision, a start too close for r_min);
#: error: anything else (a bug, a solver failure), with the exception in ``reason``.
OUTCOMES = ("reached", "failed", "invalid", "error")
#: The most plans one sweep file may hold: its row keys are kept in memory, and its tasks counted before the first
#: plan (a 10-million-plan study is about 1,500 core-hours: split bigger ones into several sweep files).
MAX_TASKS = 10_000_000
#: The result columns after the swept keys, with their Arrow type names (peak torques are added per joint).
RESULT_COLUMNS: tuple[tuple[str, str], ...] = (
    ("seed", "int64"),
    ("smoother", "string"),
    ("outcome", "string"),
    ("reason", "string"),
    ("scenario", "string"),
    ("plan_time", "float64"),  # seconds growing the foam
    ("smooth_time", "float64"),  # seconds of this path's smoother
    ("task_time", "float64"),  # seconds of the whole task (plan, every smoother, every replay)
    ("bubbles", "int64"),  # bubbles in the foam
    ("rosary", "int64"),  # bubbles in the rosary
    ("length", "float64"),
    ("angle_term", "float64"),
    ("f", "float64"),  # length + angle term (Nascimento et al. 2020 Eq. 5)
    ("tc", "float64"),
    ("sv", "float64"),
    ("min_clearance", "float64"),  # metres, along the replayed trajectory
    ("duration", "float64"),  # seconds of the trajectory
    ("max_track_error", "float64"),  # largest servo tracking error (rad for hinges, m for slides)
    ("contacts", "int64"),  # leg/obstacle contacts in the dynamic replay
    ("certified", "bool"),  # optimal smoother only: KKT-certified local optimum
    ("kkt_residual", "float64"),  # optimal smoother only
    ("foam_mj_version", "string"),  # the software that made the row (on a cluster: the node's)
    ("mujoco_version", "string"),
)
#: Columns that change from run to run of the same row (timings); everything else is deterministic.
TIMING_COLUMNS = ("plan_time", "smooth_time", "task_time")


class SweepError(FoamError):
    """A sweep file, a swept key or value, or an output folder is wrong (exit 2)."""


class WorkersDied(RuntimeError):
    """The local workers kept dying (exit 1); the rows received before are kept."""


@dataclass(frozen=True)
class Axis:
    """One swept key: its values (grid or choice), or its uniform range, and its column kind."""

    key: str
    kind: str  # "int", "float", "bool", "str" or "json" (lists and tables, stored as JSON text)
    values: tuple = ()
    low: Any = None
    high: Any = None
    source: str = "grid"  # "grid", "uniform" or "choice"


@dataclass(frozen=True)
class Sweep:
    """A parsed and validated sweep file."""

    source: Path
    scenario: str  # a built-in scenario's name, or the absolute path of a scenario TOML
    builtin: bool
    base: dict = field(repr=False)  # the base scenario's TOML table
    base_dir: Path = field(repr=False)
    seeds: tuple[int, ...] = (0,)
    smoothers: str = "optimal"
    smoother_paths: tuple[str, ...] = ()  # what foam_mj.pipeline.run is asked for
    paths: tuple[str, ...] = ()  # one row per path: "centre" and the smoothers' paths
    replay: str = "dynamic"
    grid: tuple[Axis, ...] = ()
    random: tuple[Axis, ...] = ()
    samples: int = 0
    random_seed: int = 0
    actuated_joints: tuple[str, ...] = ()  # joints whose peak torque gets a column (when replayed)
    model_hash: dict = field(default_factory=dict, repr=False)  # the base scene's foam_mj.fingerprint.model_fingerprint

    @property
    def axes(self) -> tuple[Axis, ...]:
        return self.grid + self.random

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(a.key for a in self.axes)

    @property
    def n_points(self) -> int:
        n = math.prod(len(a.values) for a in self.grid)
        return n * (len(self.draws) if self.random else 1)

    @property
    def repeated_draws(self) -> int:
        """Random samples that drew the values of an earlier one (left out of :attr:`draws`)."""
        return self.samples - len(self.draws) if self.random else 0

    @property
    def n_tasks(self) -> int:
        return self.n_points * len(self.seeds)

    @property
    def torque_columns(self) -> tuple[str, ...]:
        return tuple(f"peak_torque_{j}" for j in self.actuated_joints) if self.replay != "none" else ()

    def columns(self) -> list[tuple[str, str]]:
        """Every column of a row, in order, with its Arrow type name."""
        arrow = {"int": "int64", "float": "float64", "bool": "bool", "str": "string", "json": "string"}
        cols = [("key", "string")] + [(a.key, arrow[a.kind]) for a in self.axes] + list(RESULT_COLUMNS)
        return cols + [(c, "float64") for c in self.torque_columns]

    def points(self) -> Iterator[dict[str, Any]]:
        """Every parameter combination: the grid's product, each with every random sample."""
        grid = [[(a.key, v) for v in a.values] for a in self.grid]
        samples = self.draws if self.random else [{}]
        for combo in itertools.product(*grid):
            for sample in samples:
                yield {**dict(combo), **sample}

    def _samples(self) -> list[dict[str, Any]]:
        """The random draws, the same every time for the same [random] table (one Generator, keys in order)."""
        rng = np.random.default_rng(self.random_seed)
        columns: dict[str, list] = {}
        for a in self.random:
            if a.source == "choice":
                idx = rng.integers(0, len(a.values), size=self.samples)
                columns[a.key] = [a.values[i] for i in idx]
            elif a.kind == "int":
                columns[a.key] = [int(v) for v in rng.integers(a.low, a.high, size=self.samples, endpoint=True)]
            elif a.kind == "float":
                columns[a.key] = [float(v) for v in rng.uniform(a.low, a.high, size=self.samples)]
            else:  # element-wise uniform between two lists
                lo, hi = np.asarray(a.low, float), np.asarray(a.high, float)
                columns[a.key] = [[float(x) for x in row] for row in rng.uniform(lo, hi, size=(self.samples, lo.size))]
        return [{k: columns[k][i] for k in columns} for i in range(self.samples)]

    @cached_property
    def draws(self) -> tuple[dict[str, Any], ...]:
        """The distinct random draws, in the order drawn. A draw that repeats an earlier one (a choice among few
        values, integers in a narrow range) is the same plan with the same seeds: kept, it ran twice and wrote its
        rows twice under one key."""
        seen: set[str] = set()
        out = []
        for sample in self._samples():
            ident = json.dumps(sample, sort_keys=True)
            if ident not in seen:
                seen.add(ident)
                out.append(sample)
        return tuple(out)

    def tasks(self) -> Iterator["Task"]:
        """Every task, in order: points, then seeds."""
        for point in self.points():
            for seed in self.seeds:
                yield self.task(point, seed)

    def task(self, point: dict[str, Any], seed: int) -> "Task":
        kinds = {a.key: a.kind for a in self.axes}
        params = tuple((k, _normalize(v, kinds[k])) for k, v in point.items())
        return Task(
            scenario=self.scenario,
            builtin=self.builtin,
            base=self.base,
            params=params,
            kinds=tuple(kinds[k] for k, _ in params),
            seed=seed,
            smoother_paths=self.smoother_paths,
            paths=self.paths,
            replay=self.replay,
            actuated_joints=self.actuated_joints,
        )

    def manifest(self) -> dict:
        """What identifies the rows of this sweep (kept as sweep.json beside them)."""
        return {
            "format": FORMAT,
            "version": VERSION,
            "scenario": self.scenario,
            "base": self.base,
            "replay": self.replay,
            "keys": {a.key: a.kind for a in self.axes},
            "columns": [c for c, _ in self.columns()],
            "seeds": list(self.seeds),
            "smoothers": self.smoothers,
            "paths": list(self.paths),
            "tasks": self.n_tasks,
            "model_hash": self.model_hash,  # the base scene as compiled: an edited MJCF is another sweep
            "versions": versions(),  # of the run that wrote this manifest last
        }


def _normalize(value: Any, kind: str) -> Any:
    """A value in its column's kind (an integer in a float column becomes a float, so keys stay stable)."""
    if kind == "float":
        return float(value)
    if kind == "int":
        return int(value)
    return value


def column_value(value: Any, kind: str) -> Any:
    """What a swept value looks like in its column (lists and tables as JSON text)."""
    return json.dumps(value) if kind == "json" else value


def row_key(params: tuple[tuple[str, Any], ...], seed: int, path: str) -> str:
    """The row's identity: a hash of its parameters (by key), seed and path name (stable across runs)."""
    text = json.dumps([sorted(params), seed, path], separators=(",", ":"), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def apply_overrides(doc: dict, params) -> dict:
    """A copy of the scenario table ``doc`` with each dotted key's field replaced (tables made as needed)."""
    doc = copy.deepcopy(doc)
    for key, value in params:
        parts = key.split(".")
        table = doc
        for i, part in enumerate(parts[:-1]):
            nxt = table.setdefault(part, {})
            if not isinstance(nxt, dict):
                raise SweepError(f"key '{key}': '{'.'.join(parts[: i + 1])}' is not a table")
            table = nxt
        table[parts[-1]] = copy.deepcopy(value)
    return doc


# --------------------------------------------------------------------------------------------- tasks


@dataclass(frozen=True)
class Task:
    """One plan: the base scenario with ``params`` applied, one seed; picklable, run by :func:`run_task`."""

    scenario: str
    builtin: bool
    base: dict
    params: tuple[tuple[str, Any], ...]
    kinds: tuple[str, ...]
    seed: int
    smoother_paths: tuple[str, ...]
    paths: tuple[str, ...]
    replay: str
    actuated_joints: tuple[str, ...] = ()

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(row_key(self.params, self.seed, p) for p in self.paths)


def _base_dir(scenario: str, builtin: bool) -> Path:
    if builtin:
        from foam_mj.data import scenarios_dir

        return scenarios_dir()
    return Path(scenario).parent


#: One compiled model per scene per worker process, keyed by the scene file and the scenario's scene edits
#: (obstacle, subject, meshes: foam_mj.scene_edits); a few are kept, the oldest dropped first.
_ROBOTS: dict[str, Any] = {}
_MAX_ROBOTS = 8


def _robot_for(scenario):
    from foam_mj.scene_edits import build_robot

    ident = f"{scenario.scene}|{scenario.edits!r}|{scenario.robot_options!r}"
    robot = _ROBOTS.get(ident)
    if robot is None:
        if len(_ROBOTS) >= _MAX_ROBOTS:
            _ROBOTS.pop(next(iter(_ROBOTS)))
        robot = _ROBOTS[ident] = build_robot(scenario.scene, scenario.edits, **scenario.robot_options)
    return robot


def build_scenario(scenario: str, builtin: bool, base: dict, params, *, check: bool = True, check_clearance: bool = True):
    """The base scenario with ``params`` applied, validated (ScenarioError / SweepError otherwise); without
    ``check_clearance``, start and goal may lie within the margin of an obstacle (a problem, not a bad value)."""
    from foam_mj.scenarios import check_scenario, scenario_from_dict

    doc = apply_overrides(base, params)
    # a built-in scenario by its name, not where this install keeps it: an 'invalid' row's reason is the same on every node
    source = Path(f"{scenario}.toml") if builtin else Path(scenario)
    s = scenario_from_dict(doc, _base_dir(scenario, builtin), source=source, check=False)
    if check:
        try:
            robot = _robot_for(s)
        except FoamError as exc:
            raise ScenarioError(f"field 'scene': {exc}") from None
        check_scenario(s, robot, check_clearance=check_clearance)
    return s


def run_task(task: Task) -> list[dict]:
    """Plan, smooth and replay one task; one row per path, failures as rows (never raises for a bad plan)."""
    from foam_mj.pipeline import run

    t0 = time.perf_counter()
    common: dict[str, Any] = {k: column_value(v, kind) for (k, v), kind in zip(task.params, task.kinds)}
    common.update(seed=task.seed, scenario=task.base.get("name", Path(task.scenario).stem))
    common.update(versions())
    rows = [{"key": key, **common, "smoother": path} for key, path in zip(task.keys, task.paths)]

    def fail(outcome: str, reason: str, **extra) -> list[dict]:
        for r in rows:
            r.update(outcome=outcome, reason=reason, task_time=time.perf_counter() - t0, **extra)
        return rows

    try:
        scenario = build_scenario(task.scenario, task.builtin, task.base, task.params)
    except FoamError as exc:
        return fail("invalid", str(exc))
    try:
        # require_timing=False: when the limits fit no path, each row keeps its path's measures and its own reason
        out = run(scenario, task.seed, task.smoother_paths, replay=task.replay != "none", dynamic=task.replay == "dynamic",
                  require_timing=False)
    except PlanningFailed as exc:
        st = exc.stats
        extra = {} if st is None else {"bubbles": int(st.bubbles), "plan_time": float(st.elapsed)}
        # exc.reason leaves out the wall time the message names: that is plan_time, and in the reason it would
        # make the same row differ from run to run and between engines.
        reason = exc.reason if st is None else f"{st.outcome}: {exc.reason}"
        return fail("failed", reason, **extra)
    except FoamError as exc:  # e.g. a start whose root bubble is below r_min: this combination is no valid problem
        return fail("invalid", f"{type(exc).__name__}: {exc}")
    except Exception as exc:  # a bug or a solver failure on one task must not stop the sweep
        return fail("error", f"{type(exc).__name__}: {exc}")
    task_time = time.perf_counter() - t0
    for row in rows:
        po = out.paths.get(row["smoother"])
        # plan_time: the planner's own clock (PlanStats.elapsed), as a failed row's; the wall time around plan_scenario
        # also held a worker's first import of scipy.spatial (0.4 s: a first plan read 0.64 s where the others read 0.22)
        row.update(plan_time=float(out.plan.stats.elapsed), task_time=task_time, bubbles=int(out.plan.stats.bubbles))
        if out.plan.stats.clock_cut:  # a reached plan a clock decided: its rows can differ between machines and engines
            row["reason"] = f"clock: {out.plan.stats.clock_cut}"
        if po is None:
            row.update(outcome="error", reason=f"the pipeline produced no path '{row['smoother']}'")
            continue
        m = po.metrics
        row.update(
            outcome="reached",
            smooth_time=float(po.result.wall_time),
            rosary=int(po.rosary.k),
            length=float(m.length),
            angle_term=float(m.angle_term),
            f=float(m.f),
            tc=float(m.tc),
            sv=float(m.sv),
        )
        if po.timing_error is not None:  # the path is planned and smoothed, but no timing fits the limits
            row.update(outcome="failed", reason=po.timing_error.reason)
        if po.trajectory is not None:
            row["duration"] = float(po.trajectory.duration)
        if po.kinematic is not None:
            row["min_clearance"] = float(po.kinematic.min_clearance)
        if po.dynamic is not None:
            d = po.dynamic
            row.update(max_track_error=float(np.max(d.max_error)), contacts=len(d.contacts))
        loads = getattr(po, "loads", None)
        if loads is not None:
            row.update({f"peak_torque_{j}": float(v) for j, v in zip(loads.joint_names, loads.peak) if j in task.actuated_joints})
        info = po.result.info or {}
        if "kkt_stationarity" in info:
            row.update(certified=bool(info.get("certified")), kkt_residual=_finite(info["kkt_stationarity"]))
    return rows


def versions() -> dict[str, str]:
    """The versions of foam-mj and MuJoCo in this process (a row's ``foam_mj_version``, ``mujoco_version``)."""
    import mujoco

    from foam_mj import __version__

    return {"foam_mj_version": __version__, "mujoco_version": mujoco.__version__}


def _finite(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def actuated_joints(robot) -> tuple[str, ...]:
    """The configuration joints, whose peak torques (inverse dynamics, foam_mj.dynamics) get a column."""
    return tuple(robot.config.joint_names)
