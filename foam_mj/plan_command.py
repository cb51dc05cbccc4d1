"""``foam-mj plan``: its flags made into a scenario (--scene or --mjcf with --start/--goal, and the overrides), every
input and output checked before any work, the run, what it prints and writes (:func:`cmd_plan`). Imported only when
a command runs (foam_mj.cli keeps start-up to the standard library); ``bubble`` and ``replay`` share its helpers."""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

from foam_mj.arguments import non_ascii_text
from foam_mj.cli import DEFAULT_SCENE, EXIT_OK, EXIT_PLANNING_FAILED, EXIT_UNSAFE
from foam_mj.progress import Progress
from foam_mj.errors import FoamError, PlanningFailed, file_problem
from foam_mj.summary import fmt_mm, print_certificates, print_fronts, print_replay_notes, summary_table


def record(path: Path, outcome=None, *, scenario=None, foam=None, recorder=None) -> None:
    """Write the recording of ``outcome`` (or of the foam grown so far) to ``path``: by ``recorder``
    (a foam_mj.recorder.RecorderProcess, which has Rerun loaded already) when given and it succeeds,
    else here."""
    from foam_mj.recorder import outcome_job

    job = outcome_job(path, outcome, scenario=scenario, foam=foam)
    if recorder is None or not recorder.write(job):
        job.write()


#: A keyframe's name given for an end point (``--start home``): not a number. A letter or underscore, then anything
#: but spaces and commas: MJCF's <attach prefix="left/"> names an attached model's keyframes "left/home".
_KEYFRAME_NAME = re.compile(r"[A-Za-z_][^\s,]*")


def parse_q(text: str, flag: str, *, keyframe: bool = False) -> list[float] | str:
    """``--start "0.1 0.2 0.3"`` (spaces or commas) as a list of numbers; with ``keyframe``, a name such as ``home``
    is returned as it is (the scene's keyframe of that name, resolved with the scene: foam_mj.scenarios)."""
    if keyframe and _KEYFRAME_NAME.fullmatch(text.strip()) and text.strip().lower() not in ("nan", "inf", "infinity"):
        return text.strip()
    parts = text.replace(",", " ").split()
    if why := non_ascii_text(text):  # float("٠.٢") is 0.2: a number is written in ASCII (foam_mj.arguments)
        raise FoamError(f"{flag} must be numbers separated by spaces or commas, got {text!r}{why}")
    try:
        if any("_" in v for v in parts):  # float() reads "0_08" as 8: a typo must not become another number
            raise ValueError
        fields = text.strip().strip(",").split(",")
        if len(fields) > 1 and any(not f.strip() for f in fields):  # "0.2,,0.3": a number left out, not skipped
            raise ValueError
        values = [float(v) for v in parts]
    except ValueError:
        raise FoamError(f"{flag} must be numbers separated by spaces or commas, got {text!r}") from None
    if not values:
        raise FoamError(f"{flag} is empty; give one number per configuration joint")
    return values


def mjcf_file(text: str) -> Path:
    """``--mjcf`` (plan, bubble): an existing file (an empty name and a folder are said to be what they are)."""
    if not text:
        raise FoamError("--mjcf: empty file name; give an MJCF file")
    mjcf = Path(text)
    problem = file_problem(mjcf)
    if problem == "a folder, not a file":
        raise FoamError(f"--mjcf: {mjcf} is a folder, not an MJCF file")
    if problem == "not found":
        raise FoamError(f"--mjcf: MJCF file not found: {mjcf}")
    if problem:
        raise FoamError(f"--mjcf: {mjcf}: {problem}")
    return mjcf


def check_delta(delta: float | None) -> None:
    """``--delta`` (plan, bubble): a finite margin >= 0 in metres."""
    if delta is not None and not 0 <= delta < float("inf"):
        raise FoamError(f"--delta must be a margin >= 0 in metres, got {delta}")


#: How ``plan --mjcf`` names in its messages the scenario fields its flags fill (the user wrote no scenario).
MJCF_FIELD_FLAGS = (("fields 'q_goal' and 'q_init' are", "--start and --goal are"), ("field 'q_init'", "--start"),
                    ("field 'q_goal'", "--goal"), ("field 'scene'", "--mjcf"))


