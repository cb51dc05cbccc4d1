"""Reading a sweep file (TOML): every key and value checked, with a message naming it, before any plan; the
study it describes is a :class:`foam_mj.sweep.Sweep` (the file format is in that module's docstring)."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path
from typing import Any

from foam_mj.arguments import MAX_SEED
from foam_mj.errors import FoamError, ScenarioError, file_problem_text, text_problem, unknown_names
from foam_mj.fingerprint import model_fingerprint
from foam_mj.sweep import (
    MAX_TASKS,
    REPLAYS,
    RESULT_COLUMNS,
    Axis,
    _ROBOTS,
    Sweep,
    SweepError,
    _normalize,
    actuated_joints,
    build_scenario,
)

_TOP_FIELDS = {"scenario", "seeds", "smoothers", "replay", "grid", "random"}
_RANDOM_FIELDS = {"samples", "seed", "uniform", "choice"}
_SPLIT = ": split the study into several sweep files, each with its own --out"


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file; every swept value is tried on the base scenario (SweepError naming it)."""
    from foam_mj.smoother_names import SMOOTHERS, parse_smoothers
    from foam_mj.scenarios import read_scenario_doc

    if not isinstance(path, (str, Path)) and not hasattr(path, "__fspath__"):
        raise TypeError(f"`path` must be the path of a sweep file, got {type(path).__name__}")
    path = Path(path)
    problem = file_problem_text(path, "sweep file")
    if problem:
        raise SweepError(problem)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8-sig"))  # TOML is UTF-8; a byte-order mark is let through
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"{path}: malformed TOML: {exc}") from None
    except RecursionError:  # arrays nested thousands deep: an internal error (exit 1)
        raise SweepError(f"{path}: malformed TOML: nested too deeply to read") from None
    except UnicodeDecodeError as exc:
        raise SweepError(f"{path}: {text_problem(exc)}") from None
    except OSError as exc:
        raise SweepError(f"{path}: cannot read: {exc}") from None
    where = str(path)
    unknown = set(raw) - _TOP_FIELDS
    if unknown:
        raise SweepError(f"{where}: unknown field(s) {unknown_names(unknown, _TOP_FIELDS)}; expected {sorted(_TOP_FIELDS)}")
    if "scenario" not in raw:
        raise SweepError(f"{where}: field 'scenario' (a built-in scenario name or a TOML path) is required")
    if not isinstance(raw["scenario"], str):
        raise SweepError(f"{where}: field 'scenario' must be a built-in scenario name or a TOML path (text), got {raw['scenario']!r}")
    ref = raw["scenario"]
    candidate = path.parent / ref
    try:
        if ref.endswith(".toml") or "/" in ref:
            base, spath = read_scenario_doc(candidate)
            scenario, builtin = str(spath.resolve()), False
        else:
            base, spath = read_scenario_doc(ref)
            scenario, builtin = ref, True
    except ScenarioError as exc:
        raise SweepError(f"{where}: field 'scenario': {exc}") from None
    # seeds
    seeds = raw.get("seeds", [base.get("seed", 0)])
    if isinstance(seeds, int) and not isinstance(seeds, bool):
        if seeds < 1:
            raise SweepError(f"{where}: field 'seeds' must be a count >= 1 or a list of integers >= 0, got {seeds}")
        if seeds > MAX_TASKS:
            raise SweepError(f"{where}: field 'seeds' = {seeds:,} is more plans than one sweep takes ({MAX_TASKS:,}){_SPLIT}")
        seeds = list(range(seeds))
    if not (isinstance(seeds, list) and seeds and all(isinstance(s, int) and not isinstance(s, bool) and 0 <= s <= MAX_SEED for s in seeds)):
        raise SweepError(f"{where}: field 'seeds' must be a count >= 1 or a non-empty list of integers in [0, 2**63 - 1], got {seeds!r}")
    if len(set(seeds)) != len(seeds):
        raise SweepError(f"{where}: field 'seeds' has repeated values {seeds}")
    # smoothers and replay
    smoothers = raw.get("smoothers", "optimal")
    if isinstance(smoothers, list) and all(isinstance(s, str) for s in smoothers):
        smoothers = ",".join(smoothers)
    if not isinstance(smoothers, str):
        raise SweepError(f"{where}: field 'smoothers' must be a string or a list of names from {', '.join(SMOOTHERS)}")
    try:
        smoother_paths = parse_smoothers(smoothers)
    except FoamError as exc:
        raise SweepError(f"{where}: field 'smoothers': {exc}") from None
    paths = ("centre",) + tuple(p for p in smoother_paths if p != "centre")
    replay = raw.get("replay", "dynamic")
    if replay not in REPLAYS:
        raise SweepError(f"{where}: field 'replay' must be one of {', '.join(REPLAYS)}, got {replay!r}")
    # grid and random
    grid_raw = raw.get("grid", {})
    if not isinstance(grid_raw, dict):
        raise SweepError(f"{where}: [grid] must be a table of \"dotted.key\" = [values]")
    if "grid" in raw and not grid_raw:
        # An empty table is a sweep whose variation was forgotten: say so (leave [grid] out to sweep only seeds).
        raise SweepError(f"{where}: [grid] is empty: give at least one \"dotted.key\" = [values], or leave the table out")
    grid = []
    for key, values in grid_raw.items():
        if not isinstance(values, list) or not values:
            raise SweepError(f"{where}: [grid] '{key}' must be a non-empty list of values, got {values!r}")
        grid.append(_axis(where, "[grid]", key, values, "grid"))
    rnd = raw.get("random", {})
    if not isinstance(rnd, dict):
        raise SweepError(f"{where}: [random] must be a table")
    if "random" in raw and not (rnd.get("uniform") or rnd.get("choice")):
        raise SweepError(f"{where}: [random] has no key in [random.uniform] or [random.choice], or leave the table out")
    unknown = set(rnd) - _RANDOM_FIELDS
    if unknown:
        raise SweepError(f"{where}: unknown [random] field(s) {unknown_names(unknown, _RANDOM_FIELDS)}; expected {sorted(_RANDOM_FIELDS)} "
                         "(keys go in [random.uniform] or [random.choice])")
    random_axes = []
    for key, spec in (rnd.get("uniform") or {}).items():
        if not (isinstance(spec, list) and len(spec) == 2):
            raise SweepError(f"{where}: [random.uniform] '{key}' must be [low, high], got {spec!r}")
        random_axes.append(_uniform_axis(where, key, spec[0], spec[1]))
    for key, values in (rnd.get("choice") or {}).items():
        if not isinstance(values, list) or not values:
            raise SweepError(f"{where}: [random.choice] '{key}' must be a non-empty list of values, got {values!r}")
        random_axes.append(_axis(where, "[random.choice]", key, values, "choice"))
    samples: Any = rnd.get("samples", 0 if not random_axes else None)  # (checked below)
    if random_axes and not (isinstance(samples, int) and not isinstance(samples, bool) and samples >= 1):
        raise SweepError(f"{where}: [random] 'samples' must be an integer >= 1, got {samples!r}")
    if samples and not random_axes:
        raise SweepError(f"{where}: [random] has samples but no key in [random.uniform] or [random.choice]")
    rseed = rnd.get("seed", 0)
    if not (isinstance(rseed, int) and not isinstance(rseed, bool) and rseed >= 0):
        raise SweepError(f"{where}: [random] 'seed' must be an integer >= 0, got {rseed!r}")
    keys = [a.key for a in grid + random_axes]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise SweepError(f"{where}: key(s) {dup} swept twice")
    factors = [(len(a.values), f"'{a.key}'") for a in grid] + [(samples, "random samples")] * bool(random_axes) + [(len(seeds), "seeds")]
    if math.prod(n for n, _ in factors) > MAX_TASKS:  # before any sample is drawn or task listed (memory, minutes of start-up)
        product = " x ".join(f"{n:,} {what}" for n, what in factors if n > 1)
        raise SweepError(f"{where}: {math.prod(n for n, _ in factors):,} plans ({product}) are more than one sweep takes ({MAX_TASKS:,}){_SPLIT}")
    # every value, one key at a time, on the base scenario: bad keys and values named before any work; a value
    # that only puts the start or goal within the margin (an obstacle moved onto the goal) gives 'invalid' rows
    # the scenes as they are now: a model compiled by an earlier load in this process (a notebook's) may be of an MJCF
    # edited since, and its fingerprint would let the sweep's folder take rows of the new model under the old one's name
    _ROBOTS.clear()
    try:
        robot = build_scenario(scenario, builtin, base, ()).robot
    except FoamError as exc:
        raise SweepError(f"{where}: the base scenario: {exc}") from None
    for a in grid + random_axes:
        section = {"grid": "[grid]", "uniform": "[random.uniform]", "choice": "[random.choice]"}[a.source]
        tries = a.values if a.source != "uniform" else (a.low, a.high)
        for v in tries:
            try:
                build_scenario(scenario, builtin, base, ((a.key, _normalize(v, a.kind)),), check_clearance=False)
            except FoamError as exc:
                raise SweepError(f"{where}: {section} '{a.key}' = {json.dumps(v)}: {exc}") from None
    return Sweep(
        source=path,
        scenario=scenario,
        builtin=builtin,
        base=base,
        base_dir=spath.parent,
        seeds=tuple(seeds),
        smoothers=smoothers,
        smoother_paths=smoother_paths,
        paths=paths,
        replay=replay,
        grid=tuple(grid),
        random=tuple(random_axes),
        samples=int(samples or 0),
        random_seed=rseed,
        actuated_joints=actuated_joints(robot),
        model_hash=model_fingerprint(robot.model),
    )


