"""Publication figures from a ``foam-mj plan --json`` result.

:func:`write_figures` reads the JSON document (see :mod:`foam_mj.results` for its layout), loads its
MJCF scene and writes, into one folder:

``foam``         every bubble's centre in configuration space (3-D, sized and coloured by radius, the
                 foam's tree drawn faintly), start and goal (Nascimento et al. 2020 Fig. 7, Nascimento and Alsina 2021 Fig. 8a);
``rosary``       the rosary's bubbles (3-D wireframes and the three exact 2-D projections, where a ball
                 projects onto a disc) with the paths it holds, each in its own colour (Nascimento et al. 2020 Fig. 8,
                 Nascimento and Alsina 2021 Fig. 8b-d: T red, T_CA blue, T_RA magenta, T_RCA green; no rosary: ``paths``);
``rosary_adjusted``  likewise for a path's own rosary when it differs from the planned one (the
                 adjusted rosary of T_RA and T_RCA, Nascimento and Alsina 2021 Fig. 8c; other rosaries: ``rosary_<path>``);
``paths``        every path together without bubbles (Nascimento and Alsina 2021 Fig. 8d), when the paths lie in
                 different rosaries;
``strobe``       robot poses at evenly spaced times along each path, one panel per path, drawn from the
                 MJCF's own collision geoms projected onto the plane of motion (the sagittal x-z plane
                 for the leg, Nascimento et al. 2020 Fig. 9, Nascimento and Alsina 2021 Figs. 9-10; top-down x-y for a planar mobile
                 base, Nascimento and Alsina 2021 Figs. 12f-13f), over the obstacles and the floor;
``convergence``  best and population-mean f (Nascimento et al. 2020 Eq. 5) per iteration of each metaheuristic (HS,
                 GA, or any path whose "smoother" says its objective is "f"; Nascimento et al. 2020 Figs. 10a and
                 11a); only when such a path has ``convergence``;
``joints``       joint positions and finite-difference velocities (``numpy.gradient`` over "times") in
                 joint units, one row per configuration joint, one line per time-parametrized path;
                 only when some path has ``times``;
``map``          mobile bases only (configuration slides along world x and y): top-down map with the walls, the foam's (x, y) footprint,
                 the rosary and the paths (Nascimento and Alsina 2021 Figs. 12-13).

A one-joint robot's configuration space is a line (:mod:`foam_mj.figures_1d`): ``foam`` draws each bubble's interval of
the joint at the height of its radius, ``rosary`` the joint against the path parameter s (the fraction of the path's
length), its bubbles as bands of the joint.

Geometry is MuJoCo's: every pose runs ``mj_kinematics`` and each geom is projected onto the plane of motion
(:mod:`foam_mj.figure_geometry`).

matplotlib is optional (``pip install 'foam-mj[figures]'``). It is imported only when a figure is
drawn, and only through its object-oriented API (``matplotlib.figure.Figure``): pyplot is never
imported, no window is ever opened and the global backend is left alone.

Command line: ``foam-mj figures RESULT.json OUT_DIR [--format png svg pdf]`` (:func:`main`,
:func:`foam_mj.cli.add_figures_parser`, which the command line can build without importing this module).
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path
from typing import Any, Sequence

import mujoco
import numpy as np

from foam_mj.cli import FIGURE_DPI, FIGURE_FORMATS, FIGURE_MAX_DPI, FIGURE_MIN_DPI, add_figures_parser
from foam_mj.atomic import atomic_path
from foam_mj.errors import FoamError
from foam_mj.figure_data import (
    _ALIASES,
    _Path,
    _GOAL_STYLE,
    _OBSTACLE_EDGE,
    _OBSTACLE_FACE,
    _START_STYLE,
    _THESIS,
    _as_doc,
    _config_points,
    _coord_labels,
    _joint_labels,
    _read_paths,
    _rosary_groups,
    foam_arrays,
    stale_figures_note,
    _sample_qpos,
    path_style,
)
from foam_mj.figure_geometry import (_PLANES, Shape, _bounds, _default_plane, _shapes, base_xy, body_depth, convex_hull, has_xy_base,
                                     robot_kind, strobe_geometry, xy_of)
from foam_mj.model import RobotModel

__all__ = [
    "FORMATS",
    "Shape",
    "convex_hull",
    "add_figures_parser",
    "cmd_figures",
    "main",
    "path_style",
    "robot_kind",
    "strobe_geometry",
    "write_figures",
]

FORMATS = FIGURE_FORMATS
MISSING_MATPLOTLIB = "figures need matplotlib: pip install 'foam-mj[figures]'"
DPI = FIGURE_DPI
N_POSES = 8  # poses per strobe panel

# -- matplotlib, imported on demand ---------------------------------------------------------------------
def _matplotlib():
    """The matplotlib modules used here, or FoamError when matplotlib is not installed."""
    try:
        import matplotlib
        from matplotlib import collections, patches
        from matplotlib.figure import Figure
        from mpl_toolkits.mplot3d import art3d  # noqa: F401  (registers the "3d" projection)
    except ImportError:
        raise FoamError(MISSING_MATPLOTLIB) from None
    return matplotlib, Figure, patches, collections, art3d


_RC = {
    "font.size": 9,
    "axes.titlesize": 10,
    "axes.labelsize": 9,
    "legend.fontsize": 8,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "pdf.fonttype": 42,  # TrueType in PDFs (editable text, accepted by publishers)
    "svg.hashsalt": "foam-mj",  # reproducible SVG ids
    "savefig.dpi": DPI,
    "figure.constrained_layout.h_pad": 0.07,  # inches of margin around the figure's content
    "figure.constrained_layout.w_pad": 0.07,
}


# -- figures --------------------------------------------------------------------------------------------
def _save(fig, out_dir: Path, stem: str, formats: Sequence[str], dpi: int) -> list[Path]:
    written = []
    for fmt in formats:
        p = out_dir / f"{stem}.{fmt}"
        meta = {"Creator": "foam-mj"} if fmt == "png" else {"Creator": "foam-mj", "Date": None}
        with atomic_path(p) as tmp:  # complete or absent (foam_mj.atomic)
            fig.savefig(tmp, format=fmt, dpi=dpi, metadata=meta)  # constrained layout: nothing is cut off
        written.append(p)
    return written


def _set_box_aspect_equal(ax, points: np.ndarray) -> None:
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    pad = 0.04 * span.max()
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_zlim(lo[2] - pad, hi[2] + pad)
    ax.set_box_aspect(tuple(span + 2 * pad))
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(5))


def _fig_foam(mpl, doc, labels) -> Any | None:
    _, Figure, _, _, art3d = mpl
    foam, arrays = doc.get("foam"), foam_arrays(doc)
    if arrays is None:
        return None
    c, r = arrays
    q0, q1 = np.asarray(doc.get("q_init"), dtype=float), np.asarray(doc.get("q_goal"), dtype=float)
    fig = Figure(figsize=(6.4, 5.4), layout="constrained")
    if c.shape[1] == 1:
        from foam_mj.figures_1d import fig_foam_1d

        return fig_foam_1d(fig, c, r, q0, q1, labels[0])
    if c.shape[1] != 3:
        return _fig_foam_2d(mpl, fig, c, r, q0, q1, labels)
    ax = fig.add_subplot(projection="3d")
    parents = foam.get("parents")
    if parents is not None:
        par = np.asarray(parents, dtype=int)
        ok = (par >= 0) & (par < len(c))
        segs = np.stack([c[ok], c[par[ok]]], axis=1)
        ax.add_collection3d(art3d.Line3DCollection(segs, colors=[(0.3, 0.3, 0.3, 0.18)], linewidths=0.4))
    rmax = float(r.max()) if r.size else 1.0
    sc = ax.scatter(c[:, 0], c[:, 1], c[:, 2], s=2 + 40 * (r / rmax) ** 2, c=r, cmap="viridis", alpha=0.75,
                    linewidths=0, depthshade=False)
    ax.plot(*q0, **_START_STYLE, label=r"$q_{init}$")
    ax.plot(*q1, **_GOAL_STYLE, label=r"$q_{goal}$")
    cb = fig.colorbar(sc, ax=ax, shrink=0.6, pad=0.08)
    cb.set_label("bubble radius")
    for setter, lab in zip((ax.set_xlabel, ax.set_ylabel, ax.set_zlabel), labels):
        setter(lab)
    _set_box_aspect_equal(ax, np.vstack([c, q0, q1]))
    ax.view_init(elev=22, azim=-58)
    st = foam.get("stats") or {}
    extra = f" in {st['elapsed']:.2f} s" if isinstance(st.get("elapsed"), (int, float)) else ""
    ax.set_title(f"Probabilistic foam: {len(c)} bubbles{extra}")
    ax.legend(loc="upper left")
    return fig


def _fig_foam_2d(mpl, fig, c, r, q0, q1, labels):
    """Configuration spaces that are not 3-D: the first two coordinates."""
    _, _, patches, collections, _ = mpl
    ax = fig.add_subplot()
    circles = [patches.Circle(p[:2], rr) for p, rr in zip(c, r)]
    ax.add_collection(collections.PatchCollection(circles, facecolor=(0.2, 0.5, 0.8, 0.08), edgecolor=(0.2, 0.4, 0.7, 0.4), linewidth=0.4))
    ax.plot(*q0[:2], **_START_STYLE, label=r"$q_{init}$")
    ax.plot(*q1[:2], **_GOAL_STYLE, label=r"$q_{goal}$")
    ax.set_xlabel(labels[0])
    if len(labels) > 1:
        ax.set_ylabel(labels[1])
    ax.autoscale_view()
    ax.set_aspect("equal")
    ax.set_title(f"Probabilistic foam: {len(c)} bubbles")
    ax.legend()
    return fig


def _sphere_wires(centre: np.ndarray, radius: float) -> list[np.ndarray]:
    t = np.linspace(0.0, 2 * np.pi, 37)
    lines = []
    for lon in np.linspace(0.0, np.pi, 4, endpoint=False):  # meridians
        d = np.array([np.cos(lon), np.sin(lon), 0.0])
        lines.append(centre + radius * (np.outer(np.cos(t), d) + np.outer(np.sin(t), [0.0, 0.0, 1.0])))
    for lat in (-np.pi / 4, 0.0, np.pi / 4):  # parallels
        rr, z = radius * np.cos(lat), radius * np.sin(lat)
        lines.append(centre + np.column_stack([rr * np.cos(t), rr * np.sin(t), np.full_like(t, z)]))
    return lines


def _fig_rosary(mpl, doc, robot: RobotModel, paths: list[_Path], labels, rosary=None, title: str = "Rosary") -> Any | None:
    """The rosary's bubbles (when given) and the paths: 3-D and the three 2-D projections."""
    _, Figure, patches, collections, art3d = mpl
    cr, rr = rosary if rosary is not None else (np.zeros((0, robot.dim)), np.zeros(0))
    pts = [_config_points(p, robot) for p in paths]
    if not len(cr) and not pts:
        return None
    q0, q1 = np.asarray(doc.get("q_init"), dtype=float), np.asarray(doc.get("q_goal"), dtype=float)
    n = robot.dim
    if n == 1:  # one joint: the joint against the path parameter
        from foam_mj.figures_1d import fig_rosary_1d

        return fig_rosary_1d(Figure(figsize=(6.0, 5.0), layout="constrained"), cr, rr, paths, pts, q0, q1, labels[0], title)
    wire = (0.35, 0.35, 0.35, 0.35)
    if n == 3:
        fig = Figure(figsize=(10.0, 8.0), layout="constrained")
        ax = fig.add_subplot(2, 2, 1, projection="3d")
        lines = [ln for c, r in zip(cr, rr) for ln in _sphere_wires(c, r)]
        if lines:
            ax.add_collection3d(art3d.Line3DCollection(lines, colors=[wire], linewidths=0.5))
        for p, w in zip(paths, pts):
            ax.plot(w[:, 0], w[:, 1], w[:, 2], color=p.colour, linewidth=1.6, label=p.label)
        ax.plot(*q0, **_START_STYLE)
        ax.plot(*q1, **_GOAL_STYLE)
        allp = np.vstack([q0, q1] + pts + [cr + rr[:, None], cr - rr[:, None]] if len(cr) else [q0, q1] + pts)
        for setter, lab in zip((ax.set_xlabel, ax.set_ylabel, ax.set_zlabel), labels):
            setter(lab)
        _set_box_aspect_equal(ax, allp)
        ax.view_init(elev=22, azim=-58)
        ax.set_title(f"{title}: {len(cr)} bubbles" if len(cr) else title)
        pairs, slots = [(0, 1), (0, 2), (1, 2)], [2, 3, 4]
    else:
        fig = Figure(figsize=(6.0, 5.0), layout="constrained")
        pairs, slots = [(0, 1)], [1]
    axes2 = []
    for (a, b), slot in zip(pairs, slots):
        ax2 = fig.add_subplot(2, 2, slot) if n == 3 else fig.add_subplot()
        axes2.append(ax2)
        if len(cr):
            discs = [patches.Circle((c[a], c[b]), r) for c, r in zip(cr, rr)]
            ax2.add_collection(collections.PatchCollection(discs, facecolor=(0.5, 0.5, 0.5, 0.10), edgecolor=wire, linewidth=0.6))
        for p, w in zip(paths, pts):
            ax2.plot(w[:, a], w[:, b], color=p.colour, linewidth=1.4, label=p.label)
        ax2.plot(q0[a], q0[b], **_START_STYLE, label=r"$q_{init}$")
        ax2.plot(q1[a], q1[b], **_GOAL_STYLE, label=r"$q_{goal}$")
        ax2.set_xlabel(labels[a])
        if b < len(labels):
            ax2.set_ylabel(labels[b])
        ax2.autoscale_view()
        ax2.set_aspect("equal", adjustable="box")
        ax2.grid(True, linewidth=0.3, alpha=0.5)
    if axes2:
        handles, labs = axes2[0].get_legend_handles_labels()
        if n == 3:
            fig.legend(handles, labs, loc="outside lower center", ncol=min(3, len(labs)), frameon=False)
        else:
            axes2[0].legend()
            axes2[0].set_title(f"{title}: {len(cr)} bubbles" if len(cr) else title)
    return fig