def robot_overrides(doc: dict, args: argparse.Namespace) -> None:
    """--joints, --robot-root and --no-self-collision (plan and bubble) into a scenario document."""
    if args.joints is not None:
        joints = [j.strip() for j in args.joints.split(",")]
        if not any(joints):
            raise FoamError("--joints must name joints separated by commas")
        if not all(joints):  # "j1,,j3": a name left out, which would plan over the other joints only
            at = joints.index("") + 1
            raise FoamError(f"--joints must name joints separated by commas, got an empty name at position {at} in {args.joints!r}")
        doc["joints"] = joints
    if args.robot_root is not None:
        if not args.robot_root.strip():
            raise FoamError("--robot-root must name a body of the model, got an empty name")
        doc["robot_root"] = args.robot_root
    if args.no_self_collision:
        doc["self_collision"] = False


def no_obstacle_note(robot) -> str:
    """A note when the robot is kept clear of no obstacle at all (only of itself), naming the static geoms MuJoCo
    never collides (contype = conaffinity = 0, visual only) that a user may have meant as obstacles: a floor or a box
    added beside an included model inherits its default class, which in MuJoCo Menagerie's Cassie makes every geom
    visual, and the plan went through them without a word. "" otherwise."""
    import mujoco
    import numpy as np

    from foam_mj.geom_pairs import body_is_moving

    if not np.all(np.asarray(robot.self_pair, dtype=bool)) or robot.fixed_obstacle_distances:
        return ""
    m = robot.model
    visual = [g for g in range(m.ngeom) if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0
              and not body_is_moving(m, int(m.geom_bodyid[g]))]
    if not visual:
        return ""
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}" for g in visual]
    return (f"note: no obstacle was checked, only the robot against itself: the scene's static geoms ({', '.join(names[:5])}"
            f"{', ...' if len(names) > 5 else ''}) have contype = conaffinity = 0, visual only (MuJoCo never collides them; "
            "an included model's default class may set that): give an obstacle contype=\"1\" conaffinity=\"1\"")


def held_by_equality_note(robot) -> str:
    """A note naming the joints left out of the default configuration (every limited hinge and slide) because an
    equality constraint ties them to other motion (MuJoCo Menagerie's Panda: its two fingers, coupled to each other):
    they are held at their pose, as a joint left out is. One line per group of constraints that share a joint (the
    Stretch's telescope, four slides chained by three <joint> couplings, was three lines naming two joints twice).
    "" when there is none."""
    from foam_mj.constraints import describe_equality

    groups: list[tuple[list[str], list[str]]] = []  # (equalities, the joints they tie)
    for eq, names in robot.held_by_equality.items():
        eqs, joints = [eq], list(names)
        for group in [g for g in groups if set(g[1]) & set(names)]:
            groups.remove(group)
            eqs = group[0] + eqs
            joints = group[1] + [n for n in joints if n not in group[1]]
        groups.append((eqs, joints))
    import mujoco

    lines = []
    for eqs, names in groups:
        names = sorted(names, key=lambda n: mujoco.mj_name2id(robot.model, mujoco.mjtObj.mjOBJ_JOINT, n))  # model order
        one, many = len(names) == 1, len(eqs) > 1
        lines.append(
            f"note: {', '.join(names)} held at {('their', 'its')[one]} pose, not planned: equality constraint{'s' * many} "
            f"{', '.join(describe_equality(robot.model, eq) for eq in eqs)} tie{'s' * (not many)} {('them', 'it')[one]} to other "
            f"motion (the planner moves each joint on its own and would not follow {('them', 'it')[not many]})")
    return "\n".join(lines)


