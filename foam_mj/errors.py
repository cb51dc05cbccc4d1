"""The exceptions foam-mj raises. A model, scene, scenario, configuration, planner name or option that foam-mj cannot
use, and a plan it cannot make, raise a :class:`FoamError` (the model, configuration, scenario and planner errors are
ValueErrors too); a Python argument of the wrong type or value (``delta="0.1"``, an unknown smoother name) raises
TypeError or ValueError naming the argument. ``foam_mj.planners.PlannerError`` and ``foam_mj.timing.TimingInfeasible``
(a PlanningFailed) are defined beside their planners and time law; every one is an attribute of ``foam_mj``."""

from __future__ import annotations

import os
import stat
from typing import Any, Iterable


class FoamError(Exception):
    """Base class of every foam-mj error."""


class ModelError(FoamError, ValueError):
    """An MJCF file is missing, malformed, or does not describe a robot foam-mj can plan for."""


class ConfigurationError(FoamError, ValueError):
    """A configuration q has the wrong shape, is not finite, or lies outside the bounds."""


class ScenarioError(FoamError, ValueError):
    """A scenario file or a scenario field is missing or invalid."""


class PlanningFailed(FoamError):
    """The foam could not reach the goal within its budget.

    ``stats`` holds the foam's statistics and ``foam`` the foam itself (when available), so the
    caller can still look at what was explored. ``reason`` is the message without the wall time the
    planner took ("after 765 bubbles" where the message says "after 765 bubbles in 0.17 s"): the same
    run gives the same reason on every machine, so a study's rows can hold it (the time is in ``stats``).
    """

    def __init__(self, message: str, stats: Any = None, foam: Any = None, reason: str | None = None) -> None:
        super().__init__(message)
        self.stats = stats
        self.foam = foam
        self.reason = message if reason is None else reason

    @classmethod
    def after(cls, head: str, stats: Any, tail: str = "", foam: Any = None) -> PlanningFailed:
        """The failure "``head`` in ``stats.elapsed`` s``tail``", whose ``reason`` leaves the time out."""
        return cls(f"{head} in {stats.elapsed:.2f} s{tail}", stats, foam, reason=f"{head}{tail}")


def clearance_text(d: float, delta: float) -> str:
    """A clearance ``d`` (m) for a message beside the margin ``delta``: 4 decimals, more where 4 would print it
    equal to ``delta`` although it differs (4.999 mm is "0.004999 m", not "0.0050 m" beside a margin of 0.005 m)."""
    for k in range(4, 13):
        text = f"{d:.{k}f}"
        if d == delta or text != f"{delta:.{k}f}":
            break
    return f"{text} m"


def radius_text(r: float, bound: float) -> str:
    """A radius ``r`` for a message beside a bound such as r_min: 3 significant digits, more where 3 would print it
    equal to ``bound`` although it differs (0.06999 is "0.06999 < r_min = 0.07", not "0.07 < r_min = 0.07")."""
    for k in range(3, 13):
        text = f"{r:.{k}g}"
        if r == bound or float(text) != float(f"{bound:.{k}g}"):
            break
    return text


def is_number(value: Any) -> bool:
    """A real number (Python's or numpy's) and not a boolean: True is the integer 1 to Python, and a flag
    given where a number is expected (``K = true``) must be refused, not planned with as 1."""
    import numbers

    return isinstance(value, numbers.Real) and not isinstance(value, bool)  # numpy's bool_ is no Real


def only_numbers(value: Any) -> bool:
    """True if ``value`` is a number or (nested) lists of numbers only (:func:`is_number`): numpy's
    ``asarray(value, dtype=float)`` also reads the strings "0.3" and "\uff11" (full-width 1) and the booleans of a
    hand-edited JSON result as numbers, and the result passed as clean."""
    stack = [value]  # not recursive: a result's arrays may nest as deep as the JSON parser allows
    while stack:
        v = stack.pop()
        if isinstance(v, (list, tuple)):
            stack.extend(v)
        elif not is_number(v):
            return False
    return True


def is_finite_number(value: Any) -> bool:
    """:func:`is_number` and finite. Never raises: ``np.isfinite(2**70)`` is a TypeError ("ufunc 'isfinite' not
    supported"), ``math.isfinite(10**400)`` an OverflowError; such an integer is simply not a finite float."""
    import math

    try:
        return is_number(value) and math.isfinite(value)
    except OverflowError:
        return False


