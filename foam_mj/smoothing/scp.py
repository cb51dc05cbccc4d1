"""Sequential convex programming for :class:`~foam_mj.smoothing.optimal.OptimalSmoother`: one run from a start to a
certified local optimum of F(W) over the hatches (the problem in :mod:`foam_mj.smoothing.optimal`).

The method: sequential convex programming (prox-linear), each subproblem a second-order cone program
solved by Clarabel. Why not SLSQP or trust-constr: the angle phi is not differentiable where two segments
are collinear (it behaves like a norm there) and the optimum of f has such straight vertices (the mean
angle acts like an L1 penalty that makes angles exactly zero). Measured on the obstacle rosary,
SLSQP on a smoothed angle sqrt(phi^2 + eps^2) did not converge in 1,000 iterations and trust-constr
went uphill; smooth solvers see a gradient that jumps. The composite structure is exact instead:

    phi = h(|v|),  v = a/|a| - b/|b|,  h(s) = 2 arcsin(s / 2)

(a, b the two segments at the vertex), with h convex and increasing and v smooth. The subproblem keeps
the convex parts exact (segment lengths |p_(j+1) - p_j| <= t_j and the hatch balls as second-order
cones) and linearises only v inside the norm: s_i >= |v_i + J_i dW|, angle model h(s0) + h'(s0)(s - s0),
SV model h0^2 + (h0 h0' / s0)(s^2 - s0^2). At a straight vertex (s0 = 0) the model is the exact
first-order model |J_i dW| of the kink, so the iteration converges to points that satisfy the
nonsmooth (Clarke) first-order conditions, which a smooth method cannot certify. The trust region is a
box |dW|_inf <= delta plus, on every segment shorter than delta / 0.5, |d(p_(j+1) - p_j)|_inf <= 0.5
|p_(j+1) - p_j| (an angle next to a short segment is as sensitive as that segment is short, while its
two points may still move together); the usual ratio test on the true F accepts a step (every
accepted step decreases F), delta doubles after a good step and shrinks by 4 after a rejected one.
Most steps end inside the region, which Speed below puts to use.

Curvature (objectives without SV). Linearising v inside the norm drops v's own curvature, and the SCP
then converges only linearly (the model underestimates F near straight vertices, steps are rejected and
the trust region collapses). From the second step on, the model gets the curvature an SQP method would
use: with y_i the multiplier of v_i (at a bent vertex y_i = w_angle/M h'(|v_i|) v_i/|v_i|, the gradient of
the outer function; at a straight vertex the last subproblem's dual of the vertex cone, which is where the
subdifferential's element is known), the Hessian of sum_i y_i . v_i(W) is, per segment a = p_(j+1) - p_j
with u = a/|a|, G = (I - u u^T)/|a| and z_j = y_j - y_(j-1),

    d^2 (z_j . u) / da^2 = -(u (G z_j)^T + (G z_j) u^T + (u . z_j) G) / |a|,

whose negative eigenvalues are clipped (the subproblem must stay convex), put in P as the 2 x 2 block
pattern [[H, -H], [-H, H]] over the segment's end points; and h''(s0)(s - s0)^2 / 2 for the convex outer
function. A segment longer than 4 times the box's half-diagonal (its direction barely moves in one step)
leaves its cone: its length enters as w_len (|a| + u . da) plus w_len da^T G da / 2 added to that segment's
block before the clip (the length's curvature across the segment offsets much of the indefinite part, so
less is clipped), and the subproblem has fewer rows. P is then block-tridiagonal over the waypoints (a
fixed pattern). On a rejected step the relative
trust region of the short segments shrinks with delta (by 4; back up by 2 after a very good step, to at
most 0.5), so that a step limited by a short segment's relative region is not retried unchanged. The clipped curvature may predict too little decrease near some points (folded chains: F
falls more than predicted, step after step, and converges only linearly), so a run stops on the
certificate (``KKT_TOL``) only where the model is seen to hold: the point was reached by a curvature step
that ended inside the trust region (the model's own minimiser, not a step cut short by the region) and
whose decrease was within ``MODELLED`` (25 %) of the predicted one, so that the prediction, below
``EARLY`` |F|, measures what is left; elsewhere it asks for a residual <= 1e-5 (``POLISH_TOL``). A
prediction of no decrease, a stall, a collapsed trust region or a certificate that passes KKT_TOL where
POLISH_TOL is asked hand the run to the plain model above, which then ends it as before; a start that
still ends uncertified is run again from the start with the plain model alone. Why both conditions:
stopping on KKT_TOL everywhere (POLISH_TOL before, always) saves the plain model's polishing where the
curvature model is certified only to 1e-5..4e-5 (obstacle seeds 0, 2, 3, 4, 8, see Speed), but from random,
HS or GA starts it stopped up to 3e-6 of F above the polished value (relative), at certificates of 4e-5 to
1e-4: after steps with rho 1.3 to 3.2 (the linear regime), after steps cut by the trust region (delta
shrunk by rejections: the prediction is small because delta is; rho 1.00, +1.1e-6) and after one with rho
0.41 (+5.3e-7). With both, F ends within 1.9e-7 of the polished value on the 36 bubbletree corridors and
6 scenario rosaries below, on multistarts (3 random starts on obstacle, step_up, step_down and arm6 seeds
0-2, 4 on the scenario rosaries) and from HS and GA results (three scenario rosaries), all certified.

Repeated points (ties). The shortest path puts consecutive waypoints on the same corner wherever their
hatches overlap there, and so does the optimum of f (a corner counts once, foam_mj.paths). Two points
1e-9 apart are a numerical disaster (their angles depend on the direction of a segment of no length), so
for objectives without an SV term, points closer than ``TIE`` (1e-5) are made one: snapped together
when the first lies in the second's hatch (for f this never increases F: the triangle inequality for
the length and for the angles), else joined by an equality in the next subproblem (refused for the rest
of the run if that is infeasible). SV prefers a corner split over two close vertices (phi^2 halves), so
for objectives with an SV term only exact repeats are ties, and a second start between the shortest
path and the hatch centres is tried.

Speed. Measured on 36 bubbletree corridors (benchmarks/planners.py: obstacle, step_up and step_down
with seeds 0-9, obstacle5 and arm6 with seeds 0-2; 31-114 bubbles; the planner's waypoints as the start),
CPU time on one core, old and new interleaved. Most of a run is Clarabel's (the interior-point
iterations about half, building the solvers a sixth); the subproblems are made smaller:

- The trust region's rows (the box and the relative rows: 40 % of a subproblem's) are rarely reached:
  77 of 84 curvature steps and 31 of 36 first steps end inside the region. So a subproblem is solved
  first without them (``trust=False`` in foam_mj.smoothing.subproblem), and again with them only when it leaves
  the region (a solution inside it is the subproblem's: the region only removes other points); after one
  such miss the run keeps the rows (the plain model's polishing steps end on the region's edge half of
  the time). Without the rows, the solver no longer pulls the step towards the current point along the
  directions in which the model is flat (a clipped curvature has them), and the steps wandered along them
  (arm6: 7.6e-3 instead of 5.5e-4, worse ratios, 5 subproblems instead of 3-4); so every subproblem for an
  objective without SV carries (``PROX`` max(weights) / 2) |dW|^2, which the predicted decrease leaves
  out (``PROX`` = 1e-2; 3e-3 and 3e-2 were 2-10 % slower, 1e-1 and 1 took more subproblems). SV keeps the
  rows: its optimum is flat and moved by up to 4e-6 of F without them, for no gain.
- The hatch balls likewise: a subproblem keeps every ball that the trust region reaches (nearly all: the
  hatches are small), but while the curvature model is on, only the balls within ``NEAR`` sqrt(n) times
  the last step's |dW|_inf (+ 2 ``TIE``; before the first step, delta0 / 10 stands for it) enter the
  first solve, near the optimum the active ones (15-20 % on obstacle); a solution that leaves a ball left
  out is solved again with it (1 of 108 subproblems; none with NEAR = 0.03 after the first step, 9 with
  0), and one that meets them all is the subproblem's. The rows left out are 40 % of a second step's and
  45 % of a third's; from the first step's, -5 % on obstacle, step_up and step_down (delta0 / 25: -7 %
  there, 5 re-solves, +27 % on arm6).
- Clarabel runs without presolve (nothing to remove) and, for objectives without SV, without iterative
  refinement (a third of each solve; the same points to 1e-9 in F) until a subproblem fails
  (ill-conditioned, e.g. 5-joint corridors of 110 bubbles): then it is solved again with refinement,
  which stays on for the run; with more than ``REFINE_ABOVE`` (3) coordinates it is on from the start. Without
  it there, most runs' first subproblem failed (Clarabel's InsufficientProgress after 17-21 iterations) and
  often the trust region's solve after it too, before the switch: on the bubbletree corridors of obstacle5,
  arm6 and arm7 (seeds 0-9) 15-17 of 23-26 such solves failed, 26-41 ms of Clarabel's 61-88 ms per seed;
  with refinement from the start all 20-21 solves succeed, the smoother's CPU medians 96 / 71 / 93 ->
  59 / 38 / 59 ms and its objective's medians the same to 1e-6 (all certified); on the 3-joint leg no
  subproblem failed (70 runs) and nothing changes there. Its constructor gets Python lists (``_lists``: 0.2 ms less per build than
  numpy arrays, which it reads element by element). A subproblem with the previous one's sparsity
  pattern updates that solver in place (``DefaultSolver.update``; rare, as the rows follow the region).
  The start (the shortest path, when no waypoints are given) is solved to 1e-8 with the segment and ball
  cones the subproblems reuse; curvature subproblems are solved to 1e-7 while the last prediction is large
  (1e-3 of it relative to |F|, down to 1e-9; looser, 1e-5 or 1e-6, was no faster).
- A run ends as soon as a step's predicted decrease is below 1e-8 |F| and the point passes the
  certificate, or an accepted step predicted below ``EARLY`` |F| (1e-6) is certified by its own duals
  (objectives without SV), or so is a step predicted below ``FAST_EARLY`` |F| (1e-5) that the model held
  (as for KKT_TOL below) and whose prediction is at most ``FAST`` (0.02) x the previous accepted step's: the
  convergence is superlinear there, so what is left is about that share of the prediction, 2e-7 |F| at
  most; else at the 1e-10 |F| test. That last rule, on the planner's waypoints of obstacle, step_up,
  step_down, obstacle5, arm6 and arm7 (seeds 0-9): subproblems 166 -> 153 (obstacle 27 -> 24, step_down
  30 -> 23, obstacle5 32 -> 30, arm7 30 -> 29), F up to 2.6e-7 higher (relative; lengths within 3.2e-6,
  dense clearance within 0.005 mm), all certified (<= 8.8e-5); on the multistarts below within 9.2e-8;
  obstacle plan + optimal smoother, per-seed callgrind instructions, median -2.6 %. (``EARLY`` 1e-5 alone
  saves the same subproblems but left random starts up to 2.1e-6 of F above, where steps converge
  linearly.) Where the curvature model holds, the certificate
  is KKT_TOL's, not POLISH_TOL's (Curvature above): on obstacle seeds 0, 2, 3, 4 and 8 the curvature
  model is certified to only 1.4e-5..3.9e-5, and the plain model's polishing (1-2 subproblems, the
  SOCP) is no longer run. The certificate's SOCP, when the duals do not certify, is assembled sparse
  (obstacle seed 0: 12 ms, 21 before), and asked once per point.
- Straight runs on their chords (``COLLAPSE``, foam_mj.smoothing.collapse): at the planner's waypoints and at
  the optimum about 80 % of the interior vertices are straight (obstacle seed 0: 82 of 87), and their vertex
  and segment cones were most of a subproblem's rows. While the curvature model is on, every first solve
  (without the trust region's rows) keeps the free, untied straight points away from their spheres on their
  run's chord at their arclength fractions: the variables are the chord polyline's points, F on that set is
  F of the chord polyline exactly, and the collapsed vertices' multipliers, which the certificate needs,
  come in closed form (linear in arclength between the run's ends: that module's docstring); a solution
  outside the trust region, or a failed solve, gives way to the full subproblem as above. A collapsed
  point moves only with its run's ends, so its balls enter the first solve only within ``NEAR_RUN`` (0.03)
  sqrt(n) |last step|_inf (+ 2 TIE), as against NEAR for the others (no ball re-solve on the 60 runs below;
  with NEAR for them too, 37 % more rows on obstacle). Why not drop the straight vertices' cones from the
  full subproblem instead: they model the angle there and their duals were the certificate's multipliers
  (least-squares multipliers did not certify). On the planner's waypoints of obstacle, step_up, step_down,
  obstacle5, arm6 and arm7 (seeds 0-9): subproblem rows 59 to 79 % fewer per problem (obstacle 16459 ->
  5216; solves 132 -> 126 in all, obstacle 24 -> 25; none failed), F within -1.2e-7..+2.7e-8 relative,
  lengths within 1.1e-6, all certified (stationarity <= 8.6e-5), waypoints inside; on multistarts (3
  random starts) and convex starts, seeds 0-2 of the six, every start's F within 6.1e-8, all certified.
  Smoother callgrind instructions per run (seeds 0-9), before -> after: obstacle 116.1 -> 43.2 M (-63 %),
  step_up 48.8 -> 32.0, step_down 73.7 -> 28.2, obstacle5 404 -> 139, arm6 254 -> 94, arm7 364 -> 196 M; NEAR for the collapsed
  points' balls too: obstacle 69.6 M, step_up 27.1 (one full solve fewer).

Smoother CPU medians, before (the trust region's rows and every reachable ball in every solve, EARLY
1e-7) -> now, best of 5: obstacle 24.6 -> 16.2 ms (-34 %; per-seed ratio median 0.66), step_up 12.8 ->
6.3, step_down 17.7 -> 10.5, obstacle5 101 -> 93, arm6 69 -> 26 ms; all certified, F from -1.5e-8 to
+8.4e-8 relative (a different rounding on the way; the largest where a run now stops a subproblem
earlier, certified; step_down seed 3 takes 6 subproblems instead of 4). On the scenario rosaries of
foam_mj.benchmark (convex start) obstacle 22.5 -> 18.6 ms, step_up 22.2 -> 17.3, step_down 21.0 -> 20.3,
obstacle_thesis 90 -> 84 ms (13 subproblems against 15); F within 3.2e-8.

Stopping on KKT_TOL where the curvature model holds (POLISH_TOL before, always), interleaved against the
previous rule (best of 3, twice, taskset -c 0, a machine then 1.6 times slower than above): obstacle
median 28.4 -> 24.0 and 28.5 -> 23.6 ms (per-seed ratio median 0.89, -19 to -55 % on seeds 0, 2, 3, 4, 8,
the others unchanged), step_down -5 % (seed 3: 6 subproblems -> 3), step_up, obstacle5 and arm6 unchanged
(the same points); the scenario rosaries -20 % (obstacle_thesis 13 subproblems -> 5, 87 -> 42 ms; the
adjusted obstacle rosary 5 -> 3). F from 0 to +1.9e-7 relative (obstacle <= 3.4e-8, step_down seed 3
+1.5e-7, obstacle_thesis +1.9e-7), all certified.
"""


