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
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from .higher_order_laplacian import (
    hl_constants,
    known_neighbour_correction,
    laplacian_code,
    pair_coefficient,
)
from .kernels import weight_code
from .lattice import lattice_constants
from .operators import divergence
from .particle_kinds import is_dummy
from .source_terms import (
    SOURCE_TERMS,
    add_error_compensation,
    hs_source,
    number_density_rate,
    rate_constant,
)

WATER_COMPRESSIBILITY = 4.5e-10  # 1/Pa, 1 / (rho c^2) for water
WALL_MODELS = ("pressure_layer", "neumann")


#: largest nonzero count the int32 CSR arrays of the pressure matrix address
INT32_MAX = 2**31 - 1


class PressureSolveError(RuntimeError):
    """The pressure Poisson equation did not reach its tolerance."""


@dataclass
class SolveInfo:
    """What one pressure solve did."""

    iterations: int = 0
    residual: float = 0.0  # ||b - A p|| / ||b|| reached
    initial_residual: float = 0.0  # ||b - A p0|| / ||b|| of the warm start
    n_unknowns: int = 0
    n_rows: int = 0
    nnz: int = 0
    assembly_time: float = 0.0  # s, source term + matrix
    solve_time: float = 0.0  # s, including any AMG rebuild
    rebuilt: bool = False  # the AMG hierarchy was (re)built in this solve
    floating: int = 0  # unknowns in sets without free-surface contact (given compressibility)


# ----------------------------------------------------------------------------- source term
@njit(cache=True, parallel=True)
def mixed_source_term(div_u, number_density, kind, rho, dt, gamma, n0, out):
    """Right-hand side of eq. 2-23 per particle (0 on dummies):
    (1 - gamma) rho / dt div_u - gamma rho / dt^2 (n - n0) / n0."""
    a = (1.0 - gamma) * rho / dt
    c = gamma * rho / (dt * dt * n0)
    for i in prange(kind.shape[0]):
        k = kind[i]
        if k == 2 or k == 4:
            out[i] = 0.0
        else:
            out[i] = a * div_u[i] - c * (number_density[i] - n0)
    return out


@njit(cache=True, parallel=True)
def subtract_compressibility_source(p_prev, kind, coef, out):
    """out_i -= coef p_prev_i (not on dummies): the previous pressure's share of the
    artificial-compressibility term, coef = (1 - gamma) rho kappa / dt^2 (module docstring)."""
    for i in prange(kind.shape[0]):
        if not is_dummy(kind[i]):
            out[i] -= coef * p_prev[i]
    return out


@njit(cache=True, parallel=True)
def clamp_negative(p, mask):
    """p_i = max(p_i, 0) where mask_i is true (negative-pressure clamp)."""
    for i in prange(p.shape[0]):
        if mask[i] and p[i] < 0.0:
            p[i] = 0.0
    return p


# ----------------------------------------------------------------------------- assembly
@njit(cache=True)
def _row_map(kind, row_of):
    """Row of each pressure-carrying particle (FLUID, WALL, STRUCTURE) in particle order; -1 else."""
    m = 0
    for i in range(kind.shape[0]):
        k = kind[i]
        if k == 0 or k == 1 or k == 3:
            row_of[i] = m
            m += 1
        else:
            row_of[i] = -1
    return m


@njit(cache=True, parallel=True)
def _classify(pos, kind, free_surface, indptr, indices, re2, unknown, walls=True):
    """unknown[i] = 1 for non-surface FLUID, and non-surface WALL/STRUCTURE with a FLUID neighbour."""
    n, dim = pos.shape
    for i in prange(n):
        k = kind[i]
        u = 0
        if free_surface[i] == 0:
            if k == 0:
                u = 1
            elif walls and (k == 1 or k == 3):
                for kk in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
                    j = np.uint32(indices[kk])
                    if kind[j] == 0:
                        r2 = 0.0
                        for d in range(dim):
                            dx = pos[j, d] - pos[i, d]
                            r2 += dx * dx
                        if r2 < re2:
                            u = 1
                            break
        unknown[i] = u


