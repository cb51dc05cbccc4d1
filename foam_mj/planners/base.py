"""The planner seam: a planning problem, a planner, and a result with statistics (OMPL's split of
``ProblemDefinition`` / ``Planner`` / solution, kept small).

* :class:`PlanningProblem` -- what to solve: the bubble oracle (scene, margin delta), q_init, q_goal,
  and the budgets (wall time, bubble count). Frozen.
* :class:`Planner` -- how: a named algorithm with its own frozen ``Options`` dataclass; ``plan(problem,
  seed, progress)`` returns a :class:`PlanResult` or raises :class:`~foam_mj.errors.PlanningFailed`
  (carrying the stats and every bubble grown so far). Planners are interchangeable by name through
  :data:`foam_mj.planners.PLANNERS`.
* :class:`PlanResult` -- every bubble grown (a :class:`~foam_mj.foam.Foam`, for the recording and the
  JSON), the rosary (the certified chain of overlapping bubbles from q_init to q_goal that the
  smoothers work in) and :class:`PlanStats`.
* :class:`PlannerConfig` -- what a scenario's ``[planner]`` table says: the algorithm's name, the
  margin and budgets shared by every planner, and the algorithm's own options.
"""

from __future__ import annotations

import dataclasses
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Mapping

import numpy as np

from foam_mj.bubbles import BubbleOracle, EndBubble
from foam_mj.errors import ConfigurationError, FoamError, clearance_text, is_finite_number, is_number, unknown_names
from foam_mj.foam import Foam
from foam_mj.rosary import Rosary, fields_equal
from foam_mj.safe_curve import apart_text, coincide


class PlannerError(FoamError, ValueError):
    """An unknown planner name, or an unknown or invalid planner option."""


