"""Generalised-alpha (Chung & Hulbert 1993) in the Newton integrator (structure_fem/alpha_method.py).

References: a single-degree-of-freedom oscillator m a + k u = F, whose exact free vibration is
u = cos(omega t), and the scheme's own spectral radius at omega dt -> infinity, rho_inf (Chung &
Hulbert 1993, eq. 25; their fig. 1). Tolerances: the scheme is second order, so the observed
order of the largest error to t = 1 over dt = 1/50 ... 1/200 is 2 within 0.1; the spectral
radius approaches rho_inf as (omega dt)^(-2/3) (see the test).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp

from mpsfem.scenario.structure import StructureTime
from mpsfem.structure_fem.alpha_method import AlphaState, NonlinearNewmark


class Oscillator:
    """The StructureSystem interface for one dof: mass m, stiffness k, no damping."""

    nonlinear = False
    names = ["x"]
    dof_slices = {"x": slice(0, 1)}

    def __init__(self, m: float, k: float) -> None:
        self.M = sp.csr_matrix([[m]])
        self.K = sp.csr_matrix([[k]])
        self.C = sp.csr_matrix((1, 1))

    def internal_force(self, u):
        return self.K @ u

    def tangent(self, u):
        return self.K

    def effective_tangent(self, u, ck, cm, cc):
        return ck * self.K + cm * self.M

    def member_energy(self, name, u, v):
        return 0.5 * float(v @ (self.M @ v)), 0.5 * float(u @ (self.K @ u))


def integrator(system, rho_inf: float | None) -> NonlinearNewmark:
    """Generalised-alpha at rho_inf (None: average acceleration), coefficients from the schema."""
    if rho_inf is None:
        t = StructureTime(dt=1.0)
    else:
        t = StructureTime(dt=1.0, scheme="generalized_alpha", rho_inf=rho_inf)
    return NonlinearNewmark(
        system, beta=t.beta, gamma=t.gamma, alpha=t.alpha, alpha_m=t.alpha_m, tolerance=1e-12
    )


def free_vibration(rho_inf: float, omega: float, dt: float, steps: int) -> np.ndarray:
    integ = integrator(Oscillator(1.0, omega**2), rho_inf)
    integ.initialize(np.zeros(1), u0=np.ones(1))
    u = [1.0]
    for _ in range(steps):
        u.append(float(integ.step(dt, np.zeros(1)).u[0]))
    return np.array(u)


@pytest.mark.parametrize("rho_inf", [0.0, 0.5, 0.8, 1.0])
def test_schema_coefficients_are_chung_hulbert(rho_inf):
    t = StructureTime(dt=1e-3, scheme="generalized_alpha", rho_inf=rho_inf)
    am, af = (2 * rho_inf - 1) / (rho_inf + 1), rho_inf / (rho_inf + 1)
    assert (t.alpha_m, t.alpha_f) == pytest.approx((am, af), abs=1e-15)
    assert t.gamma == pytest.approx(0.5 - am + af, abs=1e-15)
    assert t.beta == pytest.approx(0.25 * (1 - am + af) ** 2, abs=1e-15)
    assert t.alpha == -t.alpha_f


def amplification_matrix(rho_inf: float, omega: float, dt: float) -> np.ndarray:
    """The step's linear map of (u, v / omega, a / omega^2) of the undamped oscillator (a
    balanced similarity of the map of (u, v, a)), column by column."""
    integ = integrator(Oscillator(1.0, omega**2), rho_inf)
    A = np.empty((3, 3))
    scale = np.array([1.0, 1.0 / omega, 1.0 / omega**2])
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1.0 / scale[j]
        integ.state = AlphaState(e[:1], e[1:2], e[2:], 0.0, 0, np.zeros(1))
        s = integ.step(dt, np.zeros(1))
        A[:, j] = np.array([s.u[0], s.v[0], s.a[0]]) * scale
    return A


@pytest.mark.parametrize("rho_inf", [0.0, 0.5, 0.8, 1.0])
def test_spectral_radius_at_high_frequency_is_rho_inf(rho_inf):
    """The step's amplification matrix has spectral radius rho_inf as omega dt -> infinity
    (Chung & Hulbert's design condition). Its eigenvalues there are multiple, so at a finite
    omega dt they sit off rho_inf by O((omega dt)^(-2/3)) (the cube root of the (omega dt)^-2
    perturbation; a double root, the square root): measured at 1e4 and 1e6, the gap must shrink
    by 100^(2/3) = 21.5 within 10 % and be below 2e-4 at 1e6. At omega dt = 0.1 the radius is 1
    within 1e-4."""
    gap = [
        np.abs(np.linalg.eigvals(amplification_matrix(rho_inf, w, 1.0))).max() - rho_inf
        for w in (1e4, 1e6)
    ]
    low = np.abs(np.linalg.eigvals(amplification_matrix(rho_inf, 0.1, 1.0))).max()
    print(f"rho_inf {rho_inf}: radius - rho_inf {gap} at omega dt 1e4, 1e6; {low:.9f} at 0.1")
    assert abs(gap[1]) < 2e-4
    if rho_inf < 1.0:
        assert gap[0] / gap[1] == pytest.approx(100.0 ** (2.0 / 3.0), rel=0.1)
    assert abs(low - 1.0) < 1e-4


@pytest.mark.parametrize("rho_inf", [0.0, 0.8])
def test_second_order_on_a_low_frequency_oscillator(rho_inf):
    """u'' + (2 pi)^2 u = 0, u(0) = 1 to t = 1: the largest error against cos(omega t) falls at
    order 2 (observed 2 +- 0.1)."""
    omega = 2.0 * math.pi
    errs = []
    for n in (50, 100, 200):
        u = free_vibration(rho_inf, omega, 1.0 / n, n)
        errs.append(float(np.abs(u - np.cos(omega * np.arange(n + 1) / n)).max()))
    orders = [math.log2(errs[i] / errs[i + 1]) for i in range(2)]
    print(f"rho_inf {rho_inf}: errors {errs}, orders {orders}")
    assert all(abs(p - 2.0) < 0.1 for p in orders)


def test_an_alternating_velocity_dies_under_rho_inf_zero_and_not_under_newmark():
    """A near-massless member (omega dt = 1e3) under a load that alternates from step to step
    (the noise of a particle fluid), then holds still: average acceleration keeps the
    alternation in the velocity undamped, generalised-alpha at rho_inf = 0 removes it at once
    (the motivation: docs/validation_bottom_slamming_light.md)."""
    k, dt = 1.0, 1e-3
    m = k * (dt / 1e3) ** 2  # omega dt = 1e3
    out = {}
    for name, rho in (("newmark", None), ("ga0", 0.0)):
        integ = integrator(Oscillator(m, k), rho)
        integ.initialize(np.ones(1), u0=np.ones(1))  # at rest in static balance, u = F / k
        for n in range(10):
            integ.step(dt, np.array([1.0 + 0.1 * (-1) ** n]))
        v_noisy = abs(float(integ.state.v[0]))
        for _ in range(10):
            integ.step(dt, np.ones(1))
        out[name] = (v_noisy, abs(float(integ.state.v[0])), float(integ.state.u[0]))
    print(out)
    assert out["newmark"][0] > 10.0 and out["ga0"][0] > 10.0  # 0.1 / dt: both follow the load
    assert out["newmark"][1] > 0.5 * out["newmark"][0]  # undamped
    assert out["ga0"][1] < 1e-6 * out["ga0"][0]
    assert abs(out["ga0"][2] - 1.0) < 1e-9  # at rest at the static u = F / k


def test_schema_refuses_keys_of_other_schemes():
    with pytest.raises(ValueError, match="rho_inf"):
        StructureTime(dt=1e-3, rho_inf=0.5)
    with pytest.raises(ValueError, match="rho_inf"):
        StructureTime(dt=1e-3, scheme="hht", rho_inf=0.5)
    with pytest.raises(ValueError, match="newmark_beta"):
        StructureTime(dt=1e-3, scheme="generalized_alpha", newmark_beta=0.3)
    with pytest.raises(ValueError, match="hht_alpha"):
        StructureTime(dt=1e-3, scheme="generalized_alpha", hht_alpha=-0.1)
    with pytest.raises(ValueError, match="rho_inf"):
        StructureTime(dt=1e-3, scheme="generalized_alpha", rho_inf=1.5)
    t = StructureTime(dt=1e-3, scheme="generalized_alpha", rho_inf=0.3)
    assert StructureTime(**t.model_dump()) == t  # a dumped section validates again
