"""Workspace clearance d(q): the minimum signed distance over the checked geom pairs (``RobotModel.pairs``:
robot/obstacle and robot/robot pairs MuJoCo lets collide), and each pair's distance d_p(q).

Computed with MuJoCo's own distance queries, never with a C-obstacle map:

* one configuration: ``mj_kinematics`` then ``mj_geomDistance`` over every robot/obstacle pair, at most minus a
  capsule's radius where its axis runs through a box (:mod:`foam_mj.capsule_box`: an end point, a report);
* many configurations: the same pairs as ``<distance>`` (geomdist) sensors added to a copy of the model
  with :class:`mujoco.MjSpec` (a lean copy where it compiles: :meth:`Clearance._sensor_model`), evaluated
  for the whole batch in one call by :class:`mujoco.batch.Batch` computing only the position stage
  (``mj_fwdPosition`` and the position sensors; MuJoCo's own ``mj_checkPos`` guard included). Measured on
  the obstacle scene: about 4 us per configuration, against about 10 one by one and 4.5-6 through
  ``mujoco.rollout``, which runs a whole ``mj_step`` for the same sensor values (identical to the last bit:
  the sensors are computed from the same kinematics).

The batch applies the same guard (:meth:`Clearance._guard_capsule_box`): its candidates are not all inside certified
bubbles (bubbletree's extensions reach twice the parent's radius, the corridor's chords fill gaps between bubbles),
so a candidate with a capsule through a box must not read as apart either. The poses come from frame sensors added
beside the distance sensors (each capsule's position and axis, each box's position and axes), read with them; the
test is about fifteen numpy calls per batch over every row at once (the pairs' rows untouched where no segment meets
its box, nearly every batch). Measured on the obstacle scene (seeds 0-9 x 3, interleaved, CPU time): about 40 us per
batch call of 71 configurations, bubbletree's plan x1.07 (binding MuJoCo's geom poses instead cost as much again). The values are MuJoCo's to the last bit wherever no capsule's
segment meets its box, as one configuration at a time: the plans of the shipped scenes are unchanged.

``pair_distances`` and ``batch_pairs`` return every pair's distance (the bubble radius is taken per
pair, ``foam_mj.bubbles``); ``__call__`` and ``batch`` their minimum. All return
``min(signed distance, distmax)``: negative under penetration, capped at ``distmax``
(MuJoCo's semantics: a separated pair farther than ``distmax`` reads ``distmax``).

One :class:`Clearance` (and so one :class:`~foam_mj.bubbles.BubbleOracle`) may serve several threads at once
(plans in a thread pool): each thread queries through its own ``MjData`` and batches, created on its first query.
It pickles (for process pools and Ray) without them.

MuJoCo's built-in profiler is off while a batch runs (:class:`_ProfilerOff`). The Python bindings install a clock
as its callback (``mjcb_time``) whenever an ``MjData`` is made, and ``mujoco.set_mjcb_time(None)`` puts that clock
back rather than removing it, so ``mj_fwdPosition`` reads the clock about ten times per configuration, for
``mjData.timer`` statistics nobody reads here: 13 % of a query loop's time. With the callback unset during the
batch (then restored), a query on the obstacle scene takes 2.1 instead of 2.6 us and plan + optimal smoother 3 %
less CPU time (per-seed ratio 0.968, seeds 0-9), with the same distances to the last bit (the profiler only
writes ``mjData.timer``). A callback the user set (``mujoco.set_mjcb_time(f)``) is left alone.
"""

from __future__ import annotations

import ctypes
import threading
from pathlib import Path

import mujoco
import numpy as np
from mujoco import batch as mj_batch

from foam_mj.capsule_box import _CAPSULE, is_capsule_box, segment_meets
from foam_mj.model import RobotModel

