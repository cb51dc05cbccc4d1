"""The ``.rrd`` recording of a command, written by a helper process that loads Rerun while the command plans.

Loading Rerun (``rerun``, ``pyarrow`` and what they import) costs about 0.3-0.4 s of CPU, a fifth of
``foam-mj plan --scene obstacle``. ``plan`` therefore starts :class:`RecorderProcess` first thing: a
second Python process that imports :mod:`foam_mj.recording` (and so Rerun; not the planners, not scipy)
and waits on its standard input, so that this import runs on another core beside the command's own
imports and planning instead of after them. When the run is done, the command sends a
:class:`RecordingJob` (the ``Recording`` calls with their data, pickled: a few MB, milliseconds) and the
helper writes the file, atomically as :class:`~foam_mj.recording.Recording` always does. The file holds
the same recording as one written in the command's own process (tests/test_recorder.py compares them).

The helper is a speed-up only, used where a core is free for it (:func:`helper_helps`). The environment
variable ``FOAM_MJ_RECORDER`` chooses: ``auto`` (default), ``process`` (always the helper), ``inline``
(never). When the helper is not used, cannot start, or fails for any reason, the job runs in the
command's own process, so errors (an output that cannot be written: exit 2) are reported exactly as
without it. When the command ends without sending a job (bad input, Ctrl-C), the helper is stopped: it
writes nothing before it has received a whole job.

Cost: the helper imports numpy and MuJoCo a second time (about 0.6 s of CPU in all on a busy 2-core
machine), which shortens the wall time only when a core would otherwise be idle.
"""

from __future__ import annotations

