"""The robot model: an MJCF scene, its configuration map q <-> qpos, and which geoms are robot and obstacle.

The configuration map q <-> qpos is :mod:`foam_mj.configuration`'s; MJCF loading, :mod:`foam_mj.mjcf`'s.

Robot and obstacle geoms, and the pairs that are checked
--------------------------------------------------------
A collision geom (``contype`` or ``conaffinity`` non-zero, or named in a ``<contact><pair>``) is a
*robot* geom when it belongs to the robot: the subtree of the body named ``robot_root`` when one is
given, otherwise every body some configuration joint moves. Every other collision geom is an
*obstacle*, fixed where the model puts it: joints that are not configuration coordinates stay at their
``qpos0`` (or at the pose of the keyframe named ``keyframe``), so a loose object with a free joint is an
obstacle at its initial pose.

The clearance pairs are every robot/obstacle pair of collision geoms that are not :func:`~foam_mj.geom_pairs.attached`
(on one weld body, or parent and child: they meet at a joint), whatever contype/conaffinity and
``<contact><exclude>`` say: an obstacle in another collision group is still in the way, and the
independent checkers (``foam-mj verify``, MuJoCo-only checkers) count it; and, unless ``self_collision``
is off, the robot/robot pairs MuJoCo's own collision detection would test (:func:`~foam_mj.geom_pairs.collision_pairs`: every
``<contact><pair>``, plus the pairs that pass the contype/conaffinity filter, are not on one body or
welded together, are not parent and child (unless the model disables that filter), and are not named in
a ``<contact><exclude>``): a thigh touches its shank at the knee by design. A pair whose
distance no configuration joint can change (no configuration joint lies on the kinematic path between
its two bodies: a shoulder capsule above the floor turned only by a vertical pan joint) is left out of
the checked pairs and kept in ``fixed_pairs``: no motion can bring it closer.
The independent checker ``foam-mj verify`` (foam_mj/verify.py) writes the same rule apart from this one.
"""

from __future__ import annotations

import dataclasses
import numbers
import os
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from foam_mj.capsule_box import check_sizes, geom_distance
from foam_mj.configuration import (
    _SUPPORTED_JOINTS,
    CONFIGURATION_FIELD,
    ConfigurationMap,
    _configuration_map,
    checked_normalize,
    degrees_hint,
    _joint_name,
)
from foam_mj.constraints import binding_tendon_limits, coupling_equalities, coupling_refusal, describe_equality
from foam_mj.errors import ConfigurationError, ModelError, clearance_text, unknown_names
from foam_mj.fingerprint import PARTS
from foam_mj.geom_pairs import attached, body_subtree, collision_pairs, geom_moved_by, pair_coordinates, reference_data
from foam_mj.mjcf import (
    _custom_text,
    check_mesh_hulls,
    check_no_flex,
    compile_spec,
    load_spec,
    name_unnamed_geoms,
    place_mocap_bodies,
    scene_xml,
    uncompiled_twin,
)

if TYPE_CHECKING:
    from foam_mj.bubbles import DisplacementBound

#: The cutoff of the fixed pairs' distances (metres): above any margin a plan could ask for.
FIXED_DISTMAX = 1e6
FIXED_TOLERANCE = 1e-9  # metres (per metre of delta above 1 m): a fixed pair's rounding noise as its joints turn

#: The compiled model's arrays that set the clearances (its kinematics and geometry, as in
#: :mod:`foam_mj.fingerprint`): an edit of one of them after the RobotModel was built is refused.
SHAPE_FIELDS: tuple[str, ...] = PARTS["kinematics"] + PARTS["geometry"]


