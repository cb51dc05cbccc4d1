"""The geometry of ``foam-mj verify`` (:mod:`foam_mj.verify`): which geom pairs it checks, how densely it samples
a path, and the distances, with MuJoCo and numpy alone (none of the planner's code)."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from foam_mj.errors import FoamError

#: The most samples of one polyline (a path's waypoints or its qpos rows): --step 1e-3, the default, takes a few
#: thousand. The check keeps about 4 arrays of its (sample, pair) bounds (8 bytes an entry) at its peak: the arm's 44 pairs
#: at --step 1e-5 (270,000 samples on a path) take 0.75 GB in all (2.8 GB when the sphere bounds were computed at once).
MAX_SAMPLES = 1_000_000

#: How far (relative) a value may lie beyond a joint's range, or a joint that is no coordinate from where the planner
#: held it, before verify says so.
HELD_TOL = 1e-9

#: How many times :func:`prove` may halve a segment between two samples: 30 halvings take a 1 mm travel to 1e-12 m, so
#: a segment still unproved then has a clearance within that of the margin, touching it.
PROOF_ROUNDS = 30
#: The most samples :func:`prove` adds to a polyline of S samples, and the most distance calls it makes there:
#: max(PROOF_BUDGET, 4 S), at most MAX_SAMPLES. A path that keeps a clearance above the margin needs few (only the
#: segments near its closest approach are cut, a few times each, and only its near pairs measured); one running along
#: the margin doubles its samples at every round, each costing a call per pair there, and stops here unproved (32 balls
#: at the margin made 2,016,000 calls, 5.4 s, when only the samples were counted).
PROOF_BUDGET = 100_000

#: How much (m) MuJoCo's distance of a pair may change between two samples beyond the lever arms' travel before
#: :meth:`_Checker._breach` says the travel bound fails (GJK's tolerance is far below it; a wrong lever arm, millimetres).
BREACH_TOL = 1e-5

#: :class:`_Checker` computes every pair's exact distance at every ANCHOR-th sample of a polyline, to bound the others.
ANCHOR = 16

#: How many (sample, pair) candidates with the smallest lower bounds are evaluated first, to bound the minimum.
_PROBES = 32

#: :meth:`_Checker.measure` computes the poses and sphere bounds of about this many (sample, pair) entries at a time:
#: their (sample, pair, 3) temporaries took 2.8 GB for the arm's path at --step 1e-5 (270,000 samples, 44 pairs).
_BLOCK = 1 << 18


def _moving_joints(m: mujoco.MjModel, body: int, moved: set[int] | None = None) -> frozenset[int]:
    """The joints above ``body`` (its own included) that move it: those whose qpos address is in ``moved``,
    when given, otherwise every joint."""
    out = set()
    while body != 0:
        for j in range(m.body_jntadr[body], m.body_jntadr[body] + m.body_jntnum[body]):
            if moved is None or int(m.jnt_qposadr[j]) in moved:
                out.add(j)
        body = int(m.body_parentid[body])
    return frozenset(out)


def _mujoco_tests(m: mujoco.MjModel, a: int, b: int) -> bool:
    """Would MuJoCo's collision detection test geoms a and b (no explicit pair)? Its documented filter:
    contype/conaffinity match, different weld bodies, weld bodies not parent and child (unless the model
    disables that filter or one is the world), body pair not in a ``<contact><exclude>``."""
    ct, ca = m.geom_contype, m.geom_conaffinity
    if not ((ct[a] & ca[b]) or (ct[b] & ca[a])):
        return False
    if _attached(m, a, b):
        return False
    ba, bb = int(m.geom_bodyid[a]), int(m.geom_bodyid[b])
    return ((min(ba, bb) << 16) + max(ba, bb)) not in {int(x) for x in m.exclude_signature}


def _attached(m: mujoco.MjModel, a: int, b: int) -> bool:
    """Are geoms a and b on one weld body, or on weld bodies that are parent and child (neither the world;
    unless the model disables that filter)? MuJoCo never collides such geoms: they meet at their joint by design."""
    wa, wb = int(m.body_weldid[m.geom_bodyid[a]]), int(m.body_weldid[m.geom_bodyid[b]])
    if wa == wb:
        return True
    filter_parent = not (int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT))
    return bool(filter_parent and wa and wb and (wa == int(m.body_weldid[m.body_parentid[wb]]) or wb == int(m.body_weldid[m.body_parentid[wa]])))


def collision_pairs(m: mujoco.MjModel, qpos_index: np.ndarray | None = None, self_collision: bool = False,
                    root: int | None = None) -> np.ndarray:
    """(P, 2) geom ids: every moving collision geom against every static one, and with ``self_collision``
    the robot/robot pairs.

    With ``qpos_index`` (the result's configuration coordinates), *moving* means moved by one of those
    joints; a body on any other joint (a loose box with a free joint) stays where the rows put it and is
    checked as an obstacle, as the planner treats it. Without it, any joint makes a body moving.
    Moving/static pairs are checked with no contype/conaffinity filtering (as the planner),
    except a geom attached to a moving one (:func:`_attached`: the same weld body, or parent and child, e.g. the
    upper arm, held at its ``qpos0`` when only the elbow is a coordinate, and the forearm): they overlap at their
    joint by design, MuJoCo never collides them and the planner does not check them.
    Robot/robot pairs cannot be checked unfiltered (a thigh touches its shank at the knee by design), so
    they are the pairs MuJoCo's own collision detection tests (explicit ``<contact><pair>`` elements, and
    :func:`_mujoco_tests`) whose distance some configuration joint can change (a joint moves one geom and
    not the other).

    ``root`` (the result's ``robot_root`` body): the geoms of its subtree that no configuration joint moves (a floating
    base, the other leg) are the robot too, as the planner has them: held where the rows put them, checked against the
    static geoms, and against the moving ones only as robot/robot pairs."""
    moved = None if qpos_index is None else {int(i) for i in qpos_index}
    coll = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
    joints = {g: _moving_joints(m, int(m.geom_bodyid[g]), moved) for g in coll}
    in_root = _subtree(m, root)
    moving = [g for g in coll if joints[g]]
    held = [g for g in coll if not joints[g] and in_root[int(m.geom_bodyid[g])]]  # the robot's, moved by no coordinate
    static = [g for g in coll if not joints[g] and not in_root[int(m.geom_bodyid[g])]]
    out = [(a, b) for a in moving + held for b in static if not _attached(m, a, b)]
    if self_collision:
        explicit = {(min(int(a), int(b)), max(int(a), int(b))) for a, b in zip(m.pair_geom1, m.pair_geom2)}
        robot = moving + held
        for i, a in enumerate(moving):
            for b in robot[i + 1:]:
                pair = (min(a, b), max(a, b))
                if joints[a] != joints[b] and (pair in explicit or _mujoco_tests(m, a, b)):
                    out.append(pair)
    return np.array(out, dtype=int).reshape(-1, 2)


def _subtree(m: mujoco.MjModel, root: int | None) -> np.ndarray:
    """Boolean mask over bodies: ``root`` and the bodies below it (none without a root)."""
    inside = np.zeros(m.nbody, dtype=bool)
    if root is None:
        return inside
    inside[root] = True
    for b in range(1, m.nbody):  # MuJoCo numbers parents before children
        inside[b] |= inside[int(m.body_parentid[b])]
    return inside


def _levers(m: mujoco.MjModel, idx: np.ndarray, span: np.ndarray | None = None) -> np.ndarray:
    """(nq,) how far (m) any point of a collision geom can travel per unit of each qpos entry in ``idx``: 1 for a
    slide; for a hinge, a bound on the distance from its anchor to any point of a collision geom it turns, from the
    MJCF's offsets alone (triangle inequality: joint, body and geom positions, a slide's largest travel, the geom's
    bounding sphere), whatever the other joints' values. 0 elsewhere.

    A hinge turns what its own body's later joints carry (MuJoCo applies a body's joints in order, each in the frame the
    ones before it left): a slide after it on the same body swings round with it at its full travel, and a hinge after
    it whose anchor is off the body's origin moves that origin by up to twice the anchor's offset.
    A slide moves its body by qpos - qpos0 along its axis (MuJoCo's qpos0 is the joint's ``ref``), so its largest travel
    is the largest |qpos - qpos0| ``span`` gives it (per entry, over the path: the segments between samples lie between
    them); without ``span``, that of its range's ends (an unlimited one's |qpos0|)."""
    lever = np.zeros(m.nq)
    coll = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
    wanted = set(idx.tolist())

    def carried(i: int) -> float:  # how far joint i can move the origin of its body's frame (and what it carries)
        if int(m.jnt_type[i]) == 2:  # slide
            a, q0 = int(m.jnt_qposadr[i]), float(m.qpos0[int(m.jnt_qposadr[i])])
            if span is not None:
                return float(span[a])
            return max(abs(float(m.jnt_range[i][0]) - q0), abs(float(m.jnt_range[i][1]) - q0)) if m.jnt_limited[i] else abs(q0)
        return 2 * float(np.linalg.norm(m.jnt_pos[i]))  # a hinge (or ball) off the body's origin swings it round

    for j in range(m.njnt):
        k = int(m.jnt_qposadr[j])
        if k not in wanted or int(m.jnt_type[j]) not in (2, 3):  # slide, hinge
            continue
        if int(m.jnt_type[j]) == 2:
            lever[k] = 1.0
            continue
        top, reach = int(m.jnt_bodyid[j]), 0.0
        after = sum(carried(i) for i in range(j + 1, m.body_jntadr[top] + m.body_jntnum[top]))  # its body's later joints
        for g in coll:
            b, r = int(m.geom_bodyid[g]), float(np.linalg.norm(m.geom_pos[g]) + m.geom_rbound[g])
            while b > top:  # up to the hinge's body (MuJoCo numbers parents before children)
                r += float(np.linalg.norm(m.body_pos[b]))
                r += sum(carried(i) for i in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]))
                b = int(m.body_parentid[b])
            if b == top:
                reach = max(reach, r + after + float(np.linalg.norm(m.jnt_pos[j])))
        lever[k] = reach
    return lever


def _unprovable(m: mujoco.MjModel, idx: np.ndarray) -> str:
    """Why :func:`prove` cannot bound how far the geoms travel (a coordinate of a ball or free joint, which
    :func:`_levers` does not bound), or "" when it can."""
    for j in range(m.njnt):
        k, kind = int(m.jnt_qposadr[j]), int(m.jnt_type[j])
        width = {0: 7, 1: 4}.get(kind, 1)  # free, ball
        if kind not in (2, 3) and np.any((idx >= k) & (idx < k + width)):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint {j}"
            return f"{name} is a {'free' if kind == 0 else 'ball'} joint: only the samples are checked"
    return ""


def _densify(points: np.ndarray, extra: np.ndarray, step: float, what: str = "a path", lever: np.ndarray | None = None) -> np.ndarray:
    """Linear samples along a polyline of ``points`` (rows), consecutive ones at most ``step`` apart in
    both the Euclidean norm of ``points`` and the max norm of ``extra`` (the same polyline in other units), and,
    with ``lever`` (:func:`_levers`), in how far a point of a collision geom can travel (``|d extra| . lever``);
    ``what`` (e.g. "path 'optimal': waypoints") names it in the error when that takes too many samples."""
    if len(points) == 1:
        return extra.copy()
    with np.errstate(over="ignore", invalid="ignore"):  # a coordinate of 1e308 (a damaged file): its square overflows, the count below says so
        d_pts = np.linalg.norm(np.diff(points, axis=0), axis=1)
        d_ext = np.max(np.abs(np.diff(extra, axis=0)), axis=1)
        if lever is not None:
            d_ext = np.maximum(d_ext, np.abs(np.diff(extra, axis=0)) @ lever)
        counts_f = np.maximum(1.0, np.ceil(np.maximum(d_pts, d_ext) / step))
        total = counts_f.sum()
    if not total <= MAX_SAMPLES:  # --step 1e-12 asked numpy for 33.6 TiB (a MemoryError, exit 1); (nan: inf - inf)
        raise FoamError(f"{what}: its longest segment is {np.max(np.maximum(d_pts, d_ext)):.3g} long, {total:.3g} samples at "
                        f"--step {step:g} (at most {MAX_SAMPLES:,} on one path): use a larger step, or check those numbers")
    counts = counts_f.astype(int)
    seg = np.repeat(np.arange(len(counts)), counts)
    t = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / np.repeat(counts, counts)
    out = extra[seg] + (extra[seg + 1] - extra[seg]) * t[:, None]
    return np.vstack([out, extra[-1:]])


def _distance(m: mujoco.MjModel, d: mujoco.MjData, a: int, b: int, distmax: float) -> float:
    """``mj_geomDistance``, but at most minus a capsule's radius where its axis runs through a box: MuJoCo's capsule/box
    test reads a positive distance in some such poses (a link stuck through a 2 cm wall: +25 mm). Checked here on
    its own: an end of the axis inside the box, or MuJoCo's ray from one end along the axis meeting the box before
    the other end (the planner's guard is a slab test)."""
    v = mujoco.mj_geomDistance(m, d, a, b, distmax, None)
    kinds = (int(m.geom_type[a]), int(m.geom_type[b]))
    if sorted(kinds) != sorted((int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_BOX))):
        return v
    cap, box = (a, b) if kinds[0] == int(mujoco.mjtGeom.mjGEOM_CAPSULE) else (b, a)
    half, radius = float(m.geom_size[cap][1]), float(m.geom_size[cap][0])
    if v <= -radius:
        return v
    axis = d.geom_xmat[cap].reshape(3, 3)[:, 2].copy()
    start = d.geom_xpos[cap] - half * axis
    inside = np.all(np.abs((start - d.geom_xpos[box]) @ d.geom_xmat[box].reshape(3, 3)) <= m.geom_size[box])
    hit = mujoco.mju_rayGeom(d.geom_xpos[box], d.geom_xmat[box], m.geom_size[box], start, axis, mujoco.mjtGeom.mjGEOM_BOX)
    return -radius if inside or 0 <= hit <= 2 * half else v


