"""``foam-mj report DIR``: feasibility-envelope figures and a summary table of a sweep's rows.

The envelope is drawn over the swept keys that vary most (most distinct values), or those chosen
(``--axes X [Y [PANEL]]``): the first is the heatmap's x axis, the second its y axis, and each value of a third
gets its own panel; every other key (and the seeds) is pooled into the cells, and the figure's title names the
pooled keys. A key with more than :data:`MAX_LEVELS` numeric values (random
samples) is cut into :data:`BINS` equal-width bins, labelled by their centres; a list-valued key drawn at random
(``obstacle.size`` drawn element-wise) becomes one such numeric axis per element that varies. One figure per measure and
per smoother (path name):

=====================  ==============================================  =====================================
file                   cell value                                      why this aggregate
=====================  ==============================================  =====================================
success-<path>         share of the valid plans that reached the goal  the envelope itself
min_clearance-<path>   smallest clearance (mm) over the cell's plans   safety is a worst case, not a mean
f-<path>               median f (Nascimento et al. 2020 Eq. 5) of the reached ones  robust to the odd long detour
knee_torque-<path>     largest peak knee torque (N m) of the reached   the actuator must cover the worst
=====================  ==============================================  =====================================

Empty cells (no plan, or none reached) are grey; cells whose plans were all ``invalid`` (start or goal not
free: no problem to solve) are hatched grey, with a legend, in every figure, so that "no valid problem here" is not
read as "the planner failed" (a success of 0). A measure with no value at all (no replay: no clearance) gets no
figure, but success is drawn even when every cell is hatched (a study without a valid problem). The knee figure is drawn when the rows carry a ``peak_torque_*knee*`` column
(any replay).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from foam_mj.atomic import OutputError, atomic_path, atomic_write_text, check_output_dir
from foam_mj.errors import FoamError

MAX_LEVELS = 12
BINS = 8
MAX_PANELS = 6


@dataclass(frozen=True)
class Level:
    """One axis of the envelope: the key, the label of each level, and each row's level index."""

    key: str
    labels: tuple[str, ...]
    index: np.ndarray  # (rows,) int, -1 where the value is missing
    title: str = ""  # the axis label: the key, or e.g. "obstacle.size[2]" when only that element varies

    @property
    def name(self) -> str:
        return self.title or self.key


def _levels(key: str, kind: str, values: list) -> list[Level]:
    """The envelope axes of one swept key: one, or for a list-valued key drawn at random (more than
    :data:`MAX_LEVELS` distinct lists of numbers) one numeric axis per element that varies."""
    present = [v for v in values if v is not None]
    if kind == "json":
        parsed = {v: json.loads(v) for v in set(present)}  # each distinct value decoded once: random draws are all distinct
        decoded = sorted(parsed, key=lambda s: (parsed[s] if isinstance(parsed[s], list) else [], s))
        pos = {v: i for i, v in enumerate(decoded)}
        index = np.array([pos.get(v, -1) for v in values])
        lists = [parsed[v] for v in decoded]
        if all(isinstance(v, list) and len(v) == len(lists[0]) for v in lists) and len(lists) > 1:
            numeric = all(_is_number(e) for v in lists for e in v)
            if numeric:
                table = np.array(lists, dtype=float)
                varying = [i for i in range(table.shape[1]) if table[:, i].min() < table[:, i].max()]
            else:
                varying = [i for i in range(len(lists[0])) if len({json.dumps(v[i]) for v in lists}) > 1]
            if numeric and len(lists) > MAX_LEVELS:  # e.g. obstacle.size drawn element-wise: one label per row was no envelope
                return [_number_level(key, [lists[k][i] if k >= 0 else None for k in index], f"{key}[{i}]") for i in varying]
            if len(varying) == 1:  # label by the one element that changes, e.g. the box's height
                i = varying[0]
                labels = tuple(f"{v[i]:g}" if isinstance(v[i], float) else str(v[i]) for v in lists)
                return [Level(key, labels, index, f"{key}[{i}]")]
        return [Level(key, tuple(decoded), index)]
    if kind in ("int", "float"):
        return [_number_level(key, values)]
    distinct = sorted(set(present), key=lambda v: (isinstance(v, str), v))
    pos = {v: i for i, v in enumerate(distinct)}
    return [Level(key, tuple(f"{v:g}" if isinstance(v, float) else str(v) for v in distinct), np.array([pos.get(v, -1) for v in values]))]


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _number_level(key: str, values: list, title: str = "") -> Level:
    """A numeric axis: its distinct values, or :data:`BINS` equal-width bins when there are more than :data:`MAX_LEVELS`."""
    distinct = sorted({v for v in values if v is not None})
    if len(distinct) > MAX_LEVELS:
        x = np.array([np.nan if v is None else float(v) for v in values])
        lo, hi = float(np.nanmin(x)), float(np.nanmax(x))
        edges = np.linspace(lo, hi, BINS + 1)
        idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, BINS - 1)
        idx[np.isnan(x)] = -1
        centres = 0.5 * (edges[:-1] + edges[1:])
        return Level(key, tuple(f"{c:.4g}" for c in centres), idx.astype(int), title)
    pos = {v: i for i, v in enumerate(distinct)}
    return Level(key, tuple(f"{v:g}" if isinstance(v, float) else str(v) for v in distinct), np.array([pos.get(v, -1) for v in values]), title)


