"""The smoothers' shared interface: stop criteria, the result record, hatch geometry and the fast objective.

Every smoother optimises the waypoints sigma = {q'_1, ..., q'_(k-1)} of Nascimento et al. 2020 Eq. 3, waypoint i
confined to its hatch b_i ∩ b_(i+1) (Eq. 5's constraint; ``Rosary.in_hatches``), and returns a
:class:`SmoothingResult` built from the same fields whatever the method. Because the hatches are
convex and each holds its waypoint, the polyline [q_init, sigma, q_goal] lies in the union of the
rosary's certified bubbles: no smoother needs a collision check (docs/bubbles-math.md).
"""

from __future__ import annotations

import math
import secrets
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Mapping, overload

import numpy as np

from foam_mj import paths
from foam_mj.arguments import MAX_SEED
from foam_mj.errors import indices_text
from foam_mj.paths import fill_index, row_norms
from foam_mj.rosary import Rosary, fields_equal

#: Nascimento et al. 2020 section 5.1/5.2's threshold f(sigma) < 0.38 (from Nascimento et al. 2019). Under Nascimento et al. 2020's own Eq. 5
#: (length about 3.6) f never falls below it; see docs/references.md.
PAPER_F_THRESHOLD = 0.38
#: Nascimento et al. 2019's number of improvisations NI = 2 x 10^4.
PAPER_MAX_ITERATIONS = 20_000
#: Nascimento et al. 2020 Table 1's criterion: no improvement of the population's mean fitness in 200 iterations.
PAPER_STALL_ITERATIONS = 200

SeedLike = int | np.integer | np.random.Generator | None
#: A long run's progress report: called with the iterations done and the best objective so far, at most every
#: :data:`PROGRESS_INTERVAL` seconds (HS and the GA: 2 x 10^4 iterations on a long rosary take tens of seconds).
ProgressFn = Callable[[int, float], None]
PROGRESS_INTERVAL = 0.5

_EPS = 1e-12  # the same "zero-length segment" threshold as foam_mj.paths


def check_seed(seed: SeedLike) -> None:
    """Refuse a seed that is not an integer in [0, 2**63 - 1] (a planner's, a scenario's and ``--seed``'s range), a
    numpy Generator or None (also where a method draws nothing)."""
    if isinstance(seed, np.random.Generator) or seed is None:
        return
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= MAX_SEED:
        raise ValueError(f"`seed` must be an integer in [0, 2**63 - 1], a numpy Generator or None, got {seed!r}")


def as_generator(seed: SeedLike) -> np.random.Generator:
    """A numpy Generator from an int seed (or None) or the Generator itself."""
    return seeded(seed)[0]


def seeded(seed: SeedLike) -> tuple[np.random.Generator, int | None]:
    """The Generator a run draws from and the integer seed that made it, for the run's ``info["seed"]``: ``seed``
    itself, or for None one drawn from the operating system's entropy (so that the run can be repeated with it);
    a given Generator is used as it is, and its seed is None (unknown)."""
    if isinstance(seed, np.random.Generator):
        return seed, None
    check_seed(seed)
    used = secrets.randbelow(MAX_SEED + 1) if seed is None else int(seed)
    return np.random.default_rng(used), used


def _check_int(name: str, value: Any, low: int, allow_none: bool = False) -> None:
    if value is None and allow_none:
        return
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}{' or None' if allow_none else ''}, got {value!r}")


def _is_real(value: Any) -> bool:
    """A real number: int, float or a numpy scalar of either, but not a bool (True is not a rate or a length)."""
    return isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, (bool, np.bool_))


def _check_unit(name: str, value: Any) -> None:
    if not (_is_real(value) and 0.0 <= float(value) <= 1.0):
        raise ValueError(f"{name} must be in [0, 1], got {value!r}")


def _check_positive(name: str, value: Any, allow_zero: bool = False) -> None:
    ok = _is_real(value) and math.isfinite(float(value))
    ok = ok and (float(value) >= 0.0 if allow_zero else float(value) > 0.0)
    if not ok:
        raise ValueError(f"{name} must be {'>= 0' if allow_zero else '> 0'} and finite, got {value!r}")


