"""Rosary adjustment (paper 003 section 4.3, Eq. 8) and the thesis's four paths T, T_CA, T_RA, T_RCA.

Eq. 8 moves the bubble centres p_i (all but the root's, which is q_init) up the gradient of TC
(paper 003 Eq. 6) of the centre path [q_init, p_2, ..., p_k, q_goal]:

    x_j^i <- x_j^i + eta dTC/dx_j^i,     eta = 0.1 (section 5.1).

After each move every bubble's radius is set so that its child stays on its surface,
r_i = |c_(i+1) - c_i|, and the goal bubble takes the certified radius at its new centre. A move is
kept only if every bubble stays certified and large enough:

    r_min <= r_i <= R(c_i)   for every bubble,   |q_goal - c_(k-1)| <= r_(k-1),

with R the certified radius of :class:`~foam_mj.bubbles.BubbleOracle`, re-evaluated with MuJoCo at
every moved centre (one batched ``oracle.radii`` call per trial). Because a radius is no larger than
R at its centre, every adjusted bubble is free space with clearance >= delta, and the chain stays
valid: consecutive bubbles overlap (each child centre lies on its parent's surface), q_init is the
first centre and q_goal lies in the last bubble.

Choices (the thesis does not say): all centres move at once (the gradient at the current chain);
a centre whose move breaks a constraint it takes part in has its step halved (up to
``max_halvings`` times) and is then left where it was for this iteration. The run stops on the
``stop`` criteria applied to -TC (by default 50 iterations without a TC gain above 1e-9, capped at
5,000), or when no centre can move; the chain with the highest TC is returned. The path result's
``history_best`` is the highest TC so far after each iteration, ``history_mean`` the current TC.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from foam_mj.bubbles import BubbleOracle
from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import (
    MeanStall,
    SmoothingResult,
    StopCriteria,
    _check_int,
    _check_positive,
    trivial_result,
)
from foam_mj.smoothing.gradient import GradientSmoothing, center_path_result, tc_and_gradient


@dataclass(frozen=True)
class AdjustmentResult:
    """The adjusted rosary, the centre path through it (T_RA, with TC's history), and the certified
    radius MuJoCo gives at every adjusted centre (each bubble's radius is at most this)."""

    rosary: Rosary
    path: SmoothingResult
    certified_radii: np.ndarray
    oracle_calls: int


@dataclass(frozen=True)
class RosaryAdjustment:
    """Gradient ascent of TC over the bubble centres (paper 003 Eq. 8), keeping every bubble certified.

    ``r_min`` must be the planner's minimum radius (``FoamParams.r_min``): every adjusted bubble keeps
    a radius of at least r_min, as the foam's bubbles do.
    """

    r_min: float
    eta: float = 0.1
    max_halvings: int = 4
    stop: StopCriteria = field(
        default_factory=lambda: StopCriteria(max_iterations=5000, stall_iterations=50, stall_tol=1e-9)
    )

    def __post_init__(self) -> None:
        _check_positive("r_min", self.r_min)
        _check_positive("eta", self.eta)
        _check_int("max_halvings", self.max_halvings, 0)
        if not isinstance(self.stop, StopCriteria):
            raise ValueError(f"stop must be a StopCriteria, got {self.stop!r}")

    def adjust(self, rosary: Rosary, oracle: BubbleOracle) -> AdjustmentResult:
        t_start = time.perf_counter()
        if rosary.dim != oracle.robot.dim:
            raise ValueError(f"rosary dimension {rosary.dim} does not match the robot's {oracle.robot.dim}")
        calls0 = oracle.clearance.calls
        if rosary.k < 2:  # the root holds q_goal: nothing to move
            cert = oracle.radii(rosary.centers)
            cert.setflags(write=False)
            path = trivial_result("T_RA", rosary, t_start, objective="TC")
            return AdjustmentResult(rosary, path, cert, oracle.clearance.calls - calls0)
        c = rosary.centers.copy()
        q_goal = rosary.q_goal
        cert = oracle.radii(c)
        r_min = float(self.r_min)
        ok0, why = self._feasible(c, cert, q_goal, r_min, tol=1e-9)
        if not ok0:
            raise ValueError(f"the rosary given does not satisfy the adjustment's constraints: {why}")

        pts = np.vstack([c, q_goal])
        tc, grad = tc_and_gradient(pts)
        tc0 = best = float(tc)
        best_c, best_cert = c, cert
        hist: list[float] = []
        hist_now: list[float] = []
        stall = MeanStall(-tc0, self.stop.stall_tol)
        t, reason = 0, self.stop.reason(0, -float(tc), 0)
        while reason is None:
            step = self.eta * grad[1:-1]  # centres 1..k-1 (Eq. 8: ascent)
            new_c, new_cert, moved = self._constrained_step(c, cert, step, q_goal, r_min, oracle)
            t += 1
            if not moved:
                reason = "no feasible move"
                hist.append(best)
                hist_now.append(hist_now[-1] if hist_now else tc0)
                break
            c, cert = new_c, new_cert
            pts[:-1] = c
            tc, grad = tc_and_gradient(pts)
            if float(tc) > best:
                best, best_c, best_cert = float(tc), c, cert
            hist.append(best)
            hist_now.append(float(tc))
            stall.update(-float(tc))
            reason = self.stop.reason(t, -best, stall.count)

        c, cert = best_c, best_cert
        radii = np.empty(rosary.k)
        radii[:-1] = np.linalg.norm(np.diff(c, axis=0), axis=1)
        radii[-1] = cert[-1]
        adjusted = Rosary(c, radii, rosary.q_init, rosary.q_goal, rosary.bubble_ids)
        res = SmoothingResult.build(
            "T_RA", adjusted, adjusted.center_waypoints(),
            history_best=np.array(hist), history_mean=np.array(hist_now), iterations=t, evaluations=t + 1,
            wall_time=time.perf_counter() - t_start, stop_reason=reason, objective="TC",
            info={"eta": self.eta, "r_min": r_min, "oracle_configurations": oracle.clearance.calls - calls0,
                  "initial": tc0},
        )
        cert.setflags(write=False)
        return AdjustmentResult(adjusted, res, cert, oracle.clearance.calls - calls0)

    @staticmethod
    def _violations(c: np.ndarray, cert: np.ndarray, q_goal: np.ndarray, r_min: float, tol: float = 0.0):
        """Per-bubble constraint violations: bad_link[i] for the link i -> i+1 (r_min <= |c_(i+1) - c_i| <=
        R(c_i)), bad_goal for the goal bubble (r_min <= R(c_(k-1)) and q_goal inside it)."""
        d = np.linalg.norm(np.diff(c, axis=0), axis=1)
        bad_link = (d < r_min - tol) | (d > cert[:-1] + tol)
        g = float(np.linalg.norm(q_goal - c[-1]))
        bad_goal = bool(cert[-1] < r_min - tol or g > cert[-1] + tol)
        return bad_link, bad_goal

    def _feasible(self, c, cert, q_goal, r_min, tol=0.0) -> tuple[bool, str]:
        bad_link, bad_goal = self._violations(c, cert, q_goal, r_min, tol)
        if bad_link.any():
            bad = np.flatnonzero(bad_link).tolist()
            return False, f"links {bad} break r_min <= |c_(i+1) - c_i| <= certified radius"
        if bad_goal:
            return False, "the goal bubble is below r_min or does not hold q_goal"
        return True, ""

    def _constrained_step(self, c, cert, step, q_goal, r_min, oracle):
        """Move centres 1..k-1 by ``step`` (k-1, n), halving the step of centres that break a constraint,
        then leaving them in place; returns (centres, certified radii, whether any centre moved)."""
        k = len(c)
        scale = np.ones(k - 1)
        for rnd in range(self.max_halvings + 1):
            cand = c.copy()
            cand[1:] += scale[:, None] * step
            cand_cert = cert.copy()
            moving = np.flatnonzero(scale > 0) + 1
            cand_cert[moving] = oracle.radii(cand[moving])
            bad = self._bad_centres(cand, cand_cert, q_goal, r_min) & (scale > 0)
            if not bad.any():
                return cand, cand_cert, True
            if rnd < self.max_halvings:
                scale[bad] /= 2
        # Put offenders back until no constraint is broken (no oracle call: their old radii are known).
        # This ends: with every centre back the chain is the previous, feasible one.
        for _ in range(k):
            bad = self._bad_centres(cand, cand_cert, q_goal, r_min) & (scale > 0)
            if not bad.any():
                break
            scale[bad] = 0.0
            back = np.flatnonzero(bad) + 1
            cand[back], cand_cert[back] = c[back], cert[back]
        moved = bool(np.any(scale > 0))
        return (cand, cand_cert, True) if moved else (c, cert, False)

    def _bad_centres(self, c, cert, q_goal, r_min) -> np.ndarray:
        """Movable centres 1..k-1 taking part in a broken constraint -> bool (k-1,)."""
        bad_link, bad_goal = self._violations(c, cert, q_goal, r_min)
        k = len(c)
        bad = np.zeros(k, dtype=bool)
        bad[:-1] |= bad_link
        bad[1:] |= bad_link
        bad[-1] |= bad_goal
        return bad[1:]


def thesis_paths(
    rosary: Rosary,
    oracle: BubbleOracle,
    r_min: float,
    adjustment: RosaryAdjustment | None = None,
    smoothing: GradientSmoothing | None = None,
) -> dict[str, SmoothingResult]:
    """The four paths of paper 003 Fig. 8d: T (centre path), T_CA (T smoothed by Eq. 9), T_RA (centre path
    of the rosary adjusted by Eq. 8) and T_RCA (T_RA smoothed), each with the rosary holding it."""
    adj = adjustment if adjustment is not None else RosaryAdjustment(r_min=r_min)
    sm = smoothing if smoothing is not None else GradientSmoothing()
    t = center_path_result(rosary, "T")
    t_ca = sm.smooth(rosary)
    a = adj.adjust(rosary, oracle)
    t_rca = sm.smooth(a.rosary)
    return {
        "T": t,
        "T_CA": _renamed(t_ca, "T_CA"),
        "T_RA": a.path,
        "T_RCA": _renamed(t_rca, "T_RCA"),
    }


def _renamed(r: SmoothingResult, method: str) -> SmoothingResult:
    from dataclasses import replace

    return replace(r, method=method)