def held_pose_note(robot, delta: float) -> str:
    """A note naming the held bodies (on joints outside the configuration and outside the robot: a floating base, a
    stance foot, a joint left out) that lie within ``delta`` of a fixed geom where they are held. Neither moves along
    the path, so the planner does not check them, but a MuJoCo-only checker that counts every jointed body as moving
    (MuJoCo Menagerie's H1 standing at its home keyframe: the stance foot 1 mm into the floor) reads that clearance at
    every sample. "" when there is none."""
    import mujoco

    from foam_mj.geom_pairs import attached, body_is_moving

    m = robot.model
    robot_geoms = {int(g) for g in robot.robot_geoms}
    live = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
    moving = {g: body_is_moving(m, int(m.geom_bodyid[g])) for g in live}
    held = [g for g in live if moving[g] and g not in robot_geoms]
    fixed = [g for g in live if not moving[g]]
    if not held or not fixed:
        return ""
    d = mujoco.MjData(m)
    d.qpos[:] = robot.config.qpos0
    mujoco.mj_kinematics(m, d)
    close = sorted((mujoco.mj_geomDistance(m, d, a, b, delta, None), a, b) for a in held for b in fixed if not attached(m, a, b))
    close = [c for c in close if c[0] < delta]
    if not close:
        return ""
    return (f"note: {len(close)} pair(s) of a held body (moved by a joint outside the configuration) and a fixed geom are within "
            f"the margin where they are held ({_pairs_text(robot, close)}): neither moves along the path, so the "
            "planner leaves them out, but a MuJoCo-only checker that counts every jointed body as moving reads that clearance at "
            "every sample (lift the held body clear, or plan over its joints)")


def held_self_pair_note(robot, delta: float) -> str:
    """A note naming the pairs of robot geoms that MuJoCo collides, that no configuration joint moves against each other
    (joints held outside the configuration between them) and that lie within ``delta`` of each other where they are
    held: no path can change their distance, so the planner leaves them out of its pairs (as it does such a
    robot/obstacle pair, which it refuses instead: an obstacle can be moved, a robot's own held pose is the user's
    choice) and ``foam-mj verify`` does too; without this note, a hand held 10 mm into its own forearm planned "clean".
    "" when there is none."""
    robot_geoms = {int(g) for g in robot.robot_geoms}
    close = sorted((dist, a, b) for a, b, dist in robot.fixed_distances if b in robot_geoms and dist < delta)
    if not close:
        return ""
    return (f"note: {len(close)} pair(s) of robot geoms are within the margin of each other where joints outside the "
            f"configuration hold them ({_pairs_text(robot, close)}): no configuration joint moves one against the other, so "
            "no path changes that distance and the planner (and foam-mj verify) leave them out: the margin holds between "
            "every other pair (plan over a joint between them, move one clear, or <exclude> the pair if it never should collide)")


def held_out_of_range_note(robot) -> str:
    """A note naming the limited hinges and slides outside the configuration held beyond their range (a keyframe or
    qpos0 that sets a wrist to 1.2 rad in a range of +-3 degrees: a degree/radian mix-up). The planner holds them
    there and plans around that pose; a replay leaves them there too, but MuJoCo's own simulation of the model would
    push them back by its joint limit. "" when there is none."""
    from foam_mj.configuration import HINGE, SLIDE, _joint_name

    m = robot.model
    planned = {int(a) for a in robot.config.qpos_index}
    slack = 1e-9
    off = []
    for j in range(m.njnt):
        adr = int(m.jnt_qposadr[j])
        if int(m.jnt_type[j]) not in (HINGE, SLIDE) or not m.jnt_limited[j] or adr in planned:
            continue
        v, (lo, hi) = float(robot.config.qpos0[adr]), m.jnt_range[j]
        if not lo - slack <= v <= hi + slack:
            off.append(f"{_joint_name(m, j)} at {v:.4g} outside [{lo:.4g}, {hi:.4g}]")
    if not off:
        return ""
    return (f"note: held joint{'s' * (len(off) > 1)} beyond {('its', 'their')[len(off) > 1]} range ({', '.join(off[:3])}"
            f"{', ...' if len(off) > 3 else ''}; qpos units: radians or metres): the plan holds {('it', 'them')[len(off) > 1]} "
            "there as given, but MuJoCo's own simulation of this model pushes such a joint back to its range (a degree/radian "
            "mix-up in a keyframe?)")