# -- stop criteria ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class StopCriteria:
    """When an iterative smoother stops; any combination, the first one met wins.

    * ``f_threshold``: the best objective falls below it (Nascimento et al. 2020 and 2019: f < 0.38; None = off).
    * ``max_iterations``: iteration cap (Nascimento et al. 2019: NI = 2 x 10^4; None = off).
    * ``stall_iterations``: no improvement of the population's mean objective in that many consecutive
      iterations (Nascimento et al. 2020 Table 1: 200; None = off). "Improvement" means a new lowest mean, lower
      than the previous lowest by more than ``stall_tol``. For a single-path method (gradient
      smoothing) the "population" is the one path.

    The default is Table 1's criterion with Nascimento et al. 2019's cap as a safety net. At least one criterion
    must be set, and a run with a threshold only must also have a cap (the threshold may be
    unreachable: it is, under Eq. 5, for 0.38).
    """

    f_threshold: float | None = None
    max_iterations: int | None = PAPER_MAX_ITERATIONS
    stall_iterations: int | None = PAPER_STALL_ITERATIONS
    stall_tol: float = 0.0

    def __post_init__(self) -> None:
        thr = self.f_threshold
        if thr is not None and not (_is_real(thr) and math.isfinite(float(thr))):
            raise ValueError(f"f_threshold must be a finite number or None, got {self.f_threshold!r}")
        _check_int("max_iterations", self.max_iterations, 1, allow_none=True)
        _check_int("stall_iterations", self.stall_iterations, 1, allow_none=True)
        _check_positive("stall_tol", self.stall_tol, allow_zero=True)
        if self.max_iterations is None and self.stall_iterations is None:
            raise ValueError("max_iterations and stall_iterations cannot both be None: the run might never stop")

    def reason(self, iteration: int, best: float, stall: int) -> str | None:
        """The stop reason after ``iteration`` iterations, or None to go on."""
        if self.f_threshold is not None and best < self.f_threshold:
            return "f threshold"
        if self.stall_iterations is not None and stall >= self.stall_iterations:
            return "stall"
        if self.max_iterations is not None and iteration >= self.max_iterations:
            return "iteration cap"
        return None


class MeanStall:
    """Counts consecutive iterations without a new lowest population mean (Table 1's criterion)."""

    def __init__(self, first_mean: float, tol: float = 0.0) -> None:
        self.lowest = float(first_mean)
        self.tol = float(tol)
        self.count = 0

    def update(self, mean: float) -> int:
        if mean < self.lowest - self.tol:
            self.lowest = float(mean)
            self.count = 0
        else:
            self.count += 1
        return self.count


# -- the result -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SmoothingResult:
    """What every smoother returns.

    ``path`` is [q_init, waypoints..., q_goal] (k+1, n); ``f``, ``angle_term`` and ``length`` are Nascimento
    et al. 2020 Eq. 5 and its two terms, ``tc`` and ``sv`` Nascimento and Alsina 2021 Eq. 6 and 7, all of ``path``.
    ``history_best`` / ``history_mean`` hold, after each iteration, the best and the population-mean
    value of the method's own ``objective``: f for HS and GA; the lowest SV so far (both) for gradient
    smoothing; the highest TC so far and the current TC for the rosary adjustment; for the convex
    reference a single entry, the optimal objective value.
    ``iterations`` counts the method's iterations (improvisations, generations, gradient steps, solver
    iterations), ``evaluations`` the objective evaluations the algorithm needs, ``wall_time`` seconds.
    ``rosary`` is the rosary whose hatches hold the waypoints (the adjusted one for T_RA, T_RCA).
    """

    method: str
    rosary: Rosary
    waypoints: np.ndarray
    path: np.ndarray
    f: float
    angle_term: float
    length: float
    tc: float
    sv: float
    history_best: np.ndarray
    history_mean: np.ndarray
    iterations: int
    evaluations: int
    wall_time: float
    stop_reason: str
    objective: str = "f"
    info: Mapping[str, Any] = field(default_factory=dict)

    __eq__ = fields_equal  # arrays by value (foam_mj.rosary)

    @classmethod
    def build(
        cls,
        method: str,
        rosary: Rosary,
        waypoints: np.ndarray,
        *,
        history_best: np.ndarray,
        history_mean: np.ndarray | None = None,
        iterations: int,
        evaluations: int,
        wall_time: float,
        stop_reason: str,
        objective: str = "f",
        info: Mapping[str, Any] | None = None,
    ) -> "SmoothingResult":
        """Fill in the path and its metrics from the waypoints."""
        w = np.array(waypoints, dtype=float)
        p = rosary.path(w)
        m = paths.metrics(p)
        hb = np.asarray(history_best, dtype=float)
        hm = hb.copy() if history_mean is None else np.asarray(history_mean, dtype=float)
        for a in (w, p, hb, hm):
            a.setflags(write=False)
        return cls(
            method, rosary, w, p, m.f, m.angle_term, m.length, m.tc, m.sv, hb, hm,
            int(iterations), int(evaluations), float(wall_time), stop_reason, objective, dict(info or {}),
        )

    def in_hatches(self, tol: float = 0.0) -> bool:
        """True when every waypoint lies in its hatch of ``rosary`` (closed balls, ``tol`` slack)."""
        return self.rosary.all_in_hatches(self.waypoints, tol)

    def summary(self) -> dict:
        """Scalars only (for tables and JSON)."""
        return {
            "method": self.method, "f": self.f, "angle_term": self.angle_term, "length": self.length,
            "tc": self.tc, "sv": self.sv, "iterations": self.iterations, "evaluations": self.evaluations,
            "wall_time": self.wall_time, "stop_reason": self.stop_reason, "objective": self.objective,
        }