@dataclass
class RobotModel:
    """A compiled MJCF scene with its configuration map and its robot/obstacle geom pairs.

    Everything derived from ``model`` (the checked pairs, the bubble bound, the batched distance queries' copy
    of the model) is computed once, so ``model``'s kinematics and geometry must not change afterwards: to move
    an obstacle, edit :meth:`spec_copy` and build a new RobotModel with :meth:`from_spec` (an edit of ``model``
    itself is refused by :meth:`check_unchanged` before any planning, never used half-way). Safe to share
    between threads; picklable (the spec travels as MJCF text), for process pools and Ray.
    """

    path: Path
    model: mujoco.MjModel
    config: ConfigurationMap
    robot_geoms: np.ndarray  # geom ids
    obstacle_geoms: np.ndarray  # geom ids
    pairs: np.ndarray  # (P, 2) geom ids (robot, obstacle)
    spec: mujoco.MjSpec | None = field(repr=False, default=None)  # what ``model`` was compiled from (a private copy)
    xml: str | None = field(repr=False, default=None)  # the edited scene's MJCF when it differs from ``path``
    self_pair: np.ndarray = field(default=None)  # type: ignore[arg-type,assignment]  # (P,) bool: both geoms are robot geoms
    moves: np.ndarray = field(default=None, repr=False)  # type: ignore[arg-type,assignment]  # (ngeom, n) bool: coordinate i moves geom g
    fixed_pairs: np.ndarray = field(default=None, repr=False)  # type: ignore[arg-type,assignment]  # (F, 2) pairs no coordinate can change
    pair_active: np.ndarray = field(default=None, repr=False)  # type: ignore[arg-type,assignment]  # (P, n) bool: coordinate i can change d_p
    robot_root: str | None = None
    self_collision: bool = True
    held_by_equality: dict[str, list[str]] = field(default_factory=dict)  # equality -> the default joints it held

    def __post_init__(self) -> None:
        # Per-geom masks and the checked-pair table for in_collision, computed once rather than on every call.
        ng = self.model.ngeom
        ids = np.arange(ng)
        self._is_robot = np.isin(ids, self.robot_geoms)
        self._is_obstacle = np.isin(ids, self.obstacle_geoms)
        self.pairs = np.asarray(self.pairs, dtype=int).reshape(-1, 2)
        if self.self_pair is None:
            self.self_pair = np.zeros(len(self.pairs), dtype=bool)
        if self.moves is None:
            self.moves = geom_moved_by(self.model, self.config)
        if self.pair_active is None:
            d, cfg = reference_data(self.model, self.config), self.config
            self.pair_active = np.array([pair_coordinates(self.model, cfg, self.moves, a, b, d) for a, b in self.pairs],
                                        dtype=bool).reshape(-1, cfg.dim)
        if self.fixed_pairs is None:
            self.fixed_pairs = np.empty((0, 2), dtype=int)
        self.pair_table = np.zeros((ng, ng), dtype=bool)
        self.pair_table[self.pairs[:, 0], self.pairs[:, 1]] = True
        self.pair_table |= self.pair_table.T
        self._shape = {name: np.array(getattr(self.model, name)) for name in SHAPE_FIELDS}
        self._local = threading.local()  # each thread's MjData for set_configuration

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        del state["_local"]
        state.pop("fixed_distances", None)  # caches
        state.pop("contact_reach", None)
        state.pop("displacement_bound", None)
        if self.spec is not None:  # MjSpec does not pickle: its MJCF text does
            state["spec"] = self.xml if self.xml is not None else scene_xml(self.spec.copy(), self.path)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        if isinstance(self.spec, str):
            self.spec = mujoco.MjSpec.from_string(self.spec)
        self._local = threading.local()

    def check_unchanged(self) -> None:
        """:class:`ModelError` when ``model``'s kinematics or geometry (a body's or geom's pose, a size, a joint
        range, ...) were edited after this RobotModel was built: the pairs, the bubble bound and the batched
        distance queries were computed from the model as it was, so planning on it would mix old and new scenes."""
        changed = [name for name, value in self._shape.items() if not np.array_equal(getattr(self.model, name), value)]
        if changed:
            raise ModelError(
                f"{self.path}: the compiled model was edited after its RobotModel was built ({', '.join(changed)} changed); "
                "the bubbles would still see the old scene. Edit the spec instead and build a new model and oracle: "
                "spec = robot.spec_copy(); ...; BubbleOracle(RobotModel.from_spec(spec, robot.path), delta)"
            )

    @classmethod
    def from_xml(
        cls,
        path: str | Path,
        joints: Sequence[str] | None = None,
        normalize: Mapping[str, Sequence[float]] | None = None,
        *,
        robot_root: str | None = None,
        self_collision: bool = True,
        keyframe: str | None = None,
    ) -> "RobotModel":
        """Load an MJCF scene and read its configuration (see the module docstring).

        ``joints`` and ``normalize`` (joint name -> [span] or [qpos_lo, qpos_hi, span]) override the MJCF's
        declaration, as a scenario's ``joints = [...]`` and ``[normalize]`` do. ``robot_root`` names the
        body whose subtree is the robot (default: every body a configuration joint moves; without a joint
        declaration, the robot's limited hinges and slides are the coordinates); ``self_collision`` adds
        the robot/robot pairs MuJoCo lets collide; ``keyframe`` names the keyframe whose pose holds the
        joints that are not configuration coordinates (default: qpos0).
        """
        if not isinstance(path, (str, os.PathLike)):
            hint = " (for a mujoco.MjSpec use RobotModel.from_spec(spec, name))" if isinstance(path, mujoco.MjSpec) else (
                " (a compiled MjModel cannot be turned back into a spec: load its MJCF file, or give its MjSpec to "
                "RobotModel.from_spec)" if isinstance(path, mujoco.MjModel) else "")
            raise TypeError(f"RobotModel.from_xml takes the path of an MJCF file, got {type(path).__name__}{hint}")
        p = Path(path).resolve()
        return cls.from_spec(
            load_spec(p), p, joints, normalize, robot_root=robot_root, self_collision=self_collision, keyframe=keyframe
        )

    @classmethod
    def from_spec(
        cls,
        spec: mujoco.MjSpec,
        path: str | Path,
        joints: Sequence[str] | None = None,
        normalize: Mapping[str, Sequence[float]] | None = None,
        *,
        robot_root: str | None = None,
        self_collision: bool = True,
        keyframe: str | None = None,
    ) -> "RobotModel":
        """Build from a (possibly edited) :class:`mujoco.MjSpec`; ``path`` names the source in messages.

        Unnamed geoms are named in ``spec`` (module docstring); a copy of the spec is kept (:meth:`spec_copy`), so
        later edits of ``spec`` do not reach this model. Options as in :meth:`from_xml`.
        """
        if not isinstance(spec, mujoco.MjSpec):
            raise TypeError(f"RobotModel.from_spec takes a mujoco.MjSpec, got {type(spec).__name__}")
        if not isinstance(path, (str, os.PathLike)):  # was pathlib's "expected str, bytes or os.PathLike object"
            raise TypeError(f"`path` (the MJCF file the spec came from; it names the model in messages) must be a path, got {path!r}")
        if isinstance(joints, str):
            raise TypeError(f"`joints` must be a sequence of joint names, got the string {joints!r} (write [{joints!r}])")
        if joints is not None:
            joints = list(joints)
            for i, name in enumerate(joints):  # mj_name2id dereferences a None name: the interpreter dies
                if not isinstance(name, str):
                    raise TypeError(f"`joints` must be joint names (strings), got {name!r} at position {i}")
        normalize = checked_normalize(normalize)
        for name, value in (("robot_root", robot_root), ("keyframe", keyframe)):  # an int was mj_name2id's TypeError
            if value is not None and not isinstance(value, str):
                raise TypeError(f"`{name}` must be a name (a string) or None, got {value!r}")
        if not isinstance(self_collision, (bool, np.bool_)):  # "no" is truthy: self-collision would stay on
            raise TypeError(f"`self_collision` must be True or False, got {self_collision!r}")
        p = Path(path)
        twin = spec.copy()  # never compiled: the copy that spec_copy hands out (see mjcf.uncompiled_twin)
        compile_spec(spec, p)
        name_unnamed_geoms(spec)
        m = compile_spec(spec, p)
        xml = None
        if keyframe is not None:
            k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, keyframe)
            if k < 0:
                known = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_KEY, i) for i in range(m.nkey)]
                raise ModelError(f"{p}: keyframe '{keyframe}' is not in the model (keyframes: {known})")
            placed = spec.copy()
            if place_mocap_bodies(placed, m, k, p):  # planned on the scene as saved (scene_xml), as an edited scene
                xml = scene_xml(placed, p)
                spec = mujoco.MjSpec.from_string(xml)
                twin = spec.copy()
                m = compile_spec(spec, p)
        root = None
        if robot_root is not None:
            root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, robot_root)
            if root < 0:
                names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, m.nbody)]
                known = [name for name in names if name]  # an unnamed body was listed as None
                unnamed = f"; {len(names) - len(known)} unnamed: name the root in the MJCF" if len(known) < len(names) else ""
                raise ModelError(f"{p}: robot_root {unknown_names([robot_root], known)} is not a body of the model (bodies: {known}{unnamed})")
        by_default = joints is None and _custom_text(m, CONFIGURATION_FIELD) is None  # every limited hinge/slide
        if root is not None and by_default:
            in_root = body_subtree(m, root)
            joints = [
                _joint_name(m, j)
                for j in range(m.njnt)
                if in_root[int(m.jnt_bodyid[j])] and int(m.jnt_type[j]) in _SUPPORTED_JOINTS and m.jnt_limited[j]
            ]
            if not joints:
                raise ModelError(f"{p}: robot_root '{robot_root}' has no limited hinge or slide joint in its subtree")
        config = _configuration_map(m, p, joints, normalize)
        if keyframe is not None:
            config = dataclasses.replace(config, qpos0=np.array(m.key_qpos[k]))
        coupled = coupling_equalities(m, config)
        held_by_equality: dict[str, list[str]] = {}
        # The default configuration holds the joints they tie (a gripper's coupled fingers) if others remain; a
        # joint the user normalizes is meant to be planned, so the refusal below says why it cannot be.
        tied = {n for names in coupled.values() for n in names}
        if coupled and by_default and not tied & set(normalize or {}):
            rest = [n for n in config.joint_names if n not in tied]
            narrowed = _configuration_map(m, p, rest, normalize) if rest else None
            if narrowed is not None and keyframe is not None:
                narrowed = dataclasses.replace(narrowed, qpos0=np.array(m.key_qpos[k]))
            if narrowed is not None and not coupling_equalities(m, narrowed):
                config, held_by_equality, coupled = narrowed, coupled, {}
        if coupled:
            raise ModelError(coupling_refusal(m, p, coupled, config))
        moves = geom_moved_by(m, config)
        tendons = binding_tendon_limits(m, config)
        if tendons:
            raise ModelError(
                f"{p}: limited tendon(s) {'; '.join(tendons)}: MuJoCo keeps that length within its range, a constraint "
                "between joints that the planner, which keeps each configuration joint within its own range only, would not "
                "follow (the path could leave it and the robot would not): widen the range to what the joint ranges allow, "
                "remove the limit (limited=\"false\") or plan over joints it does not touch (--joints)"
            )
        if root is not None:
            in_robot = body_subtree(m, root)
            outside = [n for n, j in zip(config.joint_names, config.joint_ids) if not in_robot[int(m.jnt_bodyid[j])]]
            if outside:
                raise ModelError(f"{p}: configuration joint(s) {outside} are not in the subtree of robot_root '{robot_root}'")
            is_robot = in_robot[m.geom_bodyid]
        else:
            is_robot = moves.any(axis=1)
        all_pairs = collision_pairs(m)
        live = sorted({g for pr in all_pairs for g in pr} | {g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]})
        robot = [g for g in live if is_robot[g]]
        obstacles = [g for g in live if not is_robot[g]]
        # robot/obstacle pairs whatever contype/conaffinity and <exclude> say (module docstring)
        all_pairs = sorted(set(all_pairs) | {(min(a, b), max(a, b)) for a in robot for b in obstacles if not attached(m, a, b)})
        if not robot:
            n = int(np.count_nonzero(is_robot))
            raise ModelError(f"{p}: no collision geom is attached to the robot (a body moved by a configuration joint)"
                             + (f": its {n} geom{'s' * (n > 1)} {('is', 'are all')[n > 1]} visual only (contype = conaffinity = 0, "
                                "maybe from a default class): give the collision ones contype=\"1\" conaffinity=\"1\"" if n else ""))
        pairs, self_pair, fixed, d0 = [], [], [], reference_data(m, config)
        for a, b in all_pairs:
            if not (is_robot[a] or is_robot[b]):
                continue
            both = bool(is_robot[a] and is_robot[b])
            if both and not self_collision:
                continue
            active = pair_coordinates(m, config, moves, a, b, d0)
            if not active.any():
                fixed.append((a, b))
                continue
            pairs.append((a, b) if is_robot[a] else (b, a))
            self_pair.append(both)
        check_no_flex(m, p)
        check_sizes(m, pairs, p)
        if not pairs:
            what = "any obstacle geom" + (" or with itself" if self_collision else "")
            nm = lambda g: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"
            left = ", ".join(f"{nm(a)} / {nm(b)} {mujoco.mj_geomDistance(m, d0, a, b, 1.0, None):.4f} m"
                             for a, b in (pr if is_robot[pr[0]] else pr[::-1] for pr in fixed))  # a pan-only arm over its floor or coaxial pedestal: no joint changes these
            raise ModelError(f"{p}: no robot geom can collide with {what} (no obstacles, or contype/conaffinity and "
                             "<contact><exclude> filter every pair, or no configuration joint moves the geoms of a pair"
                             + (f": {left}, whose distance no configuration joint changes" if left else "") + "); to "
                             "time a free motion, add a small obstacle beyond the robot's reach (a sphere the links turn about)")
        order = sorted(range(len(pairs)), key=lambda i: pairs[i])
        pairs, self_pair = [pairs[i] for i in order], [self_pair[i] for i in order]
        active = np.array([pair_coordinates(m, config, moves, a, b, d0) for a, b in pairs], dtype=bool).reshape(-1, config.dim)
        checked = sorted({g for pr in pairs for g in pr})
        check_mesh_hulls(spec, m, checked, p)
        hfields = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}" for g in checked
                   if int(m.geom_type[g]) == mujoco.mjtGeom.mjGEOM_HFIELD]
        if hfields:
            raise ModelError(
                f"{p}: collision geom(s) {hfields} are height fields, which MuJoCo's distance sensors (the planner's "
                "batched distance queries) do not support; model that terrain with boxes or a [[mesh]] obstacle"
            )
        out = cls(
            p,
            m,
            config,
            np.array(robot, dtype=int),
            np.array(obstacles, dtype=int),
            np.array(pairs, dtype=int),
            self_pair=np.array(self_pair, dtype=bool),
            pair_active=active,
            moves=moves,
            fixed_pairs=np.array(fixed, dtype=int).reshape(-1, 2),
            robot_root=robot_root,
            self_collision=self_collision,
            held_by_equality=held_by_equality,
        )
        out.spec = uncompiled_twin(twin, spec)
        out.xml = xml
        return out

    def spec_copy(self) -> mujoco.MjSpec:
        """A fresh, editable copy of the spec this model was compiled from (e.g. to add sensors)."""
        if self.spec is None:
            spec = load_spec(self.path)
            name_unnamed_geoms(spec)
            return spec
        return self.spec.copy()

    # -- configuration helpers -------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        return self.config.dim

    @property
    def lower(self) -> np.ndarray:
        return self.config.lower

    @property
    def upper(self) -> np.ndarray:
        return self.config.upper

    def geom_name(self, g: int) -> str:
        return mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, int(g)) or f"geom{g}"

    def geom_label(self, g: int) -> str:
        """The geom's name for a message: a geom the MJCF left unnamed (``geom<i>`` here, :func:`name_unnamed_geoms`)
        with the body it is on, "geom16 (on body link1)", which a user can find in the MJCF."""
        name = self.geom_name(g)
        if name.rstrip("_") != f"geom{int(g)}":
            return name
        body = int(self.model.geom_bodyid[int(g)])
        return f"{name} (on body {mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, body) or body})"

    @cached_property
    def displacement_bound(self) -> DisplacementBound:
        """The bubble bound's rho per geom and coordinate (:class:`foam_mj.bubbles.DisplacementBound`), computed once
        (5 ms on the leg): the oracle, the scenario checks' and replays' distance cap share it."""
        from foam_mj.bubbles import DisplacementBound

        return DisplacementBound.from_model(self)

    @cached_property
    def fixed_distances(self) -> tuple[tuple[int, int, float], ...]:
        """(robot geom, other geom, distance) of every pair in ``fixed_pairs``, robot/obstacle and (with self-collision)
        robot/robot: no configuration joint changes these distances, so they are measured once (at ``qpos0``)."""
        m = self.model
        robot = {int(g) for g in self.robot_geoms}
        d = mujoco.MjData(m)
        d.qpos[:] = self.config.qpos0
        mujoco.mj_kinematics(m, d)
        pairs = ((int(a), int(b)) if int(a) in robot else (int(b), int(a)) for a, b in self.fixed_pairs)
        return tuple((a, b, float(geom_distance(m, d, a, b, FIXED_DISTMAX))) for a, b in pairs)

    @property
    def fixed_obstacle_distances(self) -> tuple[tuple[int, int, float], ...]:
        """The robot/obstacle pairs of :attr:`fixed_distances` (robot/robot pairs no joint changes are left out by the
        checkers too: ``plan`` names those within delta in a note)."""
        robot = {int(g) for g in self.robot_geoms}
        return tuple(t for t in self.fixed_distances if t[1] not in robot)

    def check_fixed_pairs(self, delta: float) -> None:
        """:class:`ConfigurationError` for a robot/obstacle pair closer than ``delta`` whose distance no configuration
        joint changes (a base on the floor turned by a vertical axis, a held stance foot under ``robot_root``): left out
        of the planner's pairs (``fixed_pairs``), yet ``foam-mj verify`` and MuJoCo-only checkers count it."""
        for a, b, dist in self.fixed_obstacle_distances:
            # Turned about its axis, a pair at delta itself (Sawyer's base) read rounding noise below it in verify.
            if dist <= delta + FIXED_TOLERANCE * max(1.0, abs(delta)):
                where = "at" if dist > delta - FIXED_TOLERANCE * max(1.0, abs(delta)) else "within"
                raise ConfigurationError(
                    f"robot geom {self.geom_label(a)} and obstacle {self.geom_label(b)} are {clearance_text(dist, delta)} "
                    f"apart, {where} the safety margin delta {delta} m, and no configuration joint changes that distance, "
                    "so every path would break the margin (move one of them, give the geom contype=\"0\" conaffinity=\"0\" "
                    "if it never meets the obstacle, make a joint between them a configuration joint"
                    + (", or plan with a smaller delta)" if dist > 0 else ")") + ("" if self.moves[a].any() else
                    f"; {self.geom_name(a)} is held where qpos0 or the keyframe puts it (a floating base's stance foot): lift it "
                    "clear with a keyframe (keyframe = \"NAME\" in a scenario, or --start NAME), or leave robot_root out: "
                    "held bodies outside the robot stay where they stand as obstacles, with a note"))

    @property
    def fixed_obstacle_clearance(self) -> float:
        """The smallest distance of the robot/obstacle pairs no configuration joint changes (inf without one): part of
        every pose's clearance, which the replays' :class:`~foam_mj.clearance.Clearance` leaves out with the pairs."""
        return min((dist for _, _, dist in self.fixed_obstacle_distances), default=float("inf"))

    @cached_property
    def contact_reach(self) -> tuple[tuple[int, int, float], ...]:
        """(geom, geom, distance) of every checked pair MuJoCo's collision detection tests whose contact acts before
        the geoms touch: margin - gap > 0 (the larger margin and gap of the two geoms, the ``<contact><pair>``'s own,
        or the ``o_margin`` override), the distance at which MuJoCo's contact force starts. None when the model disables
        contacts or constraints (``<flag contact="disable"/>``, ``constraint``): no contact force ever acts then."""
        m = self.model
        if int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT):
            return ()
        explicit = {(min(int(a), int(b)), max(int(a), int(b))): i for i, (a, b) in enumerate(zip(m.pair_geom1, m.pair_geom2))}
        override = bool(int(m.opt.enableflags) & int(mujoco.mjtEnableBit.mjENBL_OVERRIDE))
        tested = set(collision_pairs(m))
        out = []
        for a, b in self.pairs:
            key = (min(int(a), int(b)), max(int(a), int(b)))
            if key not in tested:
                continue
            if key in explicit:
                margin, gap = float(m.pair_margin[explicit[key]]), float(m.pair_gap[explicit[key]])
            else:
                margin, gap = float(max(m.geom_margin[a], m.geom_margin[b])), float(max(m.geom_gap[a], m.geom_gap[b]))
            if override:
                margin = float(m.opt.o_margin)
            if margin - gap > 0:
                out.append((int(a), int(b), margin - gap))
        return tuple(out)

    def check_margins(self, delta: float) -> None:
        """:class:`ConfigurationError` for a checked pair whose MuJoCo contact acts farther out than ``delta``
        (:attr:`contact_reach`: a geom ``margin`` less its ``gap``). Margins change no distance the planner measures,
        but MuJoCo's contact pushes such geoms apart before they touch, so a path ``delta`` from an obstacle would be
        pushed off in simulation (the dynamic replay, the user's own)."""
        m = self.model
        for a, b, reach in self.contact_reach:
            if reach > delta:
                paired = {a, b} in [{int(g), int(h)} for g, h in zip(m.pair_geom1, m.pair_geom2)]
                where = ("<option o_margin> (its override flag is on)" if int(m.opt.enableflags) & int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)
                         else "their <contact><pair>" if paired else "those geoms")
                raise ConfigurationError(
                    f"collision geoms {self.geom_label(a)} and {self.geom_label(b)} have a contact margin: MuJoCo's contact "
                    f"between them acts from {reach:.6g} m (margin less gap), farther out than the safety margin delta "
                    f"{delta} m, so a planned path would be pushed off in simulation; raise delta to at least {reach:.6g} m "
                    f"(--delta), or set margin=\"0\" (or a gap as large) on {where}"
                )

    def validate(self, q: ArrayLike, name: str = "q", *, check_bounds: bool = True) -> np.ndarray:
        """Return q as a float array of shape (n,), or raise ConfigurationError saying what is wrong."""
        try:
            if not _real_numbers(q):  # True as 1.0, 0.2+1j as 0.2 (numpy only warns), "0.2" as 0.2 or None as nan
                raise TypeError
            arr = np.asarray(q, dtype=float)
        except (TypeError, ValueError):
            raise ConfigurationError(f"{name} must be a sequence of {self.dim} real numbers, got {q!r}") from None
        if arr.shape != (self.dim,):
            m = self.model
            unlimited = [_joint_name(m, j) + (' (its range is not applied: limited="false")' if np.any(m.jnt_range[j]) else "")
                         for j in range(m.njnt) if int(m.jnt_type[j]) in _SUPPORTED_JOINTS
                         and not m.jnt_limited[j] and j not in set(int(k) for k in self.config.joint_ids)]
            why = f"; not configuration joints (no range: held at qpos0): {', '.join(unlimited)}" if unlimited else ""
            for eq, names in self.held_by_equality.items():
                why += (f"; not configuration joints (tied to other motion by equality constraint {describe_equality(m, eq)}, which the "
                        f"planner would not follow: held at their pose): {', '.join(names)}")
            got = f"{arr.size}" if arr.ndim == 1 else f"an array of shape {arr.shape}"
            raise ConfigurationError(f"{name} must be {self.dim} number{'s' * (self.dim != 1)}, one per configuration joint "
                                     f"({', '.join(self.config.joint_names)}), got {got}{why}")
        if not np.all(np.isfinite(arr)):
            raise ConfigurationError(f"{name} must be finite, got {arr.tolist()}")
        if check_bounds:
            bad = np.flatnonzero((arr < self.lower) | (arr > self.upper))
            if bad.size:
                i = int(bad[0])
                raise ConfigurationError(
                    f"{name}[{i}] ({self.config.joint_names[i]}) = {arr[i]:.6g} is outside its bounds "
                    f"[{self.lower[i]:.6g}, {self.upper[i]:.6g}]{degrees_hint(self.model, self.config, i, float(arr[i]))}"
                )
        return arr

    def validate_batch(self, Q, name: str = "Q") -> np.ndarray:
        """Return Q as a float array of shape (N, n), or raise ConfigurationError (bounds are not checked)."""
        try:
            if not _real_numbers(Q):  # as in validate
                raise TypeError
            arr = np.asarray(Q, dtype=float)
        except (TypeError, ValueError):
            raise ConfigurationError(f"{name} must be an (N, {self.dim}) array of real numbers, got {Q!r}") from None
        if arr.ndim != 2 or arr.shape[1] != self.dim:
            raise ConfigurationError(f"{name} must have shape (N, {self.dim}), got shape {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ConfigurationError(f"{name} must be finite")
        return arr

    def set_configuration(self, q: np.ndarray, data: mujoco.MjData | None = None) -> mujoco.MjData:
        """Set qpos from q (validated: shape, finite; bounds not checked) and run forward kinematics
        (``mj_kinematics``); returns the MjData used (by default the calling thread's own)."""
        q = self.validate(q, check_bounds=False)
        d = data if data is not None else getattr(self._local, "data", None)
        if d is None:
            d = self._local.data = mujoco.MjData(self.model)
        d.qpos[:] = self.config.to_qpos(q)
        mujoco.mj_kinematics(self.model, d)
        return d

    def in_collision(self, q: np.ndarray, data: mujoco.MjData | None = None) -> bool:
        """MuJoCo's own contact detection (``mj_collision``): True when a checked pair (robot/obstacle, or
        robot/robot with self-collision on) touches.

        This is independent of the clearance code and is what tests use to check bubbles.
        """
        d = self.set_configuration(q, data)
        mujoco.mj_collision(self.model, d)
        g = d.contact.geom[: d.ncon]
        if len(g) == 0:
            return False
        hit = np.asarray(d.contact.dist[: d.ncon]) <= 0
        return bool(np.any(hit & self.pair_table[g[:, 0], g[:, 1]]))

    def hull_hint(self, *geoms: int) -> str:
        """"; NAME is a non-convex mesh: ..." for each of ``geoms`` whose mesh has vertices off its convex hull (a notch,
        a U): MuJoCo measures distances to the hull, so a robot that fits the notch reads as in collision there."""
        m, out = self.model, []
        for g in geoms:
            if int(m.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_MESH):
                continue
            mesh = int(m.geom_dataid[g])
            adr = int(m.mesh_graphadr[mesh])
            if adr >= 0 and int(m.mesh_graph[adr]) < int(m.mesh_vertnum[mesh]):
                out.append(self.geom_name(g))
        if not out:
            return ""
        one = len(out) == 1
        return (f"; {' and '.join(out)} {'is a non-convex mesh' if one else 'are non-convex meshes'}: MuJoCo measures distances to "
                f"{'its convex hull, which fills' if one else 'their convex hulls, which fill'} notches (split a mesh into convex parts: "
                "several mesh geoms, or a [[mesh]] obstacle, decomposed)")

    def pair_name(self, p: int) -> tuple[str, str]:
        """Geom names of checked pair p."""
        a, b = self.pairs[p]
        return self.geom_name(a), self.geom_name(b)

    def pair_label(self, p: int) -> str:
        """Checked pair p for a message, "geom8 (on body ff_medial) and peg" (:meth:`geom_label`)."""
        a, b = self.pairs[p]
        return f"{self.geom_label(a)} and {self.geom_label(b)}"


def require_robot_model(robot, hint: str = "") -> None:
    """ValueError naming the argument unless ``robot`` is a :class:`RobotModel` (``hint`` appended to the message)."""
    if not isinstance(robot, RobotModel):
        raise ValueError(f"`robot` must be a RobotModel, got {type(robot).__name__}{hint}")


def _real_numbers(values) -> bool:
    """Are ``values`` (array-like) real numbers: no booleans, complex numbers, strings or None?"""
    a = np.asarray(values)
    if a.dtype.kind == "O":
        return all(isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)) for v in a.ravel())
    return a.dtype.kind in "iuf"
