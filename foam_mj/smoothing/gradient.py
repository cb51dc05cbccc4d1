"""Gradient smoothing (paper 003 section 4.4, Eq. 9) and the analytic gradients of SV and TC.

Eq. 9 moves every interior vertex p_i of the path down the gradient of SV (paper 003 Eq. 7),

    x_j^i <- x_j^i - eta dSV/dx_j^i,     eta = 0.005 (section 5.1),

with the ends q_init and q_goal fixed. Here the vertices are the waypoints sigma, and each step is
followed by the Euclidean projection of every waypoint onto its hatch (closed form, see
:meth:`Hatches.project`), i.e. projected gradient descent: the path stays in the rosary, so it stays
safe. (The thesis does not say how it keeps the smoothed vertices in the bubbles; projection keeps the
full step inside the hatch and moves along its boundary when a constraint is active, where step
halving would stall there.) All vertices move at once (Jacobi order: Eq. 9 applied to the gradient at
the current path). The iterate with the lowest SV is returned.

Gradients (per interior vertex i, a = p_i - p_(i-1), b = p_(i+1) - p_i, c = cos of the turn theta_i):

    dc/da = b / (|a||b|) - c a / |a|^2,   dc/db = a / (|a||b|) - c b / |b|^2,
    d(theta^2)/dc = -2 theta / sin(theta)   (-> -2 as theta -> 0; no singularity at a straight vertex).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from foam_mj import paths
from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import (
    Hatches,
    MeanStall,
    SeedLike,
    SmoothingResult,
    Smoother,
    StopCriteria,
    _check_positive,
    check_initial,
    trivial_result,
)

_EPS = 1e-12


def sv_and_gradient(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SV (paper 003 Eq. 7) of paths (..., L, n) and its gradient with respect to every point (..., L, n).

    The gradient of the end points is returned too (callers keep them fixed). A vertex next to a
    zero-length segment has no defined turn: it contributes 0 to SV and to the gradient.
    """
    p = np.asarray(points, dtype=float)
    seg = np.diff(p, axis=-2)
    a, b = seg[..., :-1, :], seg[..., 1:, :]
    ls = np.sqrt(np.einsum("...i,...i->...", seg, seg))
    la, lb = ls[..., :-1], ls[..., 1:]
    den = la * lb
    ok = den > _EPS
    safe = np.where(ok, den, 1.0)
    c = np.clip(np.where(ok, np.einsum("...i,...i->...", a, b) / safe, 1.0), -1.0, 1.0)
    theta = np.arccos(c)
    n_ang = theta.shape[-1]
    sv = (theta**2).sum(axis=-1) / n_ang if n_ang else np.zeros(theta.shape[:-1])
    s = np.sin(theta)
    # d(theta^2)/dc = -2 theta / sin theta, with its limit -2 at theta = 0 (and a cap near theta = pi).
    ratio = np.where(s > 1e-8, theta / np.maximum(s, 1e-8), 1.0)
    g = np.where(ok, -2.0 * ratio, 0.0) / max(n_ang, 1)
    la_s = np.where(ok, la, 1.0)[..., None]
    lb_s = np.where(ok, lb, 1.0)[..., None]
    dc_da = b / (la_s * lb_s) - c[..., None] * a / la_s**2
    dc_db = a / (la_s * lb_s) - c[..., None] * b / lb_s**2
    ga = g[..., None] * dc_da  # d SV / d a_i
    gb = g[..., None] * dc_db  # d SV / d b_i
    grad = np.zeros_like(p)
    # a_i = p_i - p_(i-1), b_i = p_(i+1) - p_i with i the vertex index 1..L-2
    grad[..., 1:-1, :] += ga - gb
    grad[..., :-2, :] -= ga
    grad[..., 2:, :] += gb
    return sv, grad


