"""Replay a joint trajectory on the MuJoCo model: kinematically (poses and clearance) and dynamically
(the leg's position servos tracking it under gravity, with contacts reported).

Kinematic replay
----------------
Every frame's qpos is set and its pose computed (``mj_kinematics``, the pose stage of ``mj_forward``); the frame's body poses (``xpos``, ``xquat``) of the
leg's bodies (those moved by a joint) are kept for the recording, and the workspace clearance of every
frame comes from :meth:`foam_mj.clearance.Clearance.batch` (MuJoCo distance sensors).

Dynamic replay
--------------
The state starts at the trajectory's first sample and is advanced with ``mj_step1``/``mj_step2`` at the
model's timestep (which must equal the trajectory's). Each configuration joint is driven by its position
actuator, force = kp (ctrl - q) - kv qdot; the velocity reference and a feed-forward torque are folded
into ctrl so that

    force = tau_ff + kp (q_ref - q) + kv (qdot_ref - qdot),
    ctrl  = q_ref + (tau_ff + kv qdot_ref) / kp

(read generically from ``actuator_gainprm``/``actuator_biasprm``/``actuator_gear``). ``feedforward``:

* ``"inverse"`` (default): tau_ff = ``mj_inverse`` at the reference: gravity, inertia, Coriolis and joint
  damping, the usual computed-torque feed-forward, made exact for MuJoCo's discrete step
  (:func:`discrete_rates`): the velocity and acceleration references are the ones with which the semi-implicit
  step (v' = v + dt a, q' = q + dt v') lands on every row (backward differences of the rows, and their
  differences), and ``mj_inverse`` runs with MuJoCo's ``invdiscrete`` flag (the implicit damping of Euler and
  implicitfast, the servos' included). The continuous reference's (qvel, qacc) made the step run dt/2 ahead
  of the rows, about v dt / 2: 0.4-0.7 mrad on the Ortholeg, 1-7 mrad on generated arms, left for the PD part to
  correct. An RK4 model (no discrete inverse) keeps the continuous (qvel, qacc).
* ``"gravity"``: tau_ff = gravity at q_ref (``mj_inverse`` with zero velocity and acceleration).
* ``"none"``: tau_ff = 0, a PD servo on the reference.

Gains (``models/ortholeg.xml``, classes ``hinge_servo`` and ``slide_servo``): kp = 30000 N m/rad on the
hinges and 100000 N/m on the slide, critically damped (dampratio 1), forces limited to 400 N m / 3000 N.
Measured on the obstacle scene's centre path (seed 0, default limits, own time law, 3.1 s), the maximum
error with ``"inverse"`` is rounding (below 1e-16 rad and m; 0.41, 0.17 mrad and 0.17 mm with the continuous
reference), so the replay's tracking error measures what the servos cannot do (a force or ctrl range, a
contact, an RK4 model), not the feed-forward; peak forces 364 N, 234 N m, 78 N m. With ``"gravity"`` or
``"none"`` the maximum errors are about 8 mrad, 3 mrad, 4 mm (inertia is not compensated).

Models without servos
---------------------
When some configuration joint has no position servo (a user's MJCF often has no actuators, or motors),
the dynamic replay runs on a copy of the model whose actuators are replaced by one position servo per
configuration joint, sized for the path it replays and stepped implicitly: :func:`foam_mj.servos.servo_model`
(its module docstring gives the gains, the integrator and why). ``servo_note`` and ``servo_kp`` state them.
When a replay still diverges, :attr:`DynamicReplay.divergence_cause` names the likely cause.

Joints outside the configuration
--------------------------------
The planner holds every joint that is not a configuration coordinate (a floating base, a wrist or a
spinning joint left out, a loose object) at its pose in the trajectory (``qpos0`` or the scenario's
keyframe), so the dynamic replay does too: before each step their qpos is set back to the trajectory's
and their velocity to zero (:func:`~foam_mj.servos.held_joints`), and on a copy of the model (:func:`~foam_mj.servos.servo_model`) their
dofs get an armature :data:`~foam_mj.servos.HOLD_ARMATURE` times the largest diagonal inertia, so that the configuration
joints move, and servos added with a damping ratio are damped, as on a fixed mount (a free base otherwise
recoils from the servos, and falls under gravity). Contacts between bodies that no configuration joint moves, one of
them held (stance feet on the floor), are excluded in that copy: both stay put, but MuJoCo's contact would jolt them
by accelerations no armature resists, and the jolts reached the planned joints. For the same reason a held joint's
range is not applied in the copy: a keyframe that holds a wrist beyond its range (1.2 rad against +-0.5) had MuJoCo's
limit push it back every step, 67 mrad of tracking error on the planned elbow, with no note.

A servo can only do what its MJCF allows: MuJoCo clamps a ctrl outside the actuator's ``ctrlrange`` (a
position servo whose set-point range is narrower than the motion, or than the set point plus the folded-in
feed-forward) and caps its force at its ``forcerange``, and the total actuator force on a joint at the joint's
``actuatorfrcrange``. The frames where one of these happened are counted per actuator (``clamped_frames``,
``saturated_frames``) or joint (``joint_saturated_frames``) and named in ``limit_note``, which ``plan`` and
``replay`` print: the tracking error and contacts that follow are the servo's, not the path's.

Contacts are read from ``data.contact`` after each ``mj_step1`` (collision detection at that frame's
state): every contact between a leg geom and an obstacle geom with ``dist <= 0`` is reported with its
frame, time, geom names and penetration depth.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import mujoco
import numpy as np

from foam_mj.clearance import Clearance
from foam_mj.configuration import _joint_name
from foam_mj.geom_pairs import body_is_moving
from foam_mj.model import RobotModel
from foam_mj.servos import explicit_damping_note, held_joints, servo_model, servo_problem
from foam_mj.trajectory import Trajectory
from foam_mj.trajectory import check_trajectory as _check

#: The trajectory's sample spacing must match the model's timestep to within this (seconds).
DT_TOL = 1e-9
#: Feed-forward modes of the dynamic replay (module docstring).
FEEDFORWARD = ("inverse", "gravity", "none")


@dataclass(frozen=True)
class BodyPoses:
    """World poses of the leg's bodies per frame: xpos (T, B, 3) metres, xquat (T, B, 4) MuJoCo's w, x, y, z."""

    body_names: tuple[str, ...]
    body_ids: np.ndarray  # (B,)
    xpos: np.ndarray
    xquat: np.ndarray


class _ReplayMeasures:
    """What both replays report from their ``times`` and ``clearance`` arrays."""

    times: np.ndarray
    clearance: np.ndarray

    @property
    def min_clearance(self) -> float:
        return float(self.clearance.min())

    @property
    def n_frames(self) -> int:
        return len(self.times)


@dataclass(frozen=True)
class KinematicReplay(_ReplayMeasures):
    """A trajectory played back pose by pose: times (T,), qpos (T, nq), poses, clearance (T,) in metres."""

    times: np.ndarray
    qpos: np.ndarray
    poses: BodyPoses
    clearance: np.ndarray



@dataclass(frozen=True)
class Contact:
    """One contact between a leg geom and an obstacle geom: penetration = -dist >= 0 (metres), position
    the contact point in world coordinates (metres)."""

    frame: int
    time: float
    leg_geom: str
    obstacle_geom: str
    penetration: float
    position: tuple[float, float, float]


@dataclass(frozen=True)
class DynamicReplay(_ReplayMeasures):
    """The leg's servos tracking a trajectory under gravity.

    ``qpos`` is the simulated state and ``qpos_ref`` the reference, per frame (T, nq); ``error`` (T, n) is
    simulated minus reference for the configuration joints in joint units (rad, m), ``rms_error`` and
    ``max_error`` (n,) its RMS and maximum absolute value per joint. ``clearance`` (T,) is the clearance of
    the simulated configurations; ``contacts`` every leg/obstacle contact seen.
    """

    times: np.ndarray
    qpos: np.ndarray
    qpos_ref: np.ndarray
    ctrl: np.ndarray  # (T, nu) the controls applied from each frame
    joint_names: tuple[str, ...]
    error: np.ndarray
    rms_error: np.ndarray
    max_error: np.ndarray
    contacts: tuple[Contact, ...]
    poses: BodyPoses
    clearance: np.ndarray
    feedforward: str
    actuator_force: np.ndarray  # (T, nu) the actuators' forces at each frame (N m, N)
    saturated_frames: np.ndarray  # (nu,) frames at which each actuator's force sat at its force range
    warnings: tuple[str, ...]  # MuJoCo warnings raised during the simulation (e.g. "mjWARN_BADQACC")
    servo_note: str = ""  # set when servos were added to the model for this replay (module docstring)
    servo_kp: np.ndarray | None = None  # (n,) the added servos' kp per configuration joint (N m/rad, N/m), else None
    clamped_frames: np.ndarray | None = None  # (nu,) frames at which each actuator's ctrl lay outside its ctrlrange
    limit_note: str = ""  # set when a servo could not do what tracking asked (ctrl or force range; module docstring)
    joint_saturated_frames: np.ndarray | None = None  # (n,) frames at which a joint's actuator force sat at its actuatorfrcrange

    @property
    def diverged(self) -> tuple[str, ...]:
        """The warnings of :data:`DIVERGED` MuJoCo raised: its simulation blew up and restarted from the model's
        initial state, so the tracking error and contacts mean nothing (empty when it stayed stable)."""
        return tuple(w for w in self.warnings if w in DIVERGED)

    @property
    def divergence_cause(self) -> str:
        """The likely cause of a divergence, for the note that reports it ("" when the replay stayed stable): a
        singular inertia matrix when MuJoCo warned of one (two hinges on one axis), else the servos' gains against
        the model's timestep (the added servos' when :func:`servo_model` added some)."""
        if not self.diverged:
            return ""
        if "mjWARN_INERTIA" in self.warnings:
            return "MuJoCo found the inertia matrix singular, as two hinges on one axis make it: check the model's inertias"
        if self.servo_note:
            return ("the servos added for the replay (sized from the robot's inertia along the path, module docstring of "
                    "foam_mj.replay) did not hold it: check the model's inertias, or give it its own position servos")
        return "the model's position servos are too stiff or too strongly damped for its timestep: check their kp and kv"


#: Tracking error (rad or m) above which a replay with the model's own servos is checked for servos that Euler's
#: explicit actuator damping makes unstable (:func:`foam_mj.servos.explicit_damping_note`), as are saturated ones.
SHAKE_CHECK = 0.01


#: MuJoCo's warnings that its simulation diverged and was reset to the model's initial state (auto-reset).
DIVERGED = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")


def leg_bodies(robot: RobotModel) -> np.ndarray:
    """Ids of the bodies moved by some joint (the leg), in model order."""
    m = robot.model
    return np.array([b for b in range(1, m.nbody) if body_is_moving(m, b)], dtype=int)


def _addresses(m: mujoco.MjModel, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The qpos and dof addresses of ``joints``."""
    size = {int(mujoco.mjtJoint.mjJNT_FREE): (7, 6), int(mujoco.mjtJoint.mjJNT_BALL): (4, 3)}
    qpos: list[int] = []
    dof: list[int] = []
    for j in joints:
        nq, nv = size.get(int(m.jnt_type[j]), (1, 1))
        qpos += range(int(m.jnt_qposadr[j]), int(m.jnt_qposadr[j]) + nq)
        dof += range(int(m.jnt_dofadr[j]), int(m.jnt_dofadr[j]) + nv)
    return np.array(qpos, dtype=int), np.array(dof, dtype=int)


