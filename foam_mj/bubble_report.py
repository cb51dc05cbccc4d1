"""Look inside one bubble: what sets the certified radius at a configuration (``foam-mj bubble``).

For a configuration q the report holds the clearance d(q) = min_p d_p(q) and its pair, every checked
pair's distance d_p, bound rho_p (per coordinate) and term (d_p - delta) / ||rho_p||_2, the pair whose
term is smallest (it sets the radius, :mod:`foam_mj.bubbles`), the distance to the joint bounds, and the
radius. It makes the bound checkable from outside: move any coordinate set by at most the radius and
no pair's distance drops below delta.

JSON (``format`` "foam-mj/bubble", version 1)::

    {"format": "foam-mj/bubble", "version": 1, "mjcf": "/abs/scene.xml", "joints": [...], "q": [...],
     "delta": 0.005, "clearance": 0.1103, "closest_pair": ["foot_collision", "obstacle_box"],
     "radius": 0.0878, "limiting_pair": [...], "rho": [...], "rho_norm": 1.1998, "to_bounds": 0.3,
     "pairs": [{"geoms": [a, b], "self": false, "distance": d_p, "rho": [...], "rho_norm": ..., "radius": term}, ...],
     "fixed_pairs": [[a, b], ...], "fixed_distances": [{"geoms": [robot geom, obstacle], "distance": d}, ...],
     "labels": {"geom11": "geom11 (on body forearm_link)"}}

``rho`` is the limiting pair's rho_p in metres per unit of each coordinate (radians or the coordinate's
normalized unit); ``fixed_pairs`` are the pairs no coordinate can change (left out of the bound), ``fixed_distances``
the robot/obstacle ones with their distance (not in ``clearance``); ``labels`` names
the body of each unnamed geom (``geom<i>``) of the closest and limiting pairs, as the printed lines do.
"""

from __future__ import annotations

from numpy.typing import ArrayLike

from foam_mj.bubbles import BubbleOracle
from foam_mj.model import RobotModel

FORMAT = "foam-mj/bubble"
VERSION = 1


def bubble_report(robot: RobotModel, q: ArrayLike, delta: float = 0.005, name: str = "q") -> dict:
    """The report at q (validated: shape, finite, bounds; errors call it ``name``) as a JSON-able dict
    (module docstring)."""
    q = robot.validate(q, name)
    oracle = BubbleOracle(robot, delta=delta)
    try:
        rep = oracle.explain(q)
    finally:
        oracle.close()
    pairs = [
        {
            "geoms": list(robot.pair_name(i)),
            "self": bool(robot.self_pair[i]),
            "distance": float(rep.pair_distances[i]),
            "rho": [float(v) for v in oracle.pair_rho[i]],
            "rho_norm": float(oracle.pair_factor[i]),
            "radius": float(rep.pair_radii[i]),
        }
        for i in range(len(robot.pairs))
    ]
    return {
        "format": FORMAT,
        "version": VERSION,
        "mjcf": str(robot.path),
        "joints": list(robot.config.joint_names),
        "q": [float(v) for v in q],
        "delta": float(delta),
        "clearance": rep.clearance,
        "closest_pair": list(rep.closest_pair),
        "radius": rep.radius,
        "limiting_pair": list(rep.limiting_pair),
        "rho": [float(v) for v in rep.rho],
        "rho_norm": rep.rho_norm,
        "to_bounds": rep.to_bounds,
        "pairs": pairs,
        "fixed_pairs": [[robot.geom_name(a), robot.geom_name(b)] for a, b in robot.fixed_pairs],
        "fixed_distances": [{"geoms": [robot.geom_label(a), robot.geom_label(b)], "distance": dist}
                            for a, b, dist in robot.fixed_obstacle_distances],
        "labels": {robot.geom_name(g): robot.geom_label(g) for g in range(robot.model.ngeom)  # geom<i> (on body ...)
                   if robot.geom_name(g) in (*rep.closest_pair, *rep.limiting_pair) and robot.geom_label(g) != robot.geom_name(g)},
    }


def format_report(doc: dict) -> list[str]:
    """The four lines ``foam-mj bubble`` prints: clearance, closest pair, rho per joint, radius; and a fifth naming the
    robot/obstacle pairs left out of the bound, whose distance no configuration joint changes (a pan joint's link
    over its pedestal): MuJoCo, ``plan``'s min clear and ``foam-mj verify`` count them, so where one of them is
    nearer, the clearance line also gives the smallest distance over every pair, which is theirs."""
    rho = ", ".join(f"{j} {v:.4f}" for j, v in zip(doc["joints"], doc["rho"]))
    labels = doc.get("labels", {})  # an unnamed geom with its body, which a user can find in the MJCF
    limit = " / ".join(labels.get(g, g) for g in doc["limiting_pair"])
    pair_term = min((p["radius"] for p in doc["pairs"]), default=float("inf"))
    # The joint bounds set the radius where q is nearer to them than the pairs allow (on a bound: radius 0).
    setter = f"the joint bounds (pair {limit} alone: {pair_term:.6f})" if doc["to_bounds"] < pair_term else limit
    fixed = min(doc.get("fixed_distances") or [], key=lambda f: f["distance"], default=None)
    # A pair left out of the bound that is nearer than every pair in it: the first line says which clearance it gives.
    overall = (f" over the pairs in the bound; {fixed['distance']:.6f} m over every pair ({' / '.join(fixed['geoms'])}, "
               f"left out of the bound)" if fixed is not None and fixed["distance"] < doc["clearance"] else "")
    return [
        f"clearance: {doc['clearance']:.6f} m{overall}",
        f"closest pair: {' / '.join(labels.get(g, g) for g in doc['closest_pair'])}",
        f"rho per joint (m per unit, pair {limit}): {rho}; ||rho||_2 = {doc['rho_norm']:.4f}",
        f"certified radius: {doc['radius']:.6f} (delta {doc['delta']:g} m, set by {setter}; "
        f"distance to the joint bounds {doc['to_bounds']:.6f})",
    ] + (["left out of the bound, as no configuration joint changes their distance: "
          + ", ".join(f"{' / '.join(f['geoms'])} {f['distance']:.6f} m" for f in doc["fixed_distances"])]
         if doc.get("fixed_distances") else [])
