"""Certified bubbles of free space from workspace distance (Quinlan 1995; paper 003, section 3, Eq. 4).

The bound
---------
Move the robot along the straight segment from q to a in configuration space. No point of the robot
moves farther than

    D(q, a) <= sum_g rho_g ||a_g - q_g||_2                                           (paper 003, Eq. 4)

where the coordinates are split into groups g. For a hinge, rho is an upper bound, valid in every
configuration, on the distance from the joint's axis to any point of the collision geometry distal to
it: a point at distance rho from the axis moves at most rho |dtheta|. For a slide, rho is the metres
of travel per unit of q (the normalization scale). Slides on one body whose axes are mutually
orthogonal and that have equal scales form one group: together they translate the body by exactly
the Euclidean length of their displacement, so their group norm is the 2-norm (for a planar mobile
base this gives paper 003 Eq. 5's sqrt(dx^2 + dy^2) + r_robot |dtheta|). Every other coordinate is a
group of its own.

The distance from hinge j's axis to a point of a distal body depends on the joints between them, so
the value at the current configuration is not a bound. The triangle inequality along the chain gives
one that holds everywhere: for the hinges j = k_0, k_1, ..., k_m on the way from joint j to a geom,

    rho_j >= sum_i |P (anchor_{k_(i+1)} - anchor_{k_i})| + max_{p in geom} |P (p - anchor_{k_m})|

with P the projection orthogonal to j's axis when every axis on the chain is parallel to it (a planar
chain: rotations about parallel axes keep these projected lengths), and the identity otherwise (3-D
distances, always an upper bound). Distances between consecutive anchors are fixed, since anchor
k_(i+1) is rigidly attached to the body that joint k_i turns. The farthest point of a convex geom
from an axis or a point is a vertex of it (both distances are convex): box corners, capsule end
centres plus the radius, sphere centre plus radius, mesh vertices, and the bounding box's corners for
cylinders and ellipsoids.

The bubble
----------
If D(q, a) < d(q), the workspace clearance at q, the whole motion q -> a is collision-free; so is the
"diamond" {a : sum_g rho_g ||a_g - q_g|| <= d(q)} (paper 003 Eq. 4). By Cauchy-Schwarz,
sum_g rho_g ||x_g|| <= ||rho||_2 ||x||_2, so the ball of radius d(q) / ||rho||_2 about q lies in the
diamond: it is the largest ball that does (paper 003, section 3.1; ``../shared/notes/bubbles-math.md``).
With a safety margin delta >= 0 the radius is (d(q) - delta) / ||rho||_2, and every configuration in
the ball keeps at least delta of workspace clearance.

Design choice (not in the papers): the radius is also capped by the distance from q to the boundary
of the configuration bounds (the joint ranges), so that a bubble never holds a configuration the
joints cannot reach. For an exoskeleton a knee bent past its range is as unsafe as a collision. The
papers only drop candidate centres outside the bounds.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from foam_mj.clearance import Clearance
from foam_mj.model import RobotModel

_HINGE = int(mujoco.mjtJoint.mjJNT_HINGE)
_SLIDE = int(mujoco.mjtJoint.mjJNT_SLIDE)
_PARALLEL_TOL = 1e-9


@dataclass(frozen=True)
class DisplacementBound:
    """sum_g weights[g] * ||dq[groups[g]]||_2 bounds how far any robot point moves for a move dq (Eq. 4)."""

    groups: tuple[tuple[int, ...], ...]
    weights: np.ndarray  # (G,) metres per unit of q

    @property
    def ball_factor(self) -> float:
        """||rho||_2: the radius of the largest ball inside the diamond is d / ball_factor."""
        return float(np.sqrt(np.sum(self.weights**2)))

    def __call__(self, dq: np.ndarray) -> np.ndarray:
        """The bound D for moves dq of shape (n,) or (N, n)."""
        dq = np.asarray(dq, dtype=float)
        total = 0.0
        for w, g in zip(self.weights, self.groups):
            total = total + w * np.linalg.norm(dq[..., list(g)], axis=-1)
        return total

    @classmethod
    def from_model(cls, robot: RobotModel) -> "DisplacementBound":
        """Compute rho for every configuration coordinate from the compiled model's geometry."""
        m = robot.model
        d = mujoco.MjData(m)
        d.qpos[:] = m.qpos0
        mujoco.mj_kinematics(m, d)
        cfg = robot.config
        rho = np.zeros(cfg.dim)
        for i, j in enumerate(cfg.joint_ids):
            j = int(j)
            if int(m.jnt_type[j]) == _SLIDE:
                rho[i] = abs(cfg.scale[i])
            else:
                reach = max((_hinge_reach(m, d, j, int(g)) for g in robot.robot_geoms if _is_distal(m, j, int(g))), default=0.0)
                rho[i] = reach * abs(cfg.scale[i])
        groups = _slide_groups(m, d, robot)
        weights = np.array([rho[list(g)].max() for g in groups])
        return cls(tuple(groups), weights)


def _joint_body(m: mujoco.MjModel, j: int) -> int:
    return int(m.jnt_bodyid[j])