class _Checker:
    """Distances of every (sample, pair), exact where it matters (see the module docstring)."""

    def __init__(self, m: mujoco.MjModel, pairs: np.ndarray, lever: np.ndarray | None = None, self_from: int | None = None) -> None:
        """``lever`` (:func:`_levers`): with it, exact distances at every :data:`ANCHOR`-th sample bound the others
        (:meth:`_anchored`); ``self_from``: the pairs from this index on are robot/robot pairs (both geoms move)."""
        self.m, self.d, self.pairs = m, mujoco.MjData(m), pairs
        self.rb = np.asarray(m.geom_rbound, dtype=float)
        plane = int(mujoco.mjtGeom.mjGEOM_PLANE)
        self.plane_a = np.asarray(m.geom_type)[pairs[:, 0]] == plane
        self.plane_b = np.asarray(m.geom_type)[pairs[:, 1]] == plane
        self.lever, self.self_from = lever, len(pairs) if self_from is None else self_from
        self.calls = 0

    def _poses(self, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m, d = self.m, self.d
        xpos = np.empty((len(qpos), m.ngeom, 3))
        xnormal = np.empty((len(qpos), m.ngeom, 3))
        for i, row in enumerate(qpos):
            d.qpos[:] = row
            mujoco.mj_kinematics(m, d)
            xpos[i] = d.geom_xpos
            xnormal[i] = d.geom_xmat.reshape(-1, 3, 3)[:, :, 2]
        return xpos, xnormal

    def _lower_bounds(self, xpos: np.ndarray, xnormal: np.ndarray) -> np.ndarray:
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        delta = xpos[:, b] - xpos[:, a]
        lb = np.linalg.norm(delta, axis=2) - self.rb[a] - self.rb[b]
        # A plane (rbound 0, infinite): signed distance of the other geom's centre, minus its sphere.
        pa = np.einsum("spk,spk->sp", xnormal[:, a], delta) - self.rb[b]
        pb = np.einsum("spk,spk->sp", xnormal[:, b], -delta) - self.rb[a]
        lb = np.where(self.plane_a, pa, lb)
        lb = np.where(self.plane_b, pb, lb)
        lb = np.where(self.plane_a & self.plane_b, -np.inf, lb)
        return lb

    def _exact(self, qpos: np.ndarray, cand: np.ndarray, distmax: float) -> np.ndarray:
        """mj_geomDistance at (sample, pair) indices ``cand`` (K, 2), grouped by sample."""
        m, d = self.m, self.d
        out = np.empty(len(cand))
        order = np.argsort(cand[:, 0], kind="stable")
        last = -1
        for k in order:
            s, p = int(cand[k, 0]), int(cand[k, 1])
            if s != last:
                d.qpos[:] = qpos[s]
                mujoco.mj_kinematics(m, d)
                last = s
            out[k] = _distance(m, d, int(self.pairs[p, 0]), int(self.pairs[p, 1]), distmax)
        self.calls += len(cand)
        return out

    def _anchored(self, qpos: np.ndarray, lb: np.ndarray, known: np.ndarray) -> None:
        """Raise the bounds ``lb`` (S, P) in place with exact distances at every :data:`ANCHOR`-th sample (and the
        last), marked in ``known``: no point moves further between samples s and a than the lever arms' travel summed
        over the rows between them, so a pair's distance at s is at least its distance at a minus that (twice that for
        a robot/robot pair), from the nearest anchor on either side. Far tighter than the spheres of long capsules:
        most pairs then need no other exact distance."""
        n = len(qpos)
        if self.lever is None or n <= 2 * ANCHOR:
            return
        anchors = np.unique(np.append(np.arange(0, n, ANCHOR), n - 1))
        grid = np.column_stack([np.repeat(anchors, len(self.pairs)), np.tile(np.arange(len(self.pairs)), len(anchors))])
        exact = self._exact(qpos, grid, np.inf).reshape(len(anchors), len(self.pairs))
        lb[anchors], known[anchors] = exact, True
        with np.errstate(invalid="ignore"):  # inf - inf: a coordinate of a damaged file; nan bounds nothing below
            cum = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(qpos, axis=0)) @ self.lever)])
            left = np.searchsorted(anchors, np.arange(n), side="right") - 1
            right = np.minimum(left + 1, len(anchors) - 1)
            rate = np.where(np.arange(len(self.pairs)) < self.self_from, 1.0, 2.0)
            block = max(1, _BLOCK // max(1, len(self.pairs)))
            for i in range(0, n, block):  # (a few (sample, pair) arrays at a time)
                at = slice(i, i + block)
                lip = np.fmax(exact[left[at]] - (cum[at] - cum[anchors[left[at]]])[:, None] * rate,
                              exact[right[at]] - (cum[anchors[right[at]]] - cum[at])[:, None] * rate)
                np.fmax(lb[at], lip, out=lb[at])

    def measure(self, qpos: np.ndarray, margin: float) -> Measured:
        """The samples' smallest distance, violations and closest pair (exact: see :mod:`foam_mj.verify`), and lower bounds
        of each sample's smallest distance over the moving/static pairs (before the checker's ``self_from``) and over
        the robot/robot ones (from it on): the exact distance where it was computed, a bound elsewhere (the sphere bound,
        raised from the anchors' exact distances by :meth:`_anchored`). A (sample, pair) left inexact has a bound of at
        least max(margin, the smallest distance found), so the minimum and the violations are exact."""
        lb = np.empty((len(qpos), len(self.pairs)))
        block = max(1, _BLOCK // max(1, len(self.pairs)))
        for i in range(0, len(qpos), block):
            lb[i:i + block] = self._lower_bounds(*self._poses(qpos[i:i + block]))
        known = np.zeros(lb.shape, dtype=bool)
        self._anchored(qpos, lb, known)
        probe = np.argsort(np.where(known, np.inf, lb).ravel())[:_PROBES]
        probe_idx = np.column_stack(np.unravel_index(probe, lb.shape))
        probe_idx = probe_idx[~known[probe_idx[:, 0], probe_idx[:, 1]]]
        if len(probe_idx):
            lb[probe_idx[:, 0], probe_idx[:, 1]] = self._exact(qpos, probe_idx, np.inf)
            known[probe_idx[:, 0], probe_idx[:, 1]] = True
        upper = float(np.min(lb[known])) if known.any() else np.inf
        threshold = max(margin, upper)
        cand = np.column_stack(np.nonzero((lb < threshold) & ~known))
        capped = np.zeros_like(known)  # values distmax cut short: not MuJoCo's distance (for _breach)
        if len(cand):
            # min(distance, distmax): still at least the sphere bound, and exact below the threshold
            lb[cand[:, 0], cand[:, 1]] = self._exact(qpos, cand, threshold + 1e-3)
            known[cand[:, 0], cand[:, 1]] = True
            capped[cand[:, 0], cand[:, 1]] = lb[cand[:, 0], cand[:, 1]] >= threshold + 1e-3
        del cand
        cut = self.self_from
        obs, own = lb[:, :cut].min(axis=1, initial=np.inf), lb[:, cut:].min(axis=1, initial=np.inf)
        if not known.any():
            return Measured(np.inf, 0, -1, obs, own)
        exact = np.where(known, lb, np.inf)
        s, k = np.unravel_index(int(np.argmin(exact)), exact.shape)
        violating, closest = int(np.sum(np.any(exact < margin, axis=1))), float(exact[s, k])
        del exact
        known &= ~capped  # (known no more: the values that are MuJoCo's own, for _breach)
        return Measured(closest, violating, int(k), obs, own, self._breach(qpos, lb, known, margin))

    def _breach(self, qpos: np.ndarray, lb: np.ndarray, exact: np.ndarray, margin: float) -> tuple | None:
        """A self-check of the lever arms: MuJoCo's own distances of a pair at neighbouring samples differ by at most
        the travel between them (twice for a robot/robot pair). (sample, pair, change, allowed) where they differ by more
        (the largest such excess, over the values ``exact`` says are MuJoCo's, uncapped by distmax, and at least the
        margin, so that the capsule/box guard's jump does not count), else None: the travel bound, hence the proof and the anchors, does not hold there."""
        if self.lever is None or len(qpos) < 2:
            return None
        travel = np.abs(np.diff(qpos, axis=0)) @ self.lever
        rate = np.where(np.arange(lb.shape[1]) < self.self_from, 1.0, 2.0)
        best, block = (0.0, -1, -1), max(1, _BLOCK // max(1, lb.shape[1]))
        for i in range(0, len(travel), block):  # (a few (sample, pair) arrays at a time)
            rows = slice(i, min(i + block, len(travel)) + 1)  # samples i .. i + block: the steps i .. i + block - 1
            sure = exact[rows] & (lb[rows] >= margin)
            with np.errstate(invalid="ignore"):
                excess = np.where(sure[:-1] & sure[1:], np.abs(np.diff(lb[rows], axis=0)) - travel[i:rows.stop - 1, None] * rate
                                  - BREACH_TOL, -np.inf)
            s, k = (int(v) for v in np.unravel_index(int(np.argmax(np.nan_to_num(excess, nan=-np.inf))), excess.shape))
            if excess[s, k] > best[0]:
                best = (float(excess[s, k]), i + int(s), int(k))
        _, s, k = best
        if s < 0:
            return None
        return s, k, float(abs(lb[s + 1, k] - lb[s, k])), float(travel[s] * rate[k])

    def check(self, qpos: np.ndarray, margin: float) -> tuple[float, int, int]:
        """(smallest distance, samples closer than margin, index of the closest pair) over the samples."""
        r = self.measure(qpos, margin)
        return r.min_distance, r.violations, r.pair


@dataclass(frozen=True)
class Measured:
    """What :meth:`_Checker.measure` found on a set of samples."""

    min_distance: float  # metres, over every sample and pair
    violations: int  # samples closer than the margin
    pair: int  # index of the closest pair (-1 without pairs)
    obstacle_bound: np.ndarray  # (S,) a lower bound of each sample's distance over the moving/static pairs
    self_bound: np.ndarray  # (S,) and over the robot/robot pairs (inf without them)
    breach: tuple | None = None  # (sample, pair, change, allowed) where distances outran the lever arms (_Checker._breach)


@dataclass(frozen=True)
class Proof:
    """A certificate of the clearance between a polyline's samples (:func:`prove`)."""

    clearance: float  # metres: no point of the polyline (not only its samples) comes closer; -inf when nothing proves it
    samples: int  # samples the bisection added
    violations: int  # added samples closer than the margin
    min_distance: float  # the smallest distance at an added sample (inf without any)
    unproved: int  # segments neither proved at the margin nor shown below it after PROOF_ROUNDS bisections


def _segment_bounds(obs: np.ndarray, own: np.ndarray, travel: np.ndarray) -> np.ndarray:
    """Lower bounds of the clearance anywhere on segments whose ends (columns 0 and 1) have lower bounds ``obs``
    (moving/static pairs) and ``own`` (robot/robot) and on which no point of a collision geom travels more than
    ``travel``: a distance to a still geom changes at most as fast as the point moves (a robot/robot one twice
    as fast), so on a segment it is at least (d_a + d_b - travel) / 2 (the Lipschitz argument of the bubbles of free space: Quinlan,
    "Real-Time Modification of Collision-Free Paths", PhD thesis, Stanford University, 1994)."""
    with np.errstate(invalid="ignore"):
        a = 0.5 * (obs[:, 0] + obs[:, 1] - travel)  # inf on a side without pairs
        b = 0.5 * (own[:, 0] + own[:, 1] - 2 * travel)
    return np.where(np.isnan(a) | np.isnan(b), -np.inf, np.minimum(a, b))  # (nan from inf - inf: nothing proved)


def prove(checker: _Checker, samples: np.ndarray, obstacle_bound: np.ndarray, self_bound: np.ndarray, margin: float,
          rounds: int = PROOF_ROUNDS) -> Proof:
    """Prove the clearance between consecutive ``samples`` (qpos rows of one polyline, linear between them), not
    only at them, from the samples' lower bounds (:class:`Measured`'s ``obstacle_bound`` and ``self_bound``): a segment
    whose bound (:func:`_segment_bounds`, travel from the checker's lever arms, :func:`_levers`) is
    below ``margin`` while both its ends are clear is cut in half, up to ``rounds`` times, until each piece is
    proved, or a new sample is found closer than the margin (a violation), or the samples added or the distance calls
    made reach the budget (:data:`PROOF_BUDGET`): a round's midpoints are measured in batches the calls left surely
    afford (one per pair and midpoint), and those left over stay unproved. A clearance touching the margin exactly
    stays unproved."""
    if len(samples) < 2:
        d = float(min(obstacle_bound.min(initial=np.inf), self_bound.min(initial=np.inf)))
        return Proof(d, 0, 0, np.inf, 0)
    qa, qb = samples[:-1], samples[1:]
    obs = np.column_stack([obstacle_bound[:-1], obstacle_bound[1:]])
    own = np.column_stack([self_bound[:-1], self_bound[1:]])
    travel = np.abs(qb - qa) @ checker.lever
    proved, added, bad, closest = np.inf, 0, 0, np.inf
    budget = min(MAX_SAMPLES, max(PROOF_BUDGET, 4 * len(samples)))
    calls0, width, spent = checker.calls, max(1, len(checker.pairs)), False
    for r in range(rounds + 1):
        bound = _segment_bounds(obs, own, travel)
        ends_clear = np.minimum(obs, own).min(axis=1) >= margin
        open_ = (bound < margin) & ends_clear
        if len(bound) > int(open_.sum()):
            proved = min(proved, float(bound[~open_].min()))
        if not open_.any() or r == rounds or spent or added + int(open_.sum()) > budget:
            break
        qa, qb, obs, own, travel = qa[open_], qb[open_], obs[open_], own[open_], travel[open_] / 2
        mid = (qa + qb) / 2
        found, n = [], 0
        while n < len(mid):  # in batches the calls left surely afford: a midpoint costs at most one call per pair
            afford = (budget - (checker.calls - calls0)) // width
            if afford <= 0:
                break
            found.append(checker.measure(mid[n:n + afford], margin + 2 * float(travel.max())))  # exact wherever a bound could fall short
            n = min(len(mid), n + afford)
        if n == 0:
            break
        spent = n < len(mid)  # the midpoints past n stay unmeasured, their segments whole and open
        added += n
        mo, mw = (np.concatenate([getattr(at, key) for at in found]) for key in ("obstacle_bound", "self_bound"))
        lowest = np.minimum(mo, mw)  # exact where below the margin
        bad += int(np.sum(lowest < margin))
        closest = min(closest, float(lowest.min()))
        qa, qb = np.vstack([qa[:n], mid[:n], qa[n:]]), np.vstack([mid[:n], qb[:n], qb[n:]])
        obs = np.vstack([np.column_stack([obs[:n, 0], mo]), np.column_stack([mo, obs[:n, 1]]), obs[n:]])
        own = np.vstack([np.column_stack([own[:n, 0], mw]), np.column_stack([mw, own[:n, 1]]), own[n:]])
        travel = np.concatenate([travel[:n], travel[:n], 2 * travel[n:]])
    unproved = int(open_.sum())
    if unproved:
        proved = min(proved, float(bound[open_].min()))
    return Proof(proved, added, bad, closest, unproved)


def _beyond_ranges(m: mujoco.MjModel, idx: np.ndarray, qpos: np.ndarray) -> tuple[int, str]:
    """(samples with a configuration joint beyond its MJCF range, a note on the furthest one): the planner's bounds
    are those ranges, so a path that leaves one is not a plan of this robot, however clear of obstacles."""
    jnt = {int(m.jnt_qposadr[j]): j for j in range(m.njnt) if m.jnt_limited[j] and int(m.jnt_type[j]) in (2, 3)}  # slide, hinge
    adr = np.array([k for k in idx.tolist() if k in jnt], dtype=int)
    if not len(adr):
        return 0, ""
    lo, hi = (np.array([m.jnt_range[jnt[k]][i] for k in adr]) for i in (0, 1))
    tol = HELD_TOL * (1 + np.maximum(np.abs(lo), np.abs(hi)))
    excess = np.maximum(lo - qpos[:, adr], qpos[:, adr] - hi)
    bad = np.any(excess > tol, axis=1)
    if not bad.any():
        return 0, ""
    s, c = np.unravel_index(np.argmax(excess), excess.shape)
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, jnt[int(adr[c])]) or f"joint {jnt[int(adr[c])]}"
    return int(bad.sum()), f"{name} reaches {qpos[s, adr[c]]:.6g} (range [{lo[c]:g}, {hi[c]:g}])"
