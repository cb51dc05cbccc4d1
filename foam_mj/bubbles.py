"""Certified bubbles of free space from workspace distance (Quinlan 1995; Nascimento and Alsina 2021, section 3, Eq. 4).

The bound
---------
Move the robot along the straight segment from q to a in configuration space. No point of geom g
moves farther than

    D_g(q, a) <= sum_grp rho_(g,grp) ||a_grp - q_grp||_2                             (Nascimento and Alsina 2021, Eq. 4)

where the configuration coordinates are split into groups grp. For a hinge, rho is an upper bound,
valid in every configuration within the joint ranges, on the distance from the joint's axis to any
point of geom g (a point at distance rho from the axis moves at most rho |dtheta|); for a slide, rho is
the metres of travel per unit of q (the normalization scale). Slides on one body whose axes are
mutually orthogonal and that have equal scales form one group, provided no configuration hinge of that body
comes between them in its joint order: together they translate the body by exactly the Euclidean length of
their displacement, so their group norm is the 2-norm (for a planar mobile base this gives Nascimento and
Alsina 2021 Eq. 5's sqrt(dx^2 + dy^2) + r_robot |dtheta|). MuJoCo turns a slide's axis by every hinge before it
on its body, so a hinge between two slides can make their axes parallel (slide x, hinge z, slide y at 90 degrees:
both move along x, |dx| + |dy|, up to sqrt(2) times the 2-norm): such slides stay apart. Every other
coordinate is a group of its own. A joint that does not move g has rho_(g, j) = 0.

Derivation of the hinge bound for any serial chain. Only configuration joints move; every other
joint stays at its fixed value, so it is part of a rigid link. Evaluate the kinematics once at the
*reference pose*: every configuration joint at its ``qpos0`` (MuJoCo's ``ref``: the pose in which the
MJCF draws the bodies; MuJoCo rotates a hinge by qpos - qpos0 and translates a slide by
qpos - qpos0), the other joints at their fixed values. Let k = h_0, h_1, ..., h_m be the configuration
hinges from joint k down to geom g's body, in kinematic order (joints of one body in their MJCF order),
a_i their anchors, and S_i the configuration slides between h_i and h_(i+1) (S_m: those between h_m
and the geom), u_s a slide's unit axis and t_s = qpos_s - qpos0_s its travel from the reference pose.
In any configuration, for a point p of the geom,

    p - a_0 = sum_(i<m) R_i [ (a_(i+1) - a_i)^ref + sum_(s in S_i) t_s u_s^ref ] + R_m [ (p - a_m)^ref + sum_(s in S_m) t_s u_s^ref ]

with R_i the rotation accumulated from h_0 to h_i (upstream joints move a_0 and p together and drop
out; consecutive anchors are rigidly attached to the link between them; a slide translates everything
downstream by t_s along its axis, which only the hinges before it have turned). Rotations keep
lengths, so the triangle inequality gives

    dist(p, axis_k) <= |p - a_0| <= sum_i |(a_(i+1) - a_i)^ref| + sum_s T_s + max_p |(p - a_m)^ref|

where T_s = max(|lo_s - qpos0_s|, |hi_s - qpos0_s|) is the largest travel the slide's range allows,
measured from the reference pose (not max(|lo|, |hi|): a slide with ref = -0.5 and range [-1, 2]
carries its geom up to 2.5 m from where the model draws it). Tighter: dist(p, axis_k) = |P (p - a_0)| with
P the projection orthogonal to k's axis, and where the hinges h_0 .. h_i are all parallel to that axis, R_i
turns about it and commutes with P, so |P R_i v| = |P v|: the terms of segment i (its anchor step and a slide's
T_s |P u_s|) are taken after P; the segments after the first hinge not parallel to k stay whole (|P R_i v| <= |v|).
For a planar chain (every hinge parallel) every term is, the geom's farthest vertex too. A UR arm's wrist_2 sits
0.127 m from wrist_1 along wrist_1's axis: no lever for wrist_1 (the wrist_2 capsule's rho for wrist_1, 0.267 m
with that step whole, is 0.14). The farthest point of a convex geom from an axis or a
point is a vertex of it (both distances are convex): box corners, capsule end centres plus the
radius, sphere centre plus radius, mesh vertices, and the bounding box's corners for cylinders and
ellipsoids. The bound holds in every configuration within the ranges; a bubble never leaves the
ranges (below), so it holds along every segment inside a bubble.

The bubble
----------
For a pair p = (g1, g2) of geoms MuJoCo lets collide (``foam_mj.model``), the distance d_p changes by at
most D_(g1) + D_(g2), each taken over only the joints on the kinematic path between the two bodies
(joints above their lowest common ancestor move both rigidly and leave d_p unchanged; for an obstacle
pair the path is the robot geom's chain). Call rho_p the vector of these group weights. If
sum_grp rho_(p,grp) ||a_grp - q_grp|| < d_p(q) for every pair, the motion q -> a is collision-free; by
Cauchy-Schwarz, sum_grp rho_(p,grp) ||x_grp|| <= ||rho_p||_2 ||x||_2, so the ball of radius

    r(q) = min_p (d_p(q) - delta) / ||rho_p||_2

about q keeps at least delta of clearance on every pair (Nascimento and Alsina 2021 Eq. 4 applied per pair; with one
pair, or one rho for all pairs, it is the paper's (d(q) - delta) / ||rho||_2). A pair whose distance
no configuration joint can change has rho_p = 0 and drops out (``foam_mj.model`` leaves it out).
Against a plane that no coordinate moves, d_p changes only by the points' motion along the normal n;
a hinge about an axis parallel to n (or a slide perpendicular to n) whose upstream configuration
hinges all turn about axes parallel to n moves every point parallel to the plane in every
configuration, so its rho_p is 0 (a pan joint and the floor).

Design choice (not in the papers): the radius is also capped by the distance from q to the boundary
of the configuration bounds (the joint ranges), so that a bubble never holds a configuration the
joints cannot reach. For an exoskeleton a knee bent past its range is as unsafe as a collision. The
papers only drop candidate centres outside the bounds.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from foam_mj.clearance import Clearance
from foam_mj.configuration import HINGE
from foam_mj.errors import is_finite_number, is_number
from foam_mj.model import RobotModel

_SLIDE = int(mujoco.mjtJoint.mjJNT_SLIDE)
_PARALLEL_TOL = 1e-9


@dataclass(frozen=True)
class DisplacementBound:
    """sum_g weights[g] * ||dq[groups[g]]||_2 bounds how far any robot point moves for a move dq (Eq. 4).

    ``weights`` is the bound over every robot geom; ``per_geom[g]`` (ngeom, G) the bound of geom g alone
    (zero for a group that does not move it), ``rho[g]`` (ngeom, n) the same per coordinate.
    """

    groups: tuple[tuple[int, ...], ...]
    weights: np.ndarray  # (G,) metres per unit of q
    per_geom: np.ndarray | None = None  # (ngeom, G)
    rho: np.ndarray | None = None  # (ngeom, n)
    reach: float = 0.0  # metres: the farthest a robot point can be from a configuration hinge's axis (the robot's size)

    @property
    def ball_factor(self) -> float:
        """||rho||_2: the radius of the largest ball inside the diamond is d / ball_factor."""
        return float(np.sqrt(np.sum(self.weights**2)))

    def __call__(self, dq: np.ndarray) -> np.ndarray | float:
        """The bound D for moves dq of shape (n,) (a float) or (N, n) (an array)."""
        dq = np.asarray(dq, dtype=float)
        total = 0.0
        for w, g in zip(self.weights, self.groups):
            total = total + w * np.linalg.norm(dq[..., list(g)], axis=-1)
        return total

    def group_weights(self, rho: np.ndarray) -> np.ndarray:
        """Per-coordinate bounds (..., n) -> per-group weights (..., G) (the largest member of each group)."""
        return np.stack([rho[..., list(g)].max(axis=-1) for g in self.groups], axis=-1)

    @classmethod
    def from_model(cls, robot: RobotModel) -> "DisplacementBound":
        """Compute rho for every configuration coordinate and geom from the compiled model's geometry."""
        m = robot.model
        d = mujoco.MjData(m)
        cfg = robot.config
        d.qpos[:] = reference_qpos(robot)
        mujoco.mj_kinematics(m, d)
        travel = _slide_travel(robot)
        rho = np.zeros((m.ngeom, cfg.dim))
        geoms = np.unique(np.concatenate([np.asarray(robot.robot_geoms, dtype=int).ravel(), np.asarray(robot.pairs, dtype=int).ravel()]))
        for g in geoms:
            g = int(g)
            joints = _config_chain(m, cfg, g)  # configuration coordinates moving g, kinematic order
            for pos, i in enumerate(joints):
                j = int(cfg.joint_ids[i])
                if int(m.jnt_type[j]) == _SLIDE:
                    rho[g, i] = abs(cfg.scale[i])
                else:
                    rho[g, i] = _hinge_reach(m, d, cfg, joints[pos:], g, travel) * abs(cfg.scale[i])
        groups = _slide_groups(m, d, robot)
        tmp = cls(tuple(groups), np.zeros(len(groups)))
        per_geom = tmp.group_weights(rho)
        robot_geoms = np.asarray(robot.robot_geoms, dtype=int)
        weights = per_geom[robot_geoms].max(axis=0) if len(robot_geoms) else np.zeros(len(groups))
        hinge = np.array([int(m.jnt_type[int(j)]) == HINGE for j in cfg.joint_ids], dtype=bool)
        metres = rho[np.ix_(robot_geoms, np.flatnonzero(hinge))] / np.abs(cfg.scale[hinge])  # per radian, not per unit of q
        return cls(tuple(groups), weights, per_geom, rho, float(metres.max(initial=0.0)))