from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from foam_mj import paths
from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import Hatches
from foam_mj.smoothing.certificate import STRAIGHT, Certificate
from foam_mj.smoothing.objective import ObjectiveWeights, _true_value, default_tie, tie_mask
from foam_mj.smoothing.subproblem import (
    _S_MAX,
    RELATIVE,
    SOLVER_TOL,
    _dh,
    _model_value,
    _Solver,
    _Structure,
    _structure,
    _subproblem,
    _vertex_data,
    _within_trust,
    PROX,
)
from foam_mj.smoothing import collapse

LOOSE_TOL = 1e-7  # curvature model: a subproblem is solved to min(this, max(SOLVER_TOL, 1e-3 pred_last / |F|))


# -- the composite model ----------------------------------------------------------------------------
STEP_CAP = 8.0  # after a very good step (curvature model), delta <= this times the step's |dW|_inf
EARLY = 1e-6  # an accepted step predicted to gain less than this * |F| asks its own duals for a certificate
# (1e-7 before: 13 of the 36 bubbletree corridors then solved 1-2 more subproblems, 10 of them only to certify
# the same point; the other 3 now stop 7e-9 to 7e-8 of F higher, as certified)
#: ... and so does a step the model held (MODELLED) predicted below FAST_EARLY |F| and at most FAST x the previous accepted
#: step's prediction (superlinear: what is left is about FAST x this prediction, <= 2e-7 |F|; module docstring, Speed)
FAST_EARLY = 1e-5
FAST = 0.02
POLISH_TOL = 1e-5  # curvature model: the certificate a run stops on where its model is not seen to hold (module docstring)
MODELLED = 0.25  # ... it holds after a curvature step inside the trust region with |rho - 1| <= this: kkt_tol suffices
LONG = 4.0  # curvature model: a segment longer than this times the box's half-diagonal has its length in P
NEAR = 0.1  # curvature steps solved first with only the balls within NEAR sqrt(n) |last step|_inf (+ 2 TIE) of the point
#: Iterative refinement of the linear solves from the first subproblem on where the configuration has more than this many
#: coordinates (below it, only once a subproblem fails: module docstring, Speed).
REFINE_ABOVE = 3
#: Curvature runs collapse straight runs onto their chords (foam_mj.smoothing.collapse).
COLLAPSE = True
#: ... and a collapsed point's balls enter the first solve only within NEAR_RUN sqrt(n) |last step|_inf (+ 2 TIE).
NEAR_RUN = 0.03


