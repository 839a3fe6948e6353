"""Convergence measure of implicit coupling and divergence detection.

Residual of iteration k: r = x_tilde - x, the difference between the structure's answer and the
interface displacement the fluid was driven with (structure nodes, all components). Norms are
root-mean-square over the entries, so tolerances do not depend on the number of nodes:

    residual = |r|_rms / max(|s|_rms, absolute_tolerance / relative_tolerance)

and the window has converged when residual <= relative_tolerance (and at least min_iterations
were done). Equivalently |r|_rms <= max(rtol |s|_rms, atol): relative, with an absolute
floor so that a structure at rest (displacement zero) converges too. The scale s is
(``relative_to``):

* ``"displacement"``: x_tilde, the whole interface displacement (preCICE's relative measure);
* ``"window_motion"``: x_tilde - d_n, the interface's motion within the window. A window moves
  the interface by about a percent of its displacement in the slamming cases, so the same rtol
  is then about a hundred times stricter, and the residual's work, the interface work error
  (docs/coupler.md), is bounded relative to the work of the window itself.

With a fictitious mass on the structure, :class:`ForceErrorCriterion` must hold as well.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mpsfem.coupler.errors import CouplingDivergedError


def rms(a: np.ndarray) -> float:
    """Root mean square of all entries (0 for an empty array)."""
    a = np.asarray(a, dtype=np.float64).reshape(-1)
    return math.sqrt(float(a @ a) / a.size) if a.size else 0.0


@dataclass(frozen=True)
class ResidualCriterion:
    """relative_tolerance, absolute_tolerance (m), min/max iterations per window."""

    relative_tolerance: float = 1e-4
    absolute_tolerance: float = 1e-10
    min_iterations: int = 1
    max_iterations: int = 50
    relative_to: str = "displacement"

    def __post_init__(self) -> None:
        if not self.relative_tolerance > 0 or not self.absolute_tolerance > 0:
            raise ValueError("relative_tolerance and absolute_tolerance must be > 0")
        if not 1 <= self.min_iterations <= self.max_iterations:
            raise ValueError(
                f"need 1 <= min_iterations ({self.min_iterations}) <= max_iterations "
                f"({self.max_iterations})"
            )
        if self.relative_to not in ("displacement", "window_motion"):
            raise ValueError(
                f"relative_to = {self.relative_to!r}: allowed 'displacement', 'window_motion'"
            )

    @classmethod
    def from_section(cls, sec) -> ResidualCriterion:
        return cls(
            sec.relative_tolerance,
            sec.absolute_tolerance,
            sec.min_iterations,
            sec.max_iterations,
            sec.relative_to,
        )

    def measure(
        self, x: np.ndarray, x_tilde: np.ndarray, x_start: np.ndarray | None = None
    ) -> tuple[float, float]:
        """(relative residual as defined above, |r|_rms in m); ``x_start``: the displacement at
        the window's start d_n (needed for ``relative_to = "window_motion"``)."""
        x_tilde = np.asarray(x_tilde)
        r_abs = rms(x_tilde - np.asarray(x))
        floor = self.absolute_tolerance / self.relative_tolerance
        if self.relative_to == "window_motion":
            if x_start is None:
                raise ValueError("relative_to = 'window_motion' needs the window's start x_start")
            scale = rms(x_tilde - np.asarray(x_start))
        else:
            scale = rms(x_tilde)
        return r_abs / max(scale, floor), r_abs

    def converged(self, residual: float, iterations: int) -> bool:
        """True if ``residual`` (relative) meets the tolerance after ``iterations`` iterations."""
        return iterations >= self.min_iterations and residual <= self.relative_tolerance


