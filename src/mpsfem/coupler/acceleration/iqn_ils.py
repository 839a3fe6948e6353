"""IQN-ILS: interface quasi-Newton with an inverse Jacobian from least squares (Degroote et al.
2009), in preCICE's form.

The columns V, W (:mod:`.quasi_newton`: residual and answer differences, newest first, the
accepted last iteration's too, kept for ``reuse_windows`` windows, filtered) give the next iterate

    x_{k+1} = x_tilde_k + W alpha,  alpha = argmin |P (V alpha + r_k)|

(Degroote et al. 2009, the IQN-ILS step; P the per-field weights of :mod:`.preconditioner`), solved by the
QR decomposition of P V. For a linear fixed point of dimension n the residual vanishes after at
most n + 1 iterations. Secondary data (the velocity) follow x_{k+1} = x_tilde_k + W_s alpha with
their own W_s. With no columns (first iteration of the first window, or of every window when
``reuse_windows = 0``) the step is a relaxation with ``initial_relaxation``.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field
from scipy.linalg import solve_triangular

from mpsfem.coupler.acceleration.quasi_newton import PRIMARY, QuasiNewton, QuasiNewtonParams


class IQNILSParams(QuasiNewtonParams):
    """Quasi-Newton inverse least squares."""

    kind: Literal["iqn-ils"] = Field(description='"iqn-ils".')


class IQNILS(QuasiNewton):
    kind = "iqn-ils"
    Params = IQNILSParams

    def _update(self, Q, R, r, bases):
        if Q is None:
            return None
        alpha = solve_triangular(R, -(Q.T @ self.scaled(r)))  # Degroote et al. 2009, IQN-ILS step
        # x_{k+1} = x_tilde_k + W alpha, the same alpha for every field
        out = {f: base + self.columns(f) @ alpha for f, base in bases.items()}
        return out.pop(PRIMARY), out
