"""Euler-Bernoulli beam: natural frequencies and statics against ../shared/references.md section 3."""

import numpy as np
import pytest
import scipy.sparse.linalg as sla
from scipy.optimize import brentq

from mpsfem.structure_fem.beam import BeamModel
from mpsfem.structure_fem.modal import natural_modes

# references.md section 3 (tabulated beta_n L)
CANTILEVER_TABLE = [1.875104, 4.694091, 7.854757, 10.995541, 14.137168]
CLAMPED_TABLE = [4.730041, 7.853205, 10.995608]


def cantilever_roots(n):
    """Roots of cos x cosh x = -1 (clamped-free)."""
    f = lambda x: np.cos(x) + 1.0 / np.cosh(x)  # noqa: E731
    return np.array(
        [brentq(f, (k - 0.5) * np.pi - 1.5, (k - 0.5) * np.pi + 1.5) for k in range(1, n + 1)]
    )


def clamped_roots(n):
    """Roots of cos x cosh x = 1 (clamped-clamped), excluding x = 0."""
    f = lambda x: np.cos(x) - 1.0 / np.cosh(x)  # noqa: E731
    return np.array(
        [brentq(f, (k + 0.5) * np.pi - 1.5, (k + 0.5) * np.pi + 1.0) for k in range(1, n + 1)]
    )


def beam(bcs, ne, *, L=1.0, EI=1.0, rhoA=1.0, axial=False, start=(0.0, 0.0), angle=0.0, EA=1.0):
    end = np.asarray(start) + L * np.array([np.cos(angle), np.sin(angle)])
    return BeamModel.create(
        name="b", start=start, end=end, elements=ne, EI=EI, EA=EA, rhoA=rhoA, bcs=bcs, axial=axial
    )


def test_characteristic_roots_match_reference_table():
    assert np.allclose(cantilever_roots(5), CANTILEVER_TABLE, atol=1e-6)
    assert np.allclose(clamped_roots(3), CLAMPED_TABLE, atol=1e-6)


@pytest.mark.parametrize(
    "bcs, roots",
    [(["clamped", "free"], cantilever_roots(5)), (["clamped", "clamped"], clamped_roots(5))],
    ids=["cantilever", "clamped-clamped"],
)
def test_five_frequencies_at_40_elements(bcs, roots):
    L, EI, rhoA = 0.8, 3.0, 2.0
    m = beam(bcs, 40, L=L, EI=EI, rhoA=rhoA)
    omega = natural_modes(m, 5).omega
    ref = roots**2 * np.sqrt(EI / (rhoA * L**4))
    err = np.abs(omega / ref - 1.0)
    print("relative errors, 5 modes:", err)
    assert np.all(err < 1e-4)


@pytest.mark.parametrize(
    "bcs, roots",
    [(["clamped", "free"], cantilever_roots(5)), (["clamped", "clamped"], clamped_roots(5))],
    ids=["cantilever", "clamped-clamped"],
)
def test_convergence_order_of_fifth_mode(bcs, roots):
    """Cubic Hermite: eigenvalue error O(h^4) (the first mode hits round-off far earlier)."""
    errs = []
    for ne in (10, 20, 40):
        omega = natural_modes(beam(bcs, ne), 5).omega
        errs.append(omega[4] / roots[4] ** 2 - 1.0)
    errs = np.array(errs)
    order = np.log2(errs[:-1] / errs[1:])
    print(f"{bcs}: mode-5 errors {errs}, observed orders {order}")
    assert np.all(errs > 0)  # conforming: from above
    assert abs(order[-1] - 4.0) < 0.15


def static(m, F):
    f = m.free
    u = np.zeros(m.n_dof)
    u[f] = sla.spsolve(m.K[f][:, f].tocsc(), F[f])
    return u


def test_cantilever_tip_load():
    L, EI, P = 1.7, 2.5, 3.0
    m = beam(["clamped", "free"], 8, L=L, EI=EI)
    u = static(m, m.point_force_load(np.array([L, 0.0]), np.array([0.0, P])))
    tip = (m.translation @ u).reshape(-1, 2)[-1, 1]
    ref = P * L**3 / (3 * EI)
    assert abs(tip / ref - 1) < 1e-6


@pytest.mark.parametrize(
    "bcs, coef",
    [(["clamped", "clamped"], 1 / 384), (["simply_supported", "simply_supported"], 5 / 384)],
)
def test_uniform_load_mid_deflection(bcs, coef):
    L, EI, q = 2.0, 4.0, 1.5
    m = beam(bcs, 10, L=L, EI=EI, axial=True, EA=1e3)
    u = static(m, m.pressure_load(q))
    mid = (m.point_matrix(np.array([L / 2, 0.0])) @ u)[1]
    ref = coef * q * L**4 / EI
    assert abs(mid / ref - 1) < 1e-6


def test_axial_bar_and_orientation():
    """An inclined cantilever: tip force split into bending (P L^3/3EI) and axial (P L/EA) parts."""
    L, EI, EA, angle = 1.3, 2.0, 50.0, 0.7
    m = beam(["clamped", "free"], 6, L=L, EI=EI, EA=EA, axial=True, start=(0.3, -0.2), angle=angle)
    t = np.array([np.cos(angle), np.sin(angle)])
    n = np.array([-t[1], t[0]])
    Pn, Pt = 0.8, -2.0
    tip_point = m.nodes[-1]
    u = static(m, m.point_force_load(tip_point, Pn * n + Pt * t))
    tip = (m.translation @ u).reshape(-1, 2)[-1]
    assert abs(tip @ n / (Pn * L**3 / (3 * EI)) - 1) < 1e-9
    assert abs(tip @ t / (Pt * L / EA) - 1) < 1e-9
    # the same point read through the probe matrix
    assert np.allclose(m.point_matrix(tip_point) @ u, tip, rtol=1e-12, atol=1e-15)
    # rotation at the tip: P L^2 / (2 EI)
    assert abs((m.rotation @ u)[-1] / (Pn * L**2 / (2 * EI)) - 1) < 1e-9


def test_nodal_forces_do_the_same_work():
    m = beam(["clamped", "simply_supported"], 5, axial=True, angle=0.3)
    rng = np.random.default_rng(1)
    f = rng.normal(size=(m.n_nodes, 2))
    q = rng.normal(size=m.n_dof)
    assert np.isclose(m.nodal_forces_load(f) @ q, f.ravel() @ (m.translation @ q))


def test_modes_are_labelled_bending_and_axial():
    m = beam(["clamped", "clamped"], 20, L=1.0, EI=1.0, EA=200.0, rhoA=1.0, axial=True)
    res = natural_modes(m, 6)
    # axial fixed-fixed: omega = k pi sqrt(EA/rhoA)
    axial = res.omega[np.array(res.kind) == "axial"]
    assert len(axial) >= 1
    assert abs(axial[0] / (np.pi * np.sqrt(200.0)) - 1) < 1e-2
    bending = res.omega[np.array(res.kind) == "bending"]
    assert abs(bending[0] / clamped_roots(1)[0] ** 2 - 1) < 1e-5