def _body_names(m: mujoco.MjModel, ids: np.ndarray) -> tuple[str, ...]:
    return tuple(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(b)) or f"body{int(b)}" for b in ids)


def replay_clearance(robot: RobotModel, delta: float) -> Clearance:
    """The clearance the replays of a plan with margin ``delta`` measure with: distances capped above delta
    (:func:`~foam_mj.bubbles.distance_cap`; a cap of 1 m read a 1.2 m margin as broken). Close it after use."""
    from foam_mj.bubbles import distance_cap

    return Clearance(robot, distmax=distance_cap(robot, delta))


def replay_kinematic(robot: RobotModel, trajectory: Trajectory, clearance: Clearance | None = None) -> KinematicReplay:
    """Pose every frame with ``mj_kinematics`` (the body poses of ``mj_forward``); clearance of every frame from ``clearance`` (default: a new
    :class:`Clearance` of ``robot``)."""
    _check(robot, trajectory)
    m = robot.model
    d = mujoco.MjData(m)
    ids = leg_bodies(robot)
    T = len(trajectory)
    xpos = np.empty((T, len(ids), 3))
    xquat = np.empty((T, len(ids), 4))
    for i, qpos in enumerate(trajectory.qpos):
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)  # poses only: the first stage of mj_forward, same xpos and xquat
        xpos[i] = d.xpos[ids]
        xquat[i] = d.xquat[ids]
    own = clearance is None
    clr = Clearance(robot) if clearance is None else clearance
    try:
        dist = np.minimum(clr.batch(robot.config.to_q(trajectory.qpos)), robot.fixed_obstacle_clearance)
    finally:
        if own:
            clr.close()
    poses = BodyPoses(_body_names(m, ids), ids, xpos, xquat)
    return KinematicReplay(trajectory.times.copy(), trajectory.qpos.copy(), poses, dist)


