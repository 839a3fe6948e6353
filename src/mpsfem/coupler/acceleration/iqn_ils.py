"""IQN-ILS: interface quasi-Newton with an inverse Jacobian from least squares (Degroote et al.
2009), in preCICE's form.

With r = x_tilde - x, every iteration after the first of a window adds the columns
v = r_k - r_{k-1} to V and w = x_tilde_k - x_tilde_{k-1} to W (newest first), the accepted last
one too (:meth:`IQNILS.iterations_converged`, as preCICE's ``iterationsConverged``). The next iterate is
x_{k+1} = x_tilde_k + W alpha with alpha = argmin |V alpha + r_k|, solved by a QR decomposition of
V. For a linear fixed point of dimension n the residual vanishes after at most n + 1 iterations.

* Reuse: the columns of the last ``reuse_windows`` converged windows are kept, so a new window
  starts with a Jacobian estimate (the first iteration is then a quasi-Newton step, not a
  relaxation step).
* Filter: near-dependent columns make the least-squares problem ill-conditioned; they are removed
  (permanently) before each solve. "QR2": a column whose part orthogonal to the newer columns is
  below ``filter_limit`` times its norm is dropped; "QR1": a column whose |R_ii| is below
  ``filter_limit`` times the Frobenius norm of R is dropped (preCICE's QR1/QR2 filters).
* ``max_columns`` caps the number of columns (oldest dropped first), and so does the interface
  size: V never has more columns than rows.
* Secondary data (the velocity) follow x_{k+1} = x_tilde_k + W_s alpha with their own W_s.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field
from scipy.linalg import solve_triangular

from mpsfem.coupler.acceleration.base import Acceleration, relax
from mpsfem.scenario.base import Section

_DEFAULT_LIMIT = {"QR1": 1e-6, "QR2": 1e-2, "none": 0.0}


class IQNILSParams(Section):
    """Quasi-Newton inverse least squares."""

    kind: Literal["iqn-ils"] = Field(description='"iqn-ils".')
    initial_relaxation: float = Field(
        0.1,
        gt=0,
        le=1,
        description=(
            "Relaxation factor of an iteration with no columns yet (first iteration of the first "
            "window, or of every window when reuse_windows = 0), in (0, 1]."
        ),
    )
    reuse_windows: int = Field(
        8,
        ge=0,
        description="Number of past converged windows whose columns are kept (>= 0).",
    )
    max_columns: int = Field(
        100, ge=1, description="Most columns kept in V and W (>= 1); the oldest go first."
    )
    filter: Literal["QR1", "QR2", "none"] = Field(
        "QR2",
        description='Filter for near-dependent columns: "QR1", "QR2" (preCICE) or "none".',
    )
    filter_limit: float | None = Field(
        None,
        gt=0,
        lt=1,
        description="Filter threshold in (0, 1). Default: 1e-2 for QR2, 1e-6 for QR1.",
    )


class IQNILS(Acceleration):
    kind = "iqn-ils"
    Params = IQNILSParams

    def __init__(self, params=None) -> None:
        super().__init__(params)
        p = self.params
        self.limit = p.filter_limit if p.filter_limit is not None else _DEFAULT_LIMIT[p.filter]
        self.window = 0
        # columns, newest first; tags hold the window each column was made in
        self.V: list[np.ndarray] = []
        self.W: list[np.ndarray] = []
        self.Ws: dict[str, list[np.ndarray]] = {}
        self.tags: list[int] = []
        self._prev: tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]] | None = None
        self.filtered = 0  # columns removed by the filter so far

    # ------------------------------------------------------------------ window logic
    def start_window(self) -> None:
        super().start_window()
        self._prev = None
        keep = [k for k, t in enumerate(self.tags) if t >= self.window - self.params.reuse_windows]
        self._select(keep)

    def iterations_converged(self, x, x_tilde, secondary=None) -> None:
        """Add the last iteration's differences to V and W, as preCICE does when a window's
        iterations converge (the accepted iterate's residual is secant information like any
        other; the filter and the reuse window act on it as on the others)."""
        if self._prev is not None:
            x = np.asarray(x, dtype=np.float64)
            x_tilde = np.asarray(x_tilde, dtype=np.float64)
            st = {k: np.asarray(v[1], dtype=np.float64) for k, v in dict(secondary or {}).items()}
            self._add_column(x_tilde - x, x_tilde, st)
        self._prev = None

    def end_window(self) -> None:
        self.window += 1

    def _select(self, keep: list[int]) -> None:
        self.V = [self.V[k] for k in keep]
        self.W = [self.W[k] for k in keep]
        self.Ws = {n: [cols[k] for k in keep] for n, cols in self.Ws.items()}
        self.tags = [self.tags[k] for k in keep]

    # ------------------------------------------------------------------ iteration
    def _compute(self, x, x_tilde, secondary):
        r = x_tilde - x
        st = {k: np.asarray(v[1], dtype=np.float64) for k, v in secondary.items()}
        if self._prev is not None:
            self._add_column(r, x_tilde, st)
        self._prev = (r, x_tilde.copy(), {k: v.copy() for k, v in st.items()})
        Q, R = self._qr()
        if Q is None:
            return relax(self.params.initial_relaxation, x, x_tilde, secondary)
        alpha = solve_triangular(R, -(Q.T @ r))
        x_next = x_tilde + np.stack(self.W, axis=1) @ alpha
        sec = {}
        for k, (_, s_t) in secondary.items():
            cols = self.Ws.get(k)
            sec[k] = np.asarray(s_t, dtype=np.float64) + np.stack(cols, axis=1) @ alpha
        return x_next, sec

    def _add_column(self, r: np.ndarray, x_tilde: np.ndarray, st: dict[str, np.ndarray]) -> None:
        """Insert the differences to the previous iteration (newest first), capped at
        ``max_columns``."""
        r0, xt0, st0 = self._prev
        self.V.insert(0, r - r0)
        self.W.insert(0, x_tilde - xt0)
        for k in st:
            self.Ws.setdefault(k, [np.zeros_like(st[k]) for _ in self.tags]).insert(
                0, st[k] - st0[k]
            )
        self.tags.insert(0, self.window)
        if len(self.V) > self.params.max_columns:
            self._select(list(range(self.params.max_columns)))

    def _qr(self) -> tuple[np.ndarray | None, np.ndarray]:
        """QR of V (newest column first) after filtering; drops filtered columns for good.

        Householder QR (LAPACK). With the columns in this order |R_jj| is the norm of column j
        orthogonal to the newer ones, which is what QR2 compares with the column's norm; QR1
        compares it with the Frobenius norm of R. The first failing column is removed and the
        QR recomputed, until none fails. Columns beyond the interface size (more than V has
        rows) are dependent by construction and their R would not be square: the oldest go."""
        if self.V and len(self.V) > self.V[0].size:
            self._select(list(range(self.V[0].size)))
        while self.V:
            Vm = np.stack(self.V, axis=1)
            Q, R = np.linalg.qr(Vm, mode="reduced")
            diag = np.abs(np.diag(R))
            norms = np.linalg.norm(Vm, axis=0)
            if self.params.filter == "QR2":
                bad = diag < self.limit * norms
            elif self.params.filter == "QR1":
                bad = diag < self.limit * np.linalg.norm(R)
            else:
                bad = diag == 0.0
            bad |= norms == 0.0
            if not bad.any():
                return Q, R
            drop = int(np.argmax(bad))
            self.filtered += 1
            self._select([k for k in range(len(self.V)) if k != drop])
        return None, np.zeros((0, 0))

    # ------------------------------------------------------------------ restart
    def state_dict(self):
        return {
            "window": self.window,
            "tags": np.array(self.tags, dtype=np.int64),
            "V": np.array(self.V),
            "W": np.array(self.W),
            **{f"Ws/{k}": np.array(v) for k, v in self.Ws.items()},
        }

    def load_state_dict(self, state):
        self.window = int(state["window"])
        self.tags = [int(t) for t in state["tags"]]
        self.V = [np.array(c) for c in state["V"]]
        self.W = [np.array(c) for c in state["W"]]
        self.Ws = {k[3:]: [np.array(c) for c in v] for k, v in state.items() if k.startswith("Ws/")}
        self._prev = None