class Smoother(ABC):
    """A path smoother: ``smooth(rosary, initial, seed)`` -> :class:`SmoothingResult`.

    ``initial`` is a (k-1, n) array of waypoints inside the hatches (None: the method's default, see
    each class); ``seed`` an integer in [0, 2**63 - 1] or a numpy Generator (same seed, same result), or None: a seed
    drawn from the operating system's entropy, so two runs differ (where a planner's ``plan`` refuses None). The methods
    that draw random numbers (hs, ga, optimal, mgoa, mopso) record the integer seed of their run in ``info["seed"]``
    (None for a Generator; a one-bubble rosary draws nothing): ``seed=result.info["seed"]`` repeats a run.
    Implementations are frozen dataclasses of their parameters, validated on construction.
    """

    name: ClassVar[str]

    @abstractmethod
    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> SmoothingResult:
        """Smooth the path through ``rosary``."""


def check_rosary_type(rosary: Rosary) -> None:
    """TypeError naming the argument unless ``rosary`` is a :class:`Rosary` (smoothing a plan's ``result.foam``, or None,
    was an AttributeError deep inside the smoother)."""
    if not isinstance(rosary, Rosary):
        hint = " (a plan's result.rosary, not result.foam)" if type(rosary).__name__ == "Foam" else " (a plan's result.rosary)"
        raise TypeError(f"`rosary` must be a foam_mj.rosary.Rosary{hint}, got {type(rosary).__name__}")


def check_rosary(rosary: Rosary) -> None:
    """Refuse a rosary whose path would leave its bubbles: q_init outside the first bubble, q_goal outside the
    last, or two consecutive bubbles that do not overlap (every smoother's path keeps to the bubbles only then)."""
    problems = rosary.check_structure()
    if problems:
        raise ValueError(f"the rosary is not a chain from q_init to q_goal: {'; '.join(problems)}")


def trivial_result(method: str, rosary: Rosary, t_start: float, objective: str = "f") -> SmoothingResult:
    """The result for a rosary of one bubble (q_init and q_goal in the root): no waypoint, the straight path."""
    check_rosary(rosary)
    w = np.empty((0, rosary.dim))
    value = float(paths.objective(rosary.path(w)))
    return SmoothingResult.build(
        method, rosary, w, history_best=np.empty(0), iterations=0, evaluations=0,
        wall_time=time.perf_counter() - t_start, stop_reason="nothing to smooth", objective=objective,
        info={"value": value},
    )


