"""A content hash of a compiled MuJoCo model, so a saved result can refuse a scene it was not planned on.

``model_fingerprint(m)`` hashes (SHA-256) the compiled model's arrays in four parts, so a mismatch can be
named:

* ``kinematics``: body tree and poses, joints (names, types, axes, ranges), ``qpos0``;
* ``geometry``: every geom (type, body, size, pose, contype/conaffinity, margin) and mesh data;
* ``dynamics``: masses and inertias, damping, armature, actuators, timestep and gravity;
* ``declarations``: the ``<custom>`` text and numeric fields (foam-mj's configuration map).

Floats are rounded to 9 decimals before hashing so that the same MJCF gives the same digest across
compiler rounding differences; any change a user makes to the scene changes a digest. The top-level
``sha256`` combines the parts. Only MuJoCo and numpy are used (``foam-mj verify`` relies on it).
"""

from __future__ import annotations

import hashlib

import mujoco
import numpy as np

PARTS: dict[str, tuple[str, ...]] = {
    "kinematics": ("body_parentid", "body_pos", "body_quat", "jnt_type", "jnt_bodyid", "jnt_qposadr", "jnt_axis",
                   "jnt_pos", "jnt_range", "jnt_limited", "qpos0"),
    "geometry": ("geom_type", "geom_bodyid", "geom_size", "geom_pos", "geom_quat", "geom_contype",
                 "geom_conaffinity", "geom_margin", "geom_dataid", "mesh_vert", "mesh_face"),
    "dynamics": ("body_mass", "body_inertia", "body_ipos", "body_iquat", "dof_damping", "dof_armature",
                 "dof_frictionloss", "actuator_trnid", "actuator_gainprm", "actuator_biasprm", "actuator_ctrlrange"),
    "declarations": ("text_data", "numeric_data"),
}


def _digest_arrays(m: mujoco.MjModel, names: tuple[str, ...], extra: bytes = b"") -> str:
    h = hashlib.sha256()
    for name in names:
        value = getattr(m, name, None)
        if value is None:
            continue
        a = np.asarray(value)
        if a.dtype.kind == "f":
            a = np.round(a.astype(np.float64), 9) + 0.0  # + 0.0 turns -0.0 into 0.0
        h.update(name.encode() + str(a.shape).encode() + np.ascontiguousarray(a).tobytes())
    h.update(extra)
    return h.hexdigest()


def model_fingerprint(m: mujoco.MjModel) -> dict:
    """``{"sha256": ..., "parts": {"kinematics": ..., "geometry": ..., "dynamics": ..., "declarations": ...}}``."""
    joint_names = ",".join(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or "" for j in range(m.njnt)).encode()
    options = np.round(np.array([m.opt.timestep, *m.opt.gravity], dtype=np.float64), 9).tobytes()
    parts = {
        "kinematics": _digest_arrays(m, PARTS["kinematics"], joint_names),
        "geometry": _digest_arrays(m, PARTS["geometry"]),
        "dynamics": _digest_arrays(m, PARTS["dynamics"], options),
        "declarations": _digest_arrays(m, PARTS["declarations"]),
    }
    top = hashlib.sha256("".join(f"{k}={v};" for k, v in sorted(parts.items())).encode()).hexdigest()
    return {"sha256": top, "parts": parts}


def fingerprint_differences(stored: dict, current: dict) -> list[str]:
    """Names of the parts whose digests differ (all of them when ``stored`` has no parts)."""
    a, b = stored.get("parts") or {}, current.get("parts") or {}
    diff = [k for k in b if a.get(k) != b[k]]
    if not diff and stored.get("sha256") != current.get("sha256"):
        diff = ["model"]
    return diff