_RESERVED = {"seed": "sweep seeds with the `seeds` field", "key": "'key' is a result column"}


def _kind(where: str, section: str, key: str, values: list) -> str:
    kinds = set()
    for v in values:
        if isinstance(v, bool):
            kinds.add("bool")
        elif isinstance(v, int):
            kinds.add("int")
        elif isinstance(v, float):
            if not math.isfinite(v):
                raise SweepError(f"{where}: {section} '{key}' = {v}: values must be finite")
            kinds.add("float")
        elif isinstance(v, str):
            kinds.add("str")
        elif isinstance(v, (list, dict)):
            kinds.add("json")
        else:
            raise SweepError(f"{where}: {section} '{key}': unsupported value {v!r}")
    if kinds == {"int", "float"}:
        return "float"
    if len(kinds) != 1:
        raise SweepError(f"{where}: {section} '{key}' mixes kinds of values ({', '.join(sorted(kinds))}): {values!r}")
    return kinds.pop()


def _check_key(where: str, section: str, key: str) -> None:
    if key in _RESERVED:
        raise SweepError(f"{where}: {section} '{key}' cannot be swept: {_RESERVED[key]}")
    if key in {c for c, _ in RESULT_COLUMNS} or not key or any(not p for p in key.split(".")):
        raise SweepError(f"{where}: {section} '{key}' is not a scenario field (a dotted key such as 'planner.delta')")