@njit(cache=True, parallel=True)
def _count(pos, unknown, row_of, indptr, indices, re2, re2_pre, counts, counts_pre):
    """First pass: nonzeros per row of the PPE matrix (radius^2 re2) and of the preconditioner's
    matrix (re2_pre <= re2; ignored when re2_pre <= 0)."""
    n, dim = pos.shape
    for i in prange(n):
        r = row_of[i]
        if r < 0:
            continue
        c = 1
        cp = 1
        if unknown[i]:
            for kk in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
                j = np.uint32(indices[kk])
                if unknown[j]:
                    r2 = 0.0
                    for d in range(dim):
                        dx = pos[j, d] - pos[i, d]
                        r2 += dx * dx
                    if r2 < re2:
                        c += 1
                        if r2 < re2_pre:
                            cp += 1
        counts[r] = c
        counts_pre[r] = cp


@njit(cache=True)
def _prefix(counts, m, out):
    """Row pointer ``out`` (int32) from the row counts; returns the total in int64, which the
    caller checks against INT32_MAX (past it ``out`` has wrapped)."""
    out[0] = 0
    total = np.int64(0)
    for r in range(m):
        total += counts[r]
        out[r + 1] = total
    return total


@njit(cache=True, inline="always")
def _put_diagonal(a_idx, a_val, p, dpos, r, diag):
    """Close a row: the diagonal goes to its reserved slot, or to the end of the row."""
    if dpos < 0:
        dpos = p
    a_idx[dpos] = r
    a_val[dpos] = diag


@njit(cache=True, parallel=True)
def _fill(
    pos,
    kind,
    free_surface,
    unknown,
    row_of,
    indptr,
    indices,
    re,
    wcode,
    lap_code,
    coef,
    shift,
    decoupled,
    src,
    a_ptr,
    a_idx,
    a_val,
    b,
    dirichlet,
    re_pre,
    coef_pre,
    decoupled_pre,
    p_ptr,
    p_idx,
    p_val,
    p_dirichlet,
):
    """Second pass: the CSR rows (columns ascending, diagonal in place) of the PPE matrix and,
    when ``re_pre > 0``, of the preconditioner's matrix on radius re_pre, in one sweep over the
    neighbours; the right-hand side; whether each row touches a Dirichlet (free-surface)
    neighbour. ``lap_code``: the pair weight of the Laplacian, 0 the kernel (eq. 2-16), 1 the
    higher-order Laplacian's (higher_order_laplacian.py); ``coef`` its normalisation."""
    n, dim = pos.shape
    re2 = re * re
    re2p = re_pre * re_pre if re_pre > 0.0 else -1.0
    two = re_pre > 0.0
    for i in prange(n):
        r = row_of[i]
        if r < 0:
            continue
        p = a_ptr[r]
        q = p_ptr[r] if two else 0
        if unknown[i] == 0:
            a_idx[p] = r
            a_val[p] = decoupled
            b[r] = 0.0
            dirichlet[r] = 1
            if two:
                p_idx[q] = r
                p_val[q] = decoupled_pre
                p_dirichlet[r] = 1
            continue
        diag = 0.0
        dpos = -1
        touch = 0
        diag_p = 0.0
        dpos_p = -1
        touch_p = 0
        for kk in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[kk])
            uj = unknown[j]
            if uj == 0 and free_surface[j] == 0:
                continue  # dummy, or a wall too far from the fluid: no pressure coupling
            kj = kind[j]
            if kj == 2 or kj == 4:
                continue
            r2 = 0.0
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
            if r2 >= re2:
                continue
            rr = np.sqrt(r2)
            w = coef * pair_coefficient(rr, re, wcode, lap_code, dim)
            diag += w
            inner = r2 < re2p
            if inner:
                wp = coef_pre * pair_coefficient(rr, re_pre, wcode, lap_code, dim)
                diag_p += wp
            if uj:
                if dpos < 0 and j > i:
                    dpos = p
                    p += 1
                a_idx[p] = row_of[j]
                a_val[p] = -w
                p += 1
                if inner:
                    if dpos_p < 0 and j > i:
                        dpos_p = q
                        q += 1
                    p_idx[q] = row_of[j]
                    p_val[q] = -wp
                    q += 1
            else:
                touch = 1
                if inner:
                    touch_p = 1
        _put_diagonal(a_idx, a_val, p, dpos, r, diag + shift)
        dirichlet[r] = touch
        if two:
            _put_diagonal(p_idx, p_val, q, dpos_p, r, diag_p + shift)
            p_dirichlet[r] = touch_p
        b[r] = -src[i]


