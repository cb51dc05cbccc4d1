"""Position servos for the dynamic replay of a model that has none (:func:`servo_model`), and the fixed mount of
the joints outside the configuration (:func:`held_joints`, :data:`HOLD_ARMATURE`); :mod:`foam_mj.replay` drives them.

When some configuration joint has no position servo (a user's MJCF often has no actuators, or motors),
the dynamic replay runs on a copy of the model, made with :class:`mujoco.MjSpec`, whose actuators are
replaced by one position servo per configuration joint (:func:`servo_model`), sized for the path it replays:

    kp_j = I_j omega^2,    kv_j = 2 I_j omega = (2 / omega) kp_j,    omega = 2 pi f,

f = :data:`SERVO_HZ`, I_j the largest effective inertia of joint j over the trajectory's frames
(:func:`effective_inertia`: 1 / (M^-1)_jj over the configuration joints from ``mj_fullM``, armature included, the
inertia the joint drives when the others are free; M_jj would make a long chain's proximal joint, or a millimetre
robot's, far stiffer than f), no force limit: critically damped where the inertia is largest, overdamped and at
least f elsewhere. Sized at ``qpos0`` alone, a generated arm's second joint (0.03 kg m^2 there, 2.1 on the path) got
128 N m/rad and lagged 30 mrad; sized over the path, 3.6. The replay's ``servo_note`` and ``servo_kp`` state them.
The 1-7 mrad that were left on generated arms were the continuous feed-forward's mismatch with MuJoCo's discrete
step, not the gains: the feed-forward is now consistent with the step (:mod:`foam_mj.replay`) and leaves none.

Integrator (a choice, for every integrator of the model): the copy is stepped with ``implicitfast`` (an ``implicit``
model keeps ``implicit``), implicit in the servos' damping. Where the inertia is far below I_j the servos are stiff
and heavily damped: explicitly, eig(M^-1 kv) dt exceeds 2 (Euler, implicit in joint damping only) or 2.8 (RK4) and
the replay diverged (the generated arm at dt = 5 ms: every path under Euler; under RK4 errors of 2.3 to 4.8 rad or
a blow-up, some without MuJoCo's warning). Implicitly, (M + dt kv) v' = M v - dt kp q, q' = q + dt v', and as
kv = (2 / omega) kp every mode of M^-1 kp (eigenvalue lambda, any inertia and coupling) is stable when
lambda dt (dt - 4 / omega) < 4, for every lambda when omega dt < 4: omega is capped at 2 / dt (:func:`servo_omega`).
All four integrators then track alike. A model with its own servos keeps its integrator and gains (the Ortholeg's
Euler). When a replay still diverges, :attr:`foam_mj.replay.DynamicReplay.divergence_cause` names the likely cause.
"""

from __future__ import annotations

import mujoco
import numpy as np

from foam_mj.geom_pairs import bodies_moved_by, body_is_moving
from foam_mj.model import RobotModel

#: Natural frequency (Hz) of the servos added to a model that has none (module docstring).
SERVO_HZ = 10.0
#: Armature added to the dofs of joints outside the configuration in the dynamic replay, times the largest
#: diagonal inertia (module docstring): the configuration joints then move as on a fixed mount.
HOLD_ARMATURE = 1e8


def held_joints(robot: RobotModel) -> np.ndarray:
    """Ids of the joints outside the configuration (a floating base, a wrist left out, a loose object),
    which the dynamic replay holds where the trajectory puts them, as the planner does (:mod:`foam_mj.replay`)."""
    return np.setdiff1d(np.arange(robot.model.njnt), robot.config.joint_ids).astype(int)


def servo_problem(m: mujoco.MjModel, robot: RobotModel) -> str | None:
    """Why ``m`` cannot drive the configuration joints with one position servo each (None if it can)."""
    for name, j in zip(robot.config.joint_names, robot.config.joint_ids):
        acts = [
            a
            for a in range(m.nu)
            if int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT) and int(m.actuator_trnid[a, 0]) == int(j)
        ]
        if len(acts) != 1:
            return f"joint '{name}' has {len(acts)} joint actuators, not one position servo"
        a = acts[0]
        aname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or f"actuator{a}"
        if int(m.actuator_dyntype[a]) != int(mujoco.mjtDyn.mjDYN_NONE) or int(m.actuator_gaintype[a]) != int(mujoco.mjtGain.mjGAIN_FIXED):
            return f"actuator '{aname}' is not a position servo (activation dynamics or a non-fixed gain)"
        if not (m.actuator_gainprm[a, 0] > 0 and m.actuator_biasprm[a, 1] < 0):
            return f"actuator '{aname}' is not a position servo (kp > 0 needed)"
    return None