def _torque_column(columns: Sequence[str]) -> str | None:
    knee = [c for c in columns if c.startswith("peak_torque_") and "knee" in c]
    return knee[0] if knee else None


#: (file stem, title, unit, colormap, aggregate over a cell's rows -> value or nan)
def _measures(data: dict[str, np.ndarray], torque: str | None):
    reached, valid = data["outcome"] == "reached", data["outcome"] != "invalid"

    def success(rows):
        rows = rows[valid[rows]]
        return float(np.mean(reached[rows])) if rows.size else np.nan

    def over_reached(column, fn, scale=1.0):
        col = data[column]

        def agg(rows):
            r = rows[reached[rows]]
            v = col[r]
            v = v[np.isfinite(v)]
            return float(fn(v)) * scale if v.size else np.nan

        return agg

    out = [
        ("success", "success rate of valid plans", "", "RdYlGn", success, (0.0, 1.0)),
        ("min_clearance", "min clearance", "mm", "viridis", over_reached("min_clearance", np.min, 1000.0), None),
        ("f", "median f", "", "viridis_r", over_reached("f", np.median), None),
    ]
    if torque is not None:
        out.append(("knee_torque", "peak knee torque", "N m", "magma_r", over_reached(torque, np.max), None))
    return out


def _column(table, name: str) -> np.ndarray:
    column = table.column(name)
    if column.type in (_pa().float64(), _pa().int64()):
        return column.cast(_pa().float64()).to_numpy()  # nulls are nan
    return np.array(column.to_pylist(), dtype=object)


#: The columns the summary and the figures read, besides the knee torque's.
READ = ("smoother", "outcome", "f", "length", "min_clearance", "plan_time", "task_time")


def _data(table) -> dict[str, np.ndarray]:
    """The columns the report reads, as numpy arrays (not every column of every row as Python objects: memory)."""
    names = [n for n in (*READ, _torque_column(table.column_names)) if n is not None and n in table.column_names]
    return {n: _column(table, n) for n in names}


def _pa():
    import pyarrow

    return pyarrow


