"""Which geom pairs MuJoCo's collision detection tests (:func:`collision_pairs`), which are attached by design
(:func:`attached`), and which bodies a joint moves: the rules :mod:`foam_mj.model` picks its checked pairs by."""

from __future__ import annotations

import mujoco
import numpy as np


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
