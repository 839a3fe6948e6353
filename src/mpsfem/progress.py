"""Terminal progress bar over simulated time (quiet when the output is not a terminal)."""

from __future__ import annotations

import sys
import time

from tqdm import tqdm


class Progress:
    """Shows simulated time, dt, steps/s and the ETA; a no-op unless stderr is a terminal."""

    def __init__(self, t0: float, t_end: float, enabled: bool = True, label: str = "run") -> None:
        self._on = enabled and sys.stderr.isatty()
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
        if self._bar is None:
            return
        now = time.perf_counter()
        if now - self._clock < 0.2:
            return
        self._draw(t, dt, now)

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
