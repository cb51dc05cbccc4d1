"""Rerun recordings (``.rrd`` files, no viewer) of a planning run: the scene and the replayed leg, the
foam and paths in configuration space, and plots.

Usage::

    with Recording("run.rrd") as rec:
        rec.log_scene(robot)
        rec.log_foam(result.foam, result.rosary)
        rec.log_path("centre", path)
        rec.log_joint_trajectory("centre", trajectory)
        rec.log_replay("centre", robot, replay_kinematic(robot, trajectory))
        rec.log_tracking("centre", replay_dynamic(robot, trajectory))
        rec.log_convergence("hs", best, mean)
    # closing writes the file (atomically: complete or not at all); open with `foam-mj view run.rrd`

Entity paths (names given to the ``log_*`` methods must match :data:`NAME_PATTERN`; model names are
sanitized to it):

==========================================  ==========================================================
``world``                                   view coordinates (right-handed, z up), static
``world/scene/<geom>``                      static geoms of the scene (floor, obstacles), world pose
``world/leg/<name>/<body>``                 Transform3D of each leg body per frame (timelines
                                            ``time`` in seconds and ``frame``); ``plan`` and ``replay``
                                            log the planned trajectory (its kinematic replay)
``world/leg/<name>/<body>/<geom>``          the body's geoms but meshes, static, with their pose in the body:
                                            in the model's colours, or (``tint``) translucent in the path's colour
``world/meshes/<group>/<body>/<geom>``      each mesh geom ONCE per group (static), drawn once per robot by
                                            instancing: ``InstancePoses3D``, the geom's world pose per robot
                                            per frame (group ``model``: the main path's robot; ``tinted``: the
                                            others, translucent in the model's colours; static ``q_init``,
                                            ``q_goal``); a path that ended holds its last pose
``world/leg/q_init|q_goal/<body>``          the robot at q_init (model colours) and q_goal (translucent red),
                                            static: a failed plan's recording (:meth:`Recording.log_configurations`)
``world/traces/<name>``                     the path of each end body (foot, hand) in the world, static
``world/contacts/<name>``                   leg/obstacle contacts of a dynamic replay (if any), per frame
``cspace/axes``                             the configuration axes, labelled with the joint names
                                            (for more than 3 joints, cspace shows the first three;
                                            1 or 2 joints: a line or plane, the others 0)
``cspace/foam``                             every bubble of the foam (Ellipsoids3D, equal half-sizes)
``cspace/rosary``                           the rosary's bubbles
``cspace/q_init``, ``cspace/q_goal``        start and goal configurations
``cspace/paths/<name>``                     a configuration path (LineStrips3D)
``cspace/trajectories/<name>``              a trajectory's samples (LineStrips3D)
``cspace/trajectories/<name>/now``          its current configuration per frame (Points3D)
``cspace/fronts/<name>/<i>``                each member of a Pareto front (mgoa, mopso), a line strip
``pareto/<name>``                           the front's (length, angle term) pairs (Points2D)
``plots/convergence/<name>/best|mean``      a smoother's objective per iteration (timeline ``iteration``)
``plots/joints/<name>``                     joint positions in joint units (rad, m) over ``time``/``frame``:
                                            one series per joint, named after it (one entity per path:
                                            a row of n values per frame, not n rows with n index copies)
``plots/clearance/<name>``                  a replay's clearance per frame (metres; of the planned
                                            trajectory in ``plan`` and ``replay``: the summary's min clear)
``plots/tracking/<name>``                   a dynamic replay's tracking error (rad, m), a series per joint
``plots/torque/<name>``                     joint torque (N m) or force (N) from mj_inverse over ``time``/``frame``,
                                            a series per joint
``plots/power/<name>``                      joint mechanical power tau qd (W), a series per joint
==========================================  ==========================================================

Colours: every path has one colour, a function of its name only (:func:`path_color`: a paper's path the colour of
:data:`PATH_PALETTE` at its place in :data:`PATH_COLOR_ORDER`; any other name a hue hashed from the name), on its curves in ``cspace``, its end bodies'
trace and its plots: the one series of a plot (clearance, convergence ``best``) in the colour itself, a plot's series
per joint in shades of it (the first joint the colour itself, the next ones alternately darker and lighter; ``mean``
darker); a Pareto front's knee in the colour, its other members lighter. In ``foam-mj plan`` and ``replay`` recordings, the robot of the main path (``optimal`` when there, else the
last: :func:`foam_mj.recorder.primary_path`) keeps the model's colours; every other path's robot is tinted,
translucent (opacity :data:`TINT_ALPHA`), so overlaid robots are told apart at once. A robot's meshes are the
exception: their geometry is in the file once (every path held a copy), so the
tinted robots share one translucent copy in the model's colours (their primitive geoms keep the path's colour).

The default blueprint (stored in the file) shows the workspace, the configuration space and the plots
side by side. Log time and log tick are disabled and recording properties are not sent, so the
recording store's content is reproducible; the blueprint store carries random view ids, and every file its own
recording id (the stem and 8 random hex digits: Rerun's viewer merges files that share one).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike
import rerun as rr
import rerun.blueprint as rrb

from foam_mj.atomic import atomic_write_bytes
from foam_mj.geom_pairs import body_is_moving
from foam_mj.model import RobotModel, require_robot_model
from foam_mj.recording_geoms import (  # noqa: F401  (geom_rgba, HIDDEN_*, INFINITE_PLANE: re-exported)
    HIDDEN_ALPHA, HIDDEN_GROUP, INFINITE_PLANE, MeshInstances, _body_name, _geom_name, _rgba, _xyzw, geom_archetype, geom_rgba, is_mesh,
    seconds_ns,
)
from foam_mj.recording_read import _store_chunks, read_blueprint, read_component, read_recording  # noqa: F401  (re-exported)
from foam_mj.replay import DynamicReplay, KinematicReplay
from foam_mj.rosary import Rosary
from foam_mj.trajectory import Trajectory

if TYPE_CHECKING:  # imported where used: a recording needs no k-d tree (foam_mj.foam loads scipy.spatial)
    from foam_mj.foam import Foam

#: Names given to the log_* methods become entity path parts: letters, digits, '_', '-', '.'.
NAME_PATTERN = re.compile(r"^[A-Za-z0-9_.\-]+$")
_FOAM_RGBA = (0.6, 0.6, 0.6, 0.25)
_ROSARY_RGBA = (0.2, 0.5, 0.9, 0.35)
_CONFIG_RGBA = {"q_init": (0.1, 0.8, 0.1, 1.0), "q_goal": (0.9, 0.1, 0.1, 1.0)}
#: The colours (RGB) of the built-in paths: a path named in :data:`PATH_COLOR_ORDER` takes the colour at its place there;
#: any other name a colour of its own hashed from the name (:func:`path_color`).
PATH_PALETTE = (
    (0.89, 0.34, 0.35),  # red
    (0.95, 0.56, 0.17),  # orange
    (0.93, 0.79, 0.28),  # yellow
    (0.61, 0.46, 0.37),  # brown
    (0.35, 0.63, 0.31),  # green
    (0.46, 0.72, 0.70),  # teal
    (0.69, 0.48, 0.63),  # purple
    (0.90, 0.20, 0.80),  # magenta
    (0.30, 0.47, 0.65),  # blue
    (1.00, 0.62, 0.65),  # pink
)
PATH_COLOR_ORDER = ("centre", "gradient", "adjusted", "adjusted_gradient", "hs", "ga", "convex", "optimal", "mgoa", "mopso")
#: Opacity of a robot drawn in its path's colour (``log_replay(..., tint=True)``).
TINT_ALPHA = 0.35
#: Saturation and value of a custom path name's colour (its hue hashed from the name).
CUSTOM_SATURATION, CUSTOM_VALUE = 0.65, 0.8


def path_color(name: str) -> np.ndarray:
    """The colour (RGBA, uint8) of path ``name`` in every recording: a built-in path's place in :data:`PATH_PALETTE`
    (by :data:`PATH_COLOR_ORDER`); any other name a hue taken from the BLAKE2 hash of the name (saturation and value
    :data:`CUSTOM_SATURATION`, :data:`CUSTOM_VALUE`), so that a name keeps its colour whatever other paths a recording
    holds and in whatever order they were logged (it took the first palette colour not yet taken: the same custom path
    changed colour from one recording to the next). Two custom names may get close hues (one in 8 within 0.0625 of a
    turn in hue, by chance)."""
    import colorsys
    import hashlib

    if name in PATH_COLOR_ORDER:
        return _rgba((*PATH_PALETTE[PATH_COLOR_ORDER.index(name)], 1.0))
    hue = int.from_bytes(hashlib.blake2b(name.encode(), digest_size=4).digest(), "big") / 2**32
    return _rgba((*colorsys.hsv_to_rgb(hue, CUSTOM_SATURATION, CUSTOM_VALUE), 1.0))


def default_blueprint() -> rrb.Blueprint:
    """Workspace | configuration space | plots (joints, convergence, clearance, tracking), side by side."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="world", name="Workspace"),
            rrb.Spatial3DView(origin="cspace", name="Configuration space"),
            rrb.Vertical(
                rrb.Spatial2DView(origin="pareto", name="Pareto fronts (length vs angle term)"),
                rrb.TimeSeriesView(origin="plots/joints", name="Joint positions"),
                rrb.TimeSeriesView(origin="plots/convergence", name="Smoother convergence"),
                rrb.TimeSeriesView(origin="plots/clearance", name="Clearance"),
                rrb.TimeSeriesView(origin="plots/tracking", name="Tracking error"),
                rrb.TimeSeriesView(origin="plots/torque", name="Joint torque (N m, N)"),
                rrb.TimeSeriesView(origin="plots/power", name="Joint power (W)"),
            ),
            column_shares=[2, 2, 1],
        ),
        collapse_panels=False,
    )


