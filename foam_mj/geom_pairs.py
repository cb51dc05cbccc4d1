"""Which geom pairs MuJoCo's collision detection tests (:func:`collision_pairs`), which are attached by design
(:func:`attached`), which bodies a joint moves, and which coordinates can change a pair's distance
(:func:`pair_coordinates`): the rules :mod:`foam_mj.model` picks its checked pairs by."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from foam_mj.configuration import HINGE

if TYPE_CHECKING:
    from foam_mj.configuration import ConfigurationMap


def body_is_moving(m: mujoco.MjModel, body: int) -> bool:
    """True when some joint moves ``body`` (the body or one of its ancestors has a joint)."""
    while body != 0:
        if m.body_jntnum[body] > 0:
            return True
        body = int(m.body_parentid[body])
    return False


def body_subtree(m: mujoco.MjModel, root: int) -> np.ndarray:
    """Boolean mask over bodies: ``root`` and every body below it."""
    inside = np.zeros(m.nbody, dtype=bool)
    inside[root] = True
    for b in range(1, m.nbody):  # MuJoCo numbers parents before children
        if inside[int(m.body_parentid[b])]:
            inside[b] = True
    return inside


def collision_pairs(m: mujoco.MjModel) -> list[tuple[int, int]]:
    """Every geom pair (a < b) MuJoCo's ``mj_collision`` would test, whatever the configuration.

    Explicit ``<contact><pair>`` elements always; other pairs when contype/conaffinity match
    ((contype_a & conaffinity_b) or (contype_b & conaffinity_a)), the geoms are on different weld bodies
    (bodies not welded together by the absence of joints), the weld bodies are not parent and child
    unless one is the world or ``mjDSBL_FILTERPARENT`` is set, the body pair is not in a
    ``<contact><exclude>``. ``tests/test_certificate.py`` checks this against mj_collision.
    """
    out = {(min(int(a), int(b)), max(int(a), int(b))) for a, b in zip(m.pair_geom1, m.pair_geom2)}
    filter_parent = not (int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT))
    excluded = np.array(sorted({int(s) for s in m.exclude_signature}), dtype=np.int64)
    ct, ca = np.asarray(m.geom_contype), np.asarray(m.geom_conaffinity)
    live = np.flatnonzero((ct != 0) | (ca != 0))
    body = np.asarray(m.geom_bodyid, dtype=np.int64)[live]
    weld = np.asarray(m.body_weldid)[body]
    parent_weld = np.asarray(m.body_weldid)[np.asarray(m.body_parentid)[weld]]
    # Geom a against every later geom b at once: a scene of many static obstacles has ngeom^2 / 2 pairs (a Python
    # loop over them took 1.3 s for 1,000 boxes), nearly all on the world body and dropped by the weld test.
    for i in range(len(live) - 1):
        b = slice(i + 1, None)
        ok = (((ct[live[i]] & ca[live[b]]) | (ct[live[b]] & ca[live[i]])) != 0) & (weld[b] != weld[i])
        if filter_parent:
            ok &= ~((weld[i] != 0) & (weld[b] != 0) & ((weld[i] == parent_weld[b]) | (weld[b] == parent_weld[i])))
        if excluded.size:
            ok &= ~np.isin((np.minimum(body[i], body[b]) << 16) + np.maximum(body[i], body[b]), excluded)
        out.update((int(live[i]), int(g)) for g in live[b][ok])
    return sorted(out)


def attached(m: mujoco.MjModel, a: int, b: int) -> bool:
    """Are geoms a and b on one weld body, or on weld bodies that are parent and child (neither the world;
    unless the model disables that filter)? They meet at their joint by design and MuJoCo never collides them."""
    wa, wb = int(m.body_weldid[m.geom_bodyid[a]]), int(m.body_weldid[m.geom_bodyid[b]])
    if wa == wb:
        return True
    filter_parent = not (int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT))
    weld, parent = m.body_weldid, m.body_parentid
    return bool(filter_parent and wa and wb and (wa == int(weld[parent[wb]]) or wb == int(weld[parent[wa]])))


def reference_data(m: mujoco.MjModel, config: "ConfigurationMap") -> mujoco.MjData:
    """MjData at the reference pose: the held joints where the configuration holds them, the coordinates at qpos0."""
    d = mujoco.MjData(m)
    d.qpos[:] = config.qpos0
    d.qpos[config.qpos_index] = m.qpos0[config.qpos_index]
    mujoco.mj_kinematics(m, d)
    return d


_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)


def pair_coordinates(m: mujoco.MjModel, config: "ConfigurationMap", moves: np.ndarray, a: int, b: int,
                     d: mujoco.MjData | None = None) -> np.ndarray:
    """(n,) bool: the coordinates that can change the distance between geoms a and b; ``d``: :func:`reference_data`
    (m, config), made here when not given (a caller asking for many pairs passes one: making an MjData for each took
    0.7 ms on a scene of 1,000 obstacles, 7,500 of them 5 s of building its RobotModel).

    A coordinate whose joint moves exactly one of the two geoms (it lies on the kinematic path between
    their bodies) can; one that moves both or neither cannot. Against a plane that no coordinate moves,
    the distance changes only with the motion along the plane's normal n, so a hinge whose axis is
    parallel to n or a slide perpendicular to it cannot change it either, provided every configuration
    hinge above it also turns about an axis parallel to n (so that this holds in every configuration):
    a vertical pan joint cannot bring a shoulder closer to the floor. Against a fixed sphere, capsule or cylinder,
    the hinges that turn the other geom about its axis of symmetry, root first, cannot either
    (:func:`_turned_about_own_axis`): a pan joint standing on its pedestal.
    """
    active = moves[a] ^ moves[b]
    for plane, other in ((a, b), (b, a)):
        if int(m.geom_type[plane]) != _PLANE or moves[plane].any():
            continue
        d = reference_data(m, config) if d is None else d
        normal = d.geom_xmat[plane].reshape(3, 3)[:, 2]
        order = sorted(np.flatnonzero(moves[other]), key=lambda i: int(config.joint_ids[i]))  # root first
        upstream_parallel = True
        for i in order:
            j = int(config.joint_ids[i])
            axis = d.xaxis[j] / np.linalg.norm(d.xaxis[j])
            hinge = int(m.jnt_type[j]) == HINGE
            parallel = np.linalg.norm(np.cross(axis, normal)) < 1e-9
            if upstream_parallel and ((hinge and parallel) or (not hinge and abs(axis @ normal) < 1e-9)):
                active[i] = False
            if hinge and not parallel:
                upstream_parallel = False
    for solid, other in ((a, b), (b, a)):
        if int(m.geom_type[solid]) in REVOLUTION and not moves[solid].any() and moves[other].any():
            d = reference_data(m, config) if d is None else d
            active &= ~_turned_about_own_axis(m, config, moves, solid, other, d)
    return active


_SPHERE = int(mujoco.mjtGeom.mjGEOM_SPHERE)
#: Solids of revolution about their local z axis (a sphere about any line through its centre).
REVOLUTION = (_SPHERE, int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_CYLINDER))


def _turned_about_own_axis(m: mujoco.MjModel, config: "ConfigurationMap", moves: np.ndarray, solid: int,
                           other: int, d: mujoco.MjData) -> np.ndarray:
    """(n,) bool: the configuration hinges that turn geom ``other`` about the symmetry axis of the fixed solid of
    revolution ``solid`` (a robot's pedestal cylinder under its pan joint; a sphere about any line through its
    centre), root first, as long as each one above does too: such a turn maps the solid onto itself, so it cannot
    change the pair's distance, in every configuration (a turn about the line leaves the line, and so the next such
    hinge's axis, where they were). ``d``: :func:`reference_data` (m, config)."""
    centre = d.geom_xpos[solid]
    z = d.geom_xmat[solid].reshape(3, 3)[:, 2]
    sphere = int(m.geom_type[solid]) == _SPHERE
    out = np.zeros(config.dim, dtype=bool)
    for i in sorted(np.flatnonzero(moves[other]), key=lambda i: int(config.joint_ids[i])):  # root first
        j = int(config.joint_ids[i])
        if int(m.jnt_type[j]) != HINGE:
            break
        axis = d.xaxis[j] / np.linalg.norm(d.xaxis[j])
        arm = d.xanchor[j] - centre
        tol = 1e-9 * (1.0 + float(np.linalg.norm(arm)) + float(m.geom_rbound[solid]))
        if np.linalg.norm(np.cross(axis, arm)) > tol or (not sphere and np.linalg.norm(np.cross(axis, z)) > 1e-9):
            break
        out[i] = True
    return out


def bodies_moved_by(m: mujoco.MjModel, config: "ConfigurationMap") -> np.ndarray:
    """(n, nbody) bool: configuration coordinate i moves body b (its joint's body is b or above it)."""
    moved = np.zeros((config.dim, m.nbody), dtype=bool)
    for i, j in enumerate(config.joint_ids):
        moved[i] = body_subtree(m, int(m.jnt_bodyid[int(j)]))
    return moved


def geom_moved_by(m: mujoco.MjModel, config: "ConfigurationMap") -> np.ndarray:
    """(ngeom, n) bool: configuration coordinate i moves geom g (its joint's body is g's body or above it)."""
    return bodies_moved_by(m, config)[:, m.geom_bodyid].T.copy()
