"""The progress bar ends at the final simulated time, not at the last throttled redraw."""

import io
import sys

from mpsfem.progress import Progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_close_draws_the_final_time(monkeypatch):
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    bar = Progress(0.0, 1.0, enabled=True, label="run")
    for k in range(1, 11):  # far quicker than the 0.2 s redraw throttle
        bar.update(0.1 * k, 1e-3)
    bar.close()
    bar.close()  # a second close is harmless
    last = term.getvalue().replace("\r", "\n").strip().splitlines()[-1]
    assert "100%" in last and "t=1.0000/1.0000 s" in last, last


def test_disabled_bar_writes_nothing(monkeypatch):
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    bar = Progress(0.0, 1.0, enabled=False)
    bar.update(1.0, 1e-3)
    bar.close()
    assert term.getvalue() == ""


def test_no_terminal_reports_a_line_per_interval(monkeypatch):
    """stderr a file: one line per report interval with time, share, dt, rate and ETA."""
    log = io.StringIO()
    monkeypatch.setattr(sys, "stderr", log)
    clock = iter(float(k) for k in range(100))
    monkeypatch.setattr("mpsfem.progress.time.perf_counter", lambda: next(clock))
    bar = Progress(0.0, 1.0, enabled=True, label="fluid", report_interval=30.0)
    for k in range(1, 61):  # one step per (mocked) second
        bar.update(k / 100.0, 2e-3)
    bar.close()
    lines = log.getvalue().strip().splitlines()
    assert len(lines) == 2, lines  # at 30 s and 60 s of wall clock
    assert lines[0].startswith("fluid: t = 0.29 / 1 s (29 %), dt = 2.00e-03 s, 1.0 steps/s")
    assert "ETA 1 min 13 s" in lines[0]  # 29 s for 29 %: 71 % more
