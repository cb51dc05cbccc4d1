"""Helpers shared by the benchmark scripts: timing, tables, JSON output, progress on stderr, and the command-line
rules of every foam-mj command (a bad argument: one line, exit 2, before any work; Ctrl-C: exit 130, nothing
written; outputs written once, atomically, at the end)."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from foam_mj.atomic import OutputError, atomic_write_text, check_output
from foam_mj.cli import Parser, UsageError
from foam_mj.errors import ScenarioError
from foam_mj.scenarios import load_scenario

#: The most runs, seeds or repeats a script takes (a typo of a few zeros would run for days).
MAX_COUNT = 10_000


def parser(description: str) -> Parser:
    """An argument parser whose errors are one line (:class:`foam_mj.cli.UsageError`; :func:`run_script` exits 2)."""
    return Parser(description=description)


def count(lo: int = 1, hi: int = MAX_COUNT) -> Callable[[str], int]:
    """An argparse type: an integer in [lo, hi] (runs, seeds, repeats, samples)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer in [{lo}, {hi:,}], got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"expected an integer in [{lo}, {hi:,}], got {value}")
        return value

    return parse


def check_json(ap: argparse.ArgumentParser, path: str | Path | None) -> None:
    """Refuse (one line, exit 2) a --json that cannot be written or does not end in .json, before any work."""
    try:
        check_output(path, "--json", suffix=".json")
    except OutputError as exc:
        ap.error(str(exc))


def check_scenarios(ap: argparse.ArgumentParser, names: Iterable[str]) -> None:
    """Refuse (one line, exit 2) a scenario name or file that does not exist or whose fields are wrong, before any
    work (the scene itself is loaded when the script runs it)."""
    for name in names:
        try:
            load_scenario(name, check=False)
        except ScenarioError as exc:
            ap.error(f"--scenarios: {exc}")


def run_script(main: Callable[[], object]) -> None:
    """Run a script's ``main``: a bad argument prints its one line and exits 2; Ctrl-C exits 130 with nothing
    written (outputs are written after the last run); an int result is the exit status."""
    try:
        status = main()
    except UsageError as exc:
        print(exc, file=sys.stderr)
        raise SystemExit(2) from None
    except KeyboardInterrupt:
        print("\ninterrupted: nothing written", file=sys.stderr)
        raise SystemExit(130) from None
    raise SystemExit(status if isinstance(status, int) else 0)


def median_time(fn: Callable[[], object], repeats: int = 7) -> float:
    """Median wall time of ``fn()`` over ``repeats`` runs (after one warm-up run)."""
    fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def table(headers: list[str], rows: Iterable[list], floatfmt: str = ".4g") -> str:
    """A plain-text table with right-aligned columns."""
    cells = [[h for h in headers]] + [[(format(v, floatfmt) if isinstance(v, float) else str(v)) for v in r] for r in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    lines = ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def progress(i: int, total: int, label: str) -> None:
    """A progress bar on stderr."""
    width = 30
    done = int(width * i / max(total, 1))
    sys.stderr.write(f"\r{label} [{'#' * done}{'.' * (width - done)}] {i}/{total}")
    if i >= total:
        sys.stderr.write("\n")
    sys.stderr.flush()


def write_json(path: str | Path, data: dict) -> None:
    """Write ``data`` as JSON, atomically (a reader never sees a partial file)."""
    atomic_write_text(path, json.dumps(data, indent=1, default=float))
    print(f"wrote {path}")
