"""``bubbletree``: a bidirectional, goal-directed tree of certified bubbles (the default planner).

Two trees grow, one from q_init and one from q_goal, in the manner of RRT-Connect (Kuffner and LaValle,
"RRT-Connect: An efficient approach to single-query path planning", ICRA 2000), except that every node
is a certified bubble of free configuration space (Quinlan's bubbles; the radius of
:class:`~foam_mj.bubbles.BubbleOracle`) and every extension is a new bubble whose centre lies on or
just beyond its parent's surface, so that parent and child overlap and the segment between them is
certified -- the expansion step of "burs of free C-space" (Lacevic, Osmankovic and Ademovic, "Burs of
free C-space: a novel structure for path planning", ICRA 2016), with balls instead of burs.

One iteration, for both trees at once, with one batched distance query (``Clearance.batch``):

1. Targets. ``batch`` uniform samples of the configuration box per tree (exploration), plus, for the
   ``connect`` bubbles of each tree nearest to the other tree (smallest gap |c_a - c_b| - r_a - r_b;
   each bubble gets at most MAX_TRIES such turns), the centre of their nearest bubble in the other
   tree, and, as RRT-Connect, up to ``connect`` of the other tree's newest bubbles (goal-directed growth).
2. Parents. For a sample or a newest bubble, the tree's bubble of smallest power distance
   |x - c|^2 - r^2 (the bubble whose surface is nearest in the Laguerre sense); for a nearest-pair
   target, the bubble itself.
3. Candidates. Along the unit direction u from the parent's centre c_p (radius r_p) to the target,
   centres c_p + s r_p u for s in :data:`foam_mj.planners.extend.STEPS` (but not beyond the target), all evaluated in the batch
   except those too near the joint bounds for a good radius (step 4; a radius is at most the distance to
   the bounds).
4. Children. Per extension, the farthest candidate whose certified radius r is at least ``r_min`` (or
   :data:`GROW` x its parent's, for a parent under ``r_min``: a small endpoint bubble), that
   overlaps its parent with a hatch (s r_p <= r_p + (1 - HATCH) r), and whose centre lies in no other
   bubble of its tree (no growth inside explored space); candidates of one batch are also deduplicated
   against each other.
5. Connection. When a new bubble of one tree overlaps a bubble of the other with a hatch
   (|c_a - c_b| <= r_a + r_b - HATCH min(r_a, r_b)), a certified chain q_init -> q_goal exists: that is
   the time to the first path. The trees then grow for ``explore`` times as many iterations again, so
   that the overlap graph also holds other routes. These samples are *informed* (Gammell, Srinivasa and
   Barfoot, "Informed RRT*: Optimal sampling-based path planning focused via direct sampling of an
   admissible ellipsoidal heuristic", IROS 2014): uniform in the prolate hyperspheroid of points x with
   |x - q_init| + |x - q_goal| <= c_best, c_best the length of the first chain's centre polyline (an upper
   bound of the shortest path through it), since no shorter path passes elsewhere. On the obstacle scene
   this took the median final length (10 seeds, qpos) from 1.21 to 0.91; uniform samples of the whole box
   mostly grew bubbles far from any short route. ``explore = 1`` is the knee (40 seeds, median final length
   in qpos against ``explore = 1``): 0.5 costs +10 % on the obstacle scene and +1.8 % on step_down, 0.75
   +6 % and +1.8 %, while 1.5 gains at most 1.3 % for 25-28 % more bubbles (step_up: +-0.02 % throughout).

Implementation: each tree keeps its bubbles as rows [-2c, |c|^2 - r^2, 1] and [-2c, |c|^2, 1]
(:class:`foam_mj.planners.trees.Tree`), so that the power distances of step 2, the coverage test of step 4 (a power distance <
0) and the gaps of step 1 are each one matrix product with the lifted points [x, 1, |x|^2]; every candidate lies on a segment
between two points of the joint box, so none lies outside it. Of the growth's CPU time on the 3-joint obstacle scene, about 45
% is MuJoCo's distance queries (about 1,900 per plan, 3-3.5 us each in the batch; 2,100 before the bounds test of step 3,
which finds 12 % of the candidates unable to be good, nearly all at s = 2), the rest numpy over 18 iterations: some two
hundred calls each on arrays of tens to hundreds of rows, so that the count of calls more than their size sets the time (the
gaps' update, the largest part, takes about 15 %); hence rows preallocated with their constants and written in place
(:class:`foam_mj.planners.trees.Tree`), the siblings' rows stored after their tree's. Measured and left out (40-100 seeds, all
three leg scenes, the 5-joint leg and the 6-joint arm): testing candidates for coverage before their query (2 % of them are
covered: the test costs more than the queries it saves); dropping an extension whose direction is within 0.5 rad of an earlier
one from the same parent (98 % of the rejected siblings share their parent) saves a third of the candidates but lengthened the
5-joint leg's paths by 1.5-2 %; a single candidate per extension (s = 1.25 or 1.5), or one only during exploration, saves
20-45 % of the queries but adds bubbles or lengthens the obstacle scene's paths by 2-9 % (mean); larger batches with fewer
iterations, or fewer samples while exploring, lengthen the paths (depth of the trees matters); after the first path, dropping
the goal-directed extensions (both kinds: plan -4 ms on obstacle, but step_down +0.85 % and its smoother +5 ms; only the
nearest-pair ones: step_down +0.5 %; only the newest-bubble ones: +1.3 %), and ``connect = 6`` or ``batch = 20`` (obstacle
0.826 -> 0.861 / 0.892) were measured and left out as well. Also exact but no faster: sizing the s = 2 candidates first and
the s = 1 ones only where the former is not good (it is good for a fifth of the extensions: 6 % fewer queries, paid by a
second batch call); and a bound of a candidate's radius from its parent's per-pair distances (Eq. 4 along the step) finds no
candidate that the bounds test does not. The informed samples are clipped to the box (78 % of them on the obstacle scene, 93 %
on the 5-joint leg): drawing them uniform in box and informed set instead lengthened the obstacle scene's paths from 0.83 to
1.12 (median, 10 seeds), as the short routes follow joint limits. On a large configuration space the queries dominate: a UR5e
(MuJoCo Menagerie, joints +-2 pi, a pillar between home and a pose 1.57 rad away; 47 mesh pairs, 26 us a query) took 65-112
iterations, 3,100-4,900 bubbles and 8,400-14,400 queries to its first path (seeds 0-4), about 70 % of that CPU time in the
queries (the Unitree Go2 leg, 100 pairs at 77 us: also 70 %). Its bubbles are small beside the box (median radius 0.05 rad, 90
% under 0.16, in a box 12.6 wide): the gap between the trees falls from 1.15 to 0.60 within 20 iterations, then stays there
while the trees wander around the pillar (up to 6 rad from their roots) until they meet elsewhere. The s = 2 candidate is good
for only 6-7 % of the extensions there (half of the queries; s = 1: 90-95 %), but no bound rules it out before its query (a
Lipschitz bound from the parent or the s = 1 candidate always allows 3 r_p, beyond the r_p / (1 - HATCH) it needs). Measured
there and left out (medians, 5 seeds, queries to the first path against 10,700): ``batch`` 8 7,500 but 116 iterations instead
of 83, ``batch`` 48 13,200, ``connect`` 8 or 16 11,800-16,200 (``connect`` 0 never met in 20 s), MAX_TRIES 1 9,700 (within the
seeds' spread); continuing each goal-directed extension toward the same target in the next iterations (RRT-Connect's CONNECT,
once the gap had not shrunk for 5 iterations) 11,400, and also those toward the uniform samples 13,500. Cheaper queries for
the same radii: a candidate's radius is at most its parent's plus the step (the radius is 1-Lipschitz) and its distance to the
bounds, so MuJoCo measures each pair only as far as it could set the radius (:meth:`foam_mj.bubbles.BubbleOracle.radii_below`,
the distance sensors' cutoff per configuration: GJK stops once it has proven a pair that far). The same radii to the last bit;
on the UR5e 20 -> 12-15 us a query (47 mesh pairs, the recorded candidates of a plan), its whole plan (seeds 0-2) 0.71-0.85x
the CPU time; on the 3-joint leg (6 primitive pairs) no change. With the hinge reach's steps along the hinge's own axis no
longer counted as a lever (:mod:`foam_mj.bubbles`; the UR5e's forearm/wrist_2 pair had held 90 % of its bubbles to 0.163 rad),
the UR5e's first path came after 41-80 iterations and 136-260 ms of CPU (seeds 0-4; 65-112 and 267-534 ms before both
changes), its whole plan took 390-778 ms (815-1,504) and its path's median length in qpos went from 7.08 to 5.04. Still linear
in the foam, per iteration: the parents' power distances, the coverage test and the gaps' update are each one product against
every bubble of a tree (37-40 % of the UR5e's growth CPU at 7,000-10,500 bubbles; on a 7-joint arm searching a caged goal,
session 14: 12 ms an iteration at 2,000-4,000 bubbles, 33 at 45,000). An index would change the plans in the last bits (a BLAS
product over a subset of the rows rounds differently), and a k-d tree of the centres lifted to [c, sqrt(R^2 - r^2)] was no
faster at 28,000 bubbles in 7-D (the largest radius widens every query); the overlap graph beyond 4,096 bubbles is built from
k-d trees by radius class (:func:`foam_mj.planners.corridor.overlap_pairs`).

Lengths (Dijkstra's weights, the informed set, the cone program of the corridor) are measured in MuJoCo's qpos by
default (``metric = "qpos"``: q scaled by the configuration map, e.g. the leg's normalized hip displacement counted in
metres), the units in which a user and the benchmark compare paths; ``metric = "q"`` measures them in q. The balls
stay balls in q.

Then the corridor (:mod:`foam_mj.planners.corridor`): the shortest chain through the graph of all overlapping bubbles
(both trees), refined where the shortest path through it presses on a bubble's boundary. Every bubble added there is
certified as well: the margin stays delta everywhere.

Design choices (the papers leave them open): start and goal bubbles of any positive certified radius are accepted
(r_min is a resolution of the growth, not a precondition), and so are end points on a joint limit (a straight knee is
its range's end): where the joint bounds, not the clearance, keep an end point's own bubble under r_min, its tree's
root is a certified bubble moved off the bounds that holds it (:meth:`foam_mj.bubbles.BubbleOracle.holding_bubble`; on
a limit the root touches it at the end point), so the path still ends exactly there; an end point with two or more
joints at their limits (an edge or corner of the joint box, which no ball inside the box holds) gets the clearance's
ball about itself, which leaves the box: every hatch of a chain lies in an in-box neighbour, so every path stays in
the box, where the ball certifies it. ``r_min`` defaults to delta / ||rho||_2 / 2, half the radius that a clearance of
2 delta buys (the bound of Nascimento and Alsina 2021 Eq. 4 on this model), so that narrow passages down to a few
delta of clearance are still entered; at most a tenth of half the joint box's diagonal (a margin large beside the
robot's reach would otherwise ask for a resolution coarser than the box itself).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from foam_mj.errors import ConfigurationError, PlanningFailed, clearance_text, is_finite_number, radius_text
from foam_mj.foam import seed_rng
from foam_mj.planners.base import PlanningProblem, PlanResult, PlanStats, Planner, ProgressFn, Timer, check_problem, too_small_to_grow
from foam_mj.planners.corridor import CorridorOptions, load_solvers, overlap_pairs
from foam_mj.planners.extend import ESCAPING, GOAL, SAMPLED, Extender
from foam_mj.planners.routes import build_routes
from foam_mj.planners.informed import InformedSampler
from foam_mj.planners.trees import SHRINK, SHRINK_FROM, SPAN, Bubbles, GapHistory, lifted

#: The exploration after the first path counts at most this many iterations per unit of ``explore``: a bound for
#: slow narrow-passage searches (a box 0.52 m tall on the obstacle scene met after 16,049 iterations), not for a
#: large configuration space. At 20, a UR5e (MuJoCo Menagerie, joints +-2 pi, a pillar between home and a pose
#: 1.57 rad away) met after 70-130 iterations and explored 20: its corridor stayed on the first, wandering route
#: (seeds 0-4, with CHAIN_FIRST: median final length in qpos 9.10; 200: 6.94, OMPL RRTConnect + simplify 8.23). The
#: benchmark problems meet within 14 iterations (10 seeds), so the cap does not bind there. Its price: over a box
#: 0.50 m tall on the obstacle scene (first path after 913-1,171 iterations, seeds 0-1) the 200 iterations cost
#: 1.1-1.3 s of CPU more (2.1-2.9 -> 3.3-4.2 s) for paths 3-6 % shorter.
EXPLORE_CAP = 200
#: A bubble is extended toward the other tree at most this many times (then others nearby get their turn).
MAX_TRIES = 3
#: A child needs radius r_min, or GROW x its parent's if that is less and the parent has at least SMALLEST
#: (configuration units): so a start or goal bubble below r_min (an endpoint a fraction of a millimetre above delta,
#: or beside a joint bound) grows a chain of larger bubbles out of its corner instead of never growing. A bubble below
#: SMALLEST does not grow (its hatches, HATCH x its radius deep, would be thinner than the cone programs resolve:
#: roots of 0.7-1e-5 beside bubbles of 4e-3 to 6e-2 gave infeasible programs), and such an endpoint stays
#: unreachable: unless the other end's bubble holds it, it is refused before any growth (ConfigurationError naming
#: its clearance; it failed after the whole time budget, 60 s by default, before). On the obstacle scene, starts 5.02-5.4 mm from the box (delta 5 mm) failed on
#: every seed after the whole budget; now those from 5.04 mm plan in 0.1-0.4 s (seeds 0-5), and the optimal smoother's
#: paths are certified and keep their own clearance. Plans from other starts are unchanged (hashall.py). GROW was 1.5:
#: a foot resting flat 5.127 mm above a block (root 1.06e-4) beside the straight leg, which no direction lifts fast,
#: had children of at most 1.485 x its radius within two radii, and its tree never grew (stalled); at 1.25 it plans in
#: 0.3 s. A child of 1.25 x needs its clearance above delta to grow at a quarter of the bound's rate along the step.
GROW = 1.25
SMALLEST = 3e-5
#: ESCAPE: GROW asks a child on its parent's surface (s <= 2) to gain a quarter of the parent's radius; where the closest
#: pair's distance changes far slower than ||rho|| allows, no direction may (measured when GROW was 1.5: a self pair of
#: an 8-joint arm moved by two wrist joints, the best of 4,000 directions reached 1.33 x the parent's radius at s = 2),
#: and an end bubble below r_min never grew: the tree failed after the whole budget while RRT-Connect found a path in
#: 0.3 s (a child of 1.33 x now meets GROW 1.25; ESCAPE stays for pairs slower still). So while every bubble of a tree is below r_min (and its root
#: lies in the joint box), its largest bubble is also extended once per iteration up the radius's gradient (central
#: differences, 2n distance queries), keeping a child of ESCAPE x its radius: the tree climbs out of the small regime
#: in log(r_min / r) / log(ESCAPE) such steps. Trees whose roots reach r_min are unchanged (hashall.py).
ESCAPE = 1.1
#: A root that leaves the joint box (an end point on an edge or corner of it: foam_mj.bubbles.BubbleOracle.holding_bubble)
#: has children of radius r_min, or CORNER x its own if that is less: next to the corner the bounds keep every bubble
#: in the box small (a child on the root's surface is about r / sqrt(2) from two faces), and from such a child GROW
#: takes over. With r_min alone, a corner goal of step_down 7.4 mm from the floor (root 2.16e-3, r_min 2.1e-3) never grew.
CORNER = 0.5
#: TOWARD_SMALL: with such a root, an extension toward a bubble of the other tree below r_min (aimed at its centre:
#: the nearest-pair and newest-bubble targets of step 1) keeps children of CORNER x that bubble's radius, or of the
#: corner root's, whichever is larger (never smaller: no cascade of ever smaller bubbles). Beside a corner close to an
#: obstacle, every in-box bubble is bound- and clearance-limited below r_min, and the other tree came within a few
#: such radii of the stalled tree without reaching it: a step_down start on an edge 7.4 mm from the floor (root
#: 2.2e-3, r_min 2.1e-3) failed after the whole budget (seed 0: 4 start bubbles after 5 s); now seeds 0-4 plan in
#: 0.3-4.7 s, certified, and so do delta 6, 6.5 and 7.2 mm there (seed 0; 7 mm fails in 3 s). Other plans: unchanged.
#: A failed plan names an end point on a joint limit whose tree holds fewer bubbles than this (it stalled beside it).
STALLED = 20
#: ``refine_chain = 0``: refinement starts no new round once the chain holds this many bubbles per joint
#: (on the 3-joint obstacle scene 60 bubbles cut plan + optimal smoother by ~13 % CPU at the same median
#: length; on the 5-joint leg a cap of 60 cost 6 % of length, 100 costs nothing).
#: 17 (seeds 0-9, CPU medians, old and new in one process): obstacle length +1.05 % (0.8264 -> 0.8351, seed 4 +8 %) for
#: plan + optimal smoother x0.92 in one run, x1.00 in another (step_down x0.90, +0.3 %): within a shared machine's noise.
CHAIN_PER_JOINT = 20
#: ... or, if more, this many times the bubbles of the first chain (the shortest chain of the trees' overlap graph):
#: a path long beside its bubbles needs that many to hold it, and the chords that shorten it add as many again. A UR5e
#: whose first chain held 85-110 bubbles (6 joints: a cap of 120) stopped after one round, its chords half spliced
#: (seeds 0-4, EXPLORE_CAP 200: median final length in qpos 9.32 -> 6.94). The benchmark problems' first chains hold
#: at most 9.7 bubbles per joint (10 seeds), so the per-joint cap still decides there.
CHAIN_FIRST = 2.0
#: ``stall``: a level of the search for a first path ends (then FINER) after this many iterations in which the trees came
#: no closer than their smallest gap so far less r_min / 2, or, if more, as many as it had run when they last came closer
#: (a slow search that keeps progressing is not cut). Bubbles cannot prove a goal unreachable; a goal enclosed by obstacles
#: or beyond a wall leaves that gap unchanged while the trees fill their own regions (they did so for the whole budget).
#: Measured, iterations without progress before the first path: a box 0.50-0.51 m tall (11 plans) at most 720, a step_down
#: start on an edge 7.4 mm from the floor at most 587, the benchmark problems (10 seeds, met at iteration 5-18) 1; a box
#: 0.52 m tall met at iteration 16,049 after stalls of up to 1,821. The leg's cup and 0.7 m box stall from iteration 240-260. See also SHRINK.
STALL = 3_000
#: FINER: a stall is not a failure while the resolution can be refined: r_min / FINER, at most FINER_LEVELS times (not
#: below SMALLEST), tries reset, windows stall / FINER_STALL, progress still the first r_min / 2; a bubble of at least the
#: first r_min keeps no smaller child toward a random sample (finer bubbles grow toward the other tree and on within narrow
#: places, not along every obstacle). r_min is a resolution, not a precondition: a puck's slot 1-4 mm wider than the puck
#: and its margin on each side (bubbles 0.5-2 mm, r_min 2.5 mm) stalled, "maybe unreachable"; now threaded 8-325 iterations
#: after a refinement (walls 2 and 30 cm thick); a 10 mm channel between a joint limit and a wall on 5 seeds of 6.
#: Unreachable goals cost 900 iterations more (the leg's 0.7 m wall: 14,606 -> 18,260 bubbles). Benchmarks never stall.
#: RIDGE: past a stall, a nearest-pair extension from a bubble below the first r_min aims halfway up the radius's gradient
#: (2n queries; its direction to the other tree's bubble plus the unit gradient). Both trees of a puck's channel between a
#: joint limit and a wall (y in [0.44, 0.445]) had reached its ends above it and aimed at each other along the clearance's
#: edge: chains of ever smaller bubbles toward the wall's corner, stalled at every r_min (seed 0); now met 40 iterations
#: after the second refinement. Unreachable goals: as many iterations, more bubbles (the leg's 0.7 m wall 18,260 -> 18,493;
#: puck behind a wall 858 -> 1,423, seed 0).
FINER = 4.0
FINER_LEVELS = 3
FINER_STALL = 10
#: Upper bounds of ``batch``/``connect`` and of ``explore`` (beyond them memory or time explode, nothing improves).
MAX_EXTENSIONS = 1_000
MAX_EXPLORE = 100.0


@dataclass(frozen=True)
class BubbleTreeOptions:
    """``batch``: random extensions per tree per iteration; ``connect``: extensions per tree toward the
    other tree per iteration; ``r_min``: smallest bubble grown (configuration units; 0 = delta / ||rho|| / 2);
    ``refine``: build the near-shortest corridor after the first path; ``refine_tol``: stop refining when a
    round shortens the path by less than this fraction; ``refine_rounds``: at most this many rounds; ``explore``: iterations of growth after the trees meet,
    per iteration before; ``refine_floor``: refinement bubbles' smallest radius, in delta / ||rho||_2; ``refine_time``: no new round after this many seconds of
    refinement, in process CPU time (the first path is never lost: refinement only shortens it; a cap for
    pathological problems, far above what refinement takes (0.03-0.2 s): counted in CPU time and not wall
    time, so that a loaded machine gives the same path for the same seed; the problem's ``time_limit``, wall time, also ends the rounds, so a plan whose trees met near it is not refined past it); ``informed``: after the first path,
    explore only where a shorter path can pass (the informed set); ``metric``: the length the corridor
    minimises, ``"qpos"`` (MuJoCo's joint units: radians and metres, through the configuration map's scale)
    or ``"q"`` (the planner's coordinates; the same unless a joint is normalized); ``refine_chain``: no new
    refinement round once the chain holds this many bubbles (0: 20 per joint, or twice the first chain's if more); ``stall``: give up (outcome "stalled") when the
    trees have come no closer (by r_min / 2) in this many iterations before they meet, or in as many as the search had run
    when they last came closer, if more (0: search until a budget ends); ``routes``: corridors from this many chains, the shortest kept (see routes)."""

    batch: int = 24
    connect: int = 4
    r_min: float = 0.0
    refine: bool = True
    refine_tol: float = 0.005
    refine_rounds: int = 30
    refine_time: float = 10.0
    refine_floor: float = 3.0
    explore: float = 1.0
    informed: bool = True
    refine_chain: int = 0
    metric: str = "qpos"
    stall: int = STALL
    routes: int = 1

    def __post_init__(self) -> None:
        for name in ("batch", "connect", "refine_rounds", "refine_chain", "stall", "routes"):
            v, lo = getattr(self, name), 1 if name in ("batch", "routes") else 0
            if not (isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= lo):
                raise ValueError(f"`{name}` must be an integer >= {lo}, got {v!r}")
        for name in ("batch", "connect"):  # candidates are sized in one MuJoCo batch: memory grows with them
            if getattr(self, name) > MAX_EXTENSIONS:
                raise ValueError(f"`{name}` must be at most {MAX_EXTENSIONS} extensions per tree per iteration, got {getattr(self, name)!r}")
        if not (isinstance(self.r_min, (int, float)) and is_finite_number(self.r_min) and self.r_min >= 0):
            raise ValueError(f"`r_min` must be >= 0 (0: derived from delta), got {self.r_min!r}")
        if not isinstance(self.refine, bool):
            raise ValueError(f"`refine` must be true or false, got {self.refine!r}")
        if not (isinstance(self.refine_time, (int, float)) and is_finite_number(self.refine_time) and self.refine_time > 0):
            raise ValueError(f"`refine_time` must be > 0 seconds and finite, got {self.refine_time!r}")
        if not (isinstance(self.explore, (int, float)) and 0 <= self.explore <= MAX_EXPLORE):
            raise ValueError(f"`explore` must be in [0, {MAX_EXPLORE:g}] (iterations after the first path, per iteration before it), got {self.explore!r}")
        if not (isinstance(self.refine_floor, (int, float)) and 0 < self.refine_floor < np.inf):  # inf: silently no refinement bubble
            raise ValueError(f"`refine_floor` must be a finite number > 0 (a multiple of delta / ||rho||), got {self.refine_floor!r}")
        if self.metric not in ("q", "qpos"):
            raise ValueError(f"`metric` must be \"q\" or \"qpos\", got {self.metric!r}")
        if not isinstance(self.informed, bool):
            raise ValueError(f"`informed` must be true or false, got {self.informed!r}")
        if not (isinstance(self.refine_tol, (int, float)) and 0 < self.refine_tol < 1):
            raise ValueError(f"`refine_tol` must be in (0, 1), got {self.refine_tol!r}")


class BubbleTreePlanner(Planner):
    name = "bubbletree"
    summary = "bidirectional goal-directed tree of certified bubbles, then a near-shortest corridor (the default)"
    Options = BubbleTreeOptions

    def plan(self, problem: PlanningProblem, seed: int | np.random.Generator = 0, progress: ProgressFn | None = None) -> PlanResult:
        check_problem(problem, progress)
        o = self.options
        oracle = problem.oracle
        robot = oracle.robot
        rng = seed_rng(seed)
        load_solvers()
        timer = Timer(progress)
        cpu0 = time.process_time()
        calls0 = oracle.clearance.calls
        n = robot.dim
        lo, hi = robot.lower, robot.upper
        factor = oracle.bound.ball_factor
        span = hi - lo
        half_span = 0.5 * float(np.linalg.norm(span))
        r_min = o.r_min if o.r_min > 0 else min(problem.delta / factor / 2 if problem.delta > 0 else 1e-4, 0.1 * half_span)
        if r_min >= half_span:  # a resolution coarser than the joint box: no child could ever be kept
            raise ConfigurationError(f"bubbletree option `r_min` = {r_min:g} is not below half the joint box's diagonal "
                                     f"({half_span:.3g}); use a smaller one (0: derived from delta)")
        q0, q1 = problem.q_init, problem.q_goal
        e0, e1 = problem.endpoint_bubbles(r_min)  # centred at q0 and q1 unless a joint limit is in the way
        (c0, r0), (c1, r1) = (e0.center, e0.radius), (e1.center, e1.radius)
        outside = np.array([not e0.within_bounds, not e1.within_bounds])  # roots that leave the joint box
        corner_roots = bool(outside.any())
        r_corner = min(r for r, out in zip((r0, r1), outside) if out) if corner_roots else 0.0
        metric = robot.config.scale if o.metric == "qpos" else np.ones(n)

        B = Bubbles(n)
        counters = {"iterations": 0, "candidates": 0, "rejected_small": 0, "rejected_covered": 0}
        def stats(outcome: str, t_first: float | None, extra: dict | None = None) -> PlanStats:
            details = dict(counters, r_min=r_min, finer_at=list(finer_at), tree_start=int(np.sum(B.tree[: B.n] == 0)), tree_goal=int(np.sum(B.tree[: B.n] == 1)))
            details.update(extra or {})
            return PlanStats(self.name, outcome, B.n, oracle.clearance.calls - calls0, timer.elapsed(), t_first, details)

        def closest_approach(unreachable: bool) -> tuple[str, bool]:
            """Where the trees came nearest: the configuration halfway across the gap between the two bubbles
            nearest each other, its clearance and the pair that sets it (what blocks the way, for the user); with
            ``unreachable``, that the goal may be unreachable (not said when a budget, time or bubbles, cut the search short).
            With one joint (an interval: every configuration joint is limited) a configuration between q_init and
            q_goal closer than delta proves the goal unreachable, whatever the budget: then that is said, and True
            returned with the text."""
            T = B.trees[0]
            if T.n == 0 or not np.isfinite(T.gap[: T.n]).any():
                return "", False
            i = int(np.argmin(T.gap[: T.n]))
            a, b = int(T.idx[i]), int(T.mate[i])
            u = B.c[b] - B.c[a]
            u /= np.linalg.norm(u)
            q = np.clip(B.c[a] + (B.r[a] + T.gap[i] / 2) * u, lo, hi)
            report = oracle.explain(q)
            robot = oracle.robot
            closest = int(np.argmin(report.pair_distances))
            hint = robot.hull_hint(*(int(g) for g in robot.pairs[closest]))
            proven = n == 1 and min(q0[0], q1[0]) <= q[0] <= max(q0[0], q1[0]) and report.clearance < problem.delta
            verdict = (": the goal is unreachable from the start: with one joint every motion between them passes this q, "
                       "closer than delta" if proven else ": the goal may be unreachable from the start" if unreachable else "")
            return (f"; they came nearest at q = {(np.round(q, 4) + 0.0).tolist()} (a gap of {T.gap[i]:.3g} between their bubbles), with "
                    f"clearance {clearance_text(report.clearance, problem.delta)} between {robot.pair_label(closest)}"
                    f"{verdict} (`foam-mj bubble` shows more){hint}"), proven

        def chain_length(pair: tuple[int, int]) -> float:
            """Length of the polyline q_init -> centres of the tree chain through ``pair`` -> q_goal (an upper
            bound of the shortest path through it: consecutive centres lie in overlapping balls)."""
            pts = []
            for k in pair:
                side = []
                while k >= 0:
                    side.append(B.c[k])
                    k = int(B.parent[k])
                pts.append(side)
            P = np.array([q0] + pts[0][::-1] + pts[1] + [q1])
            return float(np.sum(np.linalg.norm(np.diff(P, axis=0) * metric, axis=1)))

        def escape_target(c: np.ndarray, r: float) -> np.ndarray:
            """The point 2 r up the certified radius's gradient at c (central differences of step r / 10, kept in the
            joint box), where ESCAPE's extension from the bubble (c, r) aims; c itself where the radius is flat there."""
            h = 0.1 * r
            X = np.clip(np.concatenate([c + h * np.eye(n), c - h * np.eye(n)]), lo, hi)
            R = oracle.radius_from_distances(oracle.clearance.batch_pairs(X), X)
            counters["candidates"] += len(X)
            step = X[:n].diagonal() - X[n:].diagonal()
            g = np.divide(R[:n] - R[n:], step, out=np.zeros(n), where=step > 0)
            norm = float(np.linalg.norm(g))
            return c if norm == 0.0 else np.clip(c + 2 * r * g / norm, lo, hi)

        def uphill(c: np.ndarray, r: float, target: np.ndarray) -> np.ndarray:
            """``target``'s direction from the bubble (c, r) turned halfway up the radius's gradient (RIDGE), at the
            same distance, kept in the joint box."""
            u = target - c
            d = float(np.linalg.norm(u))
            g = escape_target(c, r) - c
            norm = float(np.linalg.norm(g))
            if d == 0.0 or norm == 0.0:
                return target
            w = u / d + g / norm
            wn = float(np.linalg.norm(w))
            return target if wn == 0.0 else np.clip(c + d * w / wn, lo, hi)

        sampler: InformedSampler | None = None
        extender = Extender(oracle, o.batch + 2 * o.connect + 1, problem.max_bubbles)  # per tree per iteration: one ESCAPE
        small = [not out for out in outside.tolist()]  # a tree (its root in the box) all of whose bubbles may be below r_min
        newest = B.add(np.stack([c0, c1]), np.array([r0, r1]), np.array([-1, -1]), np.array([0, 1], dtype=np.int8))
        link = B.update_gaps(newest)
        if link is None:  # an end bubble below SMALLEST never grows, and no other bubble comes to hold its centre
            for name, q, r in (("q_init", q0, r0), ("q_goal", q1, r1)):
                if r < SMALLEST:
                    raise ConfigurationError(too_small_to_grow(oracle, name, q, r, SMALLEST))
        t_first: float | None = None
        explore_stopped: str | None = None  # why the search for other routes ended before its iterations, if it did
        it_first = it_last = 0  # the iteration of the first path, and the last one to run after it
        foam_first = 0
        gap_then, it_then = np.inf, 0  # the gap at the last progress (the trees came r_min / 2 closer), and its iteration
        r_coarse, it_level = r_min, 0  # the first resolution, and the iteration at which the present one began (FINER)
        finer_at: list[int] = []  # the iterations at which the resolution was refined
        history, shrank, first_shrank = GapHistory(), False, ""  # the gap per iteration; SHRINK ends this level; and why it ended the first
        while True:
            history.record(B.closest)
            if B.closest <= gap_then - 0.5 * r_coarse:
                gap_then, it_then = B.closest, counters["iterations"]
            if link is not None and t_first is None:
                t_first, it_first, foam_first = timer.elapsed(), counters["iterations"], B.n
                cpu_first = time.process_time() - cpu0
                if o.informed:
                    sampler = InformedSampler(q0, q1, chain_length(link), metric)
                it_last = it_first + int(np.ceil(o.explore * min(it_first, EXPLORE_CAP)))
            if t_first is not None and counters["iterations"] >= it_last:
                break  # the first path, then `explore` x as many iterations again (at most EXPLORE_CAP) for other routes
            window = o.stall if not finer_at else -(-o.stall // FINER_STALL)  # a finer level's window is shorter (FINER)
            since = max(it_then, it_level)  # this level's last progress, or its start
            stalled = t_first is None and o.stall and counters["iterations"] - since >= max(window, since - it_level)
            shrank = t_first is None and o.stall and not finer_at and history.stalled(SHRINK_FROM)  # the first level only
            stalled = stalled or shrank
            if stalled and r_min / FINER >= max(SMALLEST, r_coarse / FINER**FINER_LEVELS) * (1 - 1e-12):
                r_min /= FINER  # a finer resolution: a passage narrower than the last one's bubbles may open (FINER)
                first_shrank = f" (at {counters['iterations']:,}: the trees' gap, {B.closest:.3g}, had shrunk by less than {SHRINK:.0%} since iteration {counters['iterations'] // SPAN:,})" if shrank else first_shrank
                gap_then, it_level = B.closest, counters["iterations"]
                finer_at.append(it_level)
                for T in B.trees:  # the nearest pairs' extensions failed at the coarser resolution: try them again
                    T.tries[: T.n] = 0
                stalled = False
            if timer.elapsed() > problem.time_limit or B.n >= problem.max_bubbles or stalled:
                if t_first is not None:  # the search for other routes ends early (PlanStats.clock_cut when by the clock)
                    explore_stopped = "time limit" if timer.elapsed() > problem.time_limit else "bubble budget"
                    break
                outcome = ("time budget" if timer.elapsed() > problem.time_limit else "bubble budget" if B.n >= problem.max_bubbles
                           else "stalled")
                st = stats(outcome, None)
                stuck = "".join(
                    (f"; the {side} tree never grew: {name}'s certified bubble has radius {radius_text(r, r_min)} < r_min = {r_min:.3g}"
                     f"{f' and < {SMALLEST:g}, too small to grow from' if r < SMALLEST else ''} (its clearance "
                     f"is barely above delta or it lies next to a joint bound; `foam-mj bubble` shows which): move it away"
                     f"{'' if r < SMALLEST else ', or lower r_min (an option of the [planner] table)'}")
                    if T.n == 1 and r < r_min else
                    (f"; the {side} tree stopped at {T.n} bubbles: {name} lies on {'an edge or corner of the joint box' if out else 'a joint limit'} "
                     f"and its certified bubble has radius {r:.3g}, so the bubbles beside it are too small to grow (clearance "
                     f"{clearance_text(oracle.clearance(q), problem.delta)}): move it off a limit or away from the obstacle")
                    for side, name, q, r, out, T in (("start", "q_init", q0, r0, outside[0], B.trees[0]), ("goal", "q_goal", q1, r1, outside[1], B.trees[1]))
                    if (T.n == 1 and r < r_min) or (T.n < STALLED and (out or oracle.to_bounds(q) < r_min))
                )
                approach, proven = ("", False) if stuck else closest_approach(outcome == "stalled")
                why, tail = outcome, stuck or approach
                idle, total = counters["iterations"] - it_then, counters["iterations"]
                finer = (f", r_min refined from {r_coarse:.3g} to {r_min:.3g} at iteration{'s' if len(finer_at) > 1 else ''} "
                         f"{', '.join(f'{i:,}' for i in finer_at)}{first_shrank}") if finer_at else ""
                if outcome == "stalled" and shrank:  # SHRINK: the trees stopped coming closer, the gap that is left
                    why += f": the trees stopped coming closer, their gap {B.closest:.3g} shrank by less than {SHRINK:.0%} from iteration {total // SPAN:,} to {total:,}"
                elif outcome == "stalled":
                    why += f": {idle:,} iterations without coming r_min / 2 = {0.5 * r_coarse:.3g} closer{finer}"
                    tail += "" if proven else (f"; a passage whose free bubbles all have radius below {r_min:.3g} (clearance less than about "
                             f"{r_min * factor:.2g} m above delta) stays closed to this search; the [planner] option stall = 0 "
                             "searches until the time budget ends")
                elif not proven:  # a budget ended it: whether they were still coming closer tells whether more could help
                    tail += f"{finer.replace(',', ';', 1)}; they last came r_min / 2 closer at iteration {it_then:,} of {total:,}"
                    if o.stall and total - since < max(window, since - it_level):
                        rule = f"{max(window, since - it_level):,} iterations without coming r_min / 2 closer"
                        if not finer_at:  # the first level also ends by SHRINK
                            rule += (f", or from iteration {SHRINK_FROM:,} a gap shrinking by less than {SHRINK:.0%} while the "
                                     f"iterations grow {SPAN}-fold; the gap is {B.closest:.3g} now")
                        budget, more = ((f"time limit ({problem.time_limit:g} s)", "--time-limit, the [planner] time_limit")
                                        if outcome == "time budget" else
                                        (f"bubble budget (max_bubbles = {problem.max_bubbles:,})", "the [planner] max_bubbles"))
                        tail += (f": the {budget} ended the search before the trees stalled ({rule}); "
                                 f"with more ({more}) it goes on until they meet or stall")
                raise PlanningFailed.after(f"the trees did not meet ({why}) after {B.n} bubbles", st, tail, B.foam(q0, q1))
            if progress is not None:
                timer.report(B.n, lambda: "the trees met, exploring" if t_first is not None else f"trees {B.closest:.3g} apart, last closer at "
                             f"iteration {it_then:,} of {counters['iterations']:,}{f', r_min refined to {r_min:.3g}' if finer_at else ''}")
            counters["iterations"] += 1
            parents, targets, target_r, blocks = [], [], [], []  # blocks: (size, kind) of each array of `parents`
            escaping = False
            for t in (0, 1):
                T = B.trees[t]
                mine = T.idx[: T.n]
                if small[t]:  # ESCAPE: up the radius's gradient from its largest bubble (no longer, once one has r_min: r_min only falls)
                    if T.r[: T.n].max() < r_min:
                        top = int(mine[T.r[: T.n].argmax()])
                        parents.append(np.array([top]))
                        targets.append(escape_target(B.c[top], B.r[top])[None])
                        blocks.append((1, ESCAPING))
                        escaping = True
                        if corner_roots:
                            target_r.append(np.full(1, np.inf))
                    else:
                        small[t] = False
                # Exploration: uniform samples (after the first path: only where a shorter path can pass).
                if sampler is None:
                    X = lo + span * rng.random((o.batch, n))
                else:
                    X = np.minimum(np.maximum(sampler.sample(rng, o.batch), lo), hi)
                # Goal-directed: the bubbles nearest to the other tree (each tried at most MAX_TRIES times),
                # toward their nearest bubble there; and, as RRT-Connect, toward the other tree's newest bubbles.
                near = pick = None
                if o.connect:
                    fresh = (T.tries[: T.n] < MAX_TRIES).nonzero()[0]  # positions in the tree
                    if len(fresh):
                        k = min(o.connect, len(fresh))
                        near = fresh[T.gap[fresh].argpartition(k - 1)[:k]] if k < len(fresh) else fresh
                        T.tries[near] += 1
                        mates = T.mate[near]
                        toward = B.c[mates]
                        near = mine[near]
                        if corner_roots:
                            toward_r = B.r[mates]
                        if finer_at:  # RIDGE: a bubble below the first r_min aims up the radius's gradient as well
                            toward = np.array([uphill(B.c[i], B.r[i], x) if B.r[i] < r_coarse else x for i, x in zip(near, toward)])
                    theirs = newest[1 - t]
                    if len(theirs):
                        chosen = theirs[rng.permutation(len(theirs))[: o.connect]]
                        pick = B.c[chosen]
                        if corner_roots:
                            pick_r = B.r[chosen]
                # Samples and newest bubbles extend the bubble of smallest power distance |x - c|^2 - r^2.
                Y = X if pick is None else np.concatenate([X, pick])
                par = mine[(lifted(Y) @ T.pw[: T.n].T).argmin(axis=1)]
                parents.append(par[: len(X)])
                targets.append(X)
                blocks.append((len(X), SAMPLED))
                if corner_roots:
                    target_r.append(np.full(len(X), np.inf))
                if near is not None:
                    parents.append(near)
                    targets.append(toward)
                    blocks.append((len(near), GOAL))
                    if corner_roots:
                        target_r.append(toward_r)
                if pick is not None:
                    parents.append(par[len(X):])
                    targets.append(pick)
                    blocks.append((len(pick), GOAL))
                    if corner_roots:
                        target_r.append(pick_r)
            kind = np.repeat(np.array([k for _, k in blocks], dtype=np.int8), [b for b, _ in blocks]) if escaping or finer_at else None

            def floors(live: np.ndarray | None, P: np.ndarray, rP: np.ndarray) -> np.ndarray:
                """The smallest radius kept per extension (of the extensions ``live``, None: all) from parents P of radii rP."""
                kd = kind if kind is None or live is None else kind.take(live)
                # Past a stall (FINER), a bubble of at least the first r_min keeps no child below it toward a random sample.
                r_row = np.where((kd == SAMPLED) & (rP >= r_coarse), r_coarse, r_min) if finer_at else r_min
                floor = np.where(rP >= SMALLEST, np.minimum(r_row, GROW * rP), r_row)  # (GROW, SMALLEST)
                if corner_roots:  # children of a root on an edge or corner of the box (CORNER), and TOWARD_SMALL
                    root = P < 2
                    floor[root] = np.where(outside[P[root]], np.minimum(r_min, CORNER * rP[root]), floor[root])
                    tr = np.concatenate(target_r)  # toward a bubble of the other tree below r_min
                    tr = tr if live is None else tr.take(live)
                    floor = np.where(tr < r_min, np.minimum(floor, CORNER * np.maximum(tr, r_corner)), floor)
                if escaping:
                    floor = np.where(kd == ESCAPING, np.minimum(r_min, ESCAPE * rP), floor)
                return floor

            grown = extender.children(B, np.concatenate(parents), np.concatenate(targets), floors, counters)
            if grown is None:
                continue
            newest = B.add(*grown)
            met = B.update_gaps(newest, link is None)
            link = link if link is not None else met

        cpu_tree = time.process_time() - cpu0
        corridor = build_routes(
            o.routes, problem, B.c[: B.n], B.r[: B.n], link,
            CorridorOptions(refine=o.refine, refine_tol=o.refine_tol, refine_rounds=o.refine_rounds, time_limit=o.refine_time,
                            floor_factor=o.refine_floor, metric=metric, max_chain=o.refine_chain or CHAIN_PER_JOINT * n,
                            max_chain_first=0.0 if o.refine_chain else CHAIN_FIRST,
                            deadline=timer.t0 + problem.time_limit), rng,
        )
        if len(corridor.added_centers):
            B.add(corridor.added_centers, corridor.added_radii, corridor.added_parents, np.full(len(corridor.added_radii), 2, dtype=np.int8))
        corridor.stats["cpu_ms"] = {"first": round(1e3 * cpu_first, 2), "explore": round(1e3 * (cpu_tree - cpu_first), 2), **corridor.stats["cpu_ms"]}
        ended = {} if explore_stopped is None else {"explore_stopped": explore_stopped}
        st = stats("reached", t_first, {"bubbles_at_first_path": foam_first, "iterations_at_first_path": it_first, **ended, **corridor.stats})
        foam = B.foam(q0, q1)
        return PlanResult(foam, corridor.rosary(problem.q_init, problem.q_goal), st, corridor.waypoints)


__all__ = ["BubbleTreeOptions", "BubbleTreePlanner", "overlap_pairs"]