def _snap(p: np.ndarray, h: Hatches, inset: float, tie: float) -> np.ndarray:
    """p with every run of points closer than ``tie`` made exactly one point, where the run's
    representative lies inside the other waypoints' hatches shrunk by inset/2 (the solver meets the
    constraints shrunk by ``inset`` to 1e-9, so a tie it made passes). Ties must be exact: two points
    1e-10 apart are two vertices whose angles depend on the direction of a segment of no length.
    Returns p itself when nothing moves."""
    snappable = tie_mask(p, h, inset / 2, tie)
    lens = paths.row_norms(p[1:] - p[:-1])
    if not np.any(snappable & (lens > 0)):
        return p
    q = p[_vertex_data(p, snappable).rep]
    # A run of three or more, or one ending on q_goal, was checked pair by pair: keep any waypoint whose
    # new place is not inside its hatch where it was.
    bad = ~h.inside(q[1:-1], inset / 2)
    q[1:-1][bad] = p[1:-1][bad]
    return q


@dataclass
class SCPTrace:
    """What one run of :func:`sequential_convex` did: F after every accepted step, subproblems solved."""

    values: list[float] = field(default_factory=list)
    iterations: int = 0
    accepted: int = 0
    trust_solves: int = 0  # subproblems solved again with the trust region's rows
    ball_solves: int = 0  # subproblems solved again with more balls
    stop_reason: str = ""