def load(out: str | Path) -> tuple[dict, Any]:
    """The sweep's manifest and rows (a pyarrow Table)."""
    from foam_mj.sweep_run import read_manifest, read_rows

    out = Path(out)
    if not os.path.isdir(out):  # never raises (Path.is_dir raised OSError for a name too long on Python 3.11)
        if os.path.lexists(out):  # was "sweep folder not found" for a file that is there
            raise FoamError(f"{out} is a file, not a sweep folder (the --out folder of foam-mj sweep)")
        raise FoamError(f"sweep folder not found: {out}")
    manifest = read_manifest(out)
    if manifest is None:
        raise FoamError(f"{out} is not a sweep folder (no sweep.json): run foam-mj sweep SWEEP.toml --out {out} first")
    return manifest, read_rows(out, manifest.get("columns") or ("key",))


def summary(manifest: dict, table) -> list[dict]:
    """One line per smoother: plans, the share of the valid plans that reached (None without a valid plan), failures
    by outcome, and the medians and extremes of the reached plans."""
    data = _data(table)
    torque = _torque_column(table.column_names)
    lines = []
    for path in _paths(manifest, data):
        rows = data["smoother"] == path
        reached = rows & (data["outcome"] == "reached")

        def med(c, scale=1.0):
            v = data[c][reached]
            v = v[np.isfinite(v)]
            return float(np.median(v)) * scale if v.size else None

        def ext(c, fn, scale=1.0):
            v = data[c][reached]
            v = v[np.isfinite(v)]
            return float(fn(v)) * scale if v.size else None

        outcomes = {o: int(np.sum(rows & (data["outcome"] == o))) for o in ("reached", "failed", "invalid", "error")}
        lines.append(
            {
                "smoother": path,
                "plans": int(rows.sum()),
                **outcomes,
                # of the valid plans, as the success figure and the README's query (was reached / every plan: a study
                # whose valid plans all reached, beside as many invalid ones, read 50 % here and 1.00 in the figure)
                "success": outcomes["reached"] / valid if (valid := int(rows.sum()) - outcomes["invalid"]) else None,
                "median_f": med("f"),
                "median_length": med("length"),
                "min_clearance_mm": ext("min_clearance", np.min, 1000.0),
                "median_plan_time_s": med("plan_time"),
                "median_task_time_s": med("task_time"),
                "max_knee_torque": ext(torque, np.max) if torque else None,
            }
        )
    return lines


def _percent(share: float | None) -> str:
    """A share as a percentage, whole percents unless that would read 0% or 100% for a share strictly between them
    (233 of 234 reached read '100%' beside a failed plan): then one decimal, and '<0.1%' / '>99.9%' beyond it."""
    if share is None:
        return "-"
    p = 100.0 * share
    if 0.0 < share < 1.0 and not 0.5 <= p < 99.5:
        if p < 0.1:
            return "<0.1%"
        if p > 99.9:
            return ">99.9%"
        return f"{p:.1f}%"
    return f"{p:.0f}%"


def format_summary(lines: list[dict]) -> str:
    head = ["smoother", "plans", "reached (of valid)", "failed", "invalid", "error", "median f", "median length", "min clear", "plan time", "knee torque"]
    cells = [head]
    for ln in lines:

        def f(v, fmt):
            return "-" if v is None else format(v, fmt)

        cells.append(
            [
                ln["smoother"], str(ln["plans"]), f"{ln['reached']} ({_percent(ln['success'])})", str(ln["failed"]), str(ln["invalid"]),
                str(ln["error"]), f(ln["median_f"], ".4f"), f(ln["median_length"], ".4f"),
                "-" if ln["min_clearance_mm"] is None else f"{ln['min_clearance_mm']:.1f} mm",
                "-" if ln["median_plan_time_s"] is None else f"{ln['median_plan_time_s']:.3f} s",
                "-" if ln["max_knee_torque"] is None else f"{ln['max_knee_torque']:.1f} N m",
            ]
        )
    widths = [max(len(r[i]) for r in cells) for i in range(len(head))]
    out = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths))) for r in cells]
    out.insert(1, "-" * len(out[0]))
    return "\n".join(out)


def _paths(manifest: dict, data) -> list[str]:
    present = list(dict.fromkeys(data["smoother"].tolist()))
    order = [p for p in manifest.get("paths", []) if p in present]
    return order + [p for p in present if p not in order]