def effective_inertia(robot: RobotModel, qpos: np.ndarray | None = None, *, least: bool = False) -> np.ndarray:
    """(n,) the largest inertia each configuration joint drives over the configurations ``qpos`` (T, nq) (default:
    the configuration's ``qpos0`` alone) when the other configuration joints are free and every other joint is held:
    1 / (M_cc^-1)_jj, M_cc the joint-space inertia matrix (armature included) restricted to the configuration's dofs
    (kg m^2 or kg). Where M_cc is singular (two coaxial hinges on one body: either turns the body, so the other, free,
    drives nothing), a joint's inertia is M_jj, the inertia it drives with the others held. With ``least``, the
    smallest over the configurations instead."""
    m = robot.model
    qpos = np.atleast_2d(robot.config.qpos0 if qpos is None else np.asarray(qpos, dtype=float))
    d = mujoco.MjData(m)
    full = np.zeros((m.nv, m.nv))
    dof = m.jnt_dofadr[robot.config.joint_ids]
    M = np.empty((len(qpos), len(dof), len(dof)))
    for i, row in enumerate(qpos):
        d.qpos[:] = row
        for stage in (mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_tendon, mujoco.mj_makeM):  # mj_forward's M
            stage(m, d)
        mujoco.mj_fullM(m, d, full)
        M[i] = full[np.ix_(dof, dof)]
    held = np.diagonal(M, axis1=1, axis2=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        try:
            free = 1.0 / np.diagonal(np.linalg.inv(M), axis1=1, axis2=2)
        except np.linalg.LinAlgError:  # M_cc singular at some frame (coaxial hinges: at all): the held inertia
            free = np.zeros_like(held)
    inertia = np.where(np.isfinite(free) & (free > 1e-9 * held), free, held)
    return inertia.min(axis=0) if least else inertia.max(axis=0)


def explicit_damping_note(robot: RobotModel, m: mujoco.MjModel, actuators: np.ndarray, kv: np.ndarray, qpos: np.ndarray) -> str:
    """Why a model's own position servos shake under MuJoCo's Euler integrator ("" when they need not): Euler is
    implicit in joint damping but explicit in an actuator's, so a servo whose damping kv (times its gear squared)
    exceeds 2 I / timestep, I the smallest effective inertia of its joint over the configurations ``qpos`` (T, nq), has
    a mode that grows each step (kv dt / I is a lower bound of that mode's dt eig(M^-1 kv)): MuJoCo's own simulation
    of the model does the same, its force range at most bounding it (two Kinova Gen3 arms attached to a parent whose
    <option> is Euler's default: 3,378 mrad of tracking error, every servo at its force range; 0.00 under
    implicitfast, which the arm's own MJCF asks for). ``actuators`` and ``kv`` (N m s/rad at the joint) are the
    configuration joints' servos, in their order."""
    if int(m.opt.integrator) != int(mujoco.mjtIntegrator.mjINT_EULER) or not len(qpos):
        return ""
    inertia = effective_inertia(robot, qpos, least=True)
    ratio = kv * m.opt.timestep / inertia
    bad = np.flatnonzero(ratio > 2.0)
    if not bad.size:
        return ""
    worst = int(bad[np.argmax(ratio[bad])])
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, int(actuators[worst])) or f"actuator{int(actuators[worst])}"
    others = f" (and {bad.size - 1} other servo{'s' * (bad.size > 2)})" if bad.size > 1 else ""
    return (f"servo '{name}' ({robot.config.joint_names[worst]}){others} is unstable under MuJoCo's Euler integrator, explicit in "
            f"actuator damping: kv {kv[worst]:.4g} x timestep {m.opt.timestep:g} s / the joint's least effective inertia "
            f"{inertia[worst]:.3g} = {ratio[worst]:.3g} > 2, as in MuJoCo's own simulation "
            "of this model; step it with <option integrator=\"implicitfast\"/> (an <attach>ed model's <option> gives way "
            "to its parent's)")