# -- hatch geometry ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Hatches:
    """The two balls (ca, ra) and (cb, rb) of every hatch, as arrays (m, n) and (m,), m = k - 1."""

    ca: np.ndarray
    ra: np.ndarray
    cb: np.ndarray
    rb: np.ndarray

    @classmethod
    def of(cls, rosary: Rosary) -> "Hatches":
        if rosary.n_hatches < 1:
            raise ValueError(f"the rosary has {rosary.k} bubble(s): there is no waypoint to smooth (need k >= 2)")
        return cls(*(np.ascontiguousarray(a) for a in rosary.hatch_balls()))

    @property
    def m(self) -> int:
        return len(self.ra)

    def fitting_inset(self, inset: float) -> float:
        """``inset``, or less where a hatch is too thin for it: at most a quarter of the smallest slack
        min(ra, rb, (ra + rb - d) / 2) over the hatches (d the distance of the centres), so that every lens
        shrunk by it keeps room inside. A rosary's bubbles may be far smaller than the default insets
        (a start a micrometre beyond delta from an obstacle gets a bubble of that size); a valid rosary's
        results do not change (its slack is many times larger). Raises ValueError for an empty hatch."""
        d = row_norms(self.cb - self.ca)
        slack = np.minimum(np.minimum(self.ra, self.rb), 0.5 * (self.ra + self.rb - d))
        thin = int(np.argmin(slack))
        if not slack[thin] > 0:
            raise ValueError(f"hatch {thin} is empty or a single point: bubbles {thin} and {thin + 1} do not overlap")
        return min(float(inset), 0.25 * float(slack[thin]))

    def inside(self, w: np.ndarray, inset: float = 0.0) -> np.ndarray:
        """(..., m, n) -> bool (..., m): strictly within ``inset`` of both spheres when inset > 0, in
        both closed balls when inset = 0 (no tolerance)."""
        da = w - self.ca
        db = w - self.cb
        ra, rb = self.ra - inset, self.rb - inset
        return (np.einsum("...i,...i->...", da, da) <= ra * ra) & (np.einsum("...i,...i->...", db, db) <= rb * rb)

    def centre_distances(self, w: np.ndarray) -> np.ndarray:
        """Waypoints (m, n) -> (m, 2): each one's distance from the centres of its hatch's two balls."""
        out = np.empty((len(w), 2))
        out[:, 0] = row_norms(w - self.ca)
        out[:, 1] = row_norms(w - self.cb)
        return out

    def outside_cm(self, W: np.ndarray) -> np.ndarray:
        """Waypoints stored coordinate-major, W (n, P, m) -> bool (P, m): outside either closed ball."""
        da = W - self.ca.T[:, None, :]
        db = W - self.cb.T[:, None, :]
        return (np.einsum("i...,i...->...", da, da) > self.ra * self.ra) | (
            np.einsum("i...,i...->...", db, db) > self.rb * self.rb
        )

    def project(self, w: np.ndarray, inset: float = 0.0) -> np.ndarray:
        """Euclidean projection of waypoints (..., m, n) onto the lenses shrunk by ``inset``.

        Closed form for the intersection of two balls A, B: a point in both stays; otherwise the
        projection onto one ball is the answer if it lies in the other; otherwise both constraints
        are active and the answer is the nearest point of the rim (the (n-2)-sphere where the spheres
        meet, radius rho about the portal centre, normal to c_b - c_a). Only the waypoints outside
        are computed.
        """
        w = np.asarray(w, dtype=float)
        ra, rb = self.ra - inset, self.rb - inset
        if np.any(ra <= 0) or np.any(rb <= 0):
            raise ValueError(f"inset {inset} is larger than a hatch ball's radius")
        da = w - self.ca
        db = w - self.cb
        outside = (np.einsum("...i,...i->...", da, da) > ra * ra) | (np.einsum("...i,...i->...", db, db) > rb * rb)
        res = w.copy()
        if not outside.any():
            return res
        idx = outside.nonzero()
        j = idx[-1]  # hatch of each outside waypoint
        x = w[idx]
        ca, cb, ra, rb = self.ca[j], self.cb[j], ra[j], rb[j]
        mid, u, rho, alt = self._rim(inset)
        mid, u, rho, alt = mid[j], u[j], rho[j], alt[j]

        def ball_proj(c, r):
            d = x - c
            nd = np.sqrt(np.einsum("ki,ki->k", d, d))
            return c + d * np.minimum(1.0, r / np.maximum(nd, _EPS))[:, None]

        def inside(p, c, r):
            d = p - c
            return np.einsum("ki,ki->k", d, d) <= r * r

        in_a, in_b = inside(x, ca, ra), inside(x, cb, rb)
        pa, pb = ball_proj(ca, ra), ball_proj(cb, rb)
        y = x - mid
        y -= np.einsum("ki,ki->k", y, u)[:, None] * u
        ny = np.sqrt(np.einsum("ki,ki->k", y, y))
        # A point on the axis is equidistant from the whole rim: take any rim point (a fixed normal).
        ydir = np.where((ny > _EPS)[:, None], y / np.maximum(ny, _EPS)[:, None], alt)
        out = mid + rho[:, None] * ydir
        # Neither single-ball projection feasible: both constraints active, the rim. (When both single-ball
        # projections are feasible they coincide: the projection is unique.)
        out = np.where((~in_b & inside(pb, ca, ra))[:, None], pb, out)
        out = np.where((~in_a & inside(pa, cb, rb))[:, None], pa, out)
        res[idx] = out
        return res

    def _rim(self, inset: float):
        """Rim of every shrunk lens: portal centre (m, n), axis u (m, n), radius rho (m,), and a unit
        vector normal to u (m, n). Cached per inset."""
        cache = self.__dict__.setdefault("_rim_cache", {})
        if inset not in cache:
            ra, rb = self.ra - inset, self.rb - inset
            v = self.cb - self.ca
            d = np.maximum(np.linalg.norm(v, axis=-1), _EPS)  # concentric: nested, the rim is never used
            u = v / d[:, None]
            t = (d * d + ra * ra - rb * rb) / (2 * d)
            rho = np.sqrt(np.maximum(ra * ra - t * t, 0.0))
            cache[inset] = (self.ca + t[:, None] * u, u, rho, _any_normal(u))
        return cache[inset]

    def sample(self, rng: np.random.Generator, idx: np.ndarray, max_rounds: int = 1000) -> np.ndarray:
        """Uniform points in the hatches ``idx`` (int array, any shape) -> (*idx.shape, n).

        Rejection sampling in the smaller ball of each hatch (as ``Rosary.sample_hatches``), for an
        arbitrary multiset of hatch indices.
        """
        idx = np.asarray(idx, dtype=np.intp)
        flat = idx.ravel()
        n = self.ca.shape[1]
        out = np.empty((flat.size, n))
        small_a = self.ra <= self.rb
        cs = np.where(small_a[:, None], self.ca, self.cb)[flat]
        rs = np.where(small_a, self.ra, self.rb)[flat]
        co = np.where(small_a[:, None], self.cb, self.ca)[flat]
        ro = np.where(small_a, self.rb, self.ra)[flat]
        todo = np.arange(flat.size)
        rs2, ro2 = rs * rs, ro * ro
        for round_ in range(max_rounds):
            if todo.size == 0:
                break
            if round_ < BALL_ROUNDS:
                g = rng.standard_normal((todo.size, n))
                g /= np.sqrt(np.add.reduce(g * g, axis=1, keepdims=True))  # np.linalg.norm
                pts = cs + g * (rs * rng.random(todo.size) ** (1.0 / n))[:, None]
            else:  # a thin lens holds a tiny share of the smaller ball (in 5-D and up): its bounding cylinder
                pts = _lens_cylinder_points(rng, cs, rs, co, ro)
            d = pts - co
            ok = np.add.reduce(d * d, axis=1) <= ro2
            np.subtract(pts, cs, d)
            ok &= np.add.reduce(d * d, axis=1) <= rs2
            out[todo[ok]] = pts[ok]
            # the points still to draw, and their balls
            left = ~ok
            todo, cs, rs, co, ro, rs2, ro2 = (a[left] for a in (todo, cs, rs, co, ro, rs2, ro2))
        else:
            if todo.size:
                raise RuntimeError("hatch sampling did not converge: a hatch is empty or degenerate")
        return out.reshape(idx.shape + (n,))