def _pairs_text(robot, close: list[tuple[float, int, int]]) -> str:
    """The first three (distance, geom, geom) of ``close`` as 'a / b 1.23 mm', then ', ...' when there are more."""
    named = ", ".join(f"{robot.geom_label(a)} / {robot.geom_label(b)} {dist * 1000:.2f} mm" for dist, a, b in close[:3])
    return named + (", ..." if len(close) > 3 else "")


def _within(robot, pairs: list[tuple[int, int]], ends, delta: float) -> list[tuple[float, int, int]]:
    """(distance, a, b) of the geom pairs closer than ``delta`` at some configuration of ``ends``, nearest first."""
    import mujoco

    m = robot.model
    least: dict[tuple[int, int], float] = {}
    for q in ends if pairs else ():
        d = robot.set_configuration(q)
        for a, b in pairs:
            least[a, b] = min(least.get((a, b), delta), mujoco.mj_geomDistance(m, d, a, b, delta, None))
    return sorted((dist, a, b) for (a, b), dist in least.items() if dist < delta)


def static_robot_note(robot, ends, delta: float) -> str:
    """A note naming the pairs of a robot geom on a body no joint moves (the robot's root fixed to the world: MuJoCo
    Menagerie's LEAP hand planned with --robot-root palm) and a moving robot geom that lie within ``delta`` at an end
    point of ``ends`` (q) and that MuJoCo's filters leave out (``<exclude>``, contype/conaffinity): the planner checks
    the robot against itself as MuJoCo does, but a MuJoCo-only checker that counts every geom on a static body as an
    obstacle reads that pair (the palm rests on its finger bases at -0.00 mm). "" when there is none."""
    from foam_mj.geom_pairs import attached, body_is_moving

    m = robot.model
    moving = {int(g): body_is_moving(m, int(m.geom_bodyid[g])) for g in robot.robot_geoms}
    pairs = [(a, b) for a in moving if moving[a] for b in moving if not moving[b]
             if not robot.pair_table[a, b] and not attached(m, a, b)]
    close = _within(robot, pairs, ends, delta)
    if not close:
        return ""
    return (f"note: {len(close)} pair(s) of a moving robot geom and a robot geom on a body no joint moves are within the margin "
            f"at an end point ({_pairs_text(robot, close)}), left out as MuJoCo leaves them out (<exclude>, "
            "contype/conaffinity), but a MuJoCo-only checker that counts every geom on a static body as an obstacle reads "
            "them (give those static geoms contype=\"0\" conaffinity=\"0\" if they never meet the moving ones)")


def mount_note(robot, ends, delta: float) -> str:
    """A note naming the pairs of a moving robot geom and a geom on the fixed body its link hangs from (an arm on a
    mocap mount: MuJoCo's parent/child filter leaves out a body and its parent unless the parent is welded to the
    world) that lie within ``delta`` at an end point of ``ends`` (q): the planner leaves them out as MuJoCo does, but
    a MuJoCo-only checker that counts every geom on a body no joint moves as an obstacle reads that pair at every
    sample (a first link 10 mm into its mount's plate). The same plate on a static body is checked, so refused.
    "" when there is none."""
    from foam_mj.geom_pairs import attached, body_is_moving

    m = robot.model
    fixed = [g for g in range(m.ngeom) if (m.geom_contype[g] or m.geom_conaffinity[g])
             and not body_is_moving(m, int(m.geom_bodyid[g]))]
    pairs = [(int(a), b) for a in robot.robot_geoms if body_is_moving(m, int(m.geom_bodyid[a]))
             for b in fixed if attached(m, int(a), b)]
    close = _within(robot, pairs, ends, delta)
    if not close:
        return ""
    return (f"note: {len(close)} pair(s) of a moving robot geom and a geom on the fixed body it hangs from are within the margin "
            f"at an end point ({_pairs_text(robot, close)}), left out as MuJoCo leaves a body and its parent out (the parent "
            "is not welded to the world: a mocap mount), but a MuJoCo-only checker that counts every geom on a body no joint "
            "moves as an obstacle reads them (move the fixed geom clear of the joint, or give it contype=\"0\" conaffinity=\"0\")")


