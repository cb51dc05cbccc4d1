"""The Rerun shapes of MuJoCo geoms for :mod:`foam_mj.recording`, and :class:`MeshInstances`: every mesh geom of a
robot logged once and drawn once per path by instancing (every path held its own copy: a two-link arm
of two 16k-vertex meshes planned with ``--smoother all`` wrote 5.7 MB, 3.2 MB now)."""

from __future__ import annotations

import re
from typing import Any

import mujoco
import numpy as np
import rerun as rr


def seconds_ns(times) -> np.ndarray:
    """Times in seconds as whole nanoseconds, rounded: rerun's ``TimeColumn(duration=...)`` truncates a float array
    (2.05 s was stored as 2.049999999 s, 17 of 1,163 frames of the obstacle centre path), and rounds a scalar."""
    return np.round(np.asarray(times, dtype=float) * 1e9).astype("timedelta64[ns]")

#: Half-extent (metres) drawn for an infinite MuJoCo plane (size 0).
INFINITE_PLANE = 5.0
_PLANE_RGBA = (0.55, 0.6, 0.65, 1.0)


def _sanitize(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.\-]", "_", name) or "_"


def _rgba(rgba) -> np.ndarray:
    return (np.clip(np.asarray(rgba, dtype=float), 0.0, 1.0) * 255).round().astype(np.uint8)


def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo quaternions (w, x, y, z) -> Rerun's (x, y, z, w), any leading shape."""
    q = np.asarray(wxyz, dtype=float)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


#: MuJoCo's default geom rgba: a geom that keeps it and has a material is drawn in the material's colour.
_DEFAULT_GEOM_RGBA = (0.5, 0.5, 0.5, 1.0)


#: Geom groups from this one on are hidden in MuJoCo's viewer by default (Menagerie's collision geoms: group 3); they
#: are drawn with at most this opacity, so that the visual geoms they enclose show through.
HIDDEN_GROUP = 3
HIDDEN_ALPHA = 0.4


def geom_rgba(m: mujoco.MjModel, g: int) -> np.ndarray:
    """Geom g's colour as MuJoCo draws it: its own rgba, or its material's when it has one and its rgba is the default
    (Menagerie's meshes are coloured by materials only: every one of them was drawn grey); translucent (alpha at most
    :data:`HIDDEN_ALPHA`) in a group MuJoCo's viewer hides (a Panda's grey collision hulls hid its visual meshes)."""
    mat = int(m.geom_matid[g])
    rgba = np.array(m.mat_rgba[mat] if mat >= 0 and np.array_equal(m.geom_rgba[g], np.array(_DEFAULT_GEOM_RGBA, dtype=np.float32)) else m.geom_rgba[g])
    if m.geom_group[g] >= HIDDEN_GROUP:
        rgba[3] = min(rgba[3], HIDDEN_ALPHA)
    return rgba


def geom_archetype(m: mujoco.MjModel, g: int, rgba=None) -> Any | None:
    """The Rerun shape of geom g in its own frame (None for types not drawn: height fields, SDFs), in ``rgba``
    (default: :func:`geom_rgba`)."""
    t = int(m.geom_type[g])
    size = m.geom_size[g]
    color = [_rgba(geom_rgba(m, g) if rgba is None else rgba)]
    T = mujoco.mjtGeom
    if t == T.mjGEOM_PLANE:
        hx, hy = (s if s > 0 else INFINITE_PLANE for s in size[:2])
        return rr.Boxes3D(half_sizes=[[hx, hy, 0.0]], colors=[_rgba(_PLANE_RGBA)], fill_mode="solid")
    if t == T.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[size[:3]], colors=color, fill_mode="solid")
    if t == T.mjGEOM_SPHERE:
        return rr.Ellipsoids3D(half_sizes=[[size[0]] * 3], colors=color, fill_mode="solid")
    if t == T.mjGEOM_ELLIPSOID:
        return rr.Ellipsoids3D(half_sizes=[size[:3]], colors=color, fill_mode="solid")
    if t == T.mjGEOM_CAPSULE:  # MuJoCo's is centred on the origin; Rerun's runs from 0 to length along +z
        return rr.Capsules3D(lengths=[2 * size[1]], radii=[size[0]], translations=[[0.0, 0.0, -size[1]]], colors=color)
    if t == T.mjGEOM_CYLINDER:
        return rr.Cylinders3D(lengths=[2 * size[1]], radii=[size[0]], colors=color, fill_mode="solid")
    if t == T.mjGEOM_MESH:  # compiled mesh vertices are expressed in the geom's frame
        mid = int(m.geom_dataid[g])
        va, vn = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
        fa, fn = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
        return rr.Mesh3D(
            vertex_positions=m.mesh_vert[va : va + vn],
            triangle_indices=m.mesh_face[fa : fa + fn],
            albedo_factor=color[0],
        )
    return None


