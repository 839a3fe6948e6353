"""Residual scaling per exchanged field for the quasi-Newton least squares (preCICE's
preconditioners).

The quasi-Newton residual concatenates fields of different units (displacement in m, velocity in
m/s); unscaled, min |V alpha + r| fits the field with the largest numbers and ignores the others,
and the QR filter then drops columns that only differ there. A preconditioner gives every entry
of field k the weight w_k, and the least squares is solved for P V, P r with P = diag(w):

* ``"none"``: w_k = 1.
* ``"value"``: w_k = 1 / |x_tilde_k| (the field's values), set at every iteration of the first
  window and at every window end (preCICE's ValuePreconditioner).
* ``"residual_sum"``: w_k = 1 / sum_i |r_k,i| / |r_i| (i the window's iterations so far, r_i the
  whole residual), reset only when a weight moves by more than a factor of 10 after the first
  window (preCICE's ResidualSumPreconditioner with its update-on-threshold rule).

Scaling one field by a constant c then scales its weight by 1 / c: the scaled least squares,
and so every iterate, is the same (up to round-off), whatever units the field is written in.
Weights only rescale rows; a field whose norm is zero (or not finite) keeps its last weight.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

PreconditionerKind = Literal["none", "value", "residual_sum"]

#: a field norm at or below this counts as zero (weights left as they were)
_ZERO = 1e-300


class Preconditioner:
    """Row weights of the concatenated residual; ``sizes`` are the fields' entry counts."""

    kind: str = "none"

    def __init__(self, sizes: list[int]) -> None:
        self.sizes = [int(s) for s in sizes]
        self.offsets = np.r_[0, np.cumsum(self.sizes)].astype(int)
        self.field_weights = np.ones(len(self.sizes))
        self.first_window = True
        self.changed = False  # weights moved since the caller last looked

    @property
    def active(self) -> bool:
        """False when the weights cannot change the least squares: the identity, or a single
        field (one weight scales the whole problem, which moves neither the solution nor the
        relative QR filters); the caller then skips the multiplications."""
        return self.kind != "none" and len(self.sizes) > 1

    @property
    def weights(self) -> np.ndarray:
        """Per-entry weights, (sum(sizes),)."""
        return np.repeat(self.field_weights, self.sizes)

    def parts(self, vec: np.ndarray) -> list[np.ndarray]:
        """The fields' segments of a concatenated vector."""
        return [vec[a:b] for a, b in zip(self.offsets[:-1], self.offsets[1:], strict=True)]

    def update(self, window_complete: bool, values: np.ndarray, residual: np.ndarray) -> None:
        """After an iteration (``window_complete`` False) or at a window end (True), with the
        fields' current values x_tilde and residual r (concatenated, unscaled)."""
        if window_complete:
            self.first_window = False

    def state_dict(self) -> dict:
        return {"weights": self.field_weights.copy(), "first_window": int(self.first_window)}

    def load_state_dict(self, state: dict) -> None:
        if "weights" in state:
            self.field_weights = np.array(state["weights"], dtype=np.float64)
            self.first_window = bool(state["first_window"])


class ValuePreconditioner(Preconditioner):
    """w_k = 1 / |x_tilde_k|: every iteration of the first window, then at window ends."""

    kind = "value"

    def update(self, window_complete, values, residual):
        if window_complete or self.first_window:
            for k, part in enumerate(self.parts(values)):
                norm = float(np.linalg.norm(part))
                if _ZERO < norm < np.inf:
                    self.field_weights[k] = 1.0 / norm  # preCICE ValuePreconditioner: 1/|x_k|
            self.changed = True
        super().update(window_complete, values, residual)


class ResidualSumPreconditioner(Preconditioner):
    """w_k = 1 / sum_i |r_k,i| / |r_i| over the window's iterations, reset on a factor-10 move."""

    kind = "residual_sum"

    def __init__(self, sizes):
        super().__init__(sizes)
        self.sum = np.zeros(len(self.sizes))
        self.previous = np.zeros(len(self.sizes))

    def update(self, window_complete, values, residual):
        if window_complete:
            self.sum[:] = 0.0
            super().update(window_complete, values, residual)
            return
        norms = np.array([np.linalg.norm(p) for p in self.parts(residual)])
        total = float(np.linalg.norm(norms))
        if _ZERO < total < np.inf:  # a non-finite residual stops the scheme; keep the weights
            self.sum += norms / total  # preCICE ResidualSumPreconditioner: sum_i |r_k,i| / |r_i|
        live = self.sum > _ZERO
        reset = self.first_window
        if not reset:
            ratio = self.previous[live] / self.sum[live]
            reset = bool(np.any((ratio > 10.0) | (ratio < 0.1)))
        if reset:
            self.field_weights[live] = 1.0 / self.sum[live]
            self.previous[live] = self.sum[live]
            self.changed = True

    def state_dict(self):
        return {**super().state_dict(), "sum": self.sum.copy(), "previous": self.previous.copy()}

    def load_state_dict(self, state):
        super().load_state_dict(state)
        if "sum" in state:
            self.sum = np.array(state["sum"], dtype=np.float64)
            self.previous = np.array(state["previous"], dtype=np.float64)


PRECONDITIONERS: dict[str, type[Preconditioner]] = {
    "none": Preconditioner,
    "value": ValuePreconditioner,
    "residual_sum": ResidualSumPreconditioner,
}


def create_preconditioner(kind: str, sizes: list[int]) -> Preconditioner:
    """The preconditioner called ``kind`` for fields of ``sizes`` entries."""
    return PRECONDITIONERS[kind](sizes)
