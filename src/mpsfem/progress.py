"""Progress over simulated time: a bar on a terminal, a one-line report every 30 s elsewhere.

A run whose stderr is a file or a pipe (a batch job, ``nohup``, CI) printed nothing until it
ended; it now prints ``label: t = ... / ... s (..%), dt = ... s, ... steps/s, ETA ...`` every
``REPORT_INTERVAL`` seconds of wall clock.
"""

from __future__ import annotations

import sys
import time

from tqdm import tqdm

#: wall-clock seconds between the one-line reports when stderr is not a terminal
REPORT_INTERVAL = 30.0


def _duration(seconds: float) -> str:
    """'42 s', '3 min 05 s', '2 h 07 min'."""
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


class Progress:
    """Shows simulated time, dt, steps/s and the ETA: a bar when stderr is a terminal, a line
    every ``report_interval`` s of wall clock otherwise; nothing when not ``enabled``."""

    def __init__(
        self,
        t0: float,
        t_end: float,
        enabled: bool = True,
        label: str = "run",
        report_interval: float = REPORT_INTERVAL,
    ) -> None:
        self._on = enabled and sys.stderr.isatty()
        self._report = enabled and not self._on
        self._label = label
        self._t0 = t0
        self._t_end = t_end
        self._interval = report_interval
        self._start = time.perf_counter()
        self._next_report = self._start + report_interval
        self._report_steps = 0
        self._t = t0
        self._steps = 0
        self._last: tuple[float, float] | None = None
        self._clock = time.perf_counter()
        self._bar = (
            tqdm(
                total=t_end,
                initial=t0,
                desc=label,
                unit="s",
                unit_scale=False,
                bar_format="{desc} {percentage:3.0f}%|{bar}| t={n:.4f}/{total:.4f} s "
                "[{elapsed}<{remaining}]{postfix}",
                file=sys.stderr,
                dynamic_ncols=True,
            )
            if self._on
            else None
        )

    def update(self, t: float, dt: float) -> None:
        """Note the state after a step at simulated time ``t`` (s) with step ``dt`` (s); the bar
        is redrawn at most every 0.2 s of wall clock."""
        self._steps += 1
        self._last = (t, dt)
        if self._report:
            self._report_steps += 1
            now = time.perf_counter()
            if now >= self._next_report:
                self._report_line(t, dt, now)
            return
        if self._bar is None:
            return
        now = time.perf_counter()
        if now - self._clock < 0.2:
            return
        self._draw(t, dt, now)

    def _report_line(self, t: float, dt: float, now: float) -> None:
        """One line: simulated time, share done, dt, steps/s since the last line, ETA."""
        span = now - (self._next_report - self._interval)
        rate = self._report_steps / max(span, 1e-9)
        done = (t - self._t0) / max(self._t_end - self._t0, 1e-300)
        elapsed = now - self._start
        eta = elapsed * (1.0 - done) / done if done > 0 else float("inf")
        share = 100.0 * (t / self._t_end) if self._t_end > 0 else 100.0
        print(
            f"{self._label}: t = {t:.6g} / {self._t_end:.6g} s ({share:.0f} %), dt = {dt:.2e} s, "
            f"{rate:.1f} steps/s, ETA {_duration(eta) if eta != float('inf') else '?'}",
            file=sys.stderr,
            flush=True,
        )
        self._report_steps = 0
        self._next_report = now + self._interval

    def _draw(self, t: float, dt: float, now: float) -> None:
        rate = self._steps / max(now - self._clock, 1e-9)
        self._bar.set_postfix_str(f"dt={dt:.2e} s, {rate:.1f} steps/s", refresh=False)
        self._bar.update(t - self._t)
        self._t = t
        self._steps = 0
        self._clock = now

    def close(self) -> None:
        """Draw the last state noted (updates in the final 0.2 s were not drawn) and close."""
        if self._bar is None:
            return
        if self._last is not None and self._last[0] != self._t:
            self._draw(*self._last, time.perf_counter())
        self._bar.close()
        self._bar = None
