"""What the figures draw, read off a ``foam-mj plan --json`` document (foam_mj.figures): each path's points,
times and rosary, the paths grouped by rosary, the coordinate and joint labels, and each path's name, colour and
style (the thesis's colours for its four paths: Nascimento and Alsina 2021 Fig. 8). No matplotlib here.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

import mujoco
import numpy as np

from foam_mj.configuration import HINGE
from foam_mj.errors import FoamError
from foam_mj.figure_geometry import robot_kind
from foam_mj.model import RobotModel


# -- names, colours and labels ------------------------------------------------------------------------
# Nascimento and Alsina 2021 Fig. 8d: T red, T_CA blue, T_RA magenta, T_RCA green. The result file names them after the
# method ("centre", "gradient", "adjusted", "adjusted_gradient"); the thesis's own names work too.
_THESIS = {
    "centre": (r"$\mathcal{T}$ (rosary centres)", (0.85, 0.0, 0.0)),
    "gradient": (r"$\mathcal{T}_{CA}$ (gradient smoothing)", (0.0, 0.2, 0.95)),
    "adjusted": (r"$\mathcal{T}_{RA}$ (adjusted rosary)", (0.85, 0.0, 0.85)),
    "adjusted_gradient": (r"$\mathcal{T}_{RCA}$ (adjusted + smoothed)", (0.0, 0.6, 0.0)),
}
_ALIASES: dict[str, str] = {"T": "centre", "center": "centre", "T_CA": "gradient", "T_RA": "adjusted", "T_RCA": "adjusted_gradient"}
_OTHERS = {
    "hs": ("HS (harmony search)", (1.0, 0.55, 0.0)),
    "ga": ("GA (genetic algorithm)", (0.0, 0.7, 0.8)),
    "convex": ("convex (shortest through hatches)", (0.3, 0.3, 0.3)),
    "optimal": ("optimal (certified $f$)", (0.45, 0.0, 0.65)),
}
_FALLBACK_COLOURS = [(0.58, 0.4, 0.74), (0.55, 0.34, 0.29), (0.74, 0.74, 0.13), (0.5, 0.5, 0.5), (0.09, 0.75, 0.81)]
_ORDER = ["centre", "gradient", "adjusted", "adjusted_gradient", "hs", "ga", "convex", "optimal"]

# Symbols of the papers' configuration coordinates (Nascimento and Alsina 2021, section 5.1).
_SYMBOLS = {"hip_flexion": r"\theta_h", "knee_flexion": r"\theta_k", "hip_displacement": r"\theta_q"}
_START_STYLE = dict(marker="o", color="black", markersize=7, markeredgecolor="white", linestyle="none")
_GOAL_STYLE = dict(marker="*", color="black", markersize=12, markeredgecolor="white", linestyle="none")
_OBSTACLE_FACE = (0.80, 0.62, 0.25)
_OBSTACLE_EDGE = (0.45, 0.32, 0.1)



def _rows(value, where: str) -> np.ndarray:
    """``value`` as a float array, or FoamError naming ``where`` (ragged rows were an internal error, exit 1)."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise FoamError(f"{where} must be numbers (a list, or rows of equal length)") from None

def path_style(name: str, index: int = 0) -> tuple[str, tuple[float, float, float]]:
    """(legend label, RGB colour) of a path: the thesis's colours for T, T_CA, T_RA, T_RCA."""
    key = _ALIASES.get(name, name)
    if key in _THESIS:
        return _THESIS[key]
    if key in _OTHERS:
        return _OTHERS[key]
    return name.replace("_", " "), _FALLBACK_COLOURS[index % len(_FALLBACK_COLOURS)]


def _order_paths(names: Iterable[str]) -> list[str]:
    listed = list(names)
    rank = {n: i for i, n in enumerate(_ORDER)}

    def order(n: str) -> tuple[int, int]:  # (a lambda's overloaded dict.get confused mypy 2.4)
        return rank.get(_ALIASES.get(n, n), len(rank)), listed.index(n)

    return sorted(listed, key=order)


# -- reading the document -------------------------------------------------------------------------------
@dataclass
class _Path:
    name: str
    label: str
    colour: tuple[float, float, float]
    waypoints: np.ndarray | None  # (m, n) configuration coordinates
    qpos: np.ndarray  # (T, nq)
    times: np.ndarray | None
    convergence: dict | None
    metrics: dict
    objective: str | None = None  # what "convergence" tracks ("f", "SV", "TC", "length"), when known
    rosary: tuple[np.ndarray, np.ndarray] | None = None  # (centers, radii) of the rosary holding the path