@dataclass(frozen=True)
class PlanningProblem:
    """q_init -> q_goal among the oracle's obstacles, every bubble keeping ``delta`` (metres) of clearance.

    ``delta`` must equal ``oracle.delta`` (it is repeated so that a problem states its margin).
    ``time_limit`` (seconds of wall time) and ``max_bubbles`` bound the search for a certified chain; bubbletree's
    corridor, built after its trees meet, is not bounded by them (its refinement has its own CPU budget, the option
    ``refine_time``), so a plan may return after ``time_limit``; the clock starts once the planner has imported its
    solvers (scipy: a one-time 0.3-1 s per process, several seconds on a loaded machine), so that the first plan of a
    process searches as long as the next. q_init and q_goal are kept as
    read-only float arrays (validated: shape, finite, within the joint bounds, not equal). Picklable.
    """

    oracle: BubbleOracle
    q_init: np.ndarray
    q_goal: np.ndarray
    delta: float = 0.005
    time_limit: float = 60.0
    max_bubbles: int = 200_000

    __eq__ = fields_equal  # arrays by value (foam_mj.rosary)

    def __post_init__(self) -> None:
        if not isinstance(self.oracle, BubbleOracle):
            raise TypeError(f"`oracle` must be a foam_mj.bubbles.BubbleOracle (BubbleOracle(robot, delta)), got {type(self.oracle).__name__}")
        robot = self.oracle.robot
        robot.check_unchanged()
        for name in ("q_init", "q_goal"):
            q = robot.validate(getattr(self, name), name)
            q.flags.writeable = False  # a frozen problem: no change after validation
            object.__setattr__(self, name, q)
        if coincide(self.q_init, self.q_goal):  # as pfm, the CLI and scenarios: one answer from every planner
            raise ConfigurationError(f"q_goal equals q_init{apart_text(self.q_init, self.q_goal)} ({self.q_init.tolist()}): nothing to plan")
        for name, value in (("delta", self.delta), ("time_limit", self.time_limit), ("max_bubbles", self.max_bubbles)):
            if not is_number(value):
                raise TypeError(f"`{name}` must be a number, got {value!r}")
        if not (is_finite_number(self.delta) and self.delta >= 0):
            raise ValueError(f"`delta` must be >= 0 (metres), got {self.delta!r}")
        if self.oracle.delta != self.delta:
            raise ValueError(f"the oracle's margin delta={self.oracle.delta} differs from the problem's delta={self.delta}")
        if not (self.time_limit > 0):
            raise ValueError(f"`time_limit` must be > 0 seconds, got {self.time_limit!r}")
        if not (isinstance(self.max_bubbles, (int, np.integer)) and self.max_bubbles >= 1):
            raise ValueError(f"`max_bubbles` must be an integer >= 1, got {self.max_bubbles!r}")
        robot.check_fixed_pairs(self.delta)  # a pair within delta that no joint moves: every path would break it
        robot.check_margins(self.delta)  # a contact that acts beyond delta would push the path off in simulation

    @property
    def dim(self) -> int:
        return self.oracle.robot.dim

    def endpoint_radii(self) -> tuple[float, float]:
        """Certified radii at q_init and q_goal; :class:`ConfigurationError` naming the clearance when
        either is closer than delta to an obstacle (or has no room inside the joint bounds)."""
        Q, D = self._endpoint_distances()
        radii = self.oracle.radius_from_distances(D, Q)  # per-pair bound (foam_mj.bubbles)
        for name, q, r in zip(("q_init", "q_goal"), Q, radii):
            if not r > 0:
                raise ConfigurationError(f"{name} {q.tolist()} lies on the boundary of the joint bounds: no certified bubble "
                                         f"centred there fits (the bubbletree planner accepts it)")
        return float(radii[0]), float(radii[1])

    def endpoint_bubbles(self, want: float) -> tuple[EndBubble, EndBubble]:
        """A certified bubble holding q_init and one holding q_goal (:meth:`foam_mj.bubbles.BubbleOracle.holding_bubble`):
        centred at the end point itself unless the joint bounds keep its radius below ``want`` (an end point on or
        beside a joint limit: the centre moves off the bounds; on an edge or corner of the joint box, a ball about
        the end point that leaves the box). Two balls that leave the box are kept apart (each radius at most 0.45 x
        the distance between the end points: smaller balls about the same centres, still certified and holding
        them), so that no chain has them as neighbours, whose hatch could leave the box. :class:`ConfigurationError`
        naming the clearance when either end point is closer than delta to an obstacle."""
        Q, D = self._endpoint_distances()
        a, b = (self.oracle.holding_bubble(q, want, d) for q, d in zip(Q, D))
        if not (a.within_bounds or b.within_bounds):
            cap = 0.45 * float(np.linalg.norm(a.center - b.center))
            a, b = (EndBubble(e.center, min(e.radius, cap), False) for e in (a, b))
        return a, b

    def _endpoint_distances(self) -> tuple[np.ndarray, np.ndarray]:
        """q_init and q_goal (2, n) and their pair distances (one batch); :class:`ConfigurationError` naming the
        clearance when either is closer than delta to an obstacle."""
        Q = np.stack([self.q_init, self.q_goal])
        D = self.oracle.clearance.batch_pairs(Q)
        for name, q, dp in zip(("q_init", "q_goal"), Q, D):
            d = float(dp.min())
            if d <= self.delta:
                state = "in collision" if d < 0 else "too close to an obstacle"
                raise ConfigurationError(
                    f"{name} {q.tolist()} is {state}: clearance {clearance_text(d, self.delta)} <= margin delta = {self.delta} m"
                )
        return Q, D