@njit(cache=True)
def _floating_rows(a_ptr, a_idx, dirichlet, m, mark, queue):
    """Mark (mark[r] = 0) rows not connected to any Dirichlet-touching row; return their count.

    Breadth-first search from all rows that touch a free-surface particle (decoupled rows count as
    grounded). O(nnz), serial."""
    head = 0
    tail = 0
    for r in range(m):
        if dirichlet[r]:
            mark[r] = 1
            queue[tail] = r
            tail += 1
        else:
            mark[r] = 0
    while head < tail:
        r = queue[head]
        head += 1
        for k in range(np.uint64(a_ptr[r]), np.uint64(a_ptr[r + 1])):
            c = a_idx[k]
            if mark[c] == 0:
                mark[c] = 1
                queue[tail] = c
                tail += 1
    return m - tail


@njit(cache=True)
def _shift_floating(a_ptr, a_idx, a_val, mark, m, shift):
    for r in range(m):
        if mark[r] == 0:
            for k in range(np.uint64(a_ptr[r]), np.uint64(a_ptr[r + 1])):
                if a_idx[k] == r:
                    a_val[k] += shift


@njit(cache=True, parallel=True)
def _gather(p, row_of, unknown, x):
    for i in prange(p.shape[0]):
        r = row_of[i]
        if r >= 0:
            x[r] = p[i] if unknown[i] else 0.0


@njit(cache=True, parallel=True)
def _scatter(x, row_of, unknown, p):
    for i in prange(p.shape[0]):
        r = row_of[i]
        p[i] = x[r] if (r >= 0 and unknown[i]) else 0.0


# ----------------------------------------------------------------------------- CG kernels
_NCHUNK = 128  # dot products: fixed chunks summed in a fixed order (thread-count independent)


@njit(cache=True, parallel=True)
def _spmv(a_ptr, a_idx, a_val, x, y):
    for r in prange(y.shape[0]):
        s = 0.0
        for k in range(np.uint64(a_ptr[r]), np.uint64(a_ptr[r + 1])):
            s += a_val[k] * x[np.uint32(a_idx[k])]
        y[r] = s


@njit(cache=True, parallel=True)
def _dot(x, y, part):
    n = x.shape[0]
    for c in prange(_NCHUNK):
        lo = c * n // _NCHUNK
        hi = (c + 1) * n // _NCHUNK
        s = 0.0
        for k in range(lo, hi):
            s += x[k] * y[k]
        part[c] = s
    s = 0.0
    for c in range(_NCHUNK):
        s += part[c]
    return s


@njit(cache=True, parallel=True)
def _residual(a_ptr, a_idx, a_val, x, b, r, part):
    """r = b - A x; returns ||r||^2."""
    m = b.shape[0]
    for c in prange(_NCHUNK):
        lo = c * m // _NCHUNK
        hi = (c + 1) * m // _NCHUNK
        acc = 0.0
        for i in range(lo, hi):
            s = 0.0
            for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
                s += a_val[k] * x[np.uint32(a_idx[k])]
            v = b[i] - s
            r[i] = v
            acc += v * v
        part[c] = acc
    s = 0.0
    for c in range(_NCHUNK):
        s += part[c]
    return s


@njit(cache=True, parallel=True)
def _direction_and_product(a_ptr, a_idx, a_val, z, d, beta, q, part):
    """d = z + beta d (all rows first), then q = A d; returns d.q."""
    m = z.shape[0]
    for i in prange(m):
        d[i] = z[i] + beta * d[i]
    for c in prange(_NCHUNK):
        lo = c * m // _NCHUNK
        hi = (c + 1) * m // _NCHUNK
        acc = 0.0
        for i in range(lo, hi):
            s = 0.0
            for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
                s += a_val[k] * d[np.uint32(a_idx[k])]
            q[i] = s
            acc += d[i] * s
        part[c] = acc
    s = 0.0
    for c in range(_NCHUNK):
        s += part[c]
    return s


@njit(cache=True, parallel=True)
def _update(x, r, d, q, alpha, part):
    """x += alpha d, r -= alpha q; returns ||r||^2."""
    m = x.shape[0]
    for c in prange(_NCHUNK):
        lo = c * m // _NCHUNK
        hi = (c + 1) * m // _NCHUNK
        acc = 0.0
        for i in range(lo, hi):
            x[i] += alpha * d[i]
            v = r[i] - alpha * q[i]
            r[i] = v
            acc += v * v
        part[c] = acc
    s = 0.0
    for c in range(_NCHUNK):
        s += part[c]
    return s


