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
        self._steps += 1
        if self._bar is None:
            return
        now = time.perf_counter()
        if now - self._clock < 0.2:
            return
        rate = self._steps / (now - self._clock)
        self._bar.set_postfix_str(f"dt={dt:.2e} s, {rate:.1f} steps/s", refresh=False)
        self._bar.update(t - self._t)
        self._t = t
        self._steps = 0
        self._clock = now

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
