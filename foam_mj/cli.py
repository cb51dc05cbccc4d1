"""The ``foam-mj`` command line: one ``cmd_<name>`` function per command, registered in :func:`build_parser`.

Exit codes (:data:`EXIT_CODES`; the README lists them too):

===  =====================================================================================================
0    success
1    internal error (a bug: the one-line message says so; ``FOAM_MJ_DEBUG=1`` shows the traceback)
2    bad input: a bad argument, scenario, model, result file, output location or sweep key/value, checked before any work
     where it can be; also an output that could not be written (nothing is left half-written)
3    planning failed (the foam did not reach the goal; what was computed is still written), or no timing of a path fits
     the joint limits (``plan``, ``replay``, ``export``)
4    a check found contacts or clearance below the margin (``verify``, ``replay``; ``verify``: or a joint beyond its
     range), or ``plan``'s own replay found a
     planned trajectory below its margin (a certification fault: everything is still written, for a report)
130  interrupted (Ctrl-C or SIGTERM); no output is left half-written
===  =====================================================================================================

Errors are one line on stderr, never a traceback. To add a command: write ``cmd_<name>(args) -> int``
that raises :class:`~foam_mj.errors.FoamError` for bad input (or returns an exit code), and register it
in :func:`build_parser` with ``p.set_defaults(func=cmd_<name>)``. Check outputs with
:func:`foam_mj.atomic.check_output` before any work and write them with :func:`foam_mj.atomic.atomic_path`.

Start-up is kept short: this module imports only the standard library at load time; numpy, MuJoCo, the
pipeline, Rerun and matplotlib are imported inside the command that uses them, so ``foam-mj --help``
and argument errors answer at once (benchmarks/speed.py measures it).
``plan`` loads Rerun in a helper process beside the planning (:mod:`foam_mj.recorder`). The larger commands live in
their own modules, imported when they run: ``plan`` in :mod:`foam_mj.plan_command` (with what it prints,
:mod:`foam_mj.summary`), ``view`` in :mod:`foam_mj.viewer`, ``figures`` in :mod:`foam_mj.figures`.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path

from foam_mj import __version__
from foam_mj.arguments import CONFIGURATION_METAVAR, Parser, UsageError, port_number, real_number, seed_number, whole_number
from foam_mj.errors import FoamError, PlanningFailed
from foam_mj.interrupts import EXIT_INTERRUPTED, RETURNED, SIGNALLED, caused_by_interrupt, exit_now, forget_handled_interrupt, install, interrupt
from foam_mj.streams import OutputWithoutReader, reopen_closed_streams

#: ``foam-mj plan``'s smoother when none is named; equal to foam_mj.pipeline.DEFAULT_SMOOTHER (a test checks),
#: repeated here because the command line imports the pipeline (and MuJoCo) only when it runs.
DEFAULT_SMOOTHER = "optimal"
#: ``foam-mj plan``'s scenario when neither --scene nor --mjcf is given.
DEFAULT_SCENE = "obstacle"

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_PLANNING_FAILED, EXIT_UNSAFE = 0, 1, 2, 3, 4
EXIT_CODES = {
    EXIT_OK: "success",
    EXIT_INTERNAL: "internal error (a bug; FOAM_MJ_DEBUG=1 shows the traceback)",
    EXIT_BAD_INPUT: "bad input (argument, scenario, model, result file or output location), or an output that could not be written",
    EXIT_PLANNING_FAILED: "planning failed (the foam so far is still written), or no timing of a path fits the joint limits",
    EXIT_UNSAFE: "verify/replay found contacts or clearance below the margin (verify: or a joint beyond its range), or plan a planned trajectory below its margin",
    EXIT_INTERRUPTED: "interrupted",
}
EXIT_EPILOG = "exit codes: " + "; ".join(f"{k} {v}" for k, v in EXIT_CODES.items())
#: The end of every command's exit codes: any command can meet a bug or an interrupt.
EXIT_ANY = f"{EXIT_INTERNAL} internal error (a bug); {EXIT_INTERRUPTED} interrupted (no output half-written)"

#: Figure file formats and PNG resolution of ``foam-mj figures`` (foam_mj.figures uses these too).
FIGURE_FORMATS = ("png", "svg", "pdf")
FIGURE_DPI = 150
#: The largest --dpi: a 10 x 8 inch figure at 600 dpi is 29 million pixels (about 115 MB to draw); 100,000 dpi ended in
#: a MemoryError.
FIGURE_MAX_DPI = 600
#: The smallest --dpi: below it the figures' 8 pt legend text is under a pixel high, and FreeType refused to size it
#: ('invalid ppem value', an internal error at 6 dpi and below).
FIGURE_MIN_DPI = 10


def cmd_scenes(args: argparse.Namespace) -> int:
    from foam_mj.scenarios import available_scenarios, load_scenario
    from foam_mj.summary import fmt_q as _fmt_q

    rows = []
    for name in available_scenarios():
        s = load_scenario(name, check=False)
        rows.append((s.name, s.description, _fmt_q(s.q_init), _fmt_q(s.q_goal), s.scene.name))
    widths = [max(len(r[i]) for r in rows + [("name", "what it is", "start", "goal", "scene file")]) for i in range(5)]
    header = ("name", "what it is", "start", "goal", "scene file")
    for r in [header, *rows]:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
    return EXIT_OK


def cmd_plan(args: argparse.Namespace) -> int:
    from foam_mj.plan_command import cmd_plan as plan

    return plan(args)


def cmd_bubble(args: argparse.Namespace) -> int:
    """The certified bubble at one configuration: clearance, closest pair, rho per joint, radius."""
    import json

    from foam_mj.atomic import check_output
    from foam_mj.bubble_report import bubble_report, format_report
    from foam_mj.plan_command import check_delta as _check_delta, mjcf_file as _mjcf_file, mjcf_name, parse_q as _parse_q
    from foam_mj.plan_command import robot_overrides as _robot_overrides
    from foam_mj.scenarios import read_scenario_doc, scenario_from_dict

    json_out = check_output(args.json, "--json", suffix=".json")
    if (args.scene is None) == (args.mjcf is None):
        raise FoamError("give one of --scene SCENE or --mjcf ROBOT.xml")
    q = _parse_q(args.q, "--q", keyframe=True)  # a keyframe's name: its configuration, the other joints held there
    _check_delta(args.delta)
    if args.mjcf is not None:
        mjcf = _mjcf_file(args.mjcf)
        doc: dict = {"name": mjcf_name(mjcf), "scene": str(mjcf.resolve())}  # the stem as such: 'ärm ü' was refused
        base, source = Path.cwd(), None
    else:
        doc, source = read_scenario_doc(args.scene)
        base = source.parent
    doc = {**doc, "q_init": q, "q_goal": q}  # the scenario's own start and goal are not looked at
    if args.keyframe is not None:  # the other joints and the mocap bodies where plan --start NAME holds them
        doc["keyframe"] = args.keyframe
    _robot_overrides(doc, args)
    scenario = scenario_from_dict(doc, base, source=source, check=False)
    delta = scenario.params.delta if args.delta is None else args.delta
    report = bubble_report(scenario.robot, scenario.q_init, delta, name="--q")
    print("\n".join(format_report(report)))
    if json_out is not None:
        from foam_mj.atomic import atomic_write_text

        atomic_write_text(json_out, json.dumps(report, indent=1) + "\n")
        print(f"wrote {json_out}")
    return EXIT_OK


def cmd_replay(args: argparse.Namespace) -> int:
    from foam_mj.atomic import check_output
    from foam_mj.plan_command import record as _record, unsafe_paths as _unsafe_paths, untimed_exit as _untimed_exit
    from foam_mj.progress import Progress
    from foam_mj.results import outcome_from_result, read_result
    from foam_mj.summary import print_replay_notes, summary_table

    rrd = check_output(args.rrd, "--rrd", suffix=".rrd")
    from foam_mj.atomic import check_distinct

    check_distinct({"--rrd": rrd}, {"the result": args.result})
    doc = read_result(args.result)
    if not doc["paths"]:
        raise FoamError(f"{args.result}: the result has no paths to replay (outcome: {doc.get('outcome', 'unknown')})")
    if "delta" not in doc["planner"]:  # the replay was judged against a margin of 0 (its clearance used 5 mm)
        raise FoamError(f"{args.result}: missing field 'planner.delta' (the safety margin the replay is checked against)")
    progress = Progress()
    try:
        outcome = outcome_from_result(doc, args.result, dynamic=not args.kinematic_only, report=progress)
    finally:
        progress.done()
    timed = sum(po.trajectory is not None for po in outcome.paths.values())
    count = f"{len(outcome.paths)}" if timed == len(outcome.paths) else f"{timed} of {len(outcome.paths)}"
    print(f"replayed {count} path(s) of {args.result} on {outcome.scenario.scene}")
    print(summary_table(outcome))
    print_replay_notes(outcome)
    if rrd is not None:
        progress("recording")
        try:
            _record(rrd, outcome)
        finally:
            progress.done()
        print(f"wrote {rrd}")
    margin = outcome.scenario.params.delta
    bad = _unsafe_paths(outcome, margin)
    if bad:
        print(f"foam-mj: replay found contacts or clearance below the margin {margin * 1000:g} mm: {'; '.join(bad)}", file=sys.stderr)
        return EXIT_UNSAFE
    return _untimed_exit(outcome)


def cmd_export(args: argparse.Namespace) -> int:
    """foam-mj export RESULT.json [--path NAME] [--format csv|npz|parquet] --out FILE [--hz N]."""
    from foam_mj.atomic import check_distinct, check_output
    from foam_mj.export import check_hz, export_table, pick_path, require_pyarrow, resolve_format, write_table
    from foam_mj.progress import Progress
    from foam_mj.results import read_result

    hz = check_hz(args.hz)
    out = check_output(args.out, "--out")
    fmt = resolve_format(out, args.format)
    check_distinct({"--out": out}, {"the result": args.result})
    if fmt == "parquet":
        require_pyarrow()
    doc = read_result(args.result)
    try:
        name = pick_path(doc, args.path)
    except FoamError as exc:  # which file, as replay and verify name it
        raise FoamError(f"{args.result}: {exc}") from None
    progress = Progress()
    try:
        table = export_table(doc, args.result, name, hz, report=progress)
        progress(f"exporting: writing {table.n_rows:,} rows to {out}")
        write_table(table, out, fmt)
    finally:
        progress.done()
    print(f"wrote {out}: path '{name}', {table.n_rows} rows at {hz:g} Hz ({table.metadata['duration_s']:.3f} s), "
          f"{len(table.columns)} columns ({fmt})")
    return EXIT_OK


def cmd_verify(args: argparse.Namespace) -> int:
    from foam_mj.verify import format_report, verify_result

    report = verify_result(args.result, step=args.step)
    print(format_report(report))
    return EXIT_UNSAFE if report.unsafe else EXIT_OK


def cmd_view(args: argparse.Namespace) -> int:
    from foam_mj.viewer import cmd_view as view

    return view(args)


def cmd_bench(args: argparse.Namespace) -> int:
    from foam_mj.benchmark import main as bench_main

    rest = [a for a in args.bench_args if a != "--"] if args.bench_args[:1] == ["--"] else args.bench_args
    return bench_main(rest)


def _cmd_figures(args: argparse.Namespace) -> int:
    from foam_mj.figures import cmd_figures

    return cmd_figures(args)


def add_figures_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``figures`` command (foam_mj.figures.cmd_figures, imported only when it runs) to ``subparsers``."""
    p = subparsers.add_parser(
        "figures",
        help="draw publication figures from a plan's JSON result",
        description="Draw the foam, rosary, leg-pose strobe, convergence, joint and (walker) map figures "
        "from a result written by `foam-mj plan --json` (needs matplotlib: pip install 'foam-mj[figures]').",
        epilog=f"exit codes: 0 success; 2 bad input (result file, --paths, --dpi, unwritable DIR, matplotlib missing); {EXIT_ANY}.",
    )
    p.add_argument("result", metavar="RESULT.json", help="a result written by `foam-mj plan --json`")
    p.add_argument("out_dir", metavar="DIR", help="folder for the figures (created if missing)")
    p.add_argument("--format", nargs="+", choices=FIGURE_FORMATS, default=["png"], dest="formats",
                   help="figure file formats, one or more of png, svg, pdf (default: png)")
    p.add_argument("--paths", nargs="+", metavar="NAME", default=None, help="only these paths (default: all in the result)")
    p.add_argument("--dpi", type=whole_number, default=FIGURE_DPI, metavar="N", help=f"resolution of PNG files, {FIGURE_MIN_DPI} to {FIGURE_MAX_DPI} (default {FIGURE_DPI})")
    p.set_defaults(func=_cmd_figures)
    return p


