"""Elmi and Efe 2018's experiment: a point robot on a 1000 x 1000 map with random circular obstacles, paths from a
start SP to a target TP through n waypoints, optimised for length F1 (Eq. 10-12) and smoothness F2
(Eq. 13) by MGOA and MOPSO (:mod:`foam_mj.smoothing.goa`, :mod:`foam_mj.smoothing.pso`).

The map (:class:`CircleMap`): obstacle centres uniform in the square, radii uniform in
``radius_range`` (Elmi and Efe 2018 does not give sizes; default [20, 45] pixels), obstacles that would come
within ``keep_clear`` of SP or TP redrawn; seeded. :data:`PAPER_ENVIRONMENTS` holds section III's two
environments (80 obstacles, SP (70.6, 847.2), TP (855.57, 152.80); 50 obstacles, SP (88.73, 845.39),
TP (681.9948, 179.92)); the paper ran its PSO from other points (also recorded), here both algorithms
solve the same problem.

The decision variables (:class:`PlanarPathProblem`), ``parametrization``:

* "offsets" (default; section III: "the distance between the initial and the target positions is
  divided into n + 1 equal segments", with coordinates x', y' in the frame of the line SP -> TP):
  waypoint i sits at x'_i = i |TP - SP| / (n + 1) along the line and the decision variable is its
  signed offset y'_i normal to it, bounded so that the waypoint stays on the map (D = n);
* "points": free waypoints (x_i, y_i) in the square (D = 2n, Eq. 17's decision vectors).

Objectives: F1 = sum of the n + 1 segment lengths (Eq. 12); F2 = sum of the angles phi_i at the n
waypoints plus delta l (Eq. 13), l the number of non-degenerate segments (with a fixed n, delta l is
nearly a constant). ``smoothness`` = "turning" (default): phi_i is the turning angle between the
segments meeting at waypoint i (0 for a straight line, < pi); "target": the literal reading of
section III, the angle at TP between the lines to two successive positions.

Collisions (better than the paper's rule, which moves waypoints that fall inside an obstacle to its
border and so misses segments crossing an obstacle between two free waypoints): every segment is
checked exactly against every circle (point-to-segment distance, vectorised over swarm x segments x
obstacles); the violation is the summed penetration depth max(0, r + clearance - dist) in pixels, and
the archive and personal bests compare solutions by **constrained dominance** (a collision-free path
dominates a colliding one; of two colliding ones the smaller violation wins; see
:mod:`foam_mj.smoothing.pareto`). No penalty weight to tune, and a front made of collision-free paths
whenever the swarm has found one. With "offsets" each segment stays between two fixed stations along
SP -> TP, so only the circles that reach that stretch are checked (a broad phase, about 1 pair in 7 on
the paper's maps; the same violation bit for bit).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from foam_mj.smoothing.base import SeedLike, _check_int, _check_positive, as_generator

#: Section III's environments (start and target of the MGOA runs; those of the paper's PSO figures too).
PAPER_ENVIRONMENTS: dict[int, dict[str, Any]] = {
    1: {"n_obstacles": 80, "start": (70.6, 847.2), "target": (855.57, 152.80),
        "pso_start": (66.71, 758.59), "pso_target": (797.28, 304.70)},
    2: {"n_obstacles": 50, "start": (88.73, 845.39), "target": (681.9948, 179.92),
        "pso_start": (219.56, 789.33), "pso_target": (801.16, 64.2)},
}
MAP_SIZE = 1000.0
PARAMETRIZATIONS = ("offsets", "points")
SMOOTHNESS = ("turning", "target")
_EPS = 1e-12


def _distance_to_segments(cx, cy, bx, by, den, t, tmp) -> np.ndarray:
    """|c - t b| with t = clip((c . b) / den, 0, 1): the distance of points c (relative to a segment's start,
    coordinates ``cx``, ``cy``) to segments of direction b (``den`` = max(|b|^2, eps)). In place: the result is
    ``cx``; ``cy``, ``t`` and ``tmp`` (arrays of c's shape) are overwritten."""
    np.multiply(cx, bx, out=t)
    t += np.multiply(cy, by, out=tmp)
    t /= den
    np.clip(t, 0.0, 1.0, out=t)
    cx -= np.multiply(t, bx, out=tmp)
    cy -= np.multiply(t, by, out=tmp)
    cx *= cx
    cy *= cy
    cx += cy
    return np.sqrt(cx, out=cx)


@dataclass(frozen=True)
class CircleMap:
    """A square map [0, size]^2 with circular obstacles (centres (K, 2), radii (K,)), a start and a target."""

    centers: np.ndarray
    radii: np.ndarray
    start: np.ndarray
    target: np.ndarray
    size: float = MAP_SIZE
    info: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        c = np.asarray(self.centers, dtype=float).reshape(-1, 2)
        r = np.asarray(self.radii, dtype=float).ravel()
        if len(r) != len(c) or not (np.all(np.isfinite(c)) and np.all(np.isfinite(r)) and np.all(r > 0)):
            raise ValueError("centers must be (K, 2) and radii (K,), finite, radii > 0")
        _check_positive("size", self.size)
        for name in ("start", "target"):
            p = np.asarray(getattr(self, name), dtype=float)
            if p.shape != (2,) or not np.all((p >= 0) & (p <= self.size)):
                raise ValueError(f"{name} must be a point (x, y) on the map [0, {self.size}]^2, got {p.tolist()}")
            object.__setattr__(self, name, p)
        object.__setattr__(self, "centers", c)
        object.__setattr__(self, "radii", r)

    @classmethod
    def random(
        cls,
        n_obstacles: int,
        seed: SeedLike = 0,
        start=(70.6, 847.2),
        target=(855.57, 152.80),
        *,
        size: float = MAP_SIZE,
        radius_range: tuple[float, float] = (20.0, 45.0),
        keep_clear: float = 20.0,
    ) -> "CircleMap":
        """``n_obstacles`` circles, centres uniform on the map, radii uniform in ``radius_range``; a circle
        closer than ``keep_clear`` to the start or the target is redrawn."""
        _check_int("n_obstacles", n_obstacles, 0)
        _check_positive("keep_clear", keep_clear, allow_zero=True)
        lo, hi = (float(x) for x in radius_range)
        if not (0 < lo <= hi):
            raise ValueError(f"radius_range must satisfy 0 < low <= high, got {radius_range!r}")
        rng = as_generator(seed)
        ends = np.array([start, target], dtype=float)
        cs: list[np.ndarray] = []
        rs: list[float] = []
        while len(cs) < n_obstacles:
            c = rng.uniform(0.0, size, 2)
            r = rng.uniform(lo, hi)
            if np.all(np.linalg.norm(ends - c, axis=1) > r + keep_clear):
                cs.append(c)
                rs.append(r)
        return cls(np.array(cs).reshape(-1, 2), np.array(rs), np.asarray(start), np.asarray(target), size,
                   {"n_obstacles": n_obstacles, "seed": seed if not isinstance(seed, np.random.Generator) else None,
                    "radius_range": [lo, hi], "keep_clear": keep_clear})

    def segment_distances(self, points: np.ndarray) -> np.ndarray:
        """Distance from every circle's centre to every segment of polylines (..., m, 2) -> (..., m-1, K)."""
        p = np.asarray(points, dtype=float)
        # Per coordinate (x, y) to avoid reductions over a length-2 axis.
        ax, ay = p[..., :-1, 0, None], p[..., :-1, 1, None]  # (..., m-1, 1)
        bx = p[..., 1:, 0, None] - ax
        by = p[..., 1:, 1, None] - ay
        cx = np.empty(ax.shape[:-1] + (len(self.radii),))
        cy, t, tmp = self._work(cx.shape)
        # The operations of (cx, cy) = c - a; t = clip((cx bx + cy by) / den, 0, 1); |(cx, cy) - t b|,
        # in place: a swarm's evaluation (500 paths x 9 segments x 80 circles) then allocates and first
        # touches one large array instead of a dozen, which was most of its cost.
        np.subtract(self.centers[:, 0], ax, out=cx)  # (..., m-1, K)
        np.subtract(self.centers[:, 1], ay, out=cy)
        den = np.maximum(bx * bx + by * by, _EPS)
        return _distance_to_segments(cx, cy, bx, by, den, t, tmp)

    def _work(self, shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Three work arrays of ``shape`` for :meth:`segment_distances`, kept for the next call of the same
        shape (one map is evaluated by one thread at a time)."""
        work = self.__dict__.get("_work_arrays")
        if work is None or work[0].shape != shape:
            work = (np.empty(shape), np.empty(shape), np.empty(shape))
            object.__setattr__(self, "_work_arrays", work)
        return work

    def violation(self, points: np.ndarray, clearance: float = 0.0, near: np.ndarray | None = None) -> np.ndarray:
        """Summed penetration max(0, r + clearance - dist) over segments and circles: (..., m, 2) -> (...).

        ``near`` (optional, bool (m-1, K)): a broad phase, the segment/circle pairs that may come closer than
        r + clearance; the caller guarantees that every other pair stays farther (penetration 0) for these
        polylines (:class:`PlanarPathProblem` derives it from its fixed waypoint stations). Only the near pairs
        are computed, with the same operations, and the sum is taken in the dense order: the result is the
        same, bit for bit."""
        if len(self.radii) == 0:
            return np.zeros(np.shape(points)[:-2])
        if near is not None:
            return self._violation_near(np.asarray(points, dtype=float), clearance, near)
        d = self.segment_distances(points)
        pen = np.subtract(self.radii + clearance, d, out=d)  # (r + clearance) - dist, as written above
        return np.maximum(pen, 0.0, out=pen).sum(axis=(-1, -2))

    def _violation_near(self, p: np.ndarray, clearance: float, near: np.ndarray) -> np.ndarray:
        """:meth:`violation` over the pairs of ``near`` only (see there)."""
        lead, m = p.shape[:-2], p.shape[-2]
        K = len(self.radii)
        if near.shape != (m - 1, K):
            raise ValueError(f"near must have shape {(m - 1, K)}, got {near.shape}")
        q = p.reshape(-1, m, 2)
        P = len(q)
        work = self.__dict__.get("_near_work")
        if work is None or work[0] is not near or work[1].shape[0] != P:
            seg, circ = np.nonzero(near)  # in the dense (segment, circle) order
            # dense (P, segments x circles) penetrations: zero where not near, the near columns rewritten per call
            work = (near, np.zeros((P, (m - 1) * K)), seg, seg * K + circ, self.centers[circ, 0, None],
                    self.centers[circ, 1, None], np.empty((5, m - 1, P)))
            object.__setattr__(self, "_near_work", work)
        _, dense, seg, flat, ccx, ccy, A = work
        R = (self.radii + clearance)[flat % K, None]
        # per segment (segment-major, (m - 1, P)), as segment_distances: a, b = next - a, den = max(|b|^2, eps);
        # then gathered per pair (pairs, P) and the same operations as there
        ax, ay, bx, by, den = A
        ax[...] = q[:, :-1, 0].T
        ay[...] = q[:, :-1, 1].T
        np.subtract(q[:, 1:, 0].T, ax, out=bx)
        np.subtract(q[:, 1:, 1].T, ay, out=by)
        np.maximum(bx * bx + by * by, _EPS, out=den)
        ax, ay, bx, by, den = np.take(A, seg, axis=1)
        cx = np.subtract(ccx, ax)
        cy = np.subtract(ccy, ay)
        d = _distance_to_segments(cx, cy, bx, by, den, np.empty_like(cx), np.empty_like(cx))
        pen = np.subtract(R, d, out=d)
        np.maximum(pen, 0.0, out=pen)
        dense[:, flat] = pen.T  # summed in the dense order, zeros elsewhere: the same sum as violation's
        return dense.reshape(P, m - 1, K).sum(axis=(-1, -2)).reshape(lead)

    def collision_free(self, points: np.ndarray, clearance: float = 0.0) -> bool:
        """True when the polyline (m, 2) stays at least ``clearance`` from every circle and on the map."""
        p = np.asarray(points, dtype=float)
        on_map = bool(np.all((p >= 0) & (p <= self.size)))
        return on_map and bool(len(self.radii) == 0 or np.all(self.segment_distances(p) >= self.radii + clearance))


def paper_environment(env: int, seed: SeedLike | None = None, **kwargs) -> CircleMap:
    """Environment #1 (80 obstacles) or #2 (50) of Elmi and Efe 2018 section III, obstacles drawn with ``seed``
    (default: the environment's number)."""
    if env not in PAPER_ENVIRONMENTS:
        raise ValueError(f"env must be one of {sorted(PAPER_ENVIRONMENTS)}, got {env!r}")
    e = PAPER_ENVIRONMENTS[env]
    cmap = CircleMap.random(e["n_obstacles"], env if seed is None else seed, e["start"], e["target"], **kwargs)
    cmap.info["environment"] = env
    return cmap


def path_length(points: np.ndarray) -> np.ndarray:
    """F1 (Eq. 10-12): the sum of segment lengths, (..., m, 2) -> (...)."""
    seg = np.diff(np.asarray(points, dtype=float), axis=-2)
    return np.sqrt(np.sum(seg * seg, axis=-1)).sum(axis=-1)


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    nu = np.sqrt(np.sum(u * u, axis=-1))
    nv = np.sqrt(np.sum(v * v, axis=-1))
    den = nu * nv
    cos = np.where(den > _EPS, np.sum(u * v, axis=-1) / np.where(den > _EPS, den, 1.0), 1.0)
    return np.arccos(np.clip(cos, -1.0, 1.0))


def smoothness(points: np.ndarray, delta: float = 0.0, mode: str = "turning") -> np.ndarray:
    """F2 (Eq. 13): sum of phi_i over the m - 2 interior points plus delta x (number of segments longer than
    1e-12). ``mode`` "turning": phi_i the turning angle at point i (0 when straight; a zero-length
    segment counts as straight); "target": the angle at the last point (TP) between the lines to points
    i and i + 1, i = 0..m-3. (..., m, 2) -> (...)."""
    p = np.asarray(points, dtype=float)
    seg = np.diff(p, axis=-2)
    if mode == "turning":
        phi = _angle(seg[..., :-1, :], seg[..., 1:, :])
    elif mode == "target":
        to = p[..., :-1, :] - p[..., -1:, :]
        phi = _angle(to[..., :-1, :], to[..., 1:, :])
    else:
        raise ValueError(f"smoothness mode must be one of {SMOOTHNESS}, got {mode!r}")
    n_seg = np.count_nonzero(np.sum(seg * seg, axis=-1) > _EPS * _EPS, axis=-1)
    return phi.sum(axis=-1) + delta * n_seg


def _length_and_turning(p: np.ndarray, delta: float) -> np.ndarray:
    """(path_length, smoothness(mode="turning")) of polylines (P, m, 2) -> (P, 2), per coordinate (x, y)
    instead of reductions over a length-2 axis: the same operations, so the same values bit for bit."""
    sx = p[:, 1:, 0] - p[:, :-1, 0]
    sy = p[:, 1:, 1] - p[:, :-1, 1]
    sq = sx * sx
    sq += sy * sy
    lens = np.sqrt(sq)
    out = np.empty((len(p), 2))
    np.add.reduce(lens, axis=-1, out=out[:, 0])
    den = lens[:, :-1] * lens[:, 1:]
    dot = sx[:, :-1] * sx[:, 1:]
    dot += sy[:, :-1] * sy[:, 1:]
    ok = den > _EPS
    cos = np.where(ok, dot / np.where(ok, den, 1.0), 1.0)
    phi = np.arccos(np.clip(cos, -1.0, 1.0))
    n_seg = np.count_nonzero(sq > _EPS * _EPS, axis=-1)
    np.add(phi.sum(axis=-1), delta * n_seg, out=out[:, 1])
    return out


class PlanarPathProblem:
    """Paths on a :class:`CircleMap` as a two-objective problem (F1, F2) for MGOA / MOPSO (see the module
    docstring). Implements the :class:`~foam_mj.smoothing.multiobjective.Problem` protocol: ``lb``, ``ub``,
    ``sample``, ``repair`` (clipping to the box), ``evaluate`` -> (objectives (P, 2), violation (P,))."""

    names = ("F1", "F2")

    def __init__(
        self,
        cmap: CircleMap,
        n_waypoints: int = 8,
        *,
        parametrization: str = "offsets",
        delta: float = 0.0,
        smoothness: str = "turning",
        clearance: float = 1.0,
    ) -> None:
        _check_int("n_waypoints", n_waypoints, 1)
        if parametrization not in PARAMETRIZATIONS:
            raise ValueError(f"parametrization must be one of {PARAMETRIZATIONS}, got {parametrization!r}")
        if smoothness not in SMOOTHNESS:
            raise ValueError(f"smoothness must be one of {SMOOTHNESS}, got {smoothness!r}")
        _check_positive("delta", delta, allow_zero=True)
        _check_positive("clearance", clearance, allow_zero=True)
        self.map = cmap
        self.n = int(n_waypoints)
        self.parametrization = parametrization
        self.delta = float(delta)
        self.mode = smoothness
        self.clearance = float(clearance)
        sp, tp = cmap.start, cmap.target
        L = float(np.linalg.norm(tp - sp))
        if L <= 0:
            raise ValueError("start and target coincide")
        self.e = (tp - sp) / L
        self.normal = np.array([-self.e[1], self.e[0]])
        self.base = sp + np.outer(np.arange(1, self.n + 1) / (self.n + 1) * L, self.e)  # (n, 2) on the line
        if parametrization == "offsets":
            lo = np.full(self.n, -np.inf)
            hi = np.full(self.n, np.inf)
            for k in range(2):
                if abs(self.normal[k]) > _EPS:
                    y0 = (0.0 - self.base[:, k]) / self.normal[k]
                    y1 = (cmap.size - self.base[:, k]) / self.normal[k]
                    lo = np.maximum(lo, np.minimum(y0, y1))
                    hi = np.minimum(hi, np.maximum(y0, y1))
            self.lb, self.ub = lo, hi
        else:
            self.lb = np.zeros(2 * self.n)
            self.ub = np.full(2 * self.n, cmap.size)
        self._near = self._near_pairs()

    def _near_pairs(self) -> np.ndarray | None:
        """Broad phase of the collision check, "offsets" only: waypoint i always lies on the normal to SP -> TP
        at the station x'_i = i |TP - SP| / (n + 1), so segment i spans [x'_i, x'_(i+1)] along the line and a
        circle whose centre projects farther than its r + clearance outside that interval cannot touch it.
        -> bool (n + 1, K) of the pairs to check (a margin of 1e-6 map sizes covers rounding), None for
        "points"."""
        if self.parametrization != "offsets" or len(self.map.radii) == 0:
            return None
        L = float(np.linalg.norm(self.map.target - self.map.start))
        x = np.arange(self.n + 2) / (self.n + 1) * L
        along = (self.map.centers - self.map.start) @ self.e
        reach = self.map.radii + self.clearance + 1e-6 * self.map.size
        return (along + reach >= x[:-1, None]) & (along - reach <= x[1:, None])

    @property
    def dim(self) -> int:
        return len(self.lb)

    def waypoints(self, X: np.ndarray) -> np.ndarray:
        """Decision vectors (..., D) -> waypoints (..., n, 2)."""
        X = np.asarray(X, dtype=float)
        if self.parametrization == "offsets":
            return self.base + X[..., :, None] * self.normal
        return X.reshape(X.shape[:-1] + (self.n, 2))

    def paths(self, X: np.ndarray) -> np.ndarray:
        """Decision vectors (..., D) -> polylines [SP, waypoints, TP] (..., n + 2, 2)."""
        w = self.waypoints(X)
        lead = w.shape[:-2]
        a = np.broadcast_to(self.map.start, lead + (1, 2))
        b = np.broadcast_to(self.map.target, lead + (1, 2))
        return np.concatenate([a, w, b], axis=-2)

    def straight(self) -> np.ndarray:
        """The decision vector of the straight line SP -> TP."""
        return np.zeros(self.n) if self.parametrization == "offsets" else self.base.ravel().copy()

    def sample(self, rng: np.random.Generator, size: int) -> np.ndarray:
        return self.lb + (self.ub - self.lb) * rng.random((size, self.dim))

    def repair(self, X: np.ndarray) -> np.ndarray:
        return np.clip(X, self.lb, self.ub)

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = self.paths(X)
        if self.mode == "turning" and p.ndim == 3:
            F = _length_and_turning(p, self.delta)
        else:
            F = np.stack([path_length(p), smoothness(p, self.delta, self.mode)], axis=-1)
        # the broad phase holds for offsets within a few map sizes (rounding of the stations stays tiny)
        X = np.asarray(X, dtype=float)
        near = self._near if self._near is not None and X.size and np.abs(X).max() <= 4 * self.map.size else None
        return F, self.map.violation(p, self.clearance, near)
