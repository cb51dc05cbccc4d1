"""Constraints of a model that a plan moving each configuration joint on its own would cross unawares: equalities
that couple a configuration joint to other motion, and tendon limits that bind within the joint ranges
(:class:`foam_mj.model.RobotModel` refuses both, naming them)."""

from __future__ import annotations

import os

import mujoco
import numpy as np

from foam_mj.configuration import ConfigurationMap, _joint_name
from foam_mj.geom_pairs import bodies_moved_by


def coupling_equalities(m: mujoco.MjModel, config: ConfigurationMap) -> dict[str, list[str]]:
    """The active equality constraints that tie a configuration joint to other motion, each name with the
    configuration joints it ties: a joint or tendon coupling whose value a configuration joint changes (a mimic joint),
    or a connect/weld/distance constraint between two bodies that the configuration joints move differently (a closed
    loop through a configuration joint). The planner moves each coordinate independently and holds every other joint
    at its pose, so its path would not be the motion MuJoCo, or the robot, makes. A loop that closes below every
    configuration joint (a gripper's linkage at the end of an arm) moves as one piece with the arm's links, and holds
    as it does at the held pose."""
    moved = bodies_moved_by(m, config)
    where = {int(j): i for i, j in enumerate(config.joint_ids)}
    eq = mujoco.mjtEq

    def apart(bodies: list[int]) -> np.ndarray:  # (n,) the coordinates that move these bodies relative to each other
        out = np.zeros(config.dim, dtype=bool)
        for b in bodies[1:]:
            out |= moved[:, b] != moved[:, bodies[0]]
        return out

    def tendon_changes(t: int) -> np.ndarray:  # (n,) the coordinates that can change tendon t's length
        wraps = range(int(m.tendon_adr[t]), int(m.tendon_adr[t]) + int(m.tendon_num[t]))
        out = apart(_spatial_bodies(m, t))
        for w in wraps:
            if int(m.wrap_type[w]) == int(mujoco.mjtWrap.mjWRAP_JOINT) and int(m.wrap_objid[w]) in where:
                out[where[int(m.wrap_objid[w])]] = True
        return out

    def body_of(kind: int, obj: int) -> int:
        return int(m.site_bodyid[obj]) if kind == int(mujoco.mjtObj.mjOBJ_SITE) else obj

    out = {}
    for e in range(m.neq):
        if not m.eq_active0[e]:
            continue
        kind, a, b = int(m.eq_type[e]), int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        tied = np.zeros(config.dim, dtype=bool)
        if kind == int(eq.mjEQ_JOINT):
            for j in (a, b):
                if j in where:
                    tied[where[j]] = True
        elif kind == int(eq.mjEQ_TENDON):
            tied = tendon_changes(a) | (tendon_changes(b) if b >= 0 else tied)
        elif kind in (int(eq.mjEQ_CONNECT), int(eq.mjEQ_WELD), int(eq.mjEQ_DISTANCE)):
            objtype = int(m.eq_objtype[e])
            tied = apart([body_of(objtype, a), body_of(objtype, b) if b >= 0 else 0])  # no second body: the world
        # flex constraints act on flex vertices, not on the configuration's joints
        if tied.any():
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or f"equality {e}"
            out[name] = [config.joint_names[i] for i in np.flatnonzero(tied)]
    return out


