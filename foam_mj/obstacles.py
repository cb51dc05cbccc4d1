"""Scenario obstacles applied through :class:`mujoco.MjSpec`: a parametric box, and obstacles from mesh files.

Meshes and convexity
--------------------
MuJoCo's collision and distance queries treat every mesh geom as its convex hull. A non-convex
obstacle (a U-shaped step, a stair) loaded as one mesh geom would have its notches filled in, and the
bubbles would be sized against that filled-in hull: safe, but the leg could never enter a notch.
:func:`add_mesh_obstacle` therefore splits the mesh into convex parts by approximate convex
decomposition (CoACD: X. Wei et al., "Approximate Convex Decomposition for 3D Meshes with
Collision-Aware Concavity and Tree Search", ACM Transactions on Graphics 41(4), 2022) and adds one mesh
geom per part. Each part is the convex hull of a piece of the mesh, so the parts together cover the
whole mesh: a clearance measured against them is never larger than the true one. Where a hull bulges
past the mesh (within CoACD's concavity threshold) it adds material, which is conservative: a path
clear of the parts is clear of the mesh. ``decompose = false``
keeps one convex hull (the filled-in, most conservative obstacle).

``trimesh`` and ``coacd`` are imported only here, when a scenario has a mesh.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from foam_mj.errors import ModelError, ScenarioError

if TYPE_CHECKING:  # pragma: no cover
    from foam_mj.scene_edits import BoxObstacle, MeshObstacle

_BOX = mujoco.mjtGeom.mjGEOM_BOX


def _is_static(body: mujoco.MjsBody) -> bool:
    while body is not None and body.name != "world":
        if len(body.joints):
            return False
        body = body.parent
    return True


def resize_box(spec: mujoco.MjSpec, scene: Path, box: "BoxObstacle") -> None:
    """Resize, move and/or turn the scene's static box geom in place (:class:`~foam_mj.scene_edits.BoxObstacle`)."""
    boxes = [
        g for g in spec.geoms if g.type == _BOX and (g.contype or g.conaffinity) and _is_static(g.parent)
    ]
    if box.name is not None:
        chosen = [g for g in boxes if g.name == box.name]
        if not chosen:
            raise ScenarioError(
                f"[obstacle] name '{box.name}': no static collision box of that name in {scene.name} "
                f"(boxes: {[g.name or '(unnamed)' for g in boxes]})"
            )
    elif len(boxes) == 1:
        chosen = boxes
    elif not boxes:
        raise ScenarioError(f"[obstacle]: scene {scene.name} has no static collision box to resize")
    else:
        raise ScenarioError(
            f"[obstacle]: scene {scene.name} has {len(boxes)} static boxes {[g.name or '(unnamed)' for g in boxes]}; "
            "say which with name = \"...\""
        )
    g = chosen[0]
    _unfold_fromto(spec, g)
    old_half = np.asarray(g.size[:3], dtype=float)
    old_pos = np.asarray(g.pos, dtype=float)  # in its <frame>'s coordinates, if it sits in one
    half = old_half if box.size is None else np.asarray(box.size, dtype=float) / 2
    origin, R = _frame_pose(spec, g)
    old_rot = _world_rotation(spec, g)
    rot = old_rot
    if box.euler is not None:  # a world orientation, written in the frame's coordinates
        quat = _euler_quat(box.euler)
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, quat)
        rot = rot.reshape(3, 3)
        frame_quat, local_quat = np.zeros(4), np.zeros(4)
        mujoco.mju_mat2Quat(frame_quat, R.flatten())
        mujoco.mju_negQuat(frame_quat, frame_quat)
        mujoco.mju_mulQuat(local_quat, frame_quat, quat)
        g.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT  # the file's euler/axisangle/... no longer applies
        g.quat = local_quat
    if box.pos is not None:  # a world position, written in the frame's coordinates
        pos = R.T @ (np.asarray(box.pos, dtype=float) - origin)
    else:  # same centre in x and y, same lowest point (for a box turned about a horizontal axis too)
        # |R_zi|: the lowest point lies sum_i |R_zi| h_i below the centre
        pos = old_pos + R.T @ np.array([0.0, 0.0, np.abs(rot[2]) @ half - np.abs(old_rot[2]) @ old_half])
    g.size = half
    g.pos = pos


