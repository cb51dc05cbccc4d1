"""The objectives the smoothers minimise over a path [q_init, W, q_goal] and the ties between its points.

F(W) = w_len L + w_angle mean_i phi_i + w_sv mean_i phi_i^2, with L the length and phi_i the supplementary
angle pi - theta_i at the interior vertices (Nascimento et al. 2020 Eq. 3-5; SV: Nascimento and Alsina 2021
Eq. 7). Repeated points count once (foam_mj.paths); points closer than ``TIE`` are a tie, one point for the
optimal smoother (foam_mj.smoothing.scp, "Repeated points").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from foam_mj import paths
from foam_mj.smoothing.base import Hatches, _check_positive
from foam_mj.smoothing.subproblem import _h

TIE = 1e-5  # points closer than this are one point (a tie) in the next subproblem


@dataclass(frozen=True)
class ObjectiveWeights:
    """F = length * L + angle * mean(phi) + sv * mean(phi^2). Nascimento et al. 2020's f is (1, 1, 0)."""

    length: float = 1.0
    angle: float = 1.0
    sv: float = 0.0

    def __post_init__(self) -> None:
        for name in ("length", "angle", "sv"):
            _check_positive(f"weights.{name}", getattr(self, name), allow_zero=True)
        if self.length == 0 and self.angle == 0 and self.sv == 0:
            raise ValueError("weights: at least one of length, angle, sv must be > 0")

    PRESETS: ClassVar[dict[str, tuple[float, float, float]]] = {
        "f": (1.0, 1.0, 0.0),
        "sv": (0.0, 0.0, 1.0),
        "length": (1.0, 0.0, 0.0),
    }

    @classmethod
    def named(cls, objective: str) -> "ObjectiveWeights":
        if objective not in cls.PRESETS:
            raise ValueError(f"objective must be one of {sorted(cls.PRESETS)}, got {objective!r}")
        return cls(*cls.PRESETS[objective])

    @property
    def as_tuple(self) -> tuple[float, float, float]:
        return (float(self.length), float(self.angle), float(self.sv))

    @property
    def name(self) -> str:
        for key, value in self.PRESETS.items():
            if value == self.as_tuple:
                return key
        return "weighted({:g}, {:g}, {:g})".format(*self.as_tuple)


def objective_value(points: np.ndarray, weights: ObjectiveWeights) -> float:
    """F of a path (m, n) with the library's definitions (foam_mj.paths): the number reported."""
    p = np.asarray(points, dtype=float)
    phi = paths.turning_angles(p)
    value = weights.length * float(paths.path_length(p))
    if len(phi):
        value += weights.angle * float(phi.mean()) + weights.sv * float(np.mean(phi**2))
    return value


