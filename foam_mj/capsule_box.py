"""A guard on MuJoCo's capsule/box distance where the capsule's axis passes through the box.

``mj_geomDistance`` between a capsule and a box (MuJoCo 3.x-4.0's dedicated capsule/box test) reads a positive
distance in some poses where the capsule's segment runs right through the box: an arm link stuck through a 2 cm wall
read +25 mm of clearance (``foam-mj bubble``), and a start or goal so placed was accepted and its bubble certified.
Of random overlapping poses of two primitives of each type pair, capsule/box misread at 12 of 229 (up to +52 mm);
every other pair read a penetration. A segment that meets the box puts the sphere about that point at least the
capsule's radius into it, so the signed distance is at most minus the radius: :func:`geom_distance` returns the
smaller of MuJoCo's value and that bound where the segment meets the box (a slab test: the segment's parameter
interval inside each pair of the box's faces, as in Kay and Kajiya, "Ray tracing complex scenes", SIGGRAPH 1986),
and MuJoCo's value, to the last bit, everywhere else.

The single-configuration queries (a start or goal, a fixed pair, ``foam-mj bubble``) go through
:func:`geom_distance`, the batched ones of bubble growth through the same test on the batch's own poses
(:meth:`foam_mj.clearance.Clearance.batch_pairs`: a candidate child may lie up to twice its parent's radius out,
outside every certified bubble), and ``foam-mj verify`` has its own.
"""

from __future__ import annotations

import mujoco

_CAPSULE, _BOX = int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_BOX)


def is_capsule_box(m: mujoco.MjModel, a: int, b: int) -> bool:
    """Whether geoms a and b are a capsule and a box, in either order."""
    return {int(m.geom_type[a]), int(m.geom_type[b])} == {_CAPSULE, _BOX}


def segment_meets(d: mujoco.MjData, capsule: int, box: int, half: float, size, reach: float | None = None) -> bool:
    """Whether the capsule's segment (half-length ``half``) meets the box (half-sizes ``size``) at the kinematics of
    ``d`` (after ``mj_kinematics``), in Python floats: the capsule's centre and axis in the box's frame, the segment's
    parameter interval inside each pair of faces, intersected and clipped to [-half, half] (module docstring); an
    axis parallel to a pair of faces meets it where it lies between them. ``reach``: False at once where the centres
    are farther apart than its square root (the half-length plus the box's half-diagonal), a necessary condition the
    clearance's per-query guard precomputes."""
    cx, cy, cz = d.geom_xpos[capsule].tolist()
    bx, by, bz = d.geom_xpos[box].tolist()
    dx, dy, dz = cx - bx, cy - by, cz - bz
    if reach is not None and dx * dx + dy * dy + dz * dz > reach:
        return False
    R = d.geom_xmat[box].tolist()  # row-major: the box's axis i is column i
    A = d.geom_xmat[capsule].tolist()
    ax, ay, az = A[2], A[5], A[8]
    lo, hi = -half, half
    for i in range(3):
        p = dx * R[i] + dy * R[3 + i] + dz * R[6 + i]
        u = ax * R[i] + ay * R[3 + i] + az * R[6 + i]
        if abs(u) < 1e-12:  # parallel to these faces: between them or nowhere
            if abs(p) > size[i]:
                return False
            continue
        t0, t1 = (-size[i] - p) / u, (size[i] - p) / u
        lo, hi = max(lo, min(t0, t1)), min(hi, max(t0, t1))
        if lo > hi:
            return False
    return True


def segment_meets_box(m: mujoco.MjModel, d: mujoco.MjData, capsule: int, box: int) -> bool:
    """:func:`segment_meets` with the sizes of the model's geoms."""
    return segment_meets(d, capsule, box, float(m.geom_size[capsule][1]), m.geom_size[box].tolist())


def geom_distance(m: mujoco.MjModel, d: mujoco.MjData, a: int, b: int, distmax: float) -> float:
    """``mj_geomDistance(m, d, a, b, distmax, None)``, but at most minus the capsule's radius where a capsule's segment
    meets a box (module docstring)."""
    v = mujoco.mj_geomDistance(m, d, a, b, distmax, None)
    if is_capsule_box(m, a, b):
        capsule, box = (a, b) if int(m.geom_type[a]) == _CAPSULE else (b, a)
        radius = float(m.geom_size[capsule][0])
        if v > -radius and segment_meets_box(m, d, capsule, box):
            return -radius
    return v


#: Sizes (metres) below which MuJoCo's capsule/box test (MuJoCo 4.0) reads separated pairs farther apart than they are,
#: measured on random near poses against distances from 2,001 points along the capsule's axis: a box thinner than THIN
#: (half-size), or a capsule and a box both within SMALL (the capsule's half-length plus radius, the box's largest
#: half-size). A 0.05 mm half-thick box by a 25 mm capsule read 3 of 886 near poses too far, 0.03 mm 42 of 933; a 3-link
#: capsule arm and its box post drawn 1/1000 size 676 of 1,130 (up to the 1 m cap); none at 0.07 mm, none for a
#: 0.5 mm capsule by a 0.7 mm box (the arm at 1/250).
THIN, SMALL = 1e-4, 1e-3


def check_sizes(m: mujoco.MjModel, pairs, path) -> None:
    """ModelError naming the first checked capsule/box pair below :data:`THIN` or :data:`SMALL`: MuJoCo reads such a
    pair farther apart than it is, so no bubble of it would be certified."""
    from foam_mj.errors import ModelError

    for a, b in pairs:
        a, b = int(a), int(b)
        if not is_capsule_box(m, a, b):
            continue
        capsule, box = (a, b) if int(m.geom_type[a]) == _CAPSULE else (b, a)
        reach, size = float(m.geom_size[capsule][0] + m.geom_size[capsule][1]), m.geom_size[box]
        if size.min() < THIN or (reach < SMALL and size.max() < SMALL):
            name = lambda g: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"  # noqa: E731
            raise ModelError(
                f"{path}: collision geoms {name(capsule)} (capsule, radius {m.geom_size[capsule][0]:.3g} m, half-length "
                f"{m.geom_size[capsule][1]:.3g} m) and {name(box)} (box, half-sizes {' x '.join(f'{v:.3g}' for v in size)} m) "
                "are smaller than MuJoCo's capsule/box distance measures: it reads such pairs farther apart than they are "
                f"(a box under {THIN * 1e3:g} mm thick, or a capsule and a box both under {SMALL * 1e3:g} mm); draw the model "
                "in larger units (millimetres, delta with them), or model one of the two as another shape (a box link, a "
                "cylinder post)")