#: Batches at least this large are split over two threads (measured crossover on a 2-core machine).
THREADED_BATCH = 256
#: A thread's first Batch holds this many configurations (then doubles): a Batch costs 1.5 ms to make on the 3-joint
#: leg and 10-14 ms on a UR5e (47 mesh pairs), whatever its size, and a call costs the same in a larger one; bubbletree's
#: growth asks up to 128 at a time, its corridor a few hundred (from 64, a UR5e plan made four Batches, now two).
FIRST_BATCH = 512
_STAGE_POS = int(mujoco.mjtStage.mjSTAGE_POS)
#: The most values one of the capsule/box guard's gathered arrays holds (:meth:`Clearance._guard_capsule_box`): 8 MB.
GUARD_VALUES = 2**20


class _ProfilerOff:
    """A context that unsets MuJoCo's profiler callback ``mjcb_time`` while it is entered, if it is the bindings'
    own clock (module docstring); nested and concurrent entries share one switch (a count under a lock), and the
    last exit restores the clock unless someone set another callback meanwhile. MuJoCo loads the pointer once
    per test and call, so another thread's MuJoCo call sees either the clock or none. Where the loaded MuJoCo
    library or its ``mjcb_time`` cannot be found, it does nothing."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._depth = 0
        self._saved: int | None = None
        self._pointer = self._find()

    @staticmethod
    def _find() -> ctypes.c_void_p | None:
        """``mjcb_time`` of the MuJoCo library that the mujoco package loaded (the one in its folder)."""
        folder = Path(mujoco.__file__).parent
        for pattern in ("libmujoco.so*", "libmujoco*.dylib", "mujoco.dll"):
            for path in sorted(folder.glob(pattern)):
                try:
                    return ctypes.c_void_p.in_dll(ctypes.CDLL(str(path)), "mjcb_time")
                except (OSError, ValueError):
                    continue
        return None

    def __enter__(self) -> None:
        if self._pointer is None:
            return
        with self._lock:
            if self._depth == 0 and mujoco.get_mjcb_time() is None and self._pointer.value:
                self._saved = self._pointer.value
                self._pointer.value = None
            self._depth += 1

    def __exit__(self, *exc: object) -> None:
        if self._pointer is None:
            return
        with self._lock:
            self._depth -= 1
            if self._depth == 0 and self._saved is not None:
                if self._pointer.value is None:
                    self._pointer.value = self._saved
                self._saved = None


_PROFILER_OFF = _ProfilerOff()


def _qpos_block(index: np.ndarray) -> tuple[slice, np.ndarray | None] | None:
    """Where the coordinates' qpos addresses ``index`` are a block a, a + 1, ..., b - 1 in some order: the slice a:b and
    the coordinate written to each of its columns (None: in order), so that ``qpos[:, a:b] = q[:, order]`` is
    ``qpos[:, index] = q``; None for addresses with gaps."""
    index = np.asarray(index, dtype=np.int64)
    if len(index) == 0 or len(np.unique(index)) != len(index) or index.max() - index.min() + 1 != len(index):
        return None
    order = np.argsort(index)
    return slice(int(index.min()), int(index.max()) + 1), None if (order == np.arange(len(index))).all() else order


def _raw_forward(batch: mj_batch.Batch, ids: np.ndarray):
    """The compiled forward call of ``batch`` for sorted unique int32 ids in range (so ``ids[:n]``), which
    :meth:`mujoco.batch.Batch.forward` checks anew at every call, or None where this mujoco's Batch is not built so
    (then the public call is used)."""
    raw = getattr(getattr(batch, "_b", None), "forward", None)
    if raw is None or not callable(getattr(batch, "_check", None)):
        return None
    try:
        if mj_batch._ids(ids, batch.nsim) is not ids:  # the check passes them through untouched: the same call
            return None
    except (AttributeError, TypeError, ValueError):
        return None
    return raw


#: The compiled arrays that fix every body's and joint's frame for a given qpos (:func:`_same_frames`).
_FRAME_FIELDS = ("qpos0", "body_parentid", "body_pos", "body_quat", "jnt_type", "jnt_bodyid", "jnt_pos", "jnt_axis", "jnt_qposadr")


def _same_frames(lean: mujoco.MjModel, full: mujoco.MjModel) -> bool:
    """Whether a lean sensor model (:meth:`Clearance._sensor_model`) gives every qpos the full model's body and joint
    frames: the same qpos0, bodies (parents, positions, orientations) and joints (types, bodies, anchors, axes, qpos
    addresses). The kept geoms' frames on their bodies are then theirs too (a geom's pose on its body depends on its
    body's frame alone)."""
    if (lean.nq, lean.nbody, lean.njnt) != (full.nq, full.nbody, full.njnt):
        return False
    return all(np.array_equal(getattr(lean, f), getattr(full, f)) for f in _FRAME_FIELDS)


