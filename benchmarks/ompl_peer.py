"""OMPL as the planner benchmark's peer (``benchmarks/planners.py``): RRTConnect (+ PathSimplifier), RRT* and BIT*
on the same MJCF, joint bounds, geom pairs and margin as our planners (the optional extra: pip install -e ".[peers]")."""

from __future__ import annotations

import time

import numpy as np

from foam_mj.bubbles import BubbleOracle
from foam_mj.model import RobotModel
from foam_mj.paths import metrics

from dense_check import DenseChecker, qpos_length
from planner_problems import Problem

NO_OMPL = "OMPL is not installed (the optional extra: pip install -e \".[peers]\")"
OMPL_RESOLUTION = 0.01  # OMPL's default state validity checking resolution (fraction of the space's extent)


def have_ompl() -> bool:
    try:
        import ompl.geometric  # noqa: F401
    except ImportError:
        return False
    return True


class OMPLRunner:
    """OMPL on the same MJCF: a RealVectorStateSpace over the joint bounds in MuJoCo's units (x = scale * q: the
    leg's normalized hip displacement in metres), valid when MuJoCo's clearance > delta. In qpos units OMPL's
    distances (RRT*'s path length, simplification, ranges) are those of the ``len qpos`` column it is compared
    in; in q, RRT* minimized another length than the one compared (the leg problems).

    The bounds are the configuration joints' ranges, the box our planners sample in (every configuration joint is a
    limited hinge or slide: an unlimited joint is no configuration joint and stays at qpos0 for both sides). The
    validity checker is MuJoCo's distance over our certificate's geom pairs (contype/conaffinity, excluded and fixed
    pairs, self-collision as the problem says: ``Clearance.mujoco_clearance``), without our guard on MuJoCo's
    capsule/box distance, which costs about 7 us a state on the leg (40 % of a check) and which an OMPL user of
    MuJoCo would not have; a path it lets through a box is the dense check's to find. Motions are checked every ``resolution`` x the box's
    diagonal in qpos units (``setStateValidityCheckingResolution``; 0.01, OMPL's default, unless
    ``--ompl-resolution``); the absolute step is in the JSON (``ompl.longest_valid_segment``).

    Seeds: OMPL 2.0.1 draws every generator's seed from one process-wide seed (``RNG.setSeed``); each run sets it
    to the run's seed + 1 (0 means "random" to OMPL) before it builds its planner, so a run's samples depend on its
    seed alone, not on the runs before it in the process (measured: the same RRTConnect path whichever problems
    and seeds ran first). RRT* and BIT* stop on wall time (10 x RRTConnect's), so their iterations, and paths,
    still vary with the machine's load."""

    def __init__(self, pb: Problem, oracle: BubbleOracle, resolution: float = OMPL_RESOLUTION) -> None:
        from ompl import base as ob
        from ompl import geometric as og
        from ompl import util as ou

        self.ob, self.og, self.ou = ob, og, ou
        r = oracle.robot
        n = self.n = r.dim
        self.scale = np.asarray(r.config.scale, dtype=float)
        lo, hi = np.sort([self.scale * r.lower, self.scale * r.upper], axis=0)
        self.bounds = (lo, hi)
        self.space = ob.RealVectorStateSpace(n)
        bounds = ob.RealVectorBounds(n)
        for i in range(n):
            bounds.setLow(i, float(lo[i]))
            bounds.setHigh(i, float(hi[i]))
        self.space.setBounds(bounds)
        self.resolution = float(resolution)
        self.longest_valid_segment = self.resolution * float(np.linalg.norm(hi - lo))  # OMPL: fraction x getMaximumExtent()
        self.clearance = oracle.clearance  # the pairs and MuJoCo queries of our certificate
        self.checks = 0
        self.pb = pb

    def _setup(self, seed: int):
        ou, og = self.ou, self.og
        ou.setLogLevel(ou.LogLevel.LOG_NONE)  # setSeed's "generation already started" error: the seed applies to the generators made after it
        ou.RNG.setSeed(int(seed) + 1)
        ou.setLogLevel(ou.LogLevel.LOG_WARN)
        ss = og.SimpleSetup(self.space)
        n, clearance, delta, scale = self.n, self.clearance, self.pb.delta, self.scale

        def valid(state) -> bool:
            self.checks += 1
            return bool(clearance.mujoco_clearance(np.array([state[i] for i in range(n)]) / scale) > delta)

        ss.setStateValidityChecker(valid)
        ss.getSpaceInformation().setStateValidityCheckingResolution(self.resolution)
        start, goal = self.space.allocState(), self.space.allocState()
        x_init, x_goal = scale * self.pb.q_init, scale * self.pb.q_goal
        for i in range(n):
            start[i], goal[i] = float(x_init[i]), float(x_goal[i])
        ss.setStartAndGoalStates(start, goal)
        return ss

    def _path(self, p) -> np.ndarray:
        """The solution path as rows of q."""
        return np.array([[p.getState(k)[i] for i in range(self.n)] for k in range(p.getStateCount())]) / self.scale

    def rrtconnect(self, time_limit: float, seed: int) -> dict:
        t0, c0 = time.perf_counter(), time.process_time()
        self.checks = 0
        try:
            ss = self._setup(seed)
            si = ss.getSpaceInformation()
            ss.setPlanner(self.og.RRTConnect(si))
            solved = ss.solve(time_limit)
            first = time.perf_counter() - t0
            if not ss.haveExactSolutionPath():
                return {"ok": False, "outcome": str(solved), "seed": seed, "time": first, "queries": self.checks}
            p = ss.getSolutionPath()
            self.og.PathSimplifier(si).simplifyMax(p)
        except Exception as exc:  # OMPL's crash is counted as its failure, not a reason to lose every other run
            return {"ok": False, "outcome": f"ompl error: {type(exc).__name__}: {exc}", "seed": seed, "time": time.perf_counter() - t0}
        total, total_cpu = time.perf_counter() - t0, time.process_time() - c0
        return {"ok": True, "outcome": str(solved), "seed": seed, "first": first, "total": total, "total_cpu": total_cpu,
                "queries": self.checks, "path": self._path(p)}

    def optimizing(self, budget: float, seed: int, which: str = "rrtstar") -> dict:
        t0, c0 = time.perf_counter(), time.process_time()
        self.checks = 0
        try:
            ss = self._setup(seed)
            si = ss.getSpaceInformation()
            ss.setOptimizationObjective(self.ob.PathLengthOptimizationObjective(si))
            ss.setPlanner(self.og.RRTstar(si) if which == "rrtstar" else self.og.BITstar(si))
            solved = ss.solve(budget)
        except Exception as exc:
            return {"ok": False, "outcome": f"ompl error: {type(exc).__name__}: {exc}", "seed": seed, "budget": budget,
                    "time": time.perf_counter() - t0}
        total, total_cpu = time.perf_counter() - t0, time.process_time() - c0
        if not ss.haveExactSolutionPath():
            return {"ok": False, "outcome": str(solved), "seed": seed, "budget": budget, "time": total, "queries": self.checks}
        return {"ok": True, "outcome": str(solved), "seed": seed, "budget": budget, "first": None, "total": total, "total_cpu": total_cpu,
                "queries": self.checks, "path": self._path(ss.getSolutionPath())}


def finish_ompl(rec: dict, robot: RobotModel, checker: DenseChecker) -> dict:
    if rec.get("ok"):
        path = rec.pop("path")
        m = metrics(path)
        rec.update(len_q=m.length, len_qpos=qpos_length(robot, path), f=m.f, **checker.record(path), bubbles=None)
    return rec