@njit(cache=True, parallel=True)
def _jacobi_apply(a_ptr, a_idx, a_val, r, z, part):
    """z = D^-1 r; returns r.z."""
    m = r.shape[0]
    for c in prange(_NCHUNK):
        lo = c * m // _NCHUNK
        hi = (c + 1) * m // _NCHUNK
        acc = 0.0
        for i in range(lo, hi):
            dg = 1.0
            for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
                if a_idx[k] == i:
                    dg = a_val[k]
            v = r[i] / dg
            z[i] = v
            acc += r[i] * v
        part[c] = acc
    s = 0.0
    for c in range(_NCHUNK):
        s += part[c]
    return s


@njit(cache=True, parallel=True)
def _hybrid_gs(a_ptr, a_idx, a_val, x, b, xold, nblocks, backward):
    """One l1 hybrid Gauss-Seidel sweep (Baker, Falgout, Kolev & Yang 2011) in place on x.

    The rows are cut into ``nblocks`` fixed contiguous blocks, swept in parallel; inside a block
    it is Gauss-Seidel (forward or backward), across blocks Jacobi on the values from before the
    sweep, with the off-block absolute row sum added to the diagonal, which makes the sweep
    convergent for any SPD matrix. The result depends on nblocks, not on the thread count. A
    forward sweep as pre-smoother and a backward one as post-smoother keep the V-cycle symmetric.
    """
    m = x.shape[0]
    for i in prange(m):
        xold[i] = x[i]
    for c in prange(nblocks):
        lo = c * m // nblocks
        hi = (c + 1) * m // nblocks
        width = np.uint64(hi - lo)
        for t in range(hi - lo):
            i = hi - 1 - t if backward else lo + t
            s = b[i]
            dg = 0.0
            l1 = 0.0
            for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
                j = np.uint32(a_idx[k])
                v = a_val[k]
                if np.uint64(np.int64(j) - lo) < width:  # in block (diagonal included)
                    s -= v * x[j]
                    if j == i:
                        dg = v
                else:
                    s -= v * xold[j]
                    l1 += abs(v)
            x[i] += s / (dg + l1)


@njit(cache=True, parallel=True)
def _residual_only(a_ptr, a_idx, a_val, x, b, r):
    for i in prange(b.shape[0]):
        s = 0.0
        for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
            s += a_val[k] * x[np.uint32(a_idx[k])]
        r[i] = b[i] - s


@njit(cache=True, parallel=True)
def _spmv_add(a_ptr, a_idx, a_val, x, y):
    """y += A x."""
    for i in prange(y.shape[0]):
        s = 0.0
        for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
            s += a_val[k] * x[np.uint32(a_idx[k])]
        y[i] += s


def _csr32(M):
    """CSR copy with int32 indices and sorted columns (for the numba kernels)."""
    M = sp.csr_matrix(M)
    M.sort_indices()
    return (
        np.ascontiguousarray(M.indptr, dtype=np.int32),
        np.ascontiguousarray(M.indices, dtype=np.int32),
        np.ascontiguousarray(M.data, dtype=np.float64),
    )


# ----------------------------------------------------------------------------- solvers
class _Matrix:
    """CSR buffers of one assembled matrix (grow only when needed)."""

    def __init__(self):
        self.n = -1
        self.cap = 0

    def ensure(self, n):
        if n != self.n:
            self.counts = np.empty(n, np.int64)
            self.a_ptr = np.empty(n + 1, np.int32)
            self.b = np.empty(n)
            self.dirichlet = np.empty(n, np.int8)
            self.n = n

    def ensure_nnz(self, nnz):
        if nnz > self.cap:
            self.cap = int(nnz * 1.1) + 64
            self.a_idx = np.empty(self.cap, np.int32)
            self.a_val = np.empty(self.cap)