class _ThreadState:
    """One thread's scratch: its MjData, its batches and the configurations it evaluated."""

    def __init__(self, m: mujoco.MjModel) -> None:
        self.data = mujoco.MjData(m)
        self.batches: dict[int, tuple] = {}  # threads -> (Batch, qpos, sensordata, ids, cutoffs, raw forward)
        self.calls = 0


class Clearance:
    """d(q) for one configuration or a batch. ``distmax`` (metres) caps the distance returned; ``threads`` is
    the most threads a batch of at least :data:`THREADED_BATCH` configurations is split over (1: every query
    in one thread, as a single-threaded peer planner's; the values are the same to the last bit either way).
    Thread-safe (module docstring); ``calls`` counts the configurations the calling thread evaluated."""

    def __init__(self, robot: RobotModel, distmax: float = 1.0, threads: int = 2) -> None:
        if not distmax > 0:
            raise ValueError(f"`distmax` must be > 0, got {distmax}")
        if not (isinstance(threads, int) and threads >= 1):
            raise ValueError(f"`threads` must be an integer >= 1, got {threads!r}")
        self.threads = threads
        self.robot = robot
        self.distmax = float(distmax)
        self._m = robot.model
        self._pairs = [(int(g), int(o)) for g, o in robot.pairs]
        self._capsule_box_rows = self._capsule_box_geoms()
        self._batch_model = self._sensor_model()
        self._capsule_box = self._capsule_box_pairs()
        size = self._m.geom_size
        self._single_guard = [(p, cap, box, float(size[cap][1]), float(size[cap][0]), size[box].tolist(),
                               (float(size[cap][1]) + float(np.linalg.norm(size[box]))) ** 2 * (1 + 1e-9))
                              for p, cap, box in self._capsule_box_rows[0]]
        self._qpos_block = _qpos_block(robot.config.qpos_index)
        self._local = threading.local()

    def _state(self) -> _ThreadState:
        """The calling thread's scratch (created on its first query)."""
        try:
            return self._local.state
        except AttributeError:
            state = self._local.state = _ThreadState(self._m)
            return state

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        del state["_local"]  # MjData and batches are per thread and process; made afresh on the first query
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._local = threading.local()

    @property
    def calls(self) -> int:
        """Configurations the calling thread has evaluated, for statistics (a planner counts its own queries)."""
        return self._state().calls

    def _sensor_model(self) -> mujoco.MjModel:
        """The model with one distance sensor per checked pair, lean if it compiles so: without the geoms of no
        checked pair, the lights, actuators, keyframes, contact pairs and the model's own sensors (the kinematics
        and our sensors' values are the same to the last bit; on the obstacle scene a query costs 4-5 % less).
        A model that needs one of them (a tendon wrapping a dropped geom, a body left without mass) keeps all, and so does
        one whose lean copy places its bodies differently (:func:`_same_frames`: ``<compiler alignfree="true">`` puts a
        free body's frame at its centre of mass, which the dropped geoms move, and the rows' qpos, the full model's,
        would then carry the kept geoms off their places: an arm read 0.53 m clear of a block it ran 34 mm into)."""
        try:
            m = self._compile(lean=True)
            if not _same_frames(m, self._m):
                m = self._compile(lean=False)
        except ValueError:
            m = self._compile(lean=False)
        # Only positions and sensors matter: skip contacts, constraints, gravity and actuation.
        off = mujoco.mjtDisableBit
        m.opt.disableflags |= int(off.mjDSBL_CONTACT | off.mjDSBL_CONSTRAINT | off.mjDSBL_GRAVITY | off.mjDSBL_ACTUATION)
        # The position stage also factors the inertia matrix, which no sensor here reads. A singular one (two
        # coaxial hinges on one body) made every batch thread print MuJoCo's "Inertia matrix is too close to
        # singular" warning and append it to MUJOCO_LOG.TXT in the user's folder; armature keeps it regular.
        m.dof_armature += 1.0
        return m

    def _compile(self, lean: bool) -> mujoco.MjModel:
        spec = self.robot.spec_copy()
        names = [(self.robot.geom_name(g), self.robot.geom_name(o)) for g, o in self._pairs]
        if lean:
            used = {name for pair in names for name in pair}
            unused = [g for g in spec.geoms if g.name not in used]
            for obj in [*unused, *spec.lights, *spec.actuators, *spec.keys, *spec.pairs, *spec.sensors]:
                spec.delete(obj)
        _, caps, boxes = self._capsule_box_rows  # their frames for the batch's capsule/box guard, before ours
        frames = [(g, kind) for g in caps for kind in ("FRAMEPOS", "FRAMEZAXIS")]
        frames += [(g, kind) for g in boxes for kind in ("FRAMEPOS", "FRAMEXAXIS", "FRAMEYAXIS", "FRAMEZAXIS")]
        for g, kind in frames:
            s = spec.add_sensor()
            s.type = getattr(mujoco.mjtSensor, f"mjSENS_{kind}")
            s.objtype = mujoco.mjtObj.mjOBJ_GEOM
            s.objname = self.robot.geom_name(g)
        for g_name, o_name in names:
            s = spec.add_sensor()
            s.type = mujoco.mjtSensor.mjSENS_GEOMDIST
            s.objtype = mujoco.mjtObj.mjOBJ_GEOM
            s.objname = g_name
            s.reftype = mujoco.mjtObj.mjOBJ_GEOM
            s.refname = o_name
            s.cutoff = self.distmax
        return spec.compile()

    def __call__(self, q: np.ndarray) -> float:
        """d(q) for one configuration (shape (n,)); q is not validated here (see RobotModel.validate)."""
        state = self._state()
        d = state.data
        d.qpos[:] = self.robot.config.to_qpos(q)
        mujoco.mj_kinematics(self._m, d)
        state.calls += 1
        return min(self._distances(d))

    def mujoco_clearance(self, q: np.ndarray) -> float:
        """MuJoCo's own minimum over the checked pairs at q, without the capsule/box guard (:mod:`foam_mj.capsule_box`):
        what a peer planner's validity checker built on MuJoCo reads (``benchmarks/ompl_peer.py``), at MuJoCo's cost."""
        state = self._state()
        d = state.data
        d.qpos[:] = self.robot.config.to_qpos(q)
        mujoco.mj_kinematics(self._m, d)
        state.calls += 1
        m, dm, gd = self._m, self.distmax, mujoco.mj_geomDistance
        return min([gd(m, d, g, o, dm, None) for g, o in self._pairs])

    def pair_distances(self, q: np.ndarray) -> np.ndarray:
        """d_p(q) of every checked pair (shape (P,), in ``robot.pairs`` order)."""
        state = self._state()
        d = state.data
        d.qpos[:] = self.robot.config.to_qpos(q)
        mujoco.mj_kinematics(self._m, d)
        state.calls += 1
        return np.array(self._distances(d))

    def _distances(self, d: mujoco.MjData) -> list[float]:
        """Every checked pair's distance at the kinematics of ``d``: MuJoCo's, at most minus a capsule's radius where its
        segment meets its box (:func:`foam_mj.capsule_box.geom_distance`'s values, by its scalar test
        :func:`~foam_mj.capsule_box.segment_meets`: a peer's validity checker calls this once per state, where numpy's
        per-call cost would double it)."""
        m, dm, gd = self._m, self.distmax, mujoco.mj_geomDistance
        out = [gd(m, d, g, o, dm, None) for g, o in self._pairs]
        for p, cap, box, half, radius, size, reach in self._single_guard:
            if out[p] > -radius and segment_meets(d, cap, box, half, size, reach):
                out[p] = -radius
        return out

    def pairwise(self, q: np.ndarray) -> dict[tuple[str, str], float]:
        """Distance of every checked pair at q, keyed by geom names (for reports and debugging)."""
        name = self.robot.geom_name
        return {(name(g), name(o)): float(v) for (g, o), v in zip(self._pairs, self.pair_distances(q))}

    def batch(self, Q: np.ndarray) -> np.ndarray:
        """d(q) for every row of Q (shape (N, n)), in one rollout call."""
        D = self.batch_pairs(Q)
        return D.min(axis=1) if len(D) else np.empty(0)

    def batch_pairs(self, Q: np.ndarray, cap: np.ndarray | None = None) -> np.ndarray:
        """d_p(q) for every row of Q (shape (N, n)) and every checked pair: shape (N, P), one batched MuJoCo call.

        ``cap`` (N, P), positive metres: per configuration and pair, a smaller cap than ``distmax`` (values above it
        read as ``distmax``). A pair farther than its cap reads the cap, and MuJoCo's query stops as soon as it has
        proven the pair that far: the cap is the distance sensor's cutoff, set per configuration
        (``Batch.expand("sensor_cutoff")``), which ends GJK once its lower bound reaches the cutoff (mesh pairs
        far apart cost a fraction of a full query). A pair nearer than its cap reads the same value to the last bit
        as without a cap: the cutoff takes no part in the iterations before that exit, nor in a primitive pair's
        closed form. A penetration deeper than the cap reads minus the cap (MuJoCo clamps a sensor to its cutoff
        both ways; as it does at ``distmax``). So a capped value is never more than d_p where d_p >= 0, and stays
        negative where d_p < 0."""
        Q = np.asarray(Q, dtype=float)
        n = len(Q)
        P = len(self._pairs)
        if n == 0:
            return np.empty((0, P))
        state = self._state()
        state.calls += n
        batch, qpos, sensordata, ids, cutoff, forward = self._batch(state, n, min(self.threads, 2) if n >= THREADED_BATCH else 1)
        cfg = self.robot.config
        qpos[:n] = cfg.qpos0  # as ConfigurationMap.to_qpos, written straight into the batch's rows
        q = cfg.offset + cfg.scale * Q
        if self._qpos_block is None:
            qpos[:n, cfg.qpos_index] = q
        else:  # the coordinates fill a block of qpos: a slice and a column permutation, not a 2-D scatter (5x faster)
            block, order = self._qpos_block
            qpos[:n, block] = q if order is None else q.take(order, axis=1)
        ours = cutoff[:n, cutoff.shape[1] - P :]
        if cap is None:
            ours.fill(self.distmax)
        else:
            np.minimum(cap, self.distmax, out=ours)
        with _PROFILER_OFF:
            if n == batch.nsim:
                batch.forward(None, _STAGE_POS)
            elif forward is None:
                batch.forward(ids[:n], _STAGE_POS)
            else:  # ids[:n] were checked once (_batch): mujoco.batch's per-call check of them took 3 % of a query loop
                ids_n = ids[:n]
                batch._check(ids_n, forward(ids_n, _STAGE_POS))
        width = sensordata.shape[1]
        out = sensordata[:n, width - P :].copy()  # our sensors come last, after any the model has
        if self._capsule_box is not None:  # the capsules' and boxes' poses: the frame sensors before ours
            self._guard_capsule_box(out, sensordata[:n, width - P - self._capsule_box[0] : width - P])
        return out

    def _capsule_box_geoms(self) -> tuple[list[tuple[int, int, int]], list[int], list[int]]:
        """The checked capsule/box pairs as (column, capsule, box) in the robot model's geom ids, and the capsules and
        boxes among them (each once, in order)."""
        rows = []
        for p, (g, o) in enumerate(self._pairs):
            if is_capsule_box(self._m, g, o):
                rows.append((p, g, o) if int(self._m.geom_type[g]) == _CAPSULE else (p, o, g))
        return rows, list(dict.fromkeys(r[1] for r in rows)), list(dict.fromkeys(r[2] for r in rows))

    def _capsule_box_pairs(self) -> tuple | None:
        """The frame sensors' layout for :meth:`_guard_capsule_box`, None for a model without a capsule/box pair: their
        width; the columns of the pairs; two index arrays into the frame block, (3, 3 x 3 x k) flattened: per
        component j, for each vector v (the capsule's centre, the box's centre, the capsule's axis), box axis i and
        pair, the entry of component j of v (left) and of the box's axis i (right), so that summing their products
        over j gives R^T v (one gather each, in the order (v, i, pair)); the box's faces [-size, +size] as (2, 3 k, 1)
        (axis i, then pair); the capsule's half-length and radius, (k, 1); the screen's bounds. The block (:meth:`_compile`): per capsule its
        position and z axis (6 values), then per box its position and x, y, z axes (12)."""
        rows, caps, boxes = self._capsule_box_rows
        if not rows:
            return None
        k = len(rows)
        cols = np.array([r[0] for r in rows])
        c0 = np.array([6 * caps.index(r[1]) for r in rows])
        b0 = np.array([6 * len(caps) + 12 * boxes.index(r[2]) for r in rows])
        j = np.arange(3)[:, None]
        # vecs[j, v]: component j of the capsule's centre (v = 0), the box's centre (1) and the capsule's axis (2);
        # rot[j, i]: R[j, i], component j of the box's axis i (at b0 + 3 + 3 i + j).
        vecs = np.stack([c0 + j, b0 + j, c0 + 3 + j], axis=1)  # (3, 3, k)
        rot = np.stack([b0 + 3 + 3 * i + j for i in range(3)], axis=1)  # (3, 3, k)
        left = np.broadcast_to(vecs[:, :, None], (3, 3, 3, k)).ravel()  # (j, v, i, pair)
        right = np.broadcast_to(rot[:, None], (3, 3, 3, k)).ravel()
        size = self._m.geom_size[[r[2] for r in rows]].T[:, :, None]  # (3, k, 1)
        capsule = self._m.geom_size[[r[1] for r in rows]]
        half = capsule[:, 1:2].copy()
        # The screen's bounds (:meth:`_guard_capsule_box`): size_i and the half-length, per (axis i, pair), widened by
        # (1 + 1e-9) / (1 - 1e-9), far more than the slab test's rounding (a few ulps of size + |p|).
        widen = (1.0 + 1e-9) / (1.0 - 1e-9)
        screen = (widen * size.reshape(3 * k, 1), widen * np.tile(half, (3, 1)))
        return (6 * len(caps) + 12 * len(boxes), cols, left, right, np.stack([-size, size]).reshape(2, 3 * k, 1),
                half, capsule[:, 0:1].copy(), screen)

    def _guard_capsule_box(self, out: np.ndarray, frames: np.ndarray) -> None:
        """:meth:`_guard_block` over the rows in blocks of at most :data:`GUARD_VALUES` / (27 k) rows (k capsule/box
        pairs): its gathers hold 27 values per pair and row, three such arrays at once, 155 MB for 240 pairs (arm6 among
        60 boxes) and 1,000 rows where the result is 2.5 MB. Each row's values are computed alone, so blocks change
        none; a batch of the shipped scenes is one block."""
        assert self._capsule_box is not None  # (called only then)
        step = max(1, GUARD_VALUES // (27 * len(self._capsule_box[1])))
        for start in range(0, len(out), step):
            self._guard_block(out[start : start + step], frames[start : start + step])

    def _guard_block(self, out: np.ndarray, frames: np.ndarray) -> None:
        """In place: each capsule/box pair's distance at most minus the capsule's radius where the capsule's segment
        meets the box, as :func:`foam_mj.capsule_box.geom_distance` does for one configuration; untouched elsewhere.
        ``frames``: the rows' frame sensors (:meth:`_capsule_box_pairs`). The slab test of
        :func:`foam_mj.capsule_box.segment_meets` over every row and pair at once: the capsule's centre and axis in the box's
        frame (R^T v), the parameter interval between each pair of faces (an axis parallel to a face gives +-inf: the
        whole line or nothing), intersected and clipped to the segment. Arrays are held component first, (component,
        pair, row), so that every numpy call works on contiguous blocks: their count, not the rows, sets the cost (the
        products' operands gathered with one ``take`` each instead of two fancy indexings and a 5-D broadcast: 212,500
        -> 199,800 instructions a call of 70 rows, the same values; with the screen below 139,000)."""
        assert self._capsule_box is not None  # (called only then)
        _, cols, left, right, faces, half, radius, (size_w, half_w) = self._capsule_box
        k = len(cols)
        F = frames.T
        W = (F.take(left, axis=0) * F.take(right, axis=0)).reshape(3, 9 * k, -1).sum(axis=0)  # (v, i, pair, row): R^T v
        p, u = W[: 3 * k] - W[3 * k : 6 * k], W[6 * k :]  # the capsule's centre and axis in the box's frame
        # A screen: a segment that meets the box has |p_i| <= size_i + half |u_i| on every axis i (its extent along the
        # axis reaches the slab), and so does the slab test's rounded hit (within a few ulps of size_i + |p_i|, far
        # inside the bounds' widening). Where no pair of any row passes it (every batch of obstacle's and step_up's
        # plans, two thirds of arm6's), nothing is hit: the slab test is skipped.
        if not (np.abs(p) <= size_w + half_w * np.abs(u)).reshape(3, k, -1).all(axis=0).any():
            return
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (faces - p) / u  # (2, 3 k, n): where the axis crosses each face
        enter = np.maximum(np.minimum(t[0], t[1]).reshape(3, k, -1).max(axis=0), -half)
        leave = np.minimum(np.maximum(t[0], t[1]).reshape(3, k, -1).min(axis=0), half)
        hit = enter <= leave
        if not hit.any():  # (nearly every batch)
            return
        vals = out[:, cols]
        misread = (hit & (vals.T > -radius)).T
        if misread.any():
            out[:, cols] = np.where(misread, -radius.T, vals)

    def _batch(self, state: _ThreadState, n: int, nthread: int) -> tuple:
        """The calling thread's Batch of ``nthread`` threads with room for n configurations (grown by doubling): the
        batch, its qpos and sensordata rows, the simulation ids, the sensors' cutoffs per simulation and the batch's
        unchecked forward call (:func:`_raw_forward`)."""
        b = state.batches.get(nthread)
        if b is None or b[0].nsim < n:
            size = max(n, 2 * b[0].nsim if b is not None else FIRST_BATCH)
            batch = mj_batch.Batch(self._batch_model, size, nthread=nthread)
            ids = np.arange(size, dtype=np.int32)
            b = state.batches[nthread] = (batch, batch.bind("qpos"), batch.bind("sensordata"), ids, batch.expand("sensor_cutoff"),
                                          _raw_forward(batch, ids))
        return b

    def close(self) -> None:
        """Release every thread's batches and their threads (a later query starts afresh)."""
        self._local = threading.local()

    def __del__(self) -> None:  # pragma: no cover - best effort
        try:
            self.close()
        except Exception:
            pass