class _Certify(Protocol):
    """The KKT check sequential_convex asks (foam_mj.smoothing.optimal): waypoints, a guess of the multipliers,
    whether to solve the SOCP when the guess does not certify -> the Certificate."""

    def __call__(self, wc: np.ndarray, multipliers: tuple | None = ..., solve: bool = ...) -> Certificate: ...


def sequential_convex(
    rosary: Rosary,
    h: Hatches,
    w0: np.ndarray,
    weights: ObjectiveWeights,
    inset: float,
    *,
    delta0: float = 0.05,
    max_iter: int = 200,
    tol: float = 1e-10,
    stall: int = 4,
    tie: float | None = None,
    structure: _Structure | None = None,
    certify: _Certify | None = None,
    certify_tol: float = 1e-8,
    kkt_tol: float = 1e-4,
    curvature: bool = True,
) -> tuple[np.ndarray, SCPTrace]:
    """Trust-region SCP from ``w0`` (inside the shrunk hatches) -> (waypoints, trace).

    Each iteration solves the convex model (module docstring) in the box |W - W0|_inf <= delta, and
    accepts the step when the true decrease is at least 0.1 of the predicted one (delta doubles when
    it is 0.75 or more, else shrinks by 4 on rejection). Stops when the predicted decrease falls
    below ``tol`` * |F| ("converged"), or when ``stall`` steps in a row are rejected while the
    predicted decrease is below 1e-7 |F| (the subproblem is solved to a relative 1e-9, so such
    predictions are rounding: "converged (solver accuracy)"), or delta falls below 1e-12.

    With ``certify`` (waypoints, multiplier guess, solve the SOCP? -> Certificate), a prediction below
    ``certify_tol`` * |F| (coarser than ``tol``) asks it first, and a certified point ends the run
    ("certified"): the last few subproblems only polish F in its ninth digit. When the answer is no, the
    next question waits until the prediction is 10 times smaller. With the curvature model (objectives
    without SV) an accepted step predicted to gain less than ``EARLY`` * |F| (or ``FAST_EARLY`` * |F|, after
    a step the model held whose prediction is at most ``FAST`` x the last accepted step's) also asks, with the
    step's own duals and without the SOCP, whether its end point is certified (which saves the last subproblem);
    with it a run ends on a certificate within ``kkt_tol`` where the model holds (the point reached by a
    curvature step inside the trust region with |rho - 1| <= ``MODELLED``, and, for the SOCP's answer, the
    current subproblem's solution inside the region too), within ``POLISH_TOL`` elsewhere, and every
    other stop hands the run to the plain model (module docstring).

    With the curvature model, a very good step (rho >= 0.75) sets delta to at most ``STEP_CAP`` times the
    step's |dW|_inf (not below 1e-4): near the optimum the steps shrink fast, and the balls farther from a
    point than the box reaches are left out of the subproblem (about 40 % fewer rows). Each subproblem is
    solved first without the box's rows and with only the near balls, and again with them when its
    solution leaves the box or a ball left out (module docstring, Speed); ``trace.trust_solves`` and
    ``trace.ball_solves`` count those second solves.
    """
    st = structure or _structure(rosary, inset)
    tie = default_tie(weights) if tie is None else tie
    w = np.array(w0, dtype=float)
    p = rosary.path(w)
    F = _true_value(p, weights)
    trace = SCPTrace(values=[F])
    delta = delta0
    refine = weights.sv > 0 or st.n > REFINE_ABOVE
    solver, relaxed, collapsed = _Solver(refine), _Solver(refine), _Solver(refine)
    radii = np.stack([h.ra, h.rb], axis=1) - inset
    step_last = 0.1 * delta0  # (the first steps moved 2e-3 to 5e-3 on the 36 bubbletree corridors)
    try_relaxed = weights.sv == 0  # (SV: no faster, and its flat optimum moves with the rows)
    pred_last = np.inf
    pred_accepted = 0.0  # the last accepted step's predicted decrease (none yet: no superlinear evidence)
    trace.stop_reason = "max_iter"
    rejected = 0
    refused = np.zeros(len(p) - 1, dtype=bool)
    curvature = curvature and weights.sv == 0 and weights.angle > 0
    y_pt = np.zeros_like(p)
    rel = RELATIVE
    snapped = False
    modelled = False
    for it in range(max_iter):
        trace.iterations = it + 1
        p_snap = p if snapped else _snap(p, h, inset, tie)  # (an accepted point comes snapped)
        snapped = curvature
        if p_snap is not p:
            # For f this never increases F (the triangle inequality for the length and for the angles
            # on the sphere), and the subproblem's box is then centred on the tie.
            p, w, F = p_snap, p_snap[1:-1].copy(), _true_value(p_snap, weights)
        # The other close pairs are tied too, unless refused before: the subproblem brings them together
        # (the model counts their corner once, which the snap after the step makes true).
        lens = paths.row_norms(p[1:] - p[:-1])
        close = ((lens < tie) & ~refused) | (lens <= paths._EPS)
        vx = _vertex_data(p, close)
        y = None
        if curvature and it > 0:
            # Multipliers of v_i: exact at bent vertices (w_angle/M h'(|v|) v/|v|), the last subproblem's
            # dual at straight ones (where the subdifferential is a ball); keyed by point index.
            Mv = len(vx.s0)
            y = y_pt[vx.D[1:-1]]
            bent = vx.s0 >= STRAIGHT
            sc = np.minimum(vx.s0[bent], _S_MAX)
            y[bent] = (weights.angle * _dh(sc) / st.M / sc)[:, None] * vx.v[bent]
        keep = long_seg = None
        if curvature:
            # A ball whose sphere is farther from the point than the box's half-diagonal (plus the 1e-5 a tie
            # may move it) cannot be active in this subproblem: left out.
            reach = np.sqrt(st.n) * delta + 2 * tie
            slack = radii - h.centre_distances(p[1:-1])
            keep = slack <= reach
            # Segments much longer than the box's reach: their length to second order in P (no cone).
            long_seg = (lens >= LONG * np.sqrt(st.n) * delta) & (vx.rep[1:] != vx.rep[:-1])
        sub_tol = SOLVER_TOL
        if curvature:  # far from the optimum the step needs fewer digits than the solver's 1e-9
            sub_tol = min(LOOSE_TOL, max(SOLVER_TOL, 1e-3 * pred_last / max(abs(F), 1e-300)))
        # First without the trust region's rows and, with the curvature model, with only the balls near the point
        # (module docstring, Speed): a solution inside the region and all the balls is the subproblem's; one
        # outside a ball left out is solved again with it; one outside the region (or a failed solve) gives way
        # to the subproblem with the region, whose rows the rest of the run keeps (the plain model's steps end
        # on the region's edge).
        status, free, cp = "", True, None  # free: the solution is the model's own minimiser (not held by the trust region)
        if try_relaxed:
            near = keep
            if keep is not None:
                near = keep & (slack <= NEAR * np.sqrt(st.n) * step_last + 2 * tie)
            cp = collapse.plan(p, vx, slack, tie) if curvature and COLLAPSE else None
            if cp is not None:  # a collapsed point's balls: only the nearest (its run's ends move it)
                on_chord = cp.interior[np.searchsorted(vx.D, vx.rep[1:-1])]
                near = near & ~(on_chord[:, None] & (slack > NEAR_RUN * np.sqrt(st.n) * step_last + 2 * tie))
            while cp is not None:  # straight runs on their chords (foam_mj.smoothing.collapse)
                P, q, A, b, cones, cinfo = collapse.subproblem(cp, st, p, weights, None if y is None else y_pt, near,
                                                               PROX * max(weights.as_tuple))
                sol = collapsed.solve(P, q, A, b, cones, sub_tol)
                status = str(sol.status).rsplit(".", 1)[-1]
                if status not in ("Solved", "AlmostSolved"):
                    cp, status = None, ""  # (the full subproblem below)
                    break
                x = np.asarray(sol.x)
                Qn, Wn = collapse.expand(x, cp)
                if near is keep:
                    break
                assert keep is not None and near is not None  # (keep is None makes near keep)
                out = keep & ~near & (h.centre_distances(Wn) > radii)
                if not out.any():
                    break
                near = near | out
                trace.ball_solves += 1
            while cp is None:
                P, q, A, b, cones, curv, ball_row = _subproblem(st, p, weights, delta, vx, y, rel, near, long_seg, trust=False)
                sol = relaxed.solve(P, q, A, b, cones, sub_tol)
                status = str(sol.status).rsplit(".", 1)[-1]
                x = np.asarray(sol.x)  # (each sol.x makes a new list: read once)
                if status not in ("Solved", "AlmostSolved") or near is keep:
                    break
                assert keep is not None and near is not None
                out = keep & ~near & (h.centre_distances(x[:st.nw].reshape(w.shape)) > radii)
                if not out.any():
                    break
                near = near | out
                trace.ball_solves += 1
            if status in ("Solved", "AlmostSolved"):
                if not _within_trust(x if cp is None else Wn.ravel(), p, vx, delta, rel):
                    try_relaxed, status, cp = False, "", None
                elif keep is not None:
                    keep = near  # (the balls of the problem solved: its duals are the certificate's guess)
        if status not in ("Solved", "AlmostSolved"):
            P, q, A, b, cones, curv, ball_row = _subproblem(st, p, weights, delta, vx, y, rel, keep, long_seg)
            sol = solver.solve(P, q, A, b, cones, sub_tol)
            status = str(sol.status).rsplit(".", 1)[-1]
            x = np.asarray(sol.x)
            trace.trust_solves += 1
            free = curvature and _within_trust(x, p, vx, 0.99 * delta, 0.99 * rel)  # (the rows inactive)
        if status in ("Solved", "AlmostSolved"):
            if cp is None:
                pred = F - _model_value(x, st, weights, vx, p, curv)
            else:
                pred = F - collapse.model_value(x, cp, weights, st.M, cinfo)
            pred_last = pred
            z, cd, Mv = sol.z, st.n + 1, len(vx.s0)  # (a list: only its vertex and ball parts become arrays)
            z0 = np.zeros((st.M, 2))
            if cp is not None:
                collapse.multipliers(z, cp, Qn, weights, st.M, cinfo, vx.D, y_pt, z0)
            elif Mv and weights.angle:
                # y_i = -(the v part of vertex cone i's dual): Clarabel's dual z of the cone (s_i, v_i + J_i dW)
                # enters the Lagrangian as -z . (s_i, v_i + ...), so y_i multiplies v_i as in F's Lagrangian.
                y_pt[:] = 0.0
                y_pt[vx.D[1:-1]] = -np.asarray(z[len(b) - Mv * cd:]).reshape(Mv, cd)[:, 1:]
            if pred <= tol * abs(F) + 1e-15:
                if curvature:  # only the plain model may say so (a clipped curvature can stall short of it)
                    curvature, delta, rel, rejected = False, delta0, RELATIVE, 0
                    continue
                trace.stop_reason = "converged"
                break
            if certify is not None:
                # The subproblem's duals as the certificate's first guess of its multipliers: y for the
                # straight vertices, and z0 / (2 R) for the balls (the cone (R, w - c) against the
                # certificate's R^2 - |w - c|^2 >= 0, whose gradient is -2 (w - c) = -2 R (w - c)/|w - c|).
                if cp is None:
                    kept = np.ones((st.M, 2), dtype=bool) if keep is None else keep
                    z0[kept] = z[ball_row:ball_row + int(kept.sum()) * cd:cd]
                guess = (y_pt.copy(), z0 / (2.0 * radii))
            if certify is not None and pred <= certify_tol * abs(F):
                cert = certify(w, guess)
                if cert.certified(kkt_tol if not curvature or modelled and free else POLISH_TOL):
                    trace.stop_reason = "certified"
                    break
                if curvature and cert.certified(kkt_tol):
                    # Certified but not polished: the clipped curvature can predict too little near such a
                    # point; the plain model takes it from here (as without curvature).
                    curvature, delta, rel, rejected = False, delta0, RELATIVE, 0
                    continue
                certify_tol *= 0.1
            p_new = p.copy()
            p_new[1:-1] = x[: st.nw].reshape(w.shape) if cp is None else Wn
            p_new = _snap(rosary.path(h.project(p_new[vx.rep][1:-1], inset)), h, inset, tie)
            w_new = p_new[1:-1].copy()
            F_new = _true_value(p_new, weights)
            rho = (F - F_new) / pred
        else:
            if not refine:  # ill-conditioned: iterative refinement from now on, and the same step again
                refine = True
                solver, relaxed, collapsed = _Solver(True), _Solver(True), _Solver(True)
                continue
            unsnapped = close & (lens > paths._EPS)
            if unsnapped.any():  # a tie the hatches (or the trust region) do not allow: refuse it, retry
                refused |= unsnapped
                continue
            rho = -np.inf  # a failed subproblem: shrink the region and retry
        if rho >= 0.1:
            w_old = w
            step_last = float(np.max(np.abs(w_new - w_old)))
            w, p, F = w_new, p_new, F_new
            trace.values.append(F)
            trace.accepted += 1
            # The curvature model holds here: its step was its own minimiser and F fell as predicted, so the
            # prediction measures what is left and the certificate (kkt_tol) may end the run (module docstring).
            modelled = y is not None and free and abs(rho - 1.0) <= MODELLED
            early = pred <= EARLY * abs(F) or (modelled and pred <= min(FAST_EARLY * abs(F), FAST * pred_accepted))
            pred_accepted = pred
            if certify is not None and curvature and early and certify(w, guess, False).certified(kkt_tol if modelled else POLISH_TOL):
                # The step's own duals certify its end point (no SOCP for this check): the model is
                # second order, so the next step would only polish F far below the certificate's reach.
                trace.stop_reason = "certified"
                break
            rejected = 0
            if rho >= 0.75:
                delta = min(2.0 * delta, 1.0)
                if curvature:
                    delta = min(delta, max(STEP_CAP * float(np.max(np.abs(w_new - w_old))), 1e-4))
                rel = min(2.0 * rel, RELATIVE)
        else:
            rejected = rejected + 1 if np.isfinite(rho) and pred < 1e-7 * abs(F) else 0
            delta *= 0.25
            if curvature:
                rel *= 0.25
            if rejected >= stall or delta < 1e-12:
                if curvature:  # the plain model from here (see "converged" above)
                    curvature, delta, rel, rejected = False, delta0, RELATIVE, 0
                    continue
                if rejected >= stall:
                    trace.stop_reason = "converged (solver accuracy)"
                else:
                    trace.stop_reason = "trust region collapsed" if status in ("Solved", "AlmostSolved") else f"subproblem {status}"
                break
    return w, trace
