"""Outlines of a MuJoCo model's geoms projected onto a plane, and the world (x, y) of a mobile base, for the strobe
and map figures (foam_mj.figures).

Geometry is MuJoCo's: every pose runs ``mj_kinematics`` and each geom is projected with its
``geom_xpos``/``geom_xmat`` (:func:`strobe_geometry`): boxes become rectangles (the convex hull of
their projected corners), capsules stadiums, spheres discs, cylinders/ellipsoids/meshes the hull of
their projected surface points, and a plane a line (the floor, at its height). No matplotlib here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from foam_mj.errors import FoamError
from foam_mj.model import RobotModel


@dataclass(frozen=True)
class Shape:
    """One geom projected onto a plane: ``outline`` is a convex polygon (counter-clockwise, not closed)
    in the plane's two coordinates (metres), or for a plane geom the two ends of a line.

    ``kind`` is MuJoCo's geom type ("box", "capsule", "sphere", "cylinder", "ellipsoid", "mesh",
    "plane"); ``role`` is "robot" or "obstacle" (:class:`~foam_mj.model.RobotModel`'s split); ``centre``
    the projected ``geom_xpos``; for capsules ``ends`` holds the projected segment and ``radius`` the
    capsule's radius.
    """

    name: str
    geom: int
    kind: str
    role: str
    outline: np.ndarray
    centre: np.ndarray
    rgba: tuple[float, float, float, float]
    ends: np.ndarray | None = None
    radius: float | None = None


_PLANES = {"xz": (0, 2), "xy": (0, 1), "yz": (1, 2)}
_GEOM_KIND = {
    int(mujoco.mjtGeom.mjGEOM_PLANE): "plane",
    int(mujoco.mjtGeom.mjGEOM_SPHERE): "sphere",
    int(mujoco.mjtGeom.mjGEOM_CAPSULE): "capsule",
    int(mujoco.mjtGeom.mjGEOM_ELLIPSOID): "ellipsoid",
    int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder",
    int(mujoco.mjtGeom.mjGEOM_BOX): "box",
    int(mujoco.mjtGeom.mjGEOM_MESH): "mesh",
}
_ARC = np.linspace(0.0, 2.0 * np.pi, 64, endpoint=False)


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull of 2-D points (the monotone chain of Andrew 1979), without repeated or
    collinear vertices."""
    p = np.unique(np.round(np.asarray(points, dtype=float), 12), axis=0)
    if len(p) <= 2:
        return p
    pts = sorted(map(tuple, p))

    def half(seq):
        out: list = []
        for q in seq:
            while len(out) >= 2 and (out[-1][0] - out[-2][0]) * (q[1] - out[-2][1]) - (out[-1][1] - out[-2][1]) * (q[0] - out[-2][0]) <= 1e-15:
                out.pop()
            out.append(q)
        return out

    lower, upper = half(pts), half(reversed(pts))
    return np.array(lower[:-1] + upper[:-1])


def _stadium(a: np.ndarray, b: np.ndarray, r: float, n: int = 24) -> np.ndarray:
    """The outline of the points within r of segment ab (a capsule's projection): two half circles
    joined by tangents, counter-clockwise; every vertex lies exactly r from the segment."""
    d = b - a
    if np.linalg.norm(d) < 1e-12:  # seen end-on: a disc
        return a + r * np.column_stack([np.cos(_ARC), np.sin(_ARC)])
    phi = np.arctan2(d[1], d[0])
    t = np.linspace(-np.pi / 2, np.pi / 2, n + 1)
    arc_b = b + r * np.column_stack([np.cos(phi + t), np.sin(phi + t)])
    arc_a = a + r * np.column_stack([np.cos(phi + np.pi + t), np.sin(phi + np.pi + t)])
    return np.vstack([arc_b, arc_a])


def _joint_axes(robot: RobotModel) -> tuple[list[int], list[int]]:
    """World axis (0 x, 1 y, 2 z; -1 oblique) of every configuration slide and hinge at qpos0."""
    m = robot.model
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    slides: list[int] = []
    hinges: list[int] = []
    for j in robot.config.joint_ids:
        axis = np.abs(np.asarray(d.xaxis[j]))
        (slides if int(m.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_SLIDE) else hinges).append(
            int(np.argmax(axis)) if axis.max() > 0.99 else -1)
    return slides, hinges


def robot_kind(robot: RobotModel) -> str:
    """"planar_base" when every configuration joint moves the robot in the floor plane (slides along world
    x or y, hinges about z: the walker, a SCARA arm), "sagittal" otherwise (a leg whose hinges turn about y
    and which moves in the x-z plane; any arm with a hinge off the vertical, drawn from the side)."""
    slides, hinges = _joint_axes(robot)
    if all(a in (0, 1) for a in slides) and all(a == 2 for a in hinges):
        return "planar_base"
    return "sagittal"


def has_xy_base(robot: RobotModel) -> bool:
    """A mobile base: configuration slides along world x and y (the map draws its bubbles' (x, y) footprint)."""
    slides, _ = _joint_axes(robot)
    return robot_kind(robot) == "planar_base" and 0 in slides and 1 in slides


def _default_plane(robot: RobotModel) -> str:
    return "xy" if robot_kind(robot) == "planar_base" else "xz"


def _project_geom(m: mujoco.MjModel, d: mujoco.MjData, g: int, axes: tuple[int, int], role: str) -> Shape | None:
    kind = _GEOM_KIND.get(int(m.geom_type[g]))
    if kind is None:  # height fields, SDFs: not drawn
        return None
    pos = np.array(d.geom_xpos[g])
    R = np.array(d.geom_xmat[g]).reshape(3, 3)  # columns: the geom's axes in the world frame
    size = np.array(m.geom_size[g])
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"
    red, green, blue, alpha = (float(v) for v in m.geom_rgba[g])
    rgba = (red, green, blue, alpha)
    i, k = axes
    centre = pos[[i, k]]
    ends = radius = None
    if kind == "plane":
        normal = R[:, 2]
        if abs(normal[i]) < 1e-9 and abs(normal[k]) < 1e-9:
            return None  # the plane of the drawing itself (the floor seen from above)
        direction = np.array([normal[k], -normal[i]])
        direction /= np.linalg.norm(direction)
        half = float(size[0]) if size[0] > 0 else 50.0
        outline = np.array([centre - half * direction, centre + half * direction])
        return Shape(name, g, kind, role, outline, centre, rgba)
    if kind == "box":
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
        pts3 = pos + (signs * size) @ R.T
    elif kind in ("capsule", "sphere"):
        r = float(size[0])
        half = float(size[1]) if kind == "capsule" else 0.0
        seg = np.array([pos - half * R[:, 2], pos + half * R[:, 2]])[:, [i, k]]
        outline = _stadium(seg[0], seg[1], r)
        if kind == "capsule":
            ends, radius = seg, r
        else:
            radius = r
        return Shape(name, g, kind, role, outline, centre, rgba, ends, radius)
    elif kind == "cylinder":
        r, half = float(size[0]), float(size[1])
        rim = r * (np.outer(np.cos(_ARC), R[:, 0]) + np.outer(np.sin(_ARC), R[:, 1]))
        pts3 = np.vstack([pos + half * R[:, 2] + rim, pos - half * R[:, 2] + rim])
    elif kind == "ellipsoid":
        u, v = np.meshgrid(_ARC, np.linspace(0.0, np.pi, 33))
        unit = np.column_stack([(np.sin(v) * np.cos(u)).ravel(), (np.sin(v) * np.sin(u)).ravel(), np.cos(v).ravel()])
        pts3 = pos + (unit * size) @ R.T
    else:  # mesh: its vertices are in the geom's frame
        mesh = int(m.geom_dataid[g])
        adr, n = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
        pts3 = pos + np.asarray(m.mesh_vert[adr : adr + n], dtype=float) @ R.T
    return Shape(name, g, kind, role, convex_hull(pts3[:, [i, k]]), centre, rgba, ends, radius)


def _shapes(robot: RobotModel, data: mujoco.MjData, qpos: np.ndarray, plane: str, which: str) -> list[Shape]:
    if plane not in _PLANES:
        raise FoamError(f"plane must be one of {sorted(_PLANES)}, got {plane!r}")
    if which not in ("all", "robot", "obstacles"):
        raise FoamError(f"which must be 'all', 'robot' or 'obstacles', got {which!r}")
    m = robot.model
    data.qpos[:] = qpos
    mujoco.mj_kinematics(m, data)
    geoms = []
    if which in ("all", "robot"):
        geoms += [(int(g), "robot") for g in robot.robot_geoms]
    if which in ("all", "obstacles"):
        geoms += [(int(g), "obstacle") for g in robot.obstacle_geoms]
    out = []
    for g, role in geoms:
        s = _project_geom(m, data, g, _PLANES[plane], role)
        if s is not None:
            out.append(s)
    return out


def strobe_geometry(robot: RobotModel, q: ArrayLike, plane: str | None = None, which: str = "all") -> list[Shape]:
    """The robot's and the obstacles' collision geoms at configuration ``q`` (planner coordinates),
    projected onto ``plane`` ("xz", "xy" or "yz"; default: "xz" for a leg, "xy" for a planar mobile
    base), as :class:`Shape` s. ``which`` selects "all", "robot" or "obstacles" geoms.

    Positions come from ``mj_kinematics`` (``geom_xpos``, ``geom_xmat``) on a private ``MjData``, so the
    drawn outline of, for example, a box is exactly the convex hull of its eight corners projected."""
    q = robot.validate(q, "q", check_bounds=False)
    data = mujoco.MjData(robot.model)
    return _shapes(robot, data, robot.config.to_qpos(q), plane or _default_plane(robot), which)


def _bounds(shapes: Iterable[Shape]) -> np.ndarray | None:
    pts = [s.outline for s in shapes if s.kind != "plane"]
    if not pts:
        return None
    p = np.vstack(pts)
    return np.array([p.min(axis=0), p.max(axis=0)])


def body_depth(m: mujoco.MjModel, b: int) -> int:
    """How many bodies lie between body ``b`` and the world (the world: 0)."""
    n = 0
    while b != 0:
        b = int(m.body_parentid[b])
        n += 1
    return n


def base_xy(robot: RobotModel) -> tuple[int, tuple[float, float]]:
    """The body whose (x, y) is the mobile base's position, and the (x, y) scales of q -> world."""
    m, cfg = robot.model, robot.config
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    body, sx, sy = 0, 1.0, 1.0
    for j, s in zip(cfg.joint_ids, cfg.scale):
        body = max(body, int(m.jnt_bodyid[j]), key=lambda b: body_depth(m, b))
        if int(m.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_SLIDE):
            axis = np.abs(np.asarray(d.xaxis[j]))
            if axis[0] > 0.99:
                sx = abs(float(s))
            elif axis[1] > 0.99:
                sy = abs(float(s))
    return body, (sx, sy)


def xy_of(robot: RobotModel, body: int, qpos_rows: np.ndarray) -> np.ndarray:
    """(T, 2) the world (x, y) of ``body`` at each row of ``qpos_rows`` (``mj_kinematics``)."""
    d = mujoco.MjData(robot.model)
    out = np.empty((len(qpos_rows), 2))
    for i, row in enumerate(qpos_rows):
        d.qpos[:] = row
        mujoco.mj_kinematics(robot.model, d)
        out[i] = d.xpos[body][:2]
    return out