def file_problem(path: str | os.PathLike) -> str | None:
    """Why ``path`` names no regular file, for a message ("not found", "a folder, not a file", "File name too long"), or
    None for a regular file. Never raises: Python 3.11's ``Path.is_file`` raised OSError for a name longer than the file
    system allows and ValueError for a NUL byte, which reached the user as an internal error."""
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return "not found"
    except OSError as exc:
        return exc.strerror or type(exc).__name__
    except ValueError:
        return "not a file name (it holds a NUL byte)"
    if stat.S_ISDIR(mode):
        return "a folder, not a file"
    if not stat.S_ISREG(mode):
        return "not a regular file"
    return None


def file_problem_text(path: str | os.PathLike, what: str) -> str | None:
    """:func:`file_problem` as a message about ``what`` ("MJCF file not found: x.xml", "MJCF file x: a folder, not a
    file"), or None for a regular file."""
    problem = file_problem(path)
    if problem is None:
        return None
    return f"{what} not found: {path}" if problem == "not found" else f"{what} {path}: {problem}"


#: The first bytes of files foam-mj writes that are not JSON, and what they are (for "not a readable JSON result").
_FOREIGN = ((b"RRF", "a Rerun recording (.rrd)"), (b"PAR1", "a Parquet table"), (b"PK\x03\x04", "a ZIP/NPZ archive"),
            (b"\x89PNG", "a PNG image"), (b"%PDF", "a PDF file"))


def foreign_file_hint(path: str | os.PathLike) -> str:
    """" (the file is empty)", " (it is a Rerun recording (.rrd), not JSON)" and the like for a file given where a JSON
    result was expected, else ""."""
    try:
        with open(path, "rb") as f:
            head = f.read(8)
    except OSError:
        return ""
    if not head:
        return " (the file is empty)"
    return next((f" (it is {what}, not JSON)" for magic, what in _FOREIGN if head.startswith(magic)), "")


def unknown_names(unknown: Iterable[str], known: Iterable[str], elsewhere: dict[str, str] | None = None) -> str:
    """The unknown names, each with the known one it most looks like ("'q_goals' (did you mean 'q_goal'?)"), or with
    where it belongs when ``elsewhere`` (name -> place) holds it, for a message that lists ``known`` after it."""
    import difflib  # here, not at the top: the command line imports this module at start-up

    known = sorted(str(k) for k in known)
    folded = {k.lower().replace("-", "_"): k for k in known}
    parts = []
    for name in sorted(unknown, key=str):
        text, key = repr(name), str(name).lower().replace("-", "_")
        if elsewhere and name in elsewhere:
            text += f" ({elsewhere[name]})"
        else:
            close = [folded[key]] if key in folded else difflib.get_close_matches(str(name), known, n=1, cutoff=0.6)
            if close:
                text += f" (did you mean {close[0]!r}?)"
        parts.append(text)
    return ", ".join(parts)


def indices_text(indices: Iterable[int], most: int = 8) -> str:
    """Indices for a one-line message: all of them up to ``most``, else the first ``most`` and how many there are
    ("[0, 1, 2, 3, 4, 5, 6, 7, ... (56 in all)]"); a list of every index of a long path filled a screen."""
    items = [int(i) for i in indices]
    if len(items) <= most:
        return str(items)
    return f"[{', '.join(map(str, items[:most]))}, ... ({len(items)} in all)]"


def text_problem(exc: OSError | UnicodeDecodeError) -> str:
    """Why a text file could not be read, for "PATH: cannot read: ..." or "PATH: ...": a file saved as UTF-16 (a
    Windows editor's "Unicode") is named as such with what to do, any other byte that is not UTF-8 by its place;
    Python's "'utf-8' codec can't decode byte 0xff in position 0" said neither."""
    if not isinstance(exc, UnicodeDecodeError):
        return exc.strerror or str(exc)
    head = bytes(exc.object[:2])
    for bom, order in ((b"\xff\xfe", "little-endian"), (b"\xfe\xff", "big-endian")):
        if head == bom:
            return f"the file is UTF-16 text ({order}); save it as UTF-8"
    return f"not UTF-8 text: byte 0x{exc.object[exc.start]:02x} at offset {exc.start} ({exc.reason}); save it as UTF-8"


def json_integer(text: str) -> int | float:
    """``json.loads``'s ``parse_int``: JSON integers have no size limit, so one beyond a float's range reads as infinite
    (as 1e400 does), and the field holding it is refused by name; Python's int() refused 5,000 digits (exit 1)."""
    if len(text) > 400:  # beyond 1.8e308 whatever its digits
        return float("-inf") if text.startswith("-") else float("inf")
    value = int(text)
    return value if abs(value) <= 1.7976931348623157e308 else (float("-inf") if value < 0 else float("inf"))
