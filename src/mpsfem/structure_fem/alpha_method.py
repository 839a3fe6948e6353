"""Newmark, HHT-alpha and generalised-alpha time integration of M a + C v + f_int(u) = F(t),
Newton in every step.

The equation of motion is enforced at the HHT point (Hilber, Hughes & Taylor 1977, eq. 6;
for a nonlinear f_int the forces are averaged, as in Crisfield 1997 vol. 2 sec. 24.3)::

    (1 - alpha_m) M a1 + alpha_m M a + (1 + alpha) (C v1 + f_int(u1)) - alpha (C v + f_int(u))
        = (1 + alpha) F1 - alpha F

``alpha_m = 0`` except under generalised-alpha (Chung & Hulbert 1993, eq. 3, with alpha_f =
-alpha; ``scheme = "generalized_alpha"``: alpha_m, alpha_f, beta and gamma from the spectral
radius at infinity rho_inf in [0, 1], second order and unconditionally stable, rho_inf = 0
removes the highest modes in one step).

with the Newmark relations for u1, v1, a1 (:mod:`.newmark`). ``alpha = 0`` is Newmark with any
(beta, gamma) (``scheme = "newmark"``); ``scheme = "hht"`` takes alpha in [-1/3, 0] with
beta = (1 - alpha)^2 / 4 and gamma = 1/2 - alpha: unconditionally stable for linear systems,
second order, with spectral radius (1 + alpha) / (1 - alpha) at infinite frequency (numerical
dissipation of the high modes; the low ones are hardly touched).

The unknown of Newton is u1; the residual is the equation above, its Jacobian
``c0 M + (1 + alpha) (c1 C + K_t(u1))`` (c0 = 1/(beta dt^2), c1 = gamma/(beta dt)). Newton
(modified, the factorised Jacobian reused across iterations and steps) lives in :mod:`.newton`.
The predictor is the last displacement, u1 = u (robust where the
acceleration carries the high modes, as at a release).

Energies (:meth:`NonlinearNewmark.energy`) are those of the state at the end of each step,
1/2 v1.M v1 + strain energy(u1), not at the HHT point t + (1 + alpha) dt. Under HHT (alpha < 0),
generalised-alpha (rho_inf < 1) or gamma > 1/2 their sum decreases by the scheme's numerical
dissipation, not by a physical loss;
under average acceleration (alpha = 0, beta = 1/4, gamma = 1/2) a linear undamped member keeps
it exactly and a co-rotational one to O(dt^2).

With a fictitious mass M_f (:mod:`.fictitious_mass`) a step given the previous coupling
iterate's acceleration ``a_prev`` adds M_f (a1 - a_prev) to the residual (inertia, not weighted
by 1 + alpha) and c0 M_f to the Jacobian. The kept Jacobian always includes c0 M_f for such a
system (modified Newton: a step without ``a_prev`` still converges to its own residual, in more
iterations). :meth:`NonlinearNewmark.set_fictitious_mass` replaces M_f (a new wetted set): the
kept Jacobian is then re-formed, at the point it was formed at, when next needed.

Every vector is over the free dofs of the :class:`~.system.StructureSystem`.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from .linsolve import BandMatrix, factorize
from .newmark import NewmarkState
from .newton import ROUNDOFF, TangentFactor, newton_solve, solve_static

__all__ = ["AlphaState", "NonlinearNewmark"]


def _add_sparse(J, A: sp.csr_matrix):
    """J + A for a sparse or band-stored J (A symmetric, within J's band)."""
    if not isinstance(J, BandMatrix):
        return J + A
    U = sp.triu(A, format="coo")
    if U.nnz and int((U.col - U.row).max()) > J.bw:
        return J.tocsr() + A  # outside the band: fall back to a sparse Jacobian
    ab = J.ab.copy()
    np.add.at(ab, (J.bw + U.row - U.col, U.col), U.data)
    return BandMatrix(ab, J.bw)


class AlphaState(NewmarkState):
    """Newmark state plus the external load at t (the HHT equation needs F at the step start)."""

    __slots__ = ("f_ext",)

    def __init__(self, u, v, a, t=0.0, steps=0, f_ext=None) -> None:
        super().__init__(u, v, a, t, steps)
        self.f_ext = np.zeros_like(u) if f_ext is None else f_ext

    def copy(self) -> AlphaState:
        return AlphaState(
            self.u.copy(), self.v.copy(), self.a.copy(), self.t, self.steps, self.f_ext.copy()
        )


class NonlinearNewmark:
    """Newmark-beta / HHT-alpha with Newton iterations over a :class:`~.system.StructureSystem`.

    Same interface as :class:`~.newmark.Newmark` (``state``, ``initialize``, ``step``,
    ``energy``, ``factorizations``, ``beta``, ``gamma``) plus ``alpha``, ``iterations`` (total
    Newton iterations), :meth:`solve_static` and ``static_increments`` (load increments it took).
    """

    def __init__(
        self,
        system,
        *,
        beta: float = 0.25,
        gamma: float = 0.5,
        alpha: float = 0.0,
        alpha_m: float = 0.0,
        tolerance: float = 1e-8,
        max_iterations: int = 25,
        reuse_ratio: float = 0.01,
        fictitious_mass: sp.spmatrix | None = None,
    ) -> None:
        if beta <= 0:
            raise ValueError(f"newmark_beta = {beta}: must be > 0 (implicit schemes only)")
        if gamma < 0.5:
            raise ValueError(f"newmark_gamma = {gamma}: must be >= 0.5 (less is unstable)")
        if alpha_m == 0.0 and not -1.0 / 3.0 - 1e-15 <= alpha <= 0.0:
            raise ValueError(f"hht_alpha = {alpha}: must be in [-1/3, 0]")
        if alpha_m != 0.0 and not (-1.0 <= alpha_m <= 0.5 and -0.5 <= alpha <= 0.0):
            raise ValueError(
                f"alpha_m = {alpha_m}, alpha = {alpha}: generalised-alpha needs alpha_m in "
                "[-1, 1/2] and alpha = -alpha_f in [-1/2, 0] (rho_inf in [0, 1])"
            )
        self.system = system
        self.M = sp.csr_matrix(system.M)
        C = sp.csr_matrix(system.C, copy=True)
        C.eliminate_zeros()
        self.C = C if C.nnz else None
        self.beta, self.gamma, self.alpha = float(beta), float(gamma), float(alpha)
        self.alpha_m = float(alpha_m)
        self.tolerance = float(tolerance)
        self.max_iterations = int(max_iterations)
        self.reuse_ratio = float(reuse_ratio)
        self.n = self.M.shape[0]
        Mf = None if fictitious_mass is None else sp.csr_matrix(fictitious_mass)
        self.Mf = Mf if Mf is not None and Mf.nnz else None
        # (1 - alpha_m) M a1 + (1 + alpha) C v1 as one product [(1 - alpha_m) M | (1 + alpha) C]
        # [a1; v1] (alpha_m = 0: M itself, so Newmark and HHT are unchanged bit for bit)
        self._Mw = self.M if alpha_m == 0.0 else (1.0 - alpha_m) * self.M
        self._MC = (
            None if self.C is None else sp.hstack([self._Mw, (1.0 + alpha) * self.C], format="csr")
        )
        # row-sum norm of M: bounds the terms of M a1 = c0 M (u1 - u) + M base_a (round-off)
        self._M_norm = float(abs(self._Mw).sum(axis=1).max()) if self.n else 0.0
        self._C_norm = (
            (1.0 + alpha) * float(abs(self.C).sum(axis=1).max()) if self.C is not None else 0.0
        )
        self.tangent = TangentFactor()
        self.iterations = 0
        self.state = AlphaState(np.zeros(self.n), np.zeros(self.n), np.zeros(self.n))
        self._mass_factor = None
        self.static_increments = 0  # load increments the last solve_static took

    def set_fictitious_mass(self, fictitious_mass: sp.spmatrix | None) -> None:
        """Replace M_f (None or all zeros: none); the kept Jacobian, which holds c0 M_f, is
        re-formed at the same point and step size when next needed."""
        Mf = None if fictitious_mass is None else sp.csr_matrix(fictitious_mass)
        self.Mf = Mf if Mf is not None and Mf.nnz else None
        point, key = self.tangent.state()
        self.tangent.factor = None  # so that restore() does not keep it
        self.tangent.restore(point, key)

    @property
    def factorizations(self) -> int:
        """Jacobians factorised so far (modified Newton keeps them across steps)."""
        return self.tangent.count

    def coefficients(self, dt: float) -> tuple[float, ...]:
        """c0 .. c5 of :mod:`.newmark`."""
        b, g = self.beta, self.gamma
        return (
            1.0 / (b * dt * dt),
            g / (b * dt),
            1.0 / (b * dt),
            1.0 / (2.0 * b) - 1.0,
            g / b - 1.0,
            dt * (g / (2.0 * b) - 1.0),
        )

    # ------------------------------------------------------------------ set-up
    def initialize(
        self,
        F0: np.ndarray,
        u0: np.ndarray | None = None,
        v0: np.ndarray | None = None,
        t0: float = 0.0,
    ) -> None:
        """Start from (u0, v0) at t0; M a0 = F0 - C v0 - f_int(u0)."""
        u0 = np.zeros(self.n) if u0 is None else np.array(u0, dtype=float)
        v0 = np.zeros(self.n) if v0 is None else np.array(v0, dtype=float)
        F0 = np.array(F0, dtype=float)
        r = F0 - self.system.internal_force(u0)
        if self.C is not None:
            r = r - self.C @ v0
        if self._mass_factor is None and self.n:
            self._mass_factor = factorize(self.M)
        a0 = self._mass_factor.solve(r) if self.n else r
        self.state = AlphaState(u0, v0, np.asarray(a0, dtype=float), t0, 0, F0)

    def solve_static(self, F: np.ndarray, *, increments: int = 1) -> np.ndarray:
        """Static equilibrium f_int(u) = F by load stepping (:func:`.newton.solve_static`)."""
        u, self.static_increments = solve_static(
            self.system.internal_force,
            self.system.tangent,
            F,
            np.zeros(self.n),
            tolerance=self.tolerance,
            max_iterations=self.max_iterations,
            increments=increments,
            failure=lambda x, r, norm, scale, it: self._failure(
                "the static start", x, r, norm, scale, it
            ),
        )
        return u

    # ------------------------------------------------------------------ stepping
    def step(
        self,
        dt: float,
        F1: np.ndarray,
        a_prev: np.ndarray | None = None,
        shift: np.ndarray | None = None,
    ) -> AlphaState:
        """Advance the state by `dt` under the load F1 = F(t + dt); returns the new state.

        ``a_prev`` (needs a fictitious mass): the acceleration this step ended with in the
        previous coupling iteration; M_f (a1 - a_prev) joins the inertia (Baek & Karniadakis
        2012); ``shift`` (optional, N) is added to M_f a_prev, unweighted like it.

        Raises :class:`~.newton.NewtonFailure` (a FloatingPointError) naming the member with the
        largest residual, the step, the time and the residual when Newton does not converge.
        """
        dt = float(dt)
        if a_prev is not None and self.Mf is None:
            raise ValueError("NonlinearNewmark.step(a_prev=...) needs a fictitious mass")
        Mf = self.Mf if a_prev is not None else None
        key = self.tangent.current_key
        if isinstance(key, float) and key > 0 and abs(dt - key) <= 1e-12 * key:
            dt = key  # round-off in t_end - t: keep the factorised Jacobian (as Newmark.snap)
        c0, c1, c2, c3, _, _ = self.coefficients(dt)
        s = self.state
        u, v, a = s.u, s.v, s.a
        al = self.alpha
        g = self.gamma
        sysm, M, C, Mw = self.system, self.M, self.C, self._Mw
        rhs = np.asarray(F1, dtype=float)
        if al != 0.0:
            rhs = (1.0 + al) * rhs - al * s.f_ext
            old = sysm.internal_force(u)
            if C is not None:
                old = old + C @ v
            rhs = rhs + al * old
        if self.alpha_m != 0.0:  # generalised-alpha: the step-start inertia alpha_m M a
            rhs = rhs - self.alpha_m * (M @ a)
        if Mf is not None:  # (M + M_f) a1 + ... = ... + M_f a_prev
            rhs = rhs + Mf @ a_prev
            if shift is not None:
                rhs = rhs + shift
        base_a = -c2 * v - c3 * a  # a1 = c0 (u1 - u) + base_a
        base_v = v + dt * (1.0 - g) * a  # v1 = base_v + dt gamma a1
        rhs_norm = math.sqrt(rhs @ rhs)
        base_a_norm = math.sqrt(base_a @ base_a)
        M_norm, C_norm = self._M_norm, self._C_norm
        MC = self._MC
        n = self.n
        av = np.empty(2 * n)

        def residual(u1):
            a1 = c0 * (u1 - u) + base_a
            fi = sysm.internal_force(u1)
            if MC is None:
                ma = Mw @ a1
            else:  # (1 - alpha_m) M a1 + (1 + alpha) C v1
                av[:n] = a1
                av[n:] = base_v + (dt * g) * a1
                ma = MC @ av
            if Mf is not None:
                ma = ma + Mf @ a1
            fi *= 1.0 + al
            r = ma + fi - rhs
            # the forces in balance: inertial (+ damping), internal, external
            fn = math.sqrt(fi @ fi)
            scale = math.sqrt(ma @ ma) + fn + rhs_norm
            du = u1 - u
            terms = M_norm * (c0 * math.sqrt(du @ du) + base_a_norm) + fn + rhs_norm
            if MC is not None:
                v1 = av[n:]
                terms += C_norm * math.sqrt(v1 @ v1)
            return r, scale, ROUNDOFF * terms

        def jacobian(u1):
            cc = (1.0 + al) * c1 if C is not None else 0.0
            J = sysm.effective_tangent(u1, 1.0 + al, (1.0 - self.alpha_m) * c0, cc)
            if self.Mf is not None:  # always, so that the kept factor fits every step
                J = _add_sparse(J, c0 * self.Mf)
            return J

        where = f"step {s.steps + 1} (t = {s.t:.6g} s to {s.t + dt:.6g} s, dt = {dt:.3g} s)"
        res = newton_solve(
            residual,
            jacobian,
            u,
            tangent=self.tangent,
            key=dt,
            tolerance=self.tolerance,
            max_iterations=self.max_iterations,
            reuse_ratio=self.reuse_ratio,
            failure=lambda x, r, norm, scale, it: self._failure(where, x, r, norm, scale, it),
        )
        self.iterations += res.iterations
        u1 = res.x
        a1 = c0 * (u1 - u) + base_a
        v1 = base_v + dt * g * a1
        if not np.isfinite(u1).all():
            raise FloatingPointError(
                f"structure state not finite after the step to t = {s.t + dt:.6g} s"
            )
        self.state = AlphaState(u1, v1, a1, s.t + dt, s.steps + 1, np.array(F1, dtype=float))
        return self.state

    def _failure(self, where, x, r, norm, scale, iterations) -> str:
        sysm = self.system
        parts = {k: float(np.linalg.norm(r[sl])) for k, sl in sysm.dof_slices.items()}
        worst = max(parts, key=lambda k: parts[k] if np.isfinite(parts[k]) else np.inf)
        return (
            f"structure member {worst!r}: Newton iterations did not converge in {where} after "
            f"{iterations} iterations: residual {parts[worst]:.3e} (all members {norm:.3e}; "
            f"tolerance {self.tolerance:g} x force norm {scale:.3e} = {self.tolerance * scale:.3e}"
            "); reduce structure.time.dt, raise structure.newton.max_iterations or check the "
            "loads (a co-rotational member takes only small strains)"
        )

    # ------------------------------------------------------------------ checkpoints
    def checkpoint_extra(self) -> dict:
        """What a checkpoint needs beyond u, v, a, t, steps: the external load at t and where
        the kept Jacobian was formed (so that a restore repeats the steps bit for bit)."""
        point, key = self.tangent.state()
        return {"f_ext": self.state.f_ext.copy(), "tangent_point": point, "tangent_key": key}

    def restore_extra(self, state: NewmarkState, extra: dict) -> None:
        """Install a restored state with its :meth:`checkpoint_extra`."""
        self.state = AlphaState(
            state.u, state.v, state.a, state.t, state.steps, np.array(extra["f_ext"], dtype=float)
        )
        self.tangent.restore(extra["tangent_point"], extra["tangent_key"])

    # ------------------------------------------------------------------ diagnostics
    def energy(self) -> float:
        """Kinetic plus strain energy at the end of the last step (see the module docstring)."""
        s = self.state
        kin = 0.5 * float(s.v @ (self.M @ s.v))
        return kin + sum(self.system.member_energy(k, s.u, s.v)[1] for k in self.system.names)
