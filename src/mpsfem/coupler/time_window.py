"""Coupling windows: sub-cycling that lands exactly on window ends, and interpolation inside.

A coupling window [t_n, t_n + T] is the interval between two data exchanges; by default T is the
structure's time step. Inside a window each participant sub-cycles: the remaining time is split
into n = ceil(remaining / max_dt) *equal* sub-steps, re-planned before every sub-step because
the fluid's max_dt adapts (CFL). So a participant never takes a tiny last step (the MPS pressure
equation's source term scales with 1/dt^2) and the last sub-step ends exactly on the window end.
A window shorter than the structure's dt gives one structure step of length T; a longer one
sub-cycles the structure the same way.

Inputs at a sub-step end t are interpolated linearly between the window's start and end values,
theta = (t - t_n) / T; the window end itself gets the end value bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from mpsfem.coupler.errors import CouplingError

#: relative slack when deciding that a window is covered or that T / max_dt is an integer
TIME_EPS = 1e-9


def plan_substeps(remaining: float, max_dt: float) -> tuple[int, float]:
    """(n, dt): n = ceil(remaining / max_dt) equal sub-steps of dt = remaining / n.

    A ratio within TIME_EPS above an integer counts as that integer (no extra step for
    round-off)."""
    if not remaining > 0:
        raise ValueError(f"remaining time {remaining} must be > 0")
    if not (max_dt > 0 and math.isfinite(max_dt)):
        raise CouplingError(f"participant reported max_dt = {max_dt}; it must be > 0 and finite")
    n = max(1, math.ceil(remaining / max_dt * (1.0 - TIME_EPS)))
    return n, remaining / n


def interpolate(start: np.ndarray, end: np.ndarray, theta: float) -> np.ndarray:
    """start + theta (end - start); exact copies at theta <= 0 and theta >= 1."""
    if theta >= 1.0:
        return np.array(end, dtype=np.float64, copy=True)
    if theta <= 0.0:
        return np.array(start, dtype=np.float64, copy=True)
    return start + theta * (end - start)


def subcycle(
    advance: Callable[[float], float],
    max_dt: Callable[[], float],
    t_start: float,
    t_end: float,
    before: Callable[[float, float], None] | None = None,
    after: Callable[[float, float], None] | None = None,
    who: str = "participant",
) -> int:
    """Advance a participant from ``t_start`` to exactly ``t_end``; returns the sub-step count.

    Before every sub-step ``before(t_next, dt)`` writes the inputs for the sub-step end, then
    ``advance(dt)`` runs, then ``after(t_now, dt_done)``. A participant that advances less than
    asked (``dt_done < dt``) is allowed; the rest of the window is re-planned from where it is.
    """
    length = t_end - t_start
    if not length > 0:
        raise ValueError(f"empty window [{t_start}, {t_end}]")
    t = t_start
    steps = 0
    while t_end - t > TIME_EPS * length:
        n, dt = plan_substeps(t_end - t, max_dt())
        t_next = t_end if n == 1 else t + dt
        dt = t_next - t
        if before is not None:
            before(t_next, dt)
        done = float(advance(dt))
        if not (done > 0.0 and done <= dt * (1.0 + TIME_EPS)):
            raise CouplingError(
                f"{who}.advance({dt:.6g}) returned {done!r}; it must advance by a time in "
                f"(0, {dt:.6g}]"
            )
        t = t_next if done >= dt * (1.0 - TIME_EPS) else t + done
        steps += 1
        if after is not None:
            after(t, done)
        if steps > 10_000_000:
            raise CouplingError(f"{who} needs more than 1e7 sub-steps for one window")
    return steps


def window_ends(t0: float, window: float, end_time: float) -> np.ndarray:
    """Window end times from ``t0`` to ``end_time``: t0 + k T, the last one clipped to
    ``end_time`` (a final window shorter than T only if end_time is not a multiple of T)."""
    if not window > 0:
        raise ValueError(f"window {window} must be > 0")
    n = max(1, math.ceil((end_time - t0) / window * (1.0 - TIME_EPS)))
    ends = t0 + window * np.arange(1, n + 1, dtype=np.float64)
    ends[-1] = end_time
    return ends