def reference_qpos(robot: RobotModel) -> np.ndarray:
    """The pose the bound is measured from: configuration joints at ``qpos0`` (their MJCF ``ref``), the
    other joints at their fixed values."""
    cfg = robot.config
    q = np.array(cfg.qpos0, dtype=float)
    q[cfg.qpos_index] = robot.model.qpos0[cfg.qpos_index]
    return q


def _slide_travel(robot: RobotModel) -> np.ndarray:
    """T_s per coordinate: the largest |qpos - qpos0| the range allows (zero for hinges)."""
    cfg, m = robot.config, robot.model
    lo = cfg.offset + cfg.scale * cfg.lower
    hi = cfg.offset + cfg.scale * cfg.upper
    q0 = m.qpos0[cfg.qpos_index]
    return np.maximum(np.abs(lo - q0), np.abs(hi - q0))


def _ancestors(m: mujoco.MjModel, body: int) -> list[int]:
    """Bodies from ``body`` up to (not including) the world, nearest first."""
    out = []
    while body != 0:
        out.append(body)
        body = int(m.body_parentid[body])
    return out


def _config_chain(m: mujoco.MjModel, cfg, g: int) -> list[int]:
    """Configuration coordinates (indices into q) whose joints move geom g, root first; joints of one
    body in their MJCF order (the order MuJoCo applies them)."""
    index = {int(j): i for i, j in enumerate(cfg.joint_ids)}
    out: list[int] = []
    for b in reversed(_ancestors(m, int(m.geom_bodyid[g]))):
        adr, num = int(m.body_jntadr[b]), int(m.body_jntnum[b])
        out.extend(index[j] for j in range(adr, adr + num) if j in index)
    return out