@dataclass(frozen=True)
class PlanStats:
    """What a planner did. ``distance_queries`` counts configurations whose clearance MuJoCo evaluated;
    ``elapsed`` is the plan's wall time in seconds and ``time_to_first_path`` the wall time (s) until the first certified
    chain q_init -> q_goal existed (``None`` when none did); ``details`` holds the planner's own counters."""

    planner: str
    outcome: str  # "reached", or why not: "queue empty", "bubble budget", "time budget", "stalled" (bubbletree), ...
    bubbles: int
    distance_queries: int
    elapsed: float
    time_to_first_path: float | None = None
    details: Mapping[str, Any] = field(default_factory=dict)

    @property
    def bubbles_per_second(self) -> float:
        return self.bubbles / self.elapsed if self.elapsed > 0 else float("nan")

    @property
    def clearance_calls(self) -> int:
        return self.distance_queries

    @property
    def clock_cut(self) -> str | None:
        """Which phases of a plan a clock ended, in words (None: none did, and the seed alone decided the result).
        A phase ended by the wall-clock ``time_limit`` or by bubbletree's CPU budget ``refine_time`` depends on the
        machine's speed and load: the same seed can give another path elsewhere (``details``' ``explore_stopped``
        and ``refine_stopped``)."""
        d = self.details
        cuts = [text for key, value, text in (
            ("explore_stopped", "time limit", "the time limit ended the search for other routes after the first path"),
            ("refine_stopped", "time limit", "the time limit ended the path's refinement"),
            ("refine_stopped", "time", "refine_time (CPU seconds) ended the path's refinement"),
        ) if d.get(key) == value]
        return "; ".join(cuts) or None

    def as_dict(self) -> dict:
        d = dict(self.details)
        d.update(
            planner=self.planner, outcome=self.outcome, bubbles=self.bubbles, distance_queries=self.distance_queries,
            clearance_calls=self.distance_queries, elapsed=self.elapsed, time_to_first_path=self.time_to_first_path,
            bubbles_per_second=self.bubbles_per_second,
        )
        return d


@dataclass(frozen=True)
class PlanResult:
    """Every bubble grown (``foam``), the certified chain q_init -> q_goal (``rosary``), and statistics;
    ``waypoints``: the planner's shortest path through the rosary's hatches when it solved one (bubbletree's
    corridor, in the qpos metric), handed to the ``optimal`` smoother as its start (:func:`smoother_start`)."""

    foam: Foam
    rosary: Rosary
    stats: PlanStats
    waypoints: np.ndarray | None = None

    __eq__ = fields_equal  # arrays by value (foam_mj.rosary)


def check_problem(problem: Any, progress: Any = None) -> PlanningProblem:
    """``problem``, checked at the start of :meth:`Planner.plan`: a :class:`PlanningProblem` (TypeError otherwise)
    whose scene has not been edited since its oracle was built (:meth:`foam_mj.model.RobotModel.check_unchanged`);
    ``progress`` None or a callable (it is first called half a second into the plan)."""
    if not isinstance(problem, PlanningProblem):
        raise TypeError(f"plan() takes a foam_mj.planners.PlanningProblem, got {type(problem).__name__}")
    if progress is not None and not callable(progress):
        raise TypeError(f"`progress` must be None or a callable taking a Progress, got {type(progress).__name__}")
    problem.oracle.robot.check_unchanged()
    return problem


def check_result(result: Any, problem: PlanningProblem, planner: str) -> PlanResult:
    """``result`` of ``planner`` on ``problem``, checked before anything uses it (any registered planner, also a
    user's): a :class:`PlanResult` whose rosary holds q_init in its first bubble and q_goal in its last, overlaps
    bubble to bubble, and has no bubble larger than the oracle's certified radius at its centre (the clearance's
    term: an end bubble may leave the joint box, :meth:`~foam_mj.bubbles.BubbleOracle.holding_bubble`; one batch
    of distance queries). RuntimeError naming the planner and the first fault otherwise: a bug of that planner,
    whose paths would not keep delta."""
    if not isinstance(result, PlanResult):
        raise RuntimeError(f"planner '{planner}' returned {type(result).__name__}, not a PlanResult")
    ros = result.rosary
    if ros.dim != problem.dim or not (np.array_equal(ros.q_init, problem.q_init) and np.array_equal(ros.q_goal, problem.q_goal)):
        raise RuntimeError(f"planner '{planner}' returned a rosary for another problem (q_init, q_goal or dimension differ)")
    faults = ros.check_structure()
    if faults:
        raise RuntimeError(f"planner '{planner}' returned a broken rosary: {'; '.join(faults)}")
    oracle = problem.oracle
    certified = np.maximum(oracle.pair_radii(oracle.clearance.batch_pairs(ros.centers)).min(axis=1), 0.0)
    over = np.flatnonzero(ros.radii > certified * (1 + 1e-9) + 1e-12)
    if over.size:
        i = int(over[0])
        raise RuntimeError(
            f"planner '{planner}' returned an uncertified rosary: bubble {i} has radius {ros.radii[i]:.6g}, over the "
            f"certified radius {certified[i]:.6g} at its centre {ros.centers[i].tolist()} (margin delta {problem.delta} m)"
        )
    return result


