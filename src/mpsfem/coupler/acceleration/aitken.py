"""Aitken dynamic relaxation (Irons-Tuck / Kuettler-Wall form, as in preCICE).

omega_k = -omega_{k-1} (r_{k-1} . (r_k - r_{k-1})) / |r_k - r_{k-1}|^2, x_next = x + omega_k r_k.
The first iteration of a window uses sign(omega) min(initial_relaxation, |omega|) of the last
factor of the previous window (preCICE's choice).

``relaxation_bounds = [lo, hi]`` clips every factor into [lo, hi] (Kratos' CoSimulation Aitken
clips into [-2, 20]; preCICE does not clip, nor does the default here). With lo > 0 it stops
the factor's collapse: the factor is the old one times the projection of the residual on its
change over the change's squared length (with the sign reversed), so where the change is not
along the residual (a map whose modes converge at very different rates and are not orthogonal,
or one that is not smooth) it falls toward zero, often alternating in sign; the next steps are
smaller, the iterate stands still, and so do its residual and force error until the window's
iterations run out. Traced on the light members under MPS: factors below 1e-2 from the 40th
iteration (the obstacle at mass ratio 1e-4), down to 1e-7 in the light plate's stalled windows
(docs/coupler.md, "Aitken's collapse").
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field, field_validator

from mpsfem.coupler.acceleration.base import Acceleration, relax
from mpsfem.scenario.base import Section


class AitkenParams(Section):
    """Aitken dynamic under-relaxation."""

    kind: Literal["aitken"] = Field(description='"aitken".')
    initial_relaxation: float = Field(
        0.5,
        gt=0,
        le=1,
        description="Relaxation factor of the first iteration of the first window, in (0, 1].",
    )
    relaxation_bounds: list[float] | None = Field(
        None,
        description=(
            "[lo, hi], lo < hi, hi > 0: every factor is clipped into this interval; none "
            "(the default, as preCICE) leaves it free. A lower bound above zero (e.g. [0.05, "
            "1.5]) keeps the factor from collapsing to zero where the residual's change is not "
            "along the residual (modes of very different rates, or a map that is not smooth), "
            "and forbids negative factors (docs/coupler.md, section Aitken's collapse)."
        ),
    )

    @field_validator("relaxation_bounds")
    @classmethod
    def _an_interval(cls, v: list[float] | None) -> list[float] | None:
        if v is None:
            return v
        if len(v) != 2 or not all(math.isfinite(b) for b in v):
            raise ValueError("must be two finite numbers [lo, hi]")
        lo, hi = v
        if not lo < hi or hi <= 0.0:
            raise ValueError(f"[{lo:g}, {hi:g}]: needs lo < hi and hi > 0")
        return [float(lo), float(hi)]


class Aitken(Acceleration):
    kind = "aitken"
    Params = AitkenParams

    def __init__(self, params=None) -> None:
        super().__init__(params)
        self.omega = self.params.initial_relaxation
        self._r_prev: np.ndarray | None = None

    def start_window(self) -> None:
        super().start_window()
        self._r_prev = None

    def _compute(self, x, x_tilde, secondary):
        r = x_tilde - x
        if self._r_prev is None:
            w0 = self.params.initial_relaxation
            self.omega = math.copysign(min(w0, abs(self.omega)), self.omega)
        else:
            dr = r - self._r_prev
            den = float(dr @ dr)
            if den > 0.0:
                self.omega = -self.omega * float(self._r_prev @ dr) / den
        bounds = self.params.relaxation_bounds
        if bounds is not None:  # the factor applied, and the next one's recursion, clipped
            self.omega = min(max(self.omega, bounds[0]), bounds[1])
        self._r_prev = r
        return relax(self.omega, x, x_tilde, secondary)

    def state_dict(self):
        return {"omega": self.omega}

    def load_state_dict(self, state):
        self.omega = float(state["omega"])