def cmd_sweep(args: argparse.Namespace) -> int:
    from foam_mj.sweep import WorkersDied
    from foam_mj.sweep_file import load_sweep
    from foam_mj.sweep_run import _pyarrow, check_ray_address, run_sweep

    from foam_mj.atomic import check_output_dir

    _pyarrow()  # the install hint before any work when pyarrow is missing
    check_output_dir(args.out, "--out")
    if args.ray is not None:
        import importlib.util

        if importlib.util.find_spec("ray") is None:
            raise FoamError("--ray needs Ray, which is not installed: pip install 'foam-mj[cluster]'")
        if args.ray:
            check_ray_address(args.ray)
    for flag, value in (("--workers", args.workers), ("--batch", args.batch), ("--limit", args.limit)):
        if value is not None and value < 1:
            raise FoamError(f"{flag} must be an integer >= 1, got {value}")
    for flag, value in (("--flush-seconds", args.flush_seconds), ("--progress-interval", args.progress_interval)):
        if not 0 < value < float("inf"):
            raise FoamError(f"{flag} must be a number of seconds > 0, got {value}")
    if os.path.realpath(args.sweep) == os.path.realpath(os.path.join(args.out, "sweep.json")):  # read as a manifest
        raise FoamError(f"the sweep file {args.sweep} is where --out {args.out} keeps its manifest (sweep.json): save the "
                        "sweep file under another name, e.g. sweep.toml")
    sweep = load_sweep(args.sweep)  # every key and value checked: exit 2 naming it, before any plan
    if sweep.repeated_draws and not args.quiet:
        print(f"sweep: {sweep.repeated_draws} of the {sweep.samples} random samples repeat an earlier draw; "
              f"the {len(sweep.draws)} distinct ones are planned", file=sys.stderr)
    engine = "local" if args.ray is None else "ray"
    signal.signal(signal.SIGTERM, interrupt)  # `kill` stops it like Ctrl-C: completed rows kept
    where = Path(args.out) / "rows"
    try:
        s = run_sweep(
            sweep, args.out, engine=engine, workers=args.workers, ray_address=args.ray or None, batch=args.batch,
            flush_seconds=args.flush_seconds, progress=False if args.quiet else None, interval=args.progress_interval, limit=args.limit,
        )
    except KeyboardInterrupt:
        if any(where.glob("*.parquet")):
            print(f"foam-mj: interrupted; the completed plans are in {where} (run the same command again to continue)", file=sys.stderr)
        else:  # it said the completed plans were in a folder that did not exist
            print(f"foam-mj: interrupted before any plan was written to {where} (run the same command again to start)", file=sys.stderr)
        return 130
    except WorkersDied as exc:
        print(f"foam-mj: {exc}", file=sys.stderr)
        return EXIT_INTERNAL
    if s.run == 0:  # was "0 rows in 0 files under DIR/rows; 0.00 plans/s on Ray (local) (15.4 s)", having started Ray
        print(f"sweep {args.sweep}: {s.tasks} plans in all, {s.skipped} already done, 0 run now: nothing to do, every row is in {where}")
        return EXIT_OK
    on = f"{s.workers} local worker{'s' * (s.workers != 1)}" if engine == "local" else f"Ray ({args.ray or 'local'})"
    print(
        f"sweep {args.sweep}: {s.tasks} plans in all, {s.skipped} already done, {s.run} run now ({s.failed} not reached), "
        f"{s.rows_written} rows in {s.files_written} file{'s' * (s.files_written != 1)} under {where}; {s.rate:.2f} plans/s on {on} ({s.elapsed:.1f} s)"
    )
    return EXIT_OK


