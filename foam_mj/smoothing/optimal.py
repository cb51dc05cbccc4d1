"""The best path inside the rosary: a certified local optimum of the papers' objectives.

    minimise   F(W) = w_len * L + w_angle * mean_i phi_i + w_sv * mean_i phi_i^2
    subject to |w_i - c_i| <= r_i - inset,  |w_i - c_(i+1)| <= r_(i+1) - inset     (w_i in hatch i)

over the waypoints W = (q'_1 .. q'_(k-1)) of Nascimento et al. 2020 Eq. 3 on the path [q_init, W, q_goal]; phi_i is
the supplementary angle pi - theta_i of Eq. 4 at the k-1 interior vertices, L the length. Weights
(1, 1, 0) give f of Nascimento et al. 2020 Eq. 5, (0, 0, 1) SV of Nascimento and Alsina 2021 Eq. 7 (with the same vertex count),
(1, 0, 0) the length; any non-negative weights give the user's trade-off.

The method, sequential convex programming with a composite model, its curvature, ties and speed: see
:mod:`foam_mj.smoothing.scp`.

Certificate: :func:`foam_mj.smoothing.certificate.kkt_certificate` checks first-order optimality of the
true objective (its module docstring); during the SCP the last subproblem's duals are tried first as its multipliers
(at the points a subproblem kept on a straight run's chord, their closed form: :mod:`foam_mj.smoothing.collapse`).

Strictly inside: the balls are shrunk by ``inset`` (1e-6; less in a hatch too thin for it,
:meth:`~foam_mj.smoothing.base.Hatches.fitting_inset`); each accepted step is projected onto the
shrunk hatches (a no-op up to the solver's 1e-9 feasibility) before ties are snapped, and the returned
waypoints are checked to be at least inset/2 inside both balls.

"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from foam_mj.rosary import Rosary
from foam_mj.smoothing.base import (
    Hatches,
    SeedLike,
    Smoother,
    SmoothingResult,
    _check_positive,
    check_initial,
    check_rosary,
    check_rosary_type,
    seeded,
    trivial_result,
)
from foam_mj.smoothing.certificate import KKT_TOL, Certificate, kkt_certificate
from foam_mj.smoothing.convex import ConvexShortestPath
from foam_mj.smoothing.objective import ObjectiveWeights, objective_value
from foam_mj.smoothing.scp import POLISH_TOL, sequential_convex
from foam_mj.smoothing.subproblem import _shortest_start, _structure

# -- the smoother -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class StartOutcome:
    """One start of the multistart: where it began, F it reached, its certificate and SCP trace."""

    label: str
    value: float
    certificate: Certificate
    iterations: int
    stop_reason: str

    def as_dict(self) -> dict:
        return {"start": self.label, "value": self.value, "iterations": self.iterations,
                "stop_reason": self.stop_reason, "certified_stationarity": self.certificate.stationarity}


@dataclass(frozen=True)
class OptimalSmoother(Smoother):
    """Minimise f (or SV, or a weighted objective) over the hatches to a certified local optimum.

    ``objective`` names a preset ("f": Nascimento et al. 2020 Eq. 5, "sv": Nascimento and Alsina 2021 Eq. 7, "length") unless
    ``weights`` is given. The first start is ``initial`` when given (e.g. an HS or GA result; a stack
    (S, k-1, n) gives S starts), else the
    convex reference's shortest path (for objectives with an SV term, also the midpoint of that path
    and the hatch centres, whose close vertices can split corners); ``multistart`` more starts are random hatch points (from ``seed``); while no
    best result is not certified, up to ``restarts`` more random starts are tried. The lowest objective
    value is returned, certified or not (``info["certified"]`` and ``stop_reason`` say which). ``max_iter`` caps the
    sequential convex iterations of each start, not of all starts together (the total grows with the starts). ``info`` holds
    the objective value, the certificate of the returned waypoints (``kkt_stationarity``,
    ``kkt_complementarity``, ``certified``), and every start's outcome.
    """

    objective: str = "f"
    weights: ObjectiveWeights | None = None
    inset: float = 1e-6
    multistart: int = 0
    restarts: int = 3
    max_iter: int = 100
    kkt_tol: float = KKT_TOL

    name: ClassVar[str] = "optimal"

    def __post_init__(self) -> None:
        if self.weights is None:
            ObjectiveWeights.named(self.objective)  # validates the name
        elif not isinstance(self.weights, ObjectiveWeights):
            raise TypeError(f"weights must be an ObjectiveWeights, got {type(self.weights).__name__}")
        _check_positive("inset", self.inset)
        _check_positive("kkt_tol", self.kkt_tol)
        for name, low in (("multistart", 0), ("restarts", 0), ("max_iter", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")

    @property
    def resolved_weights(self) -> ObjectiveWeights:
        return self.weights if self.weights is not None else ObjectiveWeights.named(self.objective)

    @property
    def method(self) -> str:
        name = self.resolved_weights.name
        return "optimal" if name == "f" else f"optimal-{name}"

    def smooth(self, rosary: Rosary, initial: np.ndarray | None = None, seed: SeedLike = 0) -> SmoothingResult:
        t_start = time.perf_counter()
        check_rosary_type(rosary)
        weights = self.resolved_weights
        given = None
        if initial is not None:
            try:
                arr = np.asarray(initial, dtype=float)
            except (TypeError, ValueError):
                raise TypeError(f"initial waypoints must be an array of numbers, shape ({rosary.n_hatches}, {rosary.dim}) or "
                                f"(starts, {rosary.n_hatches}, {rosary.dim}), got {initial!r:.80}") from None
            # One set of waypoints (k-1, n), or a stack of them (S, k-1, n): several starts (e.g. HS and GA results).
            stack = arr[None] if arr.ndim == 2 else arr
            if arr.ndim not in (2, 3) or len(stack) == 0:
                raise ValueError(f"initial waypoints must have shape ({rosary.n_hatches}, {rosary.dim}) or "
                                 f"(starts, {rosary.n_hatches}, {rosary.dim}), got {arr.shape}")
            given = [check_initial(rosary, w) for w in stack]
        if rosary.n_hatches == 0:
            return trivial_result(self.method, rosary, t_start, objective=weights.name)
        check_rosary(rosary)
        h = Hatches.of(rosary)
        inset = h.fitting_inset(self.inset)
        rng, used = seeded(seed)
        starts: list[tuple[str, np.ndarray]] = []
        if given is not None:
            starts += [("initial" if len(given) == 1 else f"initial {j}", h.project(w, inset)) for j, w in enumerate(given)]
        elif weights.sv == 0 and weights.angle > 0:  # (for the length alone, the convex program is the answer)
            convex, st = _shortest_start(rosary, h, inset)
            starts.append(("convex", convex))
        else:
            convex = np.array(ConvexShortestPath(inset=inset).smooth(rosary).waypoints)
            starts.append(("convex", convex))
            if weights.sv > 0:  # SV splits corners: also start between the shortest path and the hatch centres
                centres = h.project(rosary.center_waypoints(), inset)
                starts.append(("convex/centre", 0.5 * (convex + centres)))
        for j in range(self.multistart):
            starts.append((f"random {j}", h.project(h.sample(rng, np.arange(h.m)), inset)))
        if given is not None or weights.sv > 0 or weights.angle == 0:
            st = _structure(rosary, inset)
        best = None
        outcomes: list[StartOutcome] = []
        iterations = 0
        def run(label: str, w0: np.ndarray) -> None:
            nonlocal best, iterations
            checked: dict = {}

            def certify(wc: np.ndarray, multipliers: tuple | None = None, solve: bool = True) -> Certificate:
                # The same point asked again (the curvature model hands a point certified but not polished to the
                # plain model, whose first prediction may ask at once): the last answer, when it was final (solved,
                # or certified by its guess) is this one.
                if solve and checked.get("final") and np.array_equal(checked["w"], wc):
                    return checked["cert"]
                checked["w"], checked["cert"] = wc.copy(), kkt_certificate(rosary, wc, weights, inset, multipliers,
                                                                            self.kkt_tol, solve, POLISH_TOL)
                checked["final"] = solve or checked["cert"].certified(POLISH_TOL)
                return checked["cert"]

            # With the curvature model first; a start it leaves uncertified is run again without it (the plain
            # SCP, slower but never misled by a clipped curvature).
            for curvature in (True, False) if weights.sv == 0 and weights.angle > 0 else (False,):
                w, trace = sequential_convex(rosary, h, w0, weights, inset, max_iter=self.max_iter, structure=st,
                                             certify=certify if weights.sv == 0 else None,  # SV's optimum is flat: polish it
                                             kkt_tol=self.kkt_tol, curvature=curvature)
                iterations += trace.iterations
                value = objective_value(rosary.path(w), weights)
                if "w" in checked and np.array_equal(checked["w"], w):
                    cert = checked["cert"]
                else:
                    cert = kkt_certificate(rosary, w, weights, inset)
                outcomes.append(StartOutcome(label if curvature or len(outcomes) == 0 or outcomes[-1].label != label
                                             else f"{label} (plain)", value, cert, trace.iterations, trace.stop_reason))
                key = (value, not cert.certified(self.kkt_tol))
                if best is None or key < best[0]:
                    best = (key, w, trace, cert, value, outcomes[-1].label)
                if cert.certified(self.kkt_tol):
                    break

        for label, w0 in starts:
            run(label, w0)
        assert best is not None  # (there is a start)
        for j in range(self.restarts):  # only while the best is not certified
            if not best[0][1]:
                break
            run(f"restart {j}", h.project(h.sample(rng, np.arange(h.m)), inset))
        _, w, trace, cert, value, label = best
        if not np.all(h.inside(w, inset / 2)):  # pragma: no cover - guaranteed by the projection
            raise RuntimeError("optimal smoother: a waypoint is not strictly inside its hatch")
        certified = cert.certified(self.kkt_tol)
        return SmoothingResult.build(
            self.method,
            rosary,
            w,
            history_best=np.array(trace.values),
            iterations=iterations,
            evaluations=iterations + len(starts),
            wall_time=time.perf_counter() - t_start,
            stop_reason="certified local optimum" if certified else f"not certified ({trace.stop_reason})",
            objective=weights.name,
            info={
                "objective_value": value,
                "weights": weights.as_tuple,
                "certified": certified,
                "kkt_tol": self.kkt_tol,
                **cert.as_dict(),
                "best_start": label,
                "starts": [o.as_dict() for o in outcomes],
                "inset": inset,
                "seed": used,
            },
        )
