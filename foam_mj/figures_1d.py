"""The foam and rosary figures of a one-joint robot (:mod:`foam_mj.figures`): its configuration space is a line, so a
bubble is an interval of the joint. Drawn on a plane's x axis with y = 0, both figures had an empty y axis."""

from __future__ import annotations

from typing import Any

import numpy as np

from foam_mj.figure_data import _GOAL_STYLE, _START_STYLE, _Path


def path_parameter(q: np.ndarray) -> np.ndarray:
    """The path parameter s in [0, 1] of the points q (m, 1): the fraction of the path's length (in the joint's units)
    travelled at each point; evenly spaced when the path does not move."""
    step = np.abs(np.diff(q[:, 0]))
    s = np.concatenate([[0.0], np.cumsum(step)])
    return s / s[-1] if s[-1] > 0 else np.linspace(0.0, 1.0, len(q))


def fig_foam_1d(fig, c: np.ndarray, r: np.ndarray, q0: np.ndarray, q1: np.ndarray, label: str) -> Any:
    """Every bubble as its interval of the joint [c - r, c + r], at the height of its radius."""
    ax = fig.add_subplot()
    ax.hlines(r, c[:, 0] - r, c[:, 0] + r, colors=[(0.2, 0.4, 0.7, 0.5)], linewidth=1.0)
    ax.plot(c[:, 0], r, "o", color=(0.2, 0.4, 0.7), markersize=2)
    ax.plot(q0[0], 0.0, **_START_STYLE, label=r"$q_{init}$")
    ax.plot(q1[0], 0.0, **_GOAL_STYLE, label=r"$q_{goal}$")
    ax.set_xlabel(label)
    ax.set_ylabel("bubble radius (its interval of the joint: the bar)")
    ax.set_ylim(bottom=-0.05 * max(float(r.max()) if r.size else 1.0, 1e-9))
    ax.grid(True, linewidth=0.3, alpha=0.5)
    ax.set_title(f"Probabilistic foam: {len(c)} bubbles")
    ax.legend()
    return fig


def fig_rosary_1d(fig, cr: np.ndarray, rr: np.ndarray, paths: list[_Path], pts: list[np.ndarray], q0: np.ndarray,
                  q1: np.ndarray, label: str, title: str) -> Any:
    """The joint (y) against the path parameter s (x, :func:`path_parameter`): each path from q_init at s = 0 to q_goal
    at s = 1, the rosary's bubbles as bands of the joint."""
    ax = fig.add_subplot()
    for c, r in zip(cr[:, 0] if len(cr) else [], rr):
        ax.axhspan(c - r, c + r, facecolor=(0.5, 0.5, 0.5, 0.10), edgecolor=(0.35, 0.35, 0.35, 0.35), linewidth=0.6)
    for p, w in zip(paths, pts):
        ax.plot(path_parameter(w), w[:, 0], color=p.colour, linewidth=1.4, label=p.label)
    ax.plot(0.0, q0[0], **_START_STYLE, label=r"$q_{init}$")
    ax.plot(1.0, q1[0], **_GOAL_STYLE, label=r"$q_{goal}$")
    ax.set_xlabel("path parameter s (fraction of the path's length)")
    ax.set_ylabel(label)
    ax.set_xlim(-0.05, 1.05)
    ax.grid(True, linewidth=0.3, alpha=0.5)
    ax.set_title(f"{title}: {len(cr)} bubbles" if len(cr) else title)
    ax.legend()
    return fig
