"""Loading MJCF: files and specs compiled with MuJoCo's errors turned into a :class:`~foam_mj.errors.ModelError`
naming the file, unnamed geoms named, the ``<custom>`` text and numeric fields foam-mj reads, and mocap bodies
placed at a keyframe's pose (:func:`place_mocap_bodies`).

Unnamed geoms get the name ``geom<i>`` (``i`` their index in the model) when the model is loaded, so
that the distance sensors of :mod:`foam_mj.clearance` can refer to them; an existing name is never changed.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from foam_mj.errors import ModelError, file_problem_text
from foam_mj.mujoco_warnings import install_if_routed, kept_unless_failed


def load_mjcf(path: str | Path) -> mujoco.MjModel:
    """Compile an MJCF file, turning MuJoCo's errors into a :class:`ModelError` naming the file."""
    return compile_spec(load_spec(path), path)


def load_spec(path: str | Path) -> mujoco.MjSpec:
    """Parse an MJCF file into a :class:`mujoco.MjSpec` (errors as :class:`ModelError` naming the file)."""
    p = Path(path)
    problem = file_problem_text(p, "MJCF file")
    if problem:
        raise ModelError(problem)
    try:  # MuJoCo calls a file it may not read "empty file"
        with open(p, "rb"):
            pass
    except OSError as exc:
        raise ModelError(f"MJCF file {p}: cannot read: {exc.strerror or exc}") from None
    install_if_routed()
    try:
        with kept_unless_failed():
            return mujoco.MjSpec.from_file(str(p))
    except ValueError as exc:  # MuJoCo reports XML and compile errors as ValueError
        raise ModelError(f"could not load MJCF file {p}: {' '.join(str(exc).split())}") from None


def compile_spec(spec: mujoco.MjSpec, path: str | Path) -> mujoco.MjModel:
    """Compile a spec, turning MuJoCo's errors into a :class:`ModelError` naming ``path``."""
    try:
        with kept_unless_failed():
            return spec.compile()
    except ValueError as exc:
        raise ModelError(f"could not load MJCF file {path}: {exc}") from None


def name_unnamed_geoms(spec: mujoco.MjSpec) -> int:
    """Give every unnamed geom of ``spec`` the name ``geom<i>`` (i: its index in the compiled model).

    MuJoCo's distance sensors refer to geoms by name; users' models often leave them unnamed. Returns
    how many geoms were named. A name already taken gets a ``_`` suffix until it is free.
    """
    geoms = list(spec.geoms)
    if all(g.name for g in geoms):
        return 0
    spec.compile()  # assigns the ids (g.id) the compiled model will use
    taken = {g.name for g in geoms if g.name}
    count = 0
    for g in geoms:
        if g.name:
            continue
        name = f"geom{int(g.id)}"
        while name in taken:
            name += "_"
        g.name = name
        taken.add(name)
        count += 1
    return count


def scene_xml(spec: mujoco.MjSpec, scene: Path) -> str:
    """The spec as one self-contained MJCF string (includes flattened; mesh and texture folders made absolute, from
    ``scene``'s folder, so the string loads from anywhere). Sets those folders in ``spec`` and compiles it."""
    base = Path(scene).resolve().parent
    for attr in ("meshdir", "texturedir"):
        d = getattr(spec, attr)
        setattr(spec, attr, str((base / d).resolve()) if d else str(base))
    spec.compile()
    return spec.to_xml()


def _attached(m: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> list[tuple[int, str]]:
    """(index, prefix) of each field that an ``<attach>``ed model brought in under a prefix and that stands for ``name``:
    MuJoCo prefixes every name of an attached model, its custom fields' too ('P' + 'foam_mj:configuration', and
    'P' + 'foam_mj:limits:j1' for the joint now named 'P' + 'j1'); in model order."""
    out = []
    for i in range(m.ntext if kind == mujoco.mjtObj.mjOBJ_TEXT else m.nnumeric):
        full = mujoco.mj_id2name(m, kind, i) or ""
        at = full.find("foam_mj:")
        if at <= 0:
            continue
        prefix, parts = full[:at], full[at:].split(":", 2)
        if ":".join(parts[:2] + [prefix + parts[2]] if len(parts) == 3 else parts) == name:
            out.append((i, prefix))
    return out


def _custom_text(m: mujoco.MjModel, name: str) -> str | None:
    """A text field's data; without one of that name, those of attached models (:func:`_attached`) joined, each word
    (a joint name) under its model's prefix, as MuJoCo named the joints: two attached arms declare both configurations."""
    i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TEXT, name)
    found = [(i, "")] if i >= 0 else _attached(m, mujoco.mjtObj.mjOBJ_TEXT, name)
    if not found:
        return None
    words = []
    for i, prefix in found:
        adr, size = int(m.text_adr[i]), int(m.text_size[i])
        words += [prefix + w for w in bytes(m.text_data[adr : adr + size]).rstrip(b"\x00").decode().split()]
    return " ".join(words)