def smoother_start(rosary: Rosary, waypoints: np.ndarray | None) -> np.ndarray | None:
    """``waypoints`` if they are a valid start for a smoother on ``rosary`` (shape (k-1, n), finite, every
    waypoint in its hatch), else None (the smoother then solves its own start)."""
    if waypoints is None:
        return None
    w = np.asarray(waypoints, dtype=float)
    if w.shape != (rosary.n_hatches, rosary.dim) or not np.all(np.isfinite(w)) or not np.all(rosary.in_hatches(w)):
        return None
    return w


@dataclass(frozen=True)
class Progress:
    """What a planner reports to a ``progress`` callback (about twice a second); ``note``: how its search stands, in
    its own words (bubbletree: how far apart the trees are, the resolution)."""

    bubbles: int
    elapsed: float
    note: str = ""


ProgressFn = Callable[[Progress], None]


@dataclass(frozen=True)
class NoOptions:
    """A planner without options of its own."""


class Planner(ABC):
    """A motion planner over certified bubbles. Subclasses set ``name``, ``summary`` and ``Options``
    (a frozen dataclass whose ``__post_init__`` validates with ValueError naming the field)."""

    name: ClassVar[str]
    summary: ClassVar[str] = ""
    Options: ClassVar[type] = NoOptions

    def __init__(self, options: Any = None, **kwargs: Any) -> None:
        if options is None:
            options = make_options(type(self), kwargs)
        elif kwargs:
            raise TypeError("pass either an Options instance or keyword options, not both")
        elif not isinstance(options, self.Options):
            raise TypeError(f"planner '{self.name}' takes {self.Options.__name__}, got {type(options).__name__}")
        self.options = options

    @abstractmethod
    def plan(self, problem: PlanningProblem, seed: int | np.random.Generator = 0, progress: ProgressFn | None = None) -> PlanResult:
        """Solve ``problem`` (first :func:`check_problem`); raise :class:`~foam_mj.errors.PlanningFailed` (with stats
        and bubbles) when the budget runs out, :class:`~foam_mj.errors.ConfigurationError` for bad endpoints."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.options!r})"


def option_names(cls: type[Planner]) -> list[str]:
    return [f.name for f in dataclasses.fields(cls.Options)]


def make_options(cls: type[Planner], values: Mapping[str, Any]) -> Any:
    """``cls.Options(**values)`` with unknown names and invalid values reported as :class:`PlannerError`."""
    known = option_names(cls)
    unknown = sorted(set(values) - set(known))
    if unknown:
        expected = ", ".join(known) if known else "none"
        raise PlannerError(f"planner '{cls.name}' has no option(s) {unknown_names(unknown, known)}; its options: {expected}")
    flags = {f.name for f in dataclasses.fields(cls.Options) if f.type in (bool, "bool")}
    for key, value in values.items():  # Python's True is the integer 1: K = true would plan with K = 1
        if isinstance(value, (bool, np.bool_)) and key not in flags:
            raise PlannerError(f"planner '{cls.name}': `{key}` must be a number, got {value!r}")
    values = _python_scalars(values)
    try:
        return cls.Options(**values)
    except (TypeError, ValueError) as exc:
        raise PlannerError(f"planner '{cls.name}': {exc}") from None


def _python_scalars(values: Mapping[str, Any]) -> dict[str, Any]:
    """``values`` with numpy scalars (np.int64(10), np.True_) as Python's: options are written to JSON results."""
    return {k: v.item() if isinstance(v, np.generic) else v for k, v in values.items()}


