"""Edits a scenario makes to its MJCF scene, applied through :class:`mujoco.MjSpec` (the file is never changed).

A scenario may

* name the configuration joints (``joints = [...]``) and normalize some of them (``[normalize]``): they
  are written into the spec as the ``foam_mj:configuration`` text and ``foam_mj:normalize:<joint>``
  numerics (:mod:`foam_mj.model`), so the edited scene is self-describing;
* scale the leg to a subject (``[subject] height, mass``): :mod:`foam_mj.anthropometry`;
* resize, move or turn the scene's box obstacle (``[obstacle] size, pos, euler``): :func:`foam_mj.obstacles.resize_box`;
* add obstacles from mesh files (``[[mesh]] file, pos, euler, scale``): :func:`foam_mj.obstacles.add_mesh_obstacle`.

:func:`build_robot` applies them in that order and compiles the result. An edited scene is round-tripped
through ``MjSpec.to_xml`` before compiling, so that the model planned on is exactly the one a saved
copy of the scene (:func:`scene_xml`, written beside a JSON result) reproduces.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco

from foam_mj.configuration import CONFIGURATION_FIELD, NORMALIZE_PREFIX
from foam_mj.mjcf import load_spec, scene_xml
from foam_mj.model import RobotModel


@dataclass(frozen=True)
class Subject:
    """A subject's standing height (m) and body mass (kg); None keeps the model's."""

    height: float | None = None
    mass: float | None = None


@dataclass(frozen=True)
class BoxObstacle:
    """New full extents (m, along x, y, z), centre (m, world frame) and/or orientation (``euler``: degrees,
    extrinsic x-y-z in the world frame, as a [[mesh]]'s) of a scene's box geom.

    ``name`` picks the geom when the scene has several static boxes. When ``size`` or ``euler`` changes and ``pos``
    is not given, the box keeps its centre in x and y and its lowest point (it stays on the floor, turned or not).
    """

    size: tuple[float, float, float] | None = None
    pos: tuple[float, float, float] | None = None
    name: str | None = None
    euler: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class MeshObstacle:
    """A static obstacle from a mesh file (STL, OBJ, PLY): placed at ``pos`` (m), rotated by ``euler``
    (degrees, extrinsic x-y-z, MuJoCo's default sequence "xyz"), scaled by ``scale`` (per axis), split into
    convex parts by approximate convex decomposition (``decompose``; CoACD with concavity ``threshold``)."""

    file: Path
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    euler: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    name: str | None = None
    decompose: bool = True
    threshold: float = 0.05


@dataclass(frozen=True)
class SceneEdits:
    """Everything a scenario changes in its scene; the default changes nothing."""

    joints: tuple[str, ...] | None = None
    normalize: dict[str, tuple[float, ...]] = field(default_factory=dict)
    subject: Subject | None = None
    obstacle: BoxObstacle | None = None
    meshes: tuple[MeshObstacle, ...] = ()

    @property
    def changes_scene(self) -> bool:
        """True when the compiled scene differs from the MJCF file (so a copy must be saved with results)."""
        return bool(self.joints is not None or self.normalize or self.subject or self.obstacle or self.meshes)

    def as_dict(self) -> dict:
        """A JSON-able summary (for results)."""
        out: dict = {}
        if self.joints is not None:
            out["joints"] = list(self.joints)
        if self.normalize:
            out["normalize"] = {k: list(v) for k, v in self.normalize.items()}
        if self.subject:
            out["subject"] = {"height": self.subject.height, "mass": self.subject.mass}
        if self.obstacle:
            o = self.obstacle
            out["obstacle"] = {k: v for k, v in (("size", o.size), ("pos", o.pos), ("euler", o.euler), ("name", o.name)) if v is not None}
        if self.meshes:
            out["mesh"] = [
                {"file": str(mo.file), "pos": list(mo.pos), "euler": list(mo.euler), "scale": list(mo.scale), "decompose": mo.decompose, "threshold": mo.threshold}
                for mo in self.meshes
            ]
        return out


def _set_text(spec: mujoco.MjSpec, name: str, data: str) -> None:
    for t in spec.texts:
        if t.name == name:
            t.data = data
            return
    t = spec.add_text()
    t.name, t.data = name, data


def _set_numeric(spec: mujoco.MjSpec, name: str, data: list[float]) -> None:
    for nm in spec.numerics:
        if nm.name == name:
            nm.data = list(data)
            nm.size = len(data)
            return
    nm = spec.add_numeric()
    nm.name, nm.data, nm.size = name, list(data), len(data)


def edited_spec(scene: Path, edits: SceneEdits) -> mujoco.MjSpec:
    """The scene's spec with ``edits`` applied (module docstring), not yet compiled."""
    spec = load_spec(scene)
    if edits.subject is not None and (edits.subject.height is not None or edits.subject.mass is not None):
        from foam_mj.anthropometry import scale_to_subject

        scale_to_subject(spec, scene, edits.subject.height, edits.subject.mass)
    if edits.obstacle is not None:
        from foam_mj.obstacles import resize_box

        resize_box(spec, scene, edits.obstacle)
    for i, mesh in enumerate(edits.meshes):
        from foam_mj.obstacles import add_mesh_obstacle

        add_mesh_obstacle(spec, mesh, mesh.name or f"mesh{i}")
    if edits.joints is not None:
        _set_text(spec, CONFIGURATION_FIELD, " ".join(edits.joints))
    for joint, numbers in edits.normalize.items():
        _set_numeric(spec, NORMALIZE_PREFIX + joint, list(numbers))
    return spec


def build_robot(scene: Path, edits: SceneEdits | None = None, **options) -> RobotModel:
    """The scene as a :class:`RobotModel`, with ``edits`` applied (module docstring); ``options``
    (robot_root, self_collision, keyframe) go to :meth:`RobotModel.from_spec`."""
    edits = edits or SceneEdits()
    if not edits.changes_scene:
        return RobotModel.from_xml(scene, **options)
    from foam_mj.mjcf import compile_spec, name_unnamed_geoms

    spec = edited_spec(scene, edits)
    compile_spec(spec, scene)
    name_unnamed_geoms(spec)
    xml = scene_xml(spec, scene)
    # The [normalize] table again: its values are the spec's, and a joint outside the configuration is refused
    # (the MJCF's own fields may name any joint of the model; the scenario's would be silently ignored).
    robot = RobotModel.from_spec(mujoco.MjSpec.from_string(xml), scene, normalize=edits.normalize or None, **options)
    robot.xml = robot.xml or xml  # its own when a keyframe moved a mocap body (RobotModel.from_spec)
    return robot
