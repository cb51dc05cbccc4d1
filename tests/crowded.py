"""Crowded scenes for tests: a shipped robot among many small random obstacles (boxes, capsules, cylinders, spheres,
thin plates), placed with MuJoCo so that none comes within ``keep`` of the robot at the given configurations; and
the CloudWalker before a wall with one door. Written as self-contained MJCF (``MjSpec.to_xml``)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from foam_mj.data import models_dir

#: bench_arm6's mirror poses either side of its box (benchmarks/planner_problems.py, ``arm6``).
ARM6_START = np.array([-0.7, 0.87, 1.12, -0.08, 0.0, 0.0])
ARM6_GOAL = ARM6_START * np.array([-1, 1, 1, 1, 1, 1])
KINDS = ("box", "capsule", "cylinder", "sphere")
#: The CloudWalker's footprint is 0.64 m wide (models/cloudwalker.xml).
WALKER_WIDTH = 0.64


def _quat(rng: np.random.Generator) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_euler2Quat(q, np.radians(rng.uniform(-180, 180, 3)), "xyz")
    return q


def crowded_spec(n: int, seed: int, base: str = "bench_arm6.xml", ends: tuple = (ARM6_START, ARM6_GOAL),
                 kinds: tuple[str, ...] = KINDS, keep: float | None = 0.03, radius: tuple[float, float] = (0.2, 0.95),
                 height: float = 1.1, bodies: int = 0) -> mujoco.MjSpec:
    """``base`` (a model in models/) with ``n`` obstacles at random places in a ring about the z axis (``radius``,
    heights up to ``height``), random orientation, 1.5-4 cm half-sizes (a ``plate``: a box 1-4 mm thick), none within
    ``keep`` metres of a robot geom at any configuration of ``ends`` (qpos rows of the first joints; ``keep`` None: no
    check, for obstacles placed beyond the robot's reach). ``bodies``:
    that many obstacles share each static body (a new body without joints every ``bodies``), else all on the world."""
    rng = np.random.default_rng(seed)
    spec = mujoco.MjSpec.from_file(str(models_dir() / base))
    added, holder = 0, None
    for _ in range(100 * n + 100):
        if added == n:
            break
        kind = kinds[rng.integers(len(kinds))]
        parent = spec.worldbody
        new_holder = bool(bodies) and added % bodies == 0
        if new_holder:
            holder = spec.worldbody.add_body(name=f"holder{added}", pos=[0.0, 0.0, 0.001 * added])
        if bodies:
            parent = holder
        r, th = rng.uniform(*radius), rng.uniform(-np.pi, np.pi)
        g = parent.add_geom(name=f"clutter{added}", pos=[r * np.cos(th), r * np.sin(th), rng.uniform(0.03, height)], quat=_quat(rng))
        s = rng.uniform(0.015, 0.04, 3)
        if kind == "plate":
            g.type, g.size = mujoco.mjtGeom.mjGEOM_BOX, [rng.uniform(0.0005, 0.002), rng.uniform(0.03, 0.1), rng.uniform(0.03, 0.1)]
        else:
            g.type = getattr(mujoco.mjtGeom, f"mjGEOM_{kind.upper()}")
            g.size = [s[0], 2 * s[1] if kind in ("capsule", "cylinder") else s[1], s[2]]
        g.contype, g.conaffinity, g.margin = 1, 1, 0.0
        if keep is None:
            added += 1
            continue
        m = spec.compile()
        if _clear(m, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, g.name), ends, keep):
            added += 1
        else:
            spec.delete(g)
            if new_holder:
                spec.delete(holder)
    if added < n:
        raise ValueError(f"placed only {added} of {n} obstacles")
    return spec


def _clear(m: mujoco.MjModel, geom: int, ends: tuple, keep: float) -> bool:
    """Is ``geom`` at least ``keep`` from every collision geom on a moving body at every configuration of ``ends``?"""
    d = mujoco.MjData(m)
    robot = [g for g in range(m.ngeom) if m.geom_bodyid[g] != 0 and m.body_jntnum[m.geom_bodyid[g]] > 0
             and (m.geom_contype[g] or m.geom_conaffinity[g])]
    for q in ends:
        d.qpos[: len(q)] = q
        mujoco.mj_kinematics(m, d)
        if any(mujoco.mj_geomDistance(m, d, g, geom, keep + 0.01, None) < keep for g in robot):
            return False
    return True


def write_crowded(path: Path, n: int, seed: int, **kw) -> Path:
    """:func:`crowded_spec` written to ``path`` (self-contained MJCF)."""
    path.write_text(crowded_spec(n, seed, **kw).to_xml())
    return path


def write_door(path: Path, width: float, thickness: float = 0.1) -> Path:
    """The CloudWalker on its 10 m x 10 m map (models/walker_common.xml) with a wall across it at x = 5 m, ``thickness``
    thick, pierced by one door ``width`` wide centred on y = 5 m: from the south-west to the north-east room the
    walker must pass it, with (width - 0.64 m) / 2 to spare on each side."""
    lo, hi, t = 5 - width / 2, 5 + width / 2, thickness / 2
    path.write_text(
        f'<mujoco model="door"><include file="{models_dir() / "cloudwalker.xml"}"/>'
        f'<include file="{models_dir() / "walker_common.xml"}"/><worldbody>'
        f'<geom name="wall_a" class="wall" pos="5 {lo / 2} 0.75" size="{t} {lo / 2} 0.75"/>'
        f'<geom name="wall_b" class="wall" pos="5 {(hi + 10) / 2} 0.75" size="{t} {(10 - hi) / 2} 0.75"/>'
        "</worldbody></mujoco>"
    )
    return path
