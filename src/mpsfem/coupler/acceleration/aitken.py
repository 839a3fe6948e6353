"""Aitken dynamic relaxation (Irons-Tuck / Kuettler-Wall form, as in preCICE).

omega_k = -omega_{k-1} (r_{k-1} . (r_k - r_{k-1})) / |r_k - r_{k-1}|^2, x_next = x + omega_k r_k.
The first iteration of a window uses sign(omega) min(initial_relaxation, |omega|) of the last
factor of the previous window (preCICE's choice).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field

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
        self._r_prev = r
        return relax(self.omega, x, x_tilde, secondary)

    def state_dict(self):
        return {"omega": self.omega}

    def load_state_dict(self, state):
        self.omega = float(state["omega"])