class Timer:
    """Wall time since construction, and a rate-limited progress report."""

    def __init__(self, progress: ProgressFn | None = None, every: float = 0.5) -> None:
        self.t0 = time.perf_counter()
        self._progress = progress
        self._every = every
        self._next = self.t0 + every

    def elapsed(self) -> float:
        return time.perf_counter() - self.t0

    def report(self, bubbles: int, note: Callable[[], str] | None = None) -> None:
        """Call the progress callback if it is due, with ``note()`` (computed only then) as its note."""
        if self._progress is None:
            return
        now = time.perf_counter()
        if now >= self._next:
            self._progress(Progress(bubbles, now - self.t0, "" if note is None else note()))
            self._next = now + self._every


#: The shared fields of a scenario's ``[planner]`` table (every other field is the algorithm's option).
COMMON_FIELDS = ("algorithm", "delta", "max_bubbles", "time_limit")


@dataclass(frozen=True)
class PlannerConfig:
    """A scenario's ``[planner]`` table: the algorithm, the margin and budgets, and the algorithm's options.

    Reading an attribute that is not a field falls through to ``options`` (``config.r_min`` for pfm),
    so code written for the foam's parameters keeps working.
    """

    algorithm: str = "pfm"
    delta: float = 0.005
    max_bubbles: int = 200_000
    time_limit: float = 60.0
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not (is_finite_number(self.delta) and self.delta >= 0):
            raise ValueError(f"`delta` must be >= 0 (metres), got {self.delta!r}")
        if not (isinstance(self.max_bubbles, (int, np.integer)) and not isinstance(self.max_bubbles, bool) and self.max_bubbles >= 1):
            raise ValueError(f"`max_bubbles` must be an integer >= 1, got {self.max_bubbles!r}")
        if not (is_finite_number(self.time_limit) and self.time_limit > 0):  # inf was written to the result as Infinity
            raise ValueError(f"`time_limit` must be > 0 seconds and finite, got {self.time_limit!r}")
        for name, kind in (("delta", float), ("max_bubbles", int), ("time_limit", float)):  # Python's, for JSON
            object.__setattr__(self, name, kind(getattr(self, name)))
        object.__setattr__(self, "options", _python_scalars(self.options))
        self.planner()  # validates the name and the options

    def __getattr__(self, key: str) -> Any:
        if key.startswith("_") or key == "options":
            raise AttributeError(key)
        try:
            return self.options[key]
        except KeyError:
            opts = self.planner().options
            if hasattr(opts, key):
                return getattr(opts, key)
            raise AttributeError(f"planner '{self.algorithm}' has no parameter '{key}'") from None

    def planner(self) -> Planner:
        from foam_mj.planners import get_planner

        return get_planner(self.algorithm, **self.options)

    def problem(self, oracle: BubbleOracle, q_init: np.ndarray, q_goal: np.ndarray) -> PlanningProblem:
        return PlanningProblem(oracle, q_init, q_goal, self.delta, self.time_limit, self.max_bubbles)

    def with_algorithm(self, name: str) -> "PlannerConfig":
        """The same margin and budgets with another algorithm (its default options unless it is this one)."""
        if name == self.algorithm:
            return self
        return dataclasses.replace(self, algorithm=name, options={})

    def as_dict(self) -> dict:
        d = {"algorithm": self.algorithm, "delta": self.delta, "max_bubbles": self.max_bubbles, "time_limit": self.time_limit}
        d.update(dataclasses.asdict(self.planner().options))
        return d

    @classmethod
    def from_dict(cls, table: Mapping[str, Any], default_algorithm: str | None = None) -> "PlannerConfig":
        """From a ``[planner]`` table. Without ``algorithm``, a table with pfm's options (K, r_min) means
        pfm (scenario files written before the planner seam keep their meaning), otherwise the default."""
        from foam_mj.planners import DEFAULT_PLANNER

        table = dict(table)
        algorithm = table.pop("algorithm", None)
        if algorithm is None:
            algorithm = "pfm" if ("K" in table or "r_min" in table) else (default_algorithm or DEFAULT_PLANNER)
        if not isinstance(algorithm, str):
            raise PlannerError(f"`algorithm` must be a planner name (a string), got {algorithm!r}")
        common = {k: table.pop(k) for k in ("delta", "max_bubbles", "time_limit") if k in table}
        return cls(algorithm, **common, options=table)


