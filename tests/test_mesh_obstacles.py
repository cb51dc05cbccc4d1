"""Tests for foam_mj.obstacles (meshes): a non-convex obstacle from an STL is split into convex parts, so its
notch stays open, and every planned path is checked densely against the ORIGINAL mesh with trimesh and
plain geometry, sharing nothing with MuJoCo's distance queries on the decomposed parts."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from foam_mj.data import models_dir
from foam_mj.errors import ScenarioError
from foam_mj.scenarios import scenario_from_dict

trimesh = pytest.importorskip("trimesh")
pytest.importorskip("coacd")
from scipy.spatial import cKDTree  # noqa: E402

#: Sampling spacing of the mesh surface for the dense check (m): every surface point is within this of a sample.
SPACING = 0.004


def u_step(width=0.75, height=0.25, base=0.05, wall=0.15, depth=0.5):
    """A U-shaped step drawn in the x-z plane (x along the walk, z up before rotation), extruded ``depth``:
    two walls ``wall`` thick and ``height`` tall on a ``base`` slab, a notch ``width - 2 wall`` wide between."""
    W, H, b, t = width, height, base, wall
    outline = np.array([(0, 0), (W, 0), (W, H), (W - t, H), (W - t, b), (t, b), (t, H), (0, H)], float)
    faces = np.array([(0, 1, 4), (0, 4, 5), (0, 5, 6), (0, 6, 7), (1, 2, 3), (1, 3, 4)])
    return trimesh.creation.extrude_triangulation(outline, faces, depth)


# The leg over a bare floor; the U step's notch (x 0.70 .. 1.15 m, floor of the notch 0.05 m up, walls
# 0.25 m tall) holds the obstacle task's goal foot (sole 0.175 m above the floor, heel 0.78 m): rotated
# 90 deg about x so the extrusion runs along y, centred on y = 0.
MESH_TABLE = {"pos": [0.55, 0.25, 0.0], "euler": [90, 0, 0]}
Q_INIT, Q_GOAL = [0.2, 0.3, 0.08], [0.45, 0.4536, 1.45]


@pytest.fixture(scope="module")
def stl(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("mesh") / "u_step.stl"
    m = u_step()
    assert m.is_watertight
    m.export(p)
    return p


def inside(mesh, points) -> np.ndarray:
    """Points inside a closed mesh, by the generalized winding number (sum of the triangles' solid angles;
    A. Jacobson et al., "Robust inside-outside segmentation using generalized winding numbers", SIGGRAPH 2013)."""
    P = np.atleast_2d(np.asarray(points, float))
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]  # (F, 3, 3)
    a, b, c = (tri[None, :, i, :] - P[:, None, :] for i in range(3))
    la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
    det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
    den = la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc + np.einsum("pfi,pfi->pf", b, c) * la + np.einsum("pfi,pfi->pf", c, a) * lb
    winding = (2 * np.arctan2(det, den)).sum(axis=1) / (4 * np.pi)
    return np.abs(winding) > 0.5


def _doc(stl: Path, **mesh) -> dict:
    return {
        "scene": str(models_dir() / "floor.xml"),
        "q_init": Q_INIT,
        "q_goal": Q_GOAL,
        "mesh": [{"file": stl.name, **MESH_TABLE, **mesh}],
        "planner": {"algorithm": "pfm", "K": 10, "r_min": 0.05, "delta": 0.005},
    }


@pytest.fixture(scope="module")
def scenario(stl):
    return scenario_from_dict(_doc(stl), stl.parent)


def _world_mesh(stl: Path):
    from foam_mj.obstacles import load_mesh
    from foam_mj.scene_edits import MeshObstacle

    return load_mesh(MeshObstacle(stl, tuple(MESH_TABLE["pos"]), tuple(MESH_TABLE["euler"])))


def test_the_notch_is_not_filled_in(scenario, stl):
    robot = scenario.robot
    parts = [robot.geom_name(g) for g in robot.obstacle_geoms if robot.geom_name(g).startswith("mesh0_")]
    assert len(parts) >= 3  # two walls and a base at least
    # The goal's foot sits inside the mesh's convex hull (in the notch), yet the goal is valid ...
    mesh = _world_mesh(stl)
    d = robot.set_configuration(np.array(Q_GOAL))
    foot = d.geom_xpos[robot.model.geom("foot_collision").id]
    assert inside(mesh.convex_hull, foot)[0] and not inside(mesh, foot)[0]
    from foam_mj.clearance import Clearance

    c = Clearance(robot)
    assert c(np.array(Q_GOAL)) > 0.05
    c.close()
    # ... while the undecomposed mesh (its convex hull, as MuJoCo would use it) puts the goal in collision.
    with pytest.raises(ScenarioError, match="q_goal.*in collision"):
        scenario_from_dict(_doc(stl, decompose=False), stl.parent)


class MeshChecker:
    """Distance from the leg's collision geoms (capsules, boxes) to the original mesh's surface, from surface
    samples at most SPACING apart (a lower bound: sampled distance - SPACING), plus a containment test."""

    def __init__(self, robot, mesh) -> None:
        self.robot, self.mesh = robot, mesh
        fine = mesh.subdivide_to_size(max_edge=SPACING)
        self.points = np.asarray(fine.vertices)
        self.tree = cKDTree(self.points)
        m = robot.model
        self.geoms = [int(g) for g in robot.robot_geoms]
        self.d = mujoco.MjData(m)

    def _geom_distance(self, g: int, P: np.ndarray) -> np.ndarray:
        m, d = self.robot.model, self.d
        R = d.geom_xmat[g].reshape(3, 3)
        local = (P - d.geom_xpos[g]) @ R  # points in the geom's frame
        size = m.geom_size[g]
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE:
            z = np.clip(local[:, 2], -size[1], size[1])
            return np.linalg.norm(local - np.c_[np.zeros((len(P), 2)), z], axis=1) - size[0]
        assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
        q = np.abs(local) - size[:3]
        return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)

    def min_distance(self, qpos: np.ndarray, reach: float = 0.03) -> float:
        """Smallest sampled distance over the leg's geoms at qpos (capped at ``reach``)."""
        m, d = self.robot.model, self.d
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        centres = d.geom_xpos[self.geoms]
        assert not np.any(inside(self.mesh, centres)), "a leg geom is inside the mesh"
        best = reach
        for g, c in zip(self.geoms, centres):
            size = m.geom_size[g]
            radius = size[0] + size[1] if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE else float(np.linalg.norm(size))
            bound = radius + reach  # every point of the geom lies within ``radius`` of its centre
            idx = self.tree.query_ball_point(c, bound)
            if idx:
                best = min(best, float(self._geom_distance(g, self.points[idx]).min()))
        return best


