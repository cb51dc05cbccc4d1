"""Helpers shared by the benchmark scripts: timing, tables, JSON output, progress on stderr."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Callable, Iterable

import numpy as np


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
    Path(path).write_text(json.dumps(data, indent=1, default=float))
    print(f"wrote {path}")
