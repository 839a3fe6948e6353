"""Pressure Poisson equation (PPE) of the semi-implicit MPS step, assembled in CSR and solved by PCG.

Equation (thesis eq. 2-23, mixed source term of Lee et al. / Tanaka & Masunaga)::

    <lap p>_i = (1 - gamma) rho / dt  <div u*>_i  -  gamma rho / dt^2 (n*_i - n0) / n0

with the MPS Laplacian ``<lap p>_i = 2 d / (lambda0 n0) sum_j (p_j - p_i) w_ij`` (eq. 2-16) on the
PPE's own kernel radius (default 4.01 l0) with the constants n0, lambda0 of the initial lattice, the
velocity divergence (eq. 2-15) and the number density n* (eq. 2-5) on the density radius (2.1 l0)
with that radius' n0. Multiplying by -1 gives ``A p = b`` with A symmetric positive definite:

- Unknowns: FLUID particles and pressure-carrying walls (WALL, STRUCTURE) that are not free-surface
  particles; a pressure wall without a FLUID neighbour within the PPE radius is not an unknown.
- Neighbours j in row i: DUMMY / STRUCTURE_DUMMY never enter (no pressure; their absence is a
  zero-normal-gradient condition, as in MPS-Basic), nor do pressure walls that are not unknowns and
  not free surface (too far from the fluid). Free-surface neighbours are Dirichlet p = 0: their
  weight stays on the diagonal, the column is eliminated (symmetry is kept).
- A_ij = -c w_ij (j an unknown), A_ii = c sum_j w_ij + rho kappa / dt^2, c = 2 d / (lambda0 n0),
  b_i = -(right-hand side above) + (1 - gamma) rho kappa / dt^2 p^n_i. kappa is the optional
  artificial compressibility (1/Pa, default 0; sound speed c_s = 1 / sqrt(rho kappa)), consistent
  in both parts of the mixed source: the divergence part becomes the compressible continuity
  equation div u^{n+1} = -kappa (p^{n+1} - p^n) / dt, the density part targets n0 (1 + kappa
  p^{n+1}) instead of n0 (a linear equation of state); together they add rho kappa / dt^2 (p^{n+1} -
  (1 - gamma) p^n) to the left-hand side. Still water then sits at p = rho g (H - y), compressed
  by kappa p. (The diagonal term alone, as in MPS-Basic, would compress it by kappa p / gamma,
  22 % measured for kappa = 1e-6 at gamma = 0.01, and damp the pressure towards 0: docs/fluid.md.)
- SPD: every connected set of unknowns that touches a free-surface particle is strictly diagonally
  dominant somewhere and hence SPD. A set with no free-surface contact (fluid enclosed by walls) is
  singular (pure Neumann); such sets are found each step (breadth-first search over the matrix
  graph, O(nnz)) and get the diagonal term with ``floating_compressibility`` (default
  4.5e-10 1/Pa, water's 1/(rho c^2)) when ``compressibility`` is smaller: a regularisation of the
  singular set (its bias kappa p / gamma is 1e-4 at 2 kPa), without the p^n part.

Khayyer & Gotoh's remedies for pressure noise, each behind its own switch (off by default, where
the assembly is the one above, bit for bit): ``source_term="higher_order"`` puts their higher-order
source (HS, 2009) in place of the divergence, ``error_compensation=True`` adds their
error-compensating source (ECS, 2011), both in source_terms.py; ``laplacian="higher_order"`` puts
their higher-order Laplacian (HL, 2010 / 2012) in the matrix (and the preconditioner's), pair
weight f(r) instead of w(r), in higher_order_laplacian.py. With the Neumann wall model the caller's
ghost and surface-value terms on the right-hand side come in the standard forms; HS and HL take
those back out and put their own in, so still water stays hydrostatic (docs/fluid.md).

Index space: the matrix has one row per pressure-carrying particle (FLUID, WALL, STRUCTURE), in
particle order, whether or not it is an unknown this step; rows that are not unknowns are decoupled
identity-like rows (``A_ii = c n0``, ``b_i = 0``, solution 0). Its size therefore stays fixed while
particles move and the free surface changes, so an AMG hierarchy built at one step stays a valid
(symmetric positive definite) preconditioner of later matrices; on the finest level the V-cycle
smooths with the current matrix. The hierarchy is rebuilt when CG needs more than
``rebuild_factor`` times the iterations per decade of residual reduction (a measure of the
preconditioner that does not depend on how good the warm start was) of the first solve after the
last rebuild, when the row count changes, or when a solve with an old hierarchy fails to converge
(then the solve is retried once with a fresh hierarchy).

Preconditioner radius: ``pcg_amg`` builds its V-cycle from the same equation assembled on the
smaller radius ``precond_re`` (default: the density radius, 2.1 l0), a matrix with ~3.6 times fewer
nonzeros than at 4.01 l0. Both discretise the same Laplacian with the same boundary conditions, so
CG on the 4.01 l0 system needs about as many iterations as with a V-cycle of the 4.01 l0 matrix,
each much cheaper (benchmarks/bench_pressure_solve.py). The tolerance is always that of the
system at ``re``.

Solvers by name (:data:`SOLVERS`, :func:`make_pressure_solver`): ``"pcg_amg"`` (CG preconditioned
by a pyamg smoothed-aggregation V-cycle, seeded for determinism), ``"pcg_jacobi"`` (diagonal
preconditioner) and ``"direct"`` (scipy's sparse LU; small problems). The CG is numba (parallel
matrix-vector product, dot products summed in fixed-size chunks in a fixed order, so bit-identical
for a given thread count), warm-started from the previous pressure and stopped at
``||b - A p|| <= tol ||b||``. Failing that within ``max_iter`` raises :class:`PressureSolveError`.

One module per stage; this one names the solvers and re-exports the public names:
``pressure_assembly.py`` (source term, clamp, classification of unknowns, CSR fill, floating
sets), ``pressure_system.py`` (:class:`PressureSolver`: assembly driver and the CG loop),
``pcg_kernels.py`` (the hand-written CG's kernels and the Jacobi preconditioner),
``gauss_seidel.py`` (the V-cycle's hybrid Gauss-Seidel smoother) and ``amg_pcg.py`` (the
smoothed-aggregation V-cycle preconditioner, :class:`AMGPCG`).
"""