@dataclass(frozen=True)
class _Servo:
    """The position actuator driving each configuration joint: force = gain ctrl + b0 + b1 length + b2 velocity."""

    actuator: np.ndarray  # (n,) actuator ids
    gear: np.ndarray
    gain: np.ndarray
    b0: np.ndarray
    b1: np.ndarray
    b2: np.ndarray


def _servos(robot: RobotModel, m: mujoco.MjModel | None = None) -> _Servo:
    m = robot.model if m is None else m
    cfg = robot.config
    problem = servo_problem(m, robot)
    if problem is not None:
        raise ValueError(problem)
    ids = np.array([next(a for a in range(m.nu) if int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT) and int(m.actuator_trnid[a, 0]) == int(j))
                    for j in cfg.joint_ids])
    return _Servo(
        ids,
        m.actuator_gear[ids, 0].copy(),
        m.actuator_gainprm[ids, 0].copy(),
        m.actuator_biasprm[ids, 0].copy(),
        m.actuator_biasprm[ids, 1].copy(),
        m.actuator_biasprm[ids, 2].copy(),
    )


def servo_controls(robot: RobotModel, trajectory: Trajectory, feedforward: str = "inverse", model: mujoco.MjModel | None = None) -> np.ndarray:
    """ctrl (T, nu) for the position servos (module docstring): the set point q_ref, the velocity
    reference and the feed-forward torque folded in. ``feedforward``: "inverse", "gravity" or "none".
    ``model``: the model with the servos (default ``robot.model``; see :func:`servo_model`)."""
    _check(robot, trajectory)
    if feedforward not in FEEDFORWARD:
        raise ValueError(f"`feedforward` must be one of {FEEDFORWARD}, got {feedforward!r}")
    m = robot.model if model is None else model
    cfg = robot.config
    servo = _servos(robot, m)
    dof = m.jnt_dofadr[cfg.joint_ids]
    T = len(trajectory)
    qref = trajectory.qpos[:, cfg.qpos_index]
    qvel = np.zeros((T, m.nv)) if trajectory.qvel is None else trajectory.qvel
    tau = np.zeros((T, len(dof)))
    if feedforward == "inverse" and (trajectory.qvel is None or trajectory.qacc is None):
        raise ValueError("`trajectory.qvel` and `trajectory.qacc` are needed for the inverse-dynamics feed-forward")
    qacc = None
    if feedforward == "inverse" and int(m.opt.integrator) != int(mujoco.mjtIntegrator.mjINT_RK4):
        qvel, qacc = discrete_rates(robot, trajectory)  # the rates MuJoCo's step must produce to land on every row
        m = copy.copy(m)  # the same model, its inverse dynamics discrete (the caller's options untouched)
        m.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_INVDISCRETE)
    elif feedforward == "inverse":
        qacc = trajectory.qacc
    if feedforward != "none":
        d = mujoco.MjData(m)
        for i in range(T):
            d.qpos[:] = trajectory.qpos[i]
            if feedforward == "inverse":
                assert qacc is not None  # (set above for "inverse")
                d.qvel[:] = qvel[i]
                d.qacc[:] = qacc[i]
            mujoco.mj_inverse(m, d)  # gravity only when qvel = qacc = 0
            tau[i] = d.qfrc_inverse[dof]
    # The wanted actuator force (joint force = gear F; length = gear q, velocity = gear qdot) is
    #   F = tau / gear + b1 (length - length_ref) + b2 (velocity - velocity_ref)       (b1 = -kp, b2 = -kv)
    # and the actuator makes F = gain ctrl + b0 + b1 length + b2 velocity, so
    #   ctrl = (tau / gear - b0 - b1 length_ref - b2 velocity_ref) / gain.
    g = servo.gear
    ctrl = np.zeros((T, m.nu))
    ctrl[:, servo.actuator] = (tau / g - servo.b0 - servo.b1 * g * qref - servo.b2 * g * qvel[:, dof]) / servo.gain
    return ctrl