def _strobe_limits(plane: str, robot_boxes: list[np.ndarray], obstacle_box: np.ndarray | None, floor_levels: list[float]):
    lo = np.min([b[0] for b in robot_boxes], axis=0)
    hi = np.max([b[1] for b in robot_boxes], axis=0)
    if plane == "xy" and obstacle_box is not None:  # a map: show all of it
        lo, hi = np.minimum(lo, obstacle_box[0]), np.maximum(hi, obstacle_box[1])
    elif obstacle_box is not None:  # a side view: the obstacles' tops and bottoms, where the robot is
        lo[1], hi[1] = min(lo[1], obstacle_box[0][1]), max(hi[1], obstacle_box[1][1])
    for z in floor_levels:
        lo[1] = min(lo[1], z)
    pad = 0.06 * float(np.max(hi - lo))
    return lo - pad, hi + pad


def _draw_obstacles(mpl, ax, shapes: list[Shape], lo=None, hi=None) -> None:
    _, _, patches, _, _ = mpl
    for s in shapes:
        if s.kind == "plane":
            a, b = s.outline
            ax.plot([a[0], b[0]], [a[1], b[1]], color="black", linewidth=1.4, zorder=1, solid_capstyle="butt")
            if lo is not None and abs(b[1] - a[1]) < 1e-12:  # hatch below a horizontal floor
                ax.add_patch(patches.Rectangle((lo[0] - 1, a[1] - 1), hi[0] - lo[0] + 2, 1, facecolor="none",
                                               edgecolor=(0.6, 0.6, 0.6), hatch="////", linewidth=0, zorder=0))
        else:
            ax.add_patch(patches.Polygon(s.outline, closed=True, facecolor=_OBSTACLE_FACE, edgecolor=_OBSTACLE_EDGE,
                                         linewidth=0.8, zorder=2))