@pytest.mark.slow
def test_every_path_clears_the_original_mesh(scenario, stl):
    from foam_mj.pipeline import run

    robot = scenario.robot
    checker = MeshChecker(robot, _world_mesh(stl))
    delta = scenario.params.delta
    for seed in (0,):
        outcome = run(scenario, seed, ("optimal",), replay=True, dynamic=False)
        for name, po in outcome.paths.items():
            # the configuration-space polyline, at most 3 mrad apart, and every 3rd row of the trajectory (6 ms)
            P = po.result.path
            rows = [robot.config.to_qpos(a + (b - a) * t) for a, b in zip(P[:-1], P[1:]) for t in np.linspace(0, 1, max(2, int(np.ceil(np.abs(b - a).max() / 3e-3)) + 1))]
            rows += list(po.trajectory.qpos[::3])
            worst = min(checker.min_distance(r) for r in rows)
            assert worst - SPACING > 0, f"{name} (seed {seed}) may touch the mesh: sampled {worst:.4f} m"
            assert worst >= delta, f"{name} (seed {seed}) comes {worst:.4f} m from the mesh, margin {delta}"


def test_mesh_tables_are_checked(stl, tmp_path):
    bad = tmp_path / "kerb.txt"
    bad.write_text("not a mesh")
    for mesh, message in (
        ({"file": "nowhere.stl"}, "mesh file not found"),
        ({"file": str(bad)}, "not an STL, OBJ or PLY"),
        ({"file": stl.name, "scale": [1, -1, 1]}, "'scale'"),
        ({"file": stl.name, "colour": "red"}, "unknown field"),
        ({"pos": [0, 0, 0]}, "'file'"),
    ):
        doc = _doc(stl)
        doc["mesh"] = [mesh]
        with pytest.raises(ScenarioError, match=message):
            scenario_from_dict(doc, stl.parent, check=False)


def test_an_open_or_flat_mesh_is_refused_at_once_naming_the_fix(stl, tmp_path):
    """An open surface is refused for decomposition at once (CoACD used to remesh a box with one face missing
    into 60,588 triangles and search them for 6 minutes); with decompose = false its convex hull is used, wound
    outward; a flat mesh, whose hull has no volume, is refused (its hull used to need networkx: exit 1)."""
    import time

    from foam_mj.obstacles import convex_parts
    from foam_mj.scene_edits import MeshObstacle

    box = trimesh.creation.box(extents=(0.2, 0.5, 0.15))
    box.update_faces(np.arange(len(box.faces)) != 0)
    box.remove_unreferenced_vertices()
    opened = tmp_path / "open_box.stl"
    box.export(opened)
    t0 = time.perf_counter()
    with pytest.raises(ScenarioError, match="not closed.*decompose = false"):
        convex_parts(MeshObstacle(opened))
    assert time.perf_counter() - t0 < 5.0
    ((v, f),) = convex_parts(MeshObstacle(opened, decompose=False))
    assert len(v) == 8 and len(f) == 12
    a, b, c = (v[f[:, i]] for i in range(3))
    assert np.all(np.einsum("ij,ij->i", np.cross(b - a, c - a), (a + b + c) / 3 - v.mean(axis=0)) > 0)  # outward
    flat = tmp_path / "flat.stl"
    trimesh.Trimesh([[0, -0.25, 0], [0, 0.25, 0], [0, 0.25, 0.2], [0, -0.25, 0.2]], [[0, 1, 2], [0, 2, 3]]).export(flat)
    with pytest.raises(ScenarioError, match="lie in one plane.*no volume"):
        convex_parts(MeshObstacle(flat, decompose=False))