def _ancestors(m: mujoco.MjModel, body: int) -> list[int]:
    """Bodies from ``body`` up to (not including) the world, nearest first."""
    out = []
    while body != 0:
        out.append(body)
        body = int(m.body_parentid[body])
    return out


def _is_distal(m: mujoco.MjModel, j: int, g: int) -> bool:
    """True when joint j moves geom g."""
    return _joint_body(m, j) in _ancestors(m, int(m.geom_bodyid[g]))


def _chain_joints(m: mujoco.MjModel, j: int, g: int) -> list[int]:
    """Joints from j (inclusive) down to geom g's body, in kinematic order."""
    bodies = list(reversed(_ancestors(m, int(m.geom_bodyid[g]))))
    start = bodies.index(_joint_body(m, j))
    joints = []
    for b in bodies[start:]:
        adr, num = int(m.body_jntadr[b]), int(m.body_jntnum[b])
        joints.extend(range(adr, adr + num))
    return joints[joints.index(j) :]


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
        raise ValueError(f"geom '{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)}': type {t} cannot be a robot geom")
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    return pos + (signs * half) @ mat.T, 0.0


def _hinge_reach(m: mujoco.MjModel, d: mujoco.MjData, j: int, g: int) -> float:
    """Upper bound, valid in every configuration, of the distance from hinge j's axis to geom g."""
    axis = d.xaxis[j] / np.linalg.norm(d.xaxis[j])
    chain = _chain_joints(m, j, g)
    hinges = [k for k in chain if int(m.jnt_type[k]) == _HINGE]
    planar = all(np.linalg.norm(np.cross(d.xaxis[k] / np.linalg.norm(d.xaxis[k]), axis)) < _PARALLEL_TOL for k in hinges)

    def length(v: np.ndarray) -> np.ndarray:
        if planar:
            v = v - np.outer(v @ axis, axis) if v.ndim == 2 else v - (v @ axis) * axis
        return np.linalg.norm(v, axis=-1)

    total = 0.0
    for a, b in zip(hinges[:-1], hinges[1:]):
        total += float(length(d.xanchor[b] - d.xanchor[a]))
    # Slides between j and the geom move it by at most their largest travel.
    for k in chain:
        if int(m.jnt_type[k]) == _SLIDE:
            lo, hi = m.jnt_range[k] if m.jnt_limited[k] else (-np.inf, np.inf)
            total += float(max(abs(lo), abs(hi)))
    points, radius = _geom_extreme_points(m, d, g)
    return total + float(np.max(length(points - d.xanchor[hinges[-1]]))) + radius


def _slide_groups(m: mujoco.MjModel, d: mujoco.MjData, robot: RobotModel) -> list[tuple[int, ...]]:
    """Group slides on one body with mutually orthogonal axes and equal scales; others stand alone."""
    cfg = robot.config
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
                    and np.isclose(abs(cfg.scale[grp[0]]), abs(cfg.scale[i]))
                    and all(abs(np.dot(d.xaxis[int(cfg.joint_ids[x])], d.xaxis[j])) < _PARALLEL_TOL for x in grp)
                ):
                    grp.append(i)
                    placed = True
                    break
        if not placed:
            groups.append([i])
    return [tuple(g) for g in groups]


class BubbleOracle:
    """Certified bubble radius r(q) = min((d(q) - delta) / ||rho||_2, distance to the bounds), clipped at 0.

    ``delta`` is the safety margin in metres: every configuration inside a bubble keeps at least delta
    of workspace clearance. ``distmax`` caps the clearance MuJoCo reports (and so the radius).
    """

    def __init__(self, robot: RobotModel, delta: float = 0.005, distmax: float = 1.0) -> None:
        if not (np.isfinite(delta) and delta >= 0):
            raise ValueError(f"`delta` (safety margin, metres) must be >= 0, got {delta}")
        self.robot = robot
        self.delta = float(delta)
        self.clearance = Clearance(robot, distmax=distmax)
        self.bound = DisplacementBound.from_model(robot)
        self._factor = self.bound.ball_factor

    def radius_from_clearance(self, clearance: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Radii for clearances and centres (any matching leading shape)."""
        q = np.asarray(q, dtype=float)
        to_bounds = np.minimum(q - self.robot.lower, self.robot.upper - q).min(axis=-1)
        r = np.minimum((np.asarray(clearance) - self.delta) / self._factor, to_bounds)
        return np.maximum(r, 0.0)

    def radius(self, q) -> float:
        """Certified radius at one configuration (validated: shape, finite, within bounds)."""
        q = self.robot.validate(q)
        return float(self.radius_from_clearance(self.clearance(q), q))

    def radii(self, Q: np.ndarray) -> np.ndarray:
        """Certified radii for every row of Q (N, n), evaluated in one batch. Rows are not bounds-checked:
        a row outside the bounds gets radius 0."""
        Q = self.robot.validate_batch(Q)
        return self.radius_from_clearance(self.clearance.batch(Q), Q)

    def close(self) -> None:
        self.clearance.close()