def _geom_name(m: mujoco.MjModel, g: int) -> str:
    return _sanitize(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}")


def _body_name(m: mujoco.MjModel, b: int) -> str:
    return _sanitize(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}")




def is_mesh(m: mujoco.MjModel, g: int) -> bool:
    return int(m.geom_type[g]) == mujoco.mjtGeom.mjGEOM_MESH


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products a b of quaternions (w, x, y, z), broadcast over leading axes."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vector v (3,) rotated by unit quaternions q (..., 4) (w, x, y, z)."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def geom_world_poses(m: mujoco.MjModel, g: int, xpos: np.ndarray, xquat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World poses (positions (T, 3), quaternions (T, 4) w, x, y, z) of geom g from its body's poses (T, 3), (T, 4)."""
    xquat = np.asarray(xquat, float)
    return np.asarray(xpos, float) + _rotate(xquat, m.geom_pos[g].astype(float)), _quat_mul(xquat, m.geom_quat[g].astype(float))


class MeshInstances:
    """The mesh geoms of the robots of a recording, each logged ONCE per group at ``world/meshes/<group>/<body>/<geom>``
    (static, as :func:`geom_archetype`: vertices in the geom's frame) and drawn once per robot of the group by Rerun's
    instancing (``InstancePoses3D``: one pose per robot, the geom's world pose). A group's robots share its colours: ``model``
    (the main path's robot, opaque), ``tinted`` (the other paths' robots, translucent), ``q_init``/``q_goal``. A group is
    either temporal (a pose row per time of the union of its robots' timelines, a robot past its last frame holding
    its last pose; the ``frame`` timeline counts those rows, the robots' own frames when they share one timestep) or
    static (one pose per robot)."""

    ROOT = "world/meshes"

    def __init__(self) -> None:
        self._entities: dict[str, dict] = {}

    def add(self, group: str, m: mujoco.MjModel, body_ids, xpos, xquat, times=None, alpha: float | None = None) -> None:
        """One robot of ``group``: body poses xpos (T, B, 3), xquat (T, B, 4) (MuJoCo's w, x, y, z) of ``body_ids``
        at ``times`` (T,), or (1, B, .) with ``times`` None for a static pose."""
        static = times is None
        for k, b in enumerate(body_ids):
            for g in np.flatnonzero(m.geom_bodyid == int(b)):
                if not is_mesh(m, int(g)):
                    continue
                entity = f"{self.ROOT}/{group}/{_body_name(m, int(b))}/{_geom_name(m, int(g))}"
                entry = self._entities.get(entity)
                if entry is None:
                    rgba = geom_rgba(m, int(g))
                    if alpha is not None:
                        rgba[3] = min(float(rgba[3]), alpha)
                    entry = self._entities[entity] = {"mesh": geom_archetype(m, int(g), rgba), "static": static, "poses": []}
                if entry["static"] != static:
                    raise ValueError(f"mesh group {group!r} mixes static and timed poses")
                pos, quat = geom_world_poses(m, int(g), xpos[:, k], xquat[:, k])
                entry["poses"].append((None if static else np.round(np.asarray(times, float), 9), pos, _xyzw(quat)))

    def __len__(self) -> int:
        return len(self._entities)

    def log(self, rec: rr.RecordingStream) -> None:
        """Log every mesh once and its instance poses to ``rec`` (a recording's last step)."""
        for entity, e in self._entities.items():
            rec.log(entity, e["mesh"], static=True)
            poses = e["poses"]
            if e["static"]:
                rec.log(entity, rr.InstancePoses3D(translations=[p[1][0] for p in poses], quaternions=[p[2][0] for p in poses]), static=True)
                continue
            U = np.unique(np.concatenate([p[0] for p in poses]))
            pos = np.empty((len(U), len(poses), 3))
            quat = np.empty((len(U), len(poses), 4))
            for i, (t, xyz, xyzw) in enumerate(poses):
                idx = np.clip(np.searchsorted(t, U, side="right") - 1, 0, len(t) - 1)
                pos[:, i], quat[:, i] = xyz[idx], xyzw[idx]
            rec.send_columns(
                entity,
                indexes=[rr.TimeColumn("time", duration=seconds_ns(U)), rr.TimeColumn("frame", sequence=np.arange(len(U)))],
                columns=rr.InstancePoses3D.columns(translations=pos.reshape(-1, 3), quaternions=quat.reshape(-1, 4)).partition([len(poses)] * len(U)),
            )
