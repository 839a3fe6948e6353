"""Newton iterations for the nonlinear structure: modified Newton with a reused tangent, and the
static solution by load stepping.

The solver only sees two callables: ``residual(x) -> (r, scale, floor)`` (the out-of-balance
force, the norm of the forces it balances, N or N/m, and the round-off level of r) and
``jacobian(x) -> matrix`` (d r / d x, sparse or :class:`.linsolve.BandMatrix`).
The time integrator (:mod:`.alpha_method`) and the static start build them; the member physics
sits in the element kernels (:mod:`.corotational_beam`).

**Convergence:** ``||r|| <= max(tolerance * scale, floor)`` (2-norms): the relative test, or
the residual at the round-off of its own terms (a motion decayed to nothing, where the forces
in balance are themselves at round-off).

**Modified Newton rule:** the factorised Jacobian (:class:`TangentFactor`) is kept across
iterations *and* steps while every iteration reduces the residual norm by at least the factor
``reuse_ratio`` (``||r_k+1|| <= reuse_ratio ||r_k||``): modified Newton contracts by about
``||K^-1 (K_now - K_factorised)||``, so a slow contraction means the tangent has changed. An
iteration that contracts less re-forms and refactorises the Jacobian at the current iterate (a
full Newton iteration); so does a new key (e.g. a new step size). ``reuse_ratio = 0`` is full
Newton. The factor records where it was formed (:meth:`TangentFactor.state`), so a restored
checkpoint can re-form the same one and repeat its steps bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from .linsolve import (
    BandedFactor,
    BandMatrix,
    SinglePrecisionFactor,
    SinglePrecisionJacobian,
    factorize,
)

__all__ = [
    "ROUNDOFF",
    "NewtonFailure",
    "NewtonResult",
    "TangentFactor",
    "newton_solve",
    "solve_static",
]

#: round-off level of a sum of terms, relative to their magnitude
ROUNDOFF = 64.0 * np.finfo(float).eps


class NewtonFailure(FloatingPointError):
    """Newton iterations did not converge; the message names where (member, step, residual)."""

    def __init__(self, message: str, *, residual: float, iterations: int) -> None:
        super().__init__(message)
        self.residual = residual
        self.iterations = iterations


@dataclass
class NewtonResult:
    """x: the solution; iterations; residual: final ||r||; scale: the force norm it is
    measured against; factorizations: Jacobians formed during this solve."""

    x: np.ndarray
    iterations: int
    residual: float
    scale: float
    factorizations: int


class _GeneralLU:
    """LU with partial pivoting, for a Jacobian that is not positive definite (past a limit
    point, or a compressed member's geometric stiffness)."""

    def __init__(self, A: sp.spmatrix) -> None:
        self._lu = sla.splu(sp.csc_matrix(A))

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._lu.solve(b)


def factorize_jacobian(A):
    """Cholesky when A is positive definite (banded LAPACK for a :class:`.linsolve.BandMatrix`,
    else :func:`.linsolve.factorize`), LU with pivoting otherwise. A
    :class:`.linsolve.SinglePrecisionJacobian` is first factorised in single precision
    (:class:`.linsolve.SinglePrecisionFactor`), in double as above if that one is refused."""
    if isinstance(A, SinglePrecisionJacobian):
        try:
            return SinglePrecisionFactor(A)
        except np.linalg.LinAlgError:
            A = sp.csc_matrix(A)  # unmarked: the double-precision factors below
    try:
        if isinstance(A, BandMatrix):
            return BandedFactor(A)
        return factorize(A)
    except np.linalg.LinAlgError:
        try:
            return _GeneralLU(A.tocsr() if isinstance(A, BandMatrix) else A)
        except RuntimeError as exc:  # splu: "Factor is exactly singular"
            raise np.linalg.LinAlgError(f"Jacobian singular: {exc}") from exc


class TangentFactor:
    """The factorised Jacobian reused by modified Newton, with the key (e.g. the step size) and
    the point x at which it was formed."""

    def __init__(self) -> None:
        self.factor = None
        self.key: float | None = None
        self.point: np.ndarray | None = None
        self._pending: tuple[np.ndarray, float] | None = None
        self.count = 0  # factorisations made

    def form(self, jacobian: Callable[[np.ndarray], sp.spmatrix | BandMatrix], x, key) -> None:
        """Form and factorise the Jacobian at x (a copy of x is kept)."""
        self.factor = factorize_jacobian(jacobian(x))
        self.key = key
        self.point = np.array(x, dtype=float)
        self._pending = None
        self.count += 1

    def ensure(self, jacobian, x: np.ndarray, key) -> bool:
        """Have a factor for `key`: the kept one, one re-formed at a restored point, or a new one
        at x. Returns True when a factorisation was made."""
        if self.factor is not None and self.key == key:
            return False
        if self._pending is not None and self._pending[1] == key:
            self.form(jacobian, self._pending[0], key)
        else:
            self.form(jacobian, x, key)
        return True

    @property
    def current_key(self):
        """Key of the factor in use or, after a restore, of the one to be re-formed."""
        return self._pending[1] if self._pending is not None else self.key

    def state(self) -> tuple[np.ndarray | None, float | None]:
        """(point, key) at which the current factor was formed (for checkpoints)."""
        if self._pending is not None:
            return self._pending[0].copy(), self._pending[1]
        return (None if self.point is None else self.point.copy()), self.key

    def restore(self, point: np.ndarray | None, key) -> None:
        """Arrange for the factor of a checkpoint: kept if it is the same, else re-formed at
        `point` when next needed with the same key."""
        if point is None:
            self.factor, self.key, self.point, self._pending = None, None, None, None
            return
        point = np.asarray(point, dtype=float)
        if (
            self.factor is not None
            and self.key == key
            and self.point is not None
            and np.array_equal(self.point, point)
        ):
            return
        self.factor, self.key, self.point = None, None, None
        self._pending = (point.copy(), key)


def newton_solve(
    residual: Callable[[np.ndarray], tuple[np.ndarray, float, float]],
    jacobian: Callable[[np.ndarray], sp.spmatrix],
    x0: np.ndarray,
    *,
    tangent: TangentFactor,
    key,
    tolerance: float,
    max_iterations: int,
    reuse_ratio: float,
    failure: Callable[[np.ndarray, np.ndarray, float, float, int], str],
) -> NewtonResult:
    """Solve residual(x) = 0 from x0 (modified Newton, rule in the module docstring).

    `failure(x, r, norm, scale, iterations)` writes the message of the :class:`NewtonFailure`
    raised when `max_iterations` pass without convergence or the iterate stops being finite.
    """
    x = np.array(x0, dtype=float)
    made = 0
    r, scale, floor = residual(x)
    norm = math.sqrt(r @ r)
    if norm <= max(tolerance * scale, floor):
        return NewtonResult(x, 0, norm, scale, 0)

    def form(fresh: bool, it: int) -> int:
        try:
            if fresh:
                tangent.form(jacobian, x, key)
                return 1
            return int(tangent.ensure(jacobian, x, key))
        except np.linalg.LinAlgError as exc:
            raise NewtonFailure(
                f"{failure(x, r, norm, scale, it)}; the Jacobian could not be factorised: {exc}",
                residual=norm,
                iterations=it,
            ) from exc

    made += form(reuse_ratio <= 0.0, 0)
    for it in range(1, max_iterations + 1):
        dx = tangent.factor.solve(-r)
        x += dx
        r, scale, floor = residual(x)
        new = math.sqrt(r @ r)
        if not (np.isfinite(new) and np.isfinite(x).all()):
            raise NewtonFailure(failure(x, r, new, scale, it), residual=new, iterations=it)
        if new <= max(tolerance * scale, floor):
            return NewtonResult(x, it, new, scale, made)
        if it < max_iterations and (reuse_ratio <= 0.0 or new > reuse_ratio * norm):
            # the kept tangent no longer contracts well (or full Newton): re-form it here
            norm = new
            made += form(True, it)
        norm = new
    raise NewtonFailure(
        failure(x, r, norm, scale, max_iterations), residual=norm, iterations=max_iterations
    )


def solve_static(
    internal: Callable[[np.ndarray], np.ndarray],
    tangent_matrix: Callable[[np.ndarray], sp.spmatrix],
    F: np.ndarray,
    x0: np.ndarray,
    *,
    tolerance: float,
    max_iterations: int,
    increments: int = 1,
    min_fraction: float = 1.0 / 1024.0,
    failure: Callable[[np.ndarray, np.ndarray, float, float, int], str],
) -> tuple[np.ndarray, int]:
    """Static equilibrium internal(x) = F by load stepping and full Newton.

    The load rises from 0 to F in increments, first ``1 / increments`` of it; an increment that
    fails is halved (down to `min_fraction` of the load), one that converges lets the next double
    (up to what is left). Returns (x, number of increments taken).
    """
    F = np.asarray(F, dtype=float)
    x = np.array(x0, dtype=float)
    lam, dlam, taken = 0.0, 1.0 / increments, 0
    tf = TangentFactor()
    while lam < 1.0:
        target = min(1.0, lam + dlam)
        Fk = target * F

        def residual(y, Fk=Fk):
            fi = internal(y)
            scale = math.sqrt(fi @ fi) + math.sqrt(Fk @ Fk)
            return fi - Fk, scale, ROUNDOFF * scale

        try:
            res = newton_solve(
                residual,
                tangent_matrix,
                x,
                tangent=tf,
                key=target,
                tolerance=tolerance,
                max_iterations=max_iterations,
                reuse_ratio=0.0,
                failure=failure,
            )
        except (NewtonFailure, np.linalg.LinAlgError) as exc:
            dlam *= 0.5
            if dlam < min_fraction:
                msg = str(exc)
                raise NewtonFailure(
                    f"{msg} (static start: load increments halved down to "
                    f"{min_fraction:g} of the load at load fraction {lam:.4g})",
                    residual=getattr(exc, "residual", float("nan")),
                    iterations=getattr(exc, "iterations", 0),
                ) from exc
            continue
        x, lam, taken = res.x, target, taken + 1
        dlam = min(2.0 * dlam, 1.0 - lam) if lam < 1.0 else dlam
    return x, taken