@dataclass(frozen=True)
class ForceErrorCriterion:
    """The fictitious force error of a structure with a fictitious mass (issue 21;
    structure_fem.fictitious_mass): in iteration k the structure solves (M + M_f) a^k + C v + K u
    = F^k + M_f a^{k-1}, so its true equation M a + C v + K u = F^k is off by the force e =
    M_f (a^{k-1} - a^k). The displacement residual does not bound e (with a large M_f the
    structure moves little while e is large), so a window is converged only when, in every
    sub-step,

        rms(e) <= max(tolerance * max(S, S_peak), floor * A)

    S the largest rms interface load on the dofs M_f acts on in the window, S_peak the largest
    S of the run's accepted windows so far (the scheme's ``force_scale_peak``), A the rms
    tributary length or area of those dofs' nodes (m; m^2), ``floor`` a pressure (Pa). The
    member then answers a load within that fraction of the one the fluid exerts, and its
    response (linear in the load) is within about that fraction of its response to the largest
    load so far. S_peak keeps a window with little load (water leaving the member) from being
    held to a fraction of its own noise, as the displacement criterion's scale is the whole
    displacement, not the window's; the floor does the same before the first real load (an MPS
    member near the free surface feels loads of order 1e-4 Pa that change from iterate to
    iterate, and 1 % of them cannot be converged). ``tolerance`` None: off. The structure
    reports (max rms(e), S, A) through its optional ``fictitious_force_error()`` hook; None
    from it (no fictitious mass acting) passes."""

    tolerance: float | None = 1e-2
    floor: float = 0.01  # Pa

    @classmethod
    def from_section(cls, sec) -> ForceErrorCriterion:
        tol = getattr(sec, "fictitious_force_tolerance", "off")
        floor = float(getattr(sec, "fictitious_force_floor", 0.0))
        return cls(None if tol == "off" else float(tol), floor)

    def measure(self, error: float, scale: float, area: float, peak: float = 0.0) -> float:
        """rms(e) / max(S, S_peak, floor A / tolerance): the force error relative to the load
        scale (0 for no error, inf for an error against no load); converged when <= tolerance."""
        if error == 0.0:
            return 0.0
        ref = max(scale, peak)
        if self.tolerance is not None:
            ref = max(ref, self.floor * area / self.tolerance)
        return error / ref if ref > 0.0 else math.inf

    def converged(self, ratio: float) -> bool:
        return self.tolerance is None or ratio <= self.tolerance


def check_finite(where: str, **arrays: np.ndarray) -> None:
    """Raise :class:`CouplingDivergedError` naming the first array with NaN or inf."""
    for name, a in arrays.items():
        a = np.asarray(a)
        if not np.isfinite(a).all():
            idx = np.argwhere(~np.isfinite(a))[0]
            raise CouplingDivergedError(
                f"{where}: {name} holds non-finite values (first at index {tuple(idx.tolist())}); "
                "the coupling has diverged"
            )


class InstabilityDetector:
    """Detects the added-mass instability of explicit (staggered) coupling.

    Fed the explicit coupling error e_n = x_tilde_n - x_n of every window (the structure's answer
    minus the prediction the fluid was driven with), it looks at the last K windows for
    K in ``spans``: the unstable mode of staggered coupling with a too-light structure oscillates
    near the window frequency (consecutive errors point in opposite directions,
    e_n . e_(n-1) < 0, in at least half of the windows) and grows geometrically, roughly by
    sqrt(m_added / (2 m_structure)) per window. Divergence is reported when the least-squares
    growth of log |e| over the K windows amounts to at least ``factor`` and the latest error is
    above ``floor`` (m, rms). Physical motion resolved by the window changes e smoothly
    (positive dot products) and MPS noise does not grow; neither triggers it. The growth of
    mu = 3 is caught within about 16 windows, mu = 10 within 8.
    """

    def __init__(
        self, spans: tuple[int, ...] = (8, 16, 32, 64), factor: float = 10.0, floor: float = 0.0
    ) -> None:
        self.spans, self.factor, self.floor = tuple(sorted(spans)), factor, floor
        self.reset()

    def reset(self) -> None:
        self._prev: np.ndarray | None = None
        self._log: list[float] = []
        self._neg: list[bool] = []

    def update(self, e: np.ndarray) -> str | None:
        """Feed one window; returns a description if divergence is detected, else None."""
        why = self.check(e)
        self.commit()
        return why

    def check(self, e: np.ndarray) -> str | None:
        """What :meth:`update` would return for ``e``, without recording the window yet: a
        candidate window is recorded by :meth:`commit` only once it is accepted."""
        why, *self._pending = self._assess(e)
        return why

    def commit(self) -> None:
        """Record the window last passed to :meth:`check`."""
        self._prev, self._log, self._neg = self._pending

    def _assess(self, e: np.ndarray) -> tuple[str | None, np.ndarray, list[float], list[bool]]:
        """(description or None, and the history with ``e`` appended)."""
        e = np.array(e, dtype=np.float64).reshape(-1)
        n = rms(e)
        neg = self._prev is not None and float(e @ self._prev) < 0.0
        keep = self.spans[-1]
        log = (self._log + [math.log(max(n, 1e-300))])[-keep:]
        negs = (self._neg + [neg])[-keep:]
        return self._describe(n, log, negs), e, log, negs

    def _describe(self, n: float, log: list[float], negs: list[bool]) -> str | None:
        if n <= self.floor:
            return None
        for k in self.spans:
            if len(log) < k:
                break
            y = np.array(log[-k:])
            j = np.arange(k) - 0.5 * (k - 1)
            growth = float(j @ (y - y.mean()) / (j @ j)) * (k - 1)
            flips = sum(negs[-k + 1 :]) / (k - 1)
            if growth >= math.log(self.factor) and flips >= 0.5:
                return (
                    f"the explicit coupling error oscillates from window to window and has grown "
                    f"{math.exp(growth):.3g}-fold over the last {k} windows (now {n:.3g} m rms)"
                    " — the added-mass instability of staggered coupling"
                )
        return None