def _any_normal(u: np.ndarray) -> np.ndarray:
    """A unit vector normal to each row of u (m, n), n >= 2; zeros for n = 1 (a one-joint robot), where none
    exists and none is needed: two intervals that overlap always have a one-ball projection in the other."""
    if u.shape[1] == 1:
        return np.zeros_like(u)
    e = np.zeros_like(u)
    e[np.arange(len(u)), np.argmin(np.abs(u), axis=1)] = 1.0
    v = e - np.einsum("ij,ij->i", e, u)[:, None] * u
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@overload
def check_initial(rosary: Rosary, initial: np.ndarray | None, default: np.ndarray) -> np.ndarray: ...
@overload
def check_initial(rosary: Rosary, initial: np.ndarray, default: None = None) -> np.ndarray: ...
@overload
def check_initial(rosary: Rosary, initial: np.ndarray | None, default: None = None) -> np.ndarray | None: ...
def check_initial(rosary: Rosary, initial: np.ndarray | None, default: np.ndarray | None = None) -> np.ndarray | None:
    """Validate ``rosary`` (a :class:`Rosary`) and ``initial`` waypoints: shape (k-1, n), finite, every waypoint in its
    hatch. Every smoother's ``smooth`` calls this first."""
    check_rosary_type(rosary)
    if initial is None:
        return None if default is None else np.array(default, dtype=float)
    try:
        w = np.array(initial, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"initial waypoints must be an array of numbers, shape {(rosary.n_hatches, rosary.dim)}, got {initial!r:.80}") from None
    want = (rosary.n_hatches, rosary.dim)
    if w.shape != want:
        raise ValueError(f"initial waypoints must have shape {want} (one per hatch), got {w.shape}")
    if not np.all(np.isfinite(w)):
        raise ValueError("initial waypoints must be finite")
    bad = np.flatnonzero(~rosary.in_hatches(w))
    if bad.size:
        raise ValueError(f"initial waypoints {indices_text(bad)} (of {len(w)}) lie outside their hatches")
    return w