def _as_doc(doc) -> dict:
    if isinstance(doc, (str, Path)):
        from foam_mj.results import read_result

        return read_result(doc)
    if not isinstance(doc, dict):
        raise FoamError(f"expected a result document (dict) or a path to one, got {type(doc).__name__}")
    for key in ("mjcf", "paths", "q_init", "q_goal"):
        if doc.get(key) is None:
            raise FoamError(f"the result document has no field '{key}'")
    if not isinstance(doc["mjcf"], str) or not doc["mjcf"]:
        raise FoamError(f"the result document's field 'mjcf' must be the path of the MJCF scene (a string), got {doc['mjcf']!r}")
    return doc


def _read_paths(doc: dict, robot: RobotModel, names: Sequence[str] | None) -> list[_Path]:
    entries = doc.get("paths") or {}
    if names is None:
        names = _order_paths(entries)
    else:
        missing = [n for n in names if n not in entries]
        if missing:
            raise FoamError(f"no path named {missing} in the result (it has: {sorted(entries)})")
    nq = robot.model.nq
    out = []
    for i, name in enumerate(names):
        e = entries[name] or {}
        w = np.asarray(e["waypoints"], dtype=float) if e.get("waypoints") is not None else None
        if e.get("qpos") is not None:
            qpos = _rows(e["qpos"], f"path '{name}': field 'qpos'")
        elif w is not None:
            qpos = robot.config.to_qpos(w)
        else:
            continue  # nothing to draw
        if qpos.ndim != 2 or qpos.shape[1] != nq or len(qpos) < 1 or not np.all(np.isfinite(qpos)):
            raise FoamError(f"path '{name}': qpos must have shape (T, {nq}) for this model, finite, got shape {qpos.shape}")
        if w is not None and (w.ndim != 2 or w.shape[1] != robot.dim):
            raise FoamError(f"path '{name}': waypoints must have shape (m, {robot.dim}), got {w.shape}")
        times = None
        if e.get("times") is not None:
            times = _rows(e["times"], f"path '{name}': field 'times'")
            if times.ndim != 1:  # len() of a number was an internal error
                raise FoamError(f"path '{name}': field 'times' must be a list of numbers, one per qpos row, got shape {times.shape}")
            if times.shape != (len(qpos),):
                raise FoamError(f"path '{name}': {len(times)} times for {len(qpos)} qpos rows")
            if len(times) < 2 or not np.all(np.diff(times) > 0):
                raise FoamError(f"path '{name}': times must increase")
        conv = e.get("convergence")
        if not (isinstance(conv, dict) and conv.get("best") is not None and len(conv["best"]) > 0):
            conv = None
        label, colour = path_style(name, i)
        if name not in _ALIASES and _ALIASES.get(name, name) not in _THESIS and name not in _OTHERS and e.get("label"):
            label = str(e["label"])
        smoother = e["smoother"] if isinstance(e.get("smoother"), dict) else {}
        objective = smoother.get("objective") or (conv or {}).get("objective")
        ros = _rosary_arrays(e.get("rosary"), f"path '{name}': field 'rosary'")
        out.append(_Path(name, label, colour, w, qpos, times, conv, dict(e.get("metrics") or {}),
                         None if objective is None else str(objective), ros))
    return out


def foam_arrays(doc: dict) -> tuple[np.ndarray, np.ndarray] | None:
    """The result's foam, (centers, radii), or None when it has none; FoamError for rows that are not q's width or
    numbers that are not finite (an infinite centre was matplotlib's "Axis limits cannot be infinite", exit 1)."""
    foam = doc.get("foam")
    if not isinstance(foam, dict) or not foam.get("centers"):
        return None
    try:
        c, r = np.asarray(foam["centers"], dtype=float), np.asarray(foam.get("radii"), dtype=float)
    except (TypeError, ValueError):
        raise FoamError("field 'foam': centers and radii must be numbers") from None
    if c.ndim != 2 or c.shape[1] != len(doc["q_init"]) or r.shape != (len(c),):
        raise FoamError(f"field 'foam': {r.size} radii for centers of shape {c.shape}; expected one radius per centre of {len(doc['q_init'])} numbers")
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(r)) and np.all(r > 0)):
        raise FoamError("field 'foam': centers must be finite numbers and radii finite numbers > 0")
    return c, r


def _rosary_arrays(ros, where: str = "field 'rosary'") -> tuple[np.ndarray, np.ndarray] | None:
    if not isinstance(ros, dict) or not ros.get("centers") or ros.get("radii") is None:
        return None
    c, r = np.asarray(ros["centers"], dtype=float), np.asarray(ros["radii"], dtype=float)
    if c.ndim != 2 or r.shape != (len(c),):
        raise FoamError(f"a rosary has {len(r)} radii for centers of shape {c.shape}")
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(r)) and np.all(r > 0)):  # NaN was matplotlib's ValueError (exit 1)
        raise FoamError(f"{where}: centers must be finite numbers and radii finite numbers > 0")
    return c, r


