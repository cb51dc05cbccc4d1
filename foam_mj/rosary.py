"""The rosary and its hatches (Nascimento et al. 2020 section 3.1; Nascimento and Alsina 2021 Defs. 2.2, 2.3, 2.5).

The rosary is the chain of bubbles from the root (centred at q_init) to the bubble holding q_goal,
found by following parents back from the goal bubble. Nascimento and Alsina 2021 numbers it from the goal
(b_1 = b_final); here index 0 is the root and index k-1 the goal bubble, so that paths, waypoints
and hatches all run from start to goal: hatch i is b_i ∩ b_(i+1) and holds waypoint i
(Nascimento et al. 2020 Eq. 3's q'_(i+1)).

Hatch geometry (docs/bubbles-math.md): two balls (c1, r1), (c2, r2) at distance
d < r1 + r2 meet in a lens; the spheres meet in the plane normal to c2 - c1 at distance
t = (d^2 + r1^2 - r2^2) / (2 d) from c1; the portal is the (n-1)-ball in that plane with centre
c1 + t (c2 - c1)/d and radius sqrt(r1^2 - t^2).

Balls are closed here (the bound of Nascimento and Alsina 2021 Eq. 4 is "<= d_t"), and membership allows
:data:`MEMBERSHIP_TOL` so that a child's centre, placed on its parent's surface in floating point,
counts as inside the parent.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

#: Absolute tolerance (configuration units) of every ball-membership test.
MEMBERSHIP_TOL = 1e-12


def fields_equal(a, b) -> bool:
    """``__eq__`` of a dataclass holding arrays: the same class and every compared field equal, arrays by shape and
    value, also inside dicts, lists and tuples (the generated ``__eq__`` compares field tuples, and ``==`` of two arrays
    has no single truth value: comparing two results raised numpy's ValueError). Another class: NotImplemented."""
    if type(a) is not type(b):
        return NotImplemented
    return all(_same(getattr(a, f.name), getattr(b, f.name)) for f in fields(a) if f.compare)


def _same(x, y) -> bool:
    if x is y:
        return True
    if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
        return isinstance(x, np.ndarray) and isinstance(y, np.ndarray) and np.array_equal(x, y)
    if isinstance(x, dict) and isinstance(y, dict):
        return x.keys() == y.keys() and all(_same(x[k], y[k]) for k in x)
    if isinstance(x, (list, tuple)) and isinstance(y, (list, tuple)):
        return type(x) is type(y) and len(x) == len(y) and all(_same(u, v) for u, v in zip(x, y))
    return bool(x == y)


def in_ball(points: np.ndarray, centers: np.ndarray, radii: np.ndarray, tol: float = MEMBERSHIP_TOL) -> np.ndarray:
    """Elementwise ``|points - centers| <= radii + tol`` over broadcast leading dimensions."""
    diff = np.asarray(points) - np.asarray(centers)
    return np.einsum("...i,...i->...", diff, diff) <= (np.asarray(radii) + tol) ** 2


def uniform_in_balls(rng: np.random.Generator, centers: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """One uniform point in each ball (centers (m, n), radii (m,)) -> (m, n)."""
    m, n = centers.shape
    u = rng.standard_normal((m, n))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    scale = radii * rng.random(m) ** (1.0 / n)
    return centers + u * scale[:, None]


def uniform_in_lenses(
    rng: np.random.Generator, ca: np.ndarray, ra: np.ndarray, cb: np.ndarray, rb: np.ndarray, max_rounds: int = 1000
) -> np.ndarray:
    """One uniform point in each lens (ball a ∩ ball b; centres (m, n), radii (m,)) -> (m, n).

    Rejection from the lens's bounding cylinder about the axis a -> b: along the axis the lens spans
    [max(d - r_b, -r_a), min(r_a, d + r_b)] from c_a; across it, at most the portal radius
    sqrt(r_a^2 - t^2) when the portal plane t = (d^2 + r_a^2 - r_b^2) / (2 d) lies between the centres
    (both caps are less than half balls), else the radius of the ball whose centre the lens holds.
    A thin lens, where sampling the smaller ball accepts about (overlap / diameter)^((n+1)/2) of the
    draws, is accepted here at a rate that does not shrink with its thickness. RuntimeError for an
    empty lens (d >= r_a + r_b).
    """
    ca, cb = np.atleast_2d(ca).astype(float), np.atleast_2d(cb).astype(float)
    ra, rb = np.atleast_1d(ra).astype(float), np.atleast_1d(rb).astype(float)
    m, n = ca.shape
    v = cb - ca
    d = np.linalg.norm(v, axis=1)
    u = np.where((d > 0)[:, None], v / np.maximum(d, 1e-300)[:, None], np.eye(n)[0])
    lo, hi = np.maximum(d - rb, -ra), np.minimum(ra, d + rb)
    if np.any(hi <= lo):
        raise RuntimeError("hatch sampling did not converge: a hatch is empty or degenerate")
    t = (d * d + ra * ra - rb * rb) / (2 * np.maximum(d, 1e-300))
    R = np.where(t < 0, ra, np.where(t > d, rb, np.sqrt(np.maximum(ra * ra - t * t, 0.0))))
    R = np.where(d > 0, R, np.minimum(ra, rb))
    out = np.empty((m, n))
    todo = np.arange(m)
    for _ in range(max_rounds):
        k = todo.size
        w = rng.standard_normal((k, n))
        w -= np.sum(w * u[todo], axis=1, keepdims=True) * u[todo]
        w /= np.maximum(np.linalg.norm(w, axis=1, keepdims=True), 1e-300)
        rad = R[todo] * rng.random(k) ** (1.0 / max(n - 1, 1)) if n > 1 else np.zeros(k)
        s = lo[todo] + (hi[todo] - lo[todo]) * rng.random(k)
        pts = ca[todo] + s[:, None] * u[todo] + rad[:, None] * w
        ok = in_ball(pts, ca[todo], ra[todo], tol=0.0) & in_ball(pts, cb[todo], rb[todo], tol=0.0)
        out[todo[ok]] = pts[ok]
        todo = todo[~ok]
        if todo.size == 0:
            return out
    raise RuntimeError("hatch sampling did not converge: a hatch is empty or degenerate")


@dataclass(frozen=True)
class Portal:
    """The (n-1)-ball where two consecutive bubbles' spheres meet: centre, radius and unit normal."""

    center: np.ndarray
    radius: float
    normal: np.ndarray

    __eq__ = fields_equal


@dataclass(frozen=True)
class Rosary:
    """Bubbles from the root (index 0, holds q_init) to the goal bubble (index k-1, holds q_goal).

    Everything is in the planner's coordinates q (radians for a hinge, metres for a slide, or a normalized joint's
    units): ``radii`` are Euclidean distances in q, not metres of workspace. Read-only copies, validated."""

    centers: np.ndarray  # (k, n)
    radii: np.ndarray  # (k,)
    q_init: np.ndarray  # (n,)
    q_goal: np.ndarray  # (n,)
    bubble_ids: np.ndarray | None = None  # (k,) indices into the foam, when extracted from one

    __eq__ = fields_equal  # arrays by value

    def __post_init__(self) -> None:
        c = np.array(self.centers, dtype=float)  # copies, kept read-only: an in-place edit would leave it uncertified
        r = np.array(self.radii, dtype=float)
        if c.ndim != 2 or len(c) < 1:
            raise ValueError(f"rosary centers must have shape (k, n) with k >= 1, got {c.shape}")
        if r.shape != (len(c),):
            raise ValueError(f"rosary radii must have shape ({len(c)},), got {r.shape}")
        if not (np.all(np.isfinite(c)) and np.all(np.isfinite(r)) and np.all(r > 0)):
            raise ValueError("rosary centers must be finite and radii finite and > 0")
        for name in ("q_init", "q_goal"):
            q = np.array(getattr(self, name), dtype=float)
            if q.shape != (c.shape[1],) or not np.all(np.isfinite(q)):
                raise ValueError(f"rosary {name} must be {c.shape[1]} finite numbers (the centres' dimension), got "
                                 f"{getattr(self, name)!r}")
            q.flags.writeable = False
            object.__setattr__(self, name, q)
        for name, value in (("centers", c), ("radii", r)):
            value.flags.writeable = False
            object.__setattr__(self, name, value)

    @property
    def k(self) -> int:
        """Number of bubbles."""
        return len(self.radii)

    @property
    def dim(self) -> int:
        return self.centers.shape[1]

    @property
    def n_hatches(self) -> int:
        """Number of hatches = number of free waypoints (k - 1)."""
        return self.k - 1

    # -- hatches -----------------------------------------------------------------------------------
    def hatch_balls(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(c_a, r_a, c_b, r_b) for every hatch: waypoint i must lie in ball a_i and ball b_i."""
        return self.centers[:-1], self.radii[:-1], self.centers[1:], self.radii[1:]

    def in_hatches(self, waypoints: np.ndarray, tol: float = MEMBERSHIP_TOL) -> np.ndarray:
        """Which waypoints lie in their hatch: waypoints (..., k-1, n) -> bool (..., k-1)."""
        ca, ra, cb, rb = self.hatch_balls()
        return in_ball(waypoints, ca, ra, tol) & in_ball(waypoints, cb, rb, tol)

    def all_in_hatches(self, waypoints: np.ndarray, tol: float = MEMBERSHIP_TOL) -> bool:
        return bool(np.all(self.in_hatches(waypoints, tol)))

    def portals(self) -> list[Portal]:
        """The portal of every hatch. When one ball lies inside the other the spheres do not meet and the
        portal degenerates to radius 0 (the hatch is then the smaller ball itself)."""
        out = []
        for c1, r1, c2, r2 in zip(*self.hatch_balls()):
            v = c2 - c1
            d = float(np.linalg.norm(v))
            u = v / d
            if abs(r1 - r2) >= d:  # nested balls: no sphere intersection; use the smaller ball's centre
                out.append(Portal((c1 if r1 < r2 else c2).copy(), 0.0, u))
                continue
            t = (d * d + r1 * r1 - r2 * r2) / (2 * d)
            out.append(Portal(c1 + t * u, float(np.sqrt(max(r1 * r1 - t * t, 0.0))), u))
        return out

    def sample_hatches(self, rng: np.random.Generator, size: int | None = None, max_rounds: int = 1000) -> np.ndarray:
        """Uniform random points in every hatch: (k-1, n), or (size, k-1, n) when ``size`` is given.

        Rejection sampling: draw uniformly in the smaller ball of each hatch and keep the points that
        lie in the other (the acceptance rate is the lens's share of the smaller ball).
        """
        if self.n_hatches == 0:
            return np.empty((0, self.dim) if size is None else (size, 0, self.dim))
        reps = 1 if size is None else int(size)
        ca, ra, cb, rb = self.hatch_balls()
        small_a = ra <= rb
        cs = np.where(small_a[:, None], ca, cb)
        rs = np.where(small_a, ra, rb)
        co = np.where(small_a[:, None], cb, ca)
        ro = np.where(small_a, rb, ra)
        cs, rs, co, ro = (np.tile(x, (reps,) + (1,) * (x.ndim - 1)) for x in (cs, rs, co, ro))
        out = np.empty_like(cs)
        todo = np.arange(len(rs))
        for _ in range(max_rounds):
            pts = uniform_in_balls(rng, cs[todo], rs[todo])
            ok = in_ball(pts, co[todo], ro[todo], tol=0.0) & in_ball(pts, cs[todo], rs[todo], tol=0.0)
            out[todo[ok]] = pts[ok]
            todo = todo[~ok]
            if todo.size == 0:
                break
        else:  # thin hatches: sample their lenses directly (raises for an empty one)
            out[todo] = uniform_in_lenses(rng, cs[todo], rs[todo], co[todo], ro[todo])
        out = out.reshape(reps, self.n_hatches, self.dim)
        return out[0] if size is None else out

    # -- reference paths ---------------------------------------------------------------------------
    def center_waypoints(self) -> np.ndarray:
        """The centre path's waypoints: the centres of bubbles 1..k-1 (each on its parent's surface, so in
        its hatch). With q_init (= centre 0) and q_goal they give the path T of Nascimento and Alsina 2021 (Fig. 6).

        A rosary not grown by the foam (a chain of overlapping bubbles from another planner) may have a
        centre outside its predecessor; that waypoint is then the portal centre of its hatch (on the
        segment between the two centres), so the centre path always runs through the hatches."""
        w = self.centers[1:].copy()
        ok = self.in_hatches(w)
        if not ok.all():
            w[~ok] = self.portal_waypoints()[~ok]
        return w

    def portal_waypoints(self) -> np.ndarray:
        """Waypoints at the portal centres (the middle of each hatch)."""
        return np.array([p.center for p in self.portals()]).reshape(self.n_hatches, self.dim)

    def path(self, waypoints: np.ndarray) -> np.ndarray:
        """[q_init, waypoints..., q_goal]: waypoints (..., k-1, n) -> points (..., k+1, n)."""
        w = np.asarray(waypoints, dtype=float)
        lead = w.shape[:-2]
        a = np.broadcast_to(self.q_init, lead + (1, self.dim))
        b = np.broadcast_to(self.q_goal, lead + (1, self.dim))
        return np.concatenate([a, w, b], axis=-2)

    def check_structure(self, tol: float = 1e-9) -> list[str]:
        """Problems with the rosary's structure (empty list when sound): q_init in the first bubble,
        q_goal in the last, consecutive bubbles overlapping."""
        problems = []
        if not in_ball(self.q_init, self.centers[0], self.radii[0], tol):
            problems.append("q_init is not in the first bubble")
        if not in_ball(self.q_goal, self.centers[-1], self.radii[-1], tol):
            problems.append("q_goal is not in the last bubble")
        d = np.linalg.norm(np.diff(self.centers, axis=0), axis=1)
        bad = np.flatnonzero(d >= self.radii[:-1] + self.radii[1:])
        if bad.size:
            problems.append(f"bubbles {bad.tolist()} do not overlap their successors")
        return problems