def cmd_report(args: argparse.Namespace) -> int:
    from foam_mj.progress import Progress
    from foam_mj.report import write_report

    progress = Progress()
    drew: list[str] = []
    try:
        text, written = write_report(args.dir, args.figures, formats=tuple(args.format), progress=progress, axes=tuple(args.axes or ()), drew=drew)
    finally:
        progress.done()
    print(text)
    figs = [p for p in written if p.suffix != ".txt" and p.suffix != ".json"]
    folder = written[0].parent if written else args.dir
    for line in drew:
        print(line)
    print(f"wrote {len(figs)} figure(s), summary.txt and summary.json to {folder}")
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="foam-mj",
        description="Plan safe, smooth motions for MuJoCo robots (built in: the Ortholeg exoskeleton's swing leg) over bubbles "
        "of free configuration space certified by MuJoCo distance queries (the Probabilistic Foam Method and its kin).",
        epilog=EXIT_EPILOG + ".",
    )
    parser.add_argument("--version", action="version", version=f"foam-mj {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    p = sub.add_parser("scenes", help="list the built-in scenarios", description="List the built-in scenarios: name, what it is, start, goal and scene file.")
    p.set_defaults(func=cmd_scenes)
    p = sub.add_parser(
        "plan",
        help="plan, smooth, replay and record",
        description="Plan a path of certified bubbles (the scenario's planner, or --planner), smooth it, turn every path into a "
        "joint trajectory, replay it on the simulated robot (kinematically and under gravity), print a summary and "
        "write a Rerun recording. Every output is checked before planning and written atomically.",
        epilog="exit codes: 0 success; 2 bad input or an output that could not be written; 3 planning failed "
        "(the foam did not reach the goal: the foam so far is still written; or no timing of a path fits the joint "
        "limits); 4 plan's own replay found a planned trajectory below the margin (a certification fault: everything "
        f"is still written, for a report); {EXIT_ANY}.",
    )
    p.add_argument("--scene", default=None, metavar="SCENE", help=f"a scenario name (see `foam-mj scenes`) or a path to a scenario TOML (default: {DEFAULT_SCENE})")
    p.add_argument("--mjcf", metavar="ROBOT.xml", help="plan on any MJCF scene without a scenario file (needs --start and --goal; default planner parameters)")
    p.add_argument("--start", metavar=CONFIGURATION_METAVAR, help="with --mjcf: the start configuration, one number per configuration joint (radians, metres), or a keyframe's name (home: its configuration joints' values; the other joints are held there)")
    p.add_argument("--goal", metavar=CONFIGURATION_METAVAR, help="with --mjcf: the goal configuration (numbers or a keyframe's name)")
    p.add_argument("--joints", metavar="a,b,c", help="the configuration joints, in order (default: the scenario's or the MJCF's declaration, else every limited hinge/slide joint)")
    p.add_argument("--delta", type=real_number, metavar="M", help="the safety margin in metres (default: the scenario's, else 0.005)")
    p.add_argument("--time-limit", type=real_number, metavar="S", help="the planner's time budget in seconds: a plan that has not "
                   "reached the goal by then fails (exit 3; default: the scenario's [planner] time_limit, else 60)")
    p.add_argument("--subject-height", type=real_number, metavar="M", help="scale the leg to a subject this tall, 1.2-2.2 m (Winter's segment fractions; a model that declares foam_mj:segments)")
    p.add_argument("--subject-mass", type=real_number, metavar="KG", help="scale the leg's segment masses to a subject this heavy, 25-200 kg")
    p.add_argument("--robot-root", metavar="BODY", help="the body whose subtree is the robot (other moving bodies are fixed obstacles at their qpos0 pose)")
    p.add_argument("--no-self-collision", action="store_true", help="do not check robot/robot pairs (the scenario's self_collision = false)")
    p.add_argument(
        "--smoother",
        default=DEFAULT_SMOOTHER,
        metavar="NAME",
        help="optimal, none, hs, ga, gradient, adjust, convex, mgoa, mopso or all, or a comma-separated list "
        "(default: optimal, the certified optimum of f; all: every method of the papers plus convex and optimal, "
        "for comparison). The centre path is always there.",
    )
    p.add_argument("--seed", type=seed_number, default=None, metavar="N", help="random seed of the planner and smoothers, an integer in [0, 2**63-1] (default: the scenario's)")
    p.add_argument(
        "--planner",
        metavar="NAME",
        default=None,
        help="the planner: bubbletree (the default for scenarios that name none), pfm (the papers'), gbpf, rbpf, hpf "
        "(default: the scenario's [planner] algorithm); another planner than the scenario's runs with its default "
        "options and the scenario's margin and budgets; an unknown name is refused with the list",
    )
    rec = p.add_mutually_exclusive_group()
    rec.add_argument("--rrd", metavar="OUT.rrd", help="where to write the Rerun recording (default: foam-mj-<scenario>.rrd; with --mjcf, foam-mj-mjcf-<file name>-<hash of its path>.rrd, never a built-in scenario's nor another folder's file of that name)")
    rec.add_argument("--no-rrd", action="store_true", help="write no recording")
    p.add_argument("--json", metavar="OUT.json", help="write the result as JSON (see the README; `foam-mj verify` checks it)")
    p.add_argument("--no-replay", action="store_true", help="skip trajectories and replays (paths only)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr (off a terminal: no stage lines); errors and notes still print")
    p.add_argument(
        "--time-law",
        choices=["toppra", "own"],
        default=None,
        help="how each path's safe curve is timed under joint velocity, acceleration and torque limits: toppra "
        "(time-optimal) or own (smooth minimum-jerk, stretched to fit); default: the scenario's [limits] time_law, else toppra",
    )
    p.add_argument("--figures", metavar="DIR", help="also draw the paper-style figures into DIR (needs foam-mj[figures])")
    p.add_argument("--figure-format", nargs="+", default=None, choices=FIGURE_FORMATS, help="with --figures: figure file formats, one or more of png, svg, pdf (default: png)")
    p.set_defaults(func=cmd_plan)
    p = sub.add_parser(
        "bubble",
        help="look inside the certified bubble at one configuration",
        description="Print the clearance at q, the closest geom pair, rho per joint (of the pair that sets the radius) "
        "and the certified radius: every configuration within that distance of q keeps at least delta of clearance "
        "on every checked pair.",
        epilog="exit codes: 0 success; 2 bad input (unknown scene, unreadable MJCF, q of the wrong length or outside "
        f"the joint bounds, unwritable --json); {EXIT_ANY}.",
    )
    p.add_argument("--scene", default=None, metavar="SCENE", help="a scenario name or TOML path (its scene, joints, margin and robot options)")
    p.add_argument("--mjcf", metavar="ROBOT.xml", help="any MJCF scene instead of a scenario")
    p.add_argument("--q", required=True, metavar=CONFIGURATION_METAVAR, help="the configuration, one number per configuration joint, separated by spaces or commas, or a keyframe's name (its configuration; the other joints held there)")
    p.add_argument("--keyframe", metavar="NAME", help="hold the joints outside the configuration and the mocap bodies at this keyframe's pose, as plan --start NAME does (default: the scenario's keyframe, else qpos0)")
    p.add_argument("--joints", metavar="a,b,c", help="the configuration joints, in order (default: the scenario's or the MJCF's declaration, else every limited hinge/slide joint)")
    p.add_argument("--delta", type=real_number, metavar="M", help="the safety margin in metres (default: the scenario's, else 0.005)")
    p.add_argument("--robot-root", metavar="BODY", help="the body whose subtree is the robot (other bodies are obstacles)")
    p.add_argument("--no-self-collision", action="store_true", help="do not check robot/robot pairs")
    p.add_argument("--json", metavar="OUT.json", help="also write the report as JSON (clearance, radius, rho, joints, closest_pair, every pair)")
    p.set_defaults(func=cmd_bubble)
    p = sub.add_parser(
        "replay",
        help="replay a saved result",
        description="Rebuild the joint trajectories of a `plan --json` result and replay them on the scene it names. "
        "Refuses (exit 2) a result of an unknown format version, or whose scene file now compiles to a different model.",
        epilog="exit codes: 0 clean; 2 bad input; 3 no timing of a saved path fits the result's joint limits; 4 the "
        f"replay has contacts or clearance below the result's margin; {EXIT_ANY}.",
    )
    p.add_argument("result", metavar="RESULT.json", help="a JSON file written by `foam-mj plan --json`")
    p.add_argument("--rrd", metavar="OUT.rrd", help="write a Rerun recording of the replay (without it, none is written)")
    p.add_argument("--kinematic-only", action="store_true", help="skip the dynamic (servo) replay")
    p.set_defaults(func=cmd_replay)
    p = sub.add_parser(
        "export",
        help="write a result's trajectory as CSV, NPZ or Parquet",
        description="Write the timed trajectory of one path of a `plan --json` result, one row per sample: time_s, then "
        "<joint>.q, .qd, .qdd, .tau (mj_inverse), .power per configuration joint, in qpos units (units in the file).",
        epilog=f"exit codes: 0 success; 2 bad input (unknown path, bad --hz, unwritable --out); 3 no timing fits the limits; {EXIT_ANY}.",
    )
    p.add_argument("result", metavar="RESULT.json", help="a JSON file written by `foam-mj plan --json`")
    p.add_argument("--path", default=None, metavar="NAME", help="which path of the result (default: the last one, plan's smoothed path)")
    p.add_argument("--format", default=None, choices=["csv", "npz", "parquet"],
                   help="file format (parquet needs pyarrow; default: the one --out's suffix names, .csv, .npz, .parquet or .pq)")
    p.add_argument("--out", required=True, metavar="FILE", help="where to write the table")
    p.add_argument("--hz", default=500.0, metavar="N", help="samples per second (default: 500)")
    p.set_defaults(func=cmd_export)
    p = sub.add_parser(
        "verify",
        help="check a saved result independently with MuJoCo",
        description="Independent check of a `plan --json` result, with none of the planner's code (MuJoCo, numpy and "
        "the JSON only): every path's waypoints (piecewise linear) and its timed trajectory (qpos rows), sampled "
        "densely, and mj_geomDistance over every pair of moving and static collision geoms.",
        epilog=f"exit codes: 0 every sample keeps the result's margin and the joint ranges; 4 some sample is closer, or beyond "
        f"a joint's range; 2 bad input; {EXIT_ANY}.",
    )
    p.add_argument("result", metavar="RESULT.json", help="a JSON file written by `foam-mj plan --json`")
    p.add_argument("--step", type=real_number, default=1e-3, metavar="S", help="largest step between samples, in q, in qpos and "
                   "in how far a point of the robot can travel, at most 0.1 (rad or m; default: 1e-3)")
    p.set_defaults(func=cmd_verify)
    p = sub.add_parser(
        "view",
        help="open a recording in the Rerun viewer",
        description="Open a .rrd recording in the Rerun viewer (shipped with rerun-sdk). Without a display, "
        "use --web: it serves Rerun's web viewer on 127.0.0.1 and prints the URL.",
        epilog=f"exit codes: 0 the viewer closed; 2 bad input (missing or damaged recording, no display without --web, a port in use); {EXIT_ANY}.",
    )
    p.add_argument("recording", metavar="OUT.rrd", help="a .rrd recording (`foam-mj plan` writes one)")
    p.add_argument("--web", action="store_true", help="serve Rerun's web viewer over HTTP instead of opening a window")
    p.add_argument("--bind", default="127.0.0.1", metavar="ADDR", help="address the viewer's servers listen on (default: 127.0.0.1, this machine only; 0.0.0.0 exposes them to the network)")
    p.add_argument("--web-port", type=port_number, default=9090, metavar="P", help="HTTP port of the web viewer (default: 9090; 0: a free one)")
    p.add_argument("--grpc-port", type=port_number, default=9876, metavar="P", help="gRPC port of the viewer's data server (default: 9876; 0: a free one)")
    p.set_defaults(func=cmd_view)
    p = sub.add_parser("bench", help="run the smoothing benchmark", description="The smoothing benchmark (HS and GA runs, the thesis's methods, the convex reference); every argument is passed on to it (see `foam-mj bench --help`).", add_help=False)
    p.add_argument("bench_args", nargs=argparse.REMAINDER, help="arguments for the benchmark: --quick, --runs N, --json OUT.json, --no-progress")
    p.set_defaults(func=cmd_bench)
    p = sub.add_parser(
        "sweep",
        help="run a study: many plans over a grid or random samples, rows in Parquet",
        description="Plan every combination of a sweep file's values and seeds (a grid and/or random samples over "
        "any scenario field, as dotted keys) and write one row per plan and smoother to a Parquet dataset under "
        "--out. Re-running the same command skips the rows already there.",
        epilog="exit codes: 0 done; 1 workers kept dying (the rows received are kept), or an internal error; 2 bad input "
        "(sweep file, key or value, an --out folder of another sweep or in use: before any plan), or rows that could not "
        "be written; 130 interrupted (completed rows kept: run the same command again to continue).",
    )
    p.add_argument("sweep", metavar="SWEEP.toml", help="the sweep file (see README, 'Studies')")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder: DIR/rows/*.parquet and DIR/sweep.json")
    p.add_argument("--workers", type=whole_number, default=None, metavar="N", help="worker processes (default and at most: one per core this process may use; a larger number is capped, with a note); with --ray, the local Ray instance's CPUs (capped alike)")
    p.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS", help="run the plans as Ray tasks (needs foam-mj[cluster]): alone, on a local Ray instance; with an address (auto, ray://host:10001), on that cluster")
    p.add_argument("--batch", type=whole_number, default=200, metavar="N", help="rows per Parquet file (default 200)")
    p.add_argument("--flush-seconds", type=real_number, default=10.0, metavar="S", help="write the rows received at least this often (default 10 s)")
    p.add_argument("--limit", type=whole_number, default=None, metavar="N", help="run at most this many plans now (try a sweep; re-run to continue)")
    p.add_argument("--progress-interval", type=real_number, default=5.0, metavar="S", help="seconds between progress lines when stderr is not a terminal (default 5)")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=cmd_sweep)
    p = sub.add_parser(
        "report",
        help="feasibility-envelope figures and a summary of a sweep",
        description="Heatmaps (success rate, min clearance, f, peak knee torque) over the two most varied swept keys, one panel per value of a third, and a summary table per smoother.",
        epilog=f"exit codes: 0 done; 2 bad input (not a sweep folder, a sweep with no rows, unwritable --figures, matplotlib "
        f"missing); {EXIT_ANY}.",
    )
    p.add_argument("dir", metavar="DIR", help="a folder written by foam-mj sweep")
    p.add_argument("--figures", metavar="FIGDIR", default=None, help="where to write the figures (default: DIR/report)")
    p.add_argument("--format", nargs="+", default=["png"], choices=FIGURE_FORMATS, help="figure file formats, one or more of png, svg, pdf (default: png)")
    p.add_argument("--axes", nargs="+", metavar="KEY", default=None,
                   help="the swept keys to draw: x, then y, then the key whose values get one panel each (default: the most varied "
                        "keys); the others are pooled, and each figure's title names them")
    p.set_defaults(func=cmd_report)
    add_figures_parser(sub)  # foam-mj figures RESULT.json DIR [--format png svg pdf] [--paths ...] [--dpi N]
    return parser


def _one_line(exc: BaseException) -> str:
    """An error message on one line: whitespace runs collapsed, and any other character that does not print (a file
    name holding ESC or DEL) written as its escape, ``\\x1b``: `foam-mj verify $'a\\x1b[31mb.json'` turned the
    terminal red instead of naming the file."""
    text = " ".join(str(exc).split())
    return text if text.isprintable() else "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


#: Commands after which the ``foam-mj`` process ends with ``os._exit`` once its output is flushed, skipping
#: the interpreter's teardown (0.1-0.5 s with Rerun, MuJoCo and scipy loaded, a quarter of ``plan``'s
#: wall time): every file they write is complete and closed before they return, and they start nothing
#: that needs an exit handler (no Ray, no temporary folders; the recording helper is ended).
FAST_EXIT_COMMANDS = ("plan",)
#: The variables that set the threads of numpy's BLAS (OpenBLAS; MKL and OpenMP builds), 1 for the command (:func:`main`).
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")


def main(argv: list[str] | None = None) -> int:
    command = argv is None  # the `foam-mj` command itself (not a call from Python)
    if command:
        reopen_closed_streams()  # `foam-mj plan >&-` wrote no result: exit 120, or 1 with a traceback
        if hasattr(sys.stdout, "reconfigure"):  # an ASCII stdout printing `wrote é.csv` was an internal error (exit 1)
            sys.stdout.reconfigure(errors="backslashreplace")
        sys.stdout = OutputWithoutReader(sys.stdout)
        # It never renders with MuJoCo's OpenGL; without this, `import mujoco` also loads GLFW (a tenth
        # of a second of start-up). A user's own MUJOCO_GL wins.
        os.environ.setdefault("MUJOCO_GL", "disable")
        # numpy's BLAS in one thread (set before numpy loads; a user's own setting wins): the planners' products are
        # a few dozen rows by thousands of bubbles, where a second OpenBLAS thread gains little, and with the other core
        # busy (the recording's helper process, a sweep's other workers) it waits on it: a failing bubbletree search of
        # 15 s on 2 cores grew 16,300 bubbles with it and 28,900 without it (half the CPU time per bubble).
        for var in BLAS_THREADS:
            os.environ.setdefault(var, "1")
        install()  # Ctrl-C and `kill` stop a command: exit 130, no output half-written
        import warnings

        from foam_mj.mujoco_warnings import route_to_python, show_once

        warnings.showwarning = show_once
        route_to_python()
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["bench"]:  # everything after `bench` belongs to the benchmark's own parser
        argv = ["bench", "--", *argv[1:]] if len(argv) > 1 else argv
    ran: list[str] = []
    code = _main(argv, ran)
    if command and code == EXIT_INTERRUPTED:
        forget_handled_interrupt()  # else CPython may end the process by SIGINT after its exit handlers
    if command and ran and ran[0] in FAST_EXIT_COMMANDS:
        exit_now(code)
    return code


def _main(argv: list[str], ran: list[str]) -> int:
    """Parse ``argv`` and run its command (its name appended to ``ran``); errors become exit codes."""
    SIGNALLED.clear()  # a signal of an earlier call from Python is not this call's
    RETURNED.clear()
    try:
        try:
            parser = build_parser()
            args = parser.parse_args(argv)
            ran.append(getattr(args, "command", None) or args.func.__name__.removeprefix("cmd_"))
            code = args.func(args)
            if SIGNALLED and code != EXIT_INTERRUPTED:  # a Ctrl-C that a library caught and dropped still stops it
                raise KeyboardInterrupt
            return code
        finally:  # a signal before this line is a KeyboardInterrupt, handled below
            RETURNED.append(True)
    except PlanningFailed as exc:  # e.g. a saved path that no timing fits the limits (replay, export)
        print(f"foam-mj: planning failed: {_one_line(exc)}", file=sys.stderr)
        return EXIT_PLANNING_FAILED
    except UsageError as exc:
        print(_one_line(exc), file=sys.stderr)
        return EXIT_BAD_INPUT
    except FoamError as exc:
        print(f"foam-mj: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly
        sys.stderr.close()
        return EXIT_OK
    except KeyboardInterrupt:
        print("foam-mj: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # pragma: no cover - the last line of defence
        if caused_by_interrupt(exc):  # Ctrl-C inside a C extension's import: "ImportError: initialization failed"
            print("foam-mj: interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
        if os.environ.get("FOAM_MJ_DEBUG"):
            raise
        print(f"foam-mj: internal error: {type(exc).__name__}: {_one_line(exc)} (set FOAM_MJ_DEBUG=1 for a traceback)", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
