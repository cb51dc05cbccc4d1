"""Tests for foam_mj.smoothing.collapse: straight runs on their chords, and the closed-form multipliers of their vertices."""

from __future__ import annotations

import numpy as np
import pytest

from foam_mj.planners.base import smoother_start
from foam_mj.smoothing import Hatches, collapse, scp, subproblem
from foam_mj.smoothing.objective import ObjectiveWeights, tie_mask
from foam_mj.smoothing.optimal import OptimalSmoother
from test_optimal import _bubbletree_corridor

F = ObjectiveWeights.named("f")


def _lagrangian_gradient(p: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Gradient of L + sum_i y_i . v_i at every point of p (y (vertices, n), the multiplier of vertex i on point i + 1)."""
    vx = subproblem._vertex_data(p, np.zeros(len(p) - 1, dtype=bool))
    u = (p[1:] - p[:-1]) / np.linalg.norm(p[1:] - p[:-1], axis=1)[:, None]
    grad = np.zeros_like(p)
    grad[:-1] -= u
    grad[1:] += u
    for j in range(3):
        grad[j:j + len(y)] += np.einsum("ide,id->ie", vx.J[:, j], y)
    return grad


def test_closed_form_multipliers_balance_a_straight_run_between_two_corners():
    # q_init, a right-angle corner A, four points on the segment A -> B (unevenly spaced), a corner B, q_goal:
    # the straight vertices' multipliers P ((1 - tau) y_A + tau y_B) make the Lagrangian's gradient vanish at every
    # point of the run, and each has |g| <= 1; the run's first end's multiplier alone (a constant y) does not.
    p = np.array([[0, 0, 0], [1, 0, 0], [1, 0.3, 0], [1, 0.5, 0], [1, 1.2, 0], [1, 1.9, 0], [1, 2, 0], [2, 2.5, 1.0]])
    m = len(p) - 2
    vx = subproblem._vertex_data(p, np.zeros(len(p) - 1, dtype=bool))
    cp = collapse.plan(p, vx, np.ones((m, 2)), 1e-5)
    assert cp.interior.tolist() == [False, False, True, True, True, True, False, False]
    y = np.zeros((m, 3))
    bent = vx.s0 >= 1e-3
    y[bent] = (F.angle * subproblem._dh(vx.s0[bent]) / m / vx.s0[bent])[:, None] * vx.v[bent]
    y[cp.interior[1:-1]] = collapse.run_multipliers(cp, cp.Qc, np.zeros((len(cp.Qc) - 2, 3)), F, m)
    run = np.flatnonzero(cp.interior)
    assert np.abs(_lagrangian_gradient(p, y)[run]).max() < 1e-12
    assert np.linalg.norm(y[cp.interior[1:-1]], axis=1).max() * m / F.angle <= 1.0 + 1e-12
    y[cp.interior[1:-1]] = y[0]
    assert np.abs(_lagrangian_gradient(p, y)[run]).max() > 1e-2


@pytest.fixture(scope="module")
def corridor():
    return _bubbletree_corridor("obstacle")


def test_a_collapsed_subproblem_expands_inside_the_hatches_with_its_runs_straight(corridor):
    # The first subproblem of bubbletree's obstacle corridor (seed 0) from the planner's waypoints: 82 of its 87 vertices
    # are straight; collapsed, the subproblem has less than a third of the full one's rows (204 of 860), and its solution, expanded,
    # puts every waypoint inside its hatch (shrunk by half the inset) and every collapsed point on its chord.
    ros, inset = corridor.rosary, 1e-6
    h = Hatches.of(ros)
    p = ros.path(smoother_start(ros, corridor.waypoints))
    vx = subproblem._vertex_data(p, tie_mask(p, h, inset / 2))
    slack = np.stack([h.ra, h.rb], axis=1) - inset - h.centre_distances(p[1:-1])
    st = subproblem._structure(ros, inset)
    cp = collapse.plan(p, vx, slack, 1e-5)
    near = slack <= scp.NEAR * np.sqrt(3) * 0.005 + 2e-5  # the balls the SCP puts in its first solve
    P, q, A, b, cones, _ = collapse.subproblem(cp, st, p, F, None, near, subproblem.PROX)
    sol = subproblem._Solver(False).solve(P, q, A, b, cones)
    assert str(sol.status).endswith("Solved")
    full = subproblem._subproblem(st, p, F, 0.05, vx, keep=near, trust=False)[2]
    assert A.shape[0] < full.shape[0] / 3
    Qn, W = collapse.expand(np.asarray(sol.x), cp)
    assert np.all(h.inside(W, inset / 2))
    new = ros.path(W)
    vn = subproblem._vertex_data(new[vx.D], np.zeros(len(vx.D) - 1, dtype=bool))
    assert vn.s0[cp.interior[1:-1]].max() < 1e-9


@pytest.mark.parametrize("seed", [0, 2])
def test_collapsing_straight_runs_reaches_the_same_certified_optimum_with_fewer_rows(monkeypatch, seed):
    # bubbletree's obstacle corridors (seeds 0, 2), smoothed as foam-mj plan does, with and without the collapse: F the
    # same to 1e-7 of itself (measured 5e-8 and 2e-8), both certified, and the collapsed run's subproblems have fewer
    # rows in all (measured 192 instead of 1612, 996 instead of 1708).
    res = _bubbletree_corridor("obstacle", seed)
    start = smoother_start(res.rosary, res.waypoints)
    rows = []
    solve = subproblem._Solver.solve

    def recorded(self, P, q, A, *args, **kwargs):
        rows.append(A.shape[0])
        return solve(self, P, q, A, *args, **kwargs)

    monkeypatch.setattr(subproblem._Solver, "solve", recorded)
    out = {}
    for on in (False, True):
        monkeypatch.setattr(scp, "COLLAPSE", on)
        rows.clear()
        r = OptimalSmoother().smooth(res.rosary, initial=start, seed=seed)
        out[on] = (r.info["objective_value"], r.info["certified"], sum(rows))
    assert out[False][1] and out[True][1]
    assert out[True][0] == pytest.approx(out[False][0], rel=1e-7)
    assert out[True][2] < 0.7 * out[False][2]
