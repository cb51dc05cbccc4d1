"""Path and smoother names: what ``--smoother`` (and a sweep's ``smoothers``) accepts, the paths each adds and
their labels. The standard library only: a bad ``--smoother`` or sweep file is refused before :mod:`foam_mj.pipeline`
(the smoothers, scipy, Clarabel, toppra) is imported; the pipeline re-exports every name."""

from __future__ import annotations

from foam_mj.errors import FoamError, unknown_names

#: Smoother names accepted by ``--smoother`` and what each adds to the centre path.
SMOOTHERS: dict[str, tuple[str, ...]] = {
    "none": (),
    "hs": ("hs",),
    "ga": ("ga",),
    "gradient": ("gradient",),
    "adjust": ("adjusted", "adjusted_gradient"),
    "convex": ("convex",),
    "optimal": ("optimal",),
    "mgoa": ("mgoa",),
    "mopso": ("mopso",),
}
SMOOTHERS["all"] = tuple(p for k in ("gradient", "adjust", "hs", "ga", "convex", "optimal") for p in SMOOTHERS[k])
#: Every path name: the centre path (always there) and those the smoothers produce.
PATH_NAMES: tuple[str, ...] = tuple(dict.fromkeys(("centre",) + tuple(p for paths in SMOOTHERS.values() for p in paths)))
#: What ``foam-mj plan`` runs when no smoother is named: the certified optimum of f, the best f of all the
#: methods that keep the planner's rosary (the adjusted rosary's T_RCA can end lower) and among the fastest
#: (benchmarks/smoothing.py).
DEFAULT_SMOOTHER = "optimal"

LABELS = {
    "centre": "centre (T)",
    "gradient": "gradient (T_CA)",
    "adjusted": "adjusted (T_RA)",
    "adjusted_gradient": "adjusted+gradient (T_RCA)",
    "hs": "harmony search",
    "ga": "genetic algorithm",
    "convex": "convex shortest",
    "optimal": "optimal (certified f)",
    "mgoa": "MGOA (Pareto knee)",
    "mopso": "MOPSO (Pareto knee)",
}


def parse_smoothers(spec: str) -> tuple[str, ...]:
    """Path names for a ``--smoother`` value: one name of :data:`SMOOTHERS` or a comma-separated list."""
    names: list[str] = []
    parts = spec.split(",")
    if len(parts) > 1 and "none" in (part.strip() for part in parts):  # "all,none" ran every smoother, "none,convex" one
        raise FoamError(f"'none' (no smoother) cannot be combined with other smoothers in '{spec}'; give it alone")
    for part in parts:
        part = part.strip()
        if not part:
            raise FoamError(f"an empty smoother name in '{spec}' (a stray comma?); choose from {', '.join(SMOOTHERS)} "
                            "(or a comma-separated list)")
        if part not in SMOOTHERS:
            raise FoamError(f"unknown smoother {unknown_names([part], SMOOTHERS)}; choose from {', '.join(SMOOTHERS)} (or a comma-separated list)")
        names += [p for p in SMOOTHERS[part] if p not in names]
    return tuple(names)
