"""The progress display of the ``foam-mj`` commands (planning, smoothing, replaying) and a sweep's bar or lines."""

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


def duration_text(seconds: float) -> str:
    """A duration to read at a glance: seconds up to 99 s, then minutes, hours up to 48 h, then days."""
    if seconds < 99.5:
        return f"{seconds:.0f} s"
    if seconds < 99.5 * 60:
        return f"{seconds / 60:.0f} min"
    if seconds < 48 * 3600:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} d"


class SweepProgress:
    """Plans done/total, those not reached, rate and ETA: a rich bar on a terminal, else a plain line every ``interval`` s.
    ``failed``: plans among ``done`` with a row not reached. ``stop``: where this run ends when ``--limit`` ends it
    before ``total``; the bar and the ETA count to it."""

    def __init__(self, total: int, done: int, *, failed: int = 0, terminal: bool | None = None, interval: float = 5.0, label: str = "sweep",
                 stop: int | None = None) -> None:
        bar = label  # the bar's own label is short: the bar, its counts and ETA share one terminal line
        if stop is not None and stop < total:
            label, bar, total = f"{label} (--limit: to {stop} of {total})", f"{label} --limit", stop
        self.total, self.done, self.failed = total, done, failed
        self.start_done = done
        self.t0 = time.monotonic()
        self.interval = interval
        self.label = label
        self._last = self.t0
        self.terminal = sys.stderr.isatty() if terminal is None else terminal
        self._rich = None
        if self.terminal:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

            self._rich = Progress(
                TextColumn("[bold]{task.description}"),
                BarColumn(),
                MofNCompleteColumn(),
                TextColumn("plans, {task.fields[failed]} not reached, {task.fields[rate]}"),
                TextColumn("ETA"),
                TimeRemainingColumn(),
                TimeElapsedColumn(),
                console=Console(stderr=True),
                transient=False,
            )
            self._rich.start()
            self._task = self._rich.add_task(bar, total=total, completed=done, failed=failed, rate="- plans/s")

    @property
    def rate(self) -> float:
        dt = time.monotonic() - self.t0
        return (self.done - self.start_done) / dt if dt > 0 else 0.0

    def line(self) -> str:
        rate = self.rate
        left = self.total - self.done
        eta = duration_text(left / rate) if rate > 0 else "-"
        return f"{self.label}: {self.done:,}/{self.total:,} plans, {self.failed:,} not reached, {rate:.2f} plans/s, ETA {eta}"

    def update(self, n: int = 1, failed: int = 0) -> None:
        self.done += n
        self.failed += failed
        if self._rich is not None:
            self._rich.update(self._task, completed=self.done, failed=self.failed, rate=f"{self.rate:.2f} plans/s")
        else:
            self.tick()

    def tick(self) -> None:
        if self._rich is None and time.monotonic() - self._last >= self.interval:
            self._last = time.monotonic()
            print(self.line(), file=sys.stderr, flush=True)

    def close(self) -> None:
        if self._rich is not None:
            self._rich.stop()
            self._rich = None