def _custom_numeric(m: mujoco.MjModel, name: str) -> np.ndarray | None:
    """A numeric field's data; without one of that name, the first attached model's (:func:`_attached`)."""
    i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_NUMERIC, name)
    if i < 0:
        i = next((j for j, _ in _attached(m, mujoco.mjtObj.mjOBJ_NUMERIC, name)), -1)
    if i < 0:
        return None
    adr, size = int(m.numeric_adr[i]), int(m.numeric_size[i])
    return np.array(m.numeric_data[adr : adr + size])


def mocap_apart(m: mujoco.MjModel, k: int, held: int) -> list[str]:
    """The mocap bodies that keyframe ``k`` poses elsewhere than keyframe ``held`` (its ``mpos``, or its ``mquat`` up to
    sign), each as 'NAME at [x, y, z] (not [x, y, z])' (or 'turned to' its quaternion)."""
    out = []
    for b in np.flatnonzero(m.body_mocapid >= 0):
        i = int(m.body_mocapid[b])
        pos, pos0 = m.key_mpos[k, 3 * i : 3 * i + 3], m.key_mpos[held, 3 * i : 3 * i + 3]
        quat, quat0 = m.key_mquat[k, 4 * i : 4 * i + 4], m.key_mquat[held, 4 * i : 4 * i + 4]
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(b)) or f"body {b}"
        fmt = lambda v: "[" + ", ".join(f"{x:.6g}" for x in v) + "]"  # noqa: E731
        if np.abs(pos - pos0).max() > 1e-9:
            out.append(f"{name} at {fmt(pos)} (not {fmt(pos0)})")
        elif min(np.abs(quat - quat0).max(), np.abs(quat + quat0).max()) > 1e-9:
            out.append(f"{name} turned to {fmt(quat)} (not {fmt(quat0)})")
    return out


def check_no_flex(m: mujoco.MjModel, path: str | Path) -> None:
    """ModelError naming the flexes that can collide (contype or conaffinity non-zero): MuJoCo's distance queries, the
    planner's and every MuJoCo-only checker's, measure geoms, not flexes, so a plan would pass through one unseen."""
    flexes = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_FLEX, f) or f"flex{f}" for f in range(m.nflex)
              if m.flex_contype[f] or m.flex_conaffinity[f]]
    if flexes:
        raise ModelError(f"{path}: flex(es) {flexes} can collide (contype/conaffinity), but MuJoCo's distance queries (the "
                         "planner's) do not measure flexes, so a path could pass through one; model it with geoms (boxes, "
                         "capsules, a mesh), or set its contype and conaffinity to 0 if nothing should touch it")


def check_mesh_hulls(spec: mujoco.MjSpec, m: mujoco.MjModel, geoms, path: str | Path) -> None:
    """ModelError naming a checked mesh geom whose mesh sets ``maxhullvert`` below its convex hull's vertex count:
    MuJoCo then collides (and measures distances to) a hull of only that many vertices, and the mesh's other
    extreme points lie outside it, so a path certified by MuJoCo's distances could run through them (a 200-vertex
    unit sphere capped at 8: probes 2 % inside 192 of its vertices read up to 0.40 m apart). Without the cap the hull
    holds every vertex, conservative for the mesh itself. The test: every vertex of the mesh against the planes of the
    hull's faces (``mesh_graph``), oriented away from the hull's vertex centroid."""
    mesh_type = int(mujoco.mjtGeom.mjGEOM_MESH)
    used = {int(m.geom_dataid[g]): int(g) for g in geoms if int(m.geom_type[g]) == mesh_type}
    for i in sorted(used):
        if i >= len(spec.meshes) or spec.meshes[i].maxhullvert < 0 or m.mesh_graphadr[i] < 0:
            continue
        adr, nvert = int(m.mesh_graphadr[i]), int(m.mesh_vertnum[i])
        hv, hf = int(m.mesh_graph[adr]), int(m.mesh_graph[adr + 1])
        faces_at = adr + 2 + 2 * hv + hv + 3 * hf
        faces = m.mesh_graph[faces_at : faces_at + 3 * hf].reshape(hf, 3)
        verts = m.mesh_vert[int(m.mesh_vertadr[i]) : int(m.mesh_vertadr[i]) + nvert].astype(float)
        a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
        normal = np.cross(b - a, c - a)
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
        centre = verts[m.mesh_graph[adr + 2 + hv : adr + 2 + 2 * hv]].mean(axis=0)
        normal *= np.where(np.einsum("ij,ij->i", normal, a - centre) < 0, -1.0, 1.0)[:, None]
        out = ((verts @ normal.T) - np.einsum("ij,ij->i", normal, a)).max(axis=1)  # each vertex's height above the hull
        scale = float(np.abs(verts).max(initial=0.0))
        outside = out > 1e-9 * max(scale, 1.0)
        if outside.any():
            geom = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, used[i]) or f"geom{used[i]}"
            mesh = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_MESH, i) or f"mesh{i}"
            raise ModelError(f"{path}: collision geom '{geom}': its mesh '{mesh}' sets maxhullvert=\"{spec.meshes[i].maxhullvert}\", "
                             f"so MuJoCo collides a hull of {hv} vertices that leaves {int(outside.sum())} of its {nvert} vertices "
                             f"outside (up to {float(out.max()):.3g} m), where MuJoCo's distances (the planner's) do not see "
                             "them: remove maxhullvert (or split the mesh into convex parts)")