def objective_and_gradient(points: np.ndarray, weights: ObjectiveWeights, eps: float = 0.0) -> tuple[float, np.ndarray]:
    """F and its gradient with respect to every point of the path (m, n) (ends included).

    d phi / d a = -(b^ - cos(phi) a^) / (|a| sin(phi)) (and symmetrically for b), from
    cos(phi) = a.b / (|a||b|); d phi^2 = 2 phi d phi is smooth (phi / sin(phi) -> 1). At an exactly
    straight vertex the angle's gradient is taken as 0 (a subgradient); the certificate handles the
    whole subdifferential. With ``eps`` > 0 the angle term is the smooth sqrt(phi^2 + eps^2) - eps
    instead (how benchmarks/optimal_solvers.py hands the problem to smooth solvers). Segments must
    have non-zero length.
    """
    p = np.asarray(points, dtype=float)
    seg = np.diff(p, axis=0)
    lens = np.linalg.norm(seg, axis=1)
    if np.any(lens <= 0):
        raise ValueError("objective_and_gradient: the path has a zero-length segment")
    u = seg / lens[:, None]
    grad = np.zeros_like(p)
    value = weights.length * float(lens.sum())
    grad[:-1] -= weights.length * u
    grad[1:] += weights.length * u
    M = len(p) - 2
    if M > 0 and (weights.angle or weights.sv):
        ua, ub = u[:-1], u[1:]
        c = np.clip(np.einsum("ij,ij->i", ua, ub), -1.0, 1.0)
        phi = np.arccos(c)
        s = np.sin(phi)
        bent = s > 1e-12
        inv_s = np.where(bent, 1.0 / np.where(bent, s, 1.0), 0.0)
        ratio = np.where(bent, phi * inv_s, 1.0)  # phi / sin(phi) -> 1 at 0
        if eps > 0:
            root = np.sqrt(phi**2 + eps**2)
            value += weights.angle * float(np.mean(root - eps)) + weights.sv * float(np.mean(phi**2))
            d_angle = ratio / root  # d(root)/d phi * d phi / d(-cos)
        else:
            value += weights.angle * float(phi.mean()) + weights.sv * float(np.mean(phi**2))
            d_angle = inv_s
        coef = (weights.angle * d_angle + weights.sv * 2.0 * ratio) / M  # dF/d cos = -coef
        va = (ub - c[:, None] * ua) / lens[:-1, None]  # d cos / d a
        vb = (ua - c[:, None] * ub) / lens[1:, None]  # d cos / d b
        da, db = -coef[:, None] * va, -coef[:, None] * vb  # dF / da, dF / db at each vertex
        grad[:-2] -= da
        grad[1:-1] += da - db
        grad[2:] += db
    return value, grad


def _unit_segments(seg: np.ndarray, lens: np.ndarray) -> np.ndarray:
    """Unit directions of the segments, a zero-length one taking its neighbour's (foam_mj.paths)."""
    zero = lens <= paths._EPS
    if zero.any():
        src = paths.fill_index(zero)
        seg, lens = seg[src], lens[src]
    return seg / np.maximum(lens, paths._EPS)[:, None]


def tie_mask(p: np.ndarray, h: Hatches | None = None, inset: float = 0.0, tie: float = TIE) -> np.ndarray:
    """Which segments of the path p (L, n) join a tie: shorter than ``tie`` and, with ``h``, such that the
    point after the segment may stand on the point before it (that point is inside the shrunk hatch of
    the waypoint after it; at the end of the path the waypoint stands on q_goal, which must then be in
    its hatch). Exactly repeated points (<= 1e-12 apart) always form a tie."""
    lens = paths.row_norms(p[1:] - p[:-1])
    close = lens < tie
    exact = lens <= paths._EPS  # already one point (foam_mj.paths merges them too): always a tie
    if h is not None and (close & ~exact).any():
        L = len(p)
        j = np.flatnonzero(close)
        # segment j joins points j and j+1; waypoint of point k is hatch k-1
        wp = np.where(j + 1 <= L - 2, j + 1, j)  # the waypoint that moves onto the other point
        other = np.where(j + 1 <= L - 2, j, j + 1)
        ok = Hatches(h.ca[wp - 1], h.ra[wp - 1], h.cb[wp - 1], h.rb[wp - 1]).inside(p[other], inset)
        close[j[~ok]] = False
    return close | exact


def default_tie(weights: ObjectiveWeights) -> float:
    """The tie distance the solver uses: ``TIE`` when the objective has no SV term; otherwise only exact
    coincidences (a split corner, two close vertices sharing a turn, is what minimises SV, and a tie
    would hide it)."""
    return TIE if weights.sv == 0 else paths._EPS


def _true_value(p: np.ndarray, weights: ObjectiveWeights) -> float:
    """F with the angles from h(|v|) (arccos of the cosine, better conditioned near 0) and repeated
    points as in foam_mj.paths."""
    seg = p[1:] - p[:-1]
    lens = paths.row_norms(seg)
    value = weights.length * float(lens.sum())
    if len(p) > 2 and (weights.angle or weights.sv):
        u = _unit_segments(seg, lens)
        phi = _h(paths.row_norms(u[:-1] - u[1:]))
        value += weights.angle * float(phi.mean()) + weights.sv * float(np.mean(phi**2))
    return value