def envelope_axes(manifest: dict, table) -> list[Level]:
    """The swept keys with more than one level, most varied first (ties: the sweep file's order)."""
    kinds = manifest.get("keys", {})
    levels = [level for k, kind in kinds.items() if k in table.column_names for level in _levels(k, kind, table.column(k).to_pylist())]
    varied = [lv for lv in levels if len(lv.labels) > 1]
    return sorted(varied, key=lambda lv: -len(lv.labels))


def grid_values(x: Level, y: Level | None, rows: np.ndarray, agg) -> np.ndarray:
    """(len(y), len(x)) cell values of ``agg`` over the rows selected by ``rows`` (a boolean mask); ``agg`` gets each
    non-empty cell's row indices in ascending order. One pass over the rows, however many cells."""
    nx, ny = len(x.labels), 1 if y is None else len(y.labels)
    out = np.full((ny, nx), np.nan)
    yi = np.zeros_like(x.index) if y is None else y.index
    idx = np.flatnonzero(rows & (x.index >= 0) & (yi >= 0))
    cell = yi[idx] * nx + x.index[idx]
    order = np.argsort(cell, kind="stable")
    idx, cell = idx[order], cell[order]
    for group in np.split(np.arange(len(idx)), np.flatnonzero(np.diff(cell)) + 1):
        if group.size:
            c = int(cell[group[0]])
            out[c // nx, c % nx] = agg(idx[group])
    return out


def choose_axes(levels: list[Level], names: Sequence[str], out) -> list[Level]:
    """The envelope axes named (x, then y, then the panel key), by key or element title (``obstacle.size[2]``);
    FoamError naming the choices when one is not a swept key that varies in the rows, or is named twice."""
    if len(names) > 3:
        raise FoamError(f"--axes takes at most 3 keys (x, y, the panel key), got {len(names)}: {list(names)}")
    by: dict[str, Level] = {}
    for lv in levels:
        by.setdefault(lv.name, lv)
        if lv.title:  # a key drawn element-wise: its name alone stands for its first varying element
            by.setdefault(lv.key, lv)
    chosen = []
    for name in names:
        if name not in by:
            raise FoamError(f"--axes {name!r}: not a swept key that varies in {out}; " + (f"choose from {[lv.name for lv in levels]}"
                            if levels else "no swept key varies in its rows yet (run more of the sweep, or leave --axes out)"))
        if by[name] in chosen:
            raise FoamError(f"--axes {name!r} is named twice")
        chosen.append(by[name])
    return chosen


def write_report(out: str | Path, figures_dir: str | Path | None = None, *, formats: Sequence[str] = ("png",), dpi: int = 120,
                 progress: Callable[[str], None] | None = None, axes: Sequence[str] = (),
                 drew: list[str] | None = None) -> tuple[str, list[Path]]:
    """Draw the envelope figures into ``figures_dir`` (default DIR/report) and return (summary text, files).
    ``drew``, when given, is appended one line saying over which keys the figures were drawn and which measures
    were not (and why).
    ``progress`` is told what is being done (reading the rows, each figure drawn). ``axes``: the swept keys to draw
    (x, y, the panel key), instead of the most varied ones; the keys left out are pooled, and each figure's title
    names them."""
    from foam_mj.figures import _matplotlib

    say = progress or (lambda _text: None)
    say(f"reading the rows of {out}")
    manifest, table = load(out)
    _matplotlib()  # FoamError with the install hint when matplotlib is missing
    if figures_dir is None:
        try:
            figures_dir = check_output_dir(Path(out) / "report", "report folder")
        except OutputError as exc:  # e.g. a sweep folder on read-only storage: say how to write elsewhere
            raise OutputError(f"{exc} (the default report folder; write elsewhere with --figures FIGDIR)") from None
    else:
        figures_dir = check_output_dir(figures_dir, "--figures")  # not Path(""): that is ".", and "" wrote into the current folder
    figures_dir.mkdir(exist_ok=True)
    say(f"summarising {table.num_rows:,} rows")
    lines = summary(manifest, table)
    text = format_summary(lines)
    written = [_write_text(figures_dir / "summary.txt", text + "\n"), _write_text(figures_dir / "summary.json", json.dumps(lines, indent=1) + "\n")]
    say(f"binning the swept keys of {table.num_rows:,} rows")
    levels = envelope_axes(manifest, table)
    chosen = choose_axes(levels, axes, out) if axes else levels[:3]
    say_drew = drew.append if drew is not None else (lambda _text: None)
    if not chosen:
        say_drew("no figure: no swept key to draw over (the summary only)")
        return text, written
    x, y = chosen[0], (chosen[1] if len(chosen) > 1 else None)
    panel = chosen[2] if len(chosen) > 2 else None
    # a key neither drawn nor split into panels is pooled into the cells: the title says so (planners mixed in a cell)
    pooled = [lv.name for lv in levels if lv not in chosen]
    note = f"; pooled: {', '.join(pooled)}" if pooled else ""
    data = _data(table)
    torque = _torque_column(table.column_names)
    invalid = data["outcome"] == "invalid"
    figures = [(path, measure) for path in _paths(manifest, data) for measure in _measures(data, torque)]
    empty: dict[str, list[str]] = {}
    for k, (path, (stem, title, unit, cmap, agg, lims)) in enumerate(figures, 1):
        say(f"drawing {stem}-{path} ({k} of {len(figures)}, {table.num_rows:,} rows)")
        mask = data["smoother"] == path
        files = _draw(figures_dir, f"{stem}-{path}", f"{title} ({path}{note})", unit, cmap, lims, agg, x, y, panel, mask, invalid, formats, dpi)
        written += files
        if not files:
            empty.setdefault(stem, []).append(path)
    over = f"x: {x.name}" + (f", y: {y.name}" if y is not None else "") + (f", one panel per {panel.name}" if panel is not None else "")
    line = f"figures over {over}" + (f"; pooled: {', '.join(pooled)}" if pooled else "")
    for stem, paths in empty.items():  # was only 'wrote 2 figure(s)' when no plan reached: which, and why not the others?
        why = "no replayed plan reached" if stem in ("min_clearance", "knee_torque") else "no plan reached"
        line += f"; no {stem} figure for {', '.join(paths)}: {why}"
    say_drew(line)
    return text, written


#: The legend of a hatched cell: every plan of it was invalid.
INVALID_LABEL = "every plan invalid (start or goal not free): no problem to solve"
#: The legends of a grey cell: no plan in it (success), or no plan of it reached (the measures of reached plans).
NO_PLAN_LABEL = "no plan in this cell"
NOT_REACHED_LABEL = "no plan reached: nothing to measure"


def _draw(folder, stem, title, unit, cmap, lims, agg, x, y, panel, mask, invalid, formats, dpi) -> list[Path]:
    fig = _figure(title, unit, cmap, lims, agg, x, y, panel, mask, invalid)
    if fig is None:
        return []
    out = []
    for fmt in formats:
        p = folder / f"{stem}.{fmt}"
        with atomic_path(p) as tmp:
            fig.savefig(tmp, format=fmt, dpi=dpi, metadata={"Creator": "foam-mj"} if fmt == "png" else {"Creator": "foam-mj", "Date": None})
        out.append(p)
    return out


def _figure(title, unit, cmap, lims, agg, x, y, panel, mask, invalid):
    """The heatmap figure of one measure of one path (None: nothing measured)."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch, Rectangle

    panels = [(None, mask)] if panel is None else [(lab, mask & (panel.index == k)) for k, lab in enumerate(panel.labels)]
    grids = [grid_values(x, y, m, agg) for _, m in panels]
    blocked = [grid_values(x, y, m, lambda idx: 1.0 if invalid[idx].all() else np.nan) == 1.0 for _, m in panels]
    finite = np.concatenate([g[np.isfinite(g)] for g in grids]) if grids else np.array([])
    if not finite.size and (lims is None or not any(b.any() for b in blocked)):
        return None  # nothing measured (no replay, so no clearance); success (fixed scale) still shows invalid cells
    vmin, vmax = lims if lims is not None else (float(finite.min()), float(finite.max()))
    single = vmax <= vmin  # one value in every cell (one cell reached): a scale around it, its one tick that value
    if single:  # was vmax = vmin + 1e-9: a colour bar ticked 2.00 ... 2.75 under an offset '1e-9+8.620876132e1'
        value, pad = vmin, max(0.05 * abs(vmin), 1e-3)
        vmin, vmax = value - pad, value + pad
    ncell_x = len(x.labels)
    ny = 1 if y is None else len(y.labels)
    ncols = min(len(panels), MAX_PANELS)  # rows of at most MAX_PANELS panels: every value of the third key is drawn
    nrows = -(-len(panels) // ncols)
    fig = Figure(figsize=(1.2 + ncols * max(2.6, 0.62 * ncell_x + 1.2), 1.3 + nrows * max(1.2, 0.45 * ny + 0.8)), layout="constrained")
    axs = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axs[len(panels):]:
        ax.set_visible(False)
    import matplotlib

    cm = matplotlib.colormaps[cmap].with_extremes(bad="#d0d0d0")
    im = None
    hatch: dict[str, Any] = {"facecolor": "#d0d0d0", "edgecolor": "#808080", "hatch": "///", "linewidth": 0}
    for ax, (lab, _), g, no_problem in zip(axs, panels, grids, blocked):
        im = ax.imshow(np.ma.masked_invalid(g), origin="lower", cmap=cm, vmin=vmin, vmax=vmax, aspect="auto")
        for j, i in zip(*np.nonzero(no_problem)):
            ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, **hatch))
        ax.set_xticks(range(ncell_x), x.labels, rotation=30 if max(len(s) for s in x.labels) > 6 else 0, ha="right" if max(len(s) for s in x.labels) > 6 else "center")
        ax.set_xlabel(x.name)
        if y is not None:
            ax.set_yticks(range(ny), y.labels)
            ax.set_ylabel(y.name)
        else:
            ax.set_yticks([])
        if lab is not None:
            ax.set_title(f"{panel.name} = {lab}", fontsize=9)
        if g.size <= 120:
            for (j, i), v in np.ndenumerate(g):
                if np.isfinite(v):
                    frac = (v - vmin) / (vmax - vmin)
                    r, gg, b, _ = cm(frac)
                    ink = "white" if 0.299 * r + 0.587 * gg + 0.114 * b < 0.5 else "black"
                    ax.text(i, j, f"{v:.2f}" if abs(v) < 10 else f"{v:.0f}", ha="center", va="center", fontsize=7, color=ink)
    if im is not None:
        bar = fig.colorbar(im, ax=list(axs[: len(panels)]), label=f"{title.split(' (')[0]}{f' ({unit})' if unit else ''}", shrink=0.9)
        if single:
            bar.set_ticks([value], labels=[f"{value:.4g}"])
    handles = [Patch(**hatch, label=INVALID_LABEL)] if any(b.any() for b in blocked) else []
    if any((~np.isfinite(g) & ~b).any() for g, b in zip(grids, blocked)):  # a grey cell was unexplained in the figure
        handles.append(Patch(facecolor="#d0d0d0", label=NO_PLAN_LABEL if lims is not None else NOT_REACHED_LABEL))
    if handles:
        fig.legend(handles=handles, loc="outside lower center", fontsize=8, frameon=False, ncols=1)
    fig.suptitle(title, fontsize=10)
    return fig


def _write_text(path: Path, text: str) -> Path:
    return atomic_write_text(path, text)
