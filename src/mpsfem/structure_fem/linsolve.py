"""Factorisation of the symmetric positive definite matrices of the structure, reused per solve.

Small systems (``n <= DENSE_LIMIT``) are factorised densely by LAPACK Cholesky (``dpotrf``) and
solved with ``dpotrs`` called directly. Larger ones use SuperLU (``scipy.sparse.linalg.splu``)
with a symmetric minimum-degree ordering and no pivoting (the matrices are SPD). For banded beam
systems the two cost the same per Newmark step at n ~ 150; at n = 450 SuperLU is 2.5x faster.
Both are deterministic.

A Newton Jacobian marked :class:`SinglePrecisionJacobian` (the von Karman plate's) may be
factorised in single precision (:class:`SinglePrecisionFactor`): modified Newton uses the factor
only as its iteration matrix, the residual stays double precision, so a factor error of ~1e-7
slows the contraction (~1e-3 per iteration from the ageing tangent) by nothing measurable and the
converged answer by nothing beyond the Newton tolerance, while the factor and every solve move
half the bytes. Each such factor is checked once on a fixed vector and refused (the caller falls
back to double precision) when it is not accurate to :data:`SINGLE_PRECISION_ERROR`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from scipy.linalg import lapack

__all__ = [
    "DENSE_LIMIT",
    "MIN_PIVOT_RATIO",
    "SINGLE_PRECISION_ERROR",
    "BandMatrix",
    "BandedFactor",
    "Factor",
    "SinglePrecisionFactor",
    "SinglePrecisionJacobian",
    "factorize",
]

#: largest system factorised densely
DENSE_LIMIT = 128
#: smallest pivot of a factorisation, relative to the matrix's own diagonal entry of that row,
#: taken as non-singular. An SPD matrix factorised without pivoting has pivots in (0, A_ii]; the
#: ratio does not depend on the units of each unknown, and a rigid-body mode leaves round-off,
#: 1e-15 to 5e-13 (free beams and plates), while a 3000-element cantilever, conditioned as
#: (L / h)^4, reaches 4e-11. Below this ratio a solve would carry fewer than 4 digits.
MIN_PIVOT_RATIO = 1e-12

#: largest residual ||A x - b|| / ||b|| of a single-precision factor's solve x of A x = b (b a
#: fixed vector exciting every dof) accepted for a Newton iteration matrix: the default
#: reuse_ratio, the contraction the modified Newton rule demands of every iteration. Such a b
#: is the worst case for float32 (its stiff components); the actual Newton residuals (smooth)
#: contract as with the double-precision factor: 800-element von Karman plate, b errs by 1.3e-3,
#: the residual histories agree to 2 digits and the displacements after 100 steps to 3e-13
SINGLE_PRECISION_ERROR = 1e-2

_RIGID_HINT = "is the member free to move as a rigid body without mass or supports?"


def _check_pivots(pivots: np.ndarray, diag: np.ndarray) -> None:
    """Refuse a factorisation whose pivot is not clearly positive against its diagonal entry."""
    if not pivots.size:
        return
    ratio = pivots / diag
    k = int(np.argmin(ratio))
    if not ratio[k] > MIN_PIVOT_RATIO:
        raise np.linalg.LinAlgError(
            f"matrix singular or not positive definite (pivot / diagonal = {ratio[k]:.2e} at "
            f"row {k} of the factorisation, must exceed {MIN_PIVOT_RATIO:g}); {_RIGID_HINT}"
        )


def _symmetric_splu(A: sp.csc_matrix):
    """SuperLU of a symmetric matrix: symmetric minimum-degree ordering, no pivoting."""
    return sla.splu(
        A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
    )


class Factor:
    """A factorised SPD matrix; :meth:`solve` returns ``A^-1 b`` for a vector ``b``."""

    def __init__(self, A: sp.spmatrix | np.ndarray, *, dense_limit: int = DENSE_LIMIT) -> None:
        n = A.shape[0]
        self.n = n
        self.dense = n <= dense_limit
        if self.dense:
            Ad = A.toarray() if sp.issparse(A) else np.array(A, dtype=float)
            diag = np.diag(Ad).copy()  # dpotrf overwrites Ad when it is already Fortran-ordered
            c, info = lapack.dpotrf(np.asfortranarray(Ad), lower=0, clean=1, overwrite_a=1)
            if info != 0:
                raise np.linalg.LinAlgError(
                    f"matrix not positive definite (dpotrf info {info}); {_RIGID_HINT}"
                )
            self._c = c
            self._dpotrs = lapack.dpotrs
            _check_pivots(np.diag(c) ** 2, diag)
        else:
            self._lu = _symmetric_splu(sp.csc_matrix(A))
            # Pr A Pc = L U with perm_r = perm_c (no pivoting): row k of U is row perm^-1(k) of A
            diag = np.empty(n)
            diag[self._lu.perm_c] = A.diagonal()
            _check_pivots(self._lu.U.diagonal(), diag)

    def solve(self, b: np.ndarray) -> np.ndarray:
        if self.dense:
            x, info = self._dpotrs(self._c, b, lower=0)
            if info != 0:  # pragma: no cover - only on invalid input
                raise np.linalg.LinAlgError(f"dpotrs failed (info {info})")
            return x
        return self._lu.solve(b)


def factorize(A, *, dense_limit: int = DENSE_LIMIT) -> Factor:
    """Factorise a symmetric positive definite matrix (sparse or dense)."""
    return Factor(A, dense_limit=dense_limit)


@dataclass
class BandMatrix:
    """Symmetric n x n matrix in LAPACK upper band storage: ``ab[bw + i - j, j] = A[i, j]`` for
    ``j - bw <= i <= j``; ab has shape (bw + 1, n)."""

    ab: np.ndarray
    bw: int

    @property
    def shape(self) -> tuple[int, int]:
        n = self.ab.shape[1]
        return n, n

    def tocsr(self) -> sp.csr_matrix:
        """The full symmetric matrix as CSR."""
        n, bw = self.shape[0], self.bw
        diags = [self.ab[bw - k, k:] for k in range(bw + 1)]
        U = sp.diags(diags, list(range(bw + 1)), shape=(n, n), format="csr")
        return (U + sp.triu(U, 1, format="csr").T).tocsr()


class BandedFactor:
    """Banded Cholesky (LAPACK ``dpbtrf`` / ``dpbtrs``) of an SPD :class:`BandMatrix`: O(n bw^2)
    work, for the node-major tangents of co-rotational beams (bw = 5 for a chain)."""

    def __init__(self, A: BandMatrix) -> None:
        bw = A.bw
        self.n = A.shape[0]
        self.dense = False
        diag = A.ab[bw].copy()
        c, info = lapack.dpbtrf(np.asfortranarray(A.ab), lower=0, overwrite_ab=1)
        if info != 0:
            raise np.linalg.LinAlgError(
                f"matrix not positive definite (dpbtrf info {info}); {_RIGID_HINT}"
            )
        _check_pivots(c[bw] ** 2, diag)
        self._c = c

    def solve(self, b: np.ndarray) -> np.ndarray:
        x, info = lapack.dpbtrs(self._c, b, lower=0)
        if info != 0:  # pragma: no cover - only on invalid input
            raise np.linalg.LinAlgError(f"dpbtrs failed (info {info})")
        return x


class SinglePrecisionJacobian(sp.csc_matrix):
    """A sparse Newton Jacobian (CSC) whose factor serves only as the modified-Newton iteration
    matrix, so that :func:`.newton.factorize_jacobian` may factorise it in single precision.
    A sum with another matrix keeps the mark (scipy builds the result as this class)."""


class SinglePrecisionFactor:
    """SuperLU factor of ``A`` rounded to float32 (same ordering as :class:`Factor`, no
    pivoting); :meth:`solve` takes and returns float64. Raises ``np.linalg.LinAlgError`` when a
    pivot is not positive (not positive definite: the double-precision path pivots), when the solve of ``A x = b`` (b = cos(0, 1, 2, ...), deterministic) leaves a residual above
    `limit` x ||b||, or SuperLU finds a zero pivot. ``error``: that relative residual."""

    def __init__(self, A: sp.spmatrix, *, limit: float = SINGLE_PRECISION_ERROR) -> None:
        A = sp.csc_matrix(A)
        self.n = A.shape[0]
        self.dense = False
        try:
            self._lu = _symmetric_splu(A.astype(np.float32))
        except RuntimeError as exc:  # "Factor is exactly singular"
            raise np.linalg.LinAlgError(f"single-precision factor: {exc}") from exc
        # positive definite only (no pivoting is stable there); the others take the pivoted LU
        if not (self._lu.U.diagonal() > 0).all():
            raise np.linalg.LinAlgError("single-precision factor: not positive definite")
        b = np.cos(np.arange(self.n, dtype=float))  # fixed, excites every dof
        with np.errstate(all="ignore"):
            err = float(np.linalg.norm(A @ self.solve(b) - b) / np.linalg.norm(b))
        self.error = err
        if not err <= limit:
            raise np.linalg.LinAlgError(
                f"single-precision factor leaves a relative residual {err:.2e} on a test solve, "
                f"more than {limit:g}"
            )

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._lu.solve(np.asarray(b, dtype=np.float32)).astype(np.float64)
