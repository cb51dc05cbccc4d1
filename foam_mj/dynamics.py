"""Joint loads along a timed trajectory: torques by inverse dynamics, power, work, and how they compare
with the actuators and with human walking.

Inverse dynamics
----------------
For every sample (qpos, qvel, qacc) of a :class:`~foam_mj.trajectory.Trajectory`, ``mujoco.mj_inverse``
gives the generalized force the joints must supply,

    tau = M(q) qdd + c(q, qd) + g(q) + B qd        (MuJoCo's qfrc_inverse, no contacts in swing),

with M the joint-space inertia (armature included), c the Coriolis and centrifugal forces, g gravity and
B the joint damping of the MJCF: the model's gravity and inertia, of the subject-scaled model when the
scenario scales one (it is whatever model the scenario compiled). ``mj_inverse`` has no batched form in
MuJoCo's Python bindings (``mujoco.rollout`` runs forward dynamics only), so it is called once per sample
on one MjData: about 3 us each, 3 ms for a 1,000-sample swing. Hinges are in N m, slides in N.

Mechanical power per joint is P = tau qd (W); positive work is the integral of max(P, 0) and negative
work of min(P, 0) (trapezoidal rule on the samples, joules): what a motor must supply, and what it must
absorb (brake, or regenerate).

Actuator limits
---------------
A configuration joint's torque limit is read from the MJCF: the force range of the joint-transmission
actuator(s) driving it times their gear (``actuator_forcerange`` where ``actuator_forcelimited``; for a
motor, whose force is gain x ctrl, also its ``ctrlrange`` times its gain: ``<motor gear="100"
ctrlrange="-1 1"/>`` makes at most 100 N m), else the joint's own ``actfrcrange`` (``jnt_actfrclimited``);
a joint with neither has no limit (infinity).
Where two actuators drive one joint their ranges add. The limit is symmetric: the smaller of |lower| and
upper (a choice: every actuator of the shipped models is symmetric, and a symmetric limit is what the
time law needs to stay conservative).

Human reference
---------------
:data:`HUMAN_SWING` holds the peak hip and knee moments of the swing phase of normal walking, per kilogram
of body mass, from Winter's reference walking trial (Winter 2009, Appendix A; docs/references.md). They
are printed beside the planned torques divided by the subject's body mass, so the user sees whether the
planned swing asks more of the joints than walking does. The body mass is the subject's the model is
built for, the MJCF custom numeric ``foam_mj:subject`` = "height mass" (the Ortholeg's 75 kg adult, or
the scenario's ``[subject]`` once scaled), or the caller's; without one no per-kilogram figure is given.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from foam_mj.mjcf import _custom_numeric
from foam_mj.model import RobotModel
from foam_mj.trajectory import Trajectory, check_trajectory

#: MJCF custom numeric "height mass" of the subject the model is built for (metres, kilograms; kept
#: up to date by subject scaling, foam_mj.anthropometry): its mass gives the per-kilogram torques.
SUBJECT_FIELD = "foam_mj:subject"


@dataclass(frozen=True)
class HumanReference:
    """Peak joint moments of a published gait trial, per kilogram of body mass (N m/kg)."""

    source: str
    body_mass: float  # kg, the trial's subject
    hip: float  # N m/kg, peak |hip moment| in swing
    knee: float  # N m/kg, peak |knee moment| in swing
    note: str


# Winter, D. A. (2009). Biomechanics and Motor Control of Human Movement, 4th ed., Wiley, Appendix A:
# one subject of 56.7 kg walking at about 1.43 m/s; swing of the right leg from toe-off (frame 70) to heel
# contact (frame 97), Table A.5(b) (moments on the thigh and the leg). Read every third frame: the largest
# swing moments are 19.0 N m at the hip (extensor, frame 91, late swing decelerating the thigh) and
# 14.5 N m at the knee (flexor, frames 91-94, decelerating the shank); 19.0 / 56.7 = 0.335 and
# 14.5 / 56.7 = 0.256 N m/kg. Every third frame of 69.9 frames/s: the true peaks may be slightly higher. Early swing's hip flexor moment peaks at 13.6 N m (0.24 N m/kg, frame 73).
HUMAN_SWING = HumanReference(
    source="Winter (2009), Biomechanics and Motor Control of Human Movement, 4th ed., Appendix A, Table A.5",
    body_mass=56.7,
    hip=19.0 / 56.7,
    knee=14.5 / 56.7,
    note="normal walking at 1.43 m/s, swing phase (toe-off to heel contact), one adult subject",
)


def torque_limits(robot: RobotModel) -> np.ndarray:
    """(n,) symmetric torque (N m) or force (N) limit of every configuration joint from the MJCF (module
    docstring); ``inf`` where the model declares none."""
    m = robot.model
    out = np.full(robot.dim, np.inf)
    for i, j in enumerate(robot.config.joint_ids):
        total, found = 0.0, False
        for a in range(m.nu):
            if int(m.actuator_trntype[a]) != int(mujoco.mjtTrn.mjTRN_JOINT) or int(m.actuator_trnid[a, 0]) != int(j):
                continue
            bound = _actuator_force_bound(m, a)
            if not np.isfinite(bound):
                found = False
                total = np.inf
                break
            total += bound * abs(float(m.actuator_gear[a, 0]))
            found = True
        if found and np.isfinite(total):
            out[i] = total
        if m.jnt_actfrclimited[j]:
            lo, hi = (float(v) for v in m.jnt_actfrcrange[j])
            out[i] = min(out[i], min(abs(lo), abs(hi)))
    return out


def _actuator_force_bound(m: mujoco.MjModel, a: int) -> float:
    """The largest symmetric |force| actuator ``a`` can make (before its gear; inf when unbounded): its force
    range, and for a motor (force = gain ctrl: no bias, no activation) also gain times its control range."""
    bound = np.inf
    if m.actuator_forcelimited[a]:
        lo, hi = (float(v) for v in m.actuator_forcerange[a])
        bound = min(abs(lo), abs(hi))
    motor = (int(m.actuator_dyntype[a]) == int(mujoco.mjtDyn.mjDYN_NONE)
             and int(m.actuator_gaintype[a]) == int(mujoco.mjtGain.mjGAIN_FIXED)
             and int(m.actuator_biastype[a]) == int(mujoco.mjtBias.mjBIAS_NONE))
    if motor and m.actuator_ctrllimited[a]:
        lo, hi = (float(v) for v in m.actuator_ctrlrange[a])
        bound = min(bound, abs(float(m.actuator_gainprm[a, 0])) * min(abs(lo), abs(hi)))
    return bound


def joint_units(robot: RobotModel) -> tuple[tuple[str, str, str, str], ...]:
    """Per configuration joint: units of (q, qd, qdd, tau): ("rad", "rad/s", "rad/s^2", "N m") for a
    hinge, ("m", "m/s", "m/s^2", "N") for a slide."""
    out = []
    for j in robot.config.joint_ids:
        if int(robot.model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_SLIDE):
            out.append(("m", "m/s", "m/s^2", "N"))
        else:
            out.append(("rad", "rad/s", "rad/s^2", "N m"))
    return tuple(out)


def body_mass(robot: RobotModel) -> float | None:
    """The subject's body mass (kg) declared in the MJCF (``foam_mj:subject`` = "height mass"), or None."""
    v = _custom_numeric(robot.model, SUBJECT_FIELD)
    if v is None or v.size != 2 or not (np.isfinite(v[1]) and v[1] > 0):
        return None
    return float(v[1])


