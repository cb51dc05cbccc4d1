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
``world/leg/<name>/<body>/<geom>``          the body's geoms, static, with their pose in the body: in the
                                            model's colours, or (``tint``) translucent in the path's colour
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

Colours: every path has one colour of :data:`PATH_PALETTE` (a paper's path always the same one, by its place in
:data:`PATH_COLOR_ORDER`; any other name the first colour not yet taken), on its curves in ``cspace``, its end bodies'
trace and its plots: the one series of a plot (clearance, convergence ``best``) in the colour itself, a plot's series
per joint in shades of it (the first joint the colour itself, the next ones alternately darker and lighter; ``mean``
darker); a Pareto front's knee in the colour, its other members lighter. In ``foam-mj plan`` and ``replay`` recordings, the robot of the main path (``optimal`` when there, else the
last: :func:`foam_mj.recorder.primary_path`) keeps the model's colours; every other path's robot is tinted,
translucent (opacity :data:`TINT_ALPHA`), so overlaid robots are told apart at once.

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
import rerun as rr
import rerun.blueprint as rrb
from rerun.chunk import RrdReader

from foam_mj.atomic import atomic_write_bytes
from foam_mj.geom_pairs import body_is_moving
from foam_mj.model import RobotModel
from foam_mj.replay import DynamicReplay, KinematicReplay
from foam_mj.rosary import Rosary
from foam_mj.trajectory import Trajectory

if TYPE_CHECKING:  # imported where used: a recording needs no k-d tree (foam_mj.foam loads scipy.spatial)
    from foam_mj.foam import Foam

#: Names given to the log_* methods become entity path parts: letters, digits, '_', '-', '.'.
NAME_PATTERN = re.compile(r"^[A-Za-z0-9_.\-]+$")
#: Half-extent (metres) drawn for an infinite MuJoCo plane (size 0).
INFINITE_PLANE = 5.0

_PLANE_RGBA = (0.55, 0.6, 0.65, 1.0)
_FOAM_RGBA = (0.6, 0.6, 0.6, 0.25)
_ROSARY_RGBA = (0.2, 0.5, 0.9, 0.35)
#: The path colours (RGB), one per path of a recording: a path named in :data:`PATH_COLOR_ORDER` takes the colour at its
#: place there (the same in every recording), any other name the first colour no path of the recording has taken yet.
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


def _sanitize(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.\-]", "_", name) or "_"


def _rgba(rgba) -> np.ndarray:
    return (np.clip(np.asarray(rgba, dtype=float), 0.0, 1.0) * 255).round().astype(np.uint8)


def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo quaternions (w, x, y, z) -> Rerun's (x, y, z, w), any leading shape."""
    q = np.asarray(wxyz, dtype=float)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


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


#: MuJoCo's default geom rgba: a geom that keeps it and has a material is drawn in the material's colour.
_DEFAULT_GEOM_RGBA = (0.5, 0.5, 0.5, 1.0)


#: Geom groups from this one on are hidden in MuJoCo's viewer by default (Menagerie's collision geoms: group 3); they
#: are drawn with at most this opacity, so that the visual geoms they enclose show through.
HIDDEN_GROUP = 3
HIDDEN_ALPHA = 0.4


def geom_rgba(m: mujoco.MjModel, g: int) -> np.ndarray:
    """Geom g's colour as MuJoCo draws it: its own rgba, or its material's when it has one and its rgba is the default
    (Menagerie's meshes are coloured by materials only: every one of them was drawn grey); translucent (alpha at most
    :data:`HIDDEN_ALPHA`) in a group MuJoCo's viewer hides (a Panda's grey collision hulls hid its visual meshes)."""
    mat = int(m.geom_matid[g])
    rgba = np.array(m.mat_rgba[mat] if mat >= 0 and np.array_equal(m.geom_rgba[g], np.float32(_DEFAULT_GEOM_RGBA)) else m.geom_rgba[g])
    if m.geom_group[g] >= HIDDEN_GROUP:
        rgba[3] = min(rgba[3], HIDDEN_ALPHA)
    return rgba


