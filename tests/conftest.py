"""Shared fixtures: the built-in scenes, loaded once per session, and an independent collision check."""

from __future__ import annotations

import os
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
from hypothesis import settings

from foam_mj.data import models_dir

from foam_mj.bubbles import BubbleOracle
from foam_mj.model import RobotModel
from foam_mj.rosary import Rosary

#: CI (``CI`` set, as .ci/run does) runs the property tests on hypothesis's derandomized examples, so that whether a
#: change lands does not depend on the day's draw; a local run draws new examples each time.
settings.register_profile("ci", derandomize=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

MODELS = models_dir()
SCENES = ("obstacle", "step_up", "step_down")
#: A line of ``plan``'s progress log off a terminal (foam_mj.progress): "[12.3 s] smoothing: convex shortest path".
PROGRESS_LINE = re.compile(r"\[\d+\.\d s\] ")


def messages(err: str) -> list[str]:
    """The lines of a command's stderr besides its progress log: its warnings and errors."""
    return [line for line in err.splitlines() if not PROGRESS_LINE.match(line)]


def wall_scenario(folder: Path, time_limit: float = 60.0, planner: str | None = None) -> Path:
    """A scenario TOML in ``folder``: the leg's foot behind a wall it cannot pass, so that a plan runs for a long while
    (until it stalls, or its ``time_limit``), long enough to interrupt it; ``planner``: the ``[planner]`` table's
    body instead of that time limit (e.g. ``"max_bubbles = 3000"``)."""
    scene = folder / "wall.xml"
    scene.write_text(
        f'<mujoco><include file="{MODELS / "ortholeg.xml"}"/><worldbody><geom name="floor" type="plane" size="3 3 0.1"/>'
        '<geom name="wall" type="box" pos="0.46 0 0.75" size="0.04 0.25 0.75"/></worldbody></mujoco>'
    )
    toml = folder / "wall.toml"
    toml.write_text(f'scene = "{scene}"\nq_init = [0.2, 0.3, 0.08]\nq_goal = [0.45, 0.4536, 1.45]\n[planner]\n{planner or f"time_limit = {time_limit}"}\n')
    return toml


def wait_for_stderr(proc, pattern: str, timeout: float = 120.0) -> list[str]:
    """Read ``proc``'s stderr (a text pipe) line by line until a line holds ``pattern`` (a state the command has
    observably reached: "planning (" once its plan is under way) or the process ends; the lines read. A generous
    ``timeout`` instead of a fixed sleep: under load the command reaches that state seconds later, never sooner than it
    says so. The rest of stderr stays in the pipe for ``communicate``."""
    import threading

    lines: list[str] = []
    seen = threading.Event()

    def read() -> None:
        for line in proc.stderr:
            lines.append(line)
            if pattern in line:
                break
        seen.set()

    threading.Thread(target=read, daemon=True).start()
    if not seen.wait(timeout):
        raise AssertionError(f"no stderr line with {pattern!r} within {timeout} s: {''.join(lines)}")
    return lines


#: The bring-your-own-robot example's two-link arm (a post in front of it), the base of the odd-actuator tests.
TWO_LINK_ARM = Path(__file__).resolve().parents[1] / "examples" / "two_link_arm" / "arm.xml"


def arm_with(folder: Path, actuators: str, xml_edit=None) -> Path:
    """The two-link arm with ``actuators`` (MJCF <actuator> children) written to ``folder``/arm.xml (after
    ``xml_edit``, a str -> str edit of the MJCF, if given); returns that file."""
    xml = TWO_LINK_ARM.read_text()
    xml = xml_edit(xml) if xml_edit is not None else xml
    path = folder / "arm.xml"
    path.write_text(xml.replace("</worldbody>", f"</worldbody><actuator>{actuators}</actuator>"))
    return path


def segment_rosary(a: np.ndarray, b: np.ndarray) -> Rosary:
    """One bubble holding the straight segment a -> b, its radius made up (not certified): for timing and replay
    tests, which take the path as given."""
    return Rosary(((a + b) / 2)[None], np.array([np.linalg.norm(b - a)]), a, b)


@pytest.fixture(scope="session")
def robots() -> dict[str, RobotModel]:
    return {name: RobotModel.from_xml(MODELS / f"{name}.xml") for name in SCENES}


@pytest.fixture(scope="session")
def obstacle_robot(robots) -> RobotModel:
    return robots["obstacle"]


@pytest.fixture(scope="session")
def oracles(robots) -> dict[str, BubbleOracle]:
    return {name: BubbleOracle(r, delta=0.005) for name, r in robots.items()}


class MujocoChecker:
    """Collision and distance straight from MuJoCo, sharing no code with foam_mj's clearance.

    Robot geoms are those on bodies moved by a joint, obstacles those on static bodies, as in
    shared/tools/verify_result.py.
    """

    def __init__(self, robot: RobotModel) -> None:
        self.m = robot.model
        self.d = mujoco.MjData(self.m)
        self.to_qpos = robot.config.to_qpos
        m = self.m

        def moving(b: int) -> bool:
            while b != 0:
                if m.body_jntnum[b] > 0:
                    return True
                b = m.body_parentid[b]
            return False

        colliding = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
        self.leg = {g for g in colliding if moving(int(m.geom_bodyid[g]))}
        self.obs = {g for g in colliding if not moving(int(m.geom_bodyid[g]))}
        self._leg = np.isin(np.arange(m.ngeom), list(self.leg))
        self._obs = np.isin(np.arange(m.ngeom), list(self.obs))

    def collides(self, q: np.ndarray) -> bool:
        """mj_collision at q: any contact between a leg geom and an obstacle geom."""
        return self._collides_qpos(self.to_qpos(q))

    def _collides_qpos(self, qpos: np.ndarray) -> bool:
        self.d.qpos[:] = qpos
        mujoco.mj_kinematics(self.m, self.d)
        mujoco.mj_collision(self.m, self.d)
        g = self.d.contact.geom[: self.d.ncon]
        if len(g) == 0:
            return False
        return bool(np.any((self._leg[g[:, 0]] & self._obs[g[:, 1]]) | (self._leg[g[:, 1]] & self._obs[g[:, 0]])))

    def distance(self, q: np.ndarray) -> float:
        """min mj_geomDistance over every leg/obstacle pair at q."""
        self.d.qpos[:] = self.to_qpos(q)
        mujoco.mj_kinematics(self.m, self.d)
        return min(mujoco.mj_geomDistance(self.m, self.d, g, o, 10.0, None) for g in self.leg for o in self.obs)

    def first_collision_along(self, points: np.ndarray, step: float = 1e-3) -> np.ndarray | None:
        """The first configuration in collision along the polyline sampled every ``step`` (max-norm), or None."""
        for a, b in zip(points[:-1], points[1:]):
            n = max(1, int(np.ceil(np.max(np.abs(b - a)) / step)))
            qs = a + (b - a) * np.linspace(0.0, 1.0, n + 1)[:, None]
            for q, qpos in zip(qs, self.to_qpos(qs)):
                if self._collides_qpos(qpos):
                    return q
        return None


@pytest.fixture(scope="session")
def checkers(robots) -> dict[str, MujocoChecker]:
    return {name: MujocoChecker(r) for name, r in robots.items()}


@pytest.fixture(scope="session")
def planned_result(tmp_path_factory) -> Path:
    """A `foam-mj plan --json` result of the obstacle scene (default smoother, timed trajectories)."""
    from foam_mj.cli import main

    out = tmp_path_factory.mktemp("planned") / "obstacle.json"
    assert main(["plan", "--scene", "obstacle", "--no-rrd", "--json", str(out)]) == 0
    return out
