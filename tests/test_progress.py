"""The progress display: a live line on a terminal; off one (CI logs, nohup), ``plan`` logs one line per stage."""

from __future__ import annotations

import io
import re

import pytest

from foam_mj.cli import main
from foam_mj.progress import Progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


GA = ["smoothing: genetic algorithm"] + [f"smoothing: genetic algorithm, generation {t:,} of at most 1,000, best f {1 / t:.4f}"
                                          for t in range(1, 60)] + ["smoothing: genetic algorithm done in 138.2 s"]


def test_on_a_terminal_every_message_overwrites_one_line(monkeypatch):
    monkeypatch.setattr("sys.stderr", err := _Terminal())
    progress = Progress(lines=True)
    for text in GA:
        progress(text)
    progress.done()
    assert err.getvalue() == "".join("\r\033[K" + text for text in GA) + "\r\033[K"


def test_off_a_terminal_a_line_for_each_stage_and_its_repeats_at_most_every_interval(monkeypatch):
    """`plan --smoother all` ran 236 s with nothing on stderr off a terminal: now each stage starting or done is a line
    at once, and the same stage's updates (numbers aside) again only after ``interval`` s."""
    monkeypatch.setattr("sys.stderr", err := io.StringIO())
    progress = Progress(lines=True, interval=3600)
    for text in GA:
        progress(text)
    progress.done()
    lines = err.getvalue().splitlines()
    assert [re.sub(r"^\[\d+\.\d s\] ", "", line) for line in lines] == [GA[0], GA[1], GA[-1]], lines
    assert err.getvalue().endswith("\n") and "\r" not in err.getvalue()

    monkeypatch.setattr("sys.stderr", err := io.StringIO())
    progress = Progress(lines=True, interval=0)
    for text in GA:
        progress(text)
    assert len(err.getvalue().splitlines()) == len(GA)


@pytest.mark.parametrize("kwargs", [{}, {"enabled": False, "lines": True}])
def test_without_lines_or_when_turned_off_nothing_is_written_off_a_terminal(monkeypatch, kwargs):
    monkeypatch.setattr("sys.stderr", err := io.StringIO())
    progress = Progress(**kwargs)
    for text in GA:
        progress(text)
    progress.done()
    assert err.getvalue() == ""


def test_plan_off_a_terminal_says_each_smoother_starting_and_done_with_its_time_on_stderr_only(tmp_path, capsys):
    js = tmp_path / "r.json"
    assert main(["plan", "--scene", "obstacle", "--smoother", "convex", "--no-rrd", "--no-replay", "--json", str(js)]) == 0
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert "[" not in out and "smoothing:" not in out and "smoothing:" not in js.read_text()
    start = lines.index(next(line for line in lines if line.endswith("] smoothing: convex shortest path")))
    assert re.fullmatch(r"\[\d+\.\d s\] smoothing: convex shortest path done in \d+\.\d s", lines[start + 1]), lines


def test_a_sweep_line_reads_at_a_glance_however_big_the_study():
    """A million-plan study at 0.59 plans/s said "ETA 1693220 s" (19.6 days) and "1000/1000000 plans"."""
    from foam_mj.progress import SweepProgress, duration_text

    bar = SweepProgress(1_000_000, 0, terminal=False)
    bar.done, bar.t0 = 1000, bar.t0 - 1000 / 0.59
    assert re.fullmatch(r"sweep: 1,000/1,000,000 plans, 0 not reached, 0\.59 plans/s, ETA 19\.6 d", bar.line())
    assert [duration_text(s) for s in (28.4, 99.4, 100, 5940, 6000, 47.9 * 3600, 48 * 3600)] == [
        "28 s", "99 s", "2 min", "99 min", "1.7 h", "47.9 h", "2.0 d"]