def discrete_rates(robot: RobotModel, trajectory: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """(qvel, qacc), each (T, nv), with which MuJoCo's semi-implicit step (v' = v + dt a, q' = q + dt v') lands
    exactly on every row of ``trajectory.qpos``: the configuration dofs' backward differences of the rows, and
    their differences over dt (the first row's velocity, rest, and the last row's acceleration are the
    trajectory's). The other dofs keep the trajectory's rates (zero: held)."""
    dof = robot.model.jnt_dofadr[robot.config.joint_ids]
    q = trajectory.qpos[:, robot.config.qpos_index]
    dt = robot.model.opt.timestep  # the rows' spacing (replay_dynamic checks it)
    qvel = np.zeros((len(q), robot.model.nv)) if trajectory.qvel is None else trajectory.qvel.copy()
    qacc = np.zeros_like(qvel) if trajectory.qacc is None else trajectory.qacc.copy()
    qvel[1:, dof] = np.diff(q, axis=0) / dt
    qacc[:-1, dof] = np.diff(qvel[:, dof], axis=0) / dt
    return qvel, qacc


def replay_dynamic(
    robot: RobotModel,
    trajectory: Trajectory,
    feedforward: str = "inverse",
    clearance: Clearance | None = None,
) -> DynamicReplay:
    """Simulate the leg's servos tracking ``trajectory`` under gravity (module docstring); servos are added
    to a copy of the model when it has none (:func:`servo_model`, noted in ``servo_note``)."""
    _check(robot, trajectory)
    m, note = servo_model(robot, trajectory.qpos)
    if np.any(np.abs(np.diff(trajectory.times) - m.opt.timestep) > DT_TOL):
        raise ValueError(
            f"`trajectory.times` must be spaced by the model's timestep {m.opt.timestep} s, got dt = {trajectory.dt}"
        )
    # mj_step1/mj_step2 (collision detection between the halves of a step) have no RK4 form: an RK4 model
    # is stepped whole by mj_step after mj_forward has computed frame i's kinematics and contacts.
    rk4 = int(m.opt.integrator) == int(mujoco.mjtIntegrator.mjINT_RK4)
    held_qpos, held_dof = _addresses(m, held_joints(robot))
    ctrl = servo_controls(robot, trajectory, feedforward, m)
    d = mujoco.MjData(m)
    d.qpos[:] = trajectory.qpos[0]
    if trajectory.qvel is not None:
        d.qvel[:] = trajectory.qvel[0]
    ids = leg_bodies(robot)
    # leg_obstacle[a, b]: geoms a and b are a leg geom and an obstacle geom (either order), so a step's
    # contacts are filtered with one gather instead of a Python loop over MuJoCo's contact structs
    leg_obstacle = np.zeros((m.ngeom, m.ngeom), dtype=bool)
    leg_obstacle[np.ix_(robot.robot_geoms, robot.obstacle_geoms)] = True
    leg_obstacle |= leg_obstacle.T
    is_leg = np.zeros(m.ngeom, dtype=bool)
    is_leg[robot.robot_geoms] = True
    T = len(trajectory)
    qpos = np.empty((T, m.nq))
    xpos = np.empty((T, len(ids), 3))
    xquat = np.empty((T, len(ids), 4))
    force = np.zeros((T, m.nu))
    cfg_dof = m.jnt_dofadr[robot.config.joint_ids]
    joint_force = np.zeros((T, len(cfg_dof)))  # qfrc_actuator: the actuators' force at each joint, clamped to its actuatorfrcrange
    contacts: list[Contact] = []
    for i in range(T):
        d.qpos[held_qpos] = trajectory.qpos[i, held_qpos]
        d.qvel[held_dof] = 0.0
        if rk4:
            mujoco.mj_forward(m, d)
        else:
            mujoco.mj_step1(m, d)  # kinematics and collision detection at frame i's state
        qpos[i] = d.qpos
        xpos[i] = d.xpos[ids]
        xquat[i] = d.xquat[ids]
        if d.ncon:
            con = d.contact  # the step's contacts as arrays (geom (ncon, 2), dist (ncon,), pos (ncon, 3))
            geom, dist = con.geom, con.dist
            for j in np.flatnonzero((dist <= 0) & leg_obstacle[geom[:, 0], geom[:, 1]]).tolist():
                a, b = int(geom[j, 0]), int(geom[j, 1])
                g_leg, g_obs = (a, b) if is_leg[a] else (b, a)
                contacts.append(
                    Contact(i, float(trajectory.times[i]), robot.geom_name(g_leg), robot.geom_name(g_obs), float(-dist[j]), (float(con.pos[j][0]), float(con.pos[j][1]), float(con.pos[j][2])))
                )
        d.ctrl[:] = ctrl[i]
        if i + 1 < T:
            if rk4:
                mujoco.mj_step(m, d)
            else:
                mujoco.mj_step2(m, d)
        else:
            mujoco.mj_fwdActuation(m, d)  # the last frame's forces, for the record
        force[i] = d.actuator_force
        joint_force[i] = d.qfrc_actuator[cfg_dof]
    cfg = robot.config
    error = qpos[:, cfg.qpos_index] - trajectory.qpos[:, cfg.qpos_index]
    lo, hi = m.actuator_forcerange.T
    servos = _servos(robot, m)
    servo = np.zeros(m.nu, dtype=bool)
    servo[servos.actuator] = True  # the other actuators (say a gripper's, a held joint's) are left at ctrl 0
    limited = servo & m.actuator_forcelimited.astype(bool)  # a held joint's servo pulling to 0 moves nothing: held
    at_limit = limited & ((force <= lo + 1e-9 * np.abs(lo)) | (force >= hi - 1e-9 * np.abs(hi)))
    saturated = at_limit.sum(axis=0)
    clo, chi = m.actuator_ctrlrange.T
    clamped = (servo & m.actuator_ctrllimited.astype(bool) & ((ctrl < clo) | (ctrl > chi))).sum(axis=0)
    damping = _implicit_damping_notes(robot, m, trajectory, feedforward, ctrl, servos, at_limit) if saturated.any() else {}
    jlo, jhi = m.jnt_actfrcrange[cfg.joint_ids].T  # a joint's own clamp of its actuators' total force
    joint_saturated = (m.jnt_actfrclimited[cfg.joint_ids].astype(bool)
                       & ((joint_force <= jlo + 1e-9 * np.abs(jlo)) | (joint_force >= jhi - 1e-9 * np.abs(jhi)))).sum(axis=0)
    warned = tuple(mujoco.mjtWarning(w).name for w in range(len(d.warning)) if d.warning[w].number > 0)
    shaking = ""
    if not note and (saturated.any() or joint_saturated.any() or warned or np.abs(error).max() > SHAKE_CHECK):  # own servos that did not track
        every = trajectory.qpos[:: max(1, T // 50)]
        shaking = explicit_damping_note(robot, m, servos.actuator, -servos.b2 * servos.gear**2, every)
    own = clearance is None
    clr = Clearance(robot) if clearance is None else clearance
    try:
        dist = np.minimum(clr.batch(cfg.to_q(qpos)), robot.fixed_obstacle_clearance)  # and the pairs no joint moves
    finally:
        if own:
            clr.close()
    return DynamicReplay(
        times=trajectory.times.copy(),
        qpos=qpos,
        qpos_ref=trajectory.qpos.copy(),
        ctrl=ctrl,
        joint_names=cfg.joint_names,
        error=error,
        rms_error=np.sqrt(np.mean(error**2, axis=0)),
        max_error=np.abs(error).max(axis=0),
        contacts=tuple(contacts),
        poses=BodyPoses(_body_names(m, ids), ids, xpos, xquat),
        clearance=dist,
        feedforward=feedforward,
        actuator_force=force,
        saturated_frames=saturated,
        warnings=warned,
        servo_note=note,
        servo_kp=servos.gain * servos.gear**2 if note else None,
        clamped_frames=clamped,
        limit_note="; ".join(filter(None, (shaking, _limit_note(m, clamped, saturated, T, cfg.joint_ids, joint_saturated, damping)))),
        joint_saturated_frames=joint_saturated,
    )


def _implicit_damping_notes(robot: RobotModel, m: mujoco.MjModel, trajectory: Trajectory, feedforward: str,
                            ctrl: np.ndarray, servos: _Servo, at_limit: np.ndarray) -> dict[int, str]:
    """Per servo that sat at its force range, under an implicit integrator and the exact feed-forward: how much of
    its force is its own damping and what the joint was asked for ({actuator id: text}).

    Under ``implicit`` and ``implicitfast`` MuJoCo integrates an actuator's velocity feedback implicitly: the force
    it reports and clamps (``actuator_force`` = kp (ctrl - q) - kv qdot) is followed by the step's damping of the
    velocity change, kv dt qacc, that the joint does not receive. To produce the planned motion the servo's force
    must carry that share on top of the joint torque (``discrete_rates``' qacc: hip 200 rad/s^2 x 0.52 N m s^2/rad
    = 104 N m on the Ortholeg), so it can sit at a force range the planned torque fits (foam_mj.dynamics):
    the note says both numbers, so that the replay's saturation is not read as the plan asking too much."""
    if feedforward != "inverse" or int(m.opt.integrator) not in (int(mujoco.mjtIntegrator.mjINT_IMPLICIT),
                                                                 int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST)):
        return {}
    cfg = robot.config
    dof = m.jnt_dofadr[cfg.joint_ids]
    qvel, qacc = discrete_rates(robot, trajectory)
    g, a = servos.gear, servos.actuator
    qref = trajectory.qpos[:, cfg.qpos_index]
    wanted = servos.gain * ctrl[:, a] + servos.b0 + servos.b1 * g * qref + servos.b2 * g * qvel[:, dof]  # the force at the reference
    share = -servos.b2 * g * m.opt.timestep * qacc[:, dof]  # its implicit damping (actuator force units)
    asked = wanted - share  # what the joint receives: the planned torque (over the gear)
    notes = {}
    for i, act in enumerate(a.tolist()):
        sat = at_limit[:, act]
        if not sat.any():
            continue
        slide = int(m.jnt_type[cfg.joint_ids[i]]) == int(mujoco.mjtJoint.mjJNT_SLIDE)
        unit = (" N" if slide else " N m") if abs(g[i]) == 1 else ""
        notes[act] = (f"its implicit damping kv dt qacc, up to {np.abs(share[sat, i]).max():.1f}{unit}, is in that force; "
                      f"the joint torque asked peaks at {np.abs(asked[:, i]).max():.1f}{unit}")
    return notes


def _limit_note(m: mujoco.MjModel, clamped: np.ndarray, saturated: np.ndarray, frames: int,
                joints: np.ndarray | tuple = (), joint_saturated: np.ndarray | tuple = (), damping: dict[int, str] | None = None) -> str:
    """One line naming the servos whose ctrl MuJoCo clamped to its ctrlrange, or whose force sat at its force
    range, and the ``joints`` whose actuators' total force sat at the joint's actuatorfrcrange (``joint_saturated``
    frames each), and in how many frames ("" when none): the reason of a large tracking error, never silent.
    ``damping``: per saturated servo, the share of its force that is implicit damping (:func:`_implicit_damping_notes`)."""
    parts = []
    for a in np.flatnonzero((clamped > 0) | (saturated > 0)):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, int(a)) or f"actuator{int(a)}"
        joint = m.joint(int(m.actuator_trnid[a, 0])).name if int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT) else ""
        what = []
        if clamped[a]:
            lo, hi = m.actuator_ctrlrange[a]
            what.append(f"ctrl clamped to its ctrlrange [{lo:g}, {hi:g}] in {int(clamped[a])}")
        if saturated[a]:
            lo, hi = m.actuator_forcerange[a]
            what.append(f"force at its forcerange [{lo:g}, {hi:g}] in {int(saturated[a])}")
        extra = (damping or {}).get(int(a), "")
        parts.append(f"servo '{name}'{f' ({joint})' if joint else ''}: {' and '.join(what)} of {frames} frames{f' ({extra})' if extra else ''}")
    for j, n in zip(joints, joint_saturated):
        if n:
            lo, hi = m.jnt_actfrcrange[j]
            parts.append(f"joint '{_joint_name(m, int(j))}': actuator force at its actuatorfrcrange [{lo:g}, {hi:g}] in {int(n)} of {frames} frames")
    if not parts:
        return ""
    return "; ".join(parts) + ": the tracking error and any contacts there are the servo's, not the path's"