def inverse_dynamics(robot: RobotModel, qpos, qvel, qacc, data: mujoco.MjData | None = None,
                     model: mujoco.MjModel | None = None) -> np.ndarray:
    """qfrc_inverse (T, nv) of ``mujoco.mj_inverse`` at every row of qpos (T, nq), qvel and qacc (T, nv), on
    ``model`` (default ``robot.model``; ``data`` must belong to it)."""
    m = robot.model if model is None else model
    qpos = np.atleast_2d(np.asarray(qpos, dtype=float))
    qvel = np.atleast_2d(np.asarray(qvel, dtype=float))
    qacc = np.atleast_2d(np.asarray(qacc, dtype=float))
    T = len(qpos)
    if qpos.shape != (T, m.nq) or qvel.shape != (T, m.nv) or qacc.shape != (T, m.nv):
        raise ValueError(f"qpos, qvel, qacc must be ({T}, {m.nq}), ({T}, {m.nv}), ({T}, {m.nv}); got {qpos.shape}, {qvel.shape}, {qacc.shape}")
    d = mujoco.MjData(m) if data is None else data
    out = np.empty((T, m.nv))
    for i in range(T):  # no batched mj_inverse in the bindings (module docstring)
        d.qpos[:] = qpos[i]
        d.qvel[:] = qvel[i]
        d.qacc[:] = qacc[i]
        mujoco.mj_inverse(m, d)
        out[i] = d.qfrc_inverse
    return out