def _geom_extreme_points(m: mujoco.MjModel, d: mujoco.MjData, g: int) -> tuple[np.ndarray, float]:
    """Points (world frame) and a radius such that the geom lies in the union of balls about the points'
    convex hull: every point of the geom is within ``radius`` of the hull of ``points``."""
    t = int(m.geom_type[g])
    size = m.geom_size[g]
    pos, mat = d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3)
    gt = mujoco.mjtGeom
    if t == int(gt.mjGEOM_SPHERE):
        return pos[None, :], float(size[0])
    if t == int(gt.mjGEOM_CAPSULE):
        axis = mat[:, 2] * size[1]
        return np.stack([pos - axis, pos + axis]), float(size[0])
    if t == int(gt.mjGEOM_BOX):
        half = size[:3]
    elif t in (int(gt.mjGEOM_CYLINDER),):
        half = np.array([size[0], size[0], size[1]])
    elif t == int(gt.mjGEOM_ELLIPSOID):
        half = size[:3]
    elif t == int(gt.mjGEOM_MESH):
        mesh = int(m.geom_dataid[g])
        adr, num = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
        verts = m.mesh_vert[adr : adr + num]
        return pos + verts @ mat.T, 0.0
    else:
        raise ValueError(f"geom '{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)}': type {t} cannot be moved by a joint")
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    return pos + (signs * half) @ mat.T, 0.0


