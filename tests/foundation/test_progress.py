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