def place_mocap_bodies(spec: mujoco.MjSpec, m: mujoco.MjModel, key: int, path: Path) -> bool:
    """Move the mocap bodies of ``spec`` to keyframe ``key``'s ``mpos``/``mquat`` where they differ from the bodies' own
    pose; True when one moved. MuJoCo places mocap bodies at the keyframe's pose when it is loaded (``mjData.mocap_pos``),
    but distance queries of qpos alone (the planner's, ``foam-mj verify``'s, any MuJoCo-only checker's) see them at the
    model's pose: the scene planned on (and saved with a result) carries the keyframe's. The keyframe's pose is in the
    world frame, a body's in its ``<frame>``'s: the frame's pose is read by compiling the body at the identity."""
    moving = []
    for b in range(1, m.nbody):
        i = int(m.body_mocapid[b])
        if i < 0:
            continue
        pos, quat = np.array(m.key_mpos[key, 3 * i : 3 * i + 3]), np.array(m.key_mquat[key, 4 * i : 4 * i + 4])
        if np.allclose(pos, m.body_pos[b], rtol=0, atol=1e-12) and np.allclose(quat, m.body_quat[b], rtol=0, atol=1e-12):
            continue
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)
        if not name:
            raise ModelError(f"{path}: keyframe {key} moves mocap body {b}, which has no name: name it to plan with that keyframe")
        body = spec.body(name)
        body.pos, body.quat, body.alt.type = np.zeros(3), np.array([1.0, 0, 0, 0]), mujoco.mjtOrientation.mjORIENTATION_QUAT
        moving.append((b, body, pos, quat))
    if not moving:
        return False
    frames = spec.compile()  # each moving body at the identity of its frame: its world pose is the frame's
    for b, body, pos, quat in moving:
        inverse = np.zeros(4)
        mujoco.mju_negQuat(inverse, frames.body_quat[b])
        local_quat, local_pos = np.zeros(4), np.zeros(3)
        mujoco.mju_mulQuat(local_quat, inverse, quat)
        mujoco.mju_rotVecQuat(local_pos, pos - frames.body_pos[b], inverse)
        body.pos, body.quat = local_pos, local_quat
    return True


def uncompiled_twin(twin: mujoco.MjSpec, compiled: mujoco.MjSpec) -> mujoco.MjSpec:
    """``twin`` (a copy of ``compiled`` made before it was ever compiled) with the geom names ``compiled`` was given
    (:func:`name_unnamed_geoms`): the spec a model keeps for :meth:`foam_mj.model.RobotModel.spec_copy`. MuJoCo 4.0
    deletes an element from a spec that has been compiled (or from a copy of one) in 8-14 ms when the scene has meshes,
    against under 1 ms from one never compiled: the lean distance model (:mod:`foam_mj.clearance`) deletes every geom
    of no checked pair, 68 on MuJoCo Menagerie's Panda, and that was 1.7 s of each of the three such models a plan
    makes. Where the twin's geoms do not line up with the compiled spec's (a caller's spec edited between), the
    compiled spec's own copy is kept, as before."""
    geoms, named = list(twin.geoms), list(compiled.geoms)
    if len(geoms) != len(named) or any(a.name and a.name != b.name for a, b in zip(geoms, named)):
        return compiled.copy()
    for a, b in zip(geoms, named):
        if not a.name:
            a.name = b.name
    return twin