def too_small_to_grow(oracle: BubbleOracle, name: str, q: np.ndarray, r: float, smallest: float) -> str:
    """Why end point ``name`` at q, whose certified bubble has radius r < ``smallest`` (the smallest bubble a tree
    grows from), is refused: a joint box narrower than that in some coordinate; else its clearance barely above delta
    (within a tenth of delta); else a clearance well above delta over a pair that a unit of q moves that far (a
    coordinate mapped onto a short span)."""
    robot, delta = oracle.robot, oracle.delta
    width = robot.upper - robot.lower
    j = int(np.argmin(width))
    if width[j] < 2 * smallest:
        return (f"{name} {q.tolist()} cannot be certified: the joint box is only {width[j]:.3g} wide in "
                f"'{robot.config.joint_names[j]}' (units of q), so no bubble inside it reaches radius {smallest:g}, the "
                f"smallest that grows: map that joint onto a longer span ([normalize]) or leave it out of the configuration")
    report = oracle.explain(q)
    clearance = clearance_text(report.clearance, delta)
    apart = float(np.min(report.pair_radii)) if len(report.pair_radii) else np.inf  # the radius the obstacles allow
    if report.to_bounds < apart and np.isclose(r, report.to_bounds, rtol=1e-6, atol=0.0):  # a joint bound sets it (a short slide's end)
        below, above = q - robot.lower, robot.upper - q
        j = int(np.argmin(np.minimum(below, above)))
        side, bound = ("lower", robot.lower[j]) if below[j] <= above[j] else ("upper", robot.upper[j])
        return (f"{name} {q.tolist()} lies {min(below[j], above[j]):.3g} (units of q) inside the {side} bound of "
                f"'{robot.config.joint_names[j]}' ({bound:g}), which sets its certified bubble's radius {r:.3g} < {smallest:g}, "
                f"too small to grow from (clearance {clearance}; the obstacles alone allow {apart:.3g}): move it away from "
                f"that bound, or map that joint onto a longer span ([normalize])")
    if report.clearance - delta <= 0.1 * delta:
        return (f"{name} {q.tolist()} is too close to an obstacle to certify a path from it: clearance {clearance}, barely "
                f"above delta = {delta} m, gives a certified bubble of radius {r:.3g} < {smallest:g}, too small to grow "
                f"from (`foam-mj bubble` shows the limiting pair): move it away")
    a, b = report.limiting_pair
    return (f"{name} {q.tolist()} is too close to an obstacle to certify a path from it: clearance {clearance} is "
            f"{report.clearance - delta:.3g} m above delta = {delta} m, but a unit of q moves {a} / {b} up to "
            f"||rho|| = {report.rho_norm:.3g} m, so its certified bubble has radius {r:.3g} < {smallest:g} (units of q), "
            f"too small to grow from (`foam-mj bubble` shows rho per joint): move it away, or map the coordinates onto "
            f"longer spans ([normalize])")
