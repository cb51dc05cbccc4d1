"""Rosary adjustment (Nascimento and Alsina 2021 section 4.3, Eq. 8) and the thesis's four paths T, T_CA, T_RA, T_RCA.

Eq. 8 moves the bubble centres p_i (all but the root's, which is q_init) up the gradient of TC
(Nascimento and Alsina 2021 Eq. 6) of the centre path [q_init, p_2, ..., p_k, q_goal]:

    x_j^i <- x_j^i + eta dTC/dx_j^i,     0 < eta <= 1 (Eq. 8's range), eta = 0.1 (section 5.1).

After each move every bubble's radius is set so that its child stays on its surface,
r_i = |c_(i+1) - c_i|, and the goal bubble takes the certified radius at its new centre. A move is
kept only if every bubble stays certified and large enough:

    r_min <= r_i <= R(c_i)   for every bubble,   |q_goal - c_(k-1)| <= r_(k-1),

with R the certified radius of :class:`~foam_mj.bubbles.BubbleOracle`, evaluated with MuJoCo at the
moved centres (batched ``oracle.radii`` calls; a trial position's radius is fetched only when a
decision depends on it, see :meth:`RosaryAdjustment._constrained_step`). Because a radius is no larger than
R at its centre, every adjusted bubble is free space with clearance >= delta, and the chain stays
valid: consecutive bubbles overlap (each child centre lies on its parent's surface), q_init is the
first centre and q_goal lies in the last bubble.

R is 1-Lipschitz: each pair's distance changes by at most ||rho_p|| |x - y| between two configurations
(the bound of :mod:`foam_mj.bubbles`, which holds both ways), so (d_p - delta) / ||rho_p|| changes by at
most |x - y|, and so do the minimum over the pairs, the distance to the joint bounds and max(., 0).
Many decisions are therefore taken from a radius known nearby, widened by :data:`_LIPSCHITZ_MARGIN`
for MuJoCo's numerical tolerance, without asking MuJoCo; the radii of the returned chain are fetched
afresh, and should that chain break a constraint with them (the margin exceeded), the run is redone
fetching every radius a decision needs.

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
from foam_mj.errors import indices_text
from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import (
    MeanStall,
    SmoothingResult,
    StopCriteria,
    _check_int,
    _check_positive,
    check_rosary_type,
    trivial_result,
)
from foam_mj.smoothing.gradient import _EPS, GradientSmoothing, center_path_result


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
    """Gradient ascent of TC over the bubble centres (Nascimento and Alsina 2021 Eq. 8), keeping every bubble certified.

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
        if self.eta > 1:  # "0 < eta <= 1" (Eq. 8)
            raise ValueError(f"eta must be in (0, 1] (Nascimento and Alsina 2021 Eq. 8), got {self.eta!r}")
        _check_int("max_halvings", self.max_halvings, 0)
        if not isinstance(self.stop, StopCriteria):
            raise ValueError(f"stop must be a StopCriteria, got {self.stop!r}")

    def adjust(self, rosary: Rosary, oracle: BubbleOracle) -> AdjustmentResult:
        """The rosary's centres moved to raise TC (Eq. 8), each bubble certified by ``oracle`` (its margin delta)."""
        check_rosary_type(rosary)
        if not isinstance(oracle, BubbleOracle):  # a RobotModel was "'RobotModel' object has no attribute 'robot'"
            raise TypeError(f"`oracle` must be a foam_mj.bubbles.BubbleOracle (BubbleOracle(robot, delta)), got {type(oracle).__name__}")
        if rosary.dim != oracle.robot.dim:
            raise ValueError(f"rosary dimension {rosary.dim} does not match the robot's {oracle.robot.dim}")
        return self._adjust(rosary, oracle, lipschitz=True, t_start=time.perf_counter(),
                            calls0=oracle.clearance.calls)

    def _adjust(self, rosary: Rosary, oracle: BubbleOracle, lipschitz: bool, t_start: float, calls0: int):
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
        tc, step = _tc_and_step(pts, self.eta)
        tc0 = best = tc
        best_c, best_cert = c, cert
        hist: list[float] = []
        hist_now: list[float] = []
        stall = MeanStall(-tc0, self.stop.stall_tol)
        t, reason = 0, self.stop.reason(0, -tc, 0)
        memory = _RadiusMemory(c, cert, margin=_LIPSCHITZ_MARGIN if lipschitz else np.inf)
        while reason is None:
            new_c, new_cert, moved = self._constrained_step(c, cert, step, q_goal, r_min, oracle, memory)
            t += 1
            if not moved:
                reason = "no feasible move"
                hist.append(best)
                hist_now.append(hist_now[-1] if hist_now else tc0)
                break
            c, cert = new_c, new_cert
            pts[:-1] = c
            tc, step = _tc_and_step(pts, self.eta)
            if tc > best:
                best, best_c, best_cert = tc, c, cert
            hist.append(best)
            hist_now.append(tc)
            stall.update(-tc)
            reason = self.stop.reason(t, -best, stall.count)

        c, cert = best_c, best_cert.copy()
        if lipschitz:
            # The returned radii are MuJoCo's at the returned centres, fetched afresh; should the chain
            # break a constraint with them (MuJoCo's distances broke the Lipschitz bound by more than the
            # margin), the run is redone deciding on fetched radii only.
            cert = oracle.radii(c)
            if not self._feasible(c, cert, q_goal, r_min)[0]:
                return self._adjust(rosary, oracle, lipschitz=False, t_start=t_start, calls0=calls0)
        unknown = np.flatnonzero(np.isnan(cert))
        if unknown.size:
            cert[unknown] = oracle.radii(c[unknown])
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
            bad = indices_text(np.flatnonzero(bad_link))
            return False, f"links {bad} (of {len(bad_link)}) break r_min <= |c_(i+1) - c_i| <= certified radius"
        if bad_goal:
            return False, "the goal bubble is below r_min or does not hold q_goal"
        return True, ""

    def _constrained_step(self, c, cert, step, q_goal, r_min, oracle, hint=None):
        """Move centres 1..k-1 by ``step`` (k-1, n), halving the step of centres that break a constraint,
        then leaving them in place; returns (centres, certified radii, whether any centre moved).

        Round r tries every centre i at its level h_i (position c_i + step_i / 2^h_i, level 0 first);
        the centres taking part in a broken constraint go one level down, and after ``max_halvings``
        halvings back to where they were, until no constraint is broken.

        The implementation tabulates the link lengths for every pair of levels once (numpy), decides
        the rounds in plain Python, and fetches the certified radius of a trial position from MuJoCo
        only when a decision depends on it. A centre is bad as soon as one of its constraints is known
        to be broken (a link shorter than r_min needs no radius), good when all are known to hold. The
        certified radius R is 1-Lipschitz (module docstring), so its value known exactly at one position
        of a centre (``hint``, a :class:`_RadiusMemory`) bounds it at the others: a link no longer than
        the lower bound holds, one longer than the upper bound is broken. Only when neither can be told
        is a radius fetched, for every level of that centre at once (a centre halved once is usually
        halved again) and, in a step's first batch, of the centres that needed radii in the previous
        step: usually one batch per step. The decisions, hence the result, are those of fetching every
        trial's radius (the oracle is deterministic). ``cert`` holds NaN for a centre whose radius at c
        is not known exactly; so does the returned array.
        """
        k, n = c.shape
        m, H = k - 1, self.max_halvings
        back, nl = H + 1, H + 2  # level "back": the centre stays where it was
        mem = hint if isinstance(hint, _RadiusMemory) else _RadiusMemory(c, cert, exact=True)
        # pos[h, i]: centre i at level h (the same floating-point operations as scaling the step by 1/2
        # h times and adding it); centre 0 never moves.
        pos = np.empty((nl, k, n))
        pos[:, 0] = c[0]
        np.add(c[1:], mem.scale(H)[:, None, None] * step, out=pos[: H + 1, 1:])
        pos[back, 1:] = c[1:]
        # dist[j][h1 * nl + h2] = |pos[h2, j + 1] - pos[h1, j]| (as np.linalg.norm over the last axis)
        seg = pos[None, :, 1:] - pos[:, None, :-1]
        dist_a = np.sqrt(np.add.reduce(seg * seg, axis=-1))
        dist = dist_a.reshape(nl * nl, m).T.tolist()
        # lo[h][i] <= R(pos[h, i]) <= hi[h][i]: Lipschitz bounds from the centre's reference position, and
        # lo = hi = R where it is known (at the reference itself: the oracle is deterministic; ``cert``)
        off = pos - mem.p
        dref = np.sqrt(np.add.reduce(off * off, axis=-1))
        at_ref = dref == 0.0
        dref += mem.margin
        lo_a, hi_a = mem.r - dref, mem.r + dref
        np.copyto(lo_a, mem.r, where=at_ref)
        np.copyto(hi_a, mem.r, where=at_ref)
        known = cert == cert  # not NaN
        np.copyto(lo_a[back], cert, where=known)
        np.copyto(hi_a[back], cert, where=known)
        lo_a[:, 0] = hi_a[:, 0] = cert[0]
        lo, hi = lo_a.tolist(), hi_a.tolist()
        goal_dist: list = [None] * nl
        level = [0] * k  # level of every centre (centre 0: 0, it never moves)
        first = [True]

        def fetch(centres) -> None:
            mem.needed |= centres
            if first[0]:
                # with the centres that needed radii in the last step, those with a link at some pair of
                # moving levels that the bounds leave open: one batch per step, mostly
                d = dist_a[: H + 1]
                open_ = ((d >= r_min) & (d > lo_a[: H + 1, None, :m]) & (d <= hi_a[: H + 1, None, :m])).any(axis=(0, 1))
                centres = centres | mem.hint | set(np.flatnonzero(open_).tolist())
                first[0] = False
            hs, cs = [], []
            for i in centres:
                for h in (*range(H + 1), back) if level[i] == back else range(H + 1):
                    if lo[h][i] != hi[h][i]:
                        hs.append(h)
                        cs.append(i)
            if hs:
                r = oracle.radii(pos[hs, cs])
                mem.fetched.append((np.array(hs), np.array(cs), r))
                for h, i, x in zip(hs, cs, r.tolist()):
                    lo[h][i] = hi[h][i] = x

        def link_state(j: int):
            """Link j (the goal for j = m): True broken, False kept, None not known yet."""
            lv = level
            h1 = lv[j]
            if j == m:
                g = goal_dist[h1]
                if g is None:
                    g = goal_dist[h1] = float(np.linalg.norm(q_goal - pos[h1, -1]))
                u = hi[h1][m]
                if u < r_min or g > u:
                    return True
                low = lo[h1][m]
                return False if (low >= r_min and g <= low) else None
            d = dist[j][h1 * nl + lv[j + 1]]
            if d < r_min or d > hi[h1][j]:
                return True
            return False if d <= lo[h1][j] else None

        def bad_centres() -> list[int]:
            """The moving centres taking part in a broken constraint (links i - 1 and i; the goal for
            centre k - 1), fetching the radii that cannot be done without."""
            lv = level
            # per link j, then the goal (j = m): True broken, False kept, None not known yet (inlined
            # ``link_state``)
            state: list = [None] * m
            for j in range(m):
                h1 = lv[j]
                d = dist[j][h1 * nl + lv[j + 1]]
                if d < r_min or d > hi[h1][j]:
                    state[j] = True
                elif d <= lo[h1][j]:
                    state[j] = False
            state.append(link_state(m))
            while True:
                bad, need = [], set()
                for i in range(1, k):
                    if lv[i] > H:
                        continue
                    before, after = state[i - 1], state[i]  # link i - 1; link i (the goal for i = k - 1)
                    if before or after:
                        bad.append(i)
                    elif before is None or after is None:
                        if before is None:
                            need.add(i - 1)
                        if after is None:
                            need.add(i)
                if not need:
                    return bad
                fetch(need)
                for j in need:
                    state[j] = link_state(j)

        moved = True
        for rnd in range(H + 1):
            bad = bad_centres()
            if not bad:
                break
            if rnd < H:
                for i in bad:
                    level[i] += 1
        else:
            # Put offenders back until no constraint is broken (their old radii are known). This ends:
            # with every centre back the chain is the previous, feasible one.
            for _ in range(k):
                for i in bad:
                    level[i] = back
                bad = bad_centres()
                if not bad:
                    break
            moved = any(h <= H for h in level[1:])
        idx = np.arange(k)
        lv = np.array(level)
        new_c = pos[lv, idx]
        new_cert = np.array([lo[h][i] if lo[h][i] == hi[h][i] else np.nan for i, h in enumerate(level)])
        mem.update(pos, lv, new_c, new_cert)
        if not moved:
            return c, cert, False
        return new_c, new_cert, True

    def _bad_centres(self, c, cert, q_goal, r_min) -> np.ndarray:
        """Movable centres 1..k-1 taking part in a broken constraint -> bool (k-1,)."""
        bad_link, bad_goal = self._violations(c, cert, q_goal, r_min)
        k = len(c)
        bad = np.zeros(k, dtype=bool)
        bad[:-1] |= bad_link
        bad[1:] |= bad_link
        bad[-1] |= bad_goal
        return bad[1:]


