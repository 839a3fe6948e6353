"""IQN-IMVJ: interface quasi-Newton with a multi-vector Jacobian (Lindner, Mehl & Uekermann
2015; restart modes of Scheufele & Mehl 2017), in preCICE's form.

IQN-ILS forgets what a window taught it once its columns leave the reuse window; IMVJ keeps an
inverse Jacobian J_prev (n_f x n_r per field f: the answer's response to the residual) from all
past windows and corrects it with the current window's columns V, W (:mod:`.quasi_newton`):

    J = J_prev + (W - J_prev V) Z,   Z = (V^T P^2 V)^-1 V^T P^2   (the multi-vector update)
    x_{k+1} = x_tilde_k - J r_k

so the first iteration of a window is already a quasi-Newton step with J_prev, and J satisfies
the secant equations J V = W of every column it was built from. When a window's iterations end
(:meth:`QuasiNewton.iterations_converged`) J_prev becomes that J. Secondary fields (the velocity)
carry their own J_prev,s and W_s, so they follow the same update. Nothing learnt yet (first
iteration of the first window): relaxation with ``initial_relaxation``.

How J_prev is stored (``restart``, preCICE's ``imvj-restart-mode``):

* ``"no-restart"``: a dense n_f x n_r matrix per field, J_prev += W_tilde Z at every window end
  (W_tilde = W - J_prev V). Memory and work n_f n_r per iteration: fine for a beam (tens of
  entries), 40 ms per iteration at 2000 entries.
* ``"RS-SVD"`` (the default, preCICE's): the low-rank terms W_tilde^q Z^q of the last
  ``chunk_size`` windows; after that many windows their sum (with the previous truncated SVD) is replaced by a
  truncated SVD of J_prev P^-1, singular values below ``truncation`` times the largest dropped
  (Scheufele & Mehl 2017, RS-SVD).
* ``"RS-LS"``: the terms of the last ``chunk_size`` windows; at a restart J_prev is rebuilt as
  W Z from the columns of the last ``restart_reuse_windows`` windows (an IQN-ILS-like Jacobian;
  Scheufele & Mehl 2017, RS-LS).
* ``"RS-0"``: the terms of the last ``chunk_size`` windows; at a restart all is forgotten.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from mpsfem.coupler.acceleration.preconditioner import PreconditionerKind
from mpsfem.coupler.acceleration.quasi_newton import PRIMARY, QuasiNewton, QuasiNewtonParams

Restart = Literal["no-restart", "RS-SVD", "RS-LS", "RS-0"]


class IQNIMVJParams(QuasiNewtonParams):
    """Quasi-Newton with a multi-vector Jacobian carried across windows."""

    kind: Literal["iqn-imvj"] = Field(description='"iqn-imvj".')
    reuse_windows: int = Field(
        0,
        ge=0,
        description=(
            "Number of past windows whose columns are kept besides the Jacobian (>= 0; "
            "preCICE's default for IMVJ is 0: the Jacobian carries what they taught)."
        ),
    )
    max_columns: int = Field(
        20, ge=1, description="Most columns kept in V and W (>= 1); the oldest go first."
    )
    data: list[Literal["displacement", "velocity"]] = Field(
        default_factory=lambda: ["displacement", "velocity"],
        description=(
            'Fields whose residuals the least squares fits: ["displacement", "velocity"] '
            '(default: measured best, docs/coupler.md) or ["displacement"]. The convergence '
            "criterion always measures the displacement."
        ),
    )
    preconditioner: PreconditionerKind = Field(
        "value",
        description=(
            'Residual scaling per field: "value" (default: measured best with two fields), '
            '"residual_sum" (preCICE\'s default) or "none".'
        ),
    )
    complement_relaxation: float | Literal["auto"] = Field(
        "auto",
        description=(
            'Relaxation of the residual outside the span of the columns, in (0, 1], or "auto" '
            "(default: 1 / the steepest secant slope of the residual; the only setting that "
            "converged at every added-mass ratio of the sweep, docs/coupler.md). 1 is "
            "preCICE's step."
        ),
    )
    restart: Restart = Field(
        "RS-SVD",
        description=(
            'How the Jacobian of past windows is kept: "RS-SVD" (default, preCICE\'s: low-rank '
            "terms, a truncated SVD every chunk_size windows; the same iterations as the dense "
            'matrix on the mock at a fraction of its cost), "no-restart" (dense matrix), "RS-LS" (rebuilt from the columns of the '
            'last restart_reuse_windows windows), "RS-0" (forgotten every chunk_size windows).'
        ),
    )
    chunk_size: int = Field(
        8, ge=1, description="Windows between restarts of the RS-* modes (>= 1)."
    )
    truncation: float = Field(
        1e-4,
        gt=0,
        lt=1,
        description="RS-SVD: singular values below this times the largest are dropped, (0, 1).",
    )
    restart_reuse_windows: int = Field(
        8, ge=1, description="RS-LS: windows whose columns rebuild the Jacobian (>= 1)."
    )


#: one low-rank term of J_prev per field: J_f += A_f @ B_f, A (n_f x m), B (m x n_r)
Term = dict[str, tuple[np.ndarray, np.ndarray]]


class IQNIMVJ(QuasiNewton):
    kind = "iqn-imvj"
    Params = IQNIMVJParams

    def __init__(self, params=None) -> None:
        super().__init__(params)
        self.J: dict[str, np.ndarray] = {}  # "no-restart": dense J_prev per field
        self.chunk: list[Term] = []  # RS-*: low-rank terms of J_prev
        self.restarts = 0
        self.since_restart = 0  # windows whose terms joined the chunk since the last restart
        self.svd_rank = 0  # RS-SVD: rank of the primary field's truncated J_prev
        self.truncated = 0  # RS-SVD: singular values dropped so far (all fields)
        # RS-LS: the columns of the last windows (newest first), kept apart from V, W
        self.rs_V: list[np.ndarray] = []
        self.rs_W: dict[str, list[np.ndarray]] = {}
        self.rs_tags: list[int] = []

    # ------------------------------------------------------------------ J_prev
    def has_jacobian(self) -> bool:
        return bool(self.J) or bool(self.chunk)

    def _jprev(self, field: str, M: np.ndarray) -> np.ndarray | None:
        """J_prev,f M for M (n_r x m) or (n_r,); None when J_prev is zero."""
        if self.params.restart == "no-restart":
            J = self.J.get(field)
            return None if J is None else J @ M
        out = None
        for term in self.chunk:
            if field in term:
                A, B = term[field]
                t = A @ (B @ M)
                out = t if out is None else out + t
        return out

    def jacobian(self, field: str = PRIMARY) -> np.ndarray | None:
        """J_prev of ``field`` as a dense matrix (n_f x n_r), None while it is zero."""
        if self.params.restart == "no-restart":
            J = self.J.get(field)
            return None if J is None else J.copy()
        n_r = next((t[field][1].shape[1] for t in self.chunk if field in t), None)
        return None if n_r is None else self._jprev(field, np.eye(n_r))

    def _wtilde(self, field: str, Vm: np.ndarray) -> np.ndarray:
        """W_tilde = W - J_prev V (Lindner et al. 2015, multi-vector update)."""
        W = self.columns(field)
        JV = self._jprev(field, Vm)
        return W if JV is None else W - JV

    # ------------------------------------------------------------------ iteration
    def _update(self, Q, R, r, bases):
        if Q is None and not self.has_jacobian():
            return None
        neg = -r
        Vm = Zr = None
        if Q is not None:
            Vm = np.stack(self.V, axis=1)
            Zr = self.pseudo_inverse(Q, R) @ neg
        out = {}
        for field, base in bases.items():
            step = self._jprev(field, neg)
            nxt = base if step is None else base + step
            if Q is not None:
                # x_{k+1} = x_tilde - (J_prev + W_tilde Z) r  (Lindner et al. 2015, IMVJ step)
                nxt = nxt + self._wtilde(field, Vm) @ Zr
            out[field] = nxt
        return out.pop(PRIMARY), out

    # ------------------------------------------------------------------ window end
    def _learn(self) -> None:
        """J_prev <- J_prev + W_tilde Z with this window's (filtered) columns; restart the RS-*
        modes every ``chunk_size`` windows."""
        Q, R = self._qr()
        if Q is None:
            return
        Vm = np.stack(self.V, axis=1)
        Z = self.pseudo_inverse(Q, R)
        fields = [PRIMARY, *self.Ws]
        term = {f: (np.ascontiguousarray(self._wtilde(f, Vm)), Z) for f in fields}
        if self.params.restart == "no-restart":
            for f, (Wt, Zf) in term.items():
                upd = Wt @ Zf  # Lindner et al. 2015: J = J_prev + (W - J_prev V) Z
                self.J[f] = upd if f not in self.J else self.J[f] + upd
            return
        self.chunk.append(term)
        if self.params.restart == "RS-LS":
            self._keep_rs_columns()
        self.since_restart += 1
        if self.since_restart >= self.params.chunk_size:
            self._restart()

    def _keep_rs_columns(self) -> None:
        """RS-LS: this window's columns join the restart store; windows older than
        ``restart_reuse_windows`` leave it."""
        mine = [k for k, t in enumerate(self.tags) if t == self.window]
        self.rs_V = [self.V[k] for k in mine] + self.rs_V
        for f in [PRIMARY, *self.Ws]:
            cols = self.columns(f)
            self.rs_W[f] = [cols[:, k] for k in mine] + self.rs_W.get(f, [])
        self.rs_tags = [self.window] * len(mine) + self.rs_tags
        keep = [
            k
            for k, t in enumerate(self.rs_tags)
            if t > self.window - self.params.restart_reuse_windows
        ]
        self.rs_V = [self.rs_V[k] for k in keep]
        self.rs_W = {f: [c[k] for k in keep] for f, c in self.rs_W.items()}
        self.rs_tags = [self.rs_tags[k] for k in keep]

    def _restart(self) -> None:
        self.restarts += 1
        self.since_restart = 0
        mode = self.params.restart
        if mode == "RS-0":
            self.chunk = []
        elif mode == "RS-SVD":
            self.chunk = [self._truncated_svd()]
        elif mode == "RS-LS":
            self.chunk = [self._least_squares_jacobian()] if self.rs_V else []

    def _weights(self, n_r: int) -> np.ndarray:
        if self.precon is not None and self.precon.active:
            return self.precon.weights
        return np.ones(n_r)

    def _truncated_svd(self) -> Term:
        """J_prev,f P^-1 = Psi Sigma Phi^T truncated at ``truncation`` sigma_max, per field
        (Scheufele & Mehl 2017, RS-SVD); stored as A = Psi Sigma, B = Phi^T P."""
        out: Term = {}
        fields = {f for t in self.chunk for f in t}
        for f in [PRIMARY, *sorted(fields - {PRIMARY})]:
            A = np.hstack([t[f][0] for t in self.chunk if f in t])
            B = np.vstack([t[f][1] for t in self.chunk if f in t])
            w = self._weights(B.shape[1])
            Qa, Ra = np.linalg.qr(A, mode="reduced")
            Qb, Rb = np.linalg.qr((B / w[None, :]).T, mode="reduced")
            U, sig, Vt = np.linalg.svd(Ra @ Rb.T, full_matrices=False)
            keep = sig >= self.params.truncation * sig[0] if sig.size and sig[0] > 0 else sig > 0
            self.truncated += int(sig.size - keep.sum())
            if f == PRIMARY:
                self.svd_rank = int(keep.sum())
            A_new = (Qa @ U[:, keep]) * sig[keep][None, :]
            B_new = (Vt[keep] @ Qb.T) * w[None, :]
            out[f] = (np.ascontiguousarray(A_new), np.ascontiguousarray(B_new))
        return out

    def _least_squares_jacobian(self) -> Term:
        """J_prev = W Z from the restart store's columns (Scheufele & Mehl 2017, RS-LS); the
        oldest columns go while 2 m >= n_r (preCICE's guard against a square system)."""
        V, W = list(self.rs_V), {f: list(c) for f, c in self.rs_W.items()}
        while V and 2 * len(V) >= V[0].size:
            V.pop()
            for c in W.values():
                c.pop()
        if not V:
            return {}
        from mpsfem.coupler.acceleration.qr_filter import filtered_qr

        Q, R, kept = filtered_qr(self.scaled(np.stack(V, axis=1)), self.params.filter, self.limit)
        if Q is None:
            return {}
        Z = self.pseudo_inverse(Q, R)
        return {f: (np.stack([c[k] for k in kept], axis=1), Z) for f, c in W.items()}

    # ------------------------------------------------------------------ restart state
    def state_dict(self):
        out = super().state_dict()
        out["imvj/restarts"] = self.restarts
        out["imvj/since_restart"] = self.since_restart
        out["imvj/svd_rank"] = self.svd_rank
        out["imvj/truncated"] = self.truncated
        for f, J in self.J.items():
            out[f"J/{f}"] = J.copy()
        for q, term in enumerate(self.chunk):
            for f, (A, B) in term.items():
                out[f"chunk/{q}/{f}/A"] = A.copy()
                out[f"chunk/{q}/{f}/B"] = B.copy()
        if self.rs_V:
            out["rs/V"] = np.array(self.rs_V)
            out["rs/tags"] = np.array(self.rs_tags, dtype=np.int64)
            for f, c in self.rs_W.items():
                out[f"rs/W/{f}"] = np.array(c)
        return out

    def load_state_dict(self, state):
        base = {
            k: v for k, v in state.items() if not k.startswith(("J/", "chunk/", "rs/", "imvj/"))
        }
        super().load_state_dict(base)
        self.restarts = int(state.get("imvj/restarts", 0))
        self.since_restart = int(state.get("imvj/since_restart", 0))
        self.svd_rank = int(state.get("imvj/svd_rank", 0))
        self.truncated = int(state.get("imvj/truncated", 0))
        self.J = {k[2:]: np.array(v) for k, v in state.items() if k.startswith("J/")}
        terms: dict[int, Term] = {}
        for k, v in state.items():
            if k.startswith("chunk/"):
                _, q, f, ab = k.split("/")
                pair = terms.setdefault(int(q), {}).setdefault(f, [None, None])
                pair[0 if ab == "A" else 1] = np.array(v)
        self.chunk = [{f: (p[0], p[1]) for f, p in terms[q].items()} for q in sorted(terms)]
        self.rs_V = [np.array(c) for c in state.get("rs/V", [])]
        self.rs_tags = [int(t) for t in state.get("rs/tags", [])]
        self.rs_W = {
            k[5:]: [np.array(c) for c in v] for k, v in state.items() if k.startswith("rs/W/")
        }