def describe_equality(m: mujoco.MjModel, key: str) -> str:
    """An equality constraint named as :func:`coupling_equalities` names it (its name, or "equality <id>" for an
    unnamed one, as most MuJoCo Menagerie welds and mimic joints are), quoted and followed by its kind and what it
    joins, so that an unnamed one can be found in the MJCF: "'equality 0' (a <weld> between mocap and Fixed_Jaw)"."""
    e = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, key)
    if e < 0 and key.startswith("equality ") and key[9:].isdigit():
        e = int(key[9:])
    if not 0 <= e < m.neq:
        return f"'{key}'"
    kind, a, b = int(m.eq_type[e]), int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
    eq = mujoco.mjtEq
    if kind in (int(eq.mjEQ_JOINT), int(eq.mjEQ_TENDON)):
        obj, tag = (mujoco.mjtObj.mjOBJ_JOINT, "joint") if kind == int(eq.mjEQ_JOINT) else (mujoco.mjtObj.mjOBJ_TENDON, "tendon")
        def name(i: int) -> str:
            return (_joint_name(m, i) if tag == "joint" else mujoco.mj_id2name(m, obj, i) or f"{tag} {i}")
        what = f"a <{tag}> coupling of {name(a)} to {name(b)}" if b >= 0 else f"a <{tag}> held at a fixed value: {name(a)}"
    elif kind in (int(eq.mjEQ_CONNECT), int(eq.mjEQ_WELD), int(eq.mjEQ_DISTANCE)):
        tag = {int(eq.mjEQ_CONNECT): "connect", int(eq.mjEQ_WELD): "weld", int(eq.mjEQ_DISTANCE): "distance"}[kind]
        obj = mujoco.mjtObj(int(m.eq_objtype[e]))
        def name(i: int) -> str:
            if i < 0 or (obj == mujoco.mjtObj.mjOBJ_BODY and i == 0):
                return "the world"
            return mujoco.mj_id2name(m, obj, i) or f"{'site' if obj == mujoco.mjtObj.mjOBJ_SITE else 'body'} {i}"
        what = f"a <{tag}> between {name(a)} and {name(b)}"
    else:
        return f"'{key}'"
    return f"'{key}' ({what})"


def coupling_refusal(m: mujoco.MjModel, path: str | os.PathLike, coupled: dict[str, list[str]], config: ConfigurationMap) -> str:
    """The one-line refusal of a configuration that equality constraints tie to other motion: each constraint with
    its kind and what it joins, and the configuration joints they tie (only those: a joint it does not touch is no
    reason to refuse, and naming every configuration joint sent users to the wrong one)."""
    tied = [n for n in config.joint_names if any(n in names for names in coupled.values())]
    many = len(coupled) > 1
    return (
        f"{path}: equality constraint{'s' * many} {', '.join(describe_equality(m, k) for k in coupled)} "
        f"tie{'s' * (not many)} configuration joint{'s' * (len(tied) > 1)} {', '.join(tied)} to other motion (a coupled or "
        "mimic joint, a closed loop), which the planner, moving each joint on its own, would not follow: deactivate "
        f"{('it', 'them')[many]} (active=\"false\") or plan over joints {('it does', 'they do')[many]} not touch (--joints)"
    )


def _spatial_bodies(m: mujoco.MjModel, t: int) -> list[int]:
    """The bodies of tendon t's sites and wrapping geoms (none for a fixed tendon)."""
    bodies = []
    for w in range(int(m.tendon_adr[t]), int(m.tendon_adr[t]) + int(m.tendon_num[t])):
        kind, obj = int(m.wrap_type[w]), int(m.wrap_objid[w])
        if kind == int(mujoco.mjtWrap.mjWRAP_SITE):
            bodies.append(int(m.site_bodyid[obj]))
        elif kind in (int(mujoco.mjtWrap.mjWRAP_SPHERE), int(mujoco.mjtWrap.mjWRAP_CYLINDER)):
            bodies.append(int(m.geom_bodyid[obj]))
    return bodies