#: Slack (configuration units) added to the Lipschitz bounds |R(x) - R(y)| <= |x - y| of the certified
#: radius, for MuJoCo's distance being computed to a tolerance (its default ``ccd_tolerance`` is 1e-6 m,
#: and ||rho_p|| is at least a few centimetres per unit of q for any joint that moves a geom).
_LIPSCHITZ_MARGIN = 1e-4


class _RadiusMemory:
    """Per centre, one position where its certified radius is known exactly (p, r): the source of the
    Lipschitz bounds of :meth:`RosaryAdjustment._constrained_step`, which ``margin`` widens (inf: every
    decision fetches its radius); and the centres whose radii the last step needed (``hint``)."""

    def __init__(self, c: np.ndarray, cert: np.ndarray, margin: float = _LIPSCHITZ_MARGIN, exact: bool = False) -> None:
        self.p = c.copy()
        self.r = np.asarray(cert, dtype=float).copy()
        self.margin = np.inf if exact else float(margin)
        self.fetched: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # this step's (levels, centres, radii)
        self.hint: set[int] = set()
        self.needed: set[int] = set()
        self._scale: np.ndarray | None = None

    def scale(self, H: int) -> np.ndarray:
        """1, 1/2, ..., 1/2^H."""
        if self._scale is None or len(self._scale) != H + 1:
            self._scale = 0.5 ** np.arange(H + 1)
        return self._scale

    def update(self, pos: np.ndarray, lv: np.ndarray, new_c: np.ndarray, new_cert: np.ndarray) -> None:
        """After a step: a centre whose radius is known at its new position takes it as reference; one left
        in place without it, its trial nearest to it (the deepest level) if that was fetched."""
        self.hint, self.needed = self.needed, set()
        known = new_cert == new_cert
        self.p[known] = new_c[known]
        self.r[known] = new_cert[known]
        for hs, cs, r in self.fetched:
            deepest = (hs == len(pos) - 2) & ~known[cs]
            if deepest.any():
                i = cs[deepest]
                self.p[i] = pos[-2, i]
                self.r[i] = r[deepest]
        self.fetched.clear()


def _tc_and_step(p: np.ndarray, eta: float) -> tuple[float, np.ndarray]:
    """TC of the centre path p (L, n) and Eq. 8's step eta dTC/dx for centres 1..k-1 (the interior points):
    ``tc_and_gradient`` for one path, the same operations with fewer numpy calls."""
    seg = p[1:] - p[:-1]
    ls = np.sqrt(np.add.reduce(seg * seg, axis=-1))  # np.linalg.norm(seg, axis=-1)
    u = seg / np.maximum(ls, _EPS)[:, None]
    length = ls.sum()
    e = p[-1] - p[0]
    de = np.sqrt(np.add.reduce(e * e, axis=-1))
    tc = de / np.maximum(length, _EPS)
    return float(tc), eta * (-(de / np.maximum(length, _EPS) ** 2) * (u[:-1] - u[1:]))


def thesis_paths(
    rosary: Rosary,
    oracle: BubbleOracle,
    r_min: float,
    adjustment: RosaryAdjustment | None = None,
    smoothing: GradientSmoothing | None = None,
) -> dict[str, SmoothingResult]:
    """The four paths of Nascimento and Alsina 2021 Fig. 8d: T (centre path), T_CA (T smoothed by Eq. 9), T_RA (centre path
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