def _fig_strobe(mpl, robot, paths: list[_Path], n_poses: int = N_POSES) -> Any | None:
    _, Figure, patches, _, _ = mpl
    if not paths:
        return None
    plane = _default_plane(robot)
    data = mujoco.MjData(robot.model)
    obstacles = _shapes(robot, data, robot.config.qpos0, plane, "obstacles")
    floors = [float(s.outline[0][1]) for s in obstacles if s.kind == "plane" and abs(s.outline[1][1] - s.outline[0][1]) < 1e-12]
    poses, traces, boxes = [], [], []
    # The trace follows the robot geom farthest down the kinematic chain (the foot for the leg).
    depth = lambda g: body_depth(robot.model, int(robot.model.geom_bodyid[g]))  # noqa: E731
    tip = max((int(g) for g in robot.robot_geoms), key=depth)
    for p in paths:
        rows = _sample_qpos(p, robot, n_poses)
        shp = [_shapes(robot, data, row, plane, "robot") for row in rows]
        poses.append(shp)
        boxes += [b for b in (_bounds(s) for s in shp) if b is not None]
        dense = _sample_qpos(p, robot, 200)
        trace = []
        for row in dense:
            data.qpos[:] = row
            mujoco.mj_kinematics(robot.model, data)
            trace.append(np.array(data.geom_xpos[tip])[list(_PLANES[plane])])
        traces.append(np.array(trace))
    lo, hi = _strobe_limits(plane, boxes, _bounds(obstacles), floors)
    ncol = min(len(paths), 4)
    nrow = int(np.ceil(len(paths) / ncol))
    w, h = hi - lo
    panel_w = 3.6 if plane == "xz" else 4.2
    timed = sum(p.times is not None for p in paths)
    how = ("at evenly spaced times" if timed == len(paths) else "evenly spaced by arc length in q" if timed == 0
           else "at evenly spaced times (untimed paths: by arc length in q)")
    view = "sagittal plane" if plane == "xz" else "top view"
    tip_body = int(robot.model.geom_bodyid[tip])
    tipname = mujoco.mj_id2name(robot.model, mujoco.mjtObj.mjOBJ_BODY, tip_body) or "end body"
    title = textwrap.fill(f"{n_poses} poses {how} ({view}); light = start, dark = goal; dashed: the {tipname} geom's centre",
                          int(13 * panel_w * ncol))
    # Room for the axes (equal aspect), the panel titles and axis labels, and the suptitle's lines.
    height = max(2.0, panel_w * h / w) * nrow + 0.45 * nrow + 0.18 * (title.count("\n") + 1)
    fig = Figure(figsize=(panel_w * ncol, height), layout="compressed")
    axes = fig.subplots(nrow, ncol, squeeze=False, sharex=True, sharey=True)
    for k, (p, shp, tr) in enumerate(zip(paths, poses, traces)):
        ax = axes[k // ncol][k % ncol]
        _draw_obstacles(mpl, ax, obstacles, lo, hi)
        edge = tuple(np.array(p.colour) * 0.75)
        for i, pose in enumerate(shp):
            f = i / max(1, len(shp) - 1)  # 0 at the start, 1 at the goal
            end = i in (0, len(shp) - 1)
            for s in pose:
                ax.add_patch(patches.Polygon(s.outline, closed=True, facecolor=(*p.colour, 0.05 + 0.25 * f),
                                             edgecolor=(*edge, 0.35 + 0.65 * f), linewidth=1.2 if end else 0.7, zorder=3 + i))
        ax.plot(tr[:, 0], tr[:, 1], color=p.colour, linewidth=1.0, linestyle="--", zorder=20)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        dur = f", {p.times[-1] - p.times[0]:.2f} s" if p.times is not None else ""
        ax.set_title(f"{p.label}{dur}", fontsize=9)
        if k + ncol >= len(paths):  # nothing below this panel
            ax.set_xlabel(f"{plane[0]} [m]")
            ax.xaxis.set_tick_params(labelbottom=True)
        if k % ncol == 0:
            ax.set_ylabel(f"{plane[1]} [m]")
        ax.grid(True, linewidth=0.3, alpha=0.4)
    for k in range(len(paths), nrow * ncol):
        axes[k // ncol][k % ncol].set_visible(False)
    fig.suptitle(title, fontsize=9)
    return fig


def _is_metaheuristic(p: _Path) -> bool:
    """A method minimising f (Nascimento et al. 2020 Eq. 5) step by step: HS, GA, the optimal smoother, or any path
    whose smoother says its objective is "f". Gradient descent of SV and the rosary adjustment (TC) are not."""
    if p.objective is not None:
        return p.objective == "f"
    return _ALIASES.get(p.name, p.name) not in _THESIS and p.name != "convex"


def _fig_convergence(mpl, paths: list[_Path]) -> Any | None:
    _, Figure, _, _, _ = mpl
    conv = [(p, p.convergence) for p in paths if p.convergence is not None and _is_metaheuristic(p)]
    if not conv:
        return None
    fig = Figure(figsize=(4.2 * len(conv), 3.2), layout="constrained")
    axes = fig.subplots(1, len(conv), squeeze=False)[0]
    for ax, (p, convergence) in zip(axes, conv):
        best = np.asarray(convergence["best"], dtype=float)
        it = np.arange(1, len(best) + 1)
        ax.plot(it, best, color=p.colour, linewidth=1.4, label="best")
        mean = convergence.get("mean")
        if mean is not None and len(mean) and not np.array_equal(np.asarray(mean, dtype=float), best):  # a population
            mean = np.asarray(mean, dtype=float)
            ax.plot(np.arange(1, len(mean) + 1), mean, color=p.colour, linewidth=1.0, linestyle="--", alpha=0.6, label="population mean")
        ax.set_xlabel("accepted step" if _ALIASES.get(p.name, p.name) == "optimal" else "iteration")
        ax.set_ylabel("$f$ (Nascimento et al. 2020, Eq. 5)")
        ax.set_title(f"{p.label}: best {best[-1]:.4g}", fontsize=9)
        ax.grid(True, linewidth=0.3, alpha=0.5)
        ax.legend()
    return fig


def _fig_joints(mpl, robot: RobotModel, paths: list[_Path]) -> Any | None:
    _, Figure, _, _, _ = mpl
    timed = [(p, p.times) for p in paths if p.times is not None]
    if not timed:
        return None
    cols = robot.config.qpos_index
    names = _joint_labels(robot)
    n = len(cols)
    fig = Figure(figsize=(8.0, 1.9 * n + 0.8), layout="constrained")
    axes = fig.subplots(n, 2, squeeze=False, sharex=True)
    for p, times in timed:
        t = times - times[0]
        pos = p.qpos[:, cols]
        vel = np.gradient(pos, times, axis=0) if len(t) > 2 else np.diff(pos, axis=0, prepend=pos[:1]) / max(t[-1], 1e-12)
        for i in range(n):
            axes[i][0].plot(t, pos[:, i], color=p.colour, linewidth=1.2, label=p.label)
            axes[i][1].plot(t, vel[:, i], color=p.colour, linewidth=1.2, label=p.label)
    for i, (nice, pu, vu) in enumerate(names):
        axes[i][0].set_ylabel(f"{nice}\n[{pu}]")
        axes[i][1].set_ylabel(f"velocity [{vu}]")
        for ax in axes[i]:
            ax.grid(True, linewidth=0.3, alpha=0.5)
    axes[0][0].set_title("joint position")
    axes[0][1].set_title("joint velocity (finite differences)")
    axes[-1][0].set_xlabel("time [s]")
    axes[-1][1].set_xlabel("time [s]")
    handles, labs = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labs, loc="outside lower center", ncol=min(3, len(labs)), frameon=False)
    return fig


def _fig_map(mpl, doc, robot: RobotModel, paths: list[_Path]) -> Any | None:
    """Planar mobile base: walls, the foam's (x, y) footprint, the rosary and the paths, from above."""
    _, Figure, patches, collections, _ = mpl
    body, (sx, sy) = base_xy(robot)
    cfg = robot.config
    data = mujoco.MjData(robot.model)
    walls = _shapes(robot, data, cfg.qpos0, "xy", "obstacles")
    foam, ros = doc.get("foam"), doc.get("rosary")
    q0, q1 = np.asarray(doc.get("q_init"), dtype=float), np.asarray(doc.get("q_goal"), dtype=float)
    start, goal = xy_of(robot, body, cfg.to_qpos(np.stack([q0, q1])))

    def discs(key_doc, face, edge, lw):
        if not key_doc or not key_doc.get("centers"):
            return None, np.zeros((0, 2))
        c = np.asarray(key_doc["centers"], dtype=float)
        r = np.asarray(key_doc["radii"], dtype=float)
        xy = xy_of(robot, body, cfg.to_qpos(c))
        ps = [patches.Ellipse(p, 2 * rr * sx, 2 * rr * sy) for p, rr in zip(xy, r)]
        ext = np.vstack([xy - np.column_stack([r * sx, r * sy]), xy + np.column_stack([r * sx, r * sy])])
        return collections.PatchCollection(ps, facecolor=face, edgecolor=edge, linewidth=lw), ext

    panels = [("foam", f"foam footprint ({len(foam['radii'])} bubbles)" if foam and foam.get("radii") else None),
              ("rosary", "rosary and paths")]
    panels = [pn for pn in panels if pn[1] is not None]
    wall_box = _bounds(walls)
    fig = Figure(figsize=(5.2 * len(panels), 5.0), layout="constrained")
    axes = fig.subplots(1, len(panels), squeeze=False, sharex=True, sharey=True)[0]
    ext_all = [start[None], goal[None]] + ([wall_box] if wall_box is not None else [])
    for ax, (what, title) in zip(axes, panels):
        _draw_obstacles(mpl, ax, walls)
        if what == "foam":
            coll, ext = discs(foam, (0.2, 0.5, 0.8, 0.08), (0.2, 0.4, 0.7, 0.35), 0.3)
        else:
            coll, ext = discs(ros, (0.5, 0.5, 0.5, 0.15), (0.3, 0.3, 0.3, 0.7), 0.6)
            for p in paths:
                xy = xy_of(robot, body, p.qpos if p.waypoints is None else cfg.to_qpos(p.waypoints))
                ax.plot(xy[:, 0], xy[:, 1], color=p.colour, linewidth=1.5, label=p.label, zorder=5)
        if coll is not None:
            ax.add_collection(coll)
        ext_all.append(ext)
        ax.plot(*start, **_START_STYLE, label=r"$q_{init}$", zorder=6)
        ax.plot(*goal, **_GOAL_STYLE, label=r"$q_{goal}$", zorder=6)
        ax.set_title(title)
        ax.set_xlabel("x [m]")
        ax.grid(True, linewidth=0.3, alpha=0.4)
    axes[0].set_ylabel("y [m]")
    pts = np.vstack([e for e in ext_all if len(e)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.03 * float(np.max(hi - lo))
    for ax in axes:
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
    handles, labs = axes[-1].get_legend_handles_labels()
    fig.legend(handles, labs, loc="outside lower center", ncol=min(4, len(labs)), frameon=False)
    return fig


# -- the entry point ---------------------------------------------------------------------------------------
def write_figures(doc, out_dir, formats: Sequence[str] = ("png",), paths: Sequence[str] | None = None,
                  dpi: int = DPI) -> list[Path]:
    """Write every figure the result supports into ``out_dir`` (created if missing) and return the
    files written, in order: foam, rosary, strobe, convergence, joints, map (see the module docstring;
    a figure whose data is absent is skipped). ``doc`` is the JSON result as a dict (or a path to it);
    ``formats`` any of "png", "svg", "pdf"; ``paths`` the names of the paths to draw (default: all).

    Raises :class:`~foam_mj.errors.FoamError` when matplotlib is missing, the document is malformed, a
    format or path name is unknown, or the folder cannot be written."""
    if not (isinstance(dpi, (int, np.integer)) and not isinstance(dpi, bool) and FIGURE_MIN_DPI <= dpi <= FIGURE_MAX_DPI):
        # NaN, inf, 1.5 or True reached matplotlib: a ValueError, an OverflowError, FreeType's "invalid ppem value"
        raise FoamError(f"`dpi` (--dpi) must be an integer in [{FIGURE_MIN_DPI}, {FIGURE_MAX_DPI}], got {dpi!r}")
    if isinstance(paths, str):  # one name, not its letters
        paths = (paths,)
    mpl = _matplotlib()
    formats = tuple(formats) if not isinstance(formats, str) else (formats,)
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise FoamError(f"unknown figure format(s) {bad}: choose from {list(FORMATS)}")
    doc = _as_doc(doc)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise FoamError(f"figure folder {out} is a file")
    robot = RobotModel.from_xml(doc["mjcf"])
    sel = _read_paths(doc, robot, paths)   # an unknown path name is refused before the folder is made
    foam_arrays(doc)  # and a foam or a rosary of numbers that cannot be drawn
    groups = _rosary_groups(doc, sel)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise FoamError(f"cannot create figure folder {out}: {exc}") from None
    labels = _coord_labels(robot)
    matplotlib = mpl[0]
    written: list[Path] = []
    with matplotlib.rc_context(_RC):
        makers = [
            ("foam", lambda: _fig_foam(mpl, doc, labels)),
            *[(stem, lambda t=title, r=ros, ps=ps: _fig_rosary(mpl, doc, robot, ps, labels, r, t))
              for stem, title, ros, ps in groups],
            # Every path together (Nascimento and Alsina 2021 Fig. 8d), when they lie in different rosaries.
            ("paths", lambda: _fig_rosary(mpl, doc, robot, sel, labels, None, "Paths") if len(groups) > 1 and groups[0][0] == "rosary" and len(sel) > 1 else None),
            ("strobe", lambda: _fig_strobe(mpl, robot, sel)),
            ("convergence", lambda: _fig_convergence(mpl, sel)),
            ("joints", lambda: _fig_joints(mpl, robot, sel)),
        ]
        if has_xy_base(robot):
            makers.append(("map", lambda: _fig_map(mpl, doc, robot, sel)))
        for stem, make in makers:
            fig = make()
            if fig is None:
                continue
            try:
                written += _save(fig, out, stem, formats, dpi)
            except OSError as exc:
                raise FoamError(f"cannot write figure {stem} into {out}: {exc}") from None
    return written


# -- command line --------------------------------------------------------------------------------------------
def cmd_figures(args: argparse.Namespace) -> int:
    """Run the ``figures`` command; raises FoamError for bad input (the CLI turns it into exit code 2)."""
    from foam_mj.results import read_result, resolve_model

    from foam_mj.atomic import check_output_dir

    if not FIGURE_MIN_DPI <= args.dpi <= FIGURE_MAX_DPI:  # before the folder is made (write_figures checks it too)
        raise FoamError(f"--dpi must be in [{FIGURE_MIN_DPI}, {FIGURE_MAX_DPI}], got {args.dpi}")
    check_output_dir(args.out_dir, "DIR")
    doc = read_result(args.result)
    # the scene as replay finds it: "mjcf_relative" (a result moved with its models) or "mjcf", checked against the
    # result's model_hash (a result naming another scene drew its strobe over that scene's obstacles)
    doc["mjcf"] = str(resolve_model(doc, args.result))
    written = write_figures(doc, args.out_dir, formats=args.formats, paths=args.paths, dpi=args.dpi)
    for p in written:
        print(f"wrote {p}")
    note = stale_figures_note(args.out_dir, written)  # an earlier run's figures, shown beside these without a word
    if note:
        print(note)
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m foam_mj.figures RESULT.json DIR [--format ...]``: exit 0, or 2 with a one-line error."""
    from foam_mj.arguments import Parser, UsageError

    parser = Parser(prog="foam-mj")
    add_figures_parser(parser.add_subparsers(dest="command", required=True, parser_class=Parser))
    try:
        args = parser.parse_args(["figures", *(sys.argv[1:] if argv is None else argv)])
    except UsageError as exc:  # one line, as from `foam-mj figures`
        print(exc, file=sys.stderr)
        return 2
    try:
        return args.func(args)
    except FoamError as exc:
        print(f"foam-mj: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
