"""The certified curve seen in joint units, for the time laws of :mod:`foam_mj.timing`: qpos, dq/du and d2q/du2 at
path positions, and the coefficients of the joint torques along the path (tau = a sdd + b sd^2 + g + D sd, the
module docstring of :mod:`foam_mj.timing`)."""

from __future__ import annotations

import copy

import mujoco
import numpy as np

from foam_mj.dynamics import inverse_dynamics
from foam_mj.model import RobotModel
from foam_mj.safe_curve import SafeCurve


class PathKinematics:
    """The curve at path positions in MuJoCo's units: qpos (N, nq) and dq/du, d2q/du2 (N, n).

    The torque coefficients come from a copy of the model without joint friction (``frictionloss``), which
    is no term of the form a sdd + b sd^2: MuJoCo's friction force is nearly constant while a joint moves
    (up to its frictionloss), so read off at qacc = q' it would be scaled by sdd. ``friction`` (n,) bounds it
    instead, taken off the torque limits given to toppra (:mod:`foam_mj.timing`)."""

    def __init__(self, robot: RobotModel, curve: SafeCurve) -> None:
        self.robot, self.curve = robot, curve
        self.scale = robot.config.scale
        m = robot.model
        self.dof = m.jnt_dofadr[robot.config.joint_ids]
        self.damping = m.dof_damping[self.dof].copy()
        self.friction = m.dof_frictionloss[self.dof].copy()
        self.model = m
        if np.any(m.dof_frictionloss > 0):
            self.model = copy.copy(m)
            self.model.dof_frictionloss[:] = 0.0

    def at(self, u: np.ndarray):
        q, qu, quu = self.curve.evaluate(u)
        return self.robot.config.to_qpos(q), qu * self.scale, quu * self.scale

    def coefficients(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """a(u), b(u), g(u), D(u) (N, n): tau = a sdd + b sd^2 + g + D sd, D = B q' (module docstring);
        cached per grid."""
        key = (len(u), float(u[0]), float(u[-1]), float(np.sum(u)))
        if getattr(self, "_cache_key", None) != key:
            self._cache = self._coefficients(u)
            self._cache_key = key
        return self._cache

    def _coefficients(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        m = self.model
        qpos, qu, quu = self.at(u)
        N = len(u)
        zero = np.zeros((N, m.nv))
        vel = zero.copy()
        acc = zero.copy()
        d = mujoco.MjData(m)
        g = inverse_dynamics(self.robot, qpos, zero, zero, d, m)[:, self.dof]
        acc[:, self.dof] = qu
        a = inverse_dynamics(self.robot, qpos, zero, acc, d, m)[:, self.dof] - g
        vel[:, self.dof] = qu
        acc[:, self.dof] = quu
        b = inverse_dynamics(self.robot, qpos, vel, acc, d, m)[:, self.dof] - g - self.damping * qu
        return a, b, g, self.damping * qu