def _hinge_reach(m: mujoco.MjModel, d: mujoco.MjData, cfg, chain: list[int], g: int, travel: np.ndarray) -> float:
    """Upper bound, valid in every configuration within the ranges, of the distance from the axis of the
    hinge ``chain[0]`` to geom g; ``chain`` lists the configuration coordinates from it down to g (module
    docstring: the sum over anchors, slide travels from the reference pose, and the geom's farthest
    vertex; a segment turned only by hinges parallel to the axis measured in the plane normal to it). ``d``
    holds the reference pose."""
    jid = [int(cfg.joint_ids[i]) for i in chain]
    axis = d.xaxis[jid[0]] / np.linalg.norm(d.xaxis[jid[0]])

    def length(v: np.ndarray, flat: bool | np.bool_) -> np.ndarray:
        if flat:
            v = v - np.outer(v @ axis, axis) if v.ndim == 2 else v - (v @ axis) * axis
        return np.linalg.norm(v, axis=-1)

    total = 0.0
    flat: bool | np.bool_ = True  # every hinge so far (h_0 .. h_i) parallel to the axis: segment i is measured normal to it
    last = jid[0]  # h_i
    for i, j in zip(chain[1:], jid[1:]):
        if int(m.jnt_type[j]) == _SLIDE:
            total += float(travel[i]) * float(length(d.xaxis[j] / np.linalg.norm(d.xaxis[j]), flat))
        else:
            total += float(length(d.xanchor[j] - d.xanchor[last], flat))
            flat = flat and np.linalg.norm(np.cross(d.xaxis[j] / np.linalg.norm(d.xaxis[j]), axis)) < _PARALLEL_TOL
            last = j
    points, radius = _geom_extreme_points(m, d, g)
    return total + float(np.max(length(points - d.xanchor[last], flat))) + radius


def _slide_groups(m: mujoco.MjModel, d: mujoco.MjData, robot: RobotModel) -> list[tuple[int, ...]]:
    """Group slides on one body with mutually orthogonal axes and equal scales and no configuration hinge between
    them in the body's joint order (a hinge turns the axes of the slides after it); others stand alone."""
    cfg = robot.config
    config_hinges = {int(j) for j in cfg.joint_ids if int(m.jnt_type[int(j)]) == HINGE}

    def hinges_before(j: int) -> int:
        """Configuration hinges before joint j on its body (MuJoCo applies a body's joints in id order)."""
        return sum(1 for k in range(int(m.body_jntadr[m.jnt_bodyid[j]]), j) if k in config_hinges)

    groups: list[list[int]] = []
    for i, j in enumerate(cfg.joint_ids):
        j = int(j)
        placed = False
        if int(m.jnt_type[j]) == _SLIDE:
            for grp in groups:
                k = int(cfg.joint_ids[grp[0]])
                if (
                    int(m.jnt_type[k]) == _SLIDE
                    and m.jnt_bodyid[k] == m.jnt_bodyid[j]
                    and hinges_before(k) == hinges_before(j)
                    and np.isclose(abs(cfg.scale[grp[0]]), abs(cfg.scale[i]))
                    and all(abs(np.dot(d.xaxis[int(cfg.joint_ids[x])], d.xaxis[j])) < _PARALLEL_TOL for x in grp)
                ):
                    grp.append(i)
                    placed = True
                    break
        if not placed:
            groups.append([i])
    return [tuple(g) for g in groups]