def default_recording(name: str, *, mjcf: Path | None = None) -> str:
    """The recording ``plan`` writes without --rrd: ``foam-mj-<scenario>.rrd``, and for --mjcf
    ``foam-mj-mjcf-<file stem>-<8 hex digits>.rrd``, the digits a hash of the file's resolved path: the scenario is
    named after its file, so ``--mjcf models/obstacle.xml`` replaced the built-in obstacle scenario's recording, and two
    files of one name in different folders (a/robot.xml, b/robot.xml) wrote the same recording, the second silently
    replacing the first. The same file always gets the same name."""
    if mjcf is None:
        return f"foam-mj-{name}.rrd"
    import hashlib

    digest = hashlib.blake2b(str(Path(mjcf).resolve()).encode(), digest_size=4).hexdigest()
    return f"foam-mj-mjcf-{name}-{digest}.rrd"


#: :func:`capping_pair_note`: the least rosary it looks at, the share of its bubbles one pair must size, and how much
#: that pair's distance may vary along the rosary (relative to its median) to read as one that never comes or goes.
CAPPING_MIN_ROSARY = 20
CAPPING_SHARE = 0.5
CAPPING_SPREAD = 0.25
#: ... or how close it stays all along, in margins (Shadow hand: forearm and palm 2.6-5.5 mm apart at delta 2 mm).
CAPPING_NEAR = 3.0


def capping_pair_note(robot, rosary, delta: float, dist) -> str:
    """A note naming the pair that sizes most of the rosary's bubbles while its distance hardly changes along it (or stays
    within a few margins): a pair that stays close wherever the joints go (MuJoCo Menagerie's H1 hip-yaw cylinder, 11.7 mm
    from the hip-pitch link's mesh at every hip angle) caps every bubble at about (d - delta) / ||rho||, so the planner
    grows thousands of small bubbles (H1's leg: 2,903 bubbles in 4.1 s; 346 in 0.3 s with that pair excluded). ``dist``
    (k, P): each pair's distance at the rosary's centres (the pipeline's ``Outcome.rosary_distances``, measured with
    the replays' clearance; a new one would compile the sensor model again: 1.7 s on H1). "" when no pair does."""
    import numpy as np

    from foam_mj.bubbles import pair_factor, pair_rho

    centres = np.asarray(rosary.centers, dtype=float)
    if dist is None or len(centres) < CAPPING_MIN_ROSARY:
        return ""
    dist = np.asarray(dist, dtype=float)
    bound = robot.displacement_bound
    factor = pair_factor(bound, pair_rho(robot, bound))  # ||rho_p||, as BubbleOracle's
    terms = (dist - delta) / np.maximum(factor, 1e-12)
    limiting = np.argmin(terms, axis=1)
    to_bounds = np.minimum(centres - robot.lower, robot.upper - centres).min(axis=1)
    sized = terms[np.arange(len(centres)), limiting] <= to_bounds  # a pair, not a joint bound, sets the radius
    if not sized.any():
        return ""
    p = int(np.bincount(limiting[sized]).argmax())
    count = int(np.count_nonzero(sized & (limiting == p)))
    d = dist[:, p]
    steady = np.ptp(d) <= CAPPING_SPREAD * abs(float(np.median(d))) or d.max() <= CAPPING_NEAR * delta
    if count < CAPPING_SHARE * len(centres) or not steady:
        return ""
    a, b = (int(g) for g in robot.pairs[p])
    m = robot.model
    bodies = [m.body(int(m.geom_bodyid[g])).name or f"body {int(m.geom_bodyid[g])}" for g in (a, b)]
    way = (f"if those links cannot meet on the robot, <contact><exclude body1=\"{bodies[0]}\" body2=\"{bodies[1]}\"/> "
           "leaves the pair out" if bool(robot.self_pair[p]) else "leave them a few centimetres more room")
    return (f"note: {count} of the rosary's {len(centres)} bubbles are sized by {robot.geom_label(a)} / {robot.geom_label(b)}, "
            f"{d.min() * 1000:.1f}-{d.max() * 1000:.1f} mm apart all along the path: a pair that stays so close caps every "
            f"bubble (radius about {float(np.median(terms[:, p])):.3g}), so the planner needs many small ones; {way}")


