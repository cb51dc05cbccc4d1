"""The planner benchmark's own clearance check of a final path (``benchmarks/planners.py``): mj_geomDistance every
1 mrad over :func:`foam_mj.verify.collision_pairs`, none of the planner's clearance code."""

from __future__ import annotations

import mujoco
import numpy as np

from foam_mj.model import RobotModel
from foam_mj.verify import collision_pairs

CHECK_STEP = 1e-3  # rad (max-norm in q) between densely checked configurations


class DenseChecker:
    """The smallest mj_geomDistance along a path, own code over :func:`foam_mj.verify.collision_pairs` (independent
    of the planner's model): robot/obstacle pairs (a geom moved by a configuration joint, or held in the subtree of the
    problem's ``robot_root``, against every other collision geom) and, when ``robot.self_collision``, the robot/robot
    pairs MuJoCo's collision detection tests (``foam-mj verify``'s pairs)."""

    def __init__(self, robot: RobotModel) -> None:
        m = self.m = robot.model
        self.d = mujoco.MjData(m)
        self.to_qpos = robot.config.to_qpos
        idx = robot.config.qpos_index
        # The robot_root's subtree is the robot, held parts (a floating base) included, as the planner has it: without
        # the root, a held base was an obstacle of its own arm and not checked against the floor.
        root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, robot.robot_root) if robot.robot_root else None
        self.pairs = [tuple(map(int, p)) for p in collision_pairs(m, idx, root=root)]
        obstacle = set(self.pairs)
        self.self_pairs = [tuple(map(int, p)) for p in collision_pairs(m, idx, self_collision=robot.self_collision, root=root)
                           if tuple(map(int, p)) not in obstacle]

    def min_clearance(self, path: np.ndarray) -> tuple[float, float | None]:
        """(robot/obstacle, robot/robot) smallest distance along ``path`` (rows of q), sampled every CHECK_STEP;
        the second is None without self pairs."""
        best, best_self = np.inf, np.inf
        m, d, gd = self.m, self.d, mujoco.mj_geomDistance
        for a, b in zip(path[:-1], path[1:]):
            n = max(1, int(np.ceil(np.max(np.abs(b - a)) / CHECK_STEP)))
            for qpos in self.to_qpos(a + (b - a) * np.linspace(0.0, 1.0, n + 1)[:, None]):
                d.qpos[:] = qpos
                mujoco.mj_kinematics(m, d)
                best = min(best, min(gd(m, d, g, o, 1.0, None) for g, o in self.pairs))
                if self.self_pairs:
                    best_self = min(best_self, min(gd(m, d, g, o, 1.0, None) for g, o in self.self_pairs))
        return float(best), (float(best_self) if self.self_pairs else None)

    def record(self, path: np.ndarray) -> dict:
        """The dense check's fields of a run's record: clearance and self_clearance (metres)."""
        clear, self_clear = self.min_clearance(path)
        return {"clearance": clear, "self_clearance": self_clear}


def qpos_length(robot: RobotModel, path: np.ndarray) -> float:
    qp = robot.config.to_qpos(path)[:, robot.config.qpos_index]
    return float(np.sum(np.linalg.norm(np.diff(qp, axis=0), axis=1)))