def tc_and_gradient(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """TC (paper 003 Eq. 6) = |p_last - p_first| / length of paths (..., L, n), and dTC/dp for the
    interior points (ends held fixed: their entries are 0). dTC/dp_i = -(D_e / D_cam^2) dD_cam/dp_i,
    dD_cam/dp_i = u_(i-1,i) - u_(i,i+1) (unit vectors of the adjacent segments)."""
    p = np.asarray(points, dtype=float)
    seg = np.diff(p, axis=-2)
    ls = np.linalg.norm(seg, axis=-1)
    u = seg / np.maximum(ls, _EPS)[..., None]
    length = ls.sum(axis=-1)
    de = np.linalg.norm(p[..., -1, :] - p[..., 0, :], axis=-1)
    tc = de / np.maximum(length, _EPS)
    grad = np.zeros_like(p)
    grad[..., 1:-1, :] = -(de / np.maximum(length, _EPS) ** 2)[..., None, None] * (u[..., :-1, :] - u[..., 1:, :])
    return tc, grad


@dataclass(frozen=True)
class GradientSmoothing(Smoother):
    """Projected gradient descent of SV over the waypoints (paper 003 Eq. 9, eta = 0.005).

    ``initial`` defaults to the centre path's waypoints (the thesis smooths T into T_CA, and T_RA into
    T_RCA). ``stop`` applies to SV: by default the run stops once SV has fallen by less than 1e-5 over
    100 steps (SV drops by ~95% in the first 200 steps, then creeps), capped at 20,000 steps; it also
    ends when a step moves no waypoint by more than ``tol``. ``inset`` shrinks the hatches the
    projection uses (configuration units), so waypoints end strictly inside. ``seed`` is accepted for
    the common interface and unused (the method is deterministic). The history holds the lowest SV
    after each step; ``info["initial"]`` the SV of the initial path.
    """

    eta: float = 0.005
    tol: float = 1e-12
    inset: float = 1e-10
    stop: StopCriteria = field(default_factory=lambda: StopCriteria(stall_iterations=100, stall_tol=1e-5))

    name: ClassVar[str] = "gradient"

    def __post_init__(self) -> None:
        _check_positive("eta", self.eta)
        _check_positive("tol", self.tol, allow_zero=True)
        _check_positive("inset", self.inset, allow_zero=True)
        if not isinstance(self.stop, StopCriteria):
            raise ValueError(f"stop must be a StopCriteria, got {self.stop!r}")

    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> SmoothingResult:
        t_start = time.perf_counter()
        w = check_initial(rosary, initial, default=rosary.center_waypoints())
        if rosary.n_hatches == 0:
            return trivial_result(self.name, rosary, t_start, objective="SV")
        h = Hatches.of(rosary)
        w = h.project(w, self.inset)  # a centre waypoint sits on its parent's surface: move it inside
        path = rosary.path(w)
        sv, grad = sv_and_gradient(path)
        sv = float(sv)
        best_w, best, initial_sv = w.copy(), sv, sv
        stall = MeanStall(sv, self.stop.stall_tol)
        hist: list[float] = []
        t, reason = 0, self.stop.reason(0, sv, 0)
        while reason is None:
            new = h.project(w - self.eta * grad[1:-1], self.inset)
            step = float(np.max(np.abs(new - w)))
            w = new
            path[1:-1] = w
            sv_t, grad = sv_and_gradient(path)
            sv = float(sv_t)
            t += 1
            if sv < best:
                best, best_w = sv, w.copy()
            stall.update(sv)
            hist.append(best)
            reason = self.stop.reason(t, best, stall.count)
            if reason is None and step <= self.tol:
                reason = "converged"
        return SmoothingResult.build(
            self.name,
            rosary,
            best_w,
            history_best=np.array(hist),
            iterations=t,
            evaluations=t + 1,
            wall_time=time.perf_counter() - t_start,
            stop_reason=reason,
            objective="SV",
            info={"eta": self.eta, "constraint": "projection onto the hatch", "inset": self.inset,
                  "initial": initial_sv},
        )


def center_path_result(rosary: Rosary, method: str = "centre") -> SmoothingResult:
    """The centre path T (through the bubble centres, paper 003 Fig. 6) as a result record."""
    t0 = time.perf_counter()
    w = rosary.center_waypoints()
    p = rosary.path(w)
    return SmoothingResult.build(
        method, rosary, w, history_best=np.array([float(paths.objective(p))]), iterations=0, evaluations=1,
        wall_time=time.perf_counter() - t0, stop_reason="none",
    )
