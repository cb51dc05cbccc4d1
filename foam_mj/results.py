"""The JSON result of ``foam-mj plan --json``: enough to check it independently with MuJoCo alone.

Layout (format "foam-mj/result", version 1)::

    {
      "format": "foam-mj/result", "version": 1,
      "scenario": "obstacle", "scenario_file": "/abs/path/obstacle.toml",
      "mjcf": "/abs/path/to/scene.xml",              # the compiled scene; verify_result.py reads this
      "qpos_joints": ["hip_displacement", ...],       # names of the qpos entries, in qpos order
      "configuration": {"joints": [...], "lower": [...], "upper": [...]},
      "q_init": [...], "q_goal": [...], "seed": 0,
      "planner": {"K": 10, "r_min": 0.07, ...},
      "foam": {"stats": {...}, "centers": [[...], ...], "radii": [...], "parents": [...]},   # every bubble
      "rosary": {"centers": [[...], ...], "radii": [...], "bubble_ids": [...]},
      "paths": {
        "centre": {"waypoints": [[q], ...],          # configuration-space polyline
                   "qpos": [[qpos], ...],             # joint trajectory rows (MuJoCo qpos)
                   "times": [...],                    # seconds, one per qpos row (when time-parametrized)
                   "metrics": {"length": ..., "f": ..., "tc": ..., "sv": ..., ...},
                   "convergence": {"best": [...], "mean": [...]}},   # smoothers that iterate

        ...
      }
    }
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from foam_mj.paths import metrics

FORMAT = "foam-mj/result"
VERSION = 1


def _qpos_names(m: mujoco.MjModel) -> list[str]:
    names = [""] * m.nq
    for j in range(m.njnt):
        adr = int(m.jnt_qposadr[j])
        names[adr] = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
    return names


def result_dict(scenario, plan_result, paths: dict[str, Any], seed: int, extra: dict | None = None) -> dict:
    """Build the JSON document. ``paths`` maps a name to waypoints (m, n) or to a dict with at least
    "waypoints" and optionally "qpos", "times" and "metrics"."""
    robot = scenario.robot
    cfg = robot.config
    out_paths = {}
    for name, p in paths.items():
        entry = dict(p) if isinstance(p, dict) else {"waypoints": p}
        w = np.asarray(entry["waypoints"], dtype=float)
        entry["waypoints"] = w.tolist()
        if "qpos" not in entry:
            entry["qpos"] = cfg.to_qpos(w).tolist()
        else:
            entry["qpos"] = np.asarray(entry["qpos"], dtype=float).tolist()
        if "times" in entry:
            entry["times"] = np.asarray(entry["times"], dtype=float).tolist()
        entry.setdefault("metrics", metrics(w).as_dict())
        out_paths[name] = entry
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "scenario": scenario.name,
        "scenario_file": str(scenario.source) if scenario.source else None,
        "mjcf": str(Path(scenario.scene).resolve()),
        "qpos_joints": _qpos_names(robot.model),
        "configuration": {"joints": list(cfg.joint_names), "lower": cfg.lower.tolist(), "upper": cfg.upper.tolist()},
        "q_init": np.asarray(scenario.q_init).tolist(),
        "q_goal": np.asarray(scenario.q_goal).tolist(),
        "seed": int(seed),
        "planner": {k: getattr(scenario.params, k) for k in ("K", "r_min", "delta", "max_bubbles", "time_limit")},
        "foam": None,
        "rosary": None,
        "paths": out_paths,
    }
    if plan_result is not None:
        foam = plan_result.foam
        doc["foam"] = {
            "stats": plan_result.stats.as_dict(),
            "centers": foam.centers.tolist(),
            "radii": foam.radii.tolist(),
            "parents": foam.parents.tolist(),
        }
        ros = getattr(plan_result, "rosary", None)
        if ros is not None:
            doc["rosary"] = {
                "centers": ros.centers.tolist(),
                "radii": ros.radii.tolist(),
                "bubble_ids": None if ros.bubble_ids is None else np.asarray(ros.bubble_ids).tolist(),
            }
    if extra:
        doc.update(extra)
    return doc


def write_result(path: str | Path, scenario, plan_result, paths: dict[str, Any], seed: int, extra: dict | None = None) -> Path:
    p = Path(path)
    p.write_text(json.dumps(result_dict(scenario, plan_result, paths, seed, extra), indent=1))
    return p


def read_result(path: str | Path) -> dict:
    """Load and check a result file (format and the fields replay needs)."""
    from foam_mj.errors import FoamError

    p = Path(path)
    try:
        doc = json.loads(p.read_text())
    except FileNotFoundError:
        raise FoamError(f"result file not found: {p}") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise FoamError(f"{p}: not a readable JSON result: {exc}") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise FoamError(f"{p}: not a foam-mj result (field 'format' should be '{FORMAT}')")
    for key in ("mjcf", "paths"):
        if key not in doc:
            raise FoamError(f"{p}: missing field '{key}'")
    return doc
