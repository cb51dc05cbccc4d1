"""Path metrics: length, the turning angles of Nascimento et al. 2020 Eq. 4, the objective f of Eq. 5, TC (Nascimento and Alsina 2021
Eq. 6) and SV (Eq. 7), and the dense clearance check along a path.

Every function takes points of shape (..., m, n) (m points of dimension n) and works on whole
populations at once (leading dimensions are batch dimensions).

Angles. Nascimento et al. 2020 Eq. 4 defines theta_i as the opening angle at an interior vertex (pi for a straight
line) and Eq. 5 averages pi - theta_i; Nascimento and Alsina 2021 Eq. 7 squares the supplementary angle pi - theta_i.
Both are taken over every interior vertex of [q_init, q'_1, ..., q'_(k-1), q_goal], i.e. k - 1 angles.
Nascimento et al. 2020 writes the mean as a sum over i = 1..k-2 divided by k - 2, but its own sigma holds k - 1
waypoints, so with the endpoints there are k - 1 angles; we average over all of them (the choice
does not change the minimiser's character and makes f well defined for any k >= 2).

Repeated points. At a zero-length segment (|p_(j+1) - p_j| <= 1e-12) the angle is undefined. Such a
segment takes the direction of the next segment of non-zero length (of the previous one at the end of
the path), so the repeated point adds one straight vertex and the corner it sits on is counted once,
in full: the angle sum is then the limit of the sums as the points separate along the path, the
lowest value near the repeated points. (Counting both vertices next to a zero-length segment as
straight, as an earlier version of this module did, let an optimiser hide a corner by stacking two waypoints
on it.)
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

_EPS = 1e-12


def row_norms(x: np.ndarray) -> np.ndarray:
    """Euclidean norms along the last axis of a float array: np.linalg.norm(x, axis=-1)'s numbers without its
    argument checks (a microsecond less a call; the optimal smoother makes some 60 calls a run)."""
    return np.sqrt(np.add.reduce(x * x, axis=-1))


def segment_lengths(points: np.ndarray) -> np.ndarray:
    """(..., m, n) -> (..., m-1)."""
    return np.linalg.norm(np.diff(points, axis=-2), axis=-1)


def path_length(points: np.ndarray) -> np.ndarray:
    """sigma_length: the sum of segment lengths. (..., m, n) -> (...)."""
    return segment_lengths(points).sum(axis=-1)


def fill_index(zero: np.ndarray) -> np.ndarray:
    """For a mask of zero-length segments (..., S) the index of the segment whose direction each one
    takes: itself when non-zero, else the next non-zero one, else the previous one (itself when all are
    zero). See "Repeated points" above."""
    S = zero.shape[-1]
    idx = np.broadcast_to(np.arange(S), zero.shape)
    nxt = np.flip(np.minimum.accumulate(np.flip(np.where(zero, S, idx), -1), axis=-1), -1)
    prv = np.maximum.accumulate(np.where(zero, -1, idx), axis=-1)
    return np.where(nxt < S, nxt, np.where(prv >= 0, prv, idx))


def turning_angles(points: np.ndarray) -> np.ndarray:
    """Supplementary angles pi - theta_i at the interior vertices (0 for a straight line), Nascimento et al. 2020 Eq. 4
    and Nascimento and Alsina 2021 Eq. 7. (..., m, n) -> (..., m-2). Repeated points: see the module docstring."""
    seg = np.diff(points, axis=-2)
    lens = np.linalg.norm(seg, axis=-1)
    zero = lens <= _EPS
    if zero.any():
        src = fill_index(zero)
        seg = np.take_along_axis(seg, src[..., None], axis=-2)
        lens = np.take_along_axis(lens, src, axis=-1)
    a, b = seg[..., :-1, :], seg[..., 1:, :]
    na, nb = lens[..., :-1], lens[..., 1:]
    dot = np.einsum("...i,...i->...", a, b)
    denom = na * nb
    ok = denom > _EPS * _EPS  # false only when every segment has zero length
    cos = np.where(ok, dot / np.where(ok, denom, 1.0), 1.0)
    # Eq. 4's theta_i is the angle between (q'_i - q'_(i+1)) and (q'_(i+2) - q'_(i+1)), i.e. between -a and b;
    # pi - theta_i is then the angle between a and b.
    return np.arccos(np.clip(cos, -1.0, 1.0))


def angle_term(points: np.ndarray) -> np.ndarray:
    """Mean of (pi - theta_i) over the interior vertices: the first term of Nascimento et al. 2020 Eq. 5."""
    return _vertex_mean(turning_angles(points))


def _vertex_mean(t: np.ndarray) -> np.ndarray:
    """The mean over the interior vertices (last axis) of a per-vertex value, 0 for a path without any."""
    return t.mean(axis=-1) if t.shape[-1] else np.zeros(t.shape[:-1])


def objective(points: np.ndarray) -> np.ndarray:
    """f(sigma) of Nascimento et al. 2020 Eq. 5: mean (pi - theta_i) + sigma_length. (..., m, n) -> (...)."""
    return angle_term(points) + path_length(points)


def objective_terms(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two terms of Eq. 5: (angle term, length)."""
    return angle_term(points), path_length(points)


