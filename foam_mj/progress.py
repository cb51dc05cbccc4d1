"""The progress display of the ``foam-mj`` commands (planning, smoothing, replaying, sweeping)."""

from __future__ import annotations

import re
import sys
import time

#: The numbers of a message: left out, what is left is its kind (a stage: "smoothing: genetic algorithm, generation #").
_NUMBERS = re.compile(r"\d[\d,.]*")


class Progress:
    """A one-line progress display on stderr when stderr is a terminal (or when forced with ``enabled``).

    Off a terminal, with ``lines`` (CI logs, nohup), a plain log on stderr instead: a line at once for each new kind
    of message (its text with the numbers left out: a stage starting or done), the same kind again at most every
    ``interval`` s; each line starts with the seconds since this display was made."""

    def __init__(self, enabled: bool | None = None, *, lines: bool = False, interval: float = 30.0) -> None:
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.lines = lines and enabled is None and not self.enabled
        self.interval = interval
        self._shown = False
        self._t0 = time.monotonic()
        self._kind: str | None = None
        self._last = self._t0

    def __call__(self, text: str) -> None:
        if self.enabled:
            sys.stderr.write("\r\033[K" + text)
            sys.stderr.flush()
            self._shown = True
        elif self.lines:
            now, kind = time.monotonic(), _NUMBERS.sub("#", text)
            if kind != self._kind or now - self._last >= self.interval:
                sys.stderr.write(f"[{now - self._t0:.1f} s] {text}\n")
                sys.stderr.flush()
                self._kind, self._last = kind, now

    def done(self) -> None:
        if self._shown:
            sys.stderr.write("\r\033[K")
            sys.stderr.flush()
            self._shown = False
