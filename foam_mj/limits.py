"""The joint limits a time law keeps (:mod:`foam_mj.timing`): velocity and acceleration (per joint, or the
defaults per joint type of :class:`~foam_mj.trajectory.JointLimits`) and torque (the MJCF's actuators,
:func:`foam_mj.dynamics.torque_limits`), as a scenario's ``[limits]`` table gives them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from foam_mj.dynamics import torque_limits
from foam_mj.model import RobotModel, require_robot_model
from foam_mj.trajectory import MAX_STEPS, JointLimits


def _positive_list(value, name: str, allow_inf: bool = False) -> tuple[float, ...] | None:
    if value is None:
        return None
    try:
        vals = tuple(float("inf") if (v is None and allow_inf) else float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be a list of numbers, got {value!r}") from None
    ok = all((np.isfinite(v) or (allow_inf and v == np.inf)) and v > 0 for v in vals)
    if isinstance(value, (str, bytes)) or not vals or not ok:
        raise ValueError(f"`{name}` must be a non-empty list of finite numbers > 0, got {value!r}")
    return vals


@dataclass(frozen=True)
class Limits:
    """Joint limits for the time law (:mod:`foam_mj.timing`): ``velocity``, ``acceleration``, ``torque`` lists
    in configuration-joint order and joint units, None for the defaults (``joint`` for velocity and
    acceleration, the MJCF's actuator force ranges for torque)."""

    velocity: tuple[float, ...] | None = None
    acceleration: tuple[float, ...] | None = None
    torque: tuple[float, ...] | None = None
    joint: JointLimits = field(default_factory=JointLimits)

    def __post_init__(self) -> None:
        for name in ("velocity", "acceleration", "torque"):  # torque: None/inf entries mean "no limit"
            object.__setattr__(self, name, _positive_list(getattr(self, name), name, allow_inf=name == "torque"))
        if not isinstance(self.joint, JointLimits):
            raise ValueError(f"`joint` must be a JointLimits, got {type(self.joint).__name__}")

    def resolve(self, robot: RobotModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(velocity, acceleration, torque), each (n,) in joint units; torque is inf where unlimited."""
        # an oracle was "'BubbleOracle' object has no attribute 'config'"
        require_robot_model(robot, " (a BubbleOracle's is oracle.robot)" if hasattr(robot, "robot") else "")
        v, a = self.joint.resolve(robot)
        tau = torque_limits(robot)
        n = robot.dim
        for name, given in (("velocity", self.velocity), ("acceleration", self.acceleration), ("torque", self.torque)):
            if given is not None and len(given) != n:
                raise ValueError(f"limits `{name}` must have {n} numbers ({', '.join(robot.config.joint_names)}), got {len(given)}")
        if self.velocity is not None:
            v = np.array(self.velocity)
        if self.acceleration is not None:
            a = np.array(self.acceleration)
        if self.torque is not None:
            tau = np.array(self.torque)
        return v, a, tau

    def joint_limits(self, robot: RobotModel) -> JointLimits:
        """The velocity and acceleration limits as a :class:`JointLimits` (for ``make_trajectory``)."""
        v, a, _ = self.resolve(robot)
        j = self.joint
        return JointLimits(j.hinge_velocity, j.hinge_acceleration, j.slide_velocity, j.slide_acceleration,
                           {name: (float(v[i]), float(a[i])) for i, name in enumerate(robot.config.joint_names)})

    @classmethod
    def from_dict(cls, doc: dict) -> "Limits":
        """The limits :meth:`as_dict` wrote (null torque: no limit)."""
        return cls(velocity=doc.get("velocity"), acceleration=doc.get("acceleration"), torque=doc.get("torque"))

    def as_dict(self, robot: RobotModel) -> dict:
        """The resolved limits, for the JSON result (an absent torque limit is null)."""
        v, a, tau = self.resolve(robot)
        return {"joints": list(robot.config.joint_names), "velocity": v.tolist(), "acceleration": a.tolist(),
                "torque": [float(t) if np.isfinite(t) else None for t in tau]}


def as_limits(limits: Limits | JointLimits | None) -> Limits:
    """``limits`` as a :class:`Limits` (a bare JointLimits sets the velocity/acceleration defaults)."""
    if limits is None:
        return Limits()
    if isinstance(limits, JointLimits):
        return Limits(joint=limits)
    if isinstance(limits, Limits):
        return limits
    raise ValueError(f"`limits` must be a Limits or JointLimits, got {type(limits).__name__}")


def endless_motion(limits: "Limits | None", robot: RobotModel, q_init: ArrayLike, q_goal: ArrayLike) -> str | None:
    """Why no timing of any path from ``q_init`` to ``q_goal`` fits in :data:`~foam_mj.trajectory.MAX_STEPS` timesteps
    under ``limits`` (None: the defaults), or None. Each joint moves at least d = |q_goal - q_init| (joint units), which
    takes at least max(d / v, 2 sqrt(d / a)) from rest to rest: [limits] velocity = 1e-6 was a MemoryError after
    planning, 1e-300 an OverflowError."""
    v, a, _ = (limits or Limits()).resolve(robot)
    d = np.abs((np.asarray(q_goal, float) - np.asarray(q_init, float)) * robot.config.scale)
    dt = robot.model.opt.timestep
    t = np.maximum(d / v, 2 * np.sqrt(d / a)) / dt
    if not np.any(t > MAX_STEPS):
        return None
    j = int(np.argmax(t))
    return (f"joint {robot.config.joint_names[j]} moves {d[j]:.3g} from q_init to q_goal: at its velocity limit {v[j]:g} and "
            f"acceleration limit {a[j]:g} that takes {t[j]:,.3g} timesteps of {dt:g} s or more, past the {MAX_STEPS:,} a trajectory may have")

