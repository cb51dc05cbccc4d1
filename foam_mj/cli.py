"""The ``foam-mj`` command line.

Exit codes: 0 success, 1 internal error, 2 bad input (unknown scene, malformed scenario, unwritable
output), 3 planning failed (the foam did not reach the goal; what was computed is still written).
Errors are one line on stderr, never a traceback (set FOAM_MJ_DEBUG=1 to see one).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from foam_mj.errors import FoamError, PlanningFailed

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_PLANNING_FAILED = 0, 1, 2, 3


class Progress:
    """A one-line progress display on stderr (only when stderr is a terminal, or when forced)."""

    def __init__(self, enabled: bool | None = None) -> None:
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self._shown = False

    def __call__(self, text: str) -> None:
        if self.enabled:
            sys.stderr.write("\r\033[K" + text)
            sys.stderr.flush()
            self._shown = True

    def done(self) -> None:
        if self._shown:
            sys.stderr.write("\r\033[K")
            sys.stderr.flush()
            self._shown = False


def _check_writable(path: str | None, what: str) -> Path | None:
    """Fail before any work when an output file cannot be written."""
    if path is None:
        return None
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if p.is_dir():
        raise FoamError(f"{what} output {p} is a directory")
    if not parent.is_dir():
        raise FoamError(f"{what} output {p}: folder {parent} does not exist")
    if not os.access(parent, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise FoamError(f"{what} output {p} is not writable")
    return p


def cmd_scenes(args: argparse.Namespace) -> int:
    from foam_mj.scenarios import available_scenarios, load_scenario

    rows = []
    for name in available_scenarios():
        s = load_scenario(name, check=False)
        rows.append((s.name, s.description, _fmt_q(s.q_init), _fmt_q(s.q_goal), s.scene.name))
    widths = [max(len(r[i]) for r in rows + [("name", "what it is", "start", "goal", "scene file")]) for i in range(5)]
    header = ("name", "what it is", "start", "goal", "scene file")
    print("  ".join(h.ljust(w) for h, w in zip(header, widths)))
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths)))
    return EXIT_OK


def _fmt_q(q) -> str:
    return "[" + ", ".join(f"{v:g}" for v in np.asarray(q)) + "]"


def cmd_plan(args: argparse.Namespace) -> int:
    from foam_mj.foam import plan
    from foam_mj.scenarios import load_scenario

    json_out = _check_writable(args.json, "--json")
    scenario = load_scenario(args.scene)
    seed = scenario.seed if args.seed is None else args.seed
    oracle = scenario.oracle()
    progress = Progress()
    t0 = time.perf_counter()
    try:
        result = plan(
            oracle,
            scenario.q_init,
            scenario.q_goal,
            scenario.params,
            seed=seed,
            progress=lambda st: progress(f"planning: {st.bubbles} bubbles, {st.elapsed:.1f} s"),
        )
    except PlanningFailed as exc:
        progress.done()
        print(f"foam-mj: planning failed: {exc}", file=sys.stderr)
        return EXIT_PLANNING_FAILED
    finally:
        progress.done()
    from foam_mj.paths import metrics, min_clearance_along

    rosary = result.rosary
    centre = rosary.path(rosary.center_waypoints())
    m = metrics(centre)
    clearance = min_clearance_along(oracle.clearance, centre)
    st = result.stats
    print(f"scenario {scenario.name} (seed {seed}): {st.bubbles} bubbles in {st.elapsed:.3f} s "
          f"({st.bubbles_per_second:,.0f} bubbles/s), rosary of {rosary.k} bubbles")
    print(f"{'path':<10}{'length':>9}{'f':>9}{'TC':>8}{'SV':>8}{'min clearance':>15}")
    print(f"{'centre':<10}{m.length:>9.4f}{m.f:>9.4f}{m.tc:>8.4f}{m.sv:>8.4f}{clearance * 1000:>12.1f} mm")
    if json_out is not None:
        from foam_mj.results import write_result

        write_result(json_out, scenario, result, {"centre": centre}, seed=seed)
        print(f"wrote {json_out}")
    print(f"total {time.perf_counter() - t0:.2f} s")
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="foam-mj",
        description="Plan safe, smooth swing-leg motions for the Ortholeg exoskeleton with the Probabilistic Foam Method.",
        epilog="Exit codes: 0 success, 2 bad input, 3 planning failed.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    p = sub.add_parser("scenes", help="list the built-in scenarios", description="List the built-in scenarios: name, what it is, start and goal.")
    p.set_defaults(func=cmd_scenes)
    p = sub.add_parser("plan", help="plan, smooth, replay and record", description="Plan a path with the Probabilistic Foam Method.")
    p.add_argument("--scene", default="obstacle", help="a scenario name (see `foam-mj scenes`) or a path to a scenario TOML (default: obstacle)")
    p.add_argument("--seed", type=int, default=None, help="random seed (default: the scenario's)")
    p.add_argument("--json", metavar="OUT.json", help="write the result as JSON (readable by shared/tools/verify_result.py)")
    p.set_defaults(func=cmd_plan)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except FoamError as exc:
        print(f"foam-mj: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("foam-mj: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # pragma: no cover - the last line of defence
        if os.environ.get("FOAM_MJ_DEBUG"):
            raise
        print(f"foam-mj: internal error: {type(exc).__name__}: {exc} (set FOAM_MJ_DEBUG=1 for a traceback)", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