def _exclude_held_contacts(spec: mujoco.MjSpec, m: mujoco.MjModel, robot: RobotModel) -> None:
    """Exclude contacts between bodies no configuration joint moves when one of them is held (a quadruped's stance
    feet on the floor, a base resting on its pedestal): both stay where they are, as on the planner's fixed mount,
    but MuJoCo's contact would push them apart by accelerations that no armature resists, and the held base's
    jolts reached the planned leg (34 mrad of tracking error on a Go2's swing leg, 1.1 without those contacts).
    Unnamed bodies are named in the copy for the exclusion."""
    moved = np.asarray(bodies_moved_by(m, robot.config).any(axis=0))
    live = np.zeros(m.nbody, dtype=bool)
    live[m.geom_bodyid[(m.geom_contype != 0) | (m.geom_conaffinity != 0)]] = True
    fixed = [b for b in range(m.nbody) if live[b] and not moved[b]]
    held = [b for b in fixed if body_is_moving(m, b)]
    if not held:
        return
    bodies = list(spec.bodies)  # in model order, the world first
    for b in fixed:
        if not bodies[b].name:
            bodies[b].name = f"foam_mj_body{b}"
    for a in held:
        for b in fixed:
            if b != a and (b not in held or b > a):
                spec.add_exclude(bodyname1=bodies[a].name, bodyname2=bodies[b].name)


def servo_model(robot: RobotModel, qpos: np.ndarray | None = None) -> tuple[mujoco.MjModel, str]:
    """The model the dynamic replay drives, and a one-line note ("" when no servo was added): ``robot.model`` itself
    when it has a position servo on every configuration joint and no other joint; else a copy in which the joints
    outside the configuration get the armature that makes them a fixed mount (:data:`HOLD_ARMATURE`), their range not applied, and, when some
    configuration joint lacks a position servo, all actuators are replaced by position servos sized from the joints'
    largest inertia over the configurations ``qpos`` (T, nq) the replay visits (default: ``qpos0``), stepped with
    ``implicitfast`` where the model is Euler or RK4 (module docstring)."""
    m = robot.model
    problem = servo_problem(m, robot)
    held = held_joints(robot)
    if problem is None and not len(held):
        return m, ""
    spec = robot.spec_copy()
    joints = list(spec.joints)  # in model order
    hold = HOLD_ARMATURE * max(1.0, float(m.dof_M0.max()))
    for j in held:
        joints[j].armature += hold
        # Held where the trajectory puts it (a keyframe may put it beyond its range), a joint's limit would push it
        # back by an acceleration no armature resists, and that pushed the planned joints (module docstring).
        joints[j].limited = mujoco.mjtLimited.mjLIMITED_FALSE
    _exclude_held_contacts(spec, m, robot)
    if problem is None:
        return spec.compile(), ""
    for act in list(spec.actuators):
        spec.delete(act)
    for sensor in list(spec.sensors):  # an actuator sensor (Cassie's actuatorpos) would name a deleted actuator
        if sensor.objtype == mujoco.mjtObj.mjOBJ_ACTUATOR:
            spec.delete(sensor)
    explicit = int(m.opt.integrator) in (int(mujoco.mjtIntegrator.mjINT_EULER), int(mujoco.mjtIntegrator.mjINT_RK4))
    if explicit:
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    omega = servo_omega(m.opt.timestep)
    for name, inertia in zip(robot.config.joint_names, effective_inertia(robot, qpos)):
        kp = float(inertia * omega**2)
        act = spec.add_actuator()
        act.name = f"foam_mj_servo_{name}"
        act.target = name
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.set_to_position(kp=kp, kv=2.0 * kp / omega)
    former = "RK4" if int(m.opt.integrator) == int(mujoco.mjtIntegrator.mjINT_RK4) else "Euler"
    note = (  # the same for every path of the model; the gains are the path's (DynamicReplay.servo_kp)
        f"dynamic replay: {problem}, so every configuration joint is driven by an added position servo, "
        f"kp = the joint's largest effective inertia along the path x (2 pi {omega / (2 * np.pi):.3g} Hz)^2, "
        "critically damped there"
        + (f", stepped with MuJoCo's implicitfast integrator (implicit in their damping) instead of {former}" if explicit else "")
    )
    return spec.compile(), note


def servo_omega(timestep: float) -> float:
    """The added servos' natural frequency (rad/s): 2 pi :data:`SERVO_HZ`, at most 2 / timestep (module docstring:
    with omega timestep < 4 the implicit step is stable for any inertia)."""
    return min(2 * np.pi * SERVO_HZ, 2.0 / timestep)
