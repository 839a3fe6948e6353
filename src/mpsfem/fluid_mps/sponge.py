"""Sponge layers that absorb waves at the ends of a numerical tank (thesis ch. 3.2, eq. 3-9).

Inside a zone the momentum equation gets the source term

    f_s = -rho alpha_s (x - x_s) / L_s u        (thesis eq. 3-9; 0 outside the zone)

with x_s the inner edge (``start``), L_s the zone length and alpha_s (1/s) the coefficient
(thesis: 50). Our reading, where the thesis leaves it open (docs/wave_tank.md):

- f_s is a force per unit volume, so the acceleration it adds is -alpha_s r u with
  r = (x - x_s) / L_s in [0, 1] the depth into the zone: 0 at the inner edge, 1 at the outer edge
  ``end``; a zone at the low end of an axis (end < start) counts r from its inner edge the same way;
- u is the whole velocity vector (every component is damped);
- outside [start, end] (including past the outer edge) the source is 0; overlapping zones add;
- it enters the explicit prediction stage like gravity and viscosity (explicit Euler, thesis
  eq. 2-24): u <- u (1 - dt sum_zones alpha_s r), evaluated at the positions of time n.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numba import njit, prange

from mpsfem.scenario.fluid import SpongeZone


@njit(cache=True, parallel=True)
def damp_velocity(pos, vel, n_fluid, dt, axis, start, inv_length, coefficient):
    """u_i *= 1 - dt sum_z alpha_z r_z(x_i) for the fluid particles i < n_fluid (thesis eq. 3-9,
    explicit Euler); r_z = (x - start_z) / (end_z - start_z) where it lies in [0, 1], else 0.
    ``inv_length`` = 1 / (end - start), signed; per-zone arrays of equal length."""
    dim = vel.shape[1]
    n_zones = axis.shape[0]
    for i in prange(n_fluid):
        rate = 0.0
        for z in range(n_zones):
            r = (pos[i, axis[z]] - start[z]) * inv_length[z]
            if 0.0 <= r <= 1.0:
                rate += coefficient[z] * r  # alpha_s (x - x_s) / L_s, thesis eq. 3-9
        if rate > 0.0:
            factor = 1.0 - dt * rate
            for a in range(dim):
                vel[i, a] *= factor


class SpongeLayer:
    """All sponge zones of the fluid, applied in one pass per time step (no allocation)."""

    def __init__(self, spec: SpongeZone | Sequence[SpongeZone], dim: int) -> None:
        """``spec``: one zone or the list ``fluid.sponges``; ``dim``: space dimension."""
        zones = [spec] if isinstance(spec, SpongeZone) else list(spec)
        for i, z in enumerate(zones):
            if not 0 <= z.axis < dim:
                raise ValueError(f"fluid.sponges[{i}].axis = {z.axis}: must be below dim = {dim}")
            if z.end == z.start:
                raise ValueError(f"fluid.sponges[{i}]: start = end = {z.start}; needs a length")
        self.zones = zones
        self.dim = dim
        self.axis = np.array([z.axis for z in zones], dtype=np.int32)
        self.start = np.array([z.start for z in zones], dtype=np.float64)
        self.inv_length = np.array([1.0 / (z.end - z.start) for z in zones], dtype=np.float64)
        self.coefficient = np.array([z.coefficient for z in zones], dtype=np.float64)
        self.max_rate = float(self.coefficient.sum())  # bound of sum alpha_s r

    @property
    def active(self) -> bool:
        return len(self.zones) > 0

    def apply(self, pos: np.ndarray, vel: np.ndarray, n_fluid: int, dt: float) -> None:
        """Damp ``vel`` (m/s, (N, dim), in place) of the fluid particles ``0 .. n_fluid - 1`` at
        positions ``pos`` (m) over one step ``dt`` (s). Needs dt sum(alpha_s) <= 1 (the explicit
        factor stays in [0, 1]); with alpha_s = 50 that is dt <= 0.02 s."""
        if not self.zones:
            return
        if dt * self.max_rate > 1.0:
            raise ValueError(
                f"sponge: dt = {dt:.3g} s times the summed coefficients {self.max_rate:.3g} 1/s "
                "exceeds 1; the explicit damping factor 1 - dt alpha_s r would turn negative"
            )
        damp_velocity(
            pos, vel, n_fluid, dt, self.axis, self.start, self.inv_length, self.coefficient
        )