def _name(value: Any, field: str = "name") -> str:
    if not (isinstance(value, str) and NAME_PATTERN.match(value)):
        raise ValueError(f"`{field}` must be a non-empty string of letters, digits, '_', '-' or '.', got {value!r}")
    return value


def _points3(points, field: str) -> np.ndarray:
    """Configuration points (..., n) as 3-D points: n = 3 as is, n = 1 or 2 padded with 0 (a line, a plane), n > 3
    projected on the first three coordinates (the projection of an n-ball of radius r is a 3-ball of radius r, so
    the bubbles are drawn faithfully in that projection)."""
    p = np.asarray(points, dtype=float)
    if p.ndim < 1 or p.shape[-1] < 1:
        raise ValueError(f"`{field}` must hold configurations of dimension 1 or more to draw, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"`{field}` must be finite")
    if p.shape[-1] < 3:
        p = np.concatenate([p, np.zeros(p.shape[:-1] + (3 - p.shape[-1],))], axis=-1)
    return p[..., :3]


def _check_replay_of(robot: RobotModel, replay: KinematicReplay | DynamicReplay) -> None:
    """ValueError unless ``replay`` is of ``robot``: its poses were read by body id, so another robot's replay drew that
    robot's geoms at this one's poses, silently."""
    require_robot_model(robot)
    ids, m = replay.poses.body_ids, robot.model
    names = tuple(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(b)) or f"body{int(b)}" if 0 <= int(b) < m.nbody else f"(none: id {int(b)})"
                  for b in ids)
    if replay.qpos.shape[1] != m.nq or names != tuple(replay.poses.body_names):
        raise ValueError(f"`replay` is not a replay of `robot` ({robot.path.name}): its bodies {list(replay.poses.body_names)} and "
                         f"qpos width {replay.qpos.shape[1]}, the robot's bodies at those ids {list(names)} and nq = {m.nq}")


