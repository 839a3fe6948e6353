"""CG preconditioned by a smoothed-aggregation AMG V-cycle, its hierarchy reused across steps
(``pcg_amg``; pressure_poisson.py)."""

from __future__ import annotations

import numpy as np

from .gauss_seidel import (
    _hybrid_gs,
    _residual_only,
    _spmv_add,
)
from .pcg_kernels import (
    _dot,
    _spmv,
)
from .pressure_system import (
    PressureSolver,
    _csr32,
)


class AMGPCG(PressureSolver):
    """CG preconditioned by one smoothed-aggregation V-cycle, hierarchy reused across steps.

    The V-cycle is built from the PPE matrix assembled on the radius ``precond_re`` (default: the
    density radius, 2.1 l0), which for the default PPE radius 4.01 l0 has ~3.6 times fewer
    nonzeros: CG still solves the 4.01 l0 system to its tolerance, but each V-cycle is much cheaper
    and the iteration count hardly changes (both matrices discretise the same Laplacian with the
    same boundary conditions; measured in benchmarks/bench_pressure_solve.py). With
    ``precond_re >= re`` the V-cycle is built from the PPE matrix itself.

    The hierarchy (aggregates, prolongation P, R = P^T, coarse matrices) comes from
    ``pyamg.smoothed_aggregation_solver`` (its random spectral-radius estimates seeded with
    ``seed``; the global NumPy random state is saved and restored). The V-cycle itself runs in
    numba: l1 hybrid Gauss-Seidel smoothing (forward before, backward after the coarse
    correction, so the preconditioner is symmetric; ``smoother_sweeps`` = 2 does forward+backward
    on both sides) with ``smoother_blocks`` fixed row blocks swept in parallel, the finest level
    smoothing with the current step's matrix, a dense pseudo-inverse on the coarsest level.

    Extra parameters: ``rebuild_factor`` (default 1.5), ``seed`` (0), ``smoother_blocks`` (16),
    ``smoother_sweeps`` (1), ``precond_re`` (absolute radius), ``amg_options`` (dict passed on
    to ``pyamg.smoothed_aggregation_solver``)."""

    name = "pcg_amg"
    uses_precond_matrix = True

    def __init__(
        self,
        *,
        rebuild_factor=1.5,
        seed=0,
        smoother_blocks=16,
        smoother_sweeps=1,
        amg_options=None,
        **kw,
    ):
        super().__init__(**kw)
        if not rebuild_factor > 1.0:
            raise ValueError(f"rebuild_factor must be > 1, got {rebuild_factor!r}")
        if int(smoother_blocks) < 1:
            raise ValueError(f"smoother_blocks must be >= 1, got {smoother_blocks!r}")
        if smoother_sweeps not in (1, 2):
            raise ValueError(f"smoother_sweeps must be 1 or 2, got {smoother_sweeps!r}")
        self.rebuild_factor = float(rebuild_factor)
        self.seed = int(seed)
        self.smoother_blocks = int(smoother_blocks)
        self.sweeps = int(smoother_sweeps)
        self.amg_options = dict(amg_options or {})
        self.levels = None  # [(A, P, R) as int32 CSR triples]; A of level 0 is replaced per solve
        self.coarse_inv = None
        self.sizes = []
        self.base_rate = None
        self.rebuilds = 0
        self._rebuild_next = False

    def reset(self) -> None:
        """Rebuild the AMG hierarchy at the next solve."""
        self._rebuild_next = True

    _TRIPLE = ("indptr", "indices", "data")

    def preconditioner_state(self) -> dict | None:
        """The hierarchy (P, R and the coarse matrices of every level; the finest matrix is the
        current step's), the coarsest pseudo-inverse, the convergence-rate baseline of the
        rebuild test and a pending rebuild; None before the first solve."""
        if self.levels is None:
            return None
        return {
            "levels": [tuple(lv) for lv in self.levels],
            "coarse_inv": self.coarse_inv,
            "sizes": list(self.sizes),
            "base_rate": self.base_rate,
            "rebuild_next": self._rebuild_next,
        }

    def set_preconditioner_state(self, state: dict | None) -> None:
        if state is None:
            self.levels = None
            self._rebuild_next = False
            return
        self.levels = [list(lv) for lv in state["levels"]]
        self.coarse_inv = state["coarse_inv"]
        if list(state["sizes"]) != self.sizes:
            self._level_scratch(list(state["sizes"]))
        self.base_rate = state["base_rate"]
        self._rebuild_next = bool(state["rebuild_next"])

    def preconditioner_arrays(self, state: dict | None) -> tuple[dict[str, np.ndarray], dict]:
        if state is None:
            return {}, {"built": False}
        arrays: dict[str, np.ndarray] = {"coarse_inv": state["coarse_inv"]}
        for i, lv in enumerate(state["levels"]):
            # the finest A is replaced by the current matrix before every use
            for name, triple in zip("APR", lv, strict=True):
                if name == "A" and i == 0:
                    continue
                for part, arr in zip(self._TRIPLE, triple, strict=True):
                    arrays[f"L{i}_{name}_{part}"] = arr
        meta = {
            "built": True,
            "sizes": list(state["sizes"]),  # one per level, the coarsest (pseudo-inverse) last
            "base_rate": state["base_rate"],
            "rebuild_next": bool(state["rebuild_next"]),
        }
        return arrays, meta

    def preconditioner_from_arrays(self, arrays: dict[str, np.ndarray], meta: dict) -> dict | None:
        if not meta.get("built", False):
            return None
        levels = []
        for i in range(len(meta["sizes"]) - 1):
            lv = []
            for name in "APR":
                if name == "A" and i == 0:
                    lv.append(None)
                    continue
                lv.append(tuple(np.asarray(arrays[f"L{i}_{name}_{part}"]) for part in self._TRIPLE))
            levels.append(tuple(lv))
        return {
            "levels": levels,
            "coarse_inv": np.asarray(arrays["coarse_inv"]),
            "sizes": [int(m) for m in meta["sizes"]],
            "base_rate": meta["base_rate"],
            "rebuild_next": bool(meta["rebuild_next"]),
        }

    def _build(self, A):
        import pyamg

        # at least two levels whenever possible (small problems: coarse size m / 8)
        max_coarse = max(10, min(500, A.shape[0] // 8))
        opts = dict(
            strength="symmetric",
            smooth=("jacobi", {"omega": 4.0 / 3.0}),
            max_coarse=max_coarse,
            keep=False,
        )
        opts.update(self.amg_options)
        state = np.random.get_state()  # noqa: NPY002 (pyamg draws from the legacy global RNG)
        try:
            np.random.seed(self.seed)  # noqa: NPY002
            ml = pyamg.smoothed_aggregation_solver(A, **opts)
        finally:
            np.random.set_state(state)  # noqa: NPY002
        self.levels = [[_csr32(lv.A), _csr32(lv.P), _csr32(lv.R)] for lv in ml.levels[:-1]]
        self.coarse_inv = np.linalg.pinv(ml.levels[-1].A.toarray())
        self._level_scratch([lv.A.shape[0] for lv in ml.levels])
        self.rebuilds += 1
        self.base_rate = None

    def _level_scratch(self, sizes: list[int]) -> None:
        """Level sizes, the V-cycle's work vectors (per level: x, b, residual, old x) and the
        smoother's row blocks for a hierarchy of these sizes."""
        self.sizes = sizes
        self.vecs = [np.zeros((4, m)) for m in sizes]
        self.blocks = [max(1, min(self.smoother_blocks, m // 256)) for m in sizes]

    def _vcycle(self, lvl, x, b):
        """x = V-cycle(b) from x = 0 on level lvl."""
        if lvl == len(self.levels):
            x[:] = self.coarse_inv @ b
            return
        (ap, ai, av), (pp_, pi, pv), (rp, ri, rv) = self.levels[lvl]
        w = self.vecs[lvl]
        res, old = w[2], w[3]
        nb = self.blocks[lvl]
        x[:] = 0.0
        _hybrid_gs(ap, ai, av, x, b, old, nb, False)
        if self.sweeps == 2:
            _hybrid_gs(ap, ai, av, x, b, old, nb, True)
        _residual_only(ap, ai, av, x, b, res)
        wc = self.vecs[lvl + 1]
        cx, cb = wc[0], wc[1]
        _spmv(rp, ri, rv, res, cb)
        self._vcycle(lvl + 1, cx, cb)
        _spmv_add(pp_, pi, pv, cx, x)
        if self.sweeps == 2:
            _hybrid_gs(ap, ai, av, x, b, old, nb, False)
        _hybrid_gs(ap, ai, av, x, b, old, nb, True)

    def _attach(self, M):
        """Use the current step's matrix M on the finest level."""
        if self.levels:
            self.levels[0][0] = (M.indptr, M.indices, M.data)
        else:  # one level only (tiny system): exact solve with the current matrix
            self.coarse_inv = np.linalg.pinv(M.toarray())

    def _solve(self, A, b, x, info):
        part = self.part
        M = A if self.A_pre is None else self.A_pre
        if self.levels is None or self.sizes[0] != M.shape[0] or self._rebuild_next:
            self._build(M)
            info.rebuilt = True
            self._rebuild_next = False
        self._attach(M)

        def precond(r, z):
            if self.levels:
                self._vcycle(0, z, r)
            else:
                z[:] = self.coarse_inv @ r
            return _dot(r, z, part)

        x_start = self.work[4][: x.shape[0]]
        x_start[:] = x  # warm start, kept for a retry with a fresh hierarchy
        ok = self._pcg(A, b, x, precond, info, raise_on_fail=info.rebuilt)
        if not ok:  # old hierarchy: rebuild and retry once from the same warm start
            first = info.iterations
            x[:] = x_start
            self._build(M)
            self._attach(M)
            info.rebuilt = True
            self._pcg(A, b, x, precond, info, raise_on_fail=True)
            self.base_rate = _iterations_per_decade(info)
            info.iterations += first
            return
        rate = _iterations_per_decade(info)
        if info.rebuilt or self.base_rate is None:
            self.base_rate = rate
        elif info.iterations >= 4 and rate > self.rebuild_factor * self.base_rate:
            self._rebuild_next = True


def _iterations_per_decade(info):
    """CG iterations per factor 10 of residual reduction: the preconditioner's quality, whatever
    the quality of the warm start."""
    red = info.initial_residual / max(info.residual, 1e-300)
    return info.iterations / max(np.log10(red), 0.5) if info.iterations else 0.0