def _unfold_fromto(spec: mujoco.MjSpec, g) -> None:
    """Write a box given by ``fromto`` (MuJoCo derives its centre, orientation and half-length from the segment and
    refuses a ``pos`` beside it) as the same box by pos, quat and size, so that it can be moved and resized."""
    if np.isnan(g.fromto[0]):
        return
    name = g.name
    g.name = "foam_mj_resized_box"
    try:
        pos, rot, size = _world_pose(spec, g.name)
    finally:
        g.name = name
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rot.flatten())
    origin, R = _frame_pose(spec, g)
    frame_quat, local_quat = np.zeros(4), np.zeros(4)
    mujoco.mju_mat2Quat(frame_quat, R.flatten())
    mujoco.mju_negQuat(frame_quat, frame_quat)
    mujoco.mju_mulQuat(local_quat, frame_quat, quat)
    g.fromto = [np.nan, 0, 0, 0, 0, 0]
    g.pos, g.quat, g.size = R.T @ (pos - origin), local_quat, size


def _world_pose(spec: mujoco.MjSpec, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World position, rotation matrix and size of the geom ``name``, as MuJoCo resolves them (its orientation written
    as quat, euler, axisangle, xyaxes or zaxis in the compiler's angle unit; its body's and <frame>s' poses composed):
    read off a compiled copy at qpos0, where a static body stands."""
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)
    return np.array(d.geom_xpos[k]), np.array(d.geom_xmat[k]).reshape(3, 3), np.array(m.geom_size[k])


def _frame_pose(spec: mujoco.MjSpec, g) -> tuple[np.ndarray, np.ndarray]:
    """World position and rotation matrix of the coordinates in which geom ``g``'s pos and orientation are written:
    its <frame> (nested ones composed) in its static body (or <worldbody>), as MuJoCo resolves them (zero and identity
    for a geom of <worldbody> outside any frame): read off a compiled copy with a probe geom at that frame's origin."""
    if g.frame is None and g.parent.name == "world":
        return np.zeros(3), np.eye(3)
    probe = (g.frame if g.frame is not None else g.parent).add_geom()
    probe.name = "foam_mj_frame_probe"
    probe.type = mujoco.mjtGeom.mjGEOM_SPHERE
    probe.size = [1e-3, 0, 0]
    probe.contype = probe.conaffinity = 0
    try:
        origin, R, _ = _world_pose(spec, probe.name)
    finally:
        spec.delete(probe)
    return origin, R


def _world_rotation(spec: mujoco.MjSpec, g) -> np.ndarray:
    """The world rotation matrix of geom ``g`` (:func:`_world_pose`), found by a temporary name."""
    name = g.name
    g.name = "foam_mj_resized_box"
    try:
        return _world_pose(spec, g.name)[1]
    finally:
        g.name = name


def _euler_quat(euler_deg: tuple[float, float, float]) -> np.ndarray:
    """Quaternion (w, x, y, z) of extrinsic x-y-z rotations by ``euler_deg`` degrees (MuJoCo's eulerseq "xyz")."""
    q = np.array([1.0, 0.0, 0.0, 0.0])
    for axis, angle in zip(np.eye(3), np.radians(euler_deg)):
        r = np.zeros(4)
        mujoco.mju_axisAngle2Quat(r, axis, float(angle))
        out = np.zeros(4)
        mujoco.mju_mulQuat(out, r, q)  # extrinsic: each new rotation applied on the left
        q = out
    return q


def load_mesh(mesh: "MeshObstacle"):
    """The mesh file as a ``trimesh.Trimesh`` in the world frame (scale, then rotation, then position)."""
    import trimesh

    try:
        tm = trimesh.load(str(mesh.file), force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise ScenarioError(f"[[mesh]] file {mesh.file}: cannot read it as a mesh: {exc}") from None
    if not isinstance(tm, trimesh.Trimesh) or len(tm.faces) == 0:
        raise ScenarioError(f"[[mesh]] file {mesh.file}: no triangles in it")
    tm = tm.copy()
    tm.apply_scale(np.asarray(mesh.scale, dtype=float)) if np.ptp(mesh.scale) == 0 else tm.apply_transform(np.diag([*mesh.scale, 1.0]))
    T = np.eye(4)
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, _euler_quat(mesh.euler))
    T[:3, :3] = R.reshape(3, 3)
    T[:3, 3] = mesh.pos
    tm.apply_transform(T)
    return tm


def _convex_hull(points: np.ndarray, file: Path) -> tuple[np.ndarray, np.ndarray]:
    """The convex hull of ``points`` as (vertices, faces), every face wound outward (Qhull's facet normals)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(points)
    except QhullError:
        raise ScenarioError(
            f"[[mesh]] file {file}: its points lie in one plane (or on a line), so its convex hull has no volume; "
            "give the obstacle some thickness"
        ) from None
    index = np.full(len(points), -1)
    index[hull.vertices] = np.arange(len(hull.vertices))
    faces = hull.simplices.copy()
    a, b, c = (points[faces[:, i]] for i in range(3))
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), hull.equations[:, :3]) < 0
    faces[inward] = faces[inward][:, ::-1]
    return points[hull.vertices], index[faces]


def convex_parts(mesh: "MeshObstacle") -> list[tuple[np.ndarray, np.ndarray]]:
    """The world-frame mesh split into convex parts: a list of (vertices (V, 3), faces (F, 3)).

    With ``mesh.decompose`` false, one part: the convex hull. CoACD runs with the mesh's ``threshold``
    and a fixed seed (deterministic).
    """
    tm = load_mesh(mesh)
    if not mesh.decompose:
        return [_convex_hull(np.asarray(tm.vertices, dtype=float), mesh.file)]
    try:
        import coacd
    except ImportError:
        raise ScenarioError(
            f"[[mesh]] file {mesh.file}: convex decomposition needs coacd (pip install 'foam-mj[meshes]'), "
            "or set decompose = false to use the mesh's convex hull"
        ) from None
    if not tm.is_watertight:
        # CoACD first remeshes an open surface into tens of thousands of triangles, then searches them for
        # minutes (a box of 11 triangles, one face missing: 60,588 triangles, 373 s, silent)
        raise ScenarioError(
            f"[[mesh]] file {mesh.file}: the surface is not closed (some edges border only one triangle), which "
            "convex decomposition needs; close it, or set decompose = false to use its convex hull"
        )
    coacd.set_log_level("error")
    parts = coacd.run_coacd(coacd.Mesh(np.asarray(tm.vertices), np.asarray(tm.faces)), threshold=mesh.threshold, seed=0)
    return [(np.asarray(v, dtype=float), np.asarray(f, dtype=int)) for v, f in parts]


def add_mesh_obstacle(spec: mujoco.MjSpec, mesh: "MeshObstacle", name: str) -> int:
    """Add the mesh's convex parts to ``spec``'s worldbody as static collision geoms named ``<name>_<i>``
    (mesh assets ``<name>_part<i>``, vertices in world coordinates); returns the number of parts."""
    parts = convex_parts(mesh)
    existing = {g.name for g in spec.geoms} | {m.name for m in spec.meshes}
    if any(n.startswith(name + "_") for n in existing):
        raise ModelError(f"mesh obstacle name '{name}' clashes with a geom or mesh of the scene; give [[mesh]] a name")
    for i, (v, f) in enumerate(parts):
        asset = spec.add_mesh()
        asset.name = f"{name}_part{i}"
        asset.uservert = np.asarray(v, dtype=float).ravel().tolist()
        asset.userface = np.asarray(f, dtype=int).ravel().tolist()
        g = spec.worldbody.add_geom()
        g.name = f"{name}_{i}"
        g.type = mujoco.mjtGeom.mjGEOM_MESH
        g.meshname = asset.name
        g.contype, g.conaffinity, g.margin = 1, 1, 0.0
        g.rgba = [0.7, 0.55, 0.35, 1.0]
    return len(parts)