def mjcf_name(mjcf: Path) -> str:
    """The scenario name of an --mjcf run: the file's stem, every character outside letters, digits, '_', '-' and '.'
    made '_' (it names output files and recording entities; "ärm ü.xml" is "_rm__")."""
    return re.sub(r"[^A-Za-z0-9_.\-]", "_", mjcf.stem)


def plan_scenario(args: argparse.Namespace):
    """The scenario of ``plan``: --scene, or --mjcf with --start/--goal; --joints, --delta, --time-limit,
    --subject-height/--subject-mass, --robot-root and --no-self-collision override the scenario's fields."""
    from foam_mj.errors import ScenarioError
    from foam_mj.scenarios import SUBJECT_HEIGHT_RANGE, SUBJECT_MASS_RANGE, read_scenario_doc, scenario_from_dict

    check_delta(args.delta)
    for flag, value, (lo, hi), unit in (("--subject-height", args.subject_height, SUBJECT_HEIGHT_RANGE, "m"),
                                        ("--subject-mass", args.subject_mass, SUBJECT_MASS_RANGE, "kg")):
        if value is not None and not lo <= value <= hi:
            raise FoamError(f"{flag} must be in [{lo:g}, {hi:g}] {unit}, got {value}")
    if args.mjcf is not None:
        if args.scene is not None:
            raise FoamError("give either --scene or --mjcf, not both")
        if args.start is None or args.goal is None:
            raise FoamError("--mjcf needs --start and --goal (one number per configuration joint each)")
        mjcf = mjcf_file(args.mjcf)
        doc: dict = {"name": mjcf_name(mjcf), "scene": str(mjcf.resolve()), "q_init": parse_q(args.start, "--start", keyframe=True),
                     "q_goal": parse_q(args.goal, "--goal", keyframe=True)}
        base, source = Path.cwd(), None
    else:
        if args.start is not None or args.goal is not None:
            raise FoamError("--start and --goal go with --mjcf (a scenario has its own q_init and q_goal)")
        doc, source = read_scenario_doc(DEFAULT_SCENE if args.scene is None else args.scene)
        base = source.parent
    robot_overrides(doc, args)
    if args.delta is not None:
        doc["planner"] = {**doc.get("planner", {}), "delta": args.delta}
    if args.time_limit is not None:
        if not 0 < args.time_limit < float("inf"):
            raise FoamError(f"--time-limit must be a number of seconds > 0, got {args.time_limit}")
        doc["planner"] = {**doc.get("planner", {}), "time_limit": args.time_limit}
    for flag, key in (("subject_height", "height"), ("subject_mass", "mass")):
        if getattr(args, flag) is not None:
            doc["subject"] = {**doc.get("subject", {}), key: getattr(args, flag)}
    try:
        return scenario_from_dict(doc, base, source=source)
    except ScenarioError as exc:
        if source is not None:
            raise
        # named after the flags, not a scenario file's fields (nor "scenario", the name of a TOML-less one's fields)
        message = str(exc).removeprefix(f"{doc['name']}: ").removeprefix("scenario: ")
        for field_text, flag_text in MJCF_FIELD_FLAGS:
            message = message.replace(field_text, flag_text)
        raise ScenarioError(message) from None


def check_figures_dir(path: str | None) -> Path | None:
    if path is None:
        return None
    from foam_mj.atomic import check_output_dir
    from foam_mj.figures import _matplotlib

    _matplotlib()  # fails now, with the install hint, when matplotlib is missing
    return check_output_dir(path, "--figures")


def cmd_plan(args: argparse.Namespace) -> int:
    recorder = None
    if not args.no_rrd:  # loads Rerun in a second process while this one plans (foam_mj.recorder)
        from foam_mj.recorder import RecorderProcess

        recorder = RecorderProcess.start()
    try:
        return _plan(args, recorder)
    finally:
        if recorder is not None:
            recorder.close()  # no recording sent (an error, Ctrl-C): the helper is stopped, nothing written


