"""Newmark-beta time integration of M a + C v + K u = F(t) with a factorised effective stiffness.

With the parameters ``beta`` (``newmark_beta``) and ``gamma`` (``newmark_gamma``)::

    u1 = u + dt v + dt^2 ((1/2 - beta) a + beta a1)
    v1 = v + dt ((1 - gamma) a + gamma a1)

Solving for the displacement (thesis eqs. 2-46 to 2-51, whose alpha and beta are our beta and
gamma)::

    K_eff u1 = F1 + M (c0 u + c2 v + c3 a) + C (c1 u + c4 v + c5 a)
    K_eff = K + c0 M + c1 C
    c0 = 1/(beta dt^2), c1 = gamma/(beta dt), c2 = 1/(beta dt), c3 = 1/(2 beta) - 1,
    c4 = gamma/beta - 1, c5 = dt (gamma/(2 beta) - 1)

then ``a1 = c0 (u1 - u) - c2 v - c3 a`` and ``v1`` as above. ``K_eff`` is factorised once per
step size and reused; a new ``dt`` factorises again (the last two factorisations are kept, so a
final shorter step does not evict the regular one; a ``dt`` within 1e-12 relative of a cached
one counts as that one, so round-off in ``t_end - t`` does not refactorise). Average acceleration (beta = 1/4,
gamma = 1/2) is unconditionally stable, second-order accurate and conserves the energy
``1/2 v.M v + 1/2 u.K u`` of undamped free vibration exactly.

With a fictitious mass M_f (:mod:`.fictitious_mass`) a step given the previous coupling
iterate's acceleration ``a_prev`` solves (M + M_f) a1 + C v1 + K u1 = F1 + M_f a_prev: M is
replaced by M + M_f in K_eff (factorised once per step size, kept beside the plain one) and the
right-hand side gains M_f (c0 u + c2 v + c3 a + a_prev). With a_prev = a1 it is the plain step.
:meth:`Newmark.set_fictitious_mass` replaces M_f (a new wetted set) and drops only the
fictitious factorisations; ``fictitious_factorizations`` counts those made.

Every vector here is over the free (unconstrained) degrees of freedom.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
import scipy.sparse as sp

from .linsolve import DENSE_LIMIT, Factor, factorize

__all__ = ["Newmark", "NewmarkState"]


class NewmarkState:
    """Displacement, velocity, acceleration (free dofs) and time; :meth:`copy` is a deep copy."""

    __slots__ = ("u", "v", "a", "t", "steps")

    def __init__(self, u: np.ndarray, v: np.ndarray, a: np.ndarray, t: float = 0.0, steps: int = 0):
        self.u, self.v, self.a, self.t, self.steps = u, v, a, float(t), int(steps)

    def copy(self) -> NewmarkState:
        return NewmarkState(self.u.copy(), self.v.copy(), self.a.copy(), self.t, self.steps)


class Newmark:
    """Newmark-beta integrator for the linear system (M, C, K) over free dofs."""

    def __init__(
        self,
        M: sp.spmatrix,
        K: sp.spmatrix,
        C: sp.spmatrix | None = None,
        *,
        beta: float = 0.25,
        gamma: float = 0.5,
        dense_limit: int = DENSE_LIMIT,
        fictitious_mass: sp.spmatrix | None = None,
    ) -> None:
        if beta <= 0:
            raise ValueError(f"newmark_beta = {beta}: must be > 0 (implicit schemes only)")
        if gamma < 0.5:
            raise ValueError(f"newmark_gamma = {gamma}: must be >= 0.5 (less is unstable)")
        self.M = sp.csr_matrix(M)
        self.K = sp.csr_matrix(K)
        if C is not None:
            C = sp.csr_matrix(C, copy=True)
            C.eliminate_zeros()
            if C.nnz == 0:
                C = None
        self.C = C
        self.beta = float(beta)
        self.gamma = float(gamma)
        self.dense_limit = dense_limit
        self.n = self.M.shape[0]
        self._factors: OrderedDict[float, tuple[Factor, tuple[float, ...]]] = OrderedDict()
        # fictitious mass M_f (None: off) and the factorisations of K + c0 (M + M_f) + c1 C
        Mf = None if fictitious_mass is None else sp.csr_matrix(fictitious_mass)
        self.Mf = Mf if Mf is not None and Mf.nnz else None
        self._factors_f: OrderedDict[float, tuple[Factor, tuple[float, ...]]] = OrderedDict()
        self.factorizations = 0
        self.fictitious_factorizations = 0  # of K + c0 (M + M_f) + c1 C, among the above
        self.state = NewmarkState(np.zeros(self.n), np.zeros(self.n), np.zeros(self.n))

    def set_fictitious_mass(self, fictitious_mass: sp.spmatrix | None) -> None:
        """Replace M_f (None or all zeros: none); the plain factorisations are kept, those with
        the old M_f dropped (refactorised at the next fictitious step)."""
        Mf = None if fictitious_mass is None else sp.csr_matrix(fictitious_mass)
        self.Mf = Mf if Mf is not None and Mf.nnz else None
        self._factors_f.clear()

    # ------------------------------------------------------------------ set-up
    def initialize(
        self,
        F0: np.ndarray,
        u0: np.ndarray | None = None,
        v0: np.ndarray | None = None,
        t0: float = 0.0,
    ) -> None:
        """Start from (u0, v0) at t0 with the acceleration from equilibrium: M a0 = F0 - C v0 - K u0."""
        u0 = np.zeros(self.n) if u0 is None else np.array(u0, dtype=float)
        v0 = np.zeros(self.n) if v0 is None else np.array(v0, dtype=float)
        r = np.asarray(F0, dtype=float) - self.K @ u0
        if self.C is not None:
            r = r - self.C @ v0
        a0 = factorize(self.M, dense_limit=self.dense_limit).solve(r) if self.n else r
        self.state = NewmarkState(u0, v0, np.asarray(a0, dtype=float), t0, 0)

    def coefficients(self, dt: float) -> tuple[float, ...]:
        b, g = self.beta, self.gamma
        return (
            1.0 / (b * dt * dt),
            g / (b * dt),
            1.0 / (b * dt),
            1.0 / (2.0 * b) - 1.0,
            g / b - 1.0,
            dt * (g / (2.0 * b) - 1.0),
        )

    def snap(self, dt: float) -> float:
        """`dt`, or a cached step size within 1e-12 relative of it (round-off in t_end - t)."""
        dt = float(dt)
        for key in (*self._factors, *self._factors_f):
            if abs(key - dt) <= 1e-12 * key:
                return key
        return dt

    def factor(self, dt: float, fictitious: bool = False) -> tuple[Factor, tuple[float, ...]]:
        """Factorised K_eff for `dt` (cached; the two most recent step sizes are kept), with
        M + M_f in place of M when `fictitious`."""
        key = float(dt)
        cache = self._factors_f if fictitious else self._factors
        hit = cache.get(key)
        if hit is not None:
            cache.move_to_end(key)
            return hit
        c = self.coefficients(key)
        Keff = self.K + c[0] * (self.M + self.Mf if fictitious else self.M)
        if self.C is not None:
            Keff = Keff + c[1] * self.C
        fac = factorize(Keff.tocsc(), dense_limit=self.dense_limit)
        self.factorizations += 1
        self.fictitious_factorizations += int(fictitious)
        cache[key] = (fac, c)
        while len(cache) > 2:
            cache.popitem(last=False)
        return fac, c

    # ------------------------------------------------------------------ stepping
    def step(
        self,
        dt: float,
        F1: np.ndarray,
        a_prev: np.ndarray | None = None,
        shift: np.ndarray | None = None,
    ) -> NewmarkState:
        """Advance the state by `dt` under the load F1 = F(t + dt); returns the new state.

        ``a_prev`` (needs a fictitious mass): the acceleration this step ended with in the
        previous coupling iteration; the step then solves (M + M_f) a1 + C v1 + K u1 = F1 +
        M_f a_prev (Baek & Karniadakis 2012); ``shift`` (optional, N) is added to M_f a_prev
        (:class:`.fictitious_mass.IterationHistory`: M_f delta). A `dt` within 1e-12 relative of a cached step size
        is taken as that step size.
        """
        dt = self.snap(dt)
        fictitious = a_prev is not None
        if fictitious and self.Mf is None:
            raise ValueError("Newmark.step(a_prev=...) needs a fictitious mass")
        fac, (c0, c1, c2, c3, c4, c5) = self.factor(dt, fictitious)
        s = self.state
        u, v, a = s.u, s.v, s.a
        hist = c0 * u + c2 * v + c3 * a
        rhs = F1 + self.M @ hist
        if fictitious:  # (M + M_f) a1 + C v1 + K u1 = F1 + M_f a_prev
            rhs += self.Mf @ (hist + a_prev)
            if shift is not None:
                rhs += shift
        if self.C is not None:
            rhs += self.C @ (c1 * u + c4 * v + c5 * a)
        u1 = fac.solve(rhs)
        a1 = c0 * (u1 - u) - c2 * v - c3 * a
        v1 = v + dt * ((1.0 - self.gamma) * a + self.gamma * a1)
        if not np.isfinite(u1).all():
            raise FloatingPointError(
                f"structure state not finite after the step to t = {s.t + dt:.6g} s"
            )
        self.state = NewmarkState(u1, v1, a1, s.t + dt, s.steps + 1)
        return self.state

    # ------------------------------------------------------------------ diagnostics
    def energy(self) -> float:
        """Kinetic plus strain energy 1/2 v.M v + 1/2 u.K u."""
        s = self.state
        return 0.5 * float(s.v @ (self.M @ s.v)) + 0.5 * float(s.u @ (self.K @ s.u))