def _axis(where: str, section: str, key: str, values: list, source: str) -> Axis:
    _check_key(where, section, key)
    kind = _kind(where, section, key, values)
    normalized = tuple(_normalize(v, kind) for v in values)
    if len({json.dumps(v, sort_keys=True) for v in normalized}) != len(normalized):
        raise SweepError(f"{where}: {section} '{key}' has repeated values {values!r}")
    return Axis(key, kind, normalized, source=source)


def _uniform_axis(where: str, key: str, low, high) -> Axis:
    section = "[random.uniform]"
    _check_key(where, section, key)

    def numbers(v) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    if numbers(low) and numbers(high):
        kind = "int" if isinstance(low, int) and isinstance(high, int) else "float"
        lo, hi = _normalize(low, kind), _normalize(high, kind)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise SweepError(f"{where}: {section} '{key}' = [{low}, {high}]: need finite low <= high")
        if lo == hi:  # every draw the same value: planned once, as if the key were not swept at random
            raise SweepError(f"{where}: {section} '{key}' = [{low}, {high}] is an empty range (low = high): give low < high, "
                             f"or put the one value in [grid]")
        return Axis(key, kind, low=lo, high=hi, source="uniform")
    if isinstance(low, list) and isinstance(high, list) and len(low) == len(high) and low and all(numbers(v) for v in low + high):
        lo, hi = [float(v) for v in low], [float(v) for v in high]
        if not all(math.isfinite(a) and math.isfinite(b) and a <= b for a, b in zip(lo, hi)):
            raise SweepError(f"{where}: {section} '{key}': need finite low <= high element-wise, got {low} and {high}")
        if lo == hi:
            raise SweepError(f"{where}: {section} '{key}' = [{low}, {high}] is an empty range (low = high in every element): "
                             f"give low < high in the elements to vary, or put the one value in [grid]")
        return Axis(key, "json", low=lo, high=hi, source="uniform")
    raise SweepError(f"{where}: {section} '{key}' must be [low, high] with two numbers or two lists of numbers of one length")