def _plan(args: argparse.Namespace, recorder) -> int:
    from foam_mj.atomic import check_output
    from foam_mj.smoother_names import parse_smoothers

    # Every input and output is checked before any planning, and before the pipeline (the smoothers, scipy, Clarabel,
    # toppra) is imported: a mistyped name is answered at once.
    json_out = check_output(args.json, "--json", suffix=".json")
    rrd = check_output(args.rrd, "--rrd", suffix=".rrd")
    figures_dir = check_figures_dir(args.figures)
    if args.figure_format is not None and figures_dir is None:  # it was taken and no figure drawn, without a word
        raise FoamError("--figure-format goes with --figures DIR (the folder to draw the figures in)")
    names = parse_smoothers(args.smoother)
    if args.planner is not None:
        from foam_mj.planners import planner_class

        planner_class(args.planner)  # an unknown name fails here, listing the known ones
    scenario = plan_scenario(args)
    if args.planner is not None:
        import dataclasses

        scenario = dataclasses.replace(scenario, params=scenario.params.with_algorithm(args.planner))
    if rrd is None and not args.no_rrd:
        rrd = check_output(default_recording(scenario.name, mjcf=None if args.mjcf is None else Path(args.mjcf)), "--rrd (default)", suffix=".rrd")
    from foam_mj.atomic import check_distinct

    check_distinct({"--json": json_out, "--rrd": rrd,
                    "--json's scene file": json_out.with_name(json_out.stem + ".scene.xml") if json_out is not None and scenario.edits.changes_scene else None},
                   {"the scenario file": scenario.source, "the scene (MJCF)": scenario.scene})
    if not args.no_replay:  # limits too low for any timing: refused before planning (untimed plans need none)
        from foam_mj.limits import endless_motion

        endless = endless_motion(scenario.limits, scenario.robot, scenario.q_init, scenario.q_goal)
        if endless:
            raise FoamError(f"{scenario.source or '--mjcf'}: {endless}: raise the limits, or plan untimed with --no-replay")
    seed = scenario.seed if args.seed is None else args.seed
    from foam_mj.pipeline import run
    from foam_mj.results import write_failure, write_outcome

    progress = Progress(False) if args.quiet else Progress(lines=True)  # off a terminal: a line per stage (planning, each smoother, each replay)
    t0 = time.perf_counter()
    try:
        outcome = run(scenario, seed, names, replay=not args.no_replay, dynamic=not args.no_replay, time_law=args.time_law, report=progress)
    except PlanningFailed as exc:
        progress.done()
        from foam_mj.timing import TimingInfeasible

        hint = ("; the paths themselves are certified: --no-replay plans and writes them without timing, or raise the "
                "limits ([limits] in the scenario)") if isinstance(exc, TimingInfeasible) and not args.no_replay else ""
        if not isinstance(exc, TimingInfeasible):
            from foam_mj.configuration import short_slide_hint

            hint = short_slide_hint(scenario.robot.model, scenario.robot.config)
        print(f"foam-mj: planning failed: {' '.join(str(exc).split())}{hint}", file=sys.stderr)
        if exc.foam is not None:
            if rrd is not None:
                record(rrd, scenario=scenario, foam=exc.foam, recorder=recorder)
                print(f"wrote the foam so far to {rrd}", file=sys.stderr)
            if json_out is not None:
                write_failure(json_out, scenario, exc, seed)
                print(f"wrote {json_out}", file=sys.stderr)
        return EXIT_PLANNING_FAILED
    finally:
        progress.done()
    st = outcome.plan.stats
    print(
        f"scenario {scenario.name} (seed {seed}, planner {scenario.params.algorithm}): {st.bubbles:,} bubbles in {st.elapsed:.3f} s "
        f"({st.bubbles_per_second:,.0f} bubbles/s), rosary of {outcome.plan.rosary.k} bubbles, margin {scenario.params.delta * 1000:g} mm"
    )
    print(summary_table(outcome))
    if st.clock_cut:
        print(f"note: {st.clock_cut}: this path depends on the machine's speed and load, and the same seed can give another; "
              f"a larger time limit (--time-limit, the [planner] time_limit{', refine_time' if 'refine_time' in st.clock_cut else ''}) makes it repeat")
    skipped = [n for n in names if n in ("adjusted", "adjusted_gradient") and n not in outcome.paths]
    if skipped:
        print(
            f"note: {', '.join(skipped)} left out: the rosary adjustment (T_RA) moves the centres of a foam's rosary "
            f"(each bubble on its parent's surface); planner {scenario.params.algorithm}'s chain is not one (use --planner pfm)"
        )
    from foam_mj.configuration import small_hinge_ranges_note

    for note in (small_hinge_ranges_note(scenario.robot.model, scenario.robot.config),
                 held_by_equality_note(scenario.robot), no_obstacle_note(scenario.robot),
                 held_pose_note(scenario.robot, scenario.params.delta), held_self_pair_note(scenario.robot, scenario.params.delta),
                 held_out_of_range_note(scenario.robot),
                 static_robot_note(scenario.robot, (scenario.q_init, scenario.q_goal), scenario.params.delta),
                 mount_note(scenario.robot, (scenario.q_init, scenario.q_goal), scenario.params.delta),
                 capping_pair_note(scenario.robot, outcome.plan.rosary, scenario.params.delta, outcome.rosary_distances)):
        if note:
            print(note)
    print_replay_notes(outcome)
    print_fronts(outcome)
    print_certificates(outcome)
    if rrd is not None:
        progress("recording")
        record(rrd, outcome, recorder=recorder)
        progress.done()
        from foam_mj.viewer import console_command

        print(f"wrote {rrd} (view it with: {console_command('foam-mj')} view {rrd})")
    if json_out is not None:
        write_outcome(json_out, outcome)
        print(f"wrote {json_out}")
    if figures_dir is not None:
        from foam_mj.figure_data import stale_figures_note
        from foam_mj.figures import write_figures
        from foam_mj.results import outcome_dict

        progress("drawing figures")
        written = write_figures(outcome_dict(outcome), figures_dir, formats=tuple(args.figure_format or ["png"]))
        progress.done()
        print(f"wrote {len(written)} figures to {figures_dir}")
        stale = stale_figures_note(figures_dir, written)
        if stale:
            print(stale)
    print(f"total {time.perf_counter() - t0:.2f} s")
    below = below_margin(outcome, scenario.params.delta)
    if below:  # every returned path is certified: this is a fault of ours, and it must not pass as a success
        print(f"foam-mj: a planned trajectory comes closer than the margin {scenario.params.delta * 1000:g} mm: {'; '.join(below)} "
              "(a certification fault: please report it with the files written above)", file=sys.stderr)
        return EXIT_UNSAFE
    return untimed_exit(outcome)