def geom_archetype(m: mujoco.MjModel, g: int, rgba=None) -> Any | None:
    """The Rerun shape of geom g in its own frame (None for types not drawn: height fields, SDFs), in ``rgba``
    (default: :func:`geom_rgba`)."""
    t = int(m.geom_type[g])
    size = m.geom_size[g]
    color = [_rgba(geom_rgba(m, g) if rgba is None else rgba)]
    T = mujoco.mjtGeom
    if t == T.mjGEOM_PLANE:
        hx, hy = (s if s > 0 else INFINITE_PLANE for s in size[:2])
        return rr.Boxes3D(half_sizes=[[hx, hy, 0.0]], colors=[_rgba(_PLANE_RGBA)], fill_mode="solid")
    if t == T.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[size[:3]], colors=color, fill_mode="solid")
    if t == T.mjGEOM_SPHERE:
        return rr.Ellipsoids3D(half_sizes=[[size[0]] * 3], colors=color, fill_mode="solid")
    if t == T.mjGEOM_ELLIPSOID:
        return rr.Ellipsoids3D(half_sizes=[size[:3]], colors=color, fill_mode="solid")
    if t == T.mjGEOM_CAPSULE:  # MuJoCo's is centred on the origin; Rerun's runs from 0 to length along +z
        return rr.Capsules3D(lengths=[2 * size[1]], radii=[size[0]], translations=[[0.0, 0.0, -size[1]]], colors=color)
    if t == T.mjGEOM_CYLINDER:
        return rr.Cylinders3D(lengths=[2 * size[1]], radii=[size[0]], colors=color, fill_mode="solid")
    if t == T.mjGEOM_MESH:  # compiled mesh vertices are expressed in the geom's frame
        mid = int(m.geom_dataid[g])
        va, vn = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
        fa, fn = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
        return rr.Mesh3D(
            vertex_positions=m.mesh_vert[va : va + vn],
            triangle_indices=m.mesh_face[fa : fa + fn],
            albedo_factor=color[0],
        )
    return None


def _geom_name(m: mujoco.MjModel, g: int) -> str:
    return _sanitize(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}")


def _body_name(m: mujoco.MjModel, b: int) -> str:
    return _sanitize(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}")


