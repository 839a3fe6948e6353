"""The MPS pressure Poisson system (pressure_poisson.py): its errors and solve record, the CSR buffers
and :class:`PressureSolver`, which assembles the equation each step and runs CG with the
preconditioner its subclass supplies."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .higher_order_laplacian import (
    hl_constants,
    known_neighbour_correction,
    laplacian_code,
)
from .kernels import weight_code
from .lattice import lattice_constants
from .operators import divergence
from .pcg_kernels import (
    _NCHUNK,
    _direction_and_product,
    _dot,
    _residual,
    _update,
)
from .pressure_assembly import (
    _classify,
    _count,
    _fill,
    _floating_rows,
    _gather,
    _prefix,
    _row_map,
    _scatter,
    _shift_floating,
    mixed_source_term,
    subtract_compressibility_source,
)
from .source_filter import SOURCE_FILTERS, kernel_average_divergence
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
    source_filter : "none" or "kernel_average" (the divergence of eq. 2-15 averaged over each
        fluid particle's kernel before it enters eq. 2-23; source_filter.py). Only with
        ``source_term="thesis_mixed"``.
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
        source_filter="none",
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
        if source_filter not in SOURCE_FILTERS:
            raise ValueError(
                f"unknown source filter {source_filter!r}; allowed: {', '.join(SOURCE_FILTERS)}"
            )
        if source_filter != "none" and source_term != "thesis_mixed":
            raise ValueError(
                f"source_filter = {source_filter!r} filters the divergence of eq. 2-15; it is "
                f"allowed only with source_term = 'thesis_mixed', got {source_term!r}"
            )
        self.source_filter = source_filter
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
            if self.source_filter != "none":
                self.div_filtered = np.empty(n)
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
            div = self.div
            if self.source_filter == "kernel_average":
                div = kernel_average_divergence(
                    self.div,
                    pos,
                    kind,
                    free_surface,
                    near.indptr,
                    near.indices,
                    self.re_density,
                    self.div_filtered,
                )
            self.source_div = div  # the divergence eq. 2-23 used (1/s; diagnostics read it)
            mixed_source_term(
                div, number_density, kind, self.rho, dt, self.gamma, self.n0_density, self.src
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