import copy
import os
import pickle
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: Environment variable choosing where recordings are written: ``auto`` (the default: the helper process
#: when a core is free, see :func:`helper_helps`), ``process`` (always the helper), ``inline`` (never).
MODE_ENV = "FOAM_MJ_RECORDER"
MODES = ("auto", "process", "inline")
#: Seconds the command waits for the helper to write a job before writing it itself.
TIMEOUT = 600.0


@dataclass
class RecordingJob:
    """A recording to write: ``calls`` are (method name, positional arguments) of
    :class:`~foam_mj.recording.Recording`, in order."""

    path: Path
    recording_id: str
    calls: list[tuple[str, tuple]] = field(default_factory=list)

    def add(self, method: str, *args: Any) -> None:
        self.calls.append((method, args))

    def write(self) -> None:
        """Write the file here, in this process (raises what Recording raises, e.g. OutputError)."""
        from foam_mj.recording import Recording

        with Recording(self.path, recording_id=self.recording_id) as rec:
            for method, args in self.calls:
                getattr(rec, method)(*args)


def unique_recording_id(stem: str) -> str:
    """``stem`` and 8 random hex digits: Rerun's viewer merges every file of one application and recording id into
    one recording (two plans of one scene opened together showed one foam and a mix of both runs' motions)."""
    import secrets

    return f"{stem}-{secrets.token_hex(4)}"


def primary_path(names) -> str | None:
    """Of the paths ``names`` (in the summary's order), the one whose robot a recording draws in the model's colours
    (the others' robots: translucent, in their path's colour): the default smoother's (``optimal``) when there, else
    the last one; None for no path."""
    from foam_mj.smoother_names import DEFAULT_SMOOTHER, SMOOTHERS

    names = list(names)
    default = SMOOTHERS[DEFAULT_SMOOTHER][-1]
    return default if default in names else (names[-1] if names else None)


def _portable_robot(robot):
    """``robot`` without its MjSpec (which cannot be pickled; the recording reads only the compiled model)."""
    if getattr(robot, "spec", None) is None:
        return robot
    out = copy.copy(robot)
    out.spec = None
    return out


def outcome_job(path: str | os.PathLike, outcome=None, *, scenario=None, foam=None) -> RecordingJob:
    """The recording of a pipeline outcome (scene, foam and rosary, every path with its trajectory, joint
    loads, replay, convergence and Pareto front; every robot but the :func:`primary_path`'s tinted), or with
    ``outcome`` None of the foam grown so far and the robot at q_init and q_goal."""
    scenario = outcome.scenario if outcome is not None else scenario
    robot = _portable_robot(scenario.robot)
    job = RecordingJob(Path(path), unique_recording_id(f"foam-mj-{scenario.name}"))
    job.add("log_scene", robot)
    if outcome is not None:
        foam, rosary = outcome.plan.foam, outcome.plan.rosary
    else:  # as Recording.log_foam: the foam's own rosary if it reached the goal
        rosary = foam.rosary() if foam.goal_bubble is not None else None
    # The foam's arrays, not the Foam: the helper then never imports foam_mj.foam (and its scipy.spatial).
    job.add("log_bubbles", foam.centers, foam.radii, foam.q_init, foam.q_goal, rosary)
    if outcome is None:  # a failed plan: the robot where it starts and where it was asked to go (it showed no robot)
        job.add("log_configurations", robot, {"q_init": foam.q_init, "q_goal": foam.q_goal})
        return job
    primary = primary_path(name for name, po in outcome.paths.items() if po.kinematic is not None)
    for name, po in outcome.paths.items():
        job.add("log_path", name, po.result.path)
        if po.trajectory is not None:
            job.add("log_joint_trajectory", name, po.trajectory)
        if getattr(po, "loads", None) is not None:
            job.add("log_joint_loads", name, po.loads)
        # The robot and its clearance along the planned trajectory (as the summary's min clear and `verify`); the
        # servo replay adds its tracking errors and contacts (its own poses drifted up to millimetres from the plan).
        if po.kinematic is not None:
            job.add("log_replay", name, robot, po.kinematic, name != primary)
        if po.dynamic is not None:
            job.add("log_tracking", name, po.dynamic)
        if name in ("hs", "ga") or len(po.result.history_best) > 1:
            job.add("log_convergence", name, po.result.history_best, po.result.history_mean)
        front = po.result.info.get("front") if po.result.info else None
        if front is not None:
            job.add("log_pareto_front", name, front["objectives"], front["paths"], front.get("knee"),
                    tuple(front.get("objective_names", ("length", "angle term"))))
    return job


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def helper_helps() -> bool:
    """Whether a helper process would shorten the command (``auto`` mode): two or more usable cores and a
    load average over the last minute below cores - 0.5, i.e. about a core free for it. On a machine
    whose cores are all busy the helper's own imports (~0.6 s of CPU) would only compete with the command."""
    cores = _usable_cores()
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # pragma: no cover - no load average on this system
        load = 0.0
    return cores >= 2 and load < cores - 0.5


def recorder_mode() -> str:
    """``FOAM_MJ_RECORDER`` (``auto`` when unset or empty); a value not in :data:`MODES` is bad input."""
    mode = os.environ.get(MODE_ENV, "").strip().lower() or "auto"
    if mode not in MODES:
        from foam_mj.errors import FoamError

        raise FoamError(f"environment variable {MODE_ENV} must be one of {', '.join(MODES)}, got {os.environ[MODE_ENV]!r}")
    return mode


class RecorderProcess:
    """The helper process (module docstring). :meth:`start` returns None where it would not help."""

    def __init__(self, proc: subprocess.Popen) -> None:
        self._proc: subprocess.Popen | None = proc

    @classmethod
    def start(cls, mode: str | None = None) -> "RecorderProcess | None":
        """The helper, started; None in ``inline`` mode or when ``auto`` finds no free core
        (``mode``: default :func:`recorder_mode`)."""
        mode = recorder_mode() if mode is None else mode
        if mode == "inline" or (mode == "auto" and not helper_helps()):
            return None
        env = dict(os.environ)
        root = str(Path(__file__).resolve().parent.parent)  # the helper imports this same foam_mj
        env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        env.setdefault("MUJOCO_GL", "disable")  # it never renders: MuJoCo then loads without GLFW
        try:
            proc = subprocess.Popen([sys.executable, "-m", "foam_mj.recorder"], stdin=subprocess.PIPE,
                                    stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
        except OSError:  # pragma: no cover - no process could be started
            return None
        return cls(proc)

    def write(self, job: RecordingJob) -> bool:
        """Have the helper write ``job``; True when it did, False when the caller must write it itself."""
        proc, self._proc = self._proc, None
        if proc is None:
            return False
        try:
            data = pickle.dumps(job, protocol=pickle.HIGHEST_PROTOCOL)
            _, err = proc.communicate(data, timeout=TIMEOUT)
        except (OSError, pickle.PicklingError, TypeError, subprocess.TimeoutExpired):
            _stop(proc)
            return False
        except BaseException:  # e.g. Ctrl-C while waiting: the helper gets it too; do not leave it behind
            _stop(proc)
            raise
        if proc.returncode != 0:
            return False
        if err:  # Rerun's own warnings, as they would appear without the helper
            sys.stderr.write(err.decode(errors="replace"))
        return True

    def close(self) -> None:
        """Stop the helper if no job was sent (it writes nothing before it has a whole job); idempotent."""
        proc, self._proc = self._proc, None
        if proc is not None:
            _stop(proc)

    def __enter__(self) -> "RecorderProcess":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.kill()
    proc.wait()


def main() -> int:
    """The helper: import the recording module, then write the job read from standard input (if any)."""
    try:
        import foam_mj.dynamics  # noqa: F401  # (JointLoads in the job)
        import foam_mj.recording  # noqa: F401  # the slow import (Rerun), while the command plans

        data = sys.stdin.buffer.read()
        if data:  # else the command ended without a recording
            pickle.loads(data).write()
    except KeyboardInterrupt:
        return 130
    except BaseException as exc:  # the command writes the job itself and reports the error
        print(f"foam-mj recorder: {type(exc).__name__}: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    # Done: the file is complete and in place (Recording.close renames it only once fsync'ed). Exit at once:
    # the interpreter's shutdown with Rerun, numpy and MuJoCo loaded takes about half a second, which the
    # command would spend waiting for this process to end.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main())
