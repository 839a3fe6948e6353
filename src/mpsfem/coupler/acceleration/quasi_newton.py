"""What every interface quasi-Newton method shares (preCICE's BaseQNAcceleration).

The residual the least squares sees concatenates the fields in ``data``: the primary
displacement r_x = x_tilde - x and, with ``data = ["displacement", "velocity"]``, the velocity
r_s = s_tilde - s (preCICE's several data in one acceleration). Every iteration after the first
of a window adds the columns (newest first)

    v = r_k - r_{k-1}                (V: residual differences, the fields in ``data``)
    w_f = x_tilde_f,k - x_tilde_f,k-1  (W_f: answer differences, every field f, primary and
                                       secondary, so all fields follow the same update)

and the accepted last iteration too (:meth:`QuasiNewton.iterations_converged`, preCICE's
``iterationsConverged``). The columns of the last ``reuse_windows`` windows are kept,
``max_columns`` caps them (oldest first), and V never has more columns than rows.

``complement_relaxation`` omega_c relaxes the part of the residual the columns cannot explain:
with alpha the least-squares coefficients, the step x_tilde + W alpha of preCICE is
x + (W - V) alpha + (r + V alpha), i.e. a plain fixed-point step (factor 1) on the residual
r + V alpha left outside the span of V. For an added-mass ratio mu the map has eigenvalues down
to about -1.2 mu, so in directions not yet in V every iteration multiplies the error by up to
1.2 mu; omega_c < 2 / (1 + 1.2 mu) keeps those directions contracting. Every field f uses it:
its base x_tilde_f - (1 - omega_c) r_f and columns W_f - (1 - omega_c) V_f (V_f its residual
differences), which is preCICE's scheme for omega_c = 1 (the default).

Before every solve the per-field weights P (:mod:`.preconditioner`) are updated and the QR filter
(:mod:`.qr_filter`) runs on P V; filtered columns are dropped for good. A subclass turns the
filtered QR into the next iterate (:meth:`QuasiNewton._update`): IQN-ILS from the columns alone,
IQN-IMVJ from the columns and a Jacobian carried over from past windows.

Vectors are flat float64 arrays; the primary field is called ``"displacement"`` and the
secondary ones by the names the scheme gives them (``"velocity"``).
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Literal

import numpy as np
from pydantic import Field, field_validator

from mpsfem.coupler.acceleration.base import Acceleration, relax
from mpsfem.coupler.acceleration.preconditioner import (
    Preconditioner,
    PreconditionerKind,
    create_preconditioner,
)
from mpsfem.coupler.acceleration.qr_filter import DEFAULT_LIMIT, filtered_qr
from mpsfem.scenario.base import Section

#: the primary field's name (the scheme's primary data, the interface displacement)
PRIMARY = "displacement"


class QuasiNewtonParams(Section):
    """Keys shared by the quasi-Newton accelerators."""

    kind: str = Field(description="The accelerator (each subclass names its own).")
    initial_relaxation: float = Field(
        0.1,
        gt=0,
        le=1,
        description=(
            "Relaxation factor of an iteration with nothing learnt yet (first iteration of the "
            "first window, or of every window when nothing is carried over), in (0, 1]."
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
    data: list[Literal["displacement", "velocity"]] = Field(
        default_factory=lambda: ["displacement"],
        description=(
            'Fields whose residuals the least squares fits: ["displacement"] (the primary '
            'data only) or ["displacement", "velocity"] (preCICE\'s several data in one '
            "acceleration; then the fields' units differ and a preconditioner matters). The "
            "convergence criterion always measures the displacement."
        ),
    )
    complement_relaxation: float | Literal["auto"] = Field(
        1.0,
        description=(
            "Relaxation of the residual outside the span of the columns, in (0, 1], or "
            '"auto": 1 is preCICE\'s step x_tilde + W alpha; below 2 / (1 + 1.2 mu) (mu = added '
            "/ structure mass) the directions not yet learnt contract instead of growing by up "
            'to 1.2 mu per iteration. "auto": 1 / rho, rho the largest norm(dr) / norm(dx) of any '
            "column so far (the steepest secant slope of the residual, about 1 + 1.2 mu), at most 1 "
            "(docs/coupler.md, added-mass sweep)."
        ),
    )

    @field_validator("complement_relaxation")
    @classmethod
    def _in_unit_interval(cls, v: float | str) -> float | str:
        if v != "auto" and not 0.0 < v <= 1.0:
            raise ValueError("must be in (0, 1] or 'auto'")
        return v

    preconditioner: PreconditionerKind = Field(
        "value",
        description=(
            'Residual scaling per field: "value" (1 / norm of the field\'s values; the default, measured '
            'best with two fields, docs/coupler.md), "residual_sum" (1 / the field\'s summed '
            'share of the residual; preCICE\'s default) or "none". With one field in data it '
            "only rescales the whole least squares (no effect)."
        ),
    )

    @field_validator("data")
    @classmethod
    def _primary_first(cls, v: list[str]) -> list[str]:
        if not v or v[0] != PRIMARY or len(set(v)) != len(v):
            raise ValueError('must start with "displacement" and name each field once')
        return v


class QuasiNewton(Acceleration):
    """Shared quasi-Newton machinery; subclasses implement :meth:`_update`."""

    def __init__(self, params=None) -> None:
        super().__init__(params)
        p = self.params
        self.limit = p.filter_limit if p.filter_limit is not None else DEFAULT_LIMIT[p.filter]
        self.window = 0
        # columns, newest first; tags hold the window each column was made in
        self.V: list[np.ndarray] = []
        self.W: list[np.ndarray] = []  # the primary field's
        self.Ws: dict[str, list[np.ndarray]] = {}  # each secondary field's
        self.Vs: dict[str, list[np.ndarray]] = {}  # each secondary's residual differences
        self.nx = 0  # entries of the primary field
        self.rho = 0.0  # steepest secant slope |dr| / |dx| of any column ("auto" omega_c)
        self.tags: list[int] = []
        # (residual, x_tilde, secondary answers, secondary residuals) of the last iteration
        self._prev: tuple | None = None
        self.filtered = 0  # columns removed by the filter so far
        self.precon: Preconditioner | None = None  # built at the first iteration (sizes)
        self._precon_state: dict | None = None

    # ------------------------------------------------------------------ window logic
    def start_window(self) -> None:
        super().start_window()
        self._prev = None
        keep = [k for k, t in enumerate(self.tags) if t >= self.window - self.params.reuse_windows]
        self._select(keep)

    def restart_window(self) -> None:
        """Drop this window's columns (secant pairs of the map before the change) and its last
        residual; the columns of earlier windows stay as :meth:`start_window` keeps them."""
        self.start_window()
        self._select([k for k, t in enumerate(self.tags) if t != self.window])

    def iterations_converged(self, x, x_tilde, secondary=None) -> None:
        """Add the last iteration's differences to V and W, as preCICE does when a window's
        iterations converge (the accepted iterate's residual is secant information like any
        other; the filter and the reuse window act on it as on the others), then let the
        subclass learn (:meth:`_learn`) and the preconditioner see the window end."""
        x = np.asarray(x, dtype=np.float64)
        x_tilde = np.asarray(x_tilde, dtype=np.float64)
        sec = {k: (np.asarray(a, np.float64), np.asarray(b, np.float64)) for k, (a, b) in
               dict(secondary or {}).items()}  # fmt: skip
        st = {k: v[1] for k, v in sec.items()}
        r = self._residual(x, x_tilde, sec)
        if self._prev is not None:
            self._add_column(r, x_tilde, st, {k: b - a for k, (a, b) in sec.items()})
        self._prev = None
        self._learn()
        if self.precon is not None:
            self.precon.update(True, self._values(x_tilde, st), r)

    def end_window(self) -> None:
        self.window += 1

    def _learn(self) -> None:  # noqa: B027 - optional hook
        """A window's iterations ended (its columns are in V, W): carry knowledge over."""

    def _select(self, keep: list[int]) -> None:
        self.V = [self.V[k] for k in keep]
        self.W = [self.W[k] for k in keep]
        self.Ws = {n: [cols[k] for k in keep] for n, cols in self.Ws.items()}
        self.Vs = {n: [cols[k] for k in keep] for n, cols in self.Vs.items()}
        self.tags = [self.tags[k] for k in keep]

    # ------------------------------------------------------------------ iteration
    def _residual(self, x: np.ndarray, x_tilde: np.ndarray, sec: dict) -> np.ndarray:
        """The concatenated residual of the fields in ``data`` (unscaled)."""
        parts = [x_tilde - x]
        for name in self.params.data[1:]:
            if name not in sec:
                raise KeyError(f"acceleration data names {name!r}, which the scheme does not pass")
            s, s_t = sec[name]
            parts.append(np.asarray(s_t, np.float64) - np.asarray(s, np.float64))
        return parts[0] if len(parts) == 1 else np.concatenate(parts)

    def _values(self, x_tilde: np.ndarray, st: dict[str, np.ndarray]) -> np.ndarray:
        """The concatenated answers x_tilde of the fields in ``data``."""
        if len(self.params.data) == 1:
            return x_tilde
        return np.concatenate([x_tilde, *(st[n] for n in self.params.data[1:])])

    def _compute(self, x, x_tilde, secondary):
        st = {k: np.asarray(v[1], dtype=np.float64) for k, v in secondary.items()}
        rs = {k: st[k] - np.asarray(v[0], dtype=np.float64) for k, v in secondary.items()}
        r = self._residual(x, x_tilde, secondary)
        self.nx = x.size
        if self.precon is None:
            sizes = [x.size] + [st[n].size for n in self.params.data[1:]]
            self.precon = create_preconditioner(self.params.preconditioner, sizes)
            if self._precon_state is not None:
                self.precon.load_state_dict(self._precon_state)
        self.precon.update(False, self._values(x_tilde, st), r)
        if self._prev is not None:
            self._add_column(r, x_tilde, st, rs)
        self._prev = (r, x_tilde.copy(), {k: v.copy() for k, v in st.items()}, rs)
        Q, R = self._qr()
        c = 1.0 - self.omega_c()
        if c == 0.0:
            bases = {PRIMARY: x_tilde, **st}
        else:  # x_tilde_f - (1 - omega_c) r_f: complement relaxation (ours, docs/coupler.md)
            bases = {PRIMARY: x_tilde - c * (x_tilde - x), **{k: st[k] - c * rs[k] for k in st}}
        step = self._update(Q, R, r, bases)
        if step is None:
            return relax(self.params.initial_relaxation, x, x_tilde, secondary)
        return step

    @abstractmethod
    def _update(
        self, Q: np.ndarray | None, R: np.ndarray, r: np.ndarray, bases: dict[str, np.ndarray]
    ) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
        """The next (primary, secondaries) from the filtered QR of P V (Q None: no columns),
        the residual r (unscaled) and each field's base (x_tilde_f, or x_tilde_f - (1 - omega_c)
        r_f), with :meth:`columns` as its W; None for a relaxation step (nothing learnt yet)."""

    def columns(self, field: str) -> np.ndarray:
        """The field's answer differences as the update uses them, (n_f x m): W_f, or
        W_f - (1 - omega_c) V_f with complement relaxation."""
        W = np.stack(self.W if field == PRIMARY else self.Ws[field], axis=1)
        c = 1.0 - self.omega_c()
        if c == 0.0:
            return W
        if field == PRIMARY:
            Vf = np.stack(self.V, axis=1)[: self.nx]
        else:
            Vf = np.stack(self.Vs[field], axis=1)
        return W - c * Vf

    def omega_c(self) -> float:
        """The complement relaxation in force: the configured one, or for "auto" 1 / rho (at
        most 1), rho the steepest secant slope |dr| / |dx| of any column so far (0 before any:
        omega_c = 1)."""
        w = self.params.complement_relaxation
        if w != "auto":
            return float(w)
        return 1.0 if self.rho <= 1.0 else 1.0 / self.rho

    def _add_column(
        self,
        r: np.ndarray,
        x_tilde: np.ndarray,
        st: dict[str, np.ndarray],
        rs: dict[str, np.ndarray],
    ) -> None:
        """Insert the differences to the previous iteration (newest first), capped at
        ``max_columns``."""
        r0, xt0, st0, rs0 = self._prev
        self.V.insert(0, r - r0)
        self.W.insert(0, x_tilde - xt0)
        for k in st:
            self.Ws.setdefault(k, [np.zeros_like(st[k]) for _ in self.tags]).insert(
                0, st[k] - st0[k]
            )
            self.Vs.setdefault(k, [np.zeros_like(st[k]) for _ in self.tags]).insert(
                0, rs[k] - rs0[k]
            )
        self.tags.insert(0, self.window)
        if self.params.complement_relaxation == "auto":
            dr = self.V[0][: x_tilde.size]
            ndx = float(np.linalg.norm(self.W[0] - dr))  # dx = dx_tilde - dr, the column's step
            if ndx > 0.0:  # the residual's secant slope along dx; rho never decreases
                self.rho = max(self.rho, float(np.linalg.norm(dr)) / ndx)
        if len(self.V) > self.params.max_columns:
            self._select(list(range(self.params.max_columns)))

    def scaled(self, M: np.ndarray) -> np.ndarray:
        """P M (rows weighted per field); M itself when there is no scaling."""
        if self.precon is None or not self.precon.active:
            return M
        w = self.precon.weights
        return w[:, None] * M if M.ndim == 2 else w * M

    def _qr(self) -> tuple[np.ndarray | None, np.ndarray]:
        """QR of P V (newest column first) after filtering; drops filtered columns for good.
        Columns beyond the residual's size (more than V has rows) are dependent by construction
        and their R would not be square: the oldest go first."""
        if self.V and len(self.V) > self.V[0].size:
            self._select(list(range(self.V[0].size)))
        if not self.V:
            return None, np.zeros((0, 0))
        Q, R, kept = filtered_qr(
            self.scaled(np.stack(self.V, axis=1)), self.params.filter, self.limit
        )
        if len(kept) < len(self.V):
            self.filtered += len(self.V) - len(kept)
            self._select(kept)
        return Q, R

    def pseudo_inverse(self, Q: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Z = (V^T P^2 V)^-1 V^T P^2 = R^-1 Q^T P, (m x n): the least-squares solution
        alpha = -Z r of min |P (V alpha + r)| for any r (the pseudo-inverse of Lindner et al. 2015, with
        preCICE's scaling)."""
        from scipy.linalg import solve_triangular

        Z = solve_triangular(R, Q.T)
        if self.precon is not None and self.precon.active:
            Z = Z * self.precon.weights[None, :]
        # C order, as a copy from a checkpoint has: BLAS rounds by layout (bit-identical restart)
        return np.ascontiguousarray(Z)

    # ------------------------------------------------------------------ restart
    def state_dict(self):
        out = {
            "window": self.window,
            "tags": np.array(self.tags, dtype=np.int64),
            "V": np.array(self.V),
            "W": np.array(self.W),
            **{f"Ws/{k}": np.array(v) for k, v in self.Ws.items()},
            **{f"Vs/{k}": np.array(v) for k, v in self.Vs.items()},
            "nx": self.nx,
            "rho": self.rho,
        }
        pre = self.precon.state_dict() if self.precon is not None else self._precon_state
        out.update({f"precon/{k}": v for k, v in (pre or {}).items()})
        return out

    def load_state_dict(self, state):
        self.window = int(state["window"])
        self.tags = [int(t) for t in state["tags"]]
        self.V = [np.array(c) for c in state["V"]]
        self.W = [np.array(c) for c in state["W"]]
        self.Ws = {k[3:]: [np.array(c) for c in v] for k, v in state.items() if k.startswith("Ws/")}
        self.Vs = {k[3:]: [np.array(c) for c in v] for k, v in state.items() if k.startswith("Vs/")}
        self.nx = int(state.get("nx", 0))
        self.rho = float(state.get("rho", 0.0))
        self._prev = None
        pre = {k[7:]: v for k, v in state.items() if k.startswith("precon/")}
        self.precon = None
        self._precon_state = pre or None