# -- the objective ----------------------------------------------------------------------------------
def population_objective(points: np.ndarray) -> np.ndarray:
    """f of Nascimento et al. 2020 Eq. 5 for a whole population of paths (P, m, n) -> (P,), in one numpy computation.

    The same function as :func:`foam_mj.paths.objective` (mean supplementary angle over the m - 2
    interior vertices plus the length; repeated points handled as there;
    the tests check equality), with fewer temporaries. Any leading batch shape works.
    """
    return coordinate_major_objective(np.moveaxis(np.asarray(points, dtype=float), -1, 0))


def coordinate_major_objective(X: np.ndarray) -> np.ndarray:
    """:func:`population_objective` for paths stored coordinate-major, X (n, P, m) -> (P,).

    The GA and HS keep their populations in this layout: with the short coordinate axis first every
    numpy loop runs over long contiguous rows, several times faster than over (..., 3) rows.
    """
    seg = X[..., 1:] - X[..., :-1]
    lens = np.sqrt(np.einsum("i...,i...->...", seg, seg))
    length = lens.sum(axis=-1)
    zero = lens <= _EPS
    if zero.any():  # repeated points take the next segment's direction, as in foam_mj.paths (rare: no cost otherwise)
        src = fill_index(zero)
        seg = np.take_along_axis(seg, np.broadcast_to(src, seg.shape), axis=-1)
        lens = np.take_along_axis(lens, src, axis=-1)
    dot = np.einsum("i...,i...->...", seg[..., :-1], seg[..., 1:])
    den = lens[..., :-1] * lens[..., 1:]
    # Only a path with every segment of zero length leaves den <= _EPS^2 (|dot| <= den): cos >= 1, straight.
    dot += den <= _EPS * _EPS
    cos = dot / np.maximum(den, _EPS * _EPS)
    np.minimum(cos, 1.0, out=cos)
    np.maximum(cos, -1.0, out=cos)
    ang = np.arccos(cos)
    n_ang = ang.shape[-1]
    angle = ang.sum(axis=-1) / n_ang if n_ang else np.zeros(ang.shape[:-1])
    return angle + length


#: Rounds of rejection sampling in the smaller ball before :meth:`sample` switches to the lens's bounding
#: cylinder (the ball proposal is kept first so that results drawn before the switch stay bit-identical).
BALL_ROUNDS = 200


def _lens_cylinder_points(rng: np.random.Generator, cs, rs, co, ro) -> np.ndarray:
    """Uniform points in the cylinder bounding each lens ball(cs, rs) & ball(co, ro) (rows), to be accepted
    by rejection. Along the axis u = (co - cs)/d the lens spans s in [max(-rs, d - ro), min(rs, d + ro)]
    from cs; its cross-section radius min(sqrt(rs^2 - s^2), sqrt(ro^2 - (s - d)^2)) peaks at the radical
    plane s = t or at a centre inside the other ball (s = 0 or s = d), the bound used. For a thin lens
    the acceptance stays about constant where the smaller ball's falls as (thickness / rs)^((n+1)/2)."""
    m, n = cs.shape
    v = co - cs
    d = np.maximum(np.linalg.norm(v, axis=1), _EPS)
    u = v / d[:, None]
    lo, hi = np.maximum(-rs, d - ro), np.minimum(rs, d + ro)
    t = np.clip((d * d + rs * rs - ro * ro) / (2 * d), lo, hi)

    def section(x):
        return np.sqrt(np.maximum(np.minimum(rs * rs - x * x, ro * ro - (x - d) ** 2), 0.0))

    rad = np.maximum.reduce([section(t), section(np.clip(0.0, lo, hi)), section(np.clip(d, lo, hi))])
    along = lo + (hi - lo) * rng.random(m)
    g = rng.standard_normal((m, n))
    g -= np.einsum("ki,ki->k", g, u)[:, None] * u  # uniform direction normal to u
    g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), _EPS)
    radial = rad * rng.random(m) ** (1.0 / max(n - 1, 1))
    return cs + along[:, None] * u + radial[:, None] * g