def _same_rosary(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a[0].shape == b[0].shape and np.allclose(a[0], b[0]) and np.allclose(a[1], b[1])


def _rosary_groups(doc: dict, paths: list[_Path]) -> list[tuple[str, str, tuple | None, list[_Path]]]:
    """(file stem, title, rosary, paths it holds): the planned rosary first, then each other rosary
    (the adjusted one of T_RA and T_RCA), named after the first path that lies in it."""
    main = _rosary_arrays(doc.get("rosary"))
    groups: list[tuple[str, str, tuple | None, list[_Path]]] = [("rosary", "Rosary", main, []) if main is not None else ("paths", "Paths", None, [])]
    for p in paths:
        ros = p.rosary if p.rosary is not None else main
        for g in groups:
            if _same_rosary(g[2], ros):
                g[3].append(p)
                break
        else:
            if _ALIASES.get(p.name, p.name) in ("adjusted", "adjusted_gradient"):
                stem, title = "rosary_adjusted", "Adjusted rosary"
            else:
                stem, title = f"rosary_{p.name}", f"Rosary of {p.label}"
            if any(g[0] == stem for g in groups):
                stem = f"rosary_{p.name}"
            groups.append((stem, title, ros, [p]))
    return [g for g in groups if g[2] is not None or g[3]]


def _config_points(p: _Path, robot: RobotModel) -> np.ndarray:
    """The path in configuration coordinates: its waypoints, or its qpos rows mapped back."""
    return p.waypoints if p.waypoints is not None else robot.config.to_q(p.qpos)


def _sample_qpos(p: _Path, robot: RobotModel, count: int) -> np.ndarray:
    """``count`` qpos rows at evenly spaced times (by arc length in q when the path has no times)."""
    if p.times is not None:
        t = np.linspace(p.times[0], p.times[-1], count)
        return np.column_stack([np.interp(t, p.times, p.qpos[:, c]) for c in range(p.qpos.shape[1])])
    q = robot.config.to_q(p.qpos)
    if len(q) == 1:
        return np.repeat(p.qpos, count, axis=0)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    if s[-1] <= 0:
        return np.repeat(p.qpos[:1], count, axis=0)
    u = np.linspace(0.0, s[-1], count)
    qs = np.column_stack([np.interp(u, s, q[:, c]) for c in range(q.shape[1])])
    return robot.config.to_qpos(qs)


def _coord_labels(robot: RobotModel) -> list[str]:
    """Axis labels of the configuration coordinates, with units."""
    m, cfg = robot.model, robot.config
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    labels = []
    for name, j, s, o in zip(cfg.joint_names, cfg.joint_ids, cfg.scale, cfg.offset):
        normalized = not (s == 1.0 and o == 0.0)
        hinge = int(m.jnt_type[j]) == HINGE
        if name in _SYMBOLS:
            sym = f"${_SYMBOLS[name]}$"
        else:
            axis = np.abs(np.asarray(d.xaxis[j]))
            if hinge:
                sym = r"$\theta$" if axis.max() > 0.99 and np.argmax(axis) == 2 and robot_kind(robot) == "planar_base" else name.replace("_", " ")
            else:
                sym = "xyz"[int(np.argmax(axis))] if axis.max() > 0.99 and robot_kind(robot) == "planar_base" else name.replace("_", " ")
        if normalized:  # the papers give the normalized hip displacement theta_q in rad
            unit = "rad" if name in _SYMBOLS else "normalized"
        else:
            unit = "rad" if hinge else "m"
        labels.append(f"{sym} [{unit}]")
    return labels


def _joint_labels(robot: RobotModel) -> list[tuple[str, str, str]]:
    """(name, position unit, velocity unit) of each configuration joint, in joint units."""
    m = robot.model
    out = []
    for name, j in zip(robot.config.joint_names, robot.config.joint_ids):
        hinge = int(m.jnt_type[j]) == HINGE
        nice = name.replace("_", " ")
        if name in _SYMBOLS:
            nice = f"{nice} (${_SYMBOLS[name]}$)" if hinge else nice
        out.append((nice, "rad" if hinge else "m", "rad/s" if hinge else "m/s"))
    return out


#: The names of the figures foam-mj draws (module foam_mj.figures), for the note on those an earlier run left in a folder.
_FIGURE_NAME = re.compile(r"(foam|rosary(_\w+)?|paths|strobe|convergence|joints|map)\.(png|svg|pdf)")


def stale_figures_note(folder, written) -> str | None:
    """A note naming the figure files in ``folder`` that this run did not write (``written``): an earlier run's, of
    another result or other --paths, which the folder would otherwise show beside this run's without a word."""
    try:
        here = {p.name for p in Path(folder).iterdir() if _FIGURE_NAME.fullmatch(p.name)}
    except OSError:
        return None
    stale = sorted(here - {Path(p).name for p in written})
    if not stale:
        return None
    return (f"note: {folder} also holds {len(stale)} figure(s) this run did not draw, left by an earlier run: "
            f"{', '.join(stale[:8])}{', ...' if len(stale) > 8 else ''} (remove them, or draw into an empty folder)")

