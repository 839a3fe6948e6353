"""Constant under-relaxation: x_next = x + omega (x_tilde - x)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from mpsfem.coupler.acceleration.base import Acceleration, relax
from mpsfem.scenario.base import Section


class ConstantParams(Section):
    """Constant under-relaxation."""

    kind: Literal["constant"] = Field(description='"constant".')
    relaxation: float = Field(
        0.5,
        gt=0,
        le=1,
        description=(
            "Relaxation factor omega in (0, 1]. For an added-mass problem with fixed-point "
            "eigenvalues -mu (mu = added / structure mass) the iteration converges only for "
            "omega < 2 / (1 + mu)."
        ),
    )


class ConstantRelaxation(Acceleration):
    kind = "constant"
    Params = ConstantParams

    def _compute(self, x, x_tilde, secondary):
        return relax(self.params.relaxation, x, x_tilde, secondary)
