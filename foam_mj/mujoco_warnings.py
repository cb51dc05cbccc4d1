"""Warnings in the ``foam-mj`` command, MuJoCo's runtime warnings among them: one line each, once.

MuJoCo reports a warning raised while simulating (a singular inertia matrix, an unstable step) through its C
printer unless a handler is set: it prints the warning once per simulation state, so every batch row and every
replay repeated it (a model with two coaxial hinges printed 125 copies in one `plan`), and it appends each to
``MUJOCO_LOG.TXT`` in the working folder. The command routes them to Python's :mod:`warnings` instead, which the
CLI shows once per distinct text. Only the command does: a library should not take over a process-wide handler,
so from Python MuJoCo's own behaviour (or the user's handler) stays.
"""

from __future__ import annotations

import re
import sys
import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager

_ROUTE = False


def route_to_python() -> None:
    """Route MuJoCo's runtime warnings to :mod:`warnings` in this process, from the next model loaded on (the
    ``foam-mj`` command calls it at start, before MuJoCo is imported)."""
    global _ROUTE
    _ROUTE = True


def install_if_routed() -> None:
    """Set the handler, when :func:`route_to_python` asked for it and no handler is set (called on model loads)."""
    if not _ROUTE:
        return
    import mujoco

    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(_warn)


#: The calling thread's held warnings while it is inside :func:`kept_unless_failed` (else no attribute).
_HELD = threading.local()


@contextmanager
def kept_unless_failed() -> Iterator[None]:
    """Hold the MuJoCo warnings raised inside by this thread; issue them if the block ends normally, drop them if it
    raises. A load that fails is one error line: MuJoCo's warning on the way ('Must provide extension or content_type to
    mjp_findDecoder' for a file that is no MJCF) only repeated it as a second line. Held per thread in the handler
    (:func:`_warn`), not with ``warnings.catch_warnings``, which saves and restores the process's warning filters: loads
    overlapping in several threads restored each other's changes ('always' added to the filters for good) and took
    the other threads' warnings."""
    outer = getattr(_HELD, "texts", None)
    texts: list[str] = []
    _HELD.texts = texts
    try:
        yield
    finally:
        _HELD.texts = outer
    for text in texts:
        _warn(text, stacklevel=4)


def _warn(text: str, stacklevel: int = 2) -> None:
    held = getattr(_HELD, "texts", None)
    if held is not None:
        held.append(text)
    else:
        warnings.warn(text, RuntimeWarning, stacklevel=stacklevel)


_SHOWN: set[str] = set()


def show_once(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` of the ``foam-mj`` command: each warning one line, once. MuJoCo's end in
    "Time = 0.0000.", so each was new to Python's filter; a model with a singular inertia matrix printed the same
    three-line warning from every call site."""
    text = re.sub(r"\s*Time = \S+$", "", str(message).strip())
    if text not in _SHOWN:
        _SHOWN.add(text)
        print(f"foam-mj: warning: {text}", file=sys.stderr)