class Recording:
    """A Rerun recording written to ``path`` (see the module docstring for entity paths). Use as a
    context manager, or call :meth:`close` to write the file's footer."""

    def __init__(self, path: str | Path, app_id: str = "foam-mj", recording_id: str | None = None) -> None:
        p = Path(path)
        if p.suffix != ".rrd":
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
        self._stream = self._rec.binary_stream()
        self._rec.send_blueprint(default_blueprint(), make_active=False, make_default=True)
        self._rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._rec.log("cspace", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._open = True
        self._colors: dict[str, int] = {}  # path name -> index in PATH_PALETTE

    # -- lifecycle -------------------------------------------------------------------------------------
    def close(self) -> None:
        """Write the file (complete, renamed into place; :class:`~foam_mj.atomic.OutputError` when it
        cannot be written, leaving nothing behind). Idempotent."""
        if self._open:
            self._open = False
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
        name = _name(name)
        if name not in self._colors:
            taken = set(self._colors.values())
            n = len(PATH_PALETTE)
            preferred = PATH_COLOR_ORDER.index(name) if name in PATH_COLOR_ORDER else None
            free = [i for i in range(n) if i not in taken]
            if preferred is not None and preferred not in taken:
                self._colors[name] = preferred
            elif free:
                self._colors[name] = free[0]
            else:  # more paths than colours: the palette again, in order
                self._colors[name] = len(self._colors) % n
        return _rgba((*PATH_PALETTE[self._colors[name]], 1.0))

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
        if not isinstance(robot, RobotModel):
            raise ValueError(f"`robot` must be a RobotModel, got {type(robot).__name__}")
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
        m = robot.model
        poses = replay.poses
        T = replay.n_frames
        color = self.path_color(name)
        index = [rr.TimeColumn("time", duration=replay.times), rr.TimeColumn("frame", sequence=np.arange(T))]
        for k, b in enumerate(poses.body_ids):
            body = f"world/leg/{name}/{_body_name(m, int(b))}"
            for g in np.flatnonzero(m.geom_bodyid == b):
                rgba = None
                if tint:
                    rgba = np.append(color[:3] / 255.0, min(TINT_ALPHA, float(geom_rgba(m, int(g))[3])))
                shape = geom_archetype(m, int(g), rgba)
                if shape is None:
                    continue
                rec.log(
                    f"{body}/{_geom_name(m, int(g))}",
                    rr.Transform3D(translation=m.geom_pos[g], quaternion=rr.Quaternion(xyzw=_xyzw(m.geom_quat[g]))),
                    shape,
                    static=True,
                )
            rec.send_columns(
                body,
                indexes=index,
                columns=rr.Transform3D.columns(translation=poses.xpos[:, k], quaternion=_xyzw(poses.xquat[:, k])),
            )
        ids = [int(b) for b in poses.body_ids]
        ends = [k for k, b in enumerate(ids) if not any(int(m.body_parentid[c]) == b for c in ids)]
        rec.log(f"world/traces/{name}", rr.LineStrips3D([poses.xpos[:, k] for k in ends], colors=[color], radii=[0.003], labels=[name]), static=True)
        self._scalars(f"plots/clearance/{name}", index, replay.clearance, ["clearance (m)"], self._series_colors(name, 1))
        if isinstance(replay, DynamicReplay):
            self.log_tracking(name, replay)

    def log_tracking(self, name: str, replay: DynamicReplay) -> None:
        """A servo replay's tracking error per joint at ``plots/tracking/<name>`` and its contacts at
        ``world/contacts/<name>`` (no poses: :meth:`log_replay` of the kinematic replay shows the planned motion)."""
        rec = self._check_open()
        name = _name(name)
        if not isinstance(replay, DynamicReplay):
            raise ValueError(f"`replay` must be a DynamicReplay, got {type(replay).__name__}")
        index = [rr.TimeColumn("time", duration=replay.times), rr.TimeColumn("frame", sequence=np.arange(replay.n_frames))]
        self._scalars(f"plots/tracking/{name}", index, replay.error, [f"{joint} error" for joint in replay.joint_names],
                      self._series_colors(name, len(replay.joint_names)))
        if replay.contacts:
            frames = np.array([c.frame for c in replay.contacts])
            uniq, start = np.unique(frames, return_index=True)
            counts = np.diff(np.append(start, len(frames)))
            pos = np.array([c.position for c in replay.contacts])
            rec.send_columns(
                f"world/contacts/{name}",
                indexes=[rr.TimeColumn("time", duration=replay.times[uniq]), rr.TimeColumn("frame", sequence=uniq)],
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

    def log_bubbles(self, centers, radii, q_init, q_goal, rosary: Rosary | None = None) -> None:
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
        for key, q, color in (("q_init", q_init, (0.1, 0.8, 0.1, 1.0)), ("q_goal", q_goal, (0.9, 0.1, 0.1, 1.0))):
            rec.log(f"cspace/{key}", rr.Points3D([_points3(q, f"foam.{key}")], radii=[0.02], colors=[_rgba(color)], labels=[key]), static=True)

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
        index = [rr.TimeColumn("time", duration=trajectory.times), rr.TimeColumn("frame", sequence=np.arange(T))]
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
        index = [rr.TimeColumn("time", duration=loads.times), rr.TimeColumn("frame", sequence=np.arange(T))]
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


# -- reading back (tests, inspection) ----------------------------------------------------------------------
def _store_chunks(path: str | Path, blueprint: bool = False):
    reader = RrdReader(Path(path))
    if blueprint:
        stores = reader.blueprints()
        if not stores:
            return []
        return list(reader.stream(store=stores[0]))
    return list(reader.stream())


def read_recording(path: str | Path, static: bool | None = None) -> dict[str, int]:
    """Entity path (as logged, no leading '/') -> total rows over all chunks of the recording store of an
    ``.rrd`` file: all rows (``static=None``), only static ones (True) or only temporal ones (False).
    Internal entities (``__properties``) are left out. Raises on a file without its footer (not closed)."""
    RrdReader(Path(path)).store()  # raises on a file without footer/manifest
    rows: dict[str, int] = {}
    for ch in _store_chunks(path):
        entity = str(ch.entity_path).lstrip("/")
        if entity.startswith("__") or (static is not None and bool(ch.is_static) != static):
            continue
        rows[entity] = rows.get(entity, 0) + int(ch.num_rows)
    return rows


def read_component(path: str | Path, entity: str, component: str) -> list:
    """Every row's value of ``component`` (e.g. "Ellipsoids3D:centers") at ``entity``, in file order,
    as Python lists (pyarrow ``to_pylist``); rows where the component is absent are skipped."""
    out: list = []
    for ch in _store_chunks(path):
        if str(ch.entity_path).lstrip("/") != entity.lstrip("/"):
            continue
        batch = ch.to_record_batch()
        if component in batch.schema.names:
            out.extend(v for v in batch.column(component).to_pylist() if v is not None)
    return out


def read_blueprint(path: str | Path) -> list[dict[str, str | None]]:
    """The views of the blueprint stored in an ``.rrd`` file: [{"class": "3D", "origin": "world", "name": ...}]."""
    views: dict[str, dict[str, str | None]] = {}
    for ch in _store_chunks(path, blueprint=True):
        entity = str(ch.entity_path)
        batch = ch.to_record_batch()
        for column, key in (("ViewBlueprint:class_identifier", "class"), ("ViewBlueprint:space_origin", "origin"), ("ViewBlueprint:display_name", "name")):
            if column in batch.schema.names:
                for v in batch.column(column).to_pylist():
                    if v:
                        views.setdefault(entity, {"class": None, "origin": None, "name": None})[key] = v[0]
    return list(views.values())