def default_distmax(delta: float, reach: float = 0.0) -> float:
    """The cap of measured distances (metres) for a margin ``delta`` and a robot of size ``reach``
    (:attr:`DisplacementBound.reach`): 1 m; half the reach for a robot larger than 2 m, so that a robot drawn in
    kilometres plans as it does drawn in metres (a cap of 1 m held a 900 m arm's bubbles to 1 mrad, where its 0.9 m
    copy had bubbles of 0.1-0.5 rad); 2 delta for a margin above half that (a cap at or below delta would read every
    configuration as too close). The cap only saves MuJoCo work on far pairs: a smaller one gives smaller bubbles,
    never unsafe ones."""
    return max(1.0, 2.0 * float(delta), 0.5 * float(reach))


def distance_cap(robot: RobotModel, delta: float) -> float:
    """:func:`default_distmax` for ``robot``: the cap its oracle, scenario checks and replays measure with."""
    return default_distmax(delta, robot.displacement_bound.reach)


class BubbleOracle:
    """Certified bubble radius r(q) = min(min_p (d_p(q) - delta) / ||rho_p||_2, distance to the bounds), clipped
    at 0 (module docstring; one term per checked pair p of ``robot.pairs``).

    ``delta`` is the safety margin in metres: every configuration inside a bubble keeps at least delta
    of workspace clearance on every pair. ``distmax`` caps the distances MuJoCo reports (and so the
    radius; default :func:`default_distmax`). ``pair_factor[p]`` is ||rho_p||_2, ``pair_rho[p]`` rho_p per coordinate.

    One oracle serves any number of plans, also from several threads at once, and pickles (process pools, Ray).
    It measures the scene as ``robot`` was built: to change an obstacle, build a new RobotModel and oracle
    (:class:`~foam_mj.model.RobotModel`; an edit of ``robot.model`` is refused before any planning).
    """

    def __init__(self, robot: RobotModel, delta: float = 0.005, distmax: float | None = None) -> None:
        if not isinstance(robot, RobotModel):
            raise TypeError(f"BubbleOracle takes a foam_mj.model.RobotModel (RobotModel.from_xml(path)), got {type(robot).__name__}")
        robot.check_unchanged()
        bound = robot.displacement_bound
        distmax = default_distmax(delta, bound.reach) if distmax is None and is_number(delta) else distmax
        for name, value in (("delta", delta), ("distmax", distmax)):
            if not is_number(value):
                raise TypeError(f"`{name}` must be a number (metres), got {value!r}")
        assert distmax is not None  # (a number: checked above)
        if not (is_finite_number(delta) and delta >= 0):
            raise ValueError(f"`delta` (safety margin, metres) must be >= 0, got {delta}")
        if not distmax > delta:  # every distance would read distmax <= delta: "too close" wherever the robot is
            raise ValueError(f"`distmax` (the cap of every measured distance, metres) must be > delta = {delta}, got {distmax}")
        self.robot = robot
        self.delta = float(delta)
        self.clearance = Clearance(robot, distmax=distmax)
        self.bound = bound
        self.pair_rho = pair_rho(robot, self.bound)
        self.pair_factor = pair_factor(self.bound, self.pair_rho)
        # A pair no coordinate moves has factor 0 (the model leaves such pairs out); a tiny floor keeps
        # the division defined and the sign of (d_p - delta) decides.
        self._inv = 1.0 / np.maximum(self.pair_factor, 1e-12)
        self._factor = float(self.pair_factor.max())
        # radii_below's constants (two numpy calls of each of its calls): the least upper bound that caps no pair below
        # distmax, and the caps' per-pair slope.
        self._upper_max = self.clearance.distmax * self._inv.max()
        self._cap_slope = self.pair_factor * (1.0 + CAP_SLACK_REL)

    def radius_from_distances(self, distances: np.ndarray, q: np.ndarray, bounds: np.ndarray | None = None) -> np.ndarray:
        """Radii for per-pair distances (..., P) at centres q (..., n): the per-pair bound, the least of the P
        pair terms and the 2n distances to the bounds, written as the rows of one (P + 2n, ...) array and reduced
        over its first axis (numpy reduces a short last axis of many rows far slower than it takes element-wise
        minima along a long one: 9-13 us per call against 12-37 for 10-300 configurations of the 3-joint leg).
        ``bounds``, if given, must be :meth:`to_bounds` (q): the bounds' terms already reduced (the same least value),
        one row instead of 2n (every radius still passes here: the one place a test can scale them all)."""
        q = np.asarray(q, dtype=float)
        d = np.asarray(distances)
        P, n = d.shape[-1], q.shape[-1]
        column = (P,) + (1,) * (q.ndim - 1), (n,) + (1,) * (q.ndim - 1)
        dT, qT = d.T, q.T
        if bounds is not None:
            M = np.empty((P + 1,) + dT.shape[1:])
            np.subtract(dT, self.delta, out=M[:P])
            np.multiply(M[:P], self._inv.reshape(column[0]), out=M[:P])
            M[P] = np.asarray(bounds).T
            return np.maximum(np.minimum.reduce(M, axis=0), 0.0).T
        M = np.empty((P + 2 * n,) + dT.shape[1:])
        np.subtract(dT, self.delta, out=M[:P])
        np.multiply(M[:P], self._inv.reshape(column[0]), out=M[:P])
        np.subtract(qT, self.robot.lower.reshape(column[1]), out=M[P : P + n])
        np.subtract(self.robot.upper.reshape(column[1]), qT, out=M[P + n :])
        return np.maximum(np.minimum.reduce(M, axis=0), 0.0).T

    def to_bounds(self, q: np.ndarray) -> np.ndarray:
        """Distance of configurations q (..., n) to the joint box's nearest face (...,), the radius's bounds term:
        the 2n differences as the rows of one (2n, ...) array, reduced over its first axis (faster than a
        reduction over the short last axis, see :meth:`radius_from_distances`)."""
        q = np.asarray(q, dtype=float)
        n = q.shape[-1]
        column = (n,) + (1,) * (q.ndim - 1)
        qT = q.T
        W = np.empty((2 * n,) + qT.shape[1:])
        np.subtract(qT, self.robot.lower.reshape(column), out=W[:n])
        np.subtract(self.robot.upper.reshape(column), qT, out=W[n:])
        return np.minimum.reduce(W, axis=0).T

    def radius_from_clearance(self, clearance: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Radii from the overall clearance d(q) = min_p d_p(q) alone: (d - delta) / max_p ||rho_p||, the
        paper's single bound. Certified, but smaller than :meth:`radii`, which keeps every pair's own rho."""
        r = np.minimum((np.asarray(clearance) - self.delta) / self._factor, self.to_bounds(q))
        return np.maximum(r, 0.0)

    def pair_radii(self, distances: np.ndarray) -> np.ndarray:
        """The per-pair terms (d_p - delta) / ||rho_p|| of the radius (..., P), without the bounds' terms."""
        return (np.asarray(distances) - self.delta) * self._inv

    def holding_bubble(self, q: np.ndarray, want: float, distances: np.ndarray | None = None) -> "EndBubble":
        """A certified bubble that holds q, for an end point of a path (:class:`EndBubble`).

        The bubble centred at q has at most q's distance to the joint bounds (the radius's bounds term, module
        docstring): none at all for q on a bound (a knee straight at its limit), a sliver beside one. Where that
        term, not the clearance, makes q's own radius smaller than ``want``, the centre moves inside, off the
        near faces: c = q + sum_j (rho - d_j)^+ u_j (d_j the distance from q to face j, u_j its inward normal),
        so that the ball of radius rho about c lies in the box, and it holds q when |c - q| <= rho -- always
        for q near one face (q on it: the ball touches the face at q), never for q on an edge or a corner of
        the box (two faces at distance 0: no ball inside the box holds a corner). rho starts at the
        clearance's radius at q and halves (SHRINK steps, one batch of distance queries) until c's own
        certified radius reaches |c - q|.

        Where no such ball holds q (an edge or corner), the bubble is the clearance's ball about q itself, radius
        min_p (d_p(q) - delta) / ||rho_p||, which leaves the box (``within_bounds`` False). Design choice: that is
        sound for an *end* bubble of a chain whose other bubbles lie in the box. The bound of Eq. 4 holds for
        motions inside the joint ranges, and every point of a path through the chain is in the box: the end
        point, and waypoints in hatches, each of which lies in an in-box neighbour; a segment between two such
        points stays in the box (convex) and in the ball, where the bound certifies it. Two such balls must never
        be neighbours (their hatch may leave the box): :meth:`foam_mj.planners.base.PlanningProblem.endpoint_bubbles`
        keeps them apart. Returns q's own bubble where it needs no move, radius 0 where q has no clearance to
        spare. ``distances``: q's pair distances, when the caller has them (else one query)."""
        q = np.asarray(q, dtype=float)
        lo, hi = self.robot.lower, self.robot.upper
        D = self.clearance.batch_pairs(q[None]) if distances is None else np.asarray(distances, dtype=float)[None]
        own = float(self.radius_from_distances(D, q[None])[0])
        free = float(np.maximum(self.pair_radii(D[0]).min(), 0.0))  # the clearance's radius alone
        if own >= min(want, free) or free <= 0.0:
            return EndBubble(q, own, True)
        rho = free * 0.5 ** np.arange(SHRINK)[:, None]  # (S, 1)
        rho = np.minimum(rho, 0.5 * (hi - lo))
        C = q + np.maximum(rho - (q - lo), 0.0) - np.maximum(rho - (hi - q), 0.0)
        r = self.radii(C)
        holds = np.linalg.norm(C - q, axis=1) <= r  # the test by which a chain's end bubble is found to hold q
        if not holds.any():
            return EndBubble(q, free, False)
        k = int(np.argmax(np.where(holds, r, -1.0)))
        return EndBubble(C[k], float(r[k]), True)

    def radius(self, q: ArrayLike) -> float:
        """Certified radius at one configuration (validated: shape, finite, within bounds; the scene unedited)."""
        self.robot.check_unchanged()
        q = self.robot.validate(q)
        return float(self.radius_from_distances(self.clearance.pair_distances(q), q))

    def radii(self, Q: np.ndarray) -> np.ndarray:
        """Certified radii for every row of Q (N, n), evaluated in one batch. Rows are not bounds-checked:
        a row outside the bounds gets radius 0. The planners' inner loop: the scene is checked unedited
        (:meth:`~foam_mj.model.RobotModel.check_unchanged`) when a plan starts, not here."""
        Q = self.robot.validate_batch(Q)
        return self.radius_from_distances(self.clearance.batch_pairs(Q), Q)

    def radii_below(self, Q: np.ndarray, upper: np.ndarray, bounds: np.ndarray | None = None) -> np.ndarray:
        """Certified radii for every row of Q (N, n) whose radius is known to be at most ``upper`` (N,), measuring each
        pair only as far as it could set the radius: the same values as :meth:`radii` to the last bit wherever
        r <= upper, and never larger than them anywhere (so certified whatever ``upper`` is). Rows are not checked
        (the planners' inner loop, as :meth:`radius_from_distances`); ``bounds``, if given, must be :meth:`to_bounds` (Q)
        (a caller that has it saves recomputing it).

        Pair p's distance is capped at c_p = delta + (upper (1 + CAP_SLACK_REL) + CAP_SLACK / ||rho_p||) ||rho_p||
        (at most ``distmax``; :meth:`foam_mj.clearance.Clearance.batch_pairs`), which reads: where |d_p| < c_p the
        same bits as the full query; where d_p >= c_p the cap, whose term (c_p - delta) / ||rho_p|| > upper >= r
        cannot be the least; where d_p <= -c_p (a penetration) -c_p, a negative term as d_p's, so the radius is 0
        either way. The least term is therefore the full query's, and the bounds' terms are the same; and a capped
        distance is never more than a non-negative d_p (and negative for a negative one), so the radius is never
        more than the full one. The slack keeps a pair that sets the radius clear of its cap by more than
        rounding and MuJoCo's convergence tolerance (CAP_SLACK is ten times its default ``ccd_tolerance``).

        An upper bound comes from a bubble nearby: r is 1-Lipschitz, r(a) <= r(q) + |a - q|, since each pair's
        term (d_p - delta) / ||rho_p|| changes by at most ||a - q|| (Eq. 4 and Cauchy-Schwarz, module docstring;
        the cap min(d_p, distmax) keeps that), so do the distances to the bounds, and the least of such functions,
        clipped at 0, does too. A child at distance s from a bubble (c, r(c)) has radius at most r(c) + s; the
        cap stops MuJoCo's query on the pairs farther than that needs (a UR5e's mesh pairs: 20 -> 12-15 us a
        configuration in bubbletree's growth)."""
        # An upper bound above distmax / the least ||rho_p|| caps no pair below distmax (and inf x a factor 0 is NaN).
        upper = np.minimum(np.asarray(upper, dtype=float), self._upper_max)
        cap = self.delta + CAP_SLACK + upper[:, None] * self._cap_slope
        return self.radius_from_distances(self.clearance.batch_pairs(Q, cap), Q, bounds)

    def explain(self, q: ArrayLike) -> "BubbleReport":
        """Everything behind the radius at q: per-pair distances and bounds, the pair that sets the radius."""
        self.robot.check_unchanged()
        q = self.robot.validate(q)
        dist = self.clearance.pair_distances(q)
        terms = self.pair_radii(dist)
        k = int(np.argmin(terms))
        to_bounds = float(self.to_bounds(q))
        return BubbleReport(
            q=q,
            clearance=float(dist.min()),
            closest_pair=self.robot.pair_name(int(np.argmin(dist))),
            limiting_pair=self.robot.pair_name(k),
            rho=self.pair_rho[k].copy(),
            rho_norm=float(self.pair_factor[k]),
            radius=float(max(min(terms[k], to_bounds), 0.0)),
            to_bounds=to_bounds,
            pair_distances=dist,
            pair_radii=terms,
        )

    def close(self) -> None:
        self.clearance.close()


@dataclass(frozen=True)
class EndBubble:
    """A certified bubble that holds an end point of a path (:meth:`BubbleOracle.holding_bubble`); a ball that
    leaves the joint box when ``within_bounds`` is False (an end point on an edge or corner of the box)."""

    center: np.ndarray
    radius: float
    within_bounds: bool


#: :meth:`BubbleOracle.radii_below`: a pair's distance cap lies this far (relative, and metres) above the one that its
#: term reaches the radius's upper bound at.
CAP_SLACK_REL = 1e-6
CAP_SLACK = 1e-5

#: Radii tried for an end point's bubble moved off the joint bounds (:meth:`BubbleOracle.holding_bubble`): the
#: clearance's radius at q times 1, 1/2, ... 1/2^(SHRINK - 1).
SHRINK = 16


@dataclass(frozen=True)
class BubbleReport:
    """Why the bubble at q has its radius (:meth:`BubbleOracle.explain`)."""

    q: np.ndarray
    clearance: float  # min_p d_p(q), metres
    closest_pair: tuple[str, str]  # the pair at that distance
    limiting_pair: tuple[str, str]  # the pair whose (d_p - delta) / ||rho_p|| sets the radius
    rho: np.ndarray  # rho_p of the limiting pair, per coordinate (metres per unit of q)
    rho_norm: float  # ||rho_p||_2 over the groups
    radius: float
    to_bounds: float  # distance from q to the configuration bounds
    pair_distances: np.ndarray  # (P,)
    pair_radii: np.ndarray  # (P,) (d_p - delta) / ||rho_p||


def pair_rho(robot: RobotModel, bound: DisplacementBound) -> np.ndarray:
    """rho_p per coordinate for every checked pair (P, n): a coordinate that moves exactly one of the two
    geoms (a joint on the kinematic path between their bodies) contributes that geom's rho; one that moves
    both (above their common ancestor) or neither contributes nothing, nor one that cannot change the
    distance to a plane (``foam_mj.geom_pairs.pair_coordinates``; module docstring)."""
    a, b = robot.pairs[:, 0], robot.pairs[:, 1]
    ma, mb = robot.moves[a], robot.moves[b]
    assert bound.rho is not None  # (DisplacementBound.from_model sets it)
    return (bound.rho[a] * (ma & ~mb) + bound.rho[b] * (mb & ~ma)) * robot.pair_active


def pair_factor(bound: DisplacementBound, rho: np.ndarray) -> np.ndarray:
    """||rho_p||_2 for every checked pair (P,) from its :func:`pair_rho` rows: the factor of the pair's radius term
    (d_p - delta) / ||rho_p||_2 (module docstring)."""
    return np.sqrt(np.sum(bound.group_weights(rho) ** 2, axis=-1))