class Recording:
    """A Rerun recording written to ``path`` (see the module docstring for entity paths). Use as a
    context manager, or call :meth:`close` to write the file's footer."""

    def __init__(self, path: str | Path, app_id: str = "foam-mj", recording_id: str | None = None) -> None:
        p = Path(path)
        if p.suffix.lower() != ".rrd":  # X.RRD too: Rerun's viewer reads the suffix lower-cased
            raise ValueError(f"`path` must end in .rrd, got {str(p)!r}")
        if not p.parent.is_dir():
            raise ValueError(f"`path`'s folder does not exist: {p.parent}")
        if not (isinstance(app_id, str) and app_id):
            raise ValueError(f"`app_id` must be a non-empty string, got {app_id!r}")
        self.path = p
        if recording_id is None:
            from foam_mj.recorder import unique_recording_id

            recording_id = unique_recording_id(p.stem)
        self._rec = rr.RecordingStream(app_id, recording_id=recording_id, send_properties=False)
        self._rec.set_log_time_enabled(False)
        self._rec.set_log_tick_enabled(False)
        # The stream goes to memory and reaches the file only in close(), atomically (foam_mj.atomic):
        # Rerun's own file sink reports no write error (a full disk left a truncated file behind).
        self._stream = self._rec.binary_stream()  # type: ignore[misc]  # (rerun-sdk 0.41's annotation of a bound method)
        self._rec.send_blueprint(default_blueprint(), make_active=False, make_default=True)
        self._rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._rec.log("cspace", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._open = True
        self._meshes = MeshInstances()  # the robots' meshes, logged once each in close()

    # -- lifecycle -------------------------------------------------------------------------------------
    def close(self) -> None:
        """Write the file (complete, renamed into place; :class:`~foam_mj.atomic.OutputError` when it
        cannot be written, leaving nothing behind). Idempotent."""
        if self._open:
            self._open = False
            if len(self._meshes):
                self._meshes.log(self._rec)
            data = self._stream.read(flush=True) or b""
            rr.disconnect(recording=self._rec)
            atomic_write_bytes(self.path, data)

    def discard(self) -> None:
        """Close without writing anything."""
        if self._open:
            self._open = False
            self._stream.read(flush=True)  # taken and dropped: else Rerun warns, in its own log format, that it drops it
            rr.disconnect(recording=self._rec)

    def __enter__(self) -> "Recording":
        return self

    def __exit__(self, exc_type, *exc) -> None:
        if exc_type is None:
            self.close()
        else:
            self.discard()  # an error while logging: no partial file

    def _check_open(self) -> rr.RecordingStream:
        if not self._open:
            raise ValueError(f"the recording {self.path} is closed")
        return self._rec

    # -- colours ---------------------------------------------------------------------------------------
    def path_color(self, name: str) -> np.ndarray:
        """Path ``name``'s colour (RGBA, uint8; :data:`PATH_PALETTE`): its curves in configuration space, its robot's
        trace and its plot series (a shade of it per joint) share it, so that overlaid paths are told apart."""
        return path_color(_name(name))

    def _series_colors(self, name: str, k: int) -> np.ndarray:
        """k shades of path ``name``'s colour, one per series (joint): the first is the colour itself, then alternately
        darker and lighter (mixed with black or white, which keeps its hue), at most 60 % of the way."""
        base = self.path_color(name).astype(float)
        steps = max(1, k // 2)
        out = []
        for j in range(k):
            t = 0.6 * ((j + 1) // 2) / steps
            target = 0.0 if j % 2 else 255.0
            out.append(base if j == 0 else np.append(base[:3] + t * (target - base[:3]), 255.0))
        return np.round(out).astype(np.uint8)

    # -- workspace -------------------------------------------------------------------------------------
    def log_scene(self, robot: RobotModel) -> None:
        """The static geoms of the scene at world poses, and the configuration axes named by the joints."""
        rec = self._check_open()
        require_robot_model(robot)
        m = robot.model
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        quat = np.empty(4)
        for g in range(m.ngeom):
            if body_is_moving(m, int(m.geom_bodyid[g])):
                continue
            shape = geom_archetype(m, g)
            if shape is None:
                continue
            mujoco.mju_mat2Quat(quat, d.geom_xmat[g])
            rec.log(
                f"world/scene/{_geom_name(m, g)}",
                rr.Transform3D(translation=d.geom_xpos[g], quaternion=rr.Quaternion(xyzw=_xyzw(quat))),
                shape,
                static=True,
            )
        span = float(np.max(robot.upper - robot.lower))
        k = min(robot.dim, 3)  # n > 3: the first three coordinates (a projection)
        rec.log(
            "cspace/axes",
            rr.Arrows3D(vectors=np.eye(3)[:k] * span, labels=list(robot.config.joint_names)[:k], colors=[[200, 60, 60], [60, 200, 60], [60, 60, 200]][:k]),
            static=True,
        )

    def log_replay(self, name: str, robot: RobotModel, replay: KinematicReplay | DynamicReplay, tint: bool = False) -> None:
        """The leg's geoms (static, per body; with ``tint``, in the path's colour at opacity :data:`TINT_ALPHA` instead
        of the model's colours) and the body poses of every frame of ``replay``; the trace of each end body (a moving
        body with no moving child: a foot, a hand) at ``world/traces/<name>`` in the path's colour; its clearance, and
        for a dynamic replay its tracking errors and contacts (:meth:`log_tracking`)."""
        rec = self._check_open()
        name = _name(name)
        if not isinstance(replay, (KinematicReplay, DynamicReplay)):
            raise ValueError(f"`replay` must be a KinematicReplay or DynamicReplay, got {type(replay).__name__}")
        if not isinstance(tint, bool):
            raise ValueError(f"`tint` must be True or False, got {tint!r}")
        _check_replay_of(robot, replay)
        m = robot.model
        poses = replay.poses
        T = replay.n_frames
        color = self.path_color(name)
        index = [rr.TimeColumn("time", duration=seconds_ns(replay.times)), rr.TimeColumn("frame", sequence=np.arange(T))]
        self._log_geoms(name, m, poses.body_ids, color if tint else None)
        for k, b in enumerate(poses.body_ids):
            rec.send_columns(
                f"world/leg/{name}/{_body_name(m, int(b))}",
                indexes=index,
                columns=rr.Transform3D.columns(translation=poses.xpos[:, k], quaternion=_xyzw(poses.xquat[:, k])),
            )
        self._meshes.add("tinted" if tint else "model", m, poses.body_ids, poses.xpos, poses.xquat, replay.times,
                         TINT_ALPHA if tint else None)
        ids = [int(b) for b in poses.body_ids]
        ends = [k for k, b in enumerate(ids) if not any(int(m.body_parentid[c]) == b for c in ids)]
        rec.log(f"world/traces/{name}", rr.LineStrips3D([poses.xpos[:, k] for k in ends], colors=[color], radii=[0.003], labels=[name]), static=True)
        self._scalars(f"plots/clearance/{name}", index, replay.clearance, ["clearance (m)"], self._series_colors(name, 1))
        if isinstance(replay, DynamicReplay):
            self.log_tracking(name, replay)

    def _log_geoms(self, name: str, m: mujoco.MjModel, body_ids, tint) -> None:
        """The geoms of ``body_ids`` but meshes (:class:`~foam_mj.recording_geoms.MeshInstances` draws those) at
        ``world/leg/<name>/<body>/<geom>``, static: in the model's colours, or translucent in the colour ``tint``."""
        rec = self._check_open()
        for b in body_ids:
            for g in np.flatnonzero(m.geom_bodyid == int(b)):
                if is_mesh(m, int(g)):
                    continue
                rgba = None if tint is None else np.append(tint[:3] / 255.0, min(TINT_ALPHA, float(geom_rgba(m, int(g))[3])))
                shape = geom_archetype(m, int(g), rgba)
                if shape is None:
                    continue
                rec.log(
                    f"world/leg/{name}/{_body_name(m, int(b))}/{_geom_name(m, int(g))}",
                    rr.Transform3D(translation=m.geom_pos[g], quaternion=rr.Quaternion(xyzw=_xyzw(m.geom_quat[g]))),
                    shape,
                    static=True,
                )

    def log_configurations(self, robot: RobotModel, configurations: dict) -> None:
        """The robot at fixed configurations (static; a failed plan's recording shows where the robot was asked to go):
        ``{"q_init": q, "q_goal": q}`` at ``world/leg/<key>/<body>`` (each key a name; q in configuration
        coordinates). The first in the model's colours, the others translucent (:data:`TINT_ALPHA`) in their colour
        (:func:`path_color`; ``q_init`` green and ``q_goal`` red, as their points in configuration space)."""
        rec = self._check_open()
        require_robot_model(robot)
        from foam_mj.replay import leg_bodies

        m = robot.model
        d = mujoco.MjData(m)
        ids = leg_bodies(robot)
        for i, (key, q) in enumerate(configurations.items()):
            key = _name(key, "configurations' key")
            d.qpos[:] = robot.config.to_qpos(robot.validate(q, check_bounds=False))
            mujoco.mj_kinematics(m, d)
            color = _rgba(_CONFIG_RGBA[key]) if key in _CONFIG_RGBA else path_color(key)
            self._log_geoms(key, m, ids, None if i == 0 else color)
            for b in ids:
                rec.log(f"world/leg/{key}/{_body_name(m, int(b))}",
                        rr.Transform3D(translation=d.xpos[b], quaternion=rr.Quaternion(xyzw=_xyzw(d.xquat[b]))), static=True)
            self._meshes.add(key, m, ids, d.xpos[ids][None], d.xquat[ids][None], None, None if i == 0 else TINT_ALPHA)

    def log_tracking(self, name: str, replay: DynamicReplay) -> None:
        """A servo replay's tracking error per joint at ``plots/tracking/<name>`` and its contacts at
        ``world/contacts/<name>`` (no poses: :meth:`log_replay` of the kinematic replay shows the planned motion)."""
        rec = self._check_open()
        name = _name(name)
        if not isinstance(replay, DynamicReplay):
            raise ValueError(f"`replay` must be a DynamicReplay, got {type(replay).__name__}")
        index = [rr.TimeColumn("time", duration=seconds_ns(replay.times)), rr.TimeColumn("frame", sequence=np.arange(replay.n_frames))]
        self._scalars(f"plots/tracking/{name}", index, replay.error, [f"{joint} error" for joint in replay.joint_names],
                      self._series_colors(name, len(replay.joint_names)))
        if replay.contacts:
            frames = np.array([c.frame for c in replay.contacts])
            uniq, start = np.unique(frames, return_index=True)
            counts = np.diff(np.append(start, len(frames)))
            pos = np.array([c.position for c in replay.contacts])
            rec.send_columns(
                f"world/contacts/{name}",
                indexes=[rr.TimeColumn("time", duration=seconds_ns(replay.times[uniq])), rr.TimeColumn("frame", sequence=uniq)],
                columns=rr.Points3D.columns(positions=pos).partition(counts),
            )

    # -- configuration space ---------------------------------------------------------------------------
    def log_foam(self, foam: Foam, rosary: Rosary | None = None) -> None:
        """Every bubble of ``foam`` as a sphere; the rosary (default: the foam's own, if it reached the
        goal) highlighted; q_init and q_goal (:meth:`log_bubbles` with the foam's arrays)."""
        from foam_mj.foam import Foam

        self._check_open()
        if not isinstance(foam, Foam):
            raise ValueError(f"`foam` must be a Foam, got {type(foam).__name__}")
        if rosary is None and foam.goal_bubble is not None:
            rosary = foam.rosary()
        self.log_bubbles(foam.centers, foam.radii, foam.q_init, foam.q_goal, rosary)

    def log_bubbles(self, centers: ArrayLike, radii: ArrayLike, q_init: ArrayLike, q_goal: ArrayLike, rosary: Rosary | None = None) -> None:
        """Bubbles given by their centres (m, n) and radii (m,) as spheres at ``cspace/foam``, ``rosary``
        (if any) highlighted, and the configurations q_init and q_goal."""
        rec = self._check_open()
        centers = _points3(centers, "foam.centers")
        radii = np.asarray(radii, dtype=float)
        if radii.shape != (len(centers),):
            raise ValueError(f"`foam.radii` must have shape ({len(centers)},), got {radii.shape}")
        rec.log(
            "cspace/foam",
            rr.Ellipsoids3D(centers=centers, half_sizes=np.repeat(radii[:, None], 3, axis=1), colors=[_rgba(_FOAM_RGBA)], fill_mode="majorwireframe"),
            static=True,
        )
        if rosary is not None:
            rc = _points3(rosary.centers, "rosary.centers")
            rec.log(
                "cspace/rosary",
                rr.Ellipsoids3D(centers=rc, half_sizes=np.repeat(rosary.radii[:, None], 3, axis=1), colors=[_rgba(_ROSARY_RGBA)], fill_mode="solid"),
                static=True,
            )
        for key, q in (("q_init", q_init), ("q_goal", q_goal)):
            rec.log(f"cspace/{key}", rr.Points3D([_points3(q, f"foam.{key}")], radii=[0.02], colors=[_rgba(_CONFIG_RGBA[key])], labels=[key]), static=True)

    def log_path(self, name: str, points) -> None:
        """A configuration-space path (m, n) as a line strip at ``cspace/paths/<name>``."""
        rec = self._check_open()
        name = _name(name)
        p = _points3(points, "points")
        if p.ndim != 2 or len(p) < 2:
            raise ValueError(f"`points` must have shape (m >= 2, n), got {np.shape(points)}")
        color = self.path_color(name)
        rec.log(f"cspace/paths/{name}", rr.LineStrips3D([p], colors=[color], radii=[0.005], labels=[name]), static=True)

    def log_pareto_front(self, name: str, objectives, paths, knee: int | None = None, objective_names=("length", "angle term")) -> None:
        """A Pareto front: the scatter of its objective pairs at ``pareto/<name>`` (a 2-D view) and every
        member's path as its own line strip at ``cspace/fronts/<name>/<i>`` (selectable one by one): the knee in the
        path's colour, the other members in a lighter shade of it."""
        rec = self._check_open()
        name = _name(name)
        F = np.asarray(objectives, dtype=float)
        P = np.asarray(paths, dtype=float)
        if F.ndim != 2 or F.shape[1] != 2 or len(P) != len(F):
            raise ValueError(f"`objectives` must be (F, 2) with one path per row, got {F.shape} and {P.shape}")
        own, lighter = self._series_colors(name, 3)[[0, 2]]
        colors = [own if i == knee else lighter for i in range(len(F))]
        labels = [f"{i}{' (knee)' if i == knee else ''}: {objective_names[0]} {a:.4f}, {objective_names[1]} {b:.4f}" for i, (a, b) in enumerate(F)]
        rec.log(f"pareto/{name}", rr.Points2D(F, colors=colors, radii=[0.004], labels=labels), static=True)
        for i, p in enumerate(P):
            rec.log(f"cspace/fronts/{name}/{i}", rr.LineStrips3D([_points3(p, "paths")], colors=[colors[i]], radii=[0.002], labels=[labels[i]]), static=True)

    def log_joint_trajectory(self, name: str, trajectory: Trajectory) -> None:
        """Joint positions over time (joint units) at ``plots/joints/<name>`` (a series per joint), and the samples in
        configuration space with a marker following the ``time``/``frame`` timelines."""
        rec = self._check_open()
        name = _name(name)
        if not isinstance(trajectory, Trajectory):
            raise ValueError(f"`trajectory` must be a Trajectory, got {type(trajectory).__name__}")
        T = len(trajectory)
        index = [rr.TimeColumn("time", duration=seconds_ns(trajectory.times)), rr.TimeColumn("frame", sequence=np.arange(T))]
        joints = list(trajectory.joint_names)
        self._scalars(f"plots/joints/{name}", index, trajectory.joint_positions, joints, self._series_colors(name, len(joints)))
        q3 = _points3(trajectory.q, "trajectory.q")
        color = self.path_color(name)
        rec.log(f"cspace/trajectories/{name}", rr.LineStrips3D([q3], radii=[0.003], colors=[color], labels=[name]), static=True)
        rec.send_columns(f"cspace/trajectories/{name}/now", indexes=index, columns=rr.Points3D.columns(positions=q3))
        rec.log(f"cspace/trajectories/{name}/now", rr.Points3D.from_fields(radii=[0.025], colors=[color]), static=True)

    def log_joint_loads(self, name: str, loads) -> None:
        """Joint torques at ``plots/torque/<name>`` and powers at ``plots/power/<name>`` (a series per joint)
        over the ``time``/``frame`` timelines (a :class:`foam_mj.dynamics.JointLoads`)."""
        self._check_open()
        name = _name(name)
        T = len(loads.times)
        index = [rr.TimeColumn("time", duration=seconds_ns(loads.times)), rr.TimeColumn("frame", sequence=np.arange(T))]
        joints = list(loads.joint_names)
        colors = self._series_colors(name, len(joints))
        self._scalars(f"plots/torque/{name}", index, loads.tau, [f"{j} ({u})" for j, u in zip(joints, loads.torque_units)], colors)
        self._scalars(f"plots/power/{name}", index, loads.power, [f"{j} (W)" for j in joints], colors)

    # -- plots -----------------------------------------------------------------------------------------
    def log_convergence(self, name: str, best, mean=None) -> None:
        """A smoother's best (and mean) objective per iteration at ``plots/convergence/<name>/best|mean``."""
        self._check_open()
        name = _name(name)
        curves = {"best": best} if mean is None else {"best": best, "mean": mean}
        arrays = {}
        for key, values in curves.items():
            a = np.asarray(values, dtype=float)
            if a.ndim != 1 or len(a) == 0 or not np.all(np.isfinite(a)):
                raise ValueError(f"`{key}` must be a non-empty 1-D array of finite numbers, got shape {a.shape}")
            arrays[key] = a
        if mean is not None and len(arrays["mean"]) != len(arrays["best"]):
            raise ValueError(f"`best` and `mean` must have the same length, got {len(arrays['best'])} and {len(arrays['mean'])}")
        shades = self._series_colors(name, 2)  # best in the path's colour, mean in a darker shade
        for key, color in zip(arrays, shades):
            index = [rr.TimeColumn("iteration", sequence=np.arange(len(arrays[key])))]
            self._scalars(f"plots/convergence/{name}/{key}", index, arrays[key], [f"{name} {key}"], color[None])

    def _scalars(self, entity: str, index: list, values: np.ndarray, names: list[str], colors: np.ndarray) -> None:
        """Series over ``index``: ``values`` (T,) or (T, k), one series per column, named ``names``, in ``colors``
        (k, 4)."""
        rec = self._check_open()
        rec.log(entity, rr.SeriesLines(names=names, colors=colors), static=True)
        rec.send_columns(entity, indexes=index, columns=rr.Scalars.columns(scalars=np.asarray(values, dtype=float)))