class PressureSolver:
    """Assembles and solves the PPE; subclasses supply the linear solve.

    Parameters (keywords)
    ---------------------
    dim, l0 : dimension and initial particle spacing.
    re : PPE Laplacian kernel radius (absolute, e.g. 4.01 l0).
    re_density : radius of the number density and the divergence (absolute, e.g. 2.1 l0).
    weight : kernel name ("improved" / "original").
    rho : fluid density. gamma : number-density weight of the mixed source term, in [0, 1].
    tol : relative residual. max_iter : CG iteration limit.
    compressibility : artificial compressibility kappa (1/Pa) on every unknown's diagonal (0 = off).
    floating_compressibility : kappa given to unknown sets with no free-surface contact.
    source_term : "thesis_mixed" (eq. 2-23 with the divergence of eq. 2-15) or "higher_order"
        (Khayyer & Gotoh 2009's HS replaces the divergence; source_terms.py).
    error_compensation : add Khayyer & Gotoh 2011's error-compensating source (source_terms.py).
    laplacian : "standard" (eq. 2-16) or "higher_order" (Khayyer & Gotoh 2010 / 2012's HL, in the
        matrix and its known neighbours; higher_order_laplacian.py).
    gravity : (dim,) m/s^2, needed by the Neumann wall model's ghosts in HS, ECS and HL.
    """

    name = "base"
    uses_precond_matrix = False

    def __init__(
        self,
        *,
        dim,
        l0,
        re,
        re_density,
        weight="improved",
        rho=1000.0,
        gamma=0.01,
        tol=1e-6,
        max_iter=2000,
        compressibility=0.0,
        floating_compressibility=WATER_COMPRESSIBILITY,
        precond_re=None,
        wall_model="pressure_layer",
        source_term="thesis_mixed",
        error_compensation=False,
        laplacian="standard",
        gravity=None,
        **_ignored,
    ):
        if wall_model not in WALL_MODELS:
            raise ValueError(
                f"unknown wall model {wall_model!r}; allowed: {', '.join(WALL_MODELS)}"
            )
        # "pressure_layer": the first wall layer is an unknown (thesis ch. 2.1.3);
        # "neumann": walls are ghosts of the fluid (wall_boundary.py), only fluid is unknown
        self.wall_model = wall_model
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {dim!r}")
        if not 0.0 <= gamma <= 1.0:
            raise ValueError(f"gamma must be in [0, 1], got {gamma!r}")
        if not 0.0 < tol < 1.0:
            raise ValueError(f"tol must be in (0, 1), got {tol!r}")
        if not (re > 0 and re_density > 0 and rho > 0 and l0 > 0):
            raise ValueError("l0, re, re_density and rho must be positive")
        if compressibility < 0 or floating_compressibility <= 0:
            raise ValueError("compressibility must be >= 0 and floating_compressibility > 0")
        self.dim = dim
        self.l0 = float(l0)
        self.re = float(re)
        self.re_density = float(re_density)
        self.weight = weight
        self.wcode = weight_code(weight)
        self.rho = float(rho)
        self.gamma = float(gamma)
        self.tol = float(tol)
        self.max_iter = int(max_iter)
        self.compressibility = float(compressibility)
        self.floating_compressibility = float(floating_compressibility)
        if source_term not in SOURCE_TERMS:
            raise ValueError(
                f"unknown source term {source_term!r}; allowed: {', '.join(SOURCE_TERMS)}"
            )
        self.source_term = source_term
        self.error_compensation = bool(error_compensation)
        self.laplacian = laplacian
        self.lap_code = laplacian_code(laplacian)
        self.gravity = np.zeros(dim) if gravity is None else np.asarray(gravity, np.float64)
        if self.gravity.shape != (dim,):
            raise ValueError(f"gravity must have {dim} components, got {gravity!r}")
        n0, lam = lattice_constants(dim, l0, re, weight)
        self.n0_ppe, self.lambda0 = n0, lam
        self.coef = 2.0 * dim / (lam * n0)
        self.n0_density, _ = lattice_constants(dim, l0, re_density, weight)
        self.decoupled = self.coef * n0  # diagonal of rows that are not unknowns
        self.coef_std = self.coef  # the standard Laplacian's, for known-neighbour corrections
        if self.lap_code:
            self.coef, f0 = hl_constants(dim, l0, re, weight)
            self.decoupled = self.coef * f0
        self.nu0 = rate_constant(dim, l0, re_density, weight)  # HS divergence normalisation
        # radius of the (cheaper) matrix the preconditioner is built from; see AMGPCG
        pre = self.re_density if precond_re is None else float(precond_re)
        if not pre > 0:
            raise ValueError(f"precond_re must be positive, got {precond_re!r}")
        self.precond_re = min(pre, self.re)
        self.precond_separate = self.uses_precond_matrix and self.precond_re < self.re * (1 - 1e-9)
        if self.precond_separate:
            n0p, lamp = lattice_constants(dim, l0, self.precond_re, weight)
            self.coef_pre = 2.0 * dim / (lamp * n0p)
            self.decoupled_pre = self.coef_pre * n0p
            if self.lap_code:
                self.coef_pre, f0p = hl_constants(dim, l0, self.precond_re, weight)
                self.decoupled_pre = self.coef_pre * f0p
        self._n = -1
        self._main = _Matrix()
        self._pre = _Matrix()
        self.history: list[int] = []  # iterations per solve
        self.last_info = SolveInfo()
        self.n_floating = 0

    # -- buffers --------------------------------------------------------------------------
    def _buffers(self, n):
        if n != self._n:
            self.row_of = np.empty(n, np.int64)
            self.unknown = np.empty(n, np.int8)
            self.div = np.empty(n)
            self.src = np.empty(n)
            self.x = np.empty(n)
            self.mark = np.empty(n, np.int8)
            self.queue = np.empty(n, np.int64)
            self.work = np.empty((5, n))
            self.part = np.empty(_NCHUNK)
            if self.error_compensation:  # number density and its rate at the step's start
                self.n_k = np.empty(n)
                self.rate_k = np.empty(n)
            if self.lap_code:  # HL correction of the known neighbours' right-hand side
                self.known = np.empty(n)
                self.no_surface_values = np.zeros(n)
            self._n = n

    def _matrices(self, pos, kind, free_surface, nb, m, shift):
        """Assemble the PPE matrix (and the preconditioner's, if separate) in one sweep.

        Returns the list of scipy CSR matrices wrapping the buffers (no copy)."""
        two = self.precond_separate
        mats = (self._main, self._pre)
        for mat in mats:
            mat.ensure(pos.shape[0])
        re2p = self.precond_re**2 if two else -1.0
        _count(
            pos,
            self.unknown,
            self.row_of,
            nb.indptr,
            nb.indices,
            self.re**2,
            re2p,
            mats[0].counts,
            mats[1].counts,
        )
        for mat in mats:  # (the second is unused without a separate preconditioner matrix)
            nnz = int(_prefix(mat.counts, m, mat.a_ptr[: m + 1]))
            if nnz > INT32_MAX:  # the int32 row pointer has wrapped: refuse before the fill
                raise ValueError(
                    f"the pressure matrix would hold {nnz} nonzeros ({m} rows), more than its "
                    f"32-bit CSR indices address ({INT32_MAX}): use fewer particles or a smaller "
                    "fluid.kernel.re_pressure"
                )
            mat.ensure_nnz(nnz)
        main, pre = mats
        _fill(
            pos,
            kind,
            free_surface,
            self.unknown,
            self.row_of,
            nb.indptr,
            nb.indices,
            self.re,
            self.wcode,
            self.lap_code,
            self.coef,
            shift,
            self.decoupled,
            self.src,
            main.a_ptr,
            main.a_idx,
            main.a_val,
            main.b,
            main.dirichlet,
            self.precond_re if two else 0.0,
            self.coef_pre if two else 0.0,
            self.decoupled_pre if two else 0.0,
            pre.a_ptr,
            pre.a_idx,
            pre.a_val,
            pre.dirichlet,
        )
        out = []
        for mat in mats[: 2 if two else 1]:
            k = int(mat.a_ptr[m])
            A = sp.csr_matrix(
                (mat.a_val[:k], mat.a_idx[:k], mat.a_ptr[: m + 1]), shape=(m, m), copy=False
            )
            A.has_sorted_indices = True
            out.append(A)
        return out

    def _ground(self, A, mat, m, dt):
        """Give unknown sets without free-surface contact the floating compressibility."""
        nf = _floating_rows(A.indptr, A.indices, mat.dirichlet, m, self.mark, self.queue)
        if nf and self.floating_compressibility > self.compressibility:
            extra = self.rho * (self.floating_compressibility - self.compressibility) / (dt * dt)
            _shift_floating(A.indptr, A.indices, A.data, self.mark, m, extra)
        return nf

    def assemble(
        self,
        pos,
        vel,
        kind,
        number_density,
        free_surface,
        nb,
        dt,
        extra_rhs=None,
        p_prev=None,
        density_nb=None,
        surface_values=None,
    ):
        """Build A (scipy CSR wrapping internal buffers, valid until the next call) and b.

        ``surface_values``: the Dirichlet values (Pa) of free-surface particles that the caller
        put on the right-hand side (surface_pressure.py), None when they are 0; the
        higher-order Laplacian needs them to re-weigh those known neighbours.

        ``p_prev``: the previous step's pressure (Pa), needed by the artificial compressibility
        (None: taken as 0). Returns (A, b, m) with m the number of rows. ``nb`` is the shared
        neighbour list (its radius must be >= re and >= re_density); ``density_nb``, optional,
        a shorter list (radius >= re_density) for the velocity divergence. With a separate
        preconditioner matrix, it is left in ``self.A_pre``."""
        if nb.radius < max(self.re, self.re_density) * (1 - 1e-12):
            raise ValueError(
                f"neighbour list radius {nb.radius} is smaller than the PPE radius {self.re} or "
                f"the density radius {self.re_density}"
            )
        near = nb if density_nb is None else density_nb
        if near.radius < self.re_density * (1 - 1e-12):
            raise ValueError(
                f"density list radius {near.radius} is smaller than the density radius "
                f"{self.re_density}"
            )
        n = pos.shape[0]
        self._buffers(n)
        neumann = self.wall_model == "neumann"
        if self.source_term == "higher_order":
            hs_source(
                pos,
                vel,
                kind,
                free_surface,
                near.indptr,
                near.indices,
                self.re_density,
                self.wcode,
                neumann,
                self.gravity,
                dt,
                self.nu0,
                self.n0_density,
                number_density,
                self.rho,
                self.gamma,
                self.src,
            )
        else:
            divergence(
                pos,
                vel,
                kind,
                near.indptr,
                near.indices,
                self.re_density,
                self.wcode,
                self.n0_density,
                self.div,
                neumann,
            )
            mixed_source_term(
                self.div, number_density, kind, self.rho, dt, self.gamma, self.n0_density, self.src
            )
        if self.error_compensation:
            # the step's start is up to a step's displacement away: the PPE's longer list
            number_density_rate(
                pos,
                vel,
                kind,
                free_surface,
                nb.indptr,
                nb.indices,
                self.re_density,
                self.wcode,
                neumann,
                self.gravity,
                dt,
                1.0,
                self.n_k,
                self.rate_k,
            )
            add_error_compensation(
                self.n_k, self.rate_k, kind, self.rho, dt, self.n0_density, self.src
            )
        if extra_rhs is not None:  # b = -src, so b += extra_rhs
            np.subtract(self.src, extra_rhs, out=self.src)
        if self.lap_code and neumann:  # the known neighbours with the HL weight
            self.known[:] = 0.0
            known_neighbour_correction(
                pos,
                kind,
                free_surface,
                self.no_surface_values if surface_values is None else surface_values,
                nb.indptr,
                nb.indices,
                self.re,
                self.wcode,
                self.dim,
                self.coef_std,
                self.coef,
                self.rho,
                self.gravity,
                self.known,
            )
            np.subtract(self.src, self.known, out=self.src)
        if self.compressibility > 0.0 and p_prev is not None:
            coef = (1.0 - self.gamma) * self.rho * self.compressibility / (dt * dt)
            subtract_compressibility_source(p_prev, kind, coef, self.src)
        m = _row_map(kind, self.row_of)
        _classify(
            pos,
            kind,
            free_surface,
            nb.indptr,
            nb.indices,
            self.re * self.re,
            self.unknown,
            self.wall_model == "pressure_layer",
        )
        shift = self.rho * self.compressibility / (dt * dt)
        mats = self._matrices(pos, kind, free_surface, nb, m, shift)
        A = mats[0]
        self.A_pre = None
        if self.precond_separate:
            Ap = mats[1]
            # the small-radius graph has fewer edges: grounded there implies grounded in A
            nfp = self._ground(Ap, self._pre, m, dt)
            self.n_floating = self._ground(A, self._main, m, dt) if nfp else 0
            self.A_pre = Ap
        else:
            self.n_floating = self._ground(A, self._main, m, dt)
        return A, self._main.b[:m], m

    # -- solve ------------------------------------------------------------------------------
    def solve(
        self,
        pos,
        vel,
        kind,
        number_density,
        free_surface,
        nb,
        dt,
        p,
        extra_rhs=None,
        density_nb=None,
        surface_values=None,
    ) -> SolveInfo:
        """Solve the PPE for the pressure ``p`` (N,), updated in place and used as warm start.

        ``density_nb``, ``surface_values``: see :meth:`assemble`. On return p = 0 on every particle that is not an
        unknown (free surface, dummies, walls away from the fluid). Raises PressureSolveError if
        the tolerance is not reached."""
        t0 = time.perf_counter()
        A, b, m = self.assemble(
            pos,
            vel,
            kind,
            number_density,
            free_surface,
            nb,
            dt,
            extra_rhs,
            p_prev=p,
            density_nb=density_nb,
            surface_values=surface_values,
        )
        x = self.x[:m]
        _gather(p, self.row_of, self.unknown, x)
        t1 = time.perf_counter()
        info = SolveInfo(
            n_rows=m,
            n_unknowns=int(np.count_nonzero(self.unknown)),
            nnz=A.nnz,
            assembly_time=t1 - t0,
            floating=int(self.n_floating),
        )
        self._solve(A, b, x, info)
        _scatter(x, self.row_of, self.unknown, p)
        info.solve_time = time.perf_counter() - t1
        self.history.append(info.iterations)
        self.last_info = info
        return info

    def reset(self) -> None:
        """Forget state reused between solves (a preconditioner): the next solve starts as a
        fresh solver would."""

    # -- state reused between solves, for checkpoints ---------------------------------------
    # A preconditioner reused across steps is part of the run's state: CG stops at a tolerance,
    # so two different preconditioners give pressures that differ in the last digits, and a
    # free-surface flow amplifies that. Checkpoints therefore carry it (by reference in memory,
    # as arrays on disk), and a resumed or replayed run continues with the very same one.
    def preconditioner_state(self) -> dict | None:
        """The state reused between solves, by reference (its arrays are never changed in
        place; a rebuild makes new ones); None when the solver keeps none."""
        return None

    def set_preconditioner_state(self, state: dict | None) -> None:
        """Continue with ``state`` (from :meth:`preconditioner_state` or
        :meth:`preconditioner_from_arrays`); None: :meth:`reset`."""
        self.reset()

    def preconditioner_arrays(self, state: dict | None) -> tuple[dict[str, np.ndarray], dict]:
        """``state`` as named arrays and JSON-able numbers, for a checkpoint file."""
        return {}, {}

    def preconditioner_from_arrays(self, arrays: dict[str, np.ndarray], meta: dict) -> dict | None:
        """Inverse of :meth:`preconditioner_arrays`."""
        return None

    def _solve(self, A, b, x, info):  # pragma: no cover - abstract
        raise NotImplementedError

    def _pcg(self, A, b, x, precond, info, raise_on_fail=True):
        """Preconditioned CG from the initial guess x (in place). ``precond(r, z) -> r.z``."""
        m = b.shape[0]
        r, z, d, q = (w[:m] for w in self.work[:4])
        part = self.part
        a_ptr, a_idx, a_val = A.indptr, A.indices, A.data
        bnorm = np.sqrt(_dot(b, b, part))
        if bnorm == 0.0:
            x[:] = 0.0
            info.iterations, info.residual = 0, 0.0
            return True
        target = (self.tol * bnorm) ** 2
        rr = _residual(a_ptr, a_idx, a_val, x, b, r, part)
        info.initial_residual = float(np.sqrt(rr) / bnorm)
        it = 0
        restarts = 0
        while True:
            if rr <= target:
                # confirm with the true residual (guards against drift of the recursive one)
                rr = _residual(a_ptr, a_idx, a_val, x, b, r, part)
                if rr <= target or restarts >= 3:
                    break
                restarts += 1
            if it >= self.max_iter:
                break
            rz = precond(r, z)
            beta = 0.0
            d[:] = 0.0
            while it < self.max_iter:
                dq = _direction_and_product(a_ptr, a_idx, a_val, z, d, beta, q, part)
                alpha = rz / dq
                rr = _update(x, r, d, q, alpha, part)
                it += 1
                if rr <= target:
                    break
                rz_new = precond(r, z)
                beta = rz_new / rz
                rz = rz_new
        info.iterations = it
        info.residual = float(np.sqrt(rr) / bnorm)
        ok = rr <= target
        if not ok and raise_on_fail:
            raise PressureSolveError(
                f"pressure Poisson equation ({self.name}, {m} rows, {info.n_unknowns} unknowns) "
                f"did not converge in {it} iterations: relative residual {info.residual:.3e} > "
                f"tol {self.tol:.1e} (raise fluid.pressure.max_iter, shorten dt, or check the "
                "particle configuration)"
            )
        return ok


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
