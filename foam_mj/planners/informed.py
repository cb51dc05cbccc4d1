"""Informed samples: uniform in the set of points through which a shorter path can pass (Gammell, Srinivasa
and Barfoot, "Informed RRT*: Optimal sampling-based path planning focused via direct sampling of an admissible
ellipsoidal heuristic", IROS 2014), for ``bubbletree``'s exploration after its first path."""

from __future__ import annotations

import numpy as np


class InformedSampler:
    """Uniform samples of the prolate hyperspheroid {x : |S(x - q0)| + |S(x - q1)| <= c_best} (Gammell,
    Srinivasa and Barfoot, "Informed RRT*", IROS 2014, Eq. 8-10; S = diag(metric), default identity):
    the only points through which a path shorter than c_best (in that metric) can pass. The rotation and
    the axes are computed once; :meth:`sample` draws."""

    def __init__(self, q0: np.ndarray, q1: np.ndarray, c_best: float, metric: np.ndarray | None = None) -> None:
        self.scale = None if metric is None else np.asarray(metric, dtype=float)
        if self.scale is not None:
            q0, q1 = q0 * self.scale, q1 * self.scale
        n = self.n = len(q0)
        c_min = float(np.linalg.norm(q1 - q0))
        c_best = max(c_best, c_min * (1 + 1e-9))
        self.radii = np.full(n, np.sqrt(c_best**2 - c_min**2) / 2)
        self.radii[0] = c_best / 2
        a1 = (q1 - q0) / max(c_min, 1e-300)
        # An orthonormal basis whose first vector is a1 (Householder reflection of e1 onto a1).
        e1 = np.zeros(n)
        e1[0] = 1.0
        v = e1 - a1
        nv = float(v @ v)
        self.HT = (np.eye(n) - 2.0 * np.outer(v, v) / nv if nv > 1e-24 else np.eye(n)).T
        self.centre = 0.5 * (q0 + q1)

    def sample(self, rng: np.random.Generator, m: int) -> np.ndarray:
        x = rng.standard_normal((m, self.n))
        x *= (rng.random(m) ** (1.0 / self.n) / np.sqrt(np.add.reduce(x * x, axis=1)))[:, None]  # uniform in the unit ball
        X = self.centre + (x * self.radii) @ self.HT
        return X if self.scale is None else X / self.scale


def informed_samples(
    rng: np.random.Generator, m: int, q0: np.ndarray, q1: np.ndarray, c_best: float, metric: np.ndarray | None = None
) -> np.ndarray:
    """m samples of :class:`InformedSampler` (q0, q1, c_best, metric)."""
    return InformedSampler(q0, q1, c_best, metric).sample(rng, m)
