"""The one-line progress display of the ``foam-mj`` commands (planning, smoothing, replaying, sweeping)."""

from __future__ import annotations

import sys


class Progress:
    """A one-line progress display on stderr (only when stderr is a terminal, or when forced)."""

    def __init__(self, enabled: bool | None = None) -> None:
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self._shown = False

    def __call__(self, text: str) -> None:
        if self.enabled:
            sys.stderr.write("\r\033[K" + text)
            sys.stderr.flush()
            self._shown = True

    def done(self) -> None:
        if self._shown:
            sys.stderr.write("\r\033[K")
            sys.stderr.flush()
            self._shown = False