def tc(points: np.ndarray) -> np.ndarray:
    """TC of Nascimento and Alsina 2021 Eq. 6: |q_goal - q_init| / path length (1 for a straight line, 0 for a path
    back to its start). A path that does not move (length <= 1e-12), where Eq. 6 is 0 / 0, has TC 0: it was
    |q_goal - q_init| / 1e-12, any value in [0, 1) depending on how little the path moved."""
    return _tc(points, path_length(points))


def _tc(points: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Eq. 6 for points whose path length is known."""
    de = np.linalg.norm(points[..., -1, :] - points[..., 0, :], axis=-1)
    return np.where(length > _EPS, de / np.maximum(length, _EPS), 0.0)


def sv(points: np.ndarray) -> np.ndarray:
    """SV of Nascimento and Alsina 2021 Eq. 7: mean squared supplementary angle over the interior vertices (0 = straight)."""
    return _vertex_mean(turning_angles(points) ** 2)


@dataclass(frozen=True)
class PathMetrics:
    """The papers' measures of one path."""

    length: float
    angle_term: float
    f: float
    tc: float
    sv: float
    n_points: int

    def as_dict(self) -> dict:
        return asdict(self)


def metrics(points: np.ndarray) -> PathMetrics:
    """All metrics of one path (m, n)."""
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or len(p) < 2:
        raise ValueError(f"a path needs shape (m >= 2, n), got {p.shape}")
    t, length = turning_angles(p), path_length(p)  # (each computed once for the four measures)
    a, length_ = float(_vertex_mean(t)), float(length)
    return PathMetrics(length_, a, a + length_, float(_tc(p, length)), float(_vertex_mean(t**2)), len(p))


def densify(points: np.ndarray, step: float = 1e-3) -> np.ndarray:
    """Points along the polyline with at most ``step`` between neighbours (max-norm in q), ends included."""
    p = np.asarray(points, dtype=float)
    if not step > 0:
        raise ValueError(f"`step` must be > 0, got {step}")
    out = [p[:1]]
    for a, b in zip(p[:-1], p[1:]):
        n = max(1, int(np.ceil(np.max(np.abs(b - a)) / step)))
        s = np.arange(1, n + 1)[:, None] / n
        out.append(a + (b - a) * s)
    return np.concatenate(out)


def min_clearance_along(clearance, points: np.ndarray, step: float = 1e-3) -> float:
    """The smallest MuJoCo clearance over the polyline sampled every ``step`` (max-norm) in q."""
    return float(np.min(clearance.batch(densify(points, step))))