def untimed_exit(outcome) -> int:
    """EXIT_PLANNING_FAILED, with one line naming each path that no timing fits, when some path has none (the others
    are timed, replayed and written: a failure of one smoother's path loses nothing else); else EXIT_OK."""
    from foam_mj.pipeline import untimed_paths

    untimed = untimed_paths(outcome)
    if not untimed:
        return EXIT_OK
    print(f"foam-mj: planning failed: no timing fits {len(untimed)} of {len(outcome.paths)} paths: {'; '.join(untimed)} (the other "
          "paths are timed, replayed and written; these are written untimed, as their certified waypoints: raise the limits "
          "([limits] in the scenario) to time them)", file=sys.stderr)
    return EXIT_PLANNING_FAILED


def below_margin(outcome, margin: float) -> list[str]:
    """Paths whose timed trajectory (the kinematic replay: MuJoCo's clearance at every sample) comes closer than
    ``margin``. The dynamic replay's contacts are left out: they measure the servos' tracking, not the plan."""
    return [f"{name} (min clearance {po.kinematic.min_clearance * 1000:.3f} mm)" for name, po in outcome.paths.items()
            if po.kinematic is not None and po.kinematic.min_clearance < margin]


def unsafe_paths(outcome, margin: float) -> list[str]:
    """Paths whose replay has contacts or a clearance below ``margin``."""
    bad = []
    for name, po in outcome.paths.items():
        contacts = len(po.dynamic.contacts) if po.dynamic is not None else 0
        clear = po.kinematic.min_clearance if po.kinematic is not None else float("inf")
        if contacts or clear < margin:
            bad.append(f"{name} ({contacts} contacts, min clearance {fmt_mm(clear)})")
    return bad
