"""Output cadence on a fixed time grid: samples due at k x interval, never drifting.

A sample is taken at the first step at or after each grid time k x interval, and is recorded at
the step's true time. Scheduling the next sample at t_last + interval instead lets every step's
overshoot accumulate: a dam break with 2 ms probes and ~1.2 ms steps gave 141 samples in 0.3 s
instead of 151, with gaps up to 2.95 ms. The grid does not touch the time steps, so stored runs
keep their dt sequence.
"""

from __future__ import annotations

import math

#: relative slack of a grid time: a step that lands within this fraction of an interval before
#: a grid time takes that sample (float round-off of t = sum of dt)
GRID_SLACK = 1e-9


def next_due(t: float, interval: float) -> float:
    """The first grid time k x ``interval`` (s) after a sample taken at ``t`` (s).

    ``interval`` <= 0 means every step: the next sample is due at ``t`` itself."""
    if interval <= 0.0:
        return t
    k = math.floor(t / interval + GRID_SLACK) + 1
    return k * interval


def is_due(t: float, due: float, interval: float) -> bool:
    """Whether a step ending at ``t`` (s) takes the sample due at ``due`` (s)."""
    return t >= due - GRID_SLACK * max(interval, 1e-300) - 1e-15


def take_sample(
    last: dict[str, float], key: str, t: float, due_at: float, interval: float, force: bool
) -> tuple[bool, bool]:
    """Whether the series ``key`` takes a sample at ``t`` (s), and whether that sample is off
    its grid (taken only because ``force`` asks for the final state). A series never samples
    twice at one time; ``last`` (key -> time of its last sample) is updated when it does."""
    if last.get(key) == t:
        return False, False
    due = is_due(t, due_at, interval)
    if not (due or force):
        return False, False
    last[key] = t
    return True, not due