def binding_tendon_limits(m: mujoco.MjModel, config: ConfigurationMap) -> list[str]:
    """The limited tendons whose range can bind inside the configuration's joint ranges, each as "name (why)": a
    ``<fixed>`` tendon whose length sum_j coef_j qpos_j can leave its range while the configuration joints stay
    within theirs (the others held at ``qpos0``), or a ``<spatial>`` one whose length a configuration joint can
    change (between bodies the configuration moves differently). MuJoCo holds such a tendon within its range, as it
    does a joint; the planner, which moves each joint within its own range, would not."""
    moved = bodies_moved_by(m, config)
    where = {int(j): i for i, j in enumerate(config.joint_ids)}
    lo_q = config.offset + config.scale * config.lower
    hi_q = config.offset + config.scale * config.upper
    qlo, qhi = np.minimum(lo_q, hi_q), np.maximum(lo_q, hi_q)
    wrap = mujoco.mjtWrap
    out = []
    for t in range(m.ntendon):
        if not m.tendon_limited[t]:
            continue
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TENDON, t) or f"tendon {t}"
        lo, hi = (float(v) for v in m.tendon_range[t])
        wraps = range(int(m.tendon_adr[t]), int(m.tendon_adr[t]) + int(m.tendon_num[t]))
        if all(int(m.wrap_type[w]) == int(wrap.mjWRAP_JOINT) for w in wraps):  # fixed: a linear function of qpos
            least = most = 0.0
            terms = []
            for w in wraps:
                j, coef = int(m.wrap_objid[w]), float(m.wrap_prm[w])
                if j in where:
                    i = where[j]
                    ends = (coef * qlo[i], coef * qhi[i])
                    least, most = least + min(ends), most + max(ends)
                    terms.append(f"{coef:g} {_joint_name(m, j)}")
                else:
                    value = coef * float(config.qpos0[int(m.jnt_qposadr[j])])
                    least, most = least + value, most + value
                    terms.append(f"{coef:g} {_joint_name(m, j)} (held at {float(config.qpos0[int(m.jnt_qposadr[j])]):.6g})")
            if any(int(m.wrap_objid[w]) in where for w in wraps) and (least < lo - 1e-12 or most > hi + 1e-12):
                out.append(f"'{name}' ({' + '.join(terms)} ranges over [{least:.6g}, {most:.6g}] within the joint ranges, "
                           f"its range is [{lo:.6g}, {hi:.6g}])")
            continue
        bodies = _spatial_bodies(m, t)
        if all(np.array_equal(moved[:, b], moved[:, bodies[0]]) for b in bodies[1:]):
            continue  # no configuration joint changes its length
        lengths, Q = _spatial_tendon_lengths(m, config, t, qlo, qhi)
        k = int(np.argmax(np.maximum(lo - lengths, lengths - hi)))
        if lengths[k] < lo - 1e-12 or lengths[k] > hi + 1e-12:
            out.append(f"'{name}' (a spatial tendon of length {lengths[k]:.6g} at qpos {np.round(Q[k], 6).tolist()} of "
                       f"{', '.join(config.joint_names)}, within the joint ranges; its range is [{lo:.6g}, {hi:.6g}])")
    return out


#: Configurations a spatial tendon's length is sampled at (besides the corners of the joint box) to find a limit that binds.
TENDON_SAMPLES = 2000


def _spatial_tendon_lengths(m: mujoco.MjModel, config: ConfigurationMap, t: int, qlo: np.ndarray, qhi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tendon t's length at the corners of the configuration joints' qpos box (up to 10 joints) and at
    :data:`TENDON_SAMPLES` seeded random points of it: (lengths (N,), the configuration joints' qpos (N, n)). A sample,
    not a bound: a length found outside the range is reached within the joint ranges; none found proves nothing."""
    n = config.dim
    corners = np.array(np.meshgrid(*[(0.0, 1.0)] * n, indexing="ij")).reshape(n, -1).T if n <= 10 else np.empty((0, n))
    unit = np.vstack([corners, np.random.default_rng(0).random((TENDON_SAMPLES, n))])
    Q = qlo + (qhi - qlo) * unit
    d = mujoco.MjData(m)
    lengths = np.empty(len(Q))
    for k, qpos in enumerate(Q):
        d.qpos[:] = config.qpos0
        d.qpos[config.qpos_index] = qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_tendon(m, d)
        lengths[k] = d.ten_length[t]
    return lengths, Q