@dataclass(frozen=True)
class JointLoads:
    """What the joints must do along a trajectory: tau (T, n) in N m (hinges) or N (slides), power (T, n)
    in W, for the configuration joints in order; ``limit`` (n,) the torque limits they are held to (the
    MJCF's actuator force ranges unless the time law was given others; inf: none);
    ``body_mass`` the subject's mass in kg (None when unknown)."""

    joint_names: tuple[str, ...]
    torque_units: tuple[str, ...]
    times: np.ndarray
    tau: np.ndarray
    power: np.ndarray
    limit: np.ndarray
    body_mass: float | None = None

    @property
    def peak(self) -> np.ndarray:
        """(n,) largest |tau|."""
        return np.abs(self.tau).max(axis=0)

    @property
    def rms(self) -> np.ndarray:
        """(n,) root mean square of tau over time (trapezoidal)."""
        T = self.times[-1] - self.times[0]
        return np.sqrt(np.trapezoid(self.tau**2, self.times, axis=0) / T)

    @property
    def peak_power(self) -> np.ndarray:
        """(n,) largest |P| (W)."""
        return np.abs(self.power).max(axis=0)

    @property
    def positive_work(self) -> np.ndarray:
        """(n,) integral of max(P, 0) dt (J): energy the joint's motor supplies."""
        return np.trapezoid(np.maximum(self.power, 0.0), self.times, axis=0)

    @property
    def negative_work(self) -> np.ndarray:
        """(n,) integral of min(P, 0) dt (J, <= 0): energy the joint's motor absorbs."""
        return np.trapezoid(np.minimum(self.power, 0.0), self.times, axis=0)

    @property
    def use(self) -> np.ndarray:
        """(n,) peak |tau| / limit (0 where there is no limit)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(np.isfinite(self.limit), self.peak / self.limit, 0.0)

    @property
    def per_kg(self) -> np.ndarray | None:
        """(n,) peak |tau| per kilogram of body mass, or None without a body mass."""
        return None if self.body_mass is None else self.peak / self.body_mass

    def summary(self) -> dict:
        """Plain numbers for the JSON result (a non-finite limit is null)."""
        return {
            "joints": list(self.joint_names),
            "torque_units": list(self.torque_units),
            "peak_torque": self.peak.tolist(),
            "rms_torque": self.rms.tolist(),
            "peak_power": self.peak_power.tolist(),
            "positive_work": self.positive_work.tolist(),
            "negative_work": self.negative_work.tolist(),
            "torque_limit": [float(v) if np.isfinite(v) else None for v in self.limit],
            "peak_use": self.use.tolist(),
            "body_mass": self.body_mass,
            "peak_torque_per_kg": None if self.per_kg is None else self.per_kg.tolist(),
        }


def joint_loads(robot: RobotModel, trajectory: Trajectory, mass: float | None = None, limit=None) -> JointLoads:
    """Torques (``mj_inverse``), power and work of ``trajectory`` for ``robot``'s configuration joints.
    ``mass``: the subject's body mass in kg (default: the MJCF's ``foam_mj:subject``, if any); ``limit``:
    the torque limits (n,) the loads are compared with (default: the MJCF's, :func:`torque_limits`)."""
    check_trajectory(robot, trajectory)  # another robot's trajectory gave that robot's loads of the wrong motion, silently
    if trajectory.qvel is None or trajectory.qacc is None:
        raise ValueError("`trajectory` needs qvel and qacc for inverse dynamics")
    m = robot.model
    dof = m.jnt_dofadr[robot.config.joint_ids]
    tau = inverse_dynamics(robot, trajectory.qpos, trajectory.qvel, trajectory.qacc)[:, dof]
    qd = trajectory.qvel[:, dof]
    return JointLoads(
        joint_names=tuple(robot.config.joint_names),
        torque_units=tuple(u[3] for u in joint_units(robot)),
        times=trajectory.times.copy(),
        tau=tau,
        power=tau * qd,
        limit=torque_limits(robot) if limit is None else np.asarray(limit, dtype=float),
        body_mass=body_mass(robot) if mass is None else float(mass),
    )
