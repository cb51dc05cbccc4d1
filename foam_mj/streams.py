"""The ``foam-mj`` process's standard streams: a stdout whose reader has gone, and streams the caller closed."""

from __future__ import annotations

import os
import sys


def reopen_closed_streams() -> None:
    """Open the null device on each of the descriptors 0, 1 and 2 the caller closed (``foam-mj plan >&-``, a daemon), and
    give Python a stream for each. Python's stdout was None: the first print was an internal error (exit 1) or the
    exit's flush failed (exit 120), and no result was written; a file opened later would also have taken descriptor 1,
    where MuJoCo prints its warnings."""
    for fd, name, mode in ((0, "stdin", "r"), (1, "stdout", "w"), (2, "stderr", "w")):
        try:
            os.fstat(fd)
        except OSError:
            null = os.open(os.devnull, os.O_RDONLY if mode == "r" else os.O_WRONLY)  # the lowest free descriptor: fd
            if null != fd:
                os.dup2(null, fd)
                os.close(null)
        if getattr(sys, name) is None:
            setattr(sys, name, open(fd, mode, closefd=False))


class OutputWithoutReader:
    """The command's stdout: once its reader has gone (piped into `head`, `grep -m1`), what is left to print is
    dropped and the command goes on to write its files and return its own exit code. (A closed pipe ended the
    command at its next print with exit 0: `plan --json` wrote no result and said nothing.)"""

    def __init__(self, stream) -> None:
        self._stream = stream
        self._gone = False

    def write(self, text: str) -> int:
        if not self._gone:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._drop()
        return len(text)

    def flush(self) -> None:
        if not self._gone:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._drop()

    def _drop(self) -> None:
        self._gone = True
        try:  # what the stream still buffers goes to /dev/null when the interpreter flushes it on exit
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self._stream.fileno())
            os.close(null)
        except (OSError, ValueError):
            pass

    def __getattr__(self, name: str):
        return getattr(self._stream, name)