from __future__ import annotations

import numpy as np

from .amg_pcg import AMGPCG
from .pcg_kernels import (
    _dot,
    _jacobi_apply,
    _residual,
)
from .pressure_assembly import clamp_negative, mixed_source_term, subtract_compressibility_source
from .pressure_system import (
    INT32_MAX,
    WALL_MODELS,
    WATER_COMPRESSIBILITY,
    PressureSolveError,
    PressureSolver,
    SolveInfo,
)

__all__ = [
    "AMGPCG",
    "INT32_MAX",
    "SOLVERS",
    "WALL_MODELS",
    "WATER_COMPRESSIBILITY",
    "DirectSolver",
    "JacobiPCG",
    "PressureSolveError",
    "PressureSolver",
    "SolveInfo",
    "clamp_negative",
    "make_pressure_solver",
    "mixed_source_term",
    "subtract_compressibility_source",
]


class JacobiPCG(PressureSolver):
    """CG with the diagonal (Jacobi) preconditioner."""

    name = "pcg_jacobi"

    def _solve(self, A, b, x, info):
        a_ptr, a_idx, a_val, part = A.indptr, A.indices, A.data, self.part

        def precond(r, z):
            return _jacobi_apply(a_ptr, a_idx, a_val, r, z, part)

        self._pcg(A, b, x, precond, info)


class DirectSolver(PressureSolver):
    """Sparse LU (scipy ``spsolve``); for small problems and as a reference."""

    name = "direct"

    def _solve(self, A, b, x, info):
        from scipy.sparse.linalg import spsolve

        x[:] = spsolve(A.tocsc(), b)
        rr = _residual(A.indptr, A.indices, A.data, x, b, self.work[0][: b.shape[0]], self.part)
        bnorm = np.sqrt(_dot(b, b, self.part))
        info.iterations = 1
        info.residual = float(np.sqrt(rr) / bnorm) if bnorm > 0 else 0.0
        if not info.residual <= self.tol:  # a singular or ill-conditioned LU (NaN fails too)
            raise PressureSolveError(
                f"pressure Poisson equation (direct, {b.shape[0]} rows) solved to a relative "
                f"residual {info.residual:.3e} > tol {self.tol:.1e}: the matrix is singular or "
                "ill-conditioned (check the particle configuration, or use pcg_amg)"
            )


SOLVERS: dict[str, type[PressureSolver]] = {
    "pcg_amg": AMGPCG,
    "pcg_jacobi": JacobiPCG,
    "direct": DirectSolver,
}


def make_pressure_solver(name: str, **kwargs) -> PressureSolver:
    """Pressure solver by name (see :data:`SOLVERS`) with the keyword parameters of
    :class:`PressureSolver` (and :class:`AMGPCG`)."""
    try:
        cls = SOLVERS[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown pressure solver {name!r}; allowed: {', '.join(sorted(SOLVERS))}"
        ) from None
    return cls(**kwargs)
